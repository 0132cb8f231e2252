"""Symbolic Jacobians of expressions that use ordered intermediate assignments.

For intermediates ``z_k = e_k(v, z_<k)`` and expressions ``E(v, z)`` the total derivative with
respect to the variables ``v_j`` is built in forward mode (the chain rule in the order of the
assignments)::

    dz_k/dv_j = ∂e_k/∂v_j + Σ_{i<k} ∂e_k/∂z_i · dz_i/dv_j
    dE/dv_j   = ∂E/∂v_j   + Σ_i     ∂E/∂z_i   · dz_i/dv_j

Each non-trivial ``dz_k/dv_j`` becomes a new intermediate, so the derivative code grows like
the code it differentiates instead of exploding, and nothing is ever substituted back. Code
generation asks for the derivatives of its *CSE'd* program (:mod:`.jacobians`; common
subexpressions are intermediates too), which keeps even closed-form Jacobians small. Partial
derivatives are taken structurally (sum, product and chain rule over sympy's tree, ``fdiff``
for functions) — much faster than ``sympy.diff`` on large sums; a ``Piecewise`` is
differentiated branch by branch under the same conditions (the one-sided derivative at a
switching point). The description language's non-smooth functions
(:mod:`neweul_py.model.functions`) have finite derivatives of their own; distributional
derivatives of sympy's own ``sign``, ``Heaviside``, ``Abs`` (``DiracDelta``, from models built
in Python) are replaced by zero: the generated Jacobians are the derivatives almost everywhere.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import sympy as sp

from ..model import as_expr
from ..model.program import Assignment, free_symbols, numbered_symbols, prune

__all__ = ["directional_derivative", "gradient", "jacobian"]


_ONE, _ZERO = sp.S.One, sp.S.Zero


def _no_delta(d: sp.Expr) -> sp.Expr:
    if d.has(sp.DiracDelta):
        d = d.replace(sp.DiracDelta, lambda *args: sp.Integer(0))
    return d


def _mul(a: sp.Expr, b: sp.Expr) -> sp.Expr:
    """``a*b`` without sympy's (costly) flattening and sympification (``_from_args`` builds
    the node directly: the result is correct but unevaluated); trivial factors dropped."""
    if a is _ONE:
        return b
    if b is _ONE:
        return a
    if a is _ZERO or b is _ZERO:
        return _ZERO
    return sp.Mul._from_args((a, b), _commutative((a, b)))


def _add(terms: list[sp.Expr]) -> sp.Expr:
    """A sum without sympy's (costly) flattening; zero terms dropped."""
    terms = [t for t in terms if t is not _ZERO]
    if not terms:
        return _ZERO
    return terms[0] if len(terms) == 1 else sp.Add._from_args(terms, _commutative(terms))


def _commutative(args: Sequence[sp.Expr]) -> bool | None:
    """``True`` when every argument is commutative, else ``None`` (``_from_args`` then works
    it out: ``fuzzy_and`` over the arguments, which costs more than these lookups)."""
    for a in args:
        if a.is_commutative is not True:
            return None
    return True


def gradient(expr: sp.Expr, wanted: set[sp.Symbol] | frozenset[sp.Symbol]) -> dict[sp.Symbol,
                                                                                    sp.Expr]:
    """Partial derivatives ``∂expr/∂s`` for the symbols ``s`` of ``wanted`` that occur in it.

    Zero partials are left out. Add, Mul, Pow with constant exponent and functions of one
    argument are differentiated structurally, anything else by ``sympy.diff``.
    """
    terms = _gradient_terms(expr, wanted)
    out: dict[sp.Symbol, sp.Expr] = {}
    for s in sorted(terms, key=lambda s: s.name):
        value = _add(terms[s])
        if value is not _ZERO:
            out[s] = value
    return out


def _gradient_terms(expr: sp.Basic, wanted: set[sp.Symbol] | frozenset[sp.Symbol]
                    ) -> dict[sp.Symbol, list[sp.Expr]]:
    if expr.is_Symbol:
        return {expr: [sp.S.One]} if expr in wanted else {}
    if expr.is_Atom or not (free_symbols(expr) & wanted):
        return {}
    out: dict[sp.Symbol, list[sp.Expr]] = {}
    # a symbol among the arguments is handled in place: ∂s/∂s = 1 (the recursion's result)
    if expr.is_Add:
        for arg in expr.args:
            if arg.is_Symbol:
                if arg in wanted:
                    out.setdefault(arg, []).append(_ONE)
                continue
            for s, terms in _gradient_terms(arg, wanted).items():
                out.setdefault(s, []).extend(terms)
        return out
    if expr.is_Mul:
        args = expr.args
        commutative = True if expr.is_commutative is True else None
        for i, arg in enumerate(args):
            if arg.is_Symbol:
                if arg not in wanted:
                    continue
                g = None
            else:
                g = _gradient_terms(arg, wanted)
                if not g:
                    continue
            others = args[:i] + args[i + 1:]
            rest = others[0] if len(others) == 1 else sp.Mul._from_args(others, commutative)
            if g is None:
                out.setdefault(arg, []).append(rest)  # = _mul(rest, _add([1]))
                continue
            for s, terms in g.items():
                out.setdefault(s, []).append(_mul(rest, _add(terms)))
        return out
    if isinstance(expr, sp.Piecewise):
        return _piecewise_gradient_terms(expr, wanted)
    if isinstance(expr, sp.sign | sp.Heaviside):
        # piecewise constant: zero almost everywhere (also where the argument is not known
        # to be real, for which sympy leaves an unevaluated Derivative; the first
        # derivatives of an Abs hold such a sign)
        return {}
    if expr.is_Pow and not (free_symbols(expr.exp) & wanted):
        g = _gradient_terms(expr.base, wanted)
        factor = expr.exp * expr.base ** (expr.exp - 1)
        return {s: [_mul(factor, _add(terms))] for s, terms in g.items()}
    if isinstance(expr, sp.Function) and len(expr.args) == 1:
        g = _gradient_terms(expr.args[0], wanted)
        try:
            outer = _no_delta(expr.fdiff(1))
        except (sp.ArgumentIndexError, NotImplementedError, AttributeError):
            outer = None
        if outer is not None and not isinstance(outer, sp.Derivative | sp.Subs):
            return {s: [_mul(outer, _add(terms))] for s, terms in g.items()}
    for s in sorted(free_symbols(expr) & wanted, key=lambda s: s.name):
        d = _no_delta(sp.diff(expr, s))
        if d != 0:
            out[s] = [d]
    return out


def _piecewise_gradient_terms(expr: sp.Piecewise, wanted: set[sp.Symbol] | frozenset[sp.Symbol]
                              ) -> dict[sp.Symbol, list[sp.Expr]]:
    """``∂/∂s Piecewise((e_i, c_i), …) = Piecewise((∂e_i/∂s, c_i), …)``: the derivative of the
    branch that holds, so at a switching point the one-sided derivative of that branch (the
    conditions are not differentiated — no ``DiracDelta``)."""
    grads = [_gradient_terms(e, wanted) for e, _ in expr.args]
    out: dict[sp.Symbol, list[sp.Expr]] = {}
    for s in sorted(set().union(*grads), key=lambda s: s.name):
        d = sp.Piecewise(*[(_add(g.get(s, [])), c)
                           for g, (_, c) in zip(grads, expr.args, strict=True)])
        if d != 0:
            out[s] = [d]
    return out


def jacobian(
    exprs: Sequence[sp.Expr],
    wrt: Sequence[sp.Symbol],
    intermediates: Sequence[Assignment] = (),
    prefix: str = "_ncg_d",
    tick: Callable[[float], None] | None = None,
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
    tick
        Called with the fraction of the work done (about 75 times), for progress.

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
    _ncg_d0*(2*z)
    """
    return _forward(exprs, len(wrt), {v: j for j, v in enumerate(wrt)}, {}, intermediates,
                    prefix, tick)


def directional_derivative(
    exprs: Sequence[sp.Expr],
    direction: Mapping[sp.Symbol, sp.Expr],
    intermediates: Sequence[Assignment] = (),
    prefix: str = "_ncg_s",
) -> tuple[list[Assignment], sp.ImmutableMatrix]:
    """``d/dε exprs`` along the curve on which each base symbol ``s`` of ``direction`` moves
    with the rate ``direction[s]`` (a symbol or a number), through the intermediates: the
    forward mode of :func:`jacobian` with one seeded column instead of one per variable.

    Parameters
    ----------
    exprs
        The m expressions to differentiate.
    direction
        Base symbol → its rate (symbols not listed stay fixed).
    intermediates
        Ordered assignments the expressions (and each other) may use.
    prefix
        Name prefix of the derivative intermediates created here (distinct from every
        prefix in ``intermediates``).

    Returns
    -------
    assignments, d
        The intermediates needed (each followed by its derivative intermediate) and the
        m×1 directional derivative.

    Examples
    --------
    >>> x, y, dx = sp.symbols("x y dx")
    >>> _, d = directional_derivative([x * y], {x: dx})
    >>> d[0, 0]
    dx*y
    """
    seeded = {s: {0: as_expr(d)} for s, d in direction.items() if as_expr(d) != 0}
    return _forward(exprs, 1, {}, seeded, intermediates, prefix, None)


def _forward(
    exprs: Sequence[sp.Expr],
    ncols: int,
    index: Mapping[sp.Symbol, int],
    seeded: Mapping[sp.Symbol, Mapping[int, sp.Expr]],
    intermediates: Sequence[Assignment],
    prefix: str,
    tick: Callable[[float], None] | None,
) -> tuple[list[Assignment], sp.ImmutableMatrix]:
    """The forward mode: ``index`` gives the column of each variable (derivative 1), and
    ``seeded`` the derivatives of other base symbols, by column."""
    exprs = [as_expr(e) for e in exprs]
    kept = prune(intermediates, exprs)
    names = numbered_symbols(prefix)
    # dz[z] = {j: dz/dwrt_j (a symbol or an atom)}, non-zero entries only
    dz: dict[sp.Symbol, dict[int, sp.Expr]] = {s: dict(d) for s, d in seeded.items()}
    wanted: set[sp.Symbol] = set(index) | set(dz)
    out: list[Assignment] = []

    def total(expr: sp.Expr) -> dict[int, sp.Expr]:
        acc: dict[int, list[sp.Expr]] = {}
        for s, partial in gradient(expr, wanted).items():
            if s in index:
                acc.setdefault(index[s], []).append(partial)
            else:
                for j, dsj in dz[s].items():
                    acc.setdefault(j, []).append(_mul(partial, dsj))
        result = {}
        for j in sorted(acc):
            value = _add(acc[j])
            if value is not _ZERO:
                result[j] = value
        return result

    every = max(len(kept) // 50, 1)
    for k, (sym, expr) in enumerate(kept):
        if tick is not None and k % every == 0:
            tick(0.5 * k / len(kept))
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
        wanted.add(sym)

    J = sp.zeros(len(exprs), ncols)
    every = max(len(exprs) // 25, 1)
    for i, e in enumerate(exprs):
        if tick is not None and i % every == 0:
            tick(0.5 + 0.5 * i / len(exprs))
        for j, d in total(e).items():
            J[i, j] = d
    return out, sp.ImmutableMatrix(J)
