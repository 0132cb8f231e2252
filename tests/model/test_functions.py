"""The non-smooth functions of model expressions: values against Python's own ``min``, ``max``,
``abs``, and derivatives against one-sided finite differences — finite everywhere, never a
``DiracDelta``, also after differentiating twice (kinematics takes ∂/∂t twice)."""

from __future__ import annotations

import itertools

import pytest
import sympy as sp

from neweul_py.equations.derivatives import gradient, jacobian
from neweul_py.model.functions import Abs, Heaviside, Max, Min, piecewise, sign

x, y, z = sp.symbols("x y z", real=True)

CASES = [
    (Min(x, y), min),
    (Max(x, y, z), max),
    (Min(x, 1 - x, y), min),
]


def _value(expr: sp.Expr, point: dict) -> float:
    return float(expr.subs(point))


@pytest.mark.parametrize("point", [(0.3, 0.7, -0.2), (0.5, 0.5, 0.5), (1.0, -1.0, 1.0)])
def test_min_max_values_and_first_extreme_derivative(point) -> None:
    """Reference: Python's ``min``/``max`` for the value; the derivative is that of the first
    extreme argument (at a tie: the first listed), i.e. a one-sided difference quotient."""
    subs = dict(zip((x, y, z), point, strict=True))
    for expr, py in CASES:
        args = [_value(a, subs) for a in expr.args]
        assert _value(expr, subs) == pytest.approx(py(args))
        winner = args.index(py(args))
        for s in (x, y, z):
            d = expr.diff(s)
            assert not d.has(sp.DiracDelta)
            assert _value(d, subs) == pytest.approx(_value(expr.args[winner].diff(s), subs))


def test_abs_sign_step_derivatives_are_one_sided_and_finite() -> None:
    """Reference: d|x|/dx = sign from the right at 0 (+1), step and sign have derivative 0,
    and second derivatives contain no DiracDelta."""
    for expr in (Abs(x), sign(x), Heaviside(x), Abs(sp.sin(x)) * Min(x, y)):
        for d in (expr.diff(x), expr.diff(x, 2)):
            assert not d.has(sp.DiracDelta)
    assert Abs(x).diff(x).subs(x, 0) == 1
    assert Abs(x).diff(x).subs(x, -2) == -1
    assert Heaviside(0) == 1 and Heaviside(-1e-300) == 0
    assert sign(0) == 0


def test_piecewise_time_derivatives_of_the_spin_up_ramp() -> None:
    """Reference: the closed-form rate and acceleration of the spin-up angle (one-sided at Ts:
    the branch ``t >= Ts`` holds there)."""
    t, omega, ts = sp.symbols("t Omega T_s", positive=True)
    ramp = omega / ts * (t**2 / 2 - (ts / (2 * sp.pi)) ** 2 * (1 - sp.cos(2 * sp.pi * t / ts)))
    angle = piecewise(t < ts, ramp, omega * (t - ts / 2))
    acc = angle.diff(t, 2)
    assert not acc.has(sp.DiracDelta)
    point = {omega: 6, ts: 15}
    assert acc.subs({**point, t: 15}) == 0
    assert float(acc.subs({**point, t: 7.5})) == pytest.approx(6 / 15 * 2)


def test_codegen_gradient_of_piecewise_is_branchwise() -> None:
    """Reference: ``sympy.diff`` of each branch under the same condition (the structural
    gradient of equations/derivatives.py), also through an intermediate."""
    expr = sp.Piecewise((x**2 * y, x < y), (sp.sin(x), True))
    g = gradient(expr, {x, y})
    for px, py in itertools.product((0.2, 0.9), (0.5,)):
        point = {x: px, y: py}
        for s in (x, y):
            ref = sp.Piecewise((sp.diff(x**2 * y, s), x < y), (sp.diff(sp.sin(x), s), True))
            assert float(g.get(s, sp.S.Zero).subs(point)) == pytest.approx(float(ref.subs(point)))
    w = sp.Symbol("w")
    assignments, jac = jacobian([sp.Piecewise((w, w < 1), (2 * w, True))], [x], [(w, x**2)])
    for px, expected in ((0.5, 1.0), (2.0, 8.0)):
        values = {x: px}
        for sym, e in assignments:
            values[sym] = float(e.subs(values))
        assert float(jac[0, 0].subs(values)) == pytest.approx(expected)
