"""Symbolic Jacobians of expressions that use ordered intermediate assignments.

For intermediates ``z_k = e_k(v, z_<k)`` and expressions ``E(v, z)`` the total derivative with
respect to the variables ``v_j`` is built in forward mode (the chain rule in the order of the
assignments)::

    dz_k/dv_j = ∂e_k/∂v_j + Σ_{i<k} ∂e_k/∂z_i · dz_i/dv_j
    dE/dv_j   = ∂E/∂v_j   + Σ_i     ∂E/∂z_i   · dz_i/dv_j

Each non-trivial ``dz_k/dv_j`` becomes a new intermediate, so the derivative code grows like the
code it differentiates instead of exploding, and nothing is ever substituted back. Without
intermediates this is plain ``sympy.diff``. Distributional derivatives (``DiracDelta`` from
``sign``, ``Heaviside``, ``Abs``…) are replaced by zero: the generated Jacobians are the
derivatives almost everywhere.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

import sympy as sp

from .cse import Assignment, prune

__all__ = ["jacobian"]


def _numbered(prefix: str) -> Iterator[sp.Symbol]:
    k = 0
    while True:
        yield sp.Symbol(f"{prefix}{k}", real=True)
        k += 1


def _diff(expr: sp.Expr, var: sp.Symbol) -> sp.Expr:
    d = sp.diff(expr, var)
    if d.has(sp.DiracDelta):
        d = d.replace(sp.DiracDelta, lambda *args: sp.Integer(0))
    return d


def jacobian(
    exprs: Sequence[sp.Expr],
    wrt: Sequence[sp.Symbol],
    intermediates: Sequence[Assignment] = (),
    prefix: str = "_ncg_d",
) -> tuple[list[Assignment], sp.ImmutableMatrix]:
    """Jacobian ``∂exprs/∂wrt`` through the intermediates.

    Parameters
    ----------
    exprs
        The m expressions to differentiate.
    wrt
        The n variables.
    intermediates
        Ordered assignments the expressions (and each other) may use.
    prefix
        Name prefix of the derivative intermediates created here.

    Returns
    -------
    assignments, J
        The intermediates needed (original ones, each followed by its derivative intermediates,
        in a valid order) and the m×n Jacobian in terms of them.

    Examples
    --------
    >>> x = sp.Symbol("x"); z = sp.Symbol("z")
    >>> _, J = jacobian([z**2], [x], [(z, sp.sin(x))])
    >>> J[0, 0]
    2*z*_ncg_d0
    """
    exprs = [sp.sympify(e) for e in exprs]
    kept = prune(intermediates, exprs)
    index = {v: j for j, v in enumerate(wrt)}
    names = _numbered(prefix)
    # dz[z] = {j: derivative (a symbol or a simple expression)} for the non-zero ones
    dz: dict[sp.Symbol, dict[int, sp.Expr]] = {}
    out: list[Assignment] = []

    def total(expr: sp.Expr) -> dict[int, sp.Expr]:
        free = sorted(expr.free_symbols, key=lambda s: s.name)
        acc: dict[int, sp.Expr] = {}
        for s in free:
            if s in index:
                contrib = {index[s]: sp.Integer(1)}
            elif s in dz:
                contrib = dz[s]
            else:
                continue
            partial = _diff(expr, s)
            if partial == 0:
                continue
            for j, dsj in contrib.items():
                term = partial * dsj
                acc[j] = acc[j] + term if j in acc else term
        return {j: v for j, v in sorted(acc.items()) if v != 0}

    for sym, expr in kept:
        out.append((sym, expr))
        derivs = total(expr)
        if not derivs:
            continue
        row: dict[int, sp.Expr] = {}
        for j, d in derivs.items():
            if d.is_Atom:
                row[j] = d
            else:
                dsym = next(names)
                out.append((dsym, d))
                row[j] = dsym
        dz[sym] = row

    J = sp.zeros(len(exprs), len(wrt))
    for i, e in enumerate(exprs):
        for j, d in total(e).items():
            J[i, j] = d
    return out, sp.ImmutableMatrix(J)
