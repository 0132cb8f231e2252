"""The workspace in which a derivation emits its intermediate quantities.

In *closed* form :meth:`Workspace.let` returns the expression itself, so results come out fully
substituted. In *recursive* (semi-symbolic) form it assigns every non-trivial expression to a
fresh symbol and records the ordered assignment; later expressions then refer to the symbol, so
expressions stay small and the derivation grows about linearly with the number of bodies
(``docs/architecture.md``, "Rigid bodies").

Intermediate symbols are named ``_<kind>_<owner>_<index>``; the leading underscore keeps them
apart from model names (which start with a letter). Equal expressions share one symbol.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import sympy as sp

__all__ = ["Workspace", "is_atomic"]


def is_atomic(expr: sp.Expr) -> bool:
    """True for expressions not worth a name: atoms and ``number · atom``."""
    if expr.is_Atom:
        return True
    if expr.is_Mul and len(expr.args) == 2:
        a, b = expr.args
        return bool(a.is_Number and b.is_Atom)
    return False


class Workspace:
    """Collects ordered intermediate assignments (recursive form) or passes through (closed).

    Parameters
    ----------
    recursive
        Emit intermediates (True) or substitute everything (False).
    reserved
        Names that intermediate symbols must not take.
    """

    def __init__(self, recursive: bool, reserved: Iterable[str] = ()) -> None:
        self.recursive = recursive
        self.assignments: list[tuple[sp.Symbol, sp.Expr]] = []
        self._by_expr: dict[sp.Expr, sp.Symbol] = {}
        self._names: set[str] = set(reserved)
        self.symbols: set[sp.Symbol] = set()

    def fresh(self, name: str) -> sp.Symbol:
        """A new real symbol whose name is unused in this workspace."""
        base = name if name.startswith("_") else f"_{name}"
        candidate, k = base, 1
        while candidate in self._names:
            k += 1
            candidate = f"{base}_{k}"
        self._names.add(candidate)
        sym = sp.Symbol(candidate, real=True)
        self.symbols.add(sym)
        return sym

    def let(self, expr: sp.Expr, name: str) -> sp.Expr:
        """``expr`` itself (closed form, or trivial), else a symbol assigned to it."""
        if not self.recursive or is_atomic(expr):
            return expr
        sym = self._by_expr.get(expr)
        if sym is None:
            sym = self.fresh(name)
            self.assignments.append((sym, expr))
            self._by_expr[expr] = sym
        return sym

    def let_vec(self, v: Sequence[sp.Expr], name: str) -> tuple[sp.Expr, ...]:
        """:meth:`let` for each entry; entry ``i`` is named ``<name>_<i>``."""
        return tuple(self.let(x, f"{name}_{i}") for i, x in enumerate(v))

    def let_mat(self, m: Sequence[Sequence[sp.Expr]], name: str) -> tuple[tuple[sp.Expr, ...], ...]:
        """:meth:`let` for each entry; entry ``i, j`` is named ``<name>_<i><j>``."""
        return tuple(
            tuple(self.let(x, f"{name}_{i}{j}") for j, x in enumerate(row))
            for i, row in enumerate(m)
        )
