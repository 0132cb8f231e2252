"""Non-smooth functions of model expressions with finite, one-sided derivatives.

The description language (:mod:`neweul_py.description.functions`) builds these nodes for
``min``, ``max``, ``abs``, ``sign``, ``heaviside``/``step`` and ``piecewise``; Python users may
build them too. They are sympy nodes *named like sympy's own* (``Min``, ``Max``, ``Abs``,
``sign``, ``Heaviside``, and sympy's ``Piecewise`` itself), so every printer prints them with its
``_print_Min`` … methods (sympy's printers skip a base-class print method for a function
subclass of another name). What changes is only the derivative, so that ``sympy.diff`` — in the
kinematics' time derivatives as in the equations' Jacobians — never produces a ``DiracDelta``:

=================  ===================  =================================================
language           node                 derivative
=================  ===================  =================================================
``min(a, b, …)``   :class:`Min`         ``Σ w_i a_i′``, ``w_i = 1`` for the first minimal
                                        argument, else 0 (products of steps)
``max(a, b, …)``   :class:`Max`         likewise for the first maximal argument
``abs(x)``         :class:`Abs`         ``x′·(2·step(x) − 1)``: ``+x′`` at ``x = 0``
``sign(x)``        :class:`sign`        ``0``
``heaviside(x)``,  :class:`Heaviside`   ``0``; always ``Heaviside(x, 1)``: 1 for ``x ≥ 0``
``step(x)``                             (right-continuous), 0 below
``piecewise(…)``   ``sympy.Piecewise``  the derivatives of the branches, same conditions
=================  ===================  =================================================

So the derivative at a corner is a one-sided value (of the branch that holds there), never a
distribution. :class:`TableCurve` is a piecewise polynomial of one argument (tabulated
characteristics of force elements and, as :class:`SignalTable`, input signals).

Conditions of a ``Piecewise`` are sympy relationals (``StrictLessThan``,
``LessThan``, ``StrictGreaterThan``, ``GreaterThan``) joined by ``And``/``Or``; they never contain
a ``Piecewise`` (the parser refuses that: sympy folds such conditions with a logic
simplification of exponential cost); the last condition is ``True``.
"""

from __future__ import annotations

import sympy as sp
from mpmath.libmp import prec_to_dps
from sympy.core.logic import fuzzy_and

from .symbols import as_expr

__all__ = ["Abs", "Heaviside", "Max", "Min", "Sign", "SignalTable", "Step", "TableCurve",
           "piecewise", "sign"]


# The subclasses keep the names of their sympy bases: sympy's printers skip the print method
# of a base class for a function subclass with another name (Printer._print).
class Heaviside(sp.Heaviside):
    """The unit step ``1 if x >= 0 else 0`` (``Heaviside(x, 1)``) with derivative zero."""

    def __new__(cls, arg: sp.Expr, H0: sp.Expr = sp.S.One, **options: object) -> sp.Expr:
        # sympy's Heaviside.__new__ calls super(cls, cls), which recurses for a subclass
        return super(sp.Heaviside, cls).__new__(cls, arg, sp.S.One, **options)

    def fdiff(self, argindex: int = 1) -> sp.Expr:
        return sp.S.Zero


class sign(sp.sign):
    """``sign(x)`` (0 at 0) with derivative zero."""

    def _eval_derivative(self, x: sp.Symbol) -> sp.Expr:
        return sp.S.Zero

    def fdiff(self, argindex: int = 1) -> sp.Expr:
        return sp.S.Zero


class Abs(sp.Abs):
    """``|x|`` of a real ``x`` with the one-sided derivative ``x′·(2·step(x) − 1)``."""

    def fdiff(self, argindex: int = 1) -> sp.Expr:
        return 2 * Heaviside(self.args[0]) - 1

    def _eval_derivative(self, x: sp.Symbol) -> sp.Expr:
        return self.args[0].diff(x) * self.fdiff(1)


def _first_extreme_weight(args: tuple[sp.Expr, ...], i: int, lower: bool) -> sp.Expr:
    """1 where ``args[i]`` is the first minimal (``lower``) or maximal argument, else 0.

    ``args[i]`` wins against an earlier ``args[j]`` only when strictly better and against a
    later one also on a tie, so exactly one weight is 1 at every point (also on a corner).
    """
    a = args[i]
    factors = []
    for j, b in enumerate(args):
        if j == i:
            continue
        ahead = (b - a) if lower else (a - b)  # >= 0: args[i] is at least as good as b
        factors.append(Heaviside(ahead) if j > i else 1 - Heaviside(-ahead))
    return sp.Mul(*factors)


def _pick(args: tuple[sp.Expr, ...], lower: bool) -> sp.Expr | None:
    """The first minimal (maximal) of constant arguments, or ``None`` if undecidable."""
    best = args[0]
    for arg in args[1:]:
        try:
            better = bool(arg < best) if lower else bool(arg > best)
        except TypeError:
            return None
        if better:
            best = arg
    return best


class _Extreme(sp.Function):
    """``min``/``max`` of real arguments, with the derivative of the first extreme argument.

    Own function classes (named ``Min``/``Max`` so that printers use their ``_print_Min`` /
    ``_print_Max``), not subclasses of sympy's: sympy's ``MinMaxBase`` compares classes with
    ``Min``/``Max`` itself and mixes them up for subclasses. Constant arguments are evaluated;
    nothing else is simplified.
    """

    _lower = True

    @classmethod
    def eval(cls, *args: sp.Expr) -> sp.Expr | None:
        if all(a.is_number for a in args):
            return _pick(args, cls._lower)
        return None

    def fdiff(self, argindex: int = 1) -> sp.Expr:
        return _first_extreme_weight(self.args, argindex - 1, lower=self._lower)

    def _eval_evalf(self, prec: int) -> sp.Expr | None:
        values = tuple(a.evalf(prec_to_dps(prec)) for a in self.args)
        if all(v.is_number for v in values):
            return _pick(values, self._lower)
        return None

    def _eval_is_extended_real(self) -> bool | None:
        return fuzzy_and(a.is_extended_real for a in self.args)

    def _eval_is_finite(self) -> bool | None:
        return fuzzy_and(a.is_finite for a in self.args)


class Min(_Extreme):
    """``min(a, b, …)`` whose derivative is that of the first minimal argument."""

    _lower = True


class Max(_Extreme):
    """``max(a, b, …)`` whose derivative is that of the first maximal argument."""

    _lower = False


#: Readable aliases: the language's ``step``/``heaviside`` and ``sign``.
Step = Heaviside
Sign = sign


def piecewise(*args: sp.Basic) -> sp.Expr:
    """``piecewise(c1, v1, c2, v2, …, default)`` → ``Piecewise((v1, c1), …, (default, True))``."""
    pairs = [(args[k + 1], args[k]) for k in range(0, len(args) - 1, 2)]
    return sp.Piecewise(*pairs, (args[-1], sp.true))




class TableCurve(sp.Expr):
    """A piecewise-polynomial characteristic curve ``F(v)`` of a table, as one sympy node.

    ``TableCurve(v, knots, shifts, coefficients)``: piece ``i`` is
    ``Σ_k coefficients[i][k] (v − shifts[i])^k``; piece ``i < m`` holds for ``v < knots[i]``
    (and not for the earlier ones), the last piece above the last knot. The node has the single
    argument ``v`` as far as differentiation and common-subexpression elimination see it, so
    derivatives (``F′(v) v′``, again a ``TableCurve``) and generated code grow linearly with
    the table. Generated code evaluates it as a chain of comparisons (``_pythoncode``).
    """

    is_commutative = True
    is_real = True

    def __new__(cls, v: object, knots: object, shifts: object, coefficients: object) -> TableCurve:
        return sp.Expr.__new__(cls, as_expr(v), sp.Tuple(*knots), sp.Tuple(*shifts),
                               sp.Tuple(*(sp.Tuple(*c) for c in coefficients)))

    @property
    def variable(self) -> sp.Expr:
        return self.args[0]

    def pieces(self) -> list[tuple[float, list[float]]]:
        """``(shift, coefficients)`` of every piece, in order."""
        return [(float(x0), [float(c) for c in cs]) for x0, cs in zip(self.args[2], self.args[3],
                                                                     strict=True)]

    def derivative(self) -> TableCurve:
        """``F′`` as a table curve of the same variable."""
        _, knots, shifts, coeffs = self.args
        d = [[k * c for k, c in enumerate(cs) if k > 0] or [sp.Float(0)] for cs in coeffs]
        return TableCurve(self.variable, knots, shifts, d)

    def _eval_derivative(self, x: sp.Symbol) -> sp.Expr:
        dv = self.variable.diff(x)
        return sp.S.Zero if dv == 0 else self.derivative() * dv

    def evaluate(self, value: float) -> float:
        """``F(value)`` numerically (tests, checks)."""
        knots = [float(k) for k in self.args[1]]
        i = next((j for j, k in enumerate(knots) if value < k), len(knots))
        shift, cs = self.pieces()[i]
        w = value - shift
        return sum(c * w**k for k, c in enumerate(cs))

    def _pythoncode(self, printer: object) -> str:
        """``(P0 if (_ncg_tab := v) < k1 else P1 if _ncg_tab < k2 else … else Pm)``."""
        v = printer._print(self.variable)  # type: ignore[attr-defined]
        name = "_ncg_tab"

        def poly(shift: float, cs: list[float]) -> str:
            w = f"({name} - {shift!r})" if shift != 0 else name
            out = repr(cs[-1])
            for c in cs[-2::-1]:
                out = f"{c!r} + {w}*({out})"
            return f"({out})"

        pieces = [poly(x0, cs) for x0, cs in self.pieces()]
        knots = [float(k) for k in self.args[1]]
        if not knots:
            return f"(({name} := {v}), {pieces[0]})[1]"
        chain = f"{pieces[0]} if ({name} := {v}) < {knots[0]!r}"
        for piece, knot in zip(pieces[1:], knots[1:], strict=False):
            chain += f" else {piece} if {name} < {knot!r}"
        return f"({chain} else {pieces[-1]})"

    _numpycode = _pythoncode


class SignalTable(TableCurve):
    """A tabulated signal ``u(t)`` (``inputs: {u: {table: file.csv}}``) as a :class:`TableCurve`.

    The same pieces as a characteristic curve (piece ``i`` holds below ``knots[i]``), but
    printed as a balanced tree of comparisons — depth ``log₂ n`` instead of a chain of ``n``
    conditional expressions, which Python could not even compile for a measured signal of a few
    thousand samples — and its derivatives are again signal tables.
    """

    def derivative(self) -> SignalTable:
        """``u′`` as a signal table of the same variable."""
        _, knots, shifts, coeffs = self.args
        d = [[k * c for k, c in enumerate(cs) if k > 0] or [sp.Float(0)] for cs in coeffs]
        return SignalTable(self.variable, knots, shifts, d)

    def _pythoncode(self, printer: object) -> str:
        """``(P_hi if _ncg_tab >= k_mid else P_lo)`` nested by bisection of the knots."""
        v = printer._print(self.variable)  # type: ignore[attr-defined]
        name = "_ncg_tab"
        knots = [float(k) for k in self.args[1]]
        pieces = []
        for shift, cs in self.pieces():
            w = f"({name} - {shift!r})" if shift != 0 else name
            out = repr(cs[-1])
            for c in cs[-2::-1]:
                out = f"{c!r} + {w}*({out})"
            pieces.append(f"({out})")

        def tree(lo: int, hi: int) -> str:  # pieces lo..hi; piece i holds for v >= knots[i-1]
            if lo == hi:
                return pieces[lo]
            mid = (lo + hi + 1) // 2
            return f"({tree(mid, hi)} if {name} >= {knots[mid - 1]!r} else {tree(lo, mid - 1)})"

        return f"(({name} := {v}), {tree(0, len(pieces) - 1)})[1]"

    _numpycode = _pythoncode
