"""The arrays the compiled backend binds and the compact mixing it prints
(neweul_py/codegen/c_splice_trace.py: ``bound_arrays``, ``MixedColumns``).

Reference: the mixing forms themselves — each body's first row of samples is the first row
of ``ffrf_expand`` of its own compact members — and ``ffrf_mix``, the NumPy module's mixing,
which the printed C code must reproduce for real, derivative and complex weights.
"""

from __future__ import annotations

import hashlib
import shutil

import numpy as np
import pytest

from neweul_py.codegen.c_kernel import KernelPrinter
from neweul_py.codegen.c_kernel_text import C_DOT, C_MIX
from neweul_py.codegen.c_runtime import compiled_library
from neweul_py.codegen.c_splice_trace import (
    MixedColumns,
    bound_arrays,
    constant_columns,
    restore_data,
)
from neweul_py.codegen.c_trace import Graph
from neweul_py.ffrf.data_file import ArrayStore, ffrf_split
from neweul_py.ffrf.parametric import ffrf_mix, ffrf_stack, ffrf_unmix
from neweul_py.ffrf.varying import ffrf_expand


def test_bodies_that_share_compact_members_keep_their_own_derived_arrays() -> None:
    """Two parametric bodies whose samples do not vary store equal (k, 0) ``varying``
    arrays once in the data file; each is still bound to its own first row (its base), and
    the full stacks are returned for the generator only, never bound."""
    forms = [ffrf_stack([{"mass": m, "K": m * np.eye(3)}] * 3) for m in (1.0, 5.0)]
    store = ArrayStore()
    skeleton = ffrf_split({"bodies": [{"mixing": f} for f in forms]}, "d", store)
    traced, arrays, derived, stacks = bound_arrays(skeleton, store.arrays)
    rows = [b["mixing"]["compact"]["row0"]["@"] for b in traced["bodies"]]
    assert len(set(rows)) == 2 and set(rows) <= set(derived)
    assert not any(key in arrays for key in stacks)
    for key, form, body in zip(rows, forms, traced["bodies"], strict=True):
        want = ffrf_expand(form["base"], form["base_rows"], form["index"], form["varying"],
                           form["mirror"], form["scaled"])
        np.testing.assert_array_equal(arrays[key], want[0].reshape(-1))
        np.testing.assert_array_equal(stacks[body["mixing"]["compact"]["stack"]], want)
        index = arrays[body["mixing"]["compact"]["index"]["@"]]
        assert index.dtype == np.float64 and index.size == form["index"].size


def _samples(rng: np.random.Generator, k: int) -> list[dict]:
    """``k`` samples with a symmetric varying matrix (mirrored entries), a matrix that is a
    factor times it (a scaled block), a constant matrix and a varying vector."""
    K0 = rng.normal(size=(5, 5))
    K0 = K0 + K0.T
    out = []
    for s in range(k):
        d = rng.normal(size=(5, 5)) * (np.arange(5) < 3)[:, None]     # rows 3, 4 constant
        K = K0 + s * (d + d.T)
        out.append({"mass": 2.0, "K": K, "G": 6283.0 * K, "C": np.eye(3),
                    "v": np.array([1.0, s * 0.5, 3.0])})
    return out


@pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                    reason="no C compiler")
@pytest.mark.parametrize("plan", [1, 0])
def test_compact_mixing_printed_as_c_gives_ffrf_mix(tmp_path, plan: int) -> None:
    """A mixing form with mirrored, scaled and constant entries, traced through
    ``MixedColumns`` (real weights, their derivative, complex weights), printed and
    compiled: every entry of the layout equals ``ffrf_mix`` at the same weights to
    round-off, and mixing again at other weights (the constant part kept) as well. The
    entries that vary in no sample are the first sample's (``ffrf_mix``: the value weights
    sum to one), zero for the derivative. Both ways of setting the mirrored entries: with
    their columns (the plan, ``plan=1``) and copied after (``NW_MIX_PLAN 0``)."""
    rng = np.random.default_rng(11)
    form = ffrf_stack(_samples(rng, 4))
    assert form["mirror"].size and form["scaled"].size      # the case this test is about
    store = ArrayStore()
    skeleton = ffrf_split({"bodies": [{"mixing": form}]}, "d", store)
    traced, arrays, _derived, stacks = bound_arrays(skeleton, store.arrays)
    g = Graph()
    data = sorted(k for k, a in arrays.items() if a.dtype.kind == "f")
    leaves = {key: g.leaf(key, arrays[key].shape, 0) for key in data}
    compact = restore_data(traced, leaves, arrays)["bodies"][0]["mixing"]["compact"]
    constant = constant_columns(stacks[compact["stack"]], 1)
    w, dw = g.leaf("w", (4,), 1), g.leaf("dw", (4,), 1)
    wc = g.leaf("wc", (4,), 1, cplx=True)
    entries = {}
    for name, x, deriv in (("w", w, False), ("dw", dw, True), ("wc", wc, False)):
        mixed = MixedColumns(x, compact, arrays, constant, deriv)
        entries[name] = [mixed[i:j] for _p, i, j, _s in form["layout"]]
    pr = KernelPrinter(g, data)
    for name in ("w", "dw", "wc"):
        pr.params[g.leaves[name].id] = f"nw_{name}"
    outs = [e for name in ("w", "dw", "wc") for e in entries[name]]
    sigma = pr.schedule_function("sig(void)", [], outs)
    copy = []
    offset = 0
    for e in outs:
        factor = 2 if e.node.cplx else 1
        size = f"{factor * e.size} * sizeof(double)"
        if e.node.op == "zeros":
            copy.append(f"    memset(o + {offset}, 0, {size});")
        else:
            cast = "(const double *)" if e.node.cplx else ""
            copy.append(f"    memcpy(o + {offset}, {cast}{pr.pointer(e)}, {size});")
        offset += factor * e.size
    plans = [line.split()[2] for line in pr.static if line.startswith("static nw_mixplan ")]
    decl = ", ".join(f"const double *d{i}" for i in range(len(data)))
    src = "\n".join([
        "#include <complex.h>", "#include <math.h>", "#include <string.h>",
        "#define NW_NW 4", f"#define NW_MIX_PLAN {plan}",
        f"static const double *nw_D[{len(data)}];", "static long nw_binds;",
        "static double nw_w[4], nw_dw[4];", "static double complex nw_wc[4];",
        C_DOT, C_MIX, *pr.static, *sigma,
        f"int run({decl}, const double *w, const double *dw, const double *wc, double *o)",
        "{", *(f"    nw_D[{i}] = d{i};" for i in range(len(data))),
        "    static int bound; if (!bound) { ++nw_binds; bound = 1; }", *pr.bind_lines(),
        "    memcpy(nw_w, w, sizeof nw_w); memcpy(nw_dw, dw, sizeof nw_dw);",
        "    memcpy(nw_wc, wc, sizeof nw_wc);", "    sig();", *copy, "    return 0;", "}",
        f"int planned(void) {{ return {' + '.join(f'{q}.ok' for q in plans) or '0'}; }}", ""])
    path = tmp_path / "mix.c"
    path.write_text(src)
    ffi, lib, _ = compiled_library(
        path, hashlib.sha256(src.encode()).hexdigest(),
        f"int run({decl}, const double *w, const double *dw, const double *wc, double *o);"
        "int planned(void);", tmp_path / "cache")
    bound = [np.ascontiguousarray(arrays[k]) for k in data]
    for trial in range(2):                   # the second mix reuses the constant part
        # weights as the schedule gives them: the values' weights sum to one, their
        # derivatives (and a complex step's imaginary parts) to zero
        xw = rng.normal(size=4) * (1.0 + trial)
        xw[-1] = 1.0 - xw[:-1].sum()
        xd = rng.normal(size=4)
        xd -= xd.mean()
        xi = rng.normal(size=4)
        xc = np.ascontiguousarray(xw[::-1] + 1e-3j * (xi - xi.mean()))
        got = np.empty(offset)
        lib.run(*(ffi.from_buffer("double[]", a) for a in bound),
                ffi.from_buffer("double[]", xw), ffi.from_buffer("double[]", xd),
                ffi.from_buffer("double[]", xc.view(float)), ffi.from_buffer("double[]", got))
        pos = 0
        for name, x in (("w", xw), ("dw", xd), ("wc", xc)):
            ref = ffrf_mix(form, x)
            for (path_, i, j, _shape), e in zip(form["layout"], entries[name], strict=True):
                want = ref[path_[0]] if not constant[i:j].all() or name != "dw" else 0.0
                want = np.asarray(want).reshape(-1)
                if e.node.cplx:
                    val = got[pos:pos + 2 * (j - i)].view(complex)
                    pos += 2 * (j - i)
                else:
                    val = got[pos:pos + j - i]
                    pos += j - i
                scale = max(float(np.abs(want).max(initial=0.0)), 1.0)
                assert np.abs(val - want).max() <= 1e-13 * scale, (name, path_, trial)
    assert plans and lib.planned() == plan * len(plans)     # the way this case is about


def test_unmixed_layout_reads_every_entry() -> None:
    """``ffrf_unmix`` of ``MixedColumns`` yields one traced array per entry of the layout
    (the scalar mass as a 0-d element), so no entry is left unmixed."""
    rng = np.random.default_rng(2)
    form = ffrf_stack(_samples(rng, 3))
    store = ArrayStore()
    skeleton = ffrf_split({"bodies": [{"mixing": form}]}, "d", store)
    traced, arrays, _d, stacks = bound_arrays(skeleton, store.arrays)
    g = Graph()
    leaves = {k: g.leaf(k, a.shape, 0) for k, a in arrays.items() if a.dtype.kind == "f"}
    mixing = restore_data(traced, leaves, arrays)["bodies"][0]["mixing"]
    w = g.leaf("w", (3,), 1)
    mixed = ffrf_unmix(mixing, MixedColumns(w, mixing["compact"], arrays,
                                            constant_columns(stacks[mixing["compact"]["stack"]],
                                                             1), False))
    for path, _i, _j, shape in form["layout"]:
        assert tuple(mixed[path[0]].shape) == tuple(shape)
