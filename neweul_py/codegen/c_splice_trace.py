"""The floating-frame kernel traced on a model's data, for the compiled backend.

:func:`trace_splice` runs the kernel's own functions (:mod:`neweul_py.ffrf.splice`,
:mod:`neweul_py.ffrf.body`) once on traced arrays (:mod:`.c_trace`): the arrays of the
module's data file (level 0), the weights of the parametric bodies (level 1: the samples are
mixed by them, one product ``w B`` per entry of the layout that varies) and the arguments of
a call (level 2). The context they run in — the bodies, mixed or not, ``S_V``, ``S_W`` and
the maps of the symbolic mass — is assembled as :func:`~neweul_py.ffrf.splice.ffrf_system`
and :func:`~neweul_py.ffrf.splice.ffrf_mixed` assemble it. :func:`traced_kernels` records
each splice expression the C library needs (the dynamics, the constant Jacobians of fixed
frames, the complex-step directions of moving frames, the complex step in ``σ``) as the
outputs of one C function; :mod:`.c_kernel` prints them.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from ..errors import GenerationError
from ..ffrf.parametric import ffrf_unmix
from ..ffrf.splice import (
    ffrf_add_force,
    ffrf_add_mass,
    ffrf_block_constant,
    ffrf_fixed_force_jacobians,
    ffrf_index,
    ffrf_moving,
    ffrf_symbolic_mass,
    ffrf_terms,
)
from ..ffrf.varying import ffrf_expand
from .c_matvec import matvec
from .c_trace import Graph, TArray
from .elastic import elastic_data, patterns, symbolic_part

__all__ = ["COMPACT", "STEP", "MixedColumns", "SpliceTrace", "bound_arrays",
           "constant_columns", "derived_array", "node_structure",
           "restore_data", "trace_splice", "traced_context", "traced_kernels"]

#: The complex step of the directional derivatives (as ``S["step"]`` of the NumPy module).
STEP = 1e-30


@dataclasses.dataclass
class SpliceTrace:
    """The traced kernel of a model: graph, leaves and the outputs of each C function."""

    graph: Graph
    n: int
    ns: int
    nh: int
    nu: int
    parametric: list[dict[str, Any]]      # per parametric body: name, cols, nb, nd, keys
    fixed: bool                           # some body on a fixed frame
    moving: bool                          # some body on a moving frame
    real: dict[str, Any]                  # context mixed with the real weights
    cplx: dict[str, Any] | None           # context mixed with the complex weights
    dsv: list[TArray]                     # ∂S_V/∂σ_k
    elastic: list[int]                    # the elastic coordinates (E)
    block_sigma: bool                     # M[E, E] depends on the schedule alone
    bound: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)  # nw_bind's arrays
    derived: dict[str, tuple[str, tuple[str, ...]]] = dataclasses.field(
        default_factory=dict)                 # bound arrays derived from the data file


#: The members of a mixing form in the data file (:func:`~neweul_py.ffrf.parametric.ffrf_stack`)
#: that :func:`~neweul_py.ffrf.varying.ffrf_expand` takes, in its order.
COMPACT = ("base", "base_rows", "index", "varying", "mirror", "scaled")


def derived_array(kind: str, members: tuple[np.ndarray, ...]) -> np.ndarray:
    """An array the C library is bound to that is no member of the data file, from the
    members it is derived from (the wrapper derives it the same way, ``_C_DERIVED``):
    ``"row0"`` — the first row of a mixing form's stack, ``ffrf_expand`` of its
    :data:`COMPACT` members (the entries that do not vary are read there); ``"float"`` — an
    index table of the form (``index``, ``mirror``) as float64, read by the compact mixing
    (:data:`~.c_kernel_text.C_MIX`)."""
    if kind == "row0":
        base, rows, index, varying, mirror, scaled = members
        return np.ascontiguousarray(ffrf_expand(base, np.asarray(rows)[:1], index,
                                                np.asarray(varying)[:1], mirror,
                                                scaled).reshape(-1))
    if kind == "float":
        return np.ascontiguousarray(np.asarray(members[0], dtype=np.float64).reshape(-1))
    raise ValueError(f"unknown derived array {kind!r}")


def bound_arrays(skeleton: Any, arrays: dict[str, np.ndarray]
                 ) -> tuple[Any, dict[str, np.ndarray], dict[str, tuple[str, tuple[str, ...]]],
                            dict[str, np.ndarray]]:
    """The skeleton and the arrays the C library is traced on and bound to: the data file's
    arrays, and for every mixing form its compact members as the compact mixing reads them
    (:data:`~.c_kernel_text.C_MIX`): its base, base rows and varying columns as stored, and,
    under keys of the form's path in the skeleton, its stack's first row ``_row0…`` and its
    index tables as float64 ``_index…``, ``_mirror…`` (:func:`derived_array`; the data file
    stores equal arrays once, so two bodies may share a member but not a derived array).
    Also ``derived key → (kind,
    the keys of its members)`` (what the wrapper derives when it binds) and every form's
    stack in full under ``_stack…`` (at generation only: its constant columns, the
    structure of its node maps; never bound)."""
    derived: dict[str, tuple[str, tuple[str, ...]]] = {}
    stacks: dict[str, np.ndarray] = {}

    def walk(tree: Any, path: str) -> Any:
        if isinstance(tree, dict):
            if "varying" in tree and "layout" in tree:          # a mixing form
                members = tuple(tree[name]["@"] for name in COMPACT)
                keys = {"row0": f"_row0{path}", "index": f"_index{path}",
                        "mirror": f"_mirror{path}"}
                derived[keys["row0"]] = ("row0", members)
                derived[keys["index"]] = ("float", (tree["index"]["@"],))
                derived[keys["mirror"]] = ("float", (tree["mirror"]["@"],))
                stacks[f"_stack{path}"] = ffrf_expand(*(arrays[k] for k in members))
                compact = {"stack": f"_stack{path}", "varying": tree["varying"],
                           "base": tree["base"], "rows": tree["base_rows"],
                           **{name: {"@": key} for name, key in keys.items()},
                           "scaled": np.asarray(arrays[tree["scaled"]["@"]], dtype=float)}
                return {"compact": compact, **{k: walk(v, f"{path}/{k}")
                                               for k, v in tree.items() if k not in COMPACT}}
            return {k: walk(v, f"{path}/{k}") for k, v in tree.items()}
        if isinstance(tree, list | tuple):
            items = [walk(v, f"{path}/{i}") for i, v in enumerate(tree)]
            return items if isinstance(tree, list) else tuple(items)
        return tree

    def refs(tree: Any) -> list[str]:
        if isinstance(tree, dict):
            if len(tree) == 1 and "@" in tree:
                return [tree["@"]]
            return [r for v in tree.values() for r in refs(v)]
        if isinstance(tree, list | tuple):
            return [r for v in tree for r in refs(v)]
        return []

    traced = walk(skeleton, "")
    out = {key: arrays[key] for key in refs(traced) if key not in derived}
    out.update({key: derived_array(kind, tuple(arrays[k] for k in keys))
                for key, (kind, keys) in derived.items()})
    return traced, out, derived, stacks


def restore_data(tree: Any, leaves: dict[str, TArray], arrays: dict[str, np.ndarray]) -> Any:
    """The skeleton with float arrays as data leaves and integer arrays as values."""
    if isinstance(tree, dict):
        if len(tree) == 1 and "@" in tree:
            key = tree["@"]
            return leaves[key] if key in leaves else np.asarray(arrays[key])
        return {k: restore_data(v, leaves, arrays) for k, v in tree.items()}
    if isinstance(tree, list):
        return [restore_data(v, leaves, arrays) for v in tree]
    if isinstance(tree, tuple):
        return tuple(restore_data(v, leaves, arrays) for v in tree)
    return tree


class MixedColumns:
    """The mixed values ``w B`` of a parametric body's stack, as
    :func:`~neweul_py.ffrf.parametric.ffrf_unmix` reads them (``flat[i:j]``, ``flat[i]``), one
    node per entry of the layout, so that the C code mixes only the entries the kernel uses.

    An entry that does not vary (equal in every sample, zero slopes and curvatures:
    ``constant``) is the first sample's (the value weights sum to one), or zero with the
    weights' derivative. An entry that varies is mixed from the compact form as
    :func:`~neweul_py.ffrf.parametric.ffrf_mix` mixes it — ``(w·r) base``, the varying
    columns ``w V`` set at their positions, then the mirrored entries (a ``"mix"`` node,
    :data:`~.c_kernel_text.C_MIX`) — or, a block that is a factor times another
    (``scaled``), that factor times the other block mixed."""

    def __init__(self, w: TArray, compact: dict[str, Any], arrays: dict[str, np.ndarray],
                 constant: np.ndarray, derivative: bool) -> None:
        self.w, self.c, self.constant, self.derivative = w, compact, constant, derivative
        self.index = np.asarray(arrays[compact["index"].node.params[0]]).astype(np.int64)
        mirror = np.asarray(arrays[compact["mirror"].node.params[0]]).astype(np.int64)
        self.mirror = mirror.reshape(2, -1)
        if np.any(np.diff(self.index) <= 0) or np.any(np.diff(self.mirror[0]) <= 0):
            raise GenerationError("a mixing form whose index tables do not increase")
        self._blocks: dict[tuple[int, int], TArray] = {}

    def __getitem__(self, key: Any) -> TArray:
        i, j = (key.start, key.stop) if isinstance(key, slice) else (key, key + 1)
        block = self.block(i, j)
        return block if isinstance(key, slice) else block[0]

    def block(self, i: int, j: int) -> TArray:
        """The mixed entries ``i … j − 1`` (one entry of the layout)."""
        if (i, j) not in self._blocks:
            self._blocks[i, j] = self._mixed(i, j)
        return self._blocks[i, j]

    def _mixed(self, i: int, j: int) -> TArray:
        g = self.w.graph
        if self.constant[i:j].all():
            return (self.c["row0"][i:j] if not self.derivative
                    else TArray(g, g.zeros((j - i,))))
        for start, stop, src, factor in self.c["scaled"]:
            if (int(start), int(stop)) == (i, j):
                s = int(src)
                return self.block(s, s + j - i) * float(factor)
        lo, hi = (int(v) for v in np.searchsorted(self.index, [i, j]))
        mlo, mhi = (int(v) for v in np.searchsorted(self.mirror[0], [i, j]))
        src = self.mirror[1, mlo:mhi]
        if np.any((src < i) | (src >= j)):
            raise GenerationError("a mirrored entry whose source lies in another block")
        c = self.c
        node = g.node("mix", (self.w.node, c["rows"].node, c["base"].node, c["varying"].node,
                              c["index"].node, c["mirror"].node), (j - i,), self.w.node.cplx,
                      (i, lo, hi, mlo, mhi))
        return TArray(g, node)


def constant_columns(stack: np.ndarray, blocks: int) -> np.ndarray:
    """The columns of a stack (rows ``X_1, X_1′(, X_1″), X_2 …``: ``blocks`` per sample) whose
    value rows are all equal and whose derivative rows are zero."""
    values, derivatives = stack[::blocks], np.delete(stack, np.s_[::blocks], axis=0)
    same = np.all(values == values[0], axis=0)
    return same & (~np.any(derivatives, axis=0) if derivatives.size else True)


def traced_context(g: Graph, bodies: list[dict], SV0: TArray, SW0: TArray, same: bool,
             weights: list[TArray] | None, n: int, ns: int,
             pattern: tuple[list[int], list[int]], constant: list[np.ndarray],
             arrays: dict[str, np.ndarray], derivative: bool = False) -> dict[str, Any]:
    """The splice context the traced kernel runs in, assembled as
    :func:`~neweul_py.ffrf.splice.ffrf_system` and, mixed at ``weights`` (one traced
    vector per parametric body; ``constant``: its stack's columns that do not vary,
    :class:`MixedColumns`), :func:`~neweul_py.ffrf.splice.ffrf_mixed` assemble it."""
    out, SV, SW, k = [], SV0, SW0, 0
    for b in bodies:
        if "mixing" not in b:
            bb = dict(b)
            if "quad" not in b and "fixed" not in b:      # Mee E (ffrf_add_mass)
                rows = TArray(g, g.zeros((b["nq"], n)))
                rows[:, b["first"]:b["first"] + b["nq"]] = b["Me"]
                bb["Mee_rows"] = rows
            out.append(bb)
            continue
        w = weights[k]
        mixed = ffrf_unmix(b["mixing"], MixedColumns(w, b["mixing"]["compact"], arrays,
                                                     constant[k], derivative))
        k += 1
        mixed.update(name=b["name"], first=b["first"], kin=b["kin"])
        SV, SW = SV.astype(np.result_type(SV, w)), SW.astype(np.result_type(SW, w))
        SV[b["rows"]] += mixed.pop("_sv")
        SW[b["rows"]] += mixed.pop("_sw")
        out.append(mixed)
    r, c = (np.asarray(v, dtype=np.intp) for v in pattern)
    ix = (ffrf_index(r), ffrf_index(c))
    if not (isinstance(ix[0], slice) and isinstance(ix[1], slice)):
        ix = np.ix_(r, c)
    maps = (ix, SW[ffrf_index(r)].T, SV[ffrf_index(c)])
    acc_map = np.hstack((np.eye(6), np.zeros((6, 3)), -np.eye(6, 3), np.zeros((6, 4))))
    return {"bodies": tuple(out), "n": n, "ns": ns, "SV": SV, "SW": SW,
            "same": same and k == 0, "acc_map": acc_map, "maps": (maps, None)}


def trace_splice(equations: Any) -> tuple[SpliceTrace, Any]:
    """Trace the kernel of ``equations`` on its data (module docstring); also returns the
    data file (:class:`.elastic.DataFile`)."""
    el = equations.elastic
    a_idx = list(el.active)
    keep = list(el.keep)
    true_index = {j: k for k, j in enumerate(keep)}
    skeleton, data = elastic_data(equations, a_idx, true_index)
    skeleton, arrays, derived, stacks = bound_arrays(skeleton, data.arrays)
    symbolic = symbolic_part(equations)
    mass_pattern, _kin = patterns(symbolic, el.hidden)
    g = Graph()
    leaves = {key: g.leaf(key, arr.shape, 0) for key, arr in sorted(arrays.items())
              if arr.dtype.kind == "f"}
    tree = restore_data(skeleton, leaves, arrays)
    bodies = tree["bodies"]
    n, ns, nh = len(keep), len(a_idx), len(el.hidden)
    nu = len(equations.inputs)
    same = skeleton["SV"] == skeleton["SW"]
    parametric = []
    for b, raw in zip(bodies, skeleton["bodies"], strict=True):
        if "mixing" in b:
            coeff = arrays[raw["coeff"]["@"]]
            parametric.append({"name": b["name"], "cols": int(coeff.shape[2]),
                               "nb": int(coeff.shape[1]) + 1, "nd": int(coeff.shape[0]),
                               "values": raw["values"]["@"], "coeff": raw["coeff"]["@"],
                               "rows": np.asarray(b["rows"])})
    w = [g.leaf(f"w{k}", (p["cols"],), 1) for k, p in enumerate(parametric)]
    dw = [g.leaf(f"dw{k}", (p["cols"],), 1) for k, p in enumerate(parametric)]
    wc = [g.leaf(f"wc{k}", (p["cols"],), 1, cplx=True) for k, p in enumerate(parametric)]
    constant = [constant_columns(stacks[raw["mixing"]["compact"]["stack"]], blocks)
                for raw, blocks in zip([r for r in skeleton["bodies"] if "mixing" in r],
                                       [1 + bool(s.body.slopes) + bool(s.body.curvatures)
                                        for s in el.splices if s.body.parametric],
                                       strict=True)]
    real = traced_context(g, bodies, tree["SV"], tree["SW"], same, w, n, ns, mass_pattern,
                          constant, arrays)
    cplx = (traced_context(g, bodies, tree["SV"], tree["SW"], same, wc, n, ns, mass_pattern,
                           constant, arrays) if parametric else None)
    dsv = []
    for k, p in enumerate(parametric):               # ∂S_V/∂σ_k: the node rows mixed by w′
        b = next(b for b in bodies if b.get("name") == p["name"] and "mixing" in b)
        d = ffrf_unmix(b["mixing"], MixedColumns(dw[k], b["mixing"]["compact"], arrays,
                                                 constant[k], True))["_sv"]
        m = TArray(g, g.zeros((ns, n)))
        m[p["rows"]] = d
        dsv.append(m)
    fixed = any("fixed" in b for b in bodies)
    moving = any("fixed" not in b for b in bodies)
    elastic = sorted(j for b in bodies for j in range(b["first"], b["first"] + b["nq"]))
    block_sigma = ffrf_block_constant(
        [{k: v for k, v in b.items() if not isinstance(v, TArray)} for b in bodies], ns,
        *node_structure(skeleton, arrays, stacks), mass_pattern,
        np.asarray(_kin, dtype=np.intp))
    return SpliceTrace(g, n, ns, nh, nu, parametric, fixed, moving, real, cplx, dsv,
                       elastic, block_sigma, arrays, derived), data


def node_structure(skeleton: dict, arrays: dict[str, np.ndarray],
                   stacks: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The nonzero structure of ``S_V``, ``S_W`` at every schedule: the base maps and the
    node rows of every parametric body in any sample (``stacks``: of :func:`bound_arrays`)."""
    SV = arrays[skeleton["SV"]["@"]] != 0
    SW = arrays[skeleton["SW"]["@"]] != 0
    for raw in (r for r in skeleton["bodies"] if "mixing" in r):
        stack = stacks[raw["mixing"]["compact"]["stack"]]
        rows = np.asarray(arrays[raw["rows"]["@"]])
        for path, i, j, shape in raw["mixing"]["layout"]:
            target = {("_sv",): SV, ("_sw",): SW}.get(tuple(path))
            if target is not None:
                target[rows] |= np.any(stack[:, i:j] != 0, axis=0).reshape(shape)
    return SV, SW


def traced_kernels(t: SpliceTrace) -> dict[str, tuple[list, list]]:
    """The traced C functions: name → (level-2 leaves ``(C name, TArray)``, outputs
    ``(C name, TArray)``). Each is one splice expression of :mod:`neweul_py.ffrf.splice`."""
    g, n, ns, nh = t.graph, t.n, t.ns, t.nh
    out: dict[str, tuple[list, list]] = {}

    def leaf(name: str, shape: tuple[int, ...], cplx: bool = False) -> TArray:
        return g.leaf(f"{name}@{len(g.leaves)}", shape, 2, cplx)

    def dynamics() -> tuple[list, TArray, TArray]:
        """(M, q − k) of ffrf_dynamics after the symbolic part's rhs_parts, on new leaves."""
        S = t.real
        kin, y, yd = leaf("kin", (nh,)), leaf("y", (n,)), leaf("yd", (n,))
        Ms, fs = leaf("Ms", (ns, ns)), leaf("fs", (ns,))
        terms = ffrf_terms(S, kin, y, yd)
        return ([("kin", kin), ("y", y), ("yd", yd), ("Ms", Ms), ("fs", fs)],
                ffrf_add_mass(S, ffrf_symbolic_mass(S, Ms), terms),
                ffrf_add_force(S, np.dot(S["SW"].T, fs), terms))

    S = t.real
    params, M, f = dynamics()
    out["nw_k_dyn"] = (params, [("M", M), ("f", f)])
    # the residual M a − (q − k) of the generalized-α loop, without forming M (.c_matvec)
    params, M, f = dynamics()
    a = leaf("a", (n,))
    out["nw_k_dynr"] = ([*params, ("a", a)], [("r", matvec(M, a) - f)])
    if t.fixed:                               # the constant Ke, De of fixed frames
        fy, fyd = leaf("fy", (n, n)), leaf("fyd", (n, n))
        fy2, fyd2 = TArray(g, fy.node), TArray(g, fyd.node)
        ffrf_fixed_force_jacobians(S, fy2, fyd2)
        out["nw_k_fixed"] = ([("fy", fy), ("fyd", fyd)], [("fy_out", fy2), ("fyd_out", fyd2)])
    if t.moving:                              # complex-step directions (moving frames)
        Sm = ffrf_moving(S)
        kc, yc, ydc = leaf("kin", (nh,), True), leaf("y", (n,), True), leaf("yd", (n,), True)
        zero = TArray(g, g.zeros((n,), True))
        fd = ffrf_add_force(Sm, zero, ffrf_terms(Sm, kc, yc, ydc))
        out["nw_k_dirf"] = ([("kin", kc), ("y", yc), ("yd", ydc)], [("f", fd)])
        kc2, yc2, a = leaf("kin", (nh,), True), leaf("y", (n,), True), leaf("a", (n,))
        Mz = TArray(g, g.zeros((n, n), True))
        Ma = np.dot(ffrf_add_mass(Sm, Mz, ffrf_terms(Sm, kc2, yc2,
                                                     TArray(g, g.zeros((n,))))), a)
        out["nw_k_dirm"] = ([("kin", kc2), ("y", yc2), ("a", a)], [("f", Ma)])
    # the complex step along ∂kin/∂p of every body (ffrf_force_parameter_jacobian)
    kp, yp, ydp = leaf("kin", (nh,), True), leaf("y", (n,)), leaf("yd", (n,))
    zero = TArray(g, g.zeros((n,), True))
    out["nw_k_dirp"] = ([("kin", kp), ("y", yp), ("yd", ydp)],
                        [("f", ffrf_add_force(S, zero, ffrf_terms(S, kp, yp, ydp)))])
    if t.cplx is not None:                    # the complex step in σ (ffrf_sigma_terms)
        Sc = t.cplx
        kc, y3, yd3, fsc = (leaf("kin", (nh,), True), leaf("y", (n,)), leaf("yd", (n,)),
                            leaf("fs", (ns,), True))
        fsig = ffrf_add_force(Sc, np.dot(Sc["SW"].T, fsc), ffrf_terms(Sc, kc, y3, yd3))
        out["nw_k_sigf"] = ([("kin", kc), ("y", y3), ("yd", yd3), ("fs", fsc)],
                            [("f", fsig)])
        kc4, y4, a4, Ms4, mmd = (leaf("kin", (nh,), True), leaf("y", (n,)), leaf("a", (n,)),
                                 leaf("Ms", (ns, ns)), leaf("mmd", (ns,)))
        Mz = TArray(g, g.zeros((n, n), True))
        msig = (np.dot(Sc["SW"].T, np.dot(Ms4, np.dot(Sc["SV"], a4)) + 1j * STEP * mmd)
                + np.dot(ffrf_add_mass(Sc, Mz, ffrf_terms(Sc, kc4, y4,
                                                          TArray(g, g.zeros((n,))))), a4))
        out["nw_k_sigm"] = ([("kin", kc4), ("y", y4), ("a", a4), ("Ms", Ms4), ("mmd", mmd)],
                            [("f", msig)])
    return out
