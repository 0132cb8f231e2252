"""sympy's canonical ``Mul`` and ``Add`` of simple operands, built without its general machinery.

``sympy.Mul(*factors)`` and ``sympy.Add(*terms)`` sympify their arguments, look the call up in
sympy's cache, import three modules, and run ``flatten`` (collect coefficients, combine powers
and like terms, handle infinities, orders, matrices, tensors …) before they sort the arguments
into their canonical order. The derivation of a multibody model mostly multiplies and adds
intermediate symbols whose products never combine: ``x·y`` of distinct symbols, ``a·b + c·d``
of distinct products. For such operands :func:`mul` and :func:`add` form exactly the node
sympy forms — the same class, the same arguments in the same order, the same commutativity —
at a fraction of the cost (≈ 2 µs instead of ≈ 20 µs per node); anything else is passed to
sympy unchanged. The printed code therefore cannot differ (tests/kinematics/test_canonical.py
compares both constructors on random operands, argument by argument).

What sympy's ``flatten`` does with the operands accepted here (sympy 1.14,
``sympy/core/mul.py``, ``sympy/core/add.py``):

- ``Mul``: nested products are flattened (their arguments appended to the sequence), rational
  numbers multiplied into one coefficient, every other factor ``o`` is its own base with
  exponent 1 (``Symbol``, applied function) or ``base**exp`` (``Pow`` of a non-numeric base);
  when all bases differ, nothing combines, and the factors are sorted by ``Basic.compare``
  with the coefficient (unless 1) in front. Equal bases (``x·x``) go to sympy.
- ``Add``: every term ``o = c·s`` with ``c`` its numeric coefficient; when all ``s`` differ,
  nothing combines, the terms are rebuilt equal to themselves and sorted by ``Basic.compare``,
  the sum of the rational terms (unless 0) in front. Equal ``s`` (``x − x``, ``2x + x``),
  nested sums, floats and other numbers go to sympy.

The operands sorted are in the order sympy's ``flatten`` has them before its sort (a stable
sort with the same comparison), so even a comparison that did not define a total order would
give the same arguments.
"""

from __future__ import annotations

import functools

import sympy as sp
from sympy.core.expr import Expr

__all__ = ["add", "mul"]

_ONE, _ZERO = sp.S.One, sp.S.Zero

#: The key sympy's ``Mul.flatten`` and ``Add.flatten`` sort arguments with (``_mulsort``,
#: ``_addsort``: ``cmp_to_key(Basic.compare)``).
_ORDER = functools.cmp_to_key(sp.Basic.compare)

_SYMBOL, _FUNCTION, _POW, _MUL = sp.Symbol, sp.Function, sp.Pow, sp.Mul
_TRIVIAL_BASE_EXP = Expr.as_base_exp


def _plain(o: sp.Basic) -> bool:
    """A commutative symbol or applied function that is its own base with exponent 1 in a
    product (``exp`` is ``E**x`` there and goes to sympy)."""
    if isinstance(o, _SYMBOL):
        return o.is_commutative is True
    return (isinstance(o, _FUNCTION) and type(o).as_base_exp is _TRIVIAL_BASE_EXP
            and o.is_commutative is True)


def _base(o: sp.Basic) -> sp.Basic | None:
    """The base of a factor of a product, ``None`` for a factor :func:`mul` leaves to sympy."""
    if _plain(o):
        return o
    if type(o) is _POW:
        b, e = o.args
        if isinstance(b, _SYMBOL) and b.is_commutative is True and e.is_Rational:
            return b
    return None


def mul(*factors: sp.Expr) -> sp.Expr:
    """``sympy.Mul(*factors)`` (the same node), fast for products of distinct symbols,
    functions and their rational powers, rational numbers and products of these."""
    seq = [f for f in factors if f is not _ONE]
    if len(seq) < 2:
        return seq[0] if seq else _ONE
    coeff = _ONE
    c_part: list[sp.Expr] = []
    bases: set[sp.Basic] = set()
    for o in seq:  # grows: nested products append their factors, as in Mul.flatten
        if type(o) is _MUL:
            if o.is_commutative is not True:
                return sp.Mul(*factors)
            seq.extend(o.args)
            continue
        if o.is_Rational:
            if o is _ZERO:
                return sp.Mul(*factors)
            coeff *= o
            continue
        b = _base(o)
        if b is None or b in bases:
            return sp.Mul(*factors)
        bases.add(b)
        c_part.append(o)
    if not c_part:
        return coeff
    c_part.sort(key=_ORDER)
    if coeff is not _ONE:
        c_part.insert(0, coeff)
    return _MUL._from_args(c_part, True)


def _term_key(o: sp.Basic) -> object:
    """``s`` of a term ``o = c·s`` (``c`` its rational coefficient) as a dictionary key —
    the arguments of a product ``s`` instead of the node — or ``None`` for a term :func:`add`
    leaves to sympy."""
    if type(o) is _MUL:
        if o.is_commutative is not True:
            return None
        args = o.args
        first = args[0]
        if first.is_Number:
            if not first.is_Rational:
                return None
            return args[1] if len(args) == 2 else args[1:]
        return args
    if _plain(o) or (type(o) is _POW and not o.base.is_Number and o.is_commutative is True):
        return o
    return None


def add(*terms: sp.Expr) -> sp.Expr:
    """``sympy.Add(*terms)`` (the same node), fast for sums of rational numbers and distinct
    terms ``c·s`` (``c`` rational, ``s`` a symbol, function, power or product of them)."""
    seq = [t for t in terms if t is not _ZERO]
    if len(seq) < 2:
        return seq[0] if seq else _ZERO
    coeff = _ZERO
    newseq: list[sp.Expr] = []
    keys: set[object] = set()
    for o in seq:
        if o.is_Rational:
            coeff += o
            continue
        key = _term_key(o)
        if key is None or key in keys:
            return sp.Add(*terms)
        keys.add(key)
        newseq.append(o)
    if not newseq:
        return coeff
    newseq.sort(key=_ORDER)
    if coeff is not _ZERO:
        newseq.insert(0, coeff)
    return sp.Add._from_args(newseq, True)
