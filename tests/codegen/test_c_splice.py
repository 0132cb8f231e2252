"""Models with elastic bodies in the compiled backend (codegen/c_splice.py): parametric bodies
in C against the NumPy module generated from the same equations.

Reference: the NumPy module, which runs the floating-frame kernel (neweul_py/ffrf) and whose
parametric bodies equal the elastic layer's interpolation (tests/equations/
test_parametric_elastic_bodies.py); the C library traces the same kernel and must give the
same numbers to round-off, derivatives through the schedule included.
"""

from __future__ import annotations

import functools
import itertools
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest
from fe_builders import parametric_ducts

from neweul_py.analysis import load_generated
from neweul_py.api import load_description
from neweul_py.codegen import generate_module
from neweul_py.codegen.c_module import write_c_module
from neweul_py.elastic import reduce_modal
from neweul_py.elastic.io.body_files import save_parametric_body
from neweul_py.equations import newton_euler
from neweul_py.errors import NeweulError

pytestmark = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                                reason="no C compiler")
SPEEDS = (300.0, 343.0, 390.0)
_COUNTER = itertools.count()

DESCRIPTION = """
name: scheduled_duct
parameters: {{cs: 343.0, m2: 0.02, k2: 1.0e5}}
coordinates: {{z: {{}}}}
inputs: {{F: 0}}
frames:
  carrier: {{translation: [z, 0, 0]}}
elastic_bodies:
  duct: {{frame: {frame}, data: {data}, nodes: {{piston: 1}}, schedule: {schedule}}}
bodies:
  mass: {{frame: carrier, mass: m2}}
forces:
  link:
    type: bushing
    between: [duct.piston, carrier]
    stiffness: {{diag: [k2, 0, 0]}}
  push: {{type: force, frame: carrier, vector: [F, 0, 0], in: ISYS}}
outputs:
  piston: {{position: duct.piston, in: ISYS, component: x}}
"""


@pytest.fixture(scope="module")
def bodies(tmp_path_factory) -> Path:
    """The piston ducts of every weight form (``fe_builders.parametric_ducts``)."""
    tmp = tmp_path_factory.mktemp("c_splice")
    parametric_ducts(tmp, SPEEDS)
    return tmp


@functools.cache
def _pair(tmp: Path, frame: str, data: str, schedule: str, tag: str):
    """The NumPy module and the compiled module of the description (made once per test
    session and arguments)."""
    (tmp / f"{tag}.yaml").write_text(DESCRIPTION.format(frame=frame, data=data,
                                                        schedule=schedule))
    eq = newton_euler(load_description(tmp / f"{tag}.yaml"))
    npath = generate_module(eq, "h", tmp / f"gen_{tag}" / "scheduled_duct.py")
    with warnings.catch_warnings():
        warnings.simplefilter("error")      # a fallback to NumPy would make the test vacuous
        wrapper = write_c_module(eq, npath)
        import importlib.util

        spec = importlib.util.spec_from_file_location(f"c_splice_{next(_COUNTER)}", wrapper)
        mc = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mc)
    assert mc.BACKEND == "c"
    return load_generated(npath), mc


def _same(got, ref, what: str, rtol: float = 1e-12) -> None:
    got, ref = np.asarray(got), np.asarray(ref)
    scale = float(np.abs(ref).max(initial=0.0))
    assert got.shape == ref.shape, what
    assert float(np.abs(got - ref).max(initial=0.0)) <= rtol * scale, what


@pytest.mark.parametrize(("data", "frame"), [
    ("duct.npz", "ISYS"), ("duct_q.npz", "ISYS"),
    # the cubic Hermite weights: 2.9 s of CPU (the weights of every form are one Horner
    # text in C, checked by default with the cubic spline and the quintic Hermite ones)
    pytest.param("duct_h.npz", "ISYS", marks=pytest.mark.slow),
    # every weight form on the moving frame too: 20 s of CPU more (the C backend's moving
    # frames are in tests/codegen/test_c_backend.py by default)
    pytest.param("duct.npz", "carrier", marks=pytest.mark.slow),
    pytest.param("duct_h.npz", "carrier", marks=pytest.mark.slow),
    pytest.param("duct_q.npz", "carrier", marks=pytest.mark.slow)])
def test_parametric_body_in_c_equals_the_numpy_module(bodies, frame: str, data: str) -> None:
    """``schedule: cs + 2000 z + 5 F`` (a coordinate and an input), the body on a fixed and on
    a moving frame, with cubic, cubic Hermite and quintic Hermite weights: ``rhs``, the mass
    matrix, the forces, every Jacobian (the schedule's dependence included: the analytic
    ones of the NumPy module equal finite differences, tests/equations/
    test_parametric_elastic_bodies.py), the outputs and their Jacobians, and the parameter
    derivatives (through the schedule's ``cs`` too) agree to 1e-12 of their largest entry
    (the output Jacobians' schedule terms and ``∂rhs/∂p``, a solve apart: 1e-10) at states
    between the samples, the schedule moving between calls. The compiled mixes by the
    weights read the rows of the weights' polynomials (``POLY_C``) where these are fewer than
    the weights that are not zero on an interval: the quintic Hermite weights in ``c²``
    (cubic pieces in ``c``: 4 rows for 6), not the cubic Hermite ones (4 for 4) nor the
    cubic spline on 3 samples (4 for 3). The products ``x @ S_W`` run along the nonzero
    spans of the rows of ``S_W`` (``nw_wmap``)."""
    mnp, mc = _pair(bodies, frame, data, "cs + 2000*z + 5*F", f"{frame}_{data[:-4]}")
    core = [f for f in (bodies / f"gen_{frame}_{data[:-4]}").glob("*_c.c")]
    assert len(core) == 1
    assert ("nw_poly(sigma[0], " in core[0].read_text()) == (data == "duct_q.npz")
    assert "    nw_wmap(" in core[0].read_text()          # x @ S_W along the rows' spans
    n, p = len(mnp.COORDINATES), mnp.default_parameters()
    rng = np.random.default_rng(7)
    for k in range(3):
        x = 1e-4 * rng.normal(size=2 * n)
        u = None if k == 0 else rng.normal(size=len(mnp.INPUTS))
        a = rng.normal(size=n)
        y, yd = x[:n], x[n:]
        _same(mc.rhs(0.1, x, p, u), mnp.rhs(0.1, x, p, u), "rhs")
        _same(mc.mass_matrix(0.1, y, p, u), mnp.mass_matrix(0.1, y, p, u), "M")
        _same(mc.force_vector(0.1, y, yd, p, u), mnp.force_vector(0.1, y, yd, p, u), "q - k")
        for got, ref, what in zip(mc.force_jacobians(0.1, y, yd, p, u),
                                  mnp.force_jacobians(0.1, y, yd, p, u), ("fy", "fyd", "fu"),
                                  strict=True):
            _same(got, ref, what)
        _same(mc.mass_matrix_times_derivative(0.1, y, p, a, u),
              mnp.mass_matrix_times_derivative(0.1, y, p, a, u), "d(M a)/dy")
        _same(mc.rhs_jacobian(0.1, x, p, u), mnp.rhs_jacobian(0.1, x, p, u), "rhs_jacobian")
        _same(mc.outputs(0.1, x, p, u), mnp.outputs(0.1, x, p, u), "outputs")
        C, D = mc.output_jacobians(0.1, x, p, u)
        Cr, Dr = mnp.output_jacobians(0.1, x, p, u)
        _same(C, Cr, "C")
        # D is the schedule's term alone (3e-11 m/N): both sides take it from the complex
        # step in σ; the C library's dS_V/dσ comes from the weights' derivative instead
        _same(D, Dr, "D", rtol=1e-10)
        # the parameter derivatives: through the schedule (cs) and the symbolic part (m2, k2)
        _same(mc.force_parameter_jacobian(0.1, y, yd, p, u),
              mnp.force_parameter_jacobian(0.1, y, yd, p, u), "d(q - k)/dp")
        _same(mc.mass_matrix_parameter_derivative(0.1, y, p, a, u),
              mnp.mass_matrix_parameter_derivative(0.1, y, p, a, u), "d(M a)/dp")
        _same(mc.rhs_parameter_jacobian(0.1, x, p, u), mnp.rhs_parameter_jacobian(0.1, x, p, u),
              "d rhs/dp", rtol=1e-10)
        _same(mc.output_parameter_jacobian(0.1, x, p, u),
              mnp.output_parameter_jacobian(0.1, x, p, u), "d out/dp", rtol=1e-10)


def test_schedule_outside_the_samples_gives_the_numpy_modules_error(bodies) -> None:
    """``cs = 500`` outside [300, 390]: the compiled module raises the NumPy module's
    ValueError naming the body, the value and the range (reference: that message)."""
    mnp, mc = _pair(bodies, "ISYS", "duct.npz", "cs + 2000*z + 5*F", "ISYS_duct")
    p = mnp.default_parameters()
    p[list(mnp.PARAMETERS).index("cs")] = 500.0
    x = np.zeros(mnp.STATE_SIZE)
    n = mnp.STATE_SIZE // 2
    with pytest.raises(ValueError) as ref:
        mnp.rhs(0.0, x, p)
    for call in (lambda: mc.rhs(0.0, x, p), lambda: mc.mass_matrix(0.0, x[:n], p),
                 lambda: mc.rhs_jacobian(0.0, x, p), lambda: mc.outputs(0.0, x, p)):
        with pytest.raises(ValueError) as got:
            call()
        assert str(got.value) == str(ref.value)
    assert "'duct'" in str(ref.value) and "[300.0, 390.0]" in str(ref.value)


def test_compiled_module_reads_its_data_from_the_twins_data_file(bodies) -> None:
    """The compiled module's C sources hold none of the body's numbers, and with the twin's
    data file changed after generation the compiled module does not load either: one error
    naming the body and the file (reference: the NumPy module's refusal)."""
    _pair(bodies, "ISYS", "duct.npz", "cs", "data")
    gen = bodies / "gen_data"
    (data,) = gen.glob("*.npz")
    import re

    numbers = set(re.findall(r"\d+\.\d*(?:e[-+]?\d+)?", "".join(
        f.read_text() for f in gen.glob("*.c"))))
    with np.load(data) as z:
        stack = np.concatenate((z["duct/mixing/base"], z["duct/mixing/varying"].ravel()))
    values = {repr(abs(float(v))) for v in stack.ravel()} - {"0.0", "1.0", "0.5", "2.0"}
    assert len(values) > 100 and not values & numbers
    raw = bytearray(data.read_bytes())
    raw[-300] ^= 0x01
    data.write_bytes(bytes(raw))
    with pytest.raises(NeweulError) as info:
        load_generated(gen / "scheduled_duct_c.py")
    assert "elastic body 'duct'" in str(info.value) and data.name in str(info.value)


def test_symbolic_part_writes_into_its_one_static_buffer(bodies) -> None:
    """``nw_s_rhs_parts`` sets only the entries that are not zero by construction, without a
    ``memset`` (codegen/c_splice.py). That is right only while its one caller passes the
    static buffer ``parts``, zero from the load on, that nothing else writes: both C files
    have exactly that one call, and the kernels that read the buffer (``nw_k_dyn``; in the
    core library also the residual's ``nw_k_dynr``) read it as ``const`` (reference: the
    invariant the generator states)."""
    import re

    _pair(bodies, "ISYS", "duct_q.npz", "cs + 2000*z + 5*F", "ISYS_duct_q")
    files = sorted((bodies / "gen_ISYS_duct_q").glob("*.c"))
    assert [f.name.endswith("_jac.c") for f in files] == [False, True]
    readers = {"nw_k_dyn": "nw_k_dyn(parts, y, yd, parts + NW_NH, parts + NW_NH + NW_NS * NW_NS, "
                           "M, f);",
               "nw_k_dynr": "nw_k_dynr(parts, z, z + NW_N, parts + NW_NH, "
                            "parts + NW_NH + NW_NS * NW_NS, a, r);"}
    for path, kernels in zip(files, (("nw_k_dyn", "nw_k_dynr"), ("nw_k_dyn",)), strict=True):
        text = re.sub(r"/\*.*?\*/", "", path.read_text(), flags=re.S)    # no comments
        assert re.findall(r"nw_s_rhs_parts\(([^;{]*)\);", text) == ["t, ys, yds, p, u, parts"]
        lines = [line.strip() for line in text.splitlines() if re.search(r"\bparts\b", line)]
        assert lines == ["static double parts[NW_NH + NW_NS * NW_NS + NW_NS + 1];",
                         "nw_s_rhs_parts(t, ys, yds, p, u, parts);",
                         *(readers[k] for k in kernels)]
        start = text.index("static int nw_s_rhs_parts(")
        assert "memset" not in text[start:text.index("\n}\n", start)]
        for k in kernels:
            head = text[text.index(f"static void {k}("):][:200]
            assert all(f"const double *{a}" in head for a in ("kin", "Ms", "fs"))


def test_kept_factorization_follows_the_schedule(bodies) -> None:
    """The compiled solve keeps the factorization of the elastic block and refines against
    the block at the current schedule (codegen/c_splice.py): along small steps of ``cs``,
    across a jump over the whole sampled range and back, and at a repeated value, ``rhs``
    equals the NumPy module's (reference: its direct solve at every value)."""
    mnp, mc = _pair(bodies, "ISYS", "duct_q.npz", "cs", "refine")
    n, ics = len(mnp.COORDINATES), list(mnp.PARAMETERS).index("cs")
    p = mnp.default_parameters()
    x = 1e-4 * np.random.default_rng(11).normal(size=2 * n)
    for cs in (343.0, 343.01, 343.02, 301.0, 389.5, 343.02, 343.02, 343.03):
        p[ics] = cs
        _same(mc.rhs(0.0, x, p), mnp.rhs(0.0, x, p), f"rhs at cs = {cs}")



@pytest.mark.parametrize(("data", "mixed"), [("duct_g.npz", 0), ("duct_q.npz", 1)])
def test_outputs_at_a_new_schedule_leave_the_mix_to_its_readers(bodies, data: str,
                                                                mixed: int) -> None:
    """The outputs and constraints read the symbolic part alone: at a new schedule they take
    the weights (and their range check) but leave the mix of the samples to the functions
    that read it (``nw_at_sv``, ``nw_mixed``), unless ``S_V`` is mixed too (``NW_SV_MIXED``:
    the node rows of the global-basis duct are constant, those of the interpolated local
    bodies are not). Called first at each of a series of states,
    the outputs equal the NumPy module's, and ``rhs``, the mass matrix and the residual's
    ``∂(q − k)/∂y`` at that state afterwards equal the NumPy module's too: a mix that were
    left out would keep the previous schedule's samples; so does ``rhs`` back at the
    schedule of the last mix while another one's is pending (no mix) and then at the other
    one (reference: the NumPy module at every state)."""
    mnp, mc = _pair(bodies, "ISYS", data, "cs + 2000*z + 5*F", f"ISYS_{data[:-4]}")
    core = next((bodies / f"gen_ISYS_{data[:-4]}").glob("*_c.c")).read_text()
    assert f"#define NW_SV_MIXED {mixed}" in core
    outputs = core[core.index("int nw_outputs("):]
    assert "nw_at_sv(t, x, p, u)" in outputs[:outputs.index("\n}\n")]
    n, p = len(mnp.COORDINATES), mnp.default_parameters()
    rng = np.random.default_rng(13)
    for k in range(4):
        x = 1e-3 * rng.normal(size=2 * n)
        _same(mc.outputs(0.2, x, p), mnp.outputs(0.2, x, p), f"outputs {k}")
        if k % 2:
            _same(mc.force_jacobians(0.2, x[:n], x[n:], p)[0],
                  mnp.force_jacobians(0.2, x[:n], x[n:], p)[0], f"fy {k}")
        _same(mc.rhs(0.2, x, p), mnp.rhs(0.2, x, p), f"rhs {k}")
        _same(mc.mass_matrix(0.2, x[:n], p), mnp.mass_matrix(0.2, x[:n], p), f"M {k}")
    # back at the mixed schedule while another one's mix is pending, then at the other one
    other = 1e-3 * rng.normal(size=2 * n)
    for seen, state in ((other, x), (other, other), (x, other)):
        _same(mc.outputs(0.2, seen, p), mnp.outputs(0.2, seen, p), "outputs")
        _same(mc.rhs(0.2, state, p), mnp.rhs(0.2, state, p), "rhs after a pending mix")


@pytest.mark.slow
def test_body_of_hundreds_of_modes_in_c_equals_the_numpy_module(tmp_path) -> None:
    """A spring chain of 260 DOFs whose stiffness and mass change with ``s``, reduced to 200
    modes at 4 samples with quintic Hermite weights, on ISYS with a mass on a spring at its
    free end, scheduled by ``s0 + 0.1 sin(t)``: the compiled module's M, q − k, rhs, their
    Jacobians and the outputs equal the NumPy module's to 1e-12 of their largest entry
    (reference: the NumPy module) along a few schedule values."""
    from fe_builders import spring_chain

    from neweul_py.elastic.parametric.snapshot_basis import basis_parametric_body

    n = 260

    def fe(s: float):
        return spring_chain(n, k=1.0e4 * (1 + s), m=0.1 * (1 + 0.2 * s), damping=1e-4)

    values, step = np.linspace(0.0, 1.0, 4), 0.01
    fes = [fe(s) for s in values]
    V = reduce_modal(fes[0], modes=200, store_bases=True).V
    body = basis_parametric_body(fes, V, values, parameter="s", keep_nodes=[n],
                                 interpolation="quintic-hermite",
                                 slope_models=([fe(s - step) for s in values],
                                               [fe(s + step) for s in values]),
                                 slope_step=step)
    save_parametric_body(body, tmp_path / "chain.npz")
    (tmp_path / "chain.yaml").write_text(f"""
name: chain
parameters: {{s0: 0.4, m2: 0.5, k2: 2.0e3}}
coordinates: {{z: {{}}}}
inputs: {{F: 0}}
frames:
  carrier: {{translation: [z, 0, 0]}}
elastic_bodies:
  chain: {{frame: ISYS, data: chain.npz, nodes: {{tip: {n}}}, inertia: sid,
          schedule: s0 + 0.1*sin(t)}}
bodies:
  mass: {{frame: carrier, mass: m2}}
forces:
  link: {{type: bushing, between: [chain.tip, carrier], stiffness: {{diag: [k2, 0, 0]}}}}
  push: {{type: force, frame: chain.tip, vector: [F, 0, 0], in: ISYS}}
outputs:
  x_mass: {{position: carrier, in: ISYS, component: x}}
""")
    eq = newton_euler(load_description(tmp_path / "chain.yaml"))
    npath = generate_module(eq, "h", tmp_path / "gen" / "chain.py")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mc = load_generated(write_c_module(eq, npath))
    mnp = load_generated(npath)
    assert mc.BACKEND == "c" and mnp.STATE_SIZE == 2 * 201
    nn, p = mnp.STATE_SIZE // 2, mnp.default_parameters()
    rng = np.random.default_rng(2)
    for t in (0.0, 0.3, 0.31, 2.0):
        x = 1e-3 * rng.normal(size=2 * nn)
        u = rng.normal(size=1)
        _same(mc.mass_matrix(t, x[:nn], p, u), mnp.mass_matrix(t, x[:nn], p, u), "M")
        _same(mc.force_vector(t, x[:nn], x[nn:], p, u),
              mnp.force_vector(t, x[:nn], x[nn:], p, u), "q - k")
        _same(mc.rhs(t, x, p, u), mnp.rhs(t, x, p, u), "rhs")
        for got, ref in zip(mc.force_jacobians(t, x[:nn], x[nn:], p, u),
                            mnp.force_jacobians(t, x[:nn], x[nn:], p, u), strict=True):
            _same(got, ref, "force Jacobians")
        _same(mc.rhs_jacobian(t, x, p, u), mnp.rhs_jacobian(t, x, p, u), "rhs_jacobian")
        _same(mc.outputs(t, x, p, u), mnp.outputs(t, x, p, u), "outputs")


def test_parametric_body_in_the_compiled_generalized_alpha_loop(bodies) -> None:
    """Generalized-α steps of a compiled parametric body in the module's C loop (residual
    form, the inverse of the iteration matrix kept in C) against the NumPy module's Python
    loop: a constant force moves the carrier, so the schedule ``cs + 2000 z + 5 F`` and the
    mixed samples change at every step. Reference: the NumPy
    module, to the Newton tolerance (rtol 1e-8) — the two loops iterate in different forms
    with the same matrix."""
    from neweul_py.analysis.simulate import simulate

    mnp, mc = _pair(bodies, "ISYS", "duct_q.npz", "cs + 2000*z + 5*F", "ISYS_duct_q")
    assert mc.generalized_alpha_steps is not None
    kw = {"method": "generalized-alpha", "h": 2e-5, "rho_inf": 0.8, "rtol": 1e-8,
          "atol": 1e-14, "n_out": 51, "u": {"F": 2.0}}
    c = simulate(mc, 4e-3, **kw)
    ref = simulate(mnp, 4e-3, **kw)
    z = ref.outputs[:, list(ref.output_names).index("piston")]
    got = c.outputs[:, list(c.output_names).index("piston")]
    assert np.abs(z).max() > 0
    assert np.abs(got - z).max() <= 1e-7 * np.abs(z).max()


@pytest.mark.slow
def test_compiled_loop_leaving_the_samples_gives_the_numpy_modules_error(bodies,
                                                                         tmp_path) -> None:
    """A force ``A t²`` drives the schedule ``cs + 2000 z`` out of the samples during a
    step, at a later Newton iterate than the first: the C loop's driver evaluates the model
    where it failed, so ``simulate`` reports the NumPy module's error, naming the body and
    the range (reference: that message)."""
    from neweul_py.analysis.simulate import simulate

    text = DESCRIPTION.replace("inputs: {{F: 0}}", "inputs: {{F: 'A*t*t'}}").replace(
        "parameters: {{cs: 343.0,", "parameters: {{A: 3.98e6, cs: 343.0,")
    path = tmp_path / "ramp.yaml"
    path.write_text(text.format(frame="carrier", data=bodies / "duct_q.npz",
                                schedule="cs + 2000*z"))
    eq = newton_euler(load_description(path))
    npath = generate_module(eq, "h", tmp_path / "gen" / "scheduled_duct.py")
    mc = load_generated(write_c_module(eq, npath))
    assert mc.generalized_alpha_steps is not None
    kw = {"method": "generalized-alpha", "h": 2e-4, "rho_inf": 0.8, "rtol": 1e-8,
          "atol": 1e-14, "n_out": 11}
    for mod in (load_generated(npath), mc):
        with pytest.raises(NeweulError, match=r"elastic body 'duct': schedule value 390\.00"
                                              r".* outside the sampled range \[300\.0, 390\.0\]"):
            simulate(mod, 8e-3, **kw)
