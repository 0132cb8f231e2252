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
import re
from collections.abc import Mapping

import numpy as np
import sympy as sp
from sympy.printing.c import C99CodePrinter
from sympy.printing.codeprinter import PrintMethodNotImplementedError

from ..errors import GenerationError
from ..model import as_expr
from .c_templates import C_CLONES
from .printer import join_sum

__all__ = ["CFallbackPrinter", "CPrinter", "DotRows"]

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


#: A C array element of the state-sized arrays ``y``, ``yd``, ``a`` (``"yd[3]"``).
_ELEMENT = re.compile(r"(y|yd|a)\[(\d+)\]")


class DotRows:
    """The constant coefficient rows of the long linear combinations of a C file.

    A sum with at least :attr:`least` terms ``c_i · v[i] · r`` (``c_i`` numbers, ``v`` one of
    the state-sized arrays ``y``, ``ẏ``, ``a`` of length ``n``, the same factor ``r``) prints as
    ``r*nw_dot(NW_T + k, v)`` (``k``: the row's offset, :meth:`offset`) instead of as many
    multiplications by literals. Long linear combinations of coordinates (the closed forms of
    spring chains, for one) are such sums; as straight-line code they are tens of kB of
    instructions that are fetched anew at every call from Python.

    :meth:`batch` then turns the rows one function uses into one matrix–vector product per
    array at its top — a column-major table over the columns in use, read by the loop
    ``nw_rows`` (:meth:`helper`) that the compiler vectorizes — and each ``nw_dot(…)`` into an
    element of its result (no call per row, no horizontal sums, the zero columns of the
    rigid coordinates skipped): a 20-mode beam's 93 rows cost 5 100 instructions per call as
    separate dot products; as products its 116 rows (the CSE's shared ``c·q_k`` terms among
    them, read through the printer's ``scaled`` locals) cost 2 600. Identical rows are stored
    once.
    """

    def __init__(self, n: int, least: int = 8) -> None:
        self.n = n
        self.least = max(least, n // 4)
        self.rows: dict[tuple[float, ...], int] = {}
        self._at: dict[int, tuple[float, ...]] = {}

    def offset(self, row: tuple[float, ...]) -> int:
        """The offset (key) of ``row`` (appended when new)."""
        k = self.rows.setdefault(row, len(self.rows) * self.n)
        self._at[k] = row
        return k

    def helper(self) -> list[str]:
        """C lines defining ``nw_rows`` (none without rows)."""
        if not self.rows:
            return []
        return [
            "/* out[r] = sum_j T[j * k + r] v[col[j]], r < k: the long linear combinations of "
            "one function",
            "   (codegen/c_printer.DotRows); vectorized by gcc's -O3 (the libraries build with "
            "-O1; other",
            "   compilers ignore the attribute, as the optimize(\"O0\") of "
            "codegen/c_module.BIG_FUNCTION),",
            "   with gcc and glibc on x86-64 also as an AVX2 clone chosen at load time (the "
            "same operations in",
            "   the same order on four rows at once instead of two: the same results; "
            "NW_CLONES) */",
            *C_CLONES.strip("\n").splitlines(),
            '__attribute__((optimize("O3"))) NW_CLONES static void nw_rows(int k, int nc, '
            "const double *restrict T,",
            "                                                     const int *restrict col, "
            "const double *restrict v,",
            "                                                     double *restrict out)",
            "{",
            "    int j = 0;",
            "    for (int r = 0; r < k; ++r) out[r] = 0.0;",
            "    for (; j + 4 <= nc; j += 4) {             /* four columns per pass over out */",
            "        const double v0 = v[col[j]], v1 = v[col[j + 1]], v2 = v[col[j + 2]], "
            "v3 = v[col[j + 3]];",
            "        const double *c0 = T + j * k, *c1 = c0 + k, *c2 = c1 + k, *c3 = c2 + k;",
            "        for (int r = 0; r < k; ++r)",
            "            out[r] += (c0[r] * v0 + c1[r] * v1) + (c2[r] * v2 + c3[r] * v3);",
            "    }",
            "    for (; j < nc; ++j) {",
            "        const double vj = v[col[j]], *c = T + j * k;",
            "        for (int r = 0; r < k; ++r) out[r] += c[r] * vj;",
            "    }",
            "}",
            "",
        ]

    def batch(self, lines: list[str]) -> list[str]:
        """``lines`` of one function with its ``nw_dot(NW_T + k, v)`` replaced by the elements
        of one product per array ``v``, computed first (class docstring)."""
        text = "\n".join(lines)
        used: dict[str, dict[int, int]] = {}
        for k, v in _DOT.findall(text):
            rows = used.setdefault(v, {})
            rows.setdefault(int(k), len(rows))
        if not used:
            return lines
        head: list[str] = []
        for v, rows in used.items():
            table = np.array([self._at[k] for k in rows])            # (K, n)
            cols = np.flatnonzero(np.any(table != 0.0, axis=0))
            if not cols.size:                 # (rows of zeros only: nothing to multiply)
                head.append(f"const double nw_{v}[{table.shape[0]}] = {{0}};")
                continue
            values = ", ".join(_double(x) for x in table[:, cols].T.ravel())
            head += [f"static const double nw_T{v}[{table.shape[0] * cols.size}] = "
                     f"{{{values}}};",
                     f"static const int nw_C{v}[{cols.size}] = "
                     f"{{{', '.join(str(int(c)) for c in cols)}}};",
                     f"double nw_{v}[{table.shape[0]}];",
                     f"nw_rows({table.shape[0]}, {cols.size}, nw_T{v}, nw_C{v}, {v}, nw_{v});"]
        text = _DOT.sub(lambda m: f"nw_{m.group(2)}[{used[m.group(2)][int(m.group(1))]}]", text)
        return head + text.split("\n")


#: A row of :class:`DotRows` as the printer writes it.
_DOT = re.compile(r"nw_dot\(NW_T \+ (\d+), (y|yd|a)\)")


class CPrinter:
    """Prints scalar sympy expressions as C99 ``double`` expressions.

    Parameters
    ----------
    names
        Symbol → C expression (``"y[3]"``, ``"w12"``, ``"t"``); an unknown symbol is a
        :class:`~neweul_py.errors.GenerationError`.
    dots
        Where long linear combinations of ``y``, ``yd``, ``a`` go as table rows (:class:`DotRows`);
        ``None`` prints them term by term.
    scaled
        Locals known to be ``c·v`` (hoisted constant factors: ``w → (c, v)``); within such
        combinations a factor ``w`` counts as the number ``c`` times ``v`` (the local itself
        stays for its other uses).
    """

    def __init__(self, names: Mapping[sp.Symbol, str], dots: DotRows | None = None,
                 scaled: Mapping[sp.Symbol, tuple[sp.Number, sp.Symbol]] | None = None
                 ) -> None:
        self._names = names
        self._dots = dots
        self._fallback = CFallbackPrinter(self)
        self._elements: dict[sp.Symbol, tuple[str, int]] = {}
        self._scaled = dict(scaled or {})
        #: The symbols printed by name (reset by the caller): the locals an expression reads —
        #: a local ``c·v`` that a row reads as the number ``c`` times ``v`` is not among them.
        self.used: set[sp.Symbol] = set()
        if dots is not None:
            for sym, text in names.items():
                m = _ELEMENT.fullmatch(text)
                if m:
                    self._elements[sym] = (m.group(1), int(m.group(2)))

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
                text = self._names[e]
            except KeyError:
                raise GenerationError(
                    f"the equations use the symbol {e.name!r}, which is neither a coordinate, "
                    "velocity, parameter, input, t nor an intermediate quantity"
                ) from None
            self.used.add(e)
            return text, _ATOM
        if e.is_Number or e.is_NumberSymbol:
            if e.is_Rational and not e.is_Integer:
                return f"({_double(e.p)}/{_double(e.q)})", _ATOM
            s = _double(float(e))
            return s, (_UNARY if s.startswith(("-", "(")) else _ATOM)
        if e.is_Add:
            terms = self._dot_terms(e) if self._dots is not None else e.args
            return join_sum([t if isinstance(t, str) else self._paren(t, _ADD)
                             for t in terms]), _ADD
        if e.is_Mul:
            return self._mul(e)
        if e.is_Pow:
            return self._pow(e.base, e.exp)
        func = _C_FUNCTIONS.get(type(e))
        if func is not None:
            args = ", ".join(self.p(a)[0] for a in e.args)
            return f"{func}({args})", _ATOM
        return f"({self._fallback.doprint(e)})", _ATOM

    def _dot_terms(self, e: sp.Add) -> list[sp.Basic | str]:
        """The terms of ``e``, those of each long linear combination of one array (same
        other factor) replaced by one printed ``r*nw_dot(…)`` (:class:`DotRows`)."""
        dots, elements, scaled = self._dots, self._elements, self._scaled
        args = e.args

        def element(f: sp.Basic) -> bool:
            return f in elements or (f in scaled and scaled[f][1] in elements)

        if len(args) < dots.least or sum(
                any(element(f) for f in (t.args if t.is_Mul else (t,))) for t in args
        ) < dots.least:
            return list(args)
        groups: dict[tuple[str, sp.Basic], dict[int, float]] = {}
        where: list[tuple[str, sp.Basic] | None] = []
        for term in args:
            factors = term.args if term.is_Mul else (term,)
            key = None
            hit = next((f for f in factors if element(f)), None)
            if hit is not None:
                coeff, rest = 1.0, []
                if hit in elements:
                    array, index = elements[hit]
                else:                          # a local c·v[i]: the number c times v[i]
                    array, index = elements[scaled[hit][1]]
                    coeff = float(scaled[hit][0])
                for f in factors:
                    if f is hit:
                        continue
                    if f.is_Number:
                        coeff *= float(f)
                    elif f in scaled:
                        coeff *= float(scaled[f][0])
                        rest.append(scaled[f][1])
                    else:
                        rest.append(f)
                key = (array, sp.Mul(*rest))
                row = groups.setdefault(key, {})
                if index in row:
                    key = None
                else:
                    row[index] = coeff
            where.append(key)
        out: list[sp.Basic | str] = []
        done: set[tuple[str, sp.Basic]] = set()
        for term, key in zip(args, where, strict=True):
            if key is None or len(groups[key]) < dots.least:
                out.append(term)
            elif key not in done:
                done.add(key)
                row = [0.0] * dots.n
                for i, c in groups[key].items():
                    row[i] = c
                dot = f"nw_dot(NW_T + {dots.offset(tuple(row))}, {key[0]})"
                out.append(dot if key[1] == 1 else f"{self._paren(key[1], _MUL)}*{dot}")
        return out

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
