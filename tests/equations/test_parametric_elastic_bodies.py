"""Parametric (scheduled) elastic bodies in the equations of motion (equations.md §2.3, §4).

References: the parametric body's own interpolation in the elastic layer
(``ParametricBody.at``, Panzer et al. 2010), entered as a plain reduced body — the scheduled
generated module must equal it at and between the samples — and the local reduced models at
the samples.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fe_builders import piston_duct_bodies, quintic_in_c_squared

from neweul_py.analysis import load_generated
from neweul_py.analysis.linearize import linearize
from neweul_py.api import generate
from neweul_py.elastic import save_reduced_body
from neweul_py.elastic.io.body_files import save_parametric_body
from neweul_py.elastic.parametric.local_interpolation import interpolate
from neweul_py.errors import DescriptionError

SPEEDS = (300.0, 343.0, 390.0)


def _description(data: str, schedule: str | None, c: float) -> str:
    sched = f", schedule: {schedule}" if schedule else ""
    return f"""
name: scheduled_duct
parameters: {{cs: {c!r}, m2: 0.02, k2: 1.0e5}}
coordinates: {{z: {{}}}}
inputs: {{F: 0}}
frames:
  carrier: {{translation: [z, 0, 0]}}
elastic_bodies:
  duct: {{frame: ISYS, data: {data}, nodes: {{piston: 1}}{sched}}}
bodies:
  mass: {{frame: carrier, mass: m2}}
forces:
  link:
    type: bushing
    between: [duct.piston, carrier]
    stiffness: {{diag: [k2, 0, 0]}}
  push: {{type: force, frame: carrier, vector: [F, 0, 0], in: ISYS}}
"""


@pytest.fixture(scope="module")
def parametric(tmp_path_factory) -> tuple[Path, object]:
    """Two-sided u–p piston ducts at three sound speeds, 8 modes each, interpolated."""
    tmp = tmp_path_factory.mktemp("param")
    pb = interpolate(piston_duct_bodies(tuple(SPEEDS), n_el=60, modes=8), list(SPEEDS),
                     parameter="c")
    save_parametric_body(pb, tmp / "duct.npz")
    return tmp, pb


def _frf(tmp: Path, text: str, name: str) -> np.ndarray:
    (tmp / name).write_text(text)
    mod = load_generated(generate(tmp / name, tmp / f"gen_{name}"))
    lin = linearize(mod)
    iz = list(mod.COORDINATES).index("z")
    w = 2 * np.pi * np.array([50.0, 200.0, 700.0, 1500.0])
    return np.array([np.linalg.solve(lin.Q - wi**2 * lin.M0 + 1j * wi * lin.P, lin.B[:, 0])[iz]
                     for wi in w])


@pytest.mark.parametrize("c", [343.0, 321.5, 370.0])
def test_scheduled_body_equals_the_interpolated_body(parametric, c: float) -> None:
    """The generated module with ``schedule: cs`` at ``cs = c`` gives the FRF of the same
    model built from ``ParametricBody.at(c)`` as a fixed body (at a sample: the local model)."""
    tmp, pb = parametric
    save_reduced_body(pb.at(c), tmp / f"at{c}.npz")
    ref = _frf(tmp, _description(f"at{c}.npz", None, c), f"fixed{c}.yaml")
    got = _frf(tmp, _description("duct.npz", "cs", c), f"sched{c}.yaml")
    assert np.allclose(got, ref, rtol=1e-9, atol=0)


@pytest.mark.parametrize("c", [321.5, 370.0])
def test_body_weighted_in_a_coordinate_equals_the_interpolated_body(parametric,
                                                                    c: float) -> None:
    """A body whose cubic weights are taken in ``ξ = c²`` (the interpolation coordinate,
    equations.md §4.1) gives, scheduled in the generated module, the FRF of
    ``ParametricBody.at(c)`` of that body (whose weights differ from the weights in ``c``)."""
    tmp, pb = parametric
    knots = np.linspace(SPEEDS[0], SPEEDS[-1], 31)
    knots = np.unique(np.concatenate([knots, SPEEDS]))
    xb = pb.with_(interpolation="cubic", coordinate=np.vstack([knots, knots**2]),
                  coordinate_name="c_squared")
    assert np.abs(xb.weights(c) - pb.weights(c, "cubic")).max() > 1e-4
    save_parametric_body(xb, tmp / "duct_xi.npz")
    save_reduced_body(xb.at(c), tmp / f"xi_at{c}.npz")
    ref = _frf(tmp, _description(f"xi_at{c}.npz", None, c), f"xi_fixed{c}.yaml")
    got = _frf(tmp, _description("duct_xi.npz", "cs", c), f"xi_sched{c}.yaml")
    assert np.allclose(got, ref, rtol=1e-9, atol=0)


def test_schedule_outside_the_samples_is_an_error(parametric) -> None:
    """No extrapolation: σ outside [300, 390] names the body, the value and the range."""
    tmp, _pb = parametric
    (tmp / "out.yaml").write_text(_description("duct.npz", "cs", 343.0))
    mod = load_generated(generate(tmp / "out.yaml", tmp / "gen_out"))
    p = mod.default_parameters()
    p[list(mod.PARAMETERS).index("cs")] = 500.0
    with pytest.raises(ValueError, match=r"'duct'.*500.*\[300.0, 390.0\]"):
        mod.rhs(0.0, np.array(mod.INITIAL_STATE), p)


def _fd(f, x, h):
    """Central differences of ``f`` at ``x`` (columns: the coordinates of ``x``)."""
    cols = []
    for j in range(x.size):
        e = np.zeros_like(x)
        e[j] = h * max(1.0, abs(x[j]))
        cols.append((f(x + e) - f(x - e)) / (2 * e[j]))
    return np.array(cols).T


def _fd_slopes(pb):
    """Sample slopes of ``pb``: first-order one-sided differences of its stacks at the ends,
    second-order central ones inside (``numpy.gradient``; any consistent slope data serve the
    check, and these are not those of the not-a-knot spline, a parabola for 3 samples)."""
    return {key: np.gradient(pb.stack(key), pb.samples, axis=0, edge_order=1)
            * (0.0 if key.endswith("residual") else 1.0) for key in pb.slope_keys()}


@pytest.fixture(scope="module")
def hermite(parametric) -> tuple[Path, object]:
    """The duct body with sample slopes and Hermite weights (equations.md §4.2)."""
    tmp, pb = parametric
    hb = pb.with_(interpolation="hermite", slopes=_fd_slopes(pb))
    save_parametric_body(hb, tmp / "duct_h.npz")
    return tmp, hb


@pytest.mark.parametrize("c", [321.5, 370.0])
@pytest.mark.parametrize("coordinate", [False, True])
def test_body_with_sample_slopes_equals_the_interpolated_body(hermite, c: float,
                                                              coordinate: bool) -> None:
    """A body with sample slopes and Hermite weights (in ``c``, or in ``ξ = c²``) gives,
    scheduled in the generated module, the FRF of ``ParametricBody.at(c)`` of that body; its
    weights are not the cubic ones (reference: ``ParametricBody.at``, the elastic layer's
    own interpolation, entered as a fixed body)."""
    tmp, hb = hermite
    name, other = "duct_h", hb.at(c, "cubic")
    if coordinate:
        other = hb.at(c)                            # Hermite weights in c itself
        knots = np.unique(np.concatenate([np.linspace(SPEEDS[0], SPEEDS[-1], 31), SPEEDS]))
        hb = hb.with_(coordinate=np.vstack([knots, knots**2]), coordinate_name="c_squared")
        name = "duct_hx"
        save_parametric_body(hb, tmp / f"{name}.npz")
    assert hb.weights(c).size == 2 * hb.n_samples
    assert np.abs(hb.at(c).K - other.K).max() > 1e-6 * np.abs(other.K).max()
    save_reduced_body(hb.at(c), tmp / f"{name}_at{c}.npz")
    ref = _frf(tmp, _description(f"{name}_at{c}.npz", None, c), f"{name}_fixed{c}.yaml")
    got = _frf(tmp, _description(f"{name}.npz", "cs", c), f"{name}_sched{c}.yaml")
    assert np.allclose(got, ref, rtol=1e-9, atol=0)


@pytest.fixture(scope="module")
def quintic(hermite) -> tuple[Path, object]:
    """The Hermite duct body with sample curvatures too (quintic Hermite weights in
    ``ξ = c²``, equations.md §4.2; any consistent curvature data serve the checks)."""
    tmp, hb = hermite
    qb = quintic_in_c_squared(hb)
    save_parametric_body(qb, tmp / "duct_q.npz")
    return tmp, qb


def test_body_with_sample_curvatures_equals_the_interpolated_body(hermite, quintic) -> None:
    """A body with sample slopes and curvatures (quintic Hermite weights, in ``ξ = c²``)
    gives, scheduled in the generated module, the FRF of ``ParametricBody.at(c)`` of that
    body, which is not that of its cubic Hermite weights (reference: ``ParametricBody.at``
    entered as a fixed body)."""
    tmp, qb = quintic
    c = 333.0
    assert qb.weights(c).size == 3 * qb.n_samples
    cubic = hermite[1].with_(coordinate=qb.coordinate, coordinate_name="c_squared")
    other = cubic.at(c)                            # the cubic Hermite weights in ξ too
    assert np.abs(qb.at(c).K - other.K).max() > 1e-9 * np.abs(other.K).max()
    save_reduced_body(qb.at(c), tmp / f"duct_q_at{c}.npz")
    ref = _frf(tmp, _description(f"duct_q_at{c}.npz", None, c), f"duct_q_fixed{c}.yaml")
    got = _frf(tmp, _description("duct_q.npz", "cs", c), f"duct_q_sched{c}.yaml")
    assert np.allclose(got, ref, rtol=1e-9, atol=0)


@pytest.mark.parametrize("frame", ["ISYS", "carrier"])
@pytest.mark.parametrize("data", ["duct.npz", "duct_h.npz", "duct_q.npz"])
def test_schedule_of_a_coordinate_and_an_input_enters_the_jacobians(parametric, hermite,
                                                                    quintic, frame: str,
                                                                    data: str) -> None:
    """``schedule: cs + 2000 z + 5 F`` (a coordinate of the symbolic part and an input), the
    body on a fixed and on a moving frame, with cubic, Hermite (sample slopes) or quintic
    Hermite weights (slopes and curvatures, in a coordinate):
    the analytic ``rhs_jacobian``, ``force_jacobians``
    (``∂/∂u`` included) and ``output_jacobians`` of the generated module — chain rule through
    the interpolation weights — equal central finite differences of its own ``rhs``,
    ``force_vector`` and ``outputs`` (reference: the difference quotients, error O(h²))."""
    tmp, _pb = parametric
    text = _description(data, "cs + 2000*z + 5*F", 343.0).replace(
        "duct: {frame: ISYS", f"duct: {{frame: {frame}") + """outputs:
  piston: {position: duct.piston, in: ISYS, component: x}
"""
    tag = f"{frame}{data[:-4]}"
    (tmp / f"yu{tag}.yaml").write_text(text)
    mod = load_generated(generate(tmp / f"yu{tag}.yaml", tmp / f"gen_yu{tag}"))
    p = mod.default_parameters()
    n = len(mod.COORDINATES)
    rng = np.random.default_rng(1)
    x = 1e-4 * rng.normal(size=2 * n)
    u = np.array([0.3])
    J = mod.rhs_jacobian(0.0, x, p, u)
    ref = _fd(lambda xx: mod.rhs(0.0, xx, p, u), x, 1e-6)
    assert np.abs(J - ref).max() <= 1e-9 * np.abs(ref).max()     # here 2e-14; frozen: 1e-4
    fy, _fyd, fu = mod.force_jacobians(0.0, x[:n], x[n:], p, u)
    ref_u = _fd(lambda uu: mod.force_vector(0.0, x[:n], x[n:], p, uu), u, 1e-4)
    assert np.abs(fu - ref_u).max() <= 1e-5 * np.abs(ref_u).max()
    ref_y = _fd(lambda yy: mod.force_vector(0.0, yy, x[n:], p, u), x[:n], 1e-6)
    assert np.abs(fy - ref_y).max() <= 1e-9 * np.abs(ref_y).max()
    C, D = mod.output_jacobians(0.0, x, p, u)
    ref_c = _fd(lambda xx: mod.outputs(0.0, xx, p, u), x, 1e-6)
    assert np.abs(C - ref_c).max() <= 1e-9 * np.abs(ref_c).max()   # frozen weights: 1e-8
    ref_d = _fd(lambda uu: mod.outputs(0.0, x, p, uu), u, 1e-3)   # D is 3e-11: a larger step
    assert np.abs(D - ref_d).max() <= 1e-5 * max(np.abs(ref_d).max(), 1e-300)
    # the schedule really moves the body: another z changes the mass matrix
    assert not np.allclose(mod.mass_matrix(0.0, x[:n], p, u),
                           mod.mass_matrix(0.0, x[:n] + 5e-3, p, u))


@pytest.mark.parametrize(("schedule", "words"), [
    ("cz", "cz"), ("duct_q1", "elastic or node coordinates"), (None, "schedule")])
def test_bad_schedules_name_the_key(parametric, schedule, words) -> None:
    """An unknown symbol, an elastic coordinate, or a parametric body without a schedule: one
    DescriptionError naming ``elastic_bodies.duct.schedule``."""
    tmp, _pb = parametric
    (tmp / "bad.yaml").write_text(_description("duct.npz", schedule, 343.0))
    with pytest.raises(DescriptionError) as info:
        generate(tmp / "bad.yaml", tmp / "gen_bad")
    assert "elastic_bodies.duct.schedule" in str(info.value)
    assert words in str(info.value)


def test_schedule_outside_the_samples_from_the_command_line_names_the_range(parametric,
                                                                          capsys) -> None:
    """``neweul frf … -p cs=500``: one error line naming the body, the value and the sampled
    range (it said "the mass matrix at the initial state is not finite"). Reference: the
    samples 300 and 390 of the fixture."""
    from neweul_py.cli import main

    tmp, _pb = parametric
    (tmp / "cli.yaml").write_text(_description("duct.npz", "cs", 343.0))
    code = main(["frf", str(tmp / "cli.yaml"), "--f", "100,200", "-p", "cs=500"])
    err = capsys.readouterr().err.strip()
    assert code == 1 and err.count("\n") == 0, err
    assert "'duct'" in err and "500" in err and "[300.0, 390.0]" in err, err


def _readme_scheduled_block() -> str:
    """The YAML block of a scheduled body (the one with ``schedule:``) of the how-to guide
    ``docs/howto/parametric-body.md``."""
    page = Path(__file__).resolve().parents[2] / "docs" / "howto" / "parametric-body.md"
    text = page.read_text(encoding="utf-8")
    blocks = [b.split("```", 1)[0] for b in text.split("```yaml\n")[1:]]
    found = [b for b in blocks if "schedule:" in b]
    assert len(found) == 1, "the guide holds one YAML block with a scheduled body"
    return found[0]


def test_scheduled_body_alone_without_inputs_or_coordinates(parametric) -> None:
    """The guide's block — a scheduled body on ISYS, no ``inputs:``, no rigid coordinates
    (``∂σ/∂y``, ``∂σ/∂u`` are empty; generate raised SymPy's "X must be a row or a column
    matrix") — generates a module whose mass matrix and ``rhs_jacobian`` at ``cs = 321.5``
    (between samples) are those of the model with ``ParametricBody.at(321.5)`` as a fixed
    body (reference: the elastic layer's interpolation)."""
    tmp, pb = parametric
    c = 321.5
    block = _readme_scheduled_block()
    assert "inputs" not in block and "coordinates" not in block
    save_reduced_body(pb.at(c), tmp / "alone_at.npz")
    mods = []
    for name, text in (("alone", block), ("alone_fixed", block.replace(
            "duct.npz", "alone_at.npz").replace(", schedule: cs", ""))):
        (tmp / f"{name}.yaml").write_text(text)
        mods.append(load_generated(generate(tmp / f"{name}.yaml", tmp / f"gen_{name}")))
    got, ref = mods
    assert not got.INPUTS and list(got.COORDINATES) == list(ref.COORDINATES)
    p = got.default_parameters()
    p[list(got.PARAMETERS).index("cs")] = c
    x = 1e-4 * np.random.default_rng(2).normal(size=len(got.INITIAL_STATE))
    n = len(got.COORDINATES)
    pr = ref.default_parameters()
    assert np.allclose(got.mass_matrix(0.0, x[:n], p), ref.mass_matrix(0.0, x[:n], pr),
                       rtol=1e-12, atol=0)
    assert np.allclose(got.rhs_jacobian(0.0, x, p), ref.rhs_jacobian(0.0, x, pr),
                       rtol=1e-9, atol=1e-12 * np.abs(ref.rhs_jacobian(0.0, x, pr)).max())


def test_schedule_of_a_coordinate_without_inputs_enters_the_jacobian(parametric) -> None:
    """``schedule: cs + 2000 z`` in a model with a rigid coordinate and no ``inputs:`` (an
    empty ``∂σ/∂u``): it generates, and the analytic ``rhs_jacobian`` equals central finite
    differences of its own ``rhs`` (reference: the difference quotients, error O(h²))."""
    tmp, _pb = parametric
    text = _description("duct.npz", "cs + 2000*z", 343.0).replace("inputs: {F: 0}\n", "")
    text = text.replace("  push: {type: force, frame: carrier, vector: [F, 0, 0], in: ISYS}\n",
                        "")
    (tmp / "no_inputs.yaml").write_text(text)
    mod = load_generated(generate(tmp / "no_inputs.yaml", tmp / "gen_no_inputs"))
    assert not mod.INPUTS and "z" in mod.COORDINATES
    p = mod.default_parameters()
    x = 1e-4 * np.random.default_rng(3).normal(size=len(mod.INITIAL_STATE))
    J = mod.rhs_jacobian(0.0, x, p)
    ref = _fd(lambda xx: mod.rhs(0.0, xx, p), x, 1e-6)
    assert np.abs(J - ref).max() <= 1e-9 * np.abs(ref).max()
    n = len(mod.COORDINATES)
    assert not np.allclose(mod.mass_matrix(0.0, x[:n], p),
                           mod.mass_matrix(0.0, x[:n] + 5e-3, p))


@pytest.mark.parametrize("c", [321.5, 370.0])
def test_parameter_derivatives_through_the_schedule(parametric, c: float) -> None:
    """A body scheduled by the parameter ``cs``: ``∂(q−k)/∂p``, ``∂(M a)/∂p``, ``∂rhs/∂p``
    (through ``∂σ/∂p`` and the mixed samples) equal central differences of the module's own
    functions between the samples (step 1e-4 of each parameter; at a sample the weights have a
    kink)."""
    tmp, _pb = parametric
    (tmp / "dp.yaml").write_text(_description("duct.npz", "cs", c))
    mod = load_generated(generate(tmp / "dp.yaml", tmp / "gen_dp"))
    rng = np.random.default_rng(2)
    n = len(mod.COORDINATES)
    p = mod.default_parameters()
    x = np.asarray(mod.INITIAL_STATE) + 0.1 * rng.normal(size=2 * n)
    y, yd, a, u = x[:n], x[n:], rng.normal(size=n), np.array([0.3])
    k = list(mod.PARAMETERS).index("cs")
    for got, f in ((mod.force_parameter_jacobian(0.0, y, yd, p, u),
                    lambda q: mod.force_vector(0.0, y, yd, q, u)),
                   (mod.mass_matrix_parameter_derivative(0.0, y, p, a, u),
                    lambda q: mod.mass_matrix(0.0, y, q, u) @ a),
                   (mod.rhs_parameter_jacobian(0.0, x, p, u), lambda q: mod.rhs(0.0, x, q, u))):
        ref = np.column_stack([(f(p + e) - f(p - e)) / (2 * e[j])
                               for j, e in enumerate(np.diag(1e-4 * p))])
        assert np.any(got[:, k])
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-6 * np.max(np.abs(ref)))


def test_an_output_row_that_changes_over_the_samples_is_refused(parametric) -> None:
    """A description's outputs have constant coefficients: an output of a parametric body
    whose row changes between samples (here ``p_end`` by 1 % at the second sample) is one
    DescriptionError naming the output and the change; an output whose row is the same at
    every sample (``x_piston``) is accepted from the same file (reference: the rows
    written)."""
    tmp, pb = parametric
    C = np.array(pb.C, copy=True)
    C[1, 0] *= 1.01
    save_parametric_body(pb.with_(C=C), tmp / "duct_c.npz")
    base = _description("duct_c.npz", "cs", 343.0)
    good = base.replace("{piston: 1}, schedule", "{piston: 1}, outputs: {x_piston: xp}, "
                        "schedule")
    (tmp / "good_c.yaml").write_text(good)
    assert "xp" in load_generated(generate(tmp / "good_c.yaml", tmp / "gen_good_c")).OUTPUTS
    (tmp / "bad_c.yaml").write_text(good.replace("{x_piston: xp}", "{p_end: pe}"))
    with pytest.raises(DescriptionError, match=r"output 'p_end' changes between sample 1 and "
                                                r"sample 2 by 0\.01 of its largest") as exc:
        generate(tmp / "bad_c.yaml", tmp / "gen_bad_c")
    assert "elastic_bodies.duct.outputs.p_end" in str(exc.value)
    C[1, 0] = pb.C[1, 0]                  # zero at the first sample, not at the second
    C[0, 1] = 0.0
    save_parametric_body(pb.with_(C=C), tmp / "duct_c.npz")
    with pytest.raises(DescriptionError, match=r"output 'x_piston' changes between sample 1 "
                                                r"and sample 2 from zero to coefficients"):
        generate(tmp / "good_c.yaml", tmp / "gen_zero_c")
