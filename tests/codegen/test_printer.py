"""The fast printer against high-precision evaluation of random expression trees."""

from __future__ import annotations

import math
import random

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
