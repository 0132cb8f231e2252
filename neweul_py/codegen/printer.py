"""Printing sympy expressions as Python source for generated modules.

The generated modules evaluate one state at a time, so scalar expressions are printed for
Python floats and the functions of :mod:`math` (``_math.sin``), which is several times faster
per call than NumPy ufuncs on scalars; arrays are assembled with NumPy. Every symbol must have
a name assigned by the caller: an unknown symbol is a :class:`~neweul_py.errors.GenerationError`
(it means the equations use something the module does not define).
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

__all__ = ["NamePool", "ScalarPrinter"]

#: Names the generated code uses itself (arguments, module aliases, helpers).
RESERVED: frozenset[str] = frozenset(
    {"t", "y", "yd", "x", "p", "u", "a", "M", "f", "n", "_math", "_np", "math", "np", "numpy"}
    | set(dir(builtins))
)

_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


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
        if not _IDENT.match(base) or keyword.iskeyword(base):
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
        super().__init__({"strict": True, "fully_qualified_modules": True})
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
        half = self._print(expr.args[1]) if len(expr.args) > 1 else "0.5"
        return f"(1.0 if ({arg}) > 0 else 0.0 if ({arg}) < 0 else {half})"

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
