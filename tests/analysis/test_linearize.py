"""Linearization against finite differences of ``rhs`` and against closed forms.

References: central differences of the module's ``rhs``/``outputs`` (independent of the
symbolic Jacobians that ``linearize`` uses); for the constrained pendulum the characteristic
equation m l² λ² + d l² λ + V''(phi) = 0 of the minimal (angle) model; for the double pendulum the
textbook matrices of two uniform rods about the hanging position.
"""

from __future__ import annotations

import numpy as np
import pytest
from _analysis_helpers import variant
from hypothesis import example, given, settings
from hypothesis import strategies as st

from neweul_py.analysis.equilibrium import equilibrium
from neweul_py.analysis.linearize import LinearModel, linearize
from neweul_py.analysis.modes import modes
from neweul_py.errors import ModelError, NeweulError


def _fd(fun, x0, h=1e-6):
    cols = []
    for j in range(x0.size):
        e = np.zeros_like(x0)
        e[j] = h * max(1.0, abs(x0[j]))
        cols.append((fun(x0 + e) - fun(x0 - e)) / (2 * e[j]))
    return np.array(cols).T


def test_first_order_against_finite_differences(cart_pendulum):
    """Away from equilibrium (ẏ0 ≠ 0, ÿ0 ≠ 0): the ∂M/∂y·ÿ0 term matters here."""
    p = cart_pendulum.default_parameters()
    y0, yd0, u0 = np.array([0.1, 0.7]), np.array([0.3, -1.2]), np.array([0.4])
    lin = linearize(cart_pendulum, y0, yd0, u0)
    a, b, c, d = lin.to_first_order()
    x0 = np.concatenate([y0, yd0])
    a_fd = _fd(lambda x: cart_pendulum.rhs(0.0, x, p, u0), x0)
    b_fd = _fd(lambda u: cart_pendulum.rhs(0.0, x0, p, u), u0)
    c_fd = _fd(lambda x: cart_pendulum.outputs(0.0, x, p, u0), x0)
    np.testing.assert_allclose(a, a_fd, rtol=1e-7, atol=1e-7 * np.abs(a).max())
    np.testing.assert_allclose(b, b_fd, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(c, c_fd, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(d, 0.0)
    # and exactly the module's analytic rhs_jacobian
    np.testing.assert_allclose(a, cart_pendulum.rhs_jacobian(0.0, x0, p, u0), rtol=1e-12,
                               atol=1e-12)


@settings(max_examples=25, deadline=None)
@given(
    st.lists(st.floats(-2.0, 2.0), min_size=5, max_size=5),
)
@example([0.0, 1.570854081244911, 0.0, 0.0, 1.0])      # φ ≈ π/2: a tiny entry of B
def test_random_states_against_finite_differences(cart_pendulum, values):
    """A = ∂rhs/∂x and B = ∂rhs/∂u at random (y, ẏ, u) against central differences of rhs."""
    p = cart_pendulum.default_parameters()
    y0, yd0, u0 = np.array(values[:2]), np.array(values[2:4]), np.array(values[4:])
    a, b, _, _ = linearize(cart_pendulum, y0, yd0, u0).to_first_order()
    x0 = np.concatenate([y0, yd0])
    a_fd = _fd(lambda x: cart_pendulum.rhs(0.0, x, p, u0), x0)
    b_fd = _fd(lambda u: cart_pendulum.rhs(0.0, x0, p, u), u0)
    scale = np.abs(a).max()
    np.testing.assert_allclose(a, a_fd, rtol=1e-6, atol=1e-7 * scale)
    # the differences' round-off is relative to B's scale, not to each entry: at φ ≈ π/2
    # one entry is 5.5e-5 and its central difference is off by 1.1e-9
    np.testing.assert_allclose(b, b_fd, rtol=1e-6, atol=1e-7 * np.abs(b).max())


def test_without_the_mass_derivative_term_fd_disagrees(cart_pendulum):
    """Guard: the ∂(M ÿ0)/∂y term is not negligible at this point."""
    lin = linearize(cart_pendulum, [0.1, 0.7], [0.3, -1.2], [0.4])
    ydd0 = np.linalg.solve(lin.M0, cart_pendulum.force_vector(0.0, lin.y0, lin.yd0, lin.p, lin.u0))
    term = cart_pendulum.mass_matrix_times_derivative(0.0, lin.y0, lin.p, ydd0)
    assert np.abs(term).max() > 1e-2 * np.abs(lin.Q).max()


def test_statespace_and_control_export(two_mass, tmp_path):
    lin = linearize(two_mass, [0.0, 0.0])
    ss = lin.to_statespace()
    np.testing.assert_allclose(ss.A, lin.to_first_order()[0])
    try:
        import control  # noqa: F401
    except ImportError:
        with pytest.raises(NeweulError, match="python-control is not installed"):
            lin.to_control()
    else:
        sys = lin.to_control()
        assert list(sys.input_labels) == ["F1", "F2"]
    lin.save(tmp_path / "lin.npz")
    back = LinearModel.load(tmp_path / "lin.npz")
    np.testing.assert_array_equal(back.Q, lin.Q)
    assert back.outputs == lin.outputs


def test_constrained_pendulum_on_the_manifold(cartesian_pendulum):
    """Minimal-coordinate linearization incl. the ∂(Gᵀλ)/∂y stiffness of the constraint."""
    eq = equilibrium(cartesian_pendulum)
    lin = linearize(cartesian_pendulum, eq)
    assert lin.coordinates == ("x",)
    m, l, g, k, a, b, d = eq.p
    phi = np.arctan2(k * a, m * g - k * b)
    v2 = m * g * l * np.cos(phi) + k * l * (a * np.sin(phi) - b * np.cos(phi))
    ref = np.roots([m * l * l, d * l * l, v2])
    lam = modes(lin).eigenvalues
    np.testing.assert_allclose(lam[0], ref[ref.imag > 0][0], rtol=1e-8)


def test_singular_mass_matrix_names_coordinate(two_mass):
    mod = variant(two_mass, mass_matrix=lambda t, y, p: np.diag([p[0], 0.0]))
    with pytest.raises(ModelError, match=r"no inertia in the motion of coordinate\(s\) x2$"):
        linearize(mod, [0.0, 0.0])


def test_inconsistent_operating_point(cartesian_pendulum):
    with pytest.raises(NeweulError, match="violates the constraints"):
        linearize(cartesian_pendulum, [0.1, -0.5])


def _double_pendulum():
    from pathlib import Path

    from neweul_py.analysis.module import load_generated

    return load_generated(Path(__file__).parents[2] / "generated" / "double_pendulum.py")


def test_double_pendulum_hanging_against_textbook():
    """Two uniform rods, relative second angle: M = Tᵀ M_abs T, Q = Tᵀ K_abs T with
    M_abs = [[(m1/3 + m2) l1², m2 l1 l2/2], [m2 l1 l2/2, m2 l2²/3]],
    K_abs = diag((m1/2 + m2) g l1, m2 g l2/2), T = [[1, 0], [1, 1]] (absolute = T · relative)."""
    mod = _double_pendulum()
    prm = dict(zip(mod.PARAMETERS, mod.default_parameters(), strict=True))
    m1, m2, l1, l2, g = (prm[k] for k in ("m1", "m2", "l1", "l2", "g"))
    eq = equilibrium(mod)  # from phi1 = 1.5 rad: the step limit keeps Newton in this revolution
    np.testing.assert_allclose(eq.y, 0.0, atol=1e-12)
    lin = linearize(mod, eq)
    m_abs = np.array(
        [[(m1 / 3 + m2) * l1**2, m2 * l1 * l2 / 2], [m2 * l1 * l2 / 2, m2 * l2**2 / 3]]
    )
    k_abs = np.diag([(m1 / 2 + m2) * g * l1, m2 * g * l2 / 2])
    t = np.array([[1.0, 0.0], [1.0, 1.0]])
    np.testing.assert_allclose(lin.M0, t.T @ m_abs @ t, rtol=1e-12)
    np.testing.assert_allclose(lin.Q, t.T @ k_abs @ t, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(lin.P, 0.0, atol=1e-12)
