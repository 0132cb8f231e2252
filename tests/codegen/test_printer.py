"""The fast printer against high-precision evaluation of random expression trees."""

from __future__ import annotations

import math
import random

import numpy as np
import pytest
import sympy as sp

from neweul_py.codegen.printer import FastPrinter
from neweul_py.errors import GenerationError

XS = sp.symbols("x0:4", real=True)


def _random_expr(rng: random.Random, depth: int) -> sp.Expr:
    if depth == 0 or rng.random() < 0.2:
        return rng.choice([
            *XS,
            sp.Integer(rng.randint(-3, 3)),
            sp.Rational(rng.randint(-5, 5), rng.randint(1, 4)),
            sp.Float(rng.uniform(-2, 2)),
        ])
    k = rng.random()
    if k < 0.3:
        return sp.Add(*[_random_expr(rng, depth - 1) for _ in range(rng.randint(2, 4))])
    if k < 0.6:
        return sp.Mul(*[_random_expr(rng, depth - 1) for _ in range(rng.randint(2, 4))])
    if k < 0.8:
        exps = [2, 3, -1, -2, sp.Rational(1, 2), sp.Rational(-1, 2), sp.Rational(3, 2)]
        return sp.Pow(_random_expr(rng, depth - 1), rng.choice(exps))
    return rng.choice([sp.sin, sp.cos, sp.atan, sp.sign, sp.Abs])(_random_expr(rng, depth - 1))


def test_fast_printer_evaluates_like_sympy():
    """Printed code evaluated with floats equals 40-digit evaluation of the expression."""
    printer = FastPrinter({s: s.name for s in XS})
    rng = random.Random(5)
    checked = 0
    for _ in range(700):
        e = _random_expr(rng, 4)
        if e.has(sp.I, sp.zoo, sp.nan, sp.oo):
            continue
        code = printer.doprint_expr(e)
        vals = {s.name: rng.uniform(0.5, 2) for s in XS}
        ref = complex(e.xreplace({s: sp.Float(vals[s.name], 40) for s in XS}).evalf(40))
        if abs(ref.imag) > 1e-12 or not math.isfinite(ref.real) or abs(ref.real) > 1e6:
            continue
        try:
            got = eval(code, {"_math": math, **vals})  # our own printed code
        except (ZeroDivisionError, OverflowError, ValueError, TypeError):
            continue
        assert not isinstance(got, complex), code
        assert got == pytest.approx(ref.real, rel=1e-8, abs=1e-8), (e, code)
        checked += 1
    assert checked > 400


def test_unknown_symbol_is_a_generation_error():
    with pytest.raises(GenerationError, match="'z'"):
        FastPrinter({}).doprint_expr(sp.Symbol("z") + 1)


@pytest.mark.parametrize(
    ("expr", "code"),
    [
        (XS[0] ** 2, "x0*x0"),
        (-XS[0] + XS[1], "x1 - x0"),
        (XS[0] / XS[1] ** 2, "x0/(x1*x1)"),
        (sp.sqrt(XS[0]), "_math.sqrt(x0)"),
        (sp.Rational(1, 2) * XS[0], "(1/2)*x0"),
    ],
)
def test_fast_printer_forms(expr, code):
    assert FastPrinter({s: s.name for s in XS}).doprint_expr(expr) == code


# ------------------------------------------------------------------ piecewise, min, max, abs
SPIN_UP = """\
name: spin_up
description: a bead on a hub whose angle is prescribed, a smooth ramp to constant speed
parameters: {Omega: 6.0, Ts: 15.0, m: 2.0}
coordinates: {x: 1.0, y: 0.0}
frames:
  hub:
    rotation: [[z, "piecewise(t < Ts, Omega/Ts*(t**2/2 - (Ts/(2*pi))**2*(1-cos(2*pi*t/Ts))),
                          Omega*(t - Ts/2))"]]
  bead_frame: {parent: hub, translation: [x, y, 0]}
bodies:
  bead: {frame: bead_frame, mass: m}
forces:
  stop: {type: generalized, coordinate: x,
         value: "-400*(x - 1) - 100*min(max(x - 2, 0), 1) - 0.5*abs(d_x)*d_x - 10*step(-y)*y"}
  hold: {type: generalized, coordinate: y, value: "-400*y - d_y"}
outputs:
  angle: "piecewise(t < Ts, Omega/Ts*(t**2/2 - (Ts/(2*pi))**2*(1-cos(2*pi*t/Ts))),
                    Omega*(t - Ts/2))"
"""


def _hub(t: float, omega: float = 6.0, ts: float = 15.0) -> tuple[float, float, float]:
    """Closed form of the spin-up angle, rate and acceleration (ramp, then constant speed)."""
    if t < ts:
        w = 2 * math.pi / ts
        angle = omega / ts * (t**2 / 2 - (1 - math.cos(w * t)) / w**2)
        return angle, omega / ts * (t - math.sin(w * t) / w), omega / ts * (1 - math.cos(w * t))
    return omega * (t - ts / 2), omega, 0.0


@pytest.fixture(scope="module")
def spin_up(tmp_path_factory):
    from neweul_py.analysis.module import load_generated
    from neweul_py.api import generate

    directory = tmp_path_factory.mktemp("spin_up")
    path = directory / "spin_up.yaml"
    path.write_text(SPIN_UP)
    return load_generated(generate(path, directory))


@pytest.mark.parametrize("t", [0.0, 0.3, 7.5, 14.9, 15.0, 15.0 + 1e-9, 40.0])
def test_spin_up_hub_matches_the_closed_form(spin_up, t: float) -> None:
    """Reference: the closed-form hub angle θ, rate θ' and acceleration θ'' of the spin-up ramp.
    A bead at rest at hub position (1, 0) of mass m (where its springs are relaxed) feels the
    generalized forces
    ``f = [m θ'², −m θ'']`` (centrifugal and Euler force in the rotating frame), and the output
    is θ itself — across the corner at t = Ts, where θ'' jumps from 0⁺ (ramp end) to 0."""
    m = spin_up
    p = m.default_parameters()
    angle, rate, accel = _hub(t)
    f = m.force_vector(t, np.array([1.0, 0.0]), np.zeros(2), p)
    out = m.outputs(t, np.array([1.0, 0.0, 0.0, 0.0]), p)
    assert out[0] == pytest.approx(angle, rel=1e-12, abs=1e-12)
    assert f[0] == pytest.approx(2.0 * rate**2, rel=1e-12, abs=1e-12)
    assert f[1] == pytest.approx(-2.0 * accel, rel=1e-12, abs=1e-12)


def test_spin_up_corners_have_finite_one_sided_jacobians(spin_up) -> None:
    """Reference: the one-sided derivatives of the force law by hand — d/dx of
    ``-100*min(max(x-2, 0), 1)`` is −100 on (2, 3) and 0 outside; on a tie the first argument
    of min/max counts (so −100 at both corners x = 2 and x = 3, the derivative from inside);
    the step in ``-10*step(-y)*y`` gives −10 at y = 0 (step(0) = 1). Every entry is finite."""
    m = spin_up
    p = m.default_parameters()
    for x, expected in [(2.5, -100.0), (1.0, 0.0), (3.5, 0.0), (2.0, -100.0), (3.0, -100.0)]:
        jac = m.rhs_jacobian(20.0, np.array([x, 0.0, 0.0, 0.0]), p)
        assert np.all(np.isfinite(jac))
        # ẍ row: ∂f_x/∂x / m, f_x = m θ'² x − 400 (x − 1) + stop(x) with θ' = 6 at t = 20
        assert jac[2, 0] * 2.0 - 2.0 * 6.0**2 + 400 == pytest.approx(expected, abs=1e-9), x
    jac = m.rhs_jacobian(20.0, np.array([1.0, 0.0, 0.0, 0.0]), p)
    assert jac[2, 1] * 2.0 == pytest.approx(-10.0, abs=1e-9)


def test_spin_up_simulates_from_yaml(spin_up) -> None:
    """Reference: θ(t) of the closed form, reported as the output while the bead is integrated
    through the corner at t = Ts (no corner-induced failure of the integrator)."""
    from neweul_py.analysis.simulate import simulate

    res = simulate(spin_up, 20.0, n_out=81, rtol=1e-8, atol=1e-10)
    expected = np.array([_hub(t)[0] for t in res.t])
    assert np.allclose(res.column("angle"), expected, rtol=1e-10, atol=1e-10)
    assert np.all(np.isfinite(res.table))


@pytest.mark.parametrize(
    ("expr", "point"),
    [
        (sp.Piecewise((XS[0] ** 2, XS[0] < XS[1]), (sp.sin(XS[1]), True)), (0.3, 0.7, 0, 0)),
        (sp.Piecewise((XS[0], (XS[0] > 0) & (XS[1] <= 1) | (XS[2] >= 2)), (-1, True)),
         (0.5, 2.0, 2.0, 0)),
    ],
)
def test_fast_printer_prints_piecewise_conditions(expr, point) -> None:
    """Reference: sympy's own evaluation of the Piecewise at the point."""
    printer = FastPrinter({s: s.name for s in XS})
    code = printer.doprint_expr(expr)
    values = dict(zip((s.name for s in XS), point, strict=True))
    ref = float(expr.subs(dict(zip(XS, point, strict=True))))
    assert eval(code, {"_math": math}, values) == pytest.approx(ref)  # our own printed code
