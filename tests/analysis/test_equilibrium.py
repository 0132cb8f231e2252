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
        equilibrium(spring_pendulum, y0=[2.5], maxiter=1)
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
