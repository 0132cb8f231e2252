"""Printing sympy expressions as C99 for the compiled backend (:mod:`.c_module`).

:class:`CPrinter` prints the arithmetic that dominates generated code (Symbol, numbers, Add,
Mul, Pow, the functions of ``math.h``) directly from sympy's tree — like
:class:`.printer.FastPrinter`, an order of magnitude faster than sympy's printers on large
programs — and hands everything else (``Piecewise`` with relationals, ``Min``/``Max``,
``sign``, ``Heaviside`` …) to :class:`CFallbackPrinter`, a subclass of sympy's
``C99CodePrinter`` that prints its sub-expressions back through :class:`CPrinter`. Numbers are
printed as ``double`` literals (``repr`` of the float: round-trip exact, no integer division);
integer powers become products, ``x**(1/2)`` becomes ``sqrt(x)``. The semantics follow the
NumPy module's printer (:mod:`.printer`): ``sign(0) = 0``, ``Heaviside(0) = 1/2`` unless given.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import sympy as sp
from sympy.printing.c import C99CodePrinter
from sympy.printing.codeprinter import PrintMethodNotImplementedError

from ..errors import GenerationError
from ..model import as_expr
from .printer import join_sum

__all__ = ["CFallbackPrinter", "CPrinter"]

_ADD, _MUL, _UNARY, _ATOM = 10, 20, 25, 40

#: sympy function classes printed as the ``math.h`` function of the same meaning.
_C_FUNCTIONS: dict[type, str] = {
    sp.sin: "sin", sp.cos: "cos", sp.tan: "tan", sp.asin: "asin", sp.acos: "acos",
    sp.atan: "atan", sp.sinh: "sinh", sp.cosh: "cosh", sp.tanh: "tanh", sp.exp: "exp",
    sp.atan2: "atan2", sp.log: "log", sp.Abs: "fabs", sp.floor: "floor",
    sp.ceiling: "ceil",
}

#: Largest integer exponent written out as a product (``x*x*x``) instead of ``pow``.
_MAX_PRODUCT = 4


def _double(v: float) -> str:
    if math.isnan(v):
        return "NAN"
    if math.isinf(v):
        return "INFINITY" if v > 0 else "(-INFINITY)"
    s = repr(float(v))
    return s


class CFallbackPrinter(C99CodePrinter):
    """sympy's C99 printer for the rare nodes, printing sub-expressions via :class:`CPrinter`."""

    def __init__(self, fast: CPrinter) -> None:
        super().__init__({"strict": True})
        self._fast = fast

    def _print_fast(self, expr: sp.Basic) -> str:
        s, prec = self._fast.p(expr)
        return s if prec >= _ATOM else f"({s})"

    _print_Symbol = _print_Add = _print_Mul = _print_Pow = _print_fast
    _print_Integer = _print_Rational = _print_Float = _print_Dummy = _print_fast
    _print_NumberSymbol = _print_Pi = _print_Exp1 = _print_fast

    def _print_sign(self, expr: sp.sign) -> str:
        a = self._print_fast(expr.args[0])
        return f"({a} == 0 ? 0.0 : copysign(1.0, {a}))"

    def _print_Heaviside(self, expr: sp.Heaviside) -> str:
        a = self._print_fast(expr.args[0])
        half = self._print_fast(expr.args[1]) if len(expr.args) > 1 else "0.5"
        return f"({a} > 0 ? 1.0 : ({a} < 0 ? 0.0 : {half}))"

    def _print_BooleanTrue(self, expr: sp.Basic) -> str:
        return "1"

    def _print_BooleanFalse(self, expr: sp.Basic) -> str:
        return "0"


class CPrinter:
    """Prints scalar sympy expressions as C99 ``double`` expressions.

    Parameters
    ----------
    names
        Symbol → C expression (``"y[3]"``, ``"w12"``, ``"t"``); an unknown symbol is a
        :class:`~neweul_py.errors.GenerationError`.
    """

    def __init__(self, names: Mapping[sp.Symbol, str]) -> None:
        self._names = names
        self._fallback = CFallbackPrinter(self)

    def doprint_expr(self, expr: sp.Basic) -> str:
        """Print one scalar expression or raise :class:`GenerationError`."""
        try:
            return self.p(as_expr(expr))[0]
        except PrintMethodNotImplementedError as exc:
            raise GenerationError(f"cannot generate C code for {expr}: {exc}") from None

    def _paren(self, expr: sp.Basic, min_prec: int) -> str:
        s, prec = self.p(expr)
        return s if prec >= min_prec else f"({s})"

    def p(self, e: sp.Basic) -> tuple[str, int]:
        """``(text, precedence)`` of ``e``."""
        if e.is_Symbol:
            try:
                return self._names[e], _ATOM
            except KeyError:
                raise GenerationError(
                    f"the equations use the symbol {e.name!r}, which is neither a coordinate, "
                    "velocity, parameter, input, t nor an intermediate quantity"
                ) from None
        if e.is_Number or e.is_NumberSymbol:
            if e.is_Rational and not e.is_Integer:
                return f"({_double(e.p)}/{_double(e.q)})", _ATOM
            s = _double(float(e))
            return s, (_UNARY if s.startswith(("-", "(")) else _ATOM)
        if e.is_Add:
            return join_sum([self._paren(arg, _ADD) for arg in e.args]), _ADD
        if e.is_Mul:
            return self._mul(e)
        if e.is_Pow:
            return self._pow(e.base, e.exp)
        func = _C_FUNCTIONS.get(type(e))
        if func is not None:
            args = ", ".join(self.p(a)[0] for a in e.args)
            return f"{func}({args})", _ATOM
        return f"({self._fallback.doprint(e)})", _ATOM

    def _mul(self, e: sp.Mul) -> tuple[str, int]:
        coeff, rest = e.as_coeff_Mul()
        num: list[str] = []
        den: list[tuple[sp.Basic, sp.Basic]] = []
        for f in sp.Mul.make_args(rest):
            if f.is_Pow and f.exp.is_Rational and f.exp.is_negative:
                den.append((f.base, -f.exp))
            else:
                t = self._paren(f, _MUL + 1 if f.is_Mul else _MUL)
                num.append(f"({t})" if t.startswith("-") else t)
        s = "*".join(num) if num else "1.0"
        if den:
            parts = [self._pow(b, x) for b, x in den]
            if len(parts) == 1 and parts[0][1] >= _ATOM:
                s += "/" + parts[0][0]
            else:
                s += "/(" + "*".join(p if pr > _ADD else f"({p})" for p, pr in parts) + ")"
        if coeff == 1:
            return s, _MUL
        negative = coeff.is_negative
        c = -coeff if negative else coeff
        if c != 1:
            s = f"{self._paren(c, _ATOM)}*{s}"
        if negative:
            s = "-" + (f"({s})" if s.startswith("-") else s)
        return s, _MUL

    def _pow(self, base: sp.Basic, exp: sp.Basic) -> tuple[str, int]:
        if exp == 1:
            return self.p(base)
        if exp == sp.S.Half:
            return f"sqrt({self.p(base)[0]})", _ATOM
        if exp.is_Rational and exp.is_negative:
            inner, prec = self._pow(base, -exp)
            return ("1.0/" + (inner if prec >= _ATOM else f"({inner})")), _MUL
        if exp.is_Integer and 2 <= int(exp) <= _MAX_PRODUCT:
            b = self._paren(base, _ATOM)
            return "*".join([b] * int(exp)), _MUL
        return f"pow({self.p(base)[0]}, {self.p(exp)[0]})", _ATOM
