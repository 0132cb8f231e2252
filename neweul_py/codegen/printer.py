"""Printing sympy expressions as Python source for generated modules.

The generated modules evaluate one state at a time, so scalar expressions are printed for
Python floats and the functions of :mod:`math` (``_math.sin``), which is several times faster
per call than NumPy ufuncs on scalars; arrays are assembled with NumPy. Every symbol must have
a name assigned by the caller: an unknown symbol is a :class:`~neweul_py.errors.GenerationError`
(it means the equations use something the module does not define).

Node types every printer of generated code must support
-------------------------------------------------------
Besides ``Symbol``, ``Integer``, ``Rational``, ``Float``, ``Add``, ``Mul``, ``Pow``, ``pi`` and the
functions ``sin cos tan asin acos atan atan2 sinh cosh tanh exp log`` (``sqrt`` is
``Pow(x, 1/2)``), the description language (:mod:`neweul_py.description.functions`) and its
derivatives (:mod:`neweul_py.model.functions`, :mod:`.derivatives`) produce exactly:

- ``sympy.Piecewise((v1, c1), …, (v_n, True))`` — the last condition is always ``True``;
  printed here as nested conditional expressions ``(v1 if c1 else … v_n)`` (the generated
  functions evaluate one state at a time, so scalar conditionals; a vectorized printer would
  use ``np.select``/``np.where``). Conditions never contain a ``Piecewise``.
- relationals ``StrictLessThan`` (``<``), ``LessThan`` (``<=``), ``StrictGreaterThan`` (``>``),
  ``GreaterThan`` (``>=``), joined by ``And``/``Or`` — only inside ``Piecewise`` conditions
  (sympy may also canonicalize a condition into ``Eq``/``Ne``/``Not``: print them too);
- ``Min``, ``Max`` (two or more arguments; classes of :mod:`neweul_py.model.functions` named
  like sympy's, so ``_print_Min``/``_print_Max`` apply): Python ``min``/``max``, C ``fmin``/``fmax``
  folded;
- ``Abs``: ``abs`` / C ``fabs``; ``sign``: ``0 at 0, else ±1`` (``copysign``);
- ``Heaviside(x, 1)`` (always with ``H0 = 1``: the language's ``step``/``heaviside``, 1 for
  ``x >= 0``, its derivatives' weights): ``(1.0 if x >= 0 else 0.0)``;
- ``TableCurve`` of :mod:`neweul_py.model.functions` (tabulated characteristics: a chain
  of comparisons, see its ``_pythoncode``) and its subclass ``SignalTable`` of
  :mod:`neweul_py.model.functions` (tabulated input signals of ``t``, up to 10 000 pieces: a
  balanced tree of comparisons); both expose ``pieces()`` and their knots ``args[1]``.

No ``DiracDelta`` reaches a printer from description files (sympy's own ``Heaviside``/``sign``
in models built in Python may produce one; :mod:`.derivatives` drops it in Jacobians).
"""

from __future__ import annotations

import builtins
import keyword
import re
from collections.abc import Iterable, Mapping

import sympy as sp
from sympy.printing.codeprinter import PrintMethodNotImplementedError
from sympy.printing.pycode import PythonCodePrinter

from ..errors import GenerationError
from ..model import as_expr

__all__ = ["FastPrinter", "NamePool", "ScalarPrinter", "join_sum"]

#: Names the generated code uses itself: the arguments and locals of its functions
#: (``codegen/writer.py``, ``codegen/constraints.py``), the protocol functions and constants,
#: module aliases and the embedded kernel's names. A model symbol with one of these names is
#: given another local name (``fy`` → ``fy_``), so that it can never overwrite one of them.
RESERVED: frozenset[str] = frozenset(
    {"t", "y", "yd", "ydd", "x", "xd", "p", "u", "a", "M", "f", "n", "fy", "fyd", "fu", "_fu",
     "dMa", "J", "C", "D", "G", "g", "gt", "gamma", "out", "energy", "sigma",
     "_math", "_np", "math", "np", "numpy", "base64", "zlib",
     "default_parameters", "default_inputs", "mass_matrix", "force_vector", "rhs",
     "force_jacobians", "mass_matrix_times_derivative", "rhs_jacobian", "outputs",
     "output_jacobians", "constraints", "constraint_jacobian", "constraint_time_derivative",
     "constraint_gamma", "constraint_reaction_jacobian", "schedule", "schedule_jacobians",
     "Sy", "Su",
     "PROTOCOL_VERSION", "MODEL_NAME", "DESCRIPTION", "COORDINATES", "COORDINATE_UNITS",
     "INITIAL_STATE", "PARAMETERS", "PARAMETER_RANGES", "INPUTS", "INPUT_RATES", "INPUT_UNITS",
     "OUTPUTS", "OUTPUT_UNITS", "CONSTRAINTS", "ENERGY", "STATE_SIZE", "SOURCE_HASH",
     "MASS_MATRIX_SYMMETRIC"}
    | set(dir(builtins))
)

_IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def join_sum(terms: Iterable[str]) -> str:
    """``a + b - c`` from printed terms: a term that starts with ``-`` is subtracted (shared
    by the Python and the C printer, so that both print a sum alike)."""
    out = []
    for i, s in enumerate(terms):
        if i == 0:
            out.append(s)
        elif s.startswith("-"):
            out.append(" - " + s[1:])
        else:
            out.append(" + " + s)
    return "".join(out)


class NamePool:
    """Hands out unique, valid Python identifiers for the symbols of a generated module.

    ``claim(symbol, wanted)`` gives ``wanted`` if it is a free identifier, else ``wanted_``,
    ``wanted__``, … — deterministic in the order of the calls.
    """

    def __init__(self, reserved: Iterable[str] = RESERVED) -> None:
        self._used: set[str] = set(reserved)
        self.names: dict[sp.Symbol, str] = {}

    def claim(self, sym: sp.Symbol, wanted: str | None = None) -> str:
        if sym in self.names:
            return self.names[sym]
        base = wanted if wanted is not None else sym.name
        if not _IDENT.fullmatch(base) or keyword.iskeyword(base) or base.startswith(
                ("_rigid_", "_ncg", "ffrf_", "_FFRF", "_P0", "_SV", "_SW", "_NS", "_PARTS",
                 "_ELASTIC", "_pack", "_mv", "_solve_packed", "_struct", "_dposv", "_dgesv")):
            base = "_s" + re.sub(r"[^A-Za-z0-9_]", "_", base)
        name = base
        while name in self._used or keyword.iskeyword(name):
            name += "_"
        self._used.add(name)
        self.names[sym] = name
        return name


class ScalarPrinter(PythonCodePrinter):
    """Python printer for scalar code: ``math`` as ``_math``, symbols by a fixed name table."""

    def __init__(self, names: Mapping[sp.Symbol, str]) -> None:
        super().__init__({"strict": True, "fully_qualified_modules": True, "order": "none"})
        self._names = names

    def _module_format(self, fqn: str, register: bool = True) -> str:
        out = super()._module_format(fqn, register)
        if out.startswith("math."):
            return "_math." + out[len("math."):]
        if out.startswith("numpy."):
            return "_np." + out[len("numpy."):]
        return out

    def _print_Symbol(self, expr: sp.Symbol) -> str:
        try:
            return self._names[expr]
        except KeyError:
            raise GenerationError(
                f"the equations use the symbol {expr.name!r}, which is neither a coordinate, "
                "velocity, parameter, input, t nor an intermediate quantity"
            ) from None

    _print_Dummy = _print_Symbol

    def _print_Heaviside(self, expr: sp.Heaviside) -> str:
        arg = self._print(expr.args[0])
        h0 = expr.args[1] if len(expr.args) > 1 else sp.S.Half
        if h0 == 1:  # the language's step (neweul_py.model.functions.Heaviside)
            return f"(1.0 if ({arg}) >= 0 else 0.0)"
        return f"(1.0 if ({arg}) > 0 else 0.0 if ({arg}) < 0 else {self._print(h0)})"

    def _print_Rational(self, expr: sp.Rational) -> str:
        if expr.q == 1:
            return str(expr.p)
        return f"({expr.p}/{expr.q})"

    def _print_Float(self, expr: sp.Float) -> str:
        return repr(float(expr))

    def doprint_expr(self, expr: sp.Basic) -> str:
        """Print one scalar expression or raise :class:`GenerationError`."""
        try:
            return self.doprint(expr)
        except PrintMethodNotImplementedError as exc:
            raise GenerationError(f"cannot generate code for {expr}: {exc}") from None


# ------------------------------------------------------------------------------ fast printer
_ADD, _MUL, _UNARY, _POW, _ATOM = 10, 20, 25, 30, 40
_ONE = sp.S.One

#: sympy function classes printed as ``_math.<name>(…)``.
_MATH_FUNCTIONS: dict[type, str] = {
    sp.sin: "sin", sp.cos: "cos", sp.tan: "tan", sp.asin: "asin", sp.acos: "acos",
    sp.atan: "atan", sp.sinh: "sinh", sp.cosh: "cosh", sp.tanh: "tanh", sp.exp: "exp",
    sp.atan2: "atan2",
}


class FastPrinter:
    """A direct printer for the arithmetic that dominates generated code.

    Prints Symbol, Integer, Rational, Float, Add, Mul, Pow and the functions of
    :data:`_MATH_FUNCTIONS` itself — an order of magnitude faster than sympy's printers on large
    programs — and hands everything else (``sign``, ``Heaviside``, ``Min``, ``pi`` …) to
    :class:`ScalarPrinter`. Arguments are printed in sympy's stored order (hash-independent);
    ``x**2`` of a name is printed ``x*x``.
    """

    def __init__(self, names: Mapping[sp.Symbol, str]) -> None:
        self._names = names
        self._fallback = ScalarPrinter(names)

    def doprint_expr(self, expr: sp.Basic) -> str:
        """Print one scalar expression or raise :class:`GenerationError`."""
        return self._p(as_expr(expr))[0]

    def _paren(self, expr: sp.Basic, min_prec: int) -> str:
        s, prec = self._p(expr)
        return s if prec >= min_prec else f"({s})"

    def _p(self, e: sp.Basic) -> tuple[str, int]:
        if e.is_Symbol:
            try:
                return self._names[e], _ATOM
            except KeyError:
                return self._fallback._print_Symbol(e), _ATOM  # raises GenerationError
        if e.is_Integer:
            v = int(e)
            return str(v), (_ATOM if v >= 0 else _UNARY)
        if e.is_Rational:
            return f"({e.p}/{e.q})", _ATOM
        if e.is_Float:
            v = float(e)
            if v != v or v in (float("inf"), float("-inf")):
                return f"float({str(v)!r})", _ATOM
            s = repr(v)
            return s, (_UNARY if s.startswith("-") else _ATOM)
        if e.is_Add:
            terms = []
            for arg in e.args:
                s, prec = self._p(arg)
                terms.append(s if prec >= _ADD else f"({s})")
            return join_sum(terms), _ADD
        if e.is_Mul:
            return self._mul(e)
        if e.is_Pow:
            return self._pow(e.base, e.exp)
        func = _MATH_FUNCTIONS.get(type(e))
        if func is not None:
            args = ", ".join(self._p(a)[0] for a in e.args)
            return f"_math.{func}({args})", _ATOM
        if isinstance(e, sp.Abs):
            return f"abs({self._p(e.args[0])[0]})", _ATOM
        return f"({self._fallback.doprint_expr(e)})", _ATOM

    def _mul(self, e: sp.Mul) -> tuple[str, int]:
        # the factors of ``coeff, rest = e.as_coeff_Mul()``, ``Mul.make_args(rest)``, without
        # building ``rest``
        args = e.args
        if args[0].is_Number:
            coeff, factors = args[0], args[1:]
            if len(factors) == 1 and factors[0].is_Mul:
                factors = factors[0].args
        else:
            coeff, factors = _ONE, args
        num: list[str] = []
        den: list[tuple[sp.Basic, sp.Basic]] = []
        for f in factors:
            if f.is_Pow and f.exp.is_Rational and f.exp.is_negative:
                den.append((f.base, -f.exp))
            else:
                s, prec = self._p(f)
                num.append(s if prec >= (_MUL + 1 if f.is_Mul else _MUL) else f"({s})")
        s = "*".join(num) if num else "1"
        if den:
            parts = [self._pow(b, x) for b, x in den]
            if len(parts) == 1 and parts[0][1] >= _POW:
                s += "/" + parts[0][0]
            else:
                s += "/(" + "*".join(p if pr > _ADD else f"({p})" for p, pr in parts) + ")"
        if coeff is _ONE or coeff == 1:
            return s, _MUL
        negative = coeff.is_negative
        c = -coeff if negative else coeff
        if c != 1:
            s = f"{self._paren(c, _ATOM)}*{s}"
        return ("-" + s if negative else s), _MUL

    def _pow(self, base: sp.Basic, exp: sp.Basic) -> tuple[str, int]:
        if exp is _ONE or exp == 1:
            return self._p(base)
        if exp == sp.S.Half:
            return f"_math.sqrt({self._p(base)[0]})", _ATOM
        if exp.is_Rational and exp.is_negative:
            inner, prec = self._pow(base, -exp)
            return ("1/" + (inner if prec >= _POW else f"({inner})")), _MUL
        if exp == 2 and base.is_Symbol:
            b = self._p(base)[0]
            return f"{b}*{b}", _MUL
        return f"{self._paren(base, _ATOM)}**{self._paren(exp, _ATOM)}", _POW
