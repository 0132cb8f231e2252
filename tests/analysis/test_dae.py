"""Constrained simulation of the slider–crank in redundant coordinates.

Reference: an independent minimal-coordinate model (crank angle only, loop closed by hand,
Lagrange's equation derived with sympy in ``_slider_crank_reference.py``), integrated with DOP853
at rtol 1e-12. The constraint forces are checked against Newton's law of the slider computed from
the reference motion.
"""

from __future__ import annotations

import numpy as np
import pytest
from _analysis_helpers import variant
from _slider_crank_reference import build, trajectory

from neweul_py.analysis.dae import consistent_initial_state, simulate_constrained
from neweul_py.analysis.equilibrium import equilibrium
from neweul_py.analysis.frf import frequency_response
from neweul_py.analysis.linearize import linearize
from neweul_py.analysis.modes import modes
from neweul_py.errors import ModelError, NeweulError, SolverError


@pytest.fixture(scope="module")
def reference(slider_crank):
    return build(dict(slider_crank.PARAMETERS))


@pytest.fixture(scope="module")
def run(slider_crank):
    return simulate_constrained(slider_crank, 10.0, n_out=1001, independent=["phi"])


def test_consistent_initial_state_keeps_independent(slider_crank, reference):
    y, yd = consistent_initial_state(slider_crank, independent=["phi"])
    np.testing.assert_allclose(y, reference.coordinates(0.5), atol=1e-14)
    assert yd[0] == 8.0
    p = slider_crank.default_parameters()
    assert np.abs(slider_crank.constraints(0.0, y, p)).max() < 1e-14
    assert np.abs(slider_crank.constraint_jacobian(0.0, y, p) @ yd).max() < 1e-13


def test_default_initial_state_keeps_the_first_coordinates(slider_crank, reference):
    """Without ``independent`` the dependent coordinates are the last independent columns of G
    (xr, zr, theta, s): the crank keeps exactly the given phi = 0.5 and d_phi = 8.0, the others
    follow from the loop closed by hand (reference: minimal model, s' = ds/dphi)."""
    y, yd = consistent_initial_state(slider_crank)
    assert (y[0], yd[0]) == (0.5, 8.0)
    np.testing.assert_allclose(y, reference.coordinates(0.5), atol=1e-14)
    _, s_dot, _ = reference.slider(0.5, 8.0, 0.0)
    assert yd[4] == pytest.approx(float(s_dot), rel=1e-12)
    sim = simulate_constrained(slider_crank, 0.01, n_out=3)
    assert (sim.y[0, 0], sim.yd[0, 0]) == (0.5, 8.0)
    moved = simulate_constrained(slider_crank, 0.01, n_out=3, independent=["s"])
    assert (moved.y[0, 4], moved.yd[0, 4]) == (0.37, 0.0)  # s held: now the crank moves
    assert float(reference.slider(moved.y[0, 0], 0.0, 0.0)[0]) == pytest.approx(0.37, abs=1e-13)


def test_initial_state_falls_back_to_the_metric_projection(cartesian_pendulum):
    """x = 1.0 beyond the rod length l = 0.8 cannot be held (z² = l² − x² < 0): the partition
    fails and all coordinates move by the least change in M = m I, i.e. to the nearest point of
    the circle, l (x, z) / |(x, z)| (hand computation)."""
    y0 = np.array([1.0, -0.2])
    y, yd = consistent_initial_state(cartesian_pendulum, y0=y0, yd0=[0.0, 0.0])
    l = cartesian_pendulum.PARAMETERS["l"]
    np.testing.assert_allclose(y, l * y0 / np.linalg.norm(y0), atol=1e-14)
    np.testing.assert_allclose(yd, 0.0, atol=1e-15)


def test_trajectory_against_minimal_coordinates(run, reference):
    ref = trajectory(reference, 0.5, 8.0, run.t)
    full = np.array([reference.coordinates(phi) for phi in ref[:, 0]], dtype=float)
    assert np.abs(run.y - full).max() < 1e-7
    np.testing.assert_allclose(run.yd[:, 0], ref[:, 1], atol=1e-6)
    # the motion is not trivial: several crank swings through large angles
    assert np.ptp(run.y[:, 0]) > 1.0


def test_drift_below_1e_8_over_10_s(run):
    assert run.max_drift < 1e-8
    assert run.position_residual.max() < 1e-8
    assert run.velocity_residual.max() < 1e-8


def test_constraint_forces_against_newton_law_of_the_slider(run, reference, slider_crank):
    """Slider: ms s̈ = −ks (s − s0) − ds ṡ − λ_slide_x (G[slide_x, s] = −1)."""
    prm = dict(slider_crank.PARAMETERS)
    ref = trajectory(reference, 0.5, 8.0, run.t)
    alpha = np.array([reference.acceleration(ph, om, 0.0) for ph, om in ref])
    s, sd, sdd = (np.array(v, dtype=float) for v in reference.slider(ref[:, 0], ref[:, 1], alpha))
    lam_ref = -(prm["ms"] * sdd + prm["ks"] * (s - prm["s0"]) + prm["ds"] * sd)
    i = list(run.constraints).index("slide_x")
    scale = np.abs(lam_ref).max()
    assert np.abs(run.lambdas[:, i] - lam_ref).max() < 1e-6 * scale
    # λ are outputs of the result, saved with it
    assert "lambda_slide_x" in run.result.output_names


def test_results_file_has_lambda_columns(run, tmp_path):
    path = run.save(tmp_path / "sc.csv")
    header = path.read_text().splitlines()[0].split(",")
    assert header[:6] == ["t", "phi", "xr", "zr", "theta", "s"]
    assert header[-4:] == ["lambda_pin_x", "lambda_pin_z", "lambda_slide_x", "lambda_slide_z"]


def test_equilibrium_and_linearization_against_minimal_model(slider_crank, reference):
    """The stable equilibrium lies near phi = −1 (Q(phi, 0) changes sign from + to − there);
    from phi = 0.5 (Q < 0 on (0, π)) the search reaches it too (test_equilibrium.py)."""
    eq = equilibrium(slider_crank, y0=reference.coordinates(-1.0))
    assert equilibrium(slider_crank).y == pytest.approx(eq.y, abs=1e-10)
    phi = eq.y[0]
    assert -np.pi / 2 < phi < 0
    assert reference.generalized_force(phi, 0.0, 0.0) == pytest.approx(0.0, abs=1e-10)
    lin = linearize(slider_crank, eq)
    assert lin.coordinates == ("phi",)
    ref = np.roots([reference.mass(phi), reference.damping(phi), reference.stiffness(phi)])
    lam = modes(lin).eigenvalues
    np.testing.assert_allclose(lam[0], ref[ref.imag > 0][0], rtol=1e-7)


def test_frf_of_dependent_coordinate_against_minimal_model(slider_crank, reference):
    """s/T = s'(phi_e) / (m s² + c s + k) with m, c, k of the minimal model at equilibrium."""
    eq = equilibrium(slider_crank, y0=reference.coordinates(-1.0))
    phi = eq.y[0]
    f = np.logspace(-1, 2, 50)
    fr = frequency_response(slider_crank, f, "T", ["s", "d_s"], y0=eq)
    s = 2j * np.pi * f
    ds_dphi = float(reference.slider(phi, 1.0, 0.0)[1])
    h = ds_dphi / (reference.mass(phi) * s**2 + reference.damping(phi) * s
                   + reference.stiffness(phi))
    np.testing.assert_allclose(fr.H[:, 0, 0], h, rtol=1e-7)
    np.testing.assert_allclose(fr.H[:, 1, 0], s * h, rtol=1e-7)


def test_massless_dependent_motion_named(slider_crank):
    """Without any inertia the one motion the constraints allow has no mass: its coordinates
    are named (a massless rod alone would be fine, the constraints carry it)."""
    mod = variant(slider_crank, mass_matrix=lambda t, y, p: np.diag([0.0, 0.0, 0.0, 0.0, 0.0]))
    with pytest.raises(ModelError, match=r"no inertia in the motion of coordinate\(s\) phi, "):
        simulate_constrained(mod, 0.1)
    rod_massless = variant(
        slider_crank, mass_matrix=lambda t, y, p: np.diag([p[3], 0.0, 0.0, 0.0, p[6]])
    )
    assert simulate_constrained(rod_massless, 0.05, n_out=3).max_drift < 1e-8


def test_redundant_constraints_named(slider_crank):
    base_g, base_j = slider_crank.constraints, slider_crank.constraint_jacobian
    mod = variant(
        slider_crank,
        CONSTRAINTS=[*slider_crank.CONSTRAINTS, "rail_copy"],
        constraints=lambda t, y, p: np.append(base_g(t, y, p), 2 * base_g(t, y, p)[3]),
        constraint_jacobian=lambda t, y, p: np.vstack([base_j(t, y, p), 2 * base_j(t, y, p)[3]]),
    )
    with pytest.raises(NeweulError, match=r"redundant constraints at the initial state: "
                                          r"(rail_copy|slide_z) \(= combination of"):
        simulate_constrained(mod, 0.1)


def test_inconsistent_constraints_named(slider_crank):
    """A rail at z = 0.5 m that the rod (reach 0.4 m) cannot touch."""
    base_g = slider_crank.constraints
    mod = variant(
        slider_crank,
        constraints=lambda t, y, p: base_g(t, y, p) - np.array([0, 0, 0, 0.5]),
    )
    with pytest.raises(SolverError, match=r"cannot be satisfied.*slide_z"):
        consistent_initial_state(mod)


def test_rheonomic_constraint_moving_pivot(cartesian_pendulum):
    """Pendulum whose pivot moves as x_p(t) = A sin(Ω t): rod g = (x − x_p)² + z² − l².
    Reference: the minimal equation φ̈ = −(g/l) sin φ − (ẍ_p/l) cos φ (φ from the downward
    vertical), integrated at rtol 1e-12."""
    from scipy.integrate import solve_ivp

    amp, om = 0.05, 3.0
    xp = lambda t: amp * np.sin(om * t)  # noqa: E731
    vp = lambda t: amp * om * np.cos(om * t)  # noqa: E731
    ap = lambda t: -amp * om**2 * np.sin(om * t)  # noqa: E731
    mod = variant(
        cartesian_pendulum,
        constraints=lambda t, y, p: np.array([(y[0] - xp(t)) ** 2 + y[1] ** 2 - p[1] ** 2]),
        constraint_jacobian=lambda t, y, p: np.array([[2 * (y[0] - xp(t)), 2 * y[1]]]),
        constraint_gamma=lambda t, y, yd, p: np.array(
            [2 * (yd[0] - vp(t)) ** 2 - 2 * (y[0] - xp(t)) * ap(t) + 2 * yd[1] ** 2]
        ),
    )
    prm = {"k": 0.0, "d": 0.0}
    l, g = cartesian_pendulum.PARAMETERS["l"], cartesian_pendulum.PARAMETERS["g"]
    phi0 = 0.4
    y0 = [l * np.sin(phi0), -l * np.cos(phi0)]
    res = simulate_constrained(mod, 5.0, n_out=501, y0=y0, yd0=[0.0, 0.0], p=prm,
                               independent=["x"])
    # consistent start: ẋ = 0 is held (independent), ż follows from G ẏ = −∂g/∂t (a central
    # difference in t: the module has no constraint_time_derivative); φ̇ = ż / (l sin φ)
    phidot0 = res.yd[0, 1] / (l * np.sin(phi0))
    ref = solve_ivp(
        lambda t, s: [s[1], -(g / l) * np.sin(s[0]) - ap(t) / l * np.cos(s[0])],
        (0.0, 5.0), [phi0, phidot0], t_eval=res.t, rtol=1e-12, atol=1e-12, method="DOP853",
    ).y[0]
    phi = np.arctan2(res.y[:, 0] - xp(res.t), -res.y[:, 1])
    assert np.abs(phi - ref).max() < 1e-7
    assert res.max_drift < 1e-8
    assert res.velocity_residual.max() < 1e-8


@pytest.mark.parametrize(("model", "p", "who"), [("slider_crank", {"r": 0.0}, "phi"),
                                                 ("four_bar", {"a": 0.0}, "phi1")])
def test_zero_length_crank_is_named_not_a_linalg_error(model, p, who):
    """``neweul simulate examples/slider_crank.yaml -p r=0`` gave a raw LinAlgError: the
    crank of zero radius has no inertia and the constraints do not fix it, but its entry of
    ``Vᵀ M V`` (V the null space of G) was 2e-83 — not zero, so the rank test relative to
    that 1 × 1 matrix passed. The test is relative to the scale of M now. Reference: the
    mass matrix of a crank of zero radius (its inertia m r²/3 = 0)."""
    from pathlib import Path

    from neweul_py.analysis.module import load_generated
    from neweul_py.analysis.simulate import simulate

    module = load_generated(Path(__file__).resolve().parents[2] / "generated" / f"{model}.py")
    with pytest.raises(NeweulError, match=rf"no inertia in the motion of coordinate\(s\) {who}"):
        simulate(module, 0.1, p=p)


def test_singular_system_during_the_run_names_the_time(slider_crank):
    """The mass matrix vanishes at t = 0.05 (a test double of the fixture): one SolverError
    naming the time and what is singular, never numpy's LinAlgError — from the integrator's
    right-hand side and from the output times. Reference: the time the double switches."""
    base = slider_crank.mass_matrix
    mod = variant(slider_crank,
                  mass_matrix=lambda t, y, p: base(t, y, p) * (0.0 if t > 0.05 else 1.0))
    with pytest.raises(SolverError, match=r"singular at t = 0\.05\d*: .*no inertia in the "
                                          r"motion of coordinate\(s\) phi") as info:
        simulate_constrained(mod, 0.2, n_out=5)
    assert info.value.last_iterate is not None
    at_end = variant(slider_crank,
                     mass_matrix=lambda t, y, p: base(t, y, p) * (0.0 if t >= 0.1 else 1.0))
    with pytest.raises(SolverError, match=r"singular at t = 0\.1: .*no inertia"):
        simulate_constrained(at_end, 0.1, t_eval=[0.0, 0.05, 0.1])
