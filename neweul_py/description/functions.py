"""The functions of the description language and the bounded evaluation of constants.

:data:`FUNCTIONS` maps every function name of the language to its sympy constructor. The
non-smooth ones (``min``, ``max``, ``abs``, ``sign``, ``heaviside``/``step``, ``piecewise``)
build the nodes of :mod:`neweul_py.model.functions`, whose derivatives are finite and
one-sided (never a ``DiracDelta``); the table of node types there is what every printer must
support.

Constant arguments (no symbols) of the smooth functions are evaluated numerically in 30-digit
arithmetic (:func:`constant_value`) and replaced by the exact rational of the nearest double —
bounded work, whatever sympy would try with the exact value (``acos(sin(10**20))`` is
``-10**20 + 63661977236758134309*pi/2`` for sympy, a number that cancels catastrophically in
double precision), and values outside the range of doubles (``exp(1000)``) are refused at parse
time instead of overflowing in the generated code.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from fractions import Fraction

import mpmath
import sympy as sp

from ..model.functions import Abs, Heaviside, Max, Min, piecewise, sign

__all__ = [
    "FLOAT_MAX",
    "FUNCTIONS",
    "ConstantError",
    "Function",
    "constant_power",
    "constant_value",
    "in_float_range",
]

#: The largest finite double; constants beyond it are refused.
FLOAT_MAX = 1.7976931348623157e308
#: The smallest positive normal double; non-zero constants below it are refused.
FLOAT_TINY = 2.2250738585072014e-308

_DIGITS = 30  # working precision of constant evaluation
_MAX_ROOT = 12  # largest root degree of an exact constant power (8**(1/3) stays exact)
_MAX_EXACT_BITS = 64  # largest numerator/denominator of a base raised exactly to a root
_MAX_POWER_BITS = 2**20  # bits of an exact integer power of a rational


class ConstantError(ValueError):
    """A constant value that is not finite, not real or outside the range of doubles."""


# ------------------------------------------------------------------------- constant values
def in_float_range(value: sp.Rational) -> bool:
    """Whether an exact rational is 0 or within the normal range of doubles (cheap: compares
    bit lengths first)."""
    p, q = abs(int(value.p)), int(value.q)
    if p == 0:
        return True
    # 2^(bits-1) < |value| < 2^(bits+1): certainly in [2^-1022, FLOAT_MAX] for these bits
    bits = p.bit_length() - q.bit_length()
    if -1021 <= bits <= 1022:
        return True
    if bits > 1026 or bits < -1024:
        return False
    magnitude = abs(Fraction(p, q))
    return FLOAT_TINY <= magnitude <= FLOAT_MAX


def _as_rational(value: mpmath.mpf) -> sp.Rational:
    """The exact rational of the double nearest to ``value`` (shortest decimal, like
    :func:`~neweul_py.description.expressions.number`); refuses values outside doubles."""
    if not mpmath.isfinite(value):
        raise ConstantError(f"the value {value} is not finite")
    if abs(value) > FLOAT_MAX:
        raise ConstantError("the value is too large: it exceeds the largest floating-point "
                            "number (1.8e308)")
    if value != 0 and abs(value) < FLOAT_TINY:
        raise ConstantError("the value is too small: closer to 0 than the smallest normal "
                            "floating-point number (2.2e-308)")
    frac = Fraction(repr(float(value)))
    return sp.Rational(frac.numerator, frac.denominator)


def _mp(expr: sp.Expr, digits: int = _DIGITS) -> mpmath.mpf:
    """A constant sympy expression as an mpmath number with ``digits`` digits."""
    try:
        value = expr.evalf(digits, maxn=4 * digits)
    except (ValueError, TypeError, ArithmeticError, AttributeError) as exc:
        raise ConstantError(f"cannot evaluate {expr}: {exc}") from None
    re, im = value.as_real_imag()
    if not (re.is_Float or re.is_zero) or not (im.is_zero or (im.is_Float and abs(im) < 1e-25)):
        if im.is_Float and im != 0:
            raise ConstantError(f"the value {value} is not real")
        raise ConstantError(f"the value {value} is not finite")
    return mpmath.mpf(0) if re.is_zero else mpmath.mpf(re._mpf_)


def constant_value(func: Callable[..., object], args: tuple[sp.Expr, ...]) -> sp.Rational:
    """``func(*args)`` of constant arguments, evaluated in 30-digit arithmetic.

    Raises
    ------
    ConstantError
        If the value is not real, not finite or outside the range of doubles.
    """
    coarse = _evaluate(func, args, _DIGITS)
    if coarse != 0 and abs(coarse) < 1e-20 * max([1, *(abs(v) for v in _values(args))]):
        # an exact zero computed inexactly (sin(pi)) shrinks with the working precision
        fine = _evaluate(func, args, 2 * _DIGITS)
        if abs(fine) < 1e-20 * abs(coarse):
            return sp.S.Zero
    return _as_rational(coarse)


def _values(args: tuple[sp.Expr, ...]) -> list[mpmath.mpf]:
    with mpmath.workdps(_DIGITS):
        return [_mp(a) for a in args]


def _evaluate(func: Callable[..., object], args: tuple[sp.Expr, ...], digits: int
              ) -> mpmath.mpf:
    """``func(*args)`` in ``digits``-digit arithmetic, real or :class:`ConstantError`."""
    with mpmath.workdps(digits):
        values = [_mp(a, digits) for a in args]
        try:
            result = func(*values)
        except (ValueError, ZeroDivisionError, OverflowError) as exc:
            raise ConstantError(f"invalid value: {exc}") from None
        if isinstance(result, mpmath.mpc):
            if abs(result.imag) > 1e-25 * max(1, abs(result.real)):
                raise ConstantError("the value is not real")
            result = result.real
        return result


def constant_power(base: sp.Expr, exponent: sp.Expr) -> sp.Expr:
    """``base**exponent`` of two constants with bounded work.

    Integer powers of rationals stay exact when the result is within the range of doubles;
    small roots (``2**0.5``, ``8**(1/3)``) of small rationals and integer powers of other
    constants (``pi**2``) stay exact; everything else (``351**-1e-10``, ``2**pi``) is evaluated
    in 30-digit arithmetic (:func:`constant_value`).

    Raises
    ------
    ConstantError
        For ``0`` to a negative power, non-real, non-finite or out-of-range values.
    """
    if base.is_zero:
        if exponent.is_negative:
            raise ConstantError("division by zero (0 to a negative power)")
        return sp.S.One if exponent.is_zero else sp.S.Zero
    if exponent.is_Integer:
        n = abs(int(exponent))
        if base.is_Rational and n <= 1000 and n * (base.p.bit_length() + base.q.bit_length()) \
                <= _MAX_POWER_BITS:
            result = base**exponent  # exact, at most _MAX_POWER_BITS bits of work
            if not in_float_range(result):
                raise ConstantError(f"the power {base}**{exponent} is too large or too small "
                                    "for a floating-point number")
            return result
        if base.is_Rational:
            return constant_value(mpmath.power, (base, exponent))
        if abs(int(exponent)) <= 16:
            return _checked_range(base**exponent)
    elif (exponent.is_Rational and exponent.q <= _MAX_ROOT and abs(exponent.p) <= 64
          and base.is_Rational and base.p.bit_length() <= _MAX_EXACT_BITS
          and base.q.bit_length() <= _MAX_EXACT_BITS):
        if base.is_negative:
            raise ConstantError(f"the value ({base})**({exponent}) is not real")
        return _checked_range(base**exponent)
    return constant_value(mpmath.power, (base, exponent))


def _checked_range(value: sp.Expr) -> sp.Expr:
    """``value`` if its magnitude is within doubles (numerically checked)."""
    with mpmath.workdps(_DIGITS):
        _as_rational(_mp(value))
    return value


# ------------------------------------------------------------------------------- the table
@dataclass(frozen=True)
class Function:
    """A function of the language: argument counts, sympy constructor and, for the smooth
    functions, the mpmath function that evaluates constant arguments."""

    min_args: int
    max_args: int | None  # None: any number >= min_args
    build: Callable[..., sp.Expr]
    numeric: Callable[..., object] | None = None
    #: odd argument positions 0, 2, … (but the last) are conditions (``piecewise``)
    conditions: bool = False

    def arity(self) -> str:
        if self.max_args == self.min_args:
            return f"{self.min_args} argument{'s' if self.min_args != 1 else ''}"
        if self.max_args is None:
            return f"at least {self.min_args} arguments"
        return f"{self.min_args} to {self.max_args} arguments"


_MAX_ARGS = 32  # of min, max and piecewise: their evaluation compares arguments pairwise

#: The functions of the language: name → argument counts, sympy constructor, numeric value.
FUNCTIONS: Mapping[str, Function] = {
    "sin": Function(1, 1, sp.sin, mpmath.sin),
    "cos": Function(1, 1, sp.cos, mpmath.cos),
    "tan": Function(1, 1, sp.tan, mpmath.tan),
    "asin": Function(1, 1, sp.asin, mpmath.asin),
    "acos": Function(1, 1, sp.acos, mpmath.acos),
    "atan": Function(1, 1, sp.atan, mpmath.atan),
    "atan2": Function(2, 2, sp.atan2, mpmath.atan2),
    "sinh": Function(1, 1, sp.sinh, mpmath.sinh),
    "cosh": Function(1, 1, sp.cosh, mpmath.cosh),
    "tanh": Function(1, 1, sp.tanh, mpmath.tanh),
    "exp": Function(1, 1, sp.exp, mpmath.exp),
    "log": Function(1, 1, sp.log, mpmath.log),
    "sqrt": Function(1, 1, sp.sqrt, mpmath.sqrt),
    "abs": Function(1, 1, Abs),
    "sign": Function(1, 1, sign),
    "min": Function(2, _MAX_ARGS, Min),
    "max": Function(2, _MAX_ARGS, Max),
    "heaviside": Function(1, 1, Heaviside),
    "step": Function(1, 1, Heaviside),
    "piecewise": Function(3, 2 * _MAX_ARGS + 1, piecewise, conditions=True),
}
