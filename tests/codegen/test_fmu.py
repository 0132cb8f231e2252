"""FMI 2.0 FMUs of models (codegen/fmu.py, codegen/fmu_model.py, api.export_fmu).

The independent references are the FMI standard's validator as FMPy implements it (the XML
schema, variable names, ModelStructure, start values, units: ``fmpy.validation``), FMPy's
simulation of both kinds (its CVODE for model exchange, its master algorithm for
co-simulation) against ``neweul simulate`` (``analysis.simulate``) at matching tolerances, and
the generated module's analytic Jacobians against the FMU's directional derivatives (of a
parametric elastic body too, whose module's Jacobians equal finite differences:
tests/equations/test_parametric_elastic_bodies.py).

Agreement is measured per variable relative to its largest magnitude over the run,
``max_t |a − b| / max_t |b|``, the largest over the coordinates and outputs.
"""

from __future__ import annotations

import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fe_builders import piston_duct
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Model, FMU2Slave
from fmpy.validation import validate_fmu

from neweul_py.analysis.simulate import simulate
from neweul_py.api import export_fmu, load_description_module
from neweul_py.elastic import reduce_modal
from neweul_py.elastic.io.body_files import save_parametric_body
from neweul_py.elastic.parametric.local_interpolation import interpolate
from neweul_py.elastic.reductors.invariants import attach_invariants

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
DATA = ROOT / "tests" / "data"
#: Tolerance of both sides (FMPy's relative tolerance, CVODE's absolute one is rtol times the
#: nominal 1; the co-simulation stepper's rtol = atol; simulate's rtol = atol).
TOL = 1e-10

#: The cart pendulum with its drive force as an input set by the importer (default 0).
CART = (EXAMPLES / "cart_pendulum.yaml").read_text().replace("F: F0*sin(Omega*t)", "F: 0")

#: A pendulum of the SID beam (3 modes, SID truncation) swinging about x under gravity, its
#: elastic coordinates started away from zero, with a node load and a node output.
FLEX = """
name: flex
parameters: {g: 9.81, c: 0.2}
inputs: {T: 0.0}
gravity: [0, -g, 0]
coordinates: {a: {initial: 0.3}}
frames:
  arm: {rotation: [[x, a]]}
elastic_bodies:
  beam: {frame: arm, data: beam.SID_FEM, nodes: {tip: 1793}, modes: 3, inertia: sid,
         initial: [0.002, 0.001, 0.0005]}
forces:
  drive: {type: rotational_spring_damper, coordinate: a, stiffness: 0, damping: c}
  push: {type: force, frame: beam.tip, vector: [0, T, 0], in: arm}
outputs:
  tip_y: {position: beam.tip, in: ISYS, component: y}
"""


#: A parametric u–p duct body (three sound speeds, 6 two-sided modes, cubic weights) on ISYS
#: whose schedule follows a coordinate and an input, coupled at its piston to a mass on a
#: spring started 1 cm away (the schedule moves between 323 and 363 m/s over the run).
DUCT = """
name: scheduled_duct
parameters: {cs: 343.0, m2: 0.02, k2: 1.0e5}
coordinates: {z: {initial: 0.01}}
inputs: {F: 0}
frames:
  carrier: {translation: [z, 0, 0]}
elastic_bodies:
  duct: {frame: ISYS, data: duct.npz, nodes: {piston: 1}, schedule: cs + 2000*z + 5*F}
bodies:
  mass: {frame: carrier, mass: m2}
forces:
  link:
    type: bushing
    between: [duct.piston, carrier]
    stiffness: {diag: [k2, 0, 0]}
  push: {type: force, frame: carrier, vector: [F, 0, 0], in: ISYS}
outputs:
  piston: {position: duct.piston, in: ISYS, component: x}
"""


def _duct_body(path: Path) -> None:
    """The parametric body of ``DUCT``: piston ducts at 300, 343 and 390 m/s, interpolated."""
    samples = []
    for c in (300.0, 343.0, 390.0):
        fe = piston_duct(n_el=40, c=c)
        body = reduce_modal(fe, modes=6, two_sided=True, keep_nodes=[1], store_bases=True)
        samples.append(attach_invariants(body, fe, nodes=[1]))
    save_parametric_body(interpolate(samples, [300.0, 343.0, 390.0], parameter="c"), path)


@pytest.fixture(scope="module")
def work(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("fmu")
    (d / "cart.yaml").write_text(CART)
    (d / "flex.yaml").write_text(FLEX)
    (d / "duct.yaml").write_text(DUCT)
    shutil.copy(DATA / "beam.SID_FEM", d / "beam.SID_FEM")
    _duct_body(d / "duct.npz")
    return d


_BUILT: dict[str, Path] = {}


def _fmu(work: Path, name: str) -> tuple[Path, Path]:
    """The description of ``name`` and its FMU of both kinds (built once per run)."""
    desc = EXAMPLES / f"{name}.yaml" if (EXAMPLES / f"{name}.yaml").is_file() and name not in (
        "cart", "flex", "duct") else work / f"{name}.yaml"
    if name not in _BUILT:
        _BUILT[name] = export_fmu(desc, work / f"{name}.fmu", "both", cache=work / "cache")
    return desc, _BUILT[name]


def _reference(work: Path, desc: Path, t_end: float, n_out: int, **kw):
    mod = load_description_module(desc, cache=work / "cache")
    res = simulate(mod, t_end, method="DOP853", rtol=TOL, atol=TOL, n_out=n_out, **kw)
    names = [*mod.COORDINATES, *mod.OUTPUTS]
    return mod, res.t, np.hstack([res.y, res.outputs[:, :len(mod.OUTPUTS)]]), names


def _worst(res, names, values) -> float:
    return max(float(np.max(np.abs(res[n] - values[:, k])) / np.max(np.abs(values[:, k])))
               for k, n in enumerate(names))


@pytest.mark.parametrize(("name", "t_end"), [("double_pendulum", 5.0), ("four_bar", 3.0),
                                             ("slider_crank", 2.0), ("flex", 0.5)])
def test_fmus_validate_and_agree_with_simulate(work, name, t_end):
    """FMPy's validation finds no problem, and ``simulate_fmu`` of model exchange (CVODE) and
    co-simulation (the FMU's stepper) agree with ``simulate`` (DOP853) to ≤ 1e-6 relative at
    rtol 1e-10 — a rigid chain, two closed loops (the FMU's states are the independent
    coordinates, the dependent ones follow the constraints) and an elastic body."""
    desc, fmu = _fmu(work, name)
    assert validate_fmu(str(fmu)) == []
    _mod, t, ref, names = _reference(work, desc, t_end, 201)
    for kind in ("ModelExchange", "CoSimulation"):
        res = simulate_fmu(str(fmu), fmi_type=kind, stop_time=t_end, relative_tolerance=TOL,
                           output_interval=t_end / 200, output=names)
        np.testing.assert_allclose(res["time"], t, rtol=0, atol=1e-12)
        assert _worst(res, names, ref) <= 1e-6, (name, kind)


def test_parametric_elastic_fmu_agrees_with_simulate(work):
    """A parametric elastic body whose schedule moves with a coordinate: its equations in
    the FMU's C, its arrays in ``resources/`` (none of the body file's numbers in the
    sources); FMPy's
    validation finds no problem, and both kinds agree with ``simulate`` (DOP853) to ≤ 1e-6
    relative at rtol 1e-12 (at 1e-10 the higher modes, of 3e-5 of the first one's amplitude,
    are held to the absolute tolerance: 5e-7)."""
    desc, fmu = _fmu(work, "duct")
    assert validate_fmu(str(fmu)) == []
    names = zipfile.ZipFile(fmu).namelist()
    assert "resources/scheduled_duct.bin" in names
    sources = "".join(zipfile.ZipFile(fmu).read(n).decode() for n in names
                      if n.startswith("sources/model"))
    body = np.load(work / "duct.npz")       # its entries of full precision
    values = [repr(float(v)) for key in body.files if body[key].dtype.kind == "f"
              for v in body[key].ravel()[:50] if len(repr(float(v))) > 12]
    assert values and not any(v in sources for v in values)
    t_end, tol = 0.01, 1e-12
    mod = load_description_module(desc, cache=work / "cache")
    res = simulate(mod, t_end, method="DOP853", rtol=tol, atol=tol, n_out=201)
    ref = np.hstack([res.y, res.outputs[:, :len(mod.OUTPUTS)]])
    cols = [*mod.COORDINATES, *mod.OUTPUTS]
    for kind in ("ModelExchange", "CoSimulation"):
        out = simulate_fmu(str(fmu), fmi_type=kind, stop_time=t_end, relative_tolerance=tol,
                           output_interval=t_end / 200, output=cols)
        np.testing.assert_allclose(out["time"], res.t, rtol=0, atol=1e-12)
        assert _worst(out, cols, ref) <= 1e-6, kind


def test_changed_or_missing_elastic_data_are_refused(work, tmp_path):
    """The FMU reads its elastic bodies' arrays at instantiation and refuses them (FMPy's
    ``instantiate`` fails) when one word of the file was changed, or when it is missing;
    the unchanged file instantiates (reference: the file the export wrote)."""
    _desc, fmu = _fmu(work, "duct")
    md, inst = _instance(fmu, tmp_path / "ok", FMU2Model)
    inst.freeInstance()
    data = tmp_path / "bad" / "resources" / "scheduled_duct.bin"
    extract(str(fmu), unzipdir=str(tmp_path / "bad"))
    raw = bytearray(data.read_bytes())
    raw[100] ^= 1
    data.write_bytes(bytes(raw))
    for what in ("changed", "missing"):
        if what == "missing":
            data.unlink()
        inst = FMU2Model(guid=md.guid, unzipDirectory=str(tmp_path / "bad"),
                         modelIdentifier=md.modelExchange.modelIdentifier, instanceName="t")
        with pytest.raises(Exception, match="instantiate"):
            inst.instantiate()


def test_input_driven_fmu_agrees_with_simulate(work):
    """A drive force stepping at 1 s and 2 s, set by FMPy as input events, against
    ``simulate`` restarted at the steps with the constant force of each interval."""
    desc, fmu = _fmu(work, "cart")
    assert validate_fmu(str(fmu)) == []
    t_end, steps, forces = 3.0, [0.0, 1.0, 2.0, 3.0], [0.0, 2.0, -1.0]
    signal = np.array([(0.0, 0.0), (1.0, 0.0), (1.0, 2.0), (2.0, 2.0), (2.0, -1.0),
                       (3.0, -1.0)], dtype=[("time", float), ("F", float)])
    mod = load_description_module(desc, cache=work / "cache")
    grid = np.linspace(0.0, t_end, 301)
    names = [*mod.COORDINATES, *mod.OUTPUTS]
    ref, x0 = {}, None
    for a, b, f in zip(steps[:-1], steps[1:], forces, strict=True):
        res = simulate(mod, b, t_start=a, t_eval=grid[(grid >= a) & (grid <= b)], x0=x0,
                       u={"F": f}, method="DOP853", rtol=TOL, atol=TOL)
        x0 = np.concatenate([res.y[-1], res.yd[-1]])
        for tk, row in zip(res.t, np.hstack([res.y, res.outputs]), strict=True):
            ref[float(tk)] = row
    values = np.array([ref[float(tk)] for tk in grid])
    for kind in ("ModelExchange", "CoSimulation"):
        res = simulate_fmu(str(fmu), fmi_type=kind, stop_time=t_end, relative_tolerance=TOL,
                           output_interval=0.01, output=names, input=signal,
                           record_events=False)
        np.testing.assert_allclose(res["time"], grid, rtol=0, atol=1e-12)
        assert _worst(res, names, values) <= 1e-6, kind


def _instance(fmu: Path, unzip: Path, cls, extracted: bool = False, name: str = "test"):
    """An instantiated instance of ``fmu`` extracted into ``unzip`` (already, with
    ``extracted``: instances of one extraction share the loaded library)."""
    md = read_model_description(str(fmu))
    if not extracted:
        extract(str(fmu), unzipdir=str(unzip))
    ident = (md.modelExchange if cls is FMU2Model else md.coSimulation).modelIdentifier
    inst = cls(guid=md.guid, unzipDirectory=str(unzip), modelIdentifier=ident,
               instanceName=name)
    inst.instantiate()
    return md, inst


def _ramped_run(fmu: Path, unzip: Path, tb: np.ndarray, fb: np.ndarray, slopes: bool):
    """The cart's states after each communication step ``tb[k] → tb[k+1]`` with the force
    ``fb[k]`` set at its start, and its slope when ``slopes``."""
    md, cs = _instance(fmu, unzip, FMU2Slave)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    cs.setupExperiment(tolerance=TOL, startTime=0.0)
    cs.enterInitializationMode()
    cs.exitInitializationMode()
    states = []
    for k in range(len(tb) - 1):
        cs.setReal([vr["F"]], [fb[k]])
        if slopes:
            cs.setRealInputDerivatives([vr["F"]], [1],
                                       [(fb[k + 1] - fb[k]) / (tb[k + 1] - tb[k])])
        cs.doStep(tb[k], tb[k + 1] - tb[k])
        states.append(cs.getReal([vr["x"], vr["phi"], vr["d_x"], vr["d_phi"]]))
    cs.terminate()
    cs.freeInstance()
    return np.array(states)


def test_cosimulation_interpolates_inputs(work, tmp_path):
    """``fmi2SetRealInputDerivatives`` (canInterpolateInputs): a force ramping linearly over
    each communication step, set with its slope at each step's start (FMPy's low-level
    API), against ``simulate`` with the same piecewise-linear force, restarted at its kinks
    (across them DOP853 at rtol 1e-10 is only good to 3e-8). Without the slopes (a
    zero-order hold) the same steps are off by more than 1e-4."""
    desc, fmu = _fmu(work, "cart")
    tb = np.linspace(0.0, 2.0, 41)
    fb = 2.0 * np.sin(3.0 * tb)
    mod = load_description_module(desc, cache=work / "cache")
    ref, x0 = [], None
    for k in range(len(tb) - 1):
        res = simulate(mod, tb[k + 1], t_start=tb[k], t_eval=[tb[k + 1]], x0=x0,
                       u=lambda t: np.array([np.interp(t, tb, fb)]), method="DOP853",
                       rtol=TOL, atol=TOL)
        x0 = np.concatenate([res.y[-1], res.yd[-1]])
        ref.append(x0)
    ramped = _ramped_run(fmu, tmp_path / "a", tb, fb, slopes=True)
    np.testing.assert_allclose(ramped, ref, rtol=0, atol=1e-8)
    held = _ramped_run(fmu, tmp_path / "b", tb, fb, slopes=False)
    assert np.abs(held - np.array(ref)).max() > 1e-4


@pytest.mark.parametrize("name", ["cart", "flex", "duct"])
def test_directional_derivatives_are_the_analytic_jacobians(work, tmp_path, name):
    """``fmi2GetDirectionalDerivative`` of the derivatives and outputs with respect to the
    states and inputs, column by column, against the generated module's ``rhs_jacobian``,
    ``M⁻¹ ∂(q−k)/∂u`` and ``output_jacobians`` at the start state."""
    desc, fmu = _fmu(work, name)
    md, me = _instance(fmu, tmp_path / "me", FMU2Model)
    assert md.modelExchange.providesDirectionalDerivative
    me.setupExperiment(startTime=0.0)
    me.enterInitializationMode()
    me.exitInitializationMode()
    mod = load_description_module(desc, cache=work / "cache")
    n = len(mod.COORDINATES)
    x, p = np.asarray(mod.INITIAL_STATE, dtype=float), mod.default_parameters()
    u = mod.default_inputs(0.0, p)
    jx = mod.rhs_jacobian(0.0, x, p, u)
    m = mod.mass_matrix(0.0, x[:n], p, u)
    ju = np.vstack([np.zeros((n, len(u))),
                    np.linalg.solve(m, mod.force_jacobians(0.0, x[:n], x[n:], p, u)[2])])
    cx, du = mod.output_jacobians(0.0, x, p, u)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    states = [*mod.COORDINATES, *(f"d_{c}" for c in mod.COORDINATES)]
    unknowns = [vr[f"der({s})"] for s in states] + [vr[o] for o in mod.OUTPUTS]
    expected = np.hstack([np.vstack([jx, cx]), np.vstack([ju, du])])
    knowns = [*states, *mod.INPUTS]
    for j, known in enumerate(knowns):
        col = me.getDirectionalDerivative(unknowns, [vr[known]], [1.0])
        np.testing.assert_allclose(col, expected[:, j], rtol=1e-12,
                                   atol=1e-12 * np.abs(expected).max(), err_msg=known)
    me.terminate()
    me.freeInstance()


def test_model_description_declares_what_the_model_is(work):
    """The variables of the four-bar FMU: tunable parameters with their defaults, the input
    with its start value and unit (a torque on the crank: ``N.m``), the states of the
    independent coordinate only (``phi1``; ``phi2``, ``phi3`` calculated), units, the
    outputs, no directional derivatives for a constrained model, and the sources and the
    linux binary in the archive."""
    _desc, fmu = _fmu(work, "four_bar")
    md = read_model_description(str(fmu))
    by = {v.name: v for v in md.modelVariables}
    mod = load_description_module(EXAMPLES / "four_bar.yaml", cache=work / "cache")
    for name, value in mod.PARAMETERS.items():
        assert by[name].causality == "parameter" and by[name].variability == "tunable"
        assert float(by[name].start) == value
    assert by["Md"].causality == "input" and float(by["Md"].start) == 0.0
    assert by["Md"].unit == "N.m"
    assert [d.variable.name for d in md.derivatives] == ["der(phi1)", "der(d_phi1)"]
    assert by["phi1"].initial == "exact" and by["phi2"].initial == "calculated"
    assert by["phi2"].unit == "rad" and by["d_phi1"].unit == "rad/s"
    assert by["coupler_tip_z"].unit == "m" and by["coupler_tip_z"].description
    assert [o.variable.name for o in md.outputs] == list(mod.OUTPUTS)
    assert not md.modelExchange.providesDirectionalDerivative
    assert md.coSimulation.canInterpolateInputs
    names = zipfile.ZipFile(fmu).namelist()
    assert "binaries/linux64/four_bar.so" in names
    assert {"sources/model.c", "sources/model_jac.c", "sources/neweul_fmi2.c",
            "sources/model.h", "sources/fmi2Functions.h"} <= set(names)


def _duct_run(fmu: Path, unzip: Path, cs: float, steps: int, start=None, done=None):
    """The duct's piston position after each of ``steps`` co-simulation steps of 2 ms with
    the sound speed ``cs``, an instance of the library extracted in ``unzip`` (loaded once
    per process: the instances share it); with ``start`` (a barrier) the runs begin
    together and each waits at ``done`` before it frees its instance."""
    md, inst = _instance(fmu, unzip, FMU2Slave, extracted=True, name=f"cs{cs:g}")
    vr = {v.name: v.valueReference for v in md.modelVariables}
    inst.setupExperiment(tolerance=1e-8, startTime=0.0)
    inst.enterInitializationMode()
    inst.setReal([vr["cs"]], [cs])
    inst.exitInitializationMode()
    if start is not None:
        start.wait()
    out = []
    for k in range(steps):
        inst.doStep(k * 2e-3, 2e-3)
        out.append(inst.getReal([vr["piston"]])[0])
    if done is not None:
        done.wait()
    inst.terminate()
    inst.freeInstance()
    return np.array(out)


def test_instances_stepped_in_parallel_threads_give_their_own_results(work, tmp_path):
    """Two instances of the parametric elastic FMU (``canBeInstantiatedOnlyOncePerProcess``
    false) of one loaded library, stepped at once from two threads — FMPy's calls release
    the GIL, so the C runs in parallel — each give the result of that instance run alone
    (reference: the runs one after the other, to round-off: the library's caches are
    shared). The library's work buffers are shared too (docs/fmu-export.md): without its
    lock the runs fail ("singular mass matrix") or drift. The sound speeds differ, so an
    instance that used the other's intermediate values would be far off."""
    import threading

    _desc, fmu = _fmu(work, "duct")
    unzip = tmp_path / "fmu"
    extract(str(fmu), unzipdir=str(unzip))
    speeds, steps = (320.0, 366.0), 200
    alone = [_duct_run(fmu, unzip, cs, steps) for cs in speeds]
    assert np.abs(alone[0] - alone[1]).max() > 1e-3 * np.abs(alone[0]).max()
    start, done = threading.Barrier(2, timeout=300), threading.Barrier(2, timeout=300)
    got: dict[int, object] = {}

    def run(i: int) -> None:
        try:
            got[i] = _duct_run(fmu, unzip, speeds[i], steps, start, done)
        except Exception as exc:          # reported below; the other thread is released
            got[i] = exc
            start.abort()
            done.abort()

    threads = [threading.Thread(target=run, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for i in range(2):
        assert isinstance(got[i], np.ndarray), (speeds[i], got[i])
        scale = np.abs(alone[i]).max()
        assert np.abs(got[i] - alone[i]).max() <= 1e-9 * scale, speeds[i]
