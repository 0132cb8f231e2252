"""The compiled backend (codegen/c_module.py, c_printer.py, c_runtime.py) against the NumPy
module generated from the same equations — every protocol function of every shipped example,
constraints included — and the safety rules of building and loading its library."""

from __future__ import annotations

import itertools
import os
import shutil
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from compiler import needs_c_compiler

from neweul_py.analysis.module import as_model, load_generated
from neweul_py.codegen import generate_module
from neweul_py.codegen.c_module import c_module_path, write_c_module
from neweul_py.codegen.c_printer import CPrinter
from neweul_py.codegen.c_runtime import BackendUnavailable, compiled_library
from neweul_py.commands import BACKENDS
from neweul_py.description import load_description
from neweul_py.equations import newton_euler
from neweul_py.errors import NeweulError

ROOT = Path(__file__).resolve().parents[2]
_COUNTER = itertools.count()
EXAMPLES = sorted(p.stem for p in (ROOT / "examples").glob("*.yaml"))
pytestmark = needs_c_compiler


def _fresh(path: Path):
    """Import a module file anew (``load_generated`` shares modules of equal content, which
    would hide what happens in this directory)."""
    import importlib.util

    name = f"c_backend_test_{path.stem}_{next(_COUNTER)}"
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _modules(name: str, directory: Path, form: str = "auto"):
    eq = newton_euler(load_description(ROOT / "examples" / f"{name}.yaml"), form=form)
    npath = generate_module(eq, "h", directory / f"{name}.py")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a fallback to NumPy would make the test vacuous
        cmod = _fresh(write_c_module(eq, npath))
    assert cmod.BACKEND == "c"
    return load_generated(npath), cmod


def _calls(mod, t, x, p, u, a):
    n = len(mod.COORDINATES)
    y, yd = x[:n], x[n:]
    return {
        "default_inputs": mod.default_inputs(t, p),
        "mass_matrix": mod.mass_matrix(t, y, p, u),
        "force_vector": mod.force_vector(t, y, yd, p, u),
        "rhs": mod.rhs(t, x, p, u),
        "force_jacobians": mod.force_jacobians(t, y, yd, p, u),
        "mass_matrix_times_derivative": mod.mass_matrix_times_derivative(t, y, p, a, u),
        "rhs_jacobian": mod.rhs_jacobian(t, x, p, u),
        "outputs": mod.outputs(t, x, p, u),
        "output_jacobians": mod.output_jacobians(t, x, p, u),
        "constraints": mod.constraints(t, y, p, u),
        "constraint_jacobian": mod.constraint_jacobian(t, y, p, u),
        "constraint_time_derivative": mod.constraint_time_derivative(t, y, p, u),
        "constraint_gamma": mod.constraint_gamma(t, y, yd, p, u),
        "force_parameter_jacobian": mod.force_parameter_jacobian(t, y, yd, p, u),
        "mass_matrix_parameter_derivative": mod.mass_matrix_parameter_derivative(t, y, p, a, u),
        "rhs_parameter_jacobian": mod.rhs_parameter_jacobian(t, x, p, u),
        "output_parameter_jacobian": mod.output_parameter_jacobian(t, x, p, u),
    }


def _assert_same(mnp, mc, args, label: str) -> None:
    """Every protocol function of ``mc`` equals ``mnp``'s at ``args = (t, x, p, u, a)`` to
    round-off (absolute 1e-10 of the largest entry + 1)."""
    ref, got = _calls(mnp, *args), _calls(mc, *args)
    for fname, r in ref.items():
        rs = r if isinstance(r, tuple) else (r,)
        gs = got[fname] if isinstance(got[fname], tuple) else (got[fname],)
        for rr, gg in zip(rs, gs, strict=True):
            rr, gg = np.asarray(rr), np.asarray(gg)
            assert gg.shape == rr.shape, fname
            scale = 1.0 + (np.max(np.abs(rr)) if rr.size else 0.0)
            np.testing.assert_allclose(gg, rr, rtol=0, atol=1e-10 * scale,
                                       err_msg=f"{label}: {fname}")


CASES = [(name, "auto") for name in EXAMPLES] + [("double_pendulum", "recursive"),
                                                  ("chain3_spatial", "recursive")]


@pytest.mark.parametrize(("name", "form"), CASES)
def test_every_protocol_function_equals_numpy_module(name, form, tmp_path):
    """Reference: the NumPy module printed from the same CSE'd blocks (independently
    validated against lambdify and KanesMethod in test_examples_vs_lambdify.py); agreement
    to round-off at random states, with default and explicit inputs."""
    mnp, mc = _modules(name, tmp_path, form)
    for const in ("COORDINATES", "PARAMETERS", "INPUTS", "OUTPUTS", "CONSTRAINTS",
                  "STATE_SIZE", "SOURCE_HASH", "INITIAL_STATE", "MASS_MATRIX_SYMMETRIC"):
        assert getattr(mc, const) == getattr(mnp, const)
    rng = np.random.default_rng(7)
    n, nu = len(mnp.COORDINATES), len(mnp.INPUTS)
    p = mnp.default_parameters() * (1 + 0.1 * rng.random(len(mnp.PARAMETERS)))
    for k in range(3):
        x = np.asarray(mnp.INITIAL_STATE) + 0.2 * rng.standard_normal(2 * n)
        a = rng.standard_normal(n)
        t = 0.31 * k
        for u in (None, *([rng.standard_normal(nu)] if nu else [])):
            _assert_same(mnp, mc, (t, x, p, u, a), name)


def test_library_is_cached_and_a_foreign_one_never_loaded(tmp_path):
    """Reference: the build record (SHA-256 of the library bytes); a replaced library is
    rebuilt with a warning, an unchanged one is reused without compiling."""
    _modules("pendulum", tmp_path)
    c_path = tmp_path / "pendulum_c.c"
    sha = __import__("hashlib").sha256(c_path.read_bytes()).hexdigest()
    cdef = "int nw_rhs(double, const double *, const double *, const double *, double *);"
    _, _, note = compiled_library(c_path, sha, cdef, tmp_path / "__neweul_c__")
    assert note == ""  # the library the module built is reused
    (so,) = (tmp_path / "__neweul_c__").glob("*.so")
    so.write_bytes(b"\x7fELF not the library")
    _, lib, note = compiled_library(c_path, sha, cdef, tmp_path / "__neweul_c__")
    assert lib.nw_rhs is not None  # the rebuilt library loads
    assert "did not match its build record" in note
    assert so.read_bytes()[:4] == b"\x7fELF" and b"not the library" not in so.read_bytes()
    with pytest.raises(BackendUnavailable, match="does not match"):
        compiled_library(c_path, "0" * 64, cdef, tmp_path / "__neweul_c__")


@pytest.mark.parametrize("failure", ["no compiler", "compiler error", "unwritable cache",
                                     "edited source"])
def test_fallback_to_numpy_with_one_warning(failure, tmp_path, monkeypatch):
    """Reference: the NumPy twin — the module falls back to it, warns once, and computes the
    same values."""
    eq = newton_euler(load_description(ROOT / "examples" / "double_pendulum.yaml"))
    npath = generate_module(eq, "h", tmp_path / "double_pendulum.py")
    wrapper = write_c_module(eq, npath)
    if failure == "no compiler":
        monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    elif failure == "compiler error":
        monkeypatch.setenv("CC", shutil.which("false") or "/bin/false")
    elif failure == "unwritable cache":
        (tmp_path / "__neweul_c__").write_text("a file where the cache directory belongs")
    else:
        c = wrapper.with_suffix(".c")
        c.write_text(c.read_text() + "\n/* edited */\n")
    with pytest.warns(RuntimeWarning, match="compiled backend unavailable") as record:
        mc = _fresh(wrapper)
    assert len(record) == 1
    assert mc.BACKEND == "numpy"
    mnp = load_generated(npath)
    x = np.asarray(mnp.INITIAL_STATE)
    np.testing.assert_array_equal(mc.rhs(0.0, x, mnp.default_parameters()),
                                  mnp.rhs(0.0, x, mnp.default_parameters()))


def test_derivative_library_falls_back_on_its_own(tmp_path):
    """Reference: the NumPy twin's Jacobians — an edited derivative source leaves the core
    compiled and sends only the Jacobian functions to the twin, with one warning."""
    eq = newton_euler(load_description(ROOT / "examples" / "double_pendulum.yaml"))
    npath = generate_module(eq, "h", tmp_path / "double_pendulum.py")
    wrapper = write_c_module(eq, npath)
    jac = tmp_path / "double_pendulum_c_jac.c"
    jac.write_text(jac.read_text() + "\n/* edited */\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mc = _fresh(wrapper)
    assert mc.BACKEND == "c"
    mnp = load_generated(npath)
    x, p = np.asarray(mnp.INITIAL_STATE) + 0.1, mnp.default_parameters()
    with pytest.warns(RuntimeWarning, match="compiled derivatives unavailable") as record:
        J = mc.rhs_jacobian(0.0, x, p)
        mc.rhs_jacobian(0.0, x, p)
    assert len(record) == 1
    np.testing.assert_array_equal(J, mnp.rhs_jacobian(0.0, x, p))


def test_wrong_sizes_raise_instead_of_reading_out_of_bounds(tmp_path):
    """Reference: the sizes the library was built for (a shorter array would be read past
    its end by C)."""
    _, mc = _modules("double_pendulum", tmp_path)
    p = mc.default_parameters()
    with pytest.raises(ValueError, match="shape"):
        mc.rhs(0.0, np.zeros(3), p)
    with pytest.raises(ValueError, match="shape"):
        mc.mass_matrix(0.0, np.zeros(2), p[:-1])


def test_singular_mass_matrix_raises_linalg_error(tmp_path):
    """Reference: numpy.linalg.solve, which the NumPy module calls, raises LinAlgError."""
    mnp, mc = _modules("pendulum", tmp_path)
    p = mnp.default_parameters()
    p[list(mnp.PARAMETERS).index("m")] = 0.0
    for mod in (mnp, mc):
        with pytest.raises(np.linalg.LinAlgError):
            mod.rhs(0.0, np.array([0.1, 0.0]), p)


def test_piecewise_abs_min_max_sign_heaviside_print_as_c(tmp_path):
    """Reference: sympy's own evaluation (lambdify with math) of the same expressions."""
    a, b = sp.symbols("a b", real=True)
    exprs = [
        sp.Piecewise((a**2, a > b), (sp.sin(b), sp.And(a <= b, b > 0)), (-a, True)),
        sp.Abs(a - b) + sp.Min(a, b, 0.5) * sp.Max(a, -b),
        sp.sign(a) * sp.Heaviside(b) + sp.Heaviside(b - a, 0.25) + a**-3 + sp.sqrt(b**2 + 1),
        sp.Rational(1, 3) * a**5 + sp.pi * b - sp.exp(-a) / (a * (b + 2)) ** 2,
    ]
    pr = CPrinter({a: "v[0]", b: "v[1]"})
    body = "\n".join(f"    out[{i}] = {pr.doprint_expr(e)};" for i, e in enumerate(exprs))
    src = ("#include <math.h>\n"
           f"int f(const double *v, double *out)\n{{\n{body}\n    return 0;\n}}\n")
    c_path = tmp_path / "expr.c"
    c_path.write_text(src)
    sha = __import__("hashlib").sha256(src.encode()).hexdigest()
    ffi, lib, _ = compiled_library(c_path, sha, "int f(const double *v, double *out);",
                                   tmp_path / "cache")
    ref = sp.lambdify((a, b), exprs, modules="math")
    for v in ([1.5, 0.3], [-0.7, 0.9], [0.2, -1.1], [0.4, 0.4], [0.6, 0.0]):
        vin, out = np.array(v), np.empty(len(exprs))
        lib.f(ffi.from_buffer("double[]", vin), ffi.from_buffer("double[]", out))
        np.testing.assert_allclose(out, ref(*v), rtol=1e-14, atol=1e-14)


def test_backends_agree_and_the_compiled_module_sits_next_to_its_twin():
    """Reference: api.BACKENDS, which the CLI mirrors without importing the symbolic layers,
    and the documented file name ``<name>_c.py``."""
    from neweul_py.api import BACKENDS as API_BACKENDS

    assert BACKENDS == API_BACKENDS
    assert c_module_path(os.path.join("gen", "flex.py")) == Path("gen", "flex_c.py")


_PENDULUM = """
name: {name}
parameters: {{g: 9.81, c: 0.2}}
inputs: {{T: 0.1}}
gravity: [0, -g, 0]
coordinates: {{a: {{initial: 0.3}}}}
frames:
  arm: {{rotation: [[z, a]]}}
elastic_bodies:
  beam: {{frame: {frame}, data: {name}.npz, nodes: {{tip: 9}}}}
bodies:
  hub: {{frame: arm, mass: 1.0, center_of_mass: [0.1, 0, 0], inertia: {{diag: [0.1, 0.1, 0.1]}}}}
forces:
  drive: {{type: rotational_spring_damper, coordinate: a, stiffness: 0, damping: c}}
  push: {{type: force, frame: beam.tip, vector: [0, T, 0], in: arm}}
outputs:
  tip_y: {{position: beam.tip, in: ISYS, component: y}}
"""


@pytest.mark.parametrize("form", ["plain", "first-order stiffening", "second-order field",
                                  "fixed frame",
                                  # the plain body again with more modes: 4.4 s of CPU
                                  pytest.param("plain 10 modes", marks=pytest.mark.slow)])
def test_elastic_bodies_compile_and_equal_the_numpy_module(form, tmp_path):
    """Elastic bodies in C: the kernel's operations traced and printed as loops
    (codegen/c_splice.py), the body data bound from the twin's data file, against the NumPy
    module that runs the kernel (itself checked against Newton's law of the mass points,
    tests/ffrf): every protocol function agrees to round-off — a hinged beam (3 modes;
    without stiffening, with the first-order terms, with the second-order field; 10 modes)
    and a body on ISYS (elastic rows only), with a node load, an input and an output at the
    node. No number of the body data is printed into the C sources (reference: the entries
    of ``Ke`` and ``Me``, none of which appears in them)."""
    from neweul_py.api import load_description
    from neweul_py.elastic.reductors.invariants import compute_invariants
    from neweul_py.elastic.reductors.second_order import with_second_order
    from neweul_py.fem.beam import BeamSection, beam_model

    b = beam_model(1.0, 8, BeamSection(E=50.0, G=20.0, A=1.0, Iy=1.0, Iz=1.0), planar=True)
    free = np.setdiff1d(np.arange(b.fe.n_dofs), b.node_dofs(0))
    import scipy.linalg as sla

    _lam, X = sla.eigh(b.fe.K.toarray()[np.ix_(free, free)],
                       b.fe.M.toarray()[np.ix_(free, free)])
    nq = 10 if "10 modes" in form else 3
    V = np.zeros((b.fe.n_dofs, nq))
    V[free] = X[:, :nq]
    kg = b.stiffening() if "stiffening" in form or "field" in form else None
    inv = compute_invariants(b.fe, V, nodes=[9], geometric_stiffness=kg)
    if form == "second-order field":
        inv = with_second_order(inv, b.fe, V, kg, b.stiffening_responses())
    name = "flex_" + form.replace(" ", "_").replace("-", "_")
    np.savez(tmp_path / f"{name}.npz", **inv.to_flat())
    (tmp_path / f"{name}.yaml").write_text(_PENDULUM.format(
        name=name, frame="ISYS" if form == "fixed frame" else "arm"))
    eq = newton_euler(load_description(tmp_path / f"{name}.yaml"))
    npath = generate_module(eq, "h", tmp_path / f"{name}.py")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mc = _fresh(write_c_module(eq, npath))
    assert mc.BACKEND == "c"
    c_text = (tmp_path / f"{name}_c.c").read_text() + (tmp_path / f"{name}_c_jac.c").read_text()
    assert "int nw_bind(" in c_text
    flat = inv.to_flat()
    for key in ("Ke.m0", "Me.m0"):
        values = [v for v in np.asarray(flat[key]).ravel() if v not in (0.0, 1.0, -1.0)]
        assert values and not any(repr(float(v)) in c_text for v in values), key
    mnp = load_generated(npath)
    rng = np.random.default_rng(3)
    n = len(mnp.COORDINATES)
    p = mnp.default_parameters()
    for _ in range(2):
        x = np.asarray(mnp.INITIAL_STATE) + 0.05 * rng.standard_normal(2 * n)
        a = rng.standard_normal(n)
        for u in (None, np.array([0.7])):
            _assert_same(mnp, mc, (0.2, x, p, u, a), form)


def test_api_and_cli_thread_the_backend(tmp_path, monkeypatch):
    """Reference: the NumPy module the same calls write with the default backend — the
    compiled module is its drop-in (same constants, same rhs), reused from the cache."""
    from neweul_py import api
    from neweul_py.cli import main

    desc = ROOT / "examples" / "pendulum.yaml"
    wrapper = api.generate(desc, tmp_path / "gen", backend="c")
    assert wrapper == tmp_path / "gen" / "pendulum_c.py"
    assert (tmp_path / "gen" / "pendulum.py").is_file()
    monkeypatch.setenv("NEWEUL_CACHE", str(tmp_path / "cache"))
    cached = api.generated_module(desc, backend="c")
    assert cached.name.endswith("_c.py") and cached.parent == tmp_path / "cache"
    assert api.generated_module(desc, backend="c") == cached  # a cache hit
    mc, mnp = _fresh(cached), load_generated(api.generated_module(desc))
    assert mc.BACKEND == "c" and mc.SOURCE_HASH == mnp.SOURCE_HASH
    x, p = np.array([0.3, 0.1]), mnp.default_parameters()
    np.testing.assert_allclose(mc.rhs(0.0, x, p), mnp.rhs(0.0, x, p), rtol=1e-14)
    res = api.simulate_description(desc, 1.0, backend="c", method="c-dopri5")
    ref = api.simulate_description(desc, 1.0, method="RK45")
    np.testing.assert_allclose(res.y, ref.y, rtol=0, atol=1e-12)
    assert main(["generate", str(desc), "-o", str(tmp_path / "cli"), "--backend", "c"]) == 0
    assert (tmp_path / "cli" / "pendulum_c.py").is_file()
    with pytest.raises(NeweulError, match="unknown backend"):
        api.generate(desc, tmp_path / "x", backend="fortran")


def test_lu_solves_unsymmetric_systems_with_pivoting(tmp_path):
    """Reference: numpy.linalg.solve (LAPACK gesv) on random unsymmetric matrices, one with a
    zero leading pivot (the unsymmetric mass matrices of two-sided elastic bodies); a singular
    matrix is reported, not divided by."""
    import hashlib

    from neweul_py.codegen.c_templates import C_LU

    src = ("#include <math.h>\n#include <string.h>\n" + C_LU +
           "int solve(int n, double *a, int m, double *b)\n"
           "{ int piv[64]; if (nw_lu(n, a, piv)) return 1; nw_lu_solve(n, a, piv, m, b);"
           " return 0; }\n")
    c_path = tmp_path / "lu.c"
    c_path.write_text(src)
    ffi, lib, _ = compiled_library(c_path, hashlib.sha256(src.encode()).hexdigest(),
                                   "int solve(int n, double *a, int m, double *b);",
                                   tmp_path / "cache")
    rng = np.random.default_rng(3)
    for n in (1, 3, 12):
        a = rng.standard_normal((n, n)) + np.diag(rng.random(n))
        if n > 1:
            a[0, 0] = 0.0
        b = rng.standard_normal((n, 4))
        aa, bb = a.copy(), b.copy()
        assert lib.solve(n, ffi.from_buffer("double[]", aa), 4,
                         ffi.from_buffer("double[]", bb)) == 0
        np.testing.assert_allclose(bb, np.linalg.solve(a, b), rtol=1e-10, atol=1e-12)
    singular = np.array([[1.0, 2.0], [2.0, 4.0]])
    assert lib.solve(2, ffi.from_buffer("double[]", singular), 1,
                     ffi.from_buffer("double[]", np.ones(2))) == 1


_NODE_PIN = """
name: pinned_duct
parameters: {g: 9.81, mB: 0.03}
gravity: [0, -g, 0]
coordinates: {a: {initial: 0.2}, bx: {}, by: {}, bz: {}}
frames:
  hub: {rotation: [[z, a]]}
  arm: {parent: hub, translation: [0.3, 0, 0], rotation: [[z, 0.4]]}
  bf: {translation: [bx, by, bz]}
elastic_bodies:
  duct: {frame: arm, data: duct.npz, nodes: {piston: 1}}
bodies:
  B: {frame: bf, mass: mB}
constraints:
  pin: {coincide: [duct.piston, bf]}
"""


@pytest.mark.parametrize("name", ["four_bar", "slider_crank", "two-sided node"])
def test_constraint_reaction_jacobian_as_the_numpy_module(name, tmp_path):
    """Reference: the NumPy module of the same equations. The compiled module has a
    ``constraint_reaction_jacobian`` exactly when its twin has one (rigid loops: neither,
    readers use ``G_R = G``) and returns the same ``G_R``: at a node frame of a two-sided
    elastic host (the piston–duct of tests/equations/test_elastic_constraint_on_node.py)
    ``G_R = G_s S_W`` differs from the library's ``G = G_s S_V``, and a compiled module
    without it would have sent the reactions through ``Φ_P`` instead of ``W_P``."""
    from neweul_py.analysis import protocol as proto

    if name == "two-sided node":
        sys.path.insert(0, str(ROOT / "tests" / "support"))
        from fe_builders import piston_duct

        from neweul_py.elastic import reduce_modal, save_reduced_body
        from neweul_py.elastic.reductors.invariants import attach_invariants

        fe = piston_duct(n_el=40)
        host = reduce_modal(fe, modes=5, two_sided=True, keep_nodes=[1], store_bases=True,
                            skip_rigid=True)
        save_reduced_body(attach_invariants(host, fe, nodes=[1]), tmp_path / "duct.npz")
        (tmp_path / "pinned_duct.yaml").write_text(_NODE_PIN)
        from neweul_py.api import load_description as load_with_data

        eq = newton_euler(load_with_data(tmp_path / "pinned_duct.yaml"))
        npath = generate_module(eq, "h", tmp_path / "pinned_duct.py")
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            mc = _fresh(write_c_module(eq, npath))
        mnp = load_generated(npath)
    else:
        mnp, mc = _modules(name, tmp_path)
    assert mc.BACKEND == "c"
    own = callable(getattr(mnp, "constraint_reaction_jacobian", None))
    assert callable(getattr(mc, "constraint_reaction_jacobian", None)) == own
    assert own == (name == "two-sided node")
    rng = np.random.default_rng(5)
    n, p = len(mnp.COORDINATES), mnp.default_parameters()
    for _ in range(2):
        y = np.asarray(mnp.INITIAL_STATE[:n]) + 0.1 * rng.standard_normal(n)
        ref = proto.constraint_reaction_jacobian(mnp, 0.0, y, p)
        np.testing.assert_allclose(proto.constraint_reaction_jacobian(as_model(mc), 0.0, y, p),
                                   ref,
                                   rtol=0, atol=1e-12 * (1 + np.abs(ref).max()))
        if own:
            G = mc.constraint_jacobian(0.0, y, p)
            assert np.abs(G - ref).max() > 1e-3 * np.abs(ref).max()


@pytest.mark.parametrize("failure", ["no cffi", "untrusted cache"])
def test_asking_for_the_compiled_backend_never_falls_back(failure, tmp_path, monkeypatch,
                                                          capsys, fresh_modules):
    """Reference: the documented contract of ``backend="c"`` — the API and ``--backend c``
    stop with one error naming why (no cffi; a library cache writable by others) instead of
    warning and running the NumPy module; the generated module on its own still falls back
    (BACKEND, BACKEND_ERROR say why)."""
    from neweul_py import api
    from neweul_py.cli import main

    desc = ROOT / "examples" / "pendulum.yaml"
    monkeypatch.setenv("NEWEUL_CACHE", str(tmp_path / "cache"))
    if failure == "no cffi":
        monkeypatch.setitem(sys.modules, "cffi", None)
        why = "cffi is not installed"
    else:
        wrapper = api.generated_module(desc, backend="c")
        shutil.rmtree(wrapper.parent / "__neweul_c__")
        for d in (wrapper.parent / "__neweul_c__", tmp_path / "gen" / "__neweul_c__"):
            d.mkdir(parents=True)
            os.chmod(d, 0o777)
        sys.modules.pop(next(k for k, m in sys.modules.items()
                             if getattr(m, "__file__", None) == str(wrapper)))
        why = "writable by group or others"
    with pytest.raises(NeweulError, match=why):
        api.load_description_module(desc, backend="c")
    with pytest.raises(NeweulError, match=why):
        api.generate(desc, tmp_path / "gen", backend="c")
    assert main(["simulate", str(desc), "--t-end", "0.1", "--backend", "c"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and why in err and "error" in err
    with pytest.warns(RuntimeWarning, match=why):
        mc = _fresh(tmp_path / "gen" / "pendulum_c.py")
    assert mc.BACKEND == "numpy" and why in mc.BACKEND_ERROR
