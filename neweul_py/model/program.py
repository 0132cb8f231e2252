"""Straight-line programs of sympy expressions: ordered assignments ``z_k = e_k`` and the
helpers every layer that reads or writes them shares.

A *program* is a sequence of :data:`Assignment` (each expression may use the symbols assigned
before it) followed by the expressions it computes. The recursive form of the equations is one
(``Equations.intermediates``), so are their derivatives (:mod:`neweul_py.equations.derivatives`)
and the CSE'd blocks of code generation (:mod:`neweul_py.codegen.cse`). Deterministic: nothing
here iterates over a set without sorting, and numbered symbols are the same in every process.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

import sympy as sp

__all__ = ["Assignment", "free_symbols", "numbered_symbols", "prune"]

#: One assignment ``symbol = expression`` of a program.
Assignment = tuple[sp.Symbol, sp.Expr]


def prune(intermediates: Sequence[Assignment], finals: Sequence[sp.Expr]) -> list[Assignment]:
    """The intermediates that ``finals`` need, directly or through other intermediates, in order."""
    # every free symbol is collected (not only the intermediates': only theirs are looked up)
    needed: set[sp.Symbol] = set()
    for e in finals:
        needed |= free_symbols(e)
    kept: list[Assignment] = []
    for sym, expr in reversed(intermediates):
        if sym in needed:
            kept.append((sym, expr))
            needed |= free_symbols(expr)
    kept.reverse()
    return kept


#: ``Basic.free_symbols`` (the union over the arguments: Add, Mul, Pow, numbers …) and
#: ``Symbol.free_symbols`` (``{self}``); other classes (functions, Piecewise, Derivative …)
#: define their own.
_UNION_OF_ARGS = sp.Basic.free_symbols
_ITSELF = sp.Symbol.free_symbols


def _free_walk(expr: sp.Basic) -> frozenset[sp.Symbol]:
    """``expr.free_symbols`` in one walk over the tree (sympy's property builds a set at
    every node of it), asking each class with a rule of its own for its answer."""
    out: set[sp.Basic] = set()
    stack = [expr]
    while stack:
        e = stack.pop()
        rule = type(e).free_symbols
        if rule is _UNION_OF_ARGS:
            stack.extend(e.args)
        elif rule is _ITSELF:
            out.add(e)
        else:
            out |= e.free_symbols
    return frozenset(out)


#: The free symbols of the expressions asked about, by identity: ``id(expr) → (expr,
#: symbols)`` (an entry holds its expression, so its id is not reused while it lives). Keyed
#: by identity, not equality: most expressions asked about are new (derivative and CSE
#: programs), and hashing them — sympy's ``__hash__`` hashes every new node of a tree —
#: cost more than the walk. Emptied when full.
_FREE: dict[int, tuple[sp.Basic, frozenset[sp.Symbol]]] = {}
_FREE_SIZE = 1 << 17


def free_symbols(expr: sp.Basic) -> frozenset[sp.Symbol]:
    """Free symbols (memoized: the same expressions are scanned by several functions)."""
    hit = _FREE.get(id(expr))
    if hit is not None and hit[0] is expr:
        return hit[1]
    if not isinstance(expr, sp.Basic):
        return frozenset()
    symbols = _free_walk(expr)
    if len(_FREE) >= _FREE_SIZE:
        _FREE.clear()
    _FREE[id(expr)] = (expr, symbols)
    return symbols


#: The symbols ``prefix0, prefix1, …`` made so far, per prefix (each block numbers its own
#: from 0, so the same names recur in every function of a module and in every module).
_NUMBERED: dict[str, list[sp.Symbol]] = {}


def numbered_symbols(prefix: str) -> Iterator[sp.Symbol]:
    """``Symbol(prefix0), Symbol(prefix1), …``: each made once per process and reused (equal
    to a new ``Symbol`` of that name; making them was ~10 % of generating a module)."""
    made = _NUMBERED.setdefault(prefix, [])
    k = 0
    while True:
        if k == len(made):
            made.append(sp.Symbol(f"{prefix}{k}"))
        yield made[k]
        k += 1
