"""Independent minimal-coordinate model of the slider–crank of ``fixtures/slider_crank.py``.

One coordinate, the crank angle phi. With the loop closed by hand,
sin theta = −r sin phi / l, rod center (r cos phi + (l/2) cos theta, r sin phi + (l/2) sin theta),
slider s = r cos phi + l cos theta, Lagrange's equation of T = ½ m(phi) ω² gives
m(phi) α + ½ m'(phi) ω² = Q(phi, ω) with
Q = −dV/dphi − cc ω − ds s'(phi)² ω + T and V = mc g (r/2) sin phi + mr g z_rod + ½ ks (s − s0)².
Derived here with sympy (tests may use it; the analysis layer never does).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import sympy as sp


@dataclass(frozen=True)
class MinimalSliderCrank:
    """Numeric functions of the minimal model."""

    acceleration: Callable  # (phi, omega, torque) -> alpha
    coordinates: Callable  # phi -> [phi, xr, zr, theta, s]
    slider: Callable  # (phi, omega, alpha) -> (s, s_dot, s_ddot)
    mass: Callable  # phi -> m(phi)
    generalized_force: Callable  # (phi, omega, torque) -> Q
    stiffness: Callable  # phi -> −∂Q/∂phi at ω = 0, torque = 0
    damping: Callable  # phi -> −∂Q/∂ω at ω = 0


def build(params: dict[str, float]) -> MinimalSliderCrank:
    """Derive the minimal model for the parameter values ``params`` (names of the fixture)."""
    phi, om, torque = sp.symbols("phi omega T")
    P = {k: sp.Float(v) for k, v in params.items()}
    r, l = P["r"], P["l"]
    theta = -sp.asin(r * sp.sin(phi) / l)
    xr = r * sp.cos(phi) + l / 2 * sp.cos(theta)
    zr = r * sp.sin(phi) + l / 2 * sp.sin(theta)
    s = r * sp.cos(phi) + l * sp.cos(theta)
    dth, dxr, dzr, ds_ = (sp.diff(e, phi) for e in (theta, xr, zr, s))
    mass = P["Jc"] + P["mr"] * (dxr**2 + dzr**2) + P["Ir"] * dth**2 + P["ms"] * ds_**2
    pot = P["mc"] * P["g"] * r / 2 * sp.sin(phi) + P["mr"] * P["g"] * zr
    pot += P["ks"] / 2 * (s - P["s0"]) ** 2
    q = -sp.diff(pot, phi) - P["cc"] * om - P["ds"] * ds_**2 * om + torque
    alpha = (q - sp.diff(mass, phi) / 2 * om**2) / mass
    a_sym = sp.Symbol("alpha")
    s_dd = sp.diff(s, phi, 2) * om**2 + ds_ * a_sym
    lam = lambda args, e: sp.lambdify(args, e, "numpy")  # noqa: E731
    return MinimalSliderCrank(
        acceleration=lam((phi, om, torque), alpha),
        coordinates=lam((phi,), [phi, xr, zr, theta, s]),
        slider=lam((phi, om, a_sym), [s, ds_ * om, s_dd]),
        mass=lam((phi,), mass),
        generalized_force=lam((phi, om, torque), q),
        stiffness=lam((phi,), (-sp.diff(q, phi)).subs({om: 0, torque: 0})),
        damping=lam((phi,), (-sp.diff(q, om)).subs({om: 0, torque: 0})),
    )


def trajectory(model: MinimalSliderCrank, phi0: float, omega0: float, t: np.ndarray) -> np.ndarray:
    """``[phi, omega]`` at the times ``t`` (DOP853, rtol 1e-12)."""
    from scipy.integrate import solve_ivp

    sol = solve_ivp(
        lambda _t, x: [x[1], model.acceleration(x[0], x[1], 0.0)],
        (t[0], t[-1]),
        [phi0, omega0],
        method="DOP853",
        t_eval=t,
        rtol=1e-12,
        atol=1e-12,
    )
    assert sol.success
    return sol.y.T
