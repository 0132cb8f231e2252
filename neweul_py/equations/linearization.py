"""Symbolic Jacobians of the equations for linearization (equations.md §1, "Linearization").

The protocol (docs/generated-module-protocol.md) needs ``∂(q−k)/∂y``, ``∂(q−k)/∂ẏ``,
``∂(q−k)/∂u``, ``∂(M a)/∂y`` and ``∂outputs/∂(y, ẏ, u)`` from *symbolic* derivatives. When the
equations carry intermediates (recursive form) they are differentiated by the chain rule in
forward mode: each intermediate ``s_k = f_k(base, s_1 … s_k−1)`` gets derivative intermediates

```
ds_k/dv = ∂f_k/∂v + Σ_m ∂f_k/∂s_m · ds_m/dv
```
emitted in order (only the nonzero ones), never by substituting the intermediates back. The
result's ``intermediates`` are to be evaluated *after* ``equations.intermediates``.
Distributional derivatives (``DiracDelta`` from ``sign``, ``Heaviside``, ``Abs′``) are
replaced by zero: the Jacobians are the derivatives almost everywhere.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import sympy as sp

from ..kinematics import Workspace
from ..model import as_expr
from ..model.algebra import ZERO, is_zero, total
from .result import Equations

__all__ = [
    "Derivatives",
    "force_jacobians",
    "jacobian",
    "mass_matrix_times_derivative",
    "output_jacobians",
]


@dataclass(frozen=True)
class Derivatives:
    """Symbolic derivative matrices and the intermediates they need.

    Attributes
    ----------
    intermediates
        Ordered assignments to evaluate after ``Equations.intermediates`` (empty when the
        equations are in closed form… unless derivative intermediates were emitted, which
        happens only in recursive form).
    matrices
        The requested matrices, in the order documented by the producing function.
    """

    intermediates: tuple[tuple[sp.Symbol, sp.Expr], ...]
    matrices: tuple[sp.ImmutableMatrix, ...]


def _gradient(expr: sp.Expr, wanted: frozenset[sp.Symbol]) -> dict[sp.Symbol, list[sp.Expr]]:
    """Partial derivatives of ``expr`` with respect to the ``wanted`` symbols it contains, as
    lists of terms (Add and Mul handled structurally, everything else by ``diff``)."""
    if expr.is_Symbol:
        return {expr: [sp.S.One]} if expr in wanted else {}
    if expr.is_Atom:
        return {}
    out: dict[sp.Symbol, list[sp.Expr]] = {}
    if expr.is_Add:
        for arg in expr.args:
            for s, terms in _gradient(arg, wanted).items():
                out.setdefault(s, []).extend(terms)
        return out
    if expr.is_Mul:
        args = expr.args
        for i, arg in enumerate(args):
            g = _gradient(arg, wanted)
            if not g:
                continue
            rest = sp.Mul(*args[:i], *args[i + 1:])
            for s, terms in g.items():
                out.setdefault(s, []).append(sp.Mul(rest, total(terms)))
        return out
    if expr.is_Pow and not (expr.exp.free_symbols & wanted):
        g = _gradient(expr.base, wanted)
        if not g:
            return {}
        factor = sp.Mul(expr.exp, sp.Pow(expr.base, expr.exp - 1))
        return {s: [sp.Mul(factor, total(terms))] for s, terms in g.items()}
    present = sorted(expr.free_symbols & wanted, key=sp.default_sort_key)
    for s in present:
        d = expr.diff(s)
        if d.has(sp.DiracDelta):  # from sign, Heaviside, Abs′: derivative almost everywhere
            d = d.replace(sp.DiracDelta, lambda *args: sp.S.Zero)
        if not is_zero(d):
            out[s] = [d]
    return out


def jacobian(
    equations: Equations,
    exprs: Sequence[sp.Expr],
    variables: Sequence[sp.Symbol],
    workspace: Workspace | None = None,
) -> tuple[tuple[tuple[sp.Symbol, sp.Expr], ...], sp.ImmutableMatrix]:
    """``∂exprs/∂variables`` through the intermediates of ``equations`` (forward mode).

    Parameters
    ----------
    equations
        Provides the intermediates (and whether to emit derivative intermediates: only in
        recursive form).
    exprs
        Expressions in the base symbols and the intermediates.
    variables
        Base symbols (coordinates, velocities, inputs, or any symbols not assigned as
        intermediates).
    workspace
        Where derivative intermediates go (a fresh one by default).

    Returns
    -------
    intermediates, matrix
        The derivative intermediates (evaluate after ``equations.intermediates``) and the
        ``len(exprs) × len(variables)`` Jacobian.
    """
    if workspace is None:
        workspace = _workspace(equations)
    start = len(workspace.assignments)
    index = {v: k for k, v in enumerate(variables)}
    derivs: dict[sp.Symbol, dict[int, sp.Expr]] = {}
    wanted = set(variables)

    def differentiate(expr: sp.Expr) -> dict[int, sp.Expr]:
        grad = _gradient(expr, frozenset(wanted & expr.free_symbols))
        acc: dict[int, list[sp.Expr]] = {}
        for s, terms in grad.items():
            partial = total(terms)
            if is_zero(partial):
                continue
            if s in index:
                acc.setdefault(index[s], []).append(partial)
            else:
                for k, ds in derivs[s].items():
                    acc.setdefault(k, []).append(sp.Mul(partial, ds))
        result = {}
        for k in sorted(acc):
            value = total(acc[k])
            if not is_zero(value):
                result[k] = value
        return result

    for sym, expr in equations.intermediates:
        d = differentiate(expr)
        if d:
            derivs[sym] = {
                k: workspace.let(v, f"{sym.name}__{variables[k].name}") for k, v in d.items()
            }
            wanted.add(sym)
    rows = []
    for expr in exprs:
        d = differentiate(as_expr(expr))
        rows.append([d.get(k, ZERO) for k in range(len(variables))])
    matrix = sp.ImmutableMatrix(len(rows), len(variables), [e for r in rows for e in r])
    return tuple(workspace.assignments[start:]), matrix


def _workspace(equations: Equations) -> Workspace:
    reserved = {s.name for s, _ in equations.intermediates}
    reserved |= {str(s) for s in (*equations.coordinates, *equations.velocities)}
    return Workspace(recursive=bool(equations.intermediates), reserved=reserved)


def force_jacobians(equations: Equations) -> Derivatives:
    """``∂(q−k)/∂y`` (n×n), ``∂(q−k)/∂ẏ`` (n×n), ``∂(q−k)/∂u`` (n×nu), in this order.

    Linearization (equations.md §1): ``P = −∂(q−k)/∂ẏ``, ``Q = −∂(q−k)/∂y (+ ∂(M ÿ0)/∂y)``,
    ``B = ∂(q−k)/∂u``.
    """
    ws = _workspace(equations)
    f = list(equations.force_vector)
    n, nu = equations.n, len(equations.inputs)
    variables = (*equations.coordinates, *equations.velocities, *equations.inputs)
    inter, jac = jacobian(equations, f, variables, ws)
    return Derivatives(
        inter, (jac[:, :n], jac[:, n: 2 * n], jac[:, 2 * n: 2 * n + nu])  # type: ignore
    )


def mass_matrix_times_derivative(equations: Equations, a: Sequence[sp.Symbol]) -> Derivatives:
    """``∂(M(y) a)/∂y`` (n×n) for a vector of symbols ``a`` (the ``∂M/∂y · ÿ0`` term of
    equations.md §1)."""
    n = equations.n
    if len(a) != n:
        raise ValueError(f"a must have {n} entries, got {len(a)}")
    m = equations.mass_matrix
    ma = [total(sp.Mul(m[i, j], a[j]) for j in range(n) if not is_zero(m[i, j]))
          for i in range(n)]
    inter, jac = jacobian(equations, ma, equations.coordinates)
    return Derivatives(inter, (jac,))


def output_jacobians(equations: Equations) -> Derivatives:
    """``∂outputs/∂x`` (ny × 2n, ``x = [y, ẏ]``) and ``∂outputs/∂u`` (ny × nu), in this
    order."""
    n = equations.n
    variables = (*equations.coordinates, *equations.velocities, *equations.inputs)
    inter, jac = jacobian(equations, list(equations.outputs), variables)
    return Derivatives(inter, (jac[:, : 2 * n], jac[:, 2 * n:]))  # type: ignore[arg-type]
