"""Static equilibrium against closed forms.

Reference: for the pendulum with a zero-length spring k to the anchor (a, b) the potential is
V = −m g l cos phi − k l (a sin phi − b cos phi) + const, so the equilibrium satisfies
tan phi = k a / (m g − k b); in Cartesian coordinates with the rod as a constraint the same angle
holds and the multiplier is λ = −F·r / (2 l²) (radial balance F + Gᵀλ = 0, G = 2 rᵀ).
"""

from __future__ import annotations

import numpy as np
import pytest
from _analysis_helpers import variant

from neweul_py.analysis.equilibrium import equilibrium
from neweul_py.errors import NeweulError, SolverError


def _closed_form(p):
    m, _, g, k, a, b, _ = p
    return np.arctan2(k * a, m * g - k * b)


def test_spring_pendulum_closed_form_angle(spring_pendulum):
    eq = equilibrium(spring_pendulum)
    assert eq.y[0] == pytest.approx(_closed_form(spring_pendulum.default_parameters()), abs=1e-13)
    assert eq.residual < 1e-12


@pytest.mark.parametrize("k", [5.0, 15.0, 60.0])
def test_spring_pendulum_parameter_sweep(spring_pendulum, k):
    eq = equilibrium(spring_pendulum, p={"k": k})
    assert eq.y[0] == pytest.approx(_closed_form(eq.p), abs=1e-12)


def test_cartesian_pendulum_with_constraint(cartesian_pendulum):
    eq = equilibrium(cartesian_pendulum)
    p = eq.p
    m, l, g, k, a, b, _ = p
    phi = _closed_form(p)
    r = np.array([l * np.sin(phi), -l * np.cos(phi)])
    np.testing.assert_allclose(eq.y, r, atol=1e-12)
    f = np.array([-k * (r[0] - a), -k * (r[1] - b) - m * g])
    assert eq.lambda_[0] == pytest.approx(-f @ r / (2 * l * l), rel=1e-10)
    assert eq.as_dict()["lambda_rod"] == eq.lambda_[0]


def test_free_coordinate_is_named_and_can_be_fixed(cart_pendulum):
    """Without the cart spring the cart position has no stiffness."""
    with pytest.raises(SolverError, match=r"no stiffness in the motion of coordinate\(s\) x\b"):
        equilibrium(cart_pendulum, p={"c": 0.0}, u=[0.0])
    eq = equilibrium(cart_pendulum, p={"c": 0.0}, u=[0.0], fixed=["x"])
    assert eq.y[0] == 0.05  # held at its start value
    assert eq.y[1] == pytest.approx(0.0, abs=1e-14)


def test_non_convergence_reports_iterate_and_residual(spring_pendulum):
    with pytest.raises(SolverError, match="no convergence in 1 iterations; residual") as info:
        equilibrium(spring_pendulum, y0=[2.5], maxiter=1, max_continuation=0)
    err = info.value
    assert err.names == ["phi"]
    assert err.last_iterate.shape == (1,)
    assert err.residual > 0


def test_redundant_constraints_are_named(cartesian_pendulum):
    mod = variant(
        cartesian_pendulum,
        CONSTRAINTS=["rod", "rod_again"],
        constraints=lambda t, y, p: np.array([y[0] ** 2 + y[1] ** 2 - p[1] ** 2] * 2),
        constraint_jacobian=lambda t, y, p: np.array([[2 * y[0], 2 * y[1]]] * 2),
    )
    with pytest.raises(SolverError, match=r"redundant constraints: rod(_again)? \(= combination"):
        equilibrium(mod)


def test_unknown_names(spring_pendulum):
    with pytest.raises(NeweulError, match="unknown parameter 'kk'; valid parameters: m, l"):
        equilibrium(spring_pendulum, p={"kk": 1.0})
    with pytest.raises(NeweulError, match="unknown coordinate 'x'"):
        equilibrium(spring_pendulum, fixed=["x"])


# ----------------------------------------------------------- globalization (continuation)
def _slider_crank_potential(p):
    """Hand-written minimal slider–crank (crank angle φ; loop closed by hand, sin θ = −r sin φ/l):
    z_rod = (r/2) sin φ, s = r cos φ + √(l² − r² sin² φ),
    V(φ) = (mc + mr) g (r/2) sin φ + ½ ks (s − s0)² and its derivative dV/dφ."""
    r, l, mc, mr, ks, s0, g = (p[k] for k in ("r", "l", "mc", "mr", "ks", "s0", "g"))

    def slider(phi):
        return r * np.cos(phi) + np.sqrt(l**2 - (r * np.sin(phi)) ** 2)

    def potential(phi):
        return (mc + mr) * g * r / 2 * np.sin(phi) + ks / 2 * (slider(phi) - s0) ** 2

    def dpotential(phi):
        root = np.sqrt(l**2 - (r * np.sin(phi)) ** 2)
        ds = -r * np.sin(phi) - r**2 * np.sin(phi) * np.cos(phi) / root
        return (mc + mr) * g * r / 2 * np.cos(phi) + ks * (slider(phi) - s0) * ds

    return slider, potential, dpotential


def test_slider_crank_from_its_initial_state_settles_in_the_stable_equilibrium(slider_crank):
    """From the fixture's own initial state (phi = 0.5, where Newton's line search stalls) the
    continuation follows the damped motion downhill to the minimum of the potential V(phi) it
    falls into. Reference: walk V (written by hand above) downhill from 0.5 on a grid to bracket
    the minimum, then solve dV/dphi = 0 there by brentq; the other coordinates from the closed
    loop, the slider multiplier from its static balance −ks (s − s0) − λ_slide_x = 0."""
    from scipy.optimize import brentq

    prm = dict(slider_crank.PARAMETERS)
    slider, potential, dpotential = _slider_crank_potential(prm)
    phi0 = slider_crank.INITIAL_STATE[0]
    step = -0.01 if dpotential(phi0) > 0 else 0.01
    phi = phi0
    while potential(phi + step) < potential(phi):
        phi += step
    phi_ref = brentq(dpotential, min(phi - step, phi + step), max(phi - step, phi + step),
                     xtol=1e-15)
    assert -np.pi / 2 < phi_ref < -1.0  # the equilibrium of the issue: phi ≈ −1.0855

    with pytest.raises(SolverError, match="line search stalled"):  # Newton alone fails here
        equilibrium(slider_crank, max_continuation=0)
    eq = equilibrium(slider_crank)
    assert eq.y[0] == pytest.approx(phi_ref, abs=1e-10)
    r, l = prm["r"], prm["l"]
    theta = -np.arcsin(r * np.sin(phi_ref) / l)
    closed = [phi_ref, r * np.cos(phi_ref) + l / 2 * np.cos(theta),
              r * np.sin(phi_ref) + l / 2 * np.sin(theta), theta, slider(phi_ref)]
    np.testing.assert_allclose(eq.y, closed, atol=1e-10)
    lam = eq.as_dict()["lambda_slide_x"]
    assert lam == pytest.approx(-prm["ks"] * (slider(phi_ref) - prm["s0"]), rel=1e-9)
    assert eq.residual < 1e-12


def test_constant_force_on_a_free_cart_reports_non_convergence(cart_pendulum):
    """No equilibrium exists: without the cart spring (c = 0) a constant force F = 1 N pushes the
    cart for ever. The error reports non-convergence, the residual — exactly F, the unbalanced
    static force in the cart equation (hand computation) — and the last iterate."""
    with pytest.raises(SolverError, match=r"no convergence: .* pseudo-transient continuation "
                                          r".*; residual 1 \(largest in the equation of x\); "
                                          r"last iterate x=") as info:
        equilibrium(cart_pendulum, p={"c": 0.0}, u=[1.0])
    err = info.value
    assert err.residual == pytest.approx(1.0, rel=1e-12)
    assert err.names == ["x", "phi"]
    assert err.last_iterate.shape == (2,)
    assert err.last_iterate[0] > 10.0  # the cart ran away in the direction of the force


def test_torque_beyond_the_static_capacity_reports_non_convergence(spring_pendulum):
    """A torque T above the largest static restoring torque of gravity and spring,
    l √((k a)² + (k b − m g)²) (amplitude of k l (a cos φ + b sin φ) − m g l sin φ), has no
    equilibrium; the residual is at least T minus that amplitude."""
    m, l, g, k, a, b, _ = spring_pendulum.default_parameters()
    capacity = l * np.hypot(k * a, k * b - m * g)
    torque = 5 * capacity
    pattern = r"no convergence.*; residual .*; last iterate phi="
    with pytest.raises(SolverError, match=pattern) as info:
        equilibrium(spring_pendulum, u=[torque])
    assert info.value.residual >= torque - capacity
    eq = equilibrium(spring_pendulum, u=[0.5 * capacity])  # below the capacity: one exists
    phi = eq.y[0]
    assert k * l * (a * np.cos(phi) + b * np.sin(phi)) - m * g * l * np.sin(phi) == pytest.approx(
        -0.5 * capacity, abs=1e-10)


def test_equilibrium_files(spring_pendulum, tmp_path):
    """CSV and NPZ hold the closed-form angle; other suffixes are refused."""
    eq = equilibrium(spring_pendulum)
    ref = _closed_form(spring_pendulum.default_parameters())
    text = eq.save(tmp_path / "a" / "eq.csv").read_text().splitlines()
    assert text[0] == "name,value"
    assert float(text[1].split(",")[1]) == pytest.approx(ref, abs=1e-13)
    with np.load(eq.save(tmp_path / "eq.npz")) as f:
        assert f["y"][0] == pytest.approx(ref, abs=1e-13)
        assert list(f["coordinates"]) == ["phi"]
    with pytest.raises(NeweulError, match=r"eq.txt: equilibria are written as .csv or .npz"):
        eq.save(tmp_path / "eq.txt")
