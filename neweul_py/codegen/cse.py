"""Deterministic common-subexpression elimination over a block of generated code.

A block is what one generated function computes: ordered *intermediate* assignments ``z_k =
e_k`` (from the recursive form of the equations, or from the derivatives of
:mod:`neweul_py.equations.jacobians`) followed by final expressions. :func:`eliminate` runs
``sympy.cse`` over all of them at once and schedules the resulting assignments so that each
comes after what it uses — intermediates keep their order, common subexpressions are placed
just before their first use. Only intermediates that the final expressions need (directly or
through other intermediates) are kept.

Determinism: ``sympy.cse`` is called with ``order='none'`` and a numbered symbol generator; the
arguments of sympy's ``Add``/``Mul`` are stored in a hash-independent canonical order, and this
module never iterates over sets without sorting. The result is the same for every
``PYTHONHASHSEED`` (tested).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Literal

import sympy as sp

from ..model import as_expr
from ..model.canonical import mul
from ..model.program import Assignment, free_symbols, numbered_symbols, prune

#: ``"full"``: ``sympy.cse`` (tree CSE plus its search for common argument subsets of Add/Mul,
#: best for large closed-form expressions); ``"tree"``: only repeated identical subtrees
#: (:func:`tree_cse`, an order of magnitude faster, nearly as good when the input already reuses
#: intermediates); ``"none"``: no elimination.
CseMethod = Literal["full", "tree", "none"]

__all__ = ["Assignment", "Block", "CseMethod", "eliminate", "free_symbols",
           "hoist_constant_factors", "numbered_symbols", "prune", "tree_cse"]


@dataclass(frozen=True)
class Block:
    """Straight-line code: ``assignments`` in order, then the values ``finals``."""

    assignments: tuple[Assignment, ...]
    finals: tuple[sp.Expr, ...]


def _rebuilt(expr: sp.Basic, args: tuple[sp.Basic, ...]) -> sp.Basic:
    """``expr`` with new arguments (symbols for subtrees), without re-evaluating it."""
    if expr.is_Add or expr.is_Mul:
        # commutative stays commutative (symbols of commutative subtrees replace them)
        return expr.func._from_args(args, True if expr.is_commutative is True else None)
    if expr.is_Pow:
        return sp.Pow(*args, evaluate=False)
    return expr.func(*args)


def tree_cse(
    exprs: Sequence[sp.Basic], symbols: Iterator[sp.Symbol]
) -> tuple[list[Assignment], list[sp.Basic]]:
    """Replace every subtree that occurs more than once by a symbol (sympy's ``tree_cse``
    without its optimizations, and rebuilding nodes without re-evaluation).

    Returns ``(replacements, reduced)`` like ``sympy.cse``: replacements in dependency order
    (each uses only earlier ones), numbered in the order of a depth-first walk of ``exprs`` —
    deterministic, independent of ``PYTHONHASHSEED``.
    """
    seen: set[sp.Basic] = set()
    repeated: set[sp.Basic] = set()
    stack: list[sp.Basic] = list(reversed(exprs))
    while stack:
        e = stack.pop()
        if e.is_Atom or not e.args:
            continue
        if e in seen:
            if isinstance(e, sp.Expr):  # not (expr, cond) pairs, relations, tuples
                repeated.add(e)
            continue
        seen.add(e)
        stack.extend(reversed(e.args))

    replacements: list[Assignment] = []
    done: dict[sp.Basic, sp.Basic] = {}

    def rebuild(e: sp.Basic) -> sp.Basic:
        if e.is_Atom or not e.args:
            return e
        hit = done.get(e)
        if hit is not None:
            return hit
        args = tuple(rebuild(a) for a in e.args)
        new = e if all(a is b for a, b in zip(args, e.args, strict=True)) else _rebuilt(e, args)
        if e in repeated:
            sym = next(symbols)
            replacements.append((sym, new))
            new = sym
        done[e] = new
        return new

    reduced = [rebuild(e) for e in exprs]
    return replacements, reduced


def eliminate(
    intermediates: Sequence[Assignment],
    finals: Sequence[sp.Expr],
    prefix: str = "_ncg_c",
    method: CseMethod = "full",
) -> Block:
    """Prune the intermediates, run CSE over everything, and schedule the assignments.

    Parameters
    ----------
    intermediates
        Ordered assignments; each expression may use earlier intermediate symbols.
    finals
        The values the block computes.
    prefix
        Name prefix of the symbols CSE introduces (they must not clash with other symbols).
    method
        ``"full"``, ``"tree"`` or ``"none"`` (see :data:`CseMethod`).

    Returns
    -------
    Block
        Assignments (intermediates and common subexpressions, each after what it uses) and the
        reduced final expressions.
    """
    kept = prune(intermediates, finals)
    finals = [as_expr(e) for e in finals]
    if method == "none":
        return Block(tuple(kept), tuple(finals))
    exprs = [e for _, e in kept] + finals
    if method == "full":
        replacements, reduced = sp.cse(exprs, symbols=numbered_symbols(prefix), order="none")
    elif method == "tree":
        replacements, reduced = tree_cse(exprs, numbered_symbols(prefix))
    else:
        raise ValueError(f"unknown CSE method {method!r}")
    reduced_inter = reduced[: len(kept)]
    reduced_finals = reduced[len(kept):]

    # Common subexpressions are emitted just before the first intermediate needing them.
    rep_index = {sym: i for i, (sym, _) in enumerate(replacements)}
    rep_free = [free_symbols(e) for _, e in replacements]
    emitted = [False] * len(replacements)
    out: list[Assignment] = []

    def emit_needed(expr_free: set[sp.Symbol]) -> None:
        stack = [rep_index[s] for s in expr_free if s in rep_index]
        todo: set[int] = set()
        while stack:
            i = stack.pop()
            if emitted[i] or i in todo:
                continue
            todo.add(i)
            stack.extend(rep_index[s] for s in rep_free[i] if s in rep_index)
        for i in sorted(todo):  # replacements are already in dependency order
            out.append(replacements[i])
            emitted[i] = True

    for (sym, _), expr in zip(kept, reduced_inter, strict=True):
        emit_needed(free_symbols(expr))
        out.append((sym, expr))
    for expr in reduced_finals:
        emit_needed(free_symbols(expr))
    return Block(tuple(out), tuple(reduced_finals))


def hoist_constant_factors(
    intermediates: Sequence[Assignment],
    finals: Sequence[sp.Expr],
    constants: Sequence[sp.Symbol],
    prefix: str = "_ncg_k",
) -> tuple[list[Assignment], list[sp.Expr]]:
    """Hoist the constant part of every product: ``(1/2)·x·l·m`` becomes ``k·x`` with
    ``k = l·m/2`` assigned once, ahead of the program (``constants``: the parameters).

    A product of ``c`` constant factors and other factors costs ``c`` multiplications per
    evaluation; hoisted it costs one. Equal constant parts share one symbol. Products made of
    constants only are left alone (CSE shares them). Deterministic: symbols are numbered in
    the order of a depth-first walk.

    Returns
    -------
    tuple
        The assignments (the hoisted constants first, then the rewritten intermediates) and
        the rewritten finals.
    """
    const = frozenset(constants)
    table: dict[sp.Expr, sp.Symbol] = {}
    hoisted: list[Assignment] = []
    done: dict[sp.Basic, sp.Basic] = {}

    def is_const(e: sp.Basic) -> bool:
        if e.is_Number:
            return True
        fs = free_symbols(e)
        return bool(fs) and fs <= const

    def rebuild(e: sp.Basic) -> sp.Basic:
        if e.is_Atom or not e.args:
            return e
        hit = done.get(e)
        if hit is not None:
            return hit
        args = tuple(rebuild(a) for a in e.args)
        new = e if all(a is b for a, b in zip(args, e.args, strict=True)) else _rebuilt(e, args)
        if new.is_Mul:
            flags = [is_const(a) for a in new.args]
            c = [a for a, f in zip(new.args, flags, strict=True) if f]
            rest = [a for a, f in zip(new.args, flags, strict=True) if not f]
            if len(c) >= 2 and rest:
                key = mul(*c)  # = sp.Mul(*c)
                sym = table.get(key)
                if sym is None:
                    sym = table[key] = sp.Symbol(f"{prefix}{len(table)}")
                    hoisted.append((sym, key))
                new = sp.Mul._from_args((sym, *rest),
                                        True if new.is_commutative is True else None)
        done[e] = new
        return new

    inter = [(s, rebuild(e)) for s, e in intermediates]
    out = [rebuild(as_expr(e)) for e in finals]
    return [*hoisted, *inter], out
