"""sympy's canonical ``Mul`` and ``Add`` of simple operands, built without its general machinery.

``sympy.Mul(*factors)`` and ``sympy.Add(*terms)`` sympify their arguments, look the call up in
sympy's cache and run ``flatten`` — coefficients, powers, like terms, and the cases of
infinities, orders, matrices and tensors (the first ``Add`` of a process imports
``sympy.tensor.tensor`` for these, ≈ 25 ms) — before they sort the arguments into their
canonical order. The derivation of a multibody model multiplies and adds intermediate symbols,
rational numbers and products of these. For such operands :func:`mul` and :func:`add` form
exactly the node sympy forms — the same class, the same arguments in the same order, the same
commutativity — at a fraction of the cost (≈ 2 µs instead of ≈ 20 µs per node); anything else
is passed to sympy unchanged. The printed code therefore cannot differ
(tests/model/test_canonical.py compares both with sympy's constructors on random operands,
argument by argument).

What sympy's ``flatten`` does with the operands accepted here (sympy 1.14, ``core/mul.py``,
``core/add.py``), and these functions do the same:

- ``Mul``: a rational number times a sum distributes (``_keep_coeff`` on each term: the
  "2-arg hack"); otherwise nested products are flattened (their factors appended), rational
  numbers multiplied into one coefficient, and every other factor is ``base**exp`` —
  exponent 1 for symbols, applied functions and sums, a rational exponent for powers of
  these. Exponents of equal bases are added (``x·x = x**2``, ``x·x⁻¹`` drops out), the factors
  sorted by ``Basic.compare`` and the coefficient (unless 1) put first.
- ``Add``: nested sums are flattened, rational numbers added into one coefficient, every
  other term written ``c·s`` (``c`` its rational coefficient); the coefficients of equal ``s``
  are added (a zero sum drops the term), the terms sorted by ``Basic.compare`` and the
  coefficient (unless 0) put first.

Floats, other numbers, non-commutative objects, exponents that are not rational, a
coefficient times a sum left unevaluated (``2*(x + y)`` as one product) and the like go to
sympy. The operands are sorted in the order sympy has them before its (stable) sort, with
the same comparison, so even a comparison that were no total order would give the same
arguments.
"""

from __future__ import annotations

import functools

import sympy as sp
from sympy.core.expr import Expr

__all__ = ["add", "mul"]

_ONE, _ZERO, _MINUS_ONE = sp.S.One, sp.S.Zero, sp.S.NegativeOne

#: The key sympy's ``Mul.flatten`` and ``Add.flatten`` sort arguments with (``_mulsort``,
#: ``_addsort``: ``cmp_to_key(Basic.compare)``).
_ORDER = functools.cmp_to_key(sp.Basic.compare)

_SYMBOL, _FUNCTION, _POW, _MUL, _ADD = sp.Symbol, sp.Function, sp.Pow, sp.Mul, sp.Add
_TRIVIAL_BASE_EXP = Expr.as_base_exp


def _plain(o: sp.Basic) -> bool:
    """A commutative symbol or applied function that is its own base with exponent 1 in a
    product (``exp`` is ``E**x`` there and goes to sympy)."""
    if isinstance(o, _SYMBOL):
        return o.is_commutative is True
    return (isinstance(o, _FUNCTION) and type(o).as_base_exp is _TRIVIAL_BASE_EXP
            and o.is_commutative is True)


def _base_exp(o: sp.Basic) -> tuple[sp.Basic, sp.Basic] | None:
    """``(base, exp)`` of a factor of a product (``o.as_base_exp()``), ``None`` for a factor
    :func:`mul` leaves to sympy. Powers only of symbols: sympy rebuilds every power it
    multiplies (``Pow(b, e)``), which for a symbol is the same node even if ``o`` was built
    unevaluated (a function's or a sum's power may evaluate: ``Abs(x)**2 = x**2``)."""
    if _plain(o) or (type(o) is _ADD and o.is_commutative is True):
        return o, _ONE
    if type(o) is _POW:
        b, e = o.args
        if (e.is_Rational and e is not _ONE and e is not _ZERO and isinstance(b, _SYMBOL)
                and b.is_commutative is True):
            return b, e
    return None


def _own_term(o: sp.Basic) -> bool:
    """A term sympy's ``Add`` keeps as it is (coefficient 1) and rebuilds as itself times a
    coefficient: a commutative symbol, applied function or power of a symbol."""
    if _plain(o):
        return True
    if type(o) is _POW:
        b = o.args[0]
        return isinstance(b, _SYMBOL) and b.is_commutative is True
    return False


def _is_sum_times(o: sp.Basic) -> bool:
    """``o.as_coeff_Mul()[1]`` is a sum (``x + y`` or ``c·(x + y)``)."""
    if type(o) is _ADD:
        return True
    if type(o) is _MUL:
        args = o.args
        return len(args) == 2 and args[0].is_Number and type(args[1]) is _ADD
    return False


def _keep_coeff(c: sp.Rational, t: sp.Expr) -> sp.Expr:
    """``c·t`` for a term ``t`` of a sum, as sympy's ``_keep_coeff(c, t)`` distributes a
    rational ``c`` (not 1) over a sum."""
    if t.is_Number:
        return c * t
    if c is _MINUS_ONE:
        return -t
    if t.is_Mul:
        margs = list(t.args)
        if margs[0].is_Number:
            margs[0] *= c
            if margs[0] == 1:
                margs.pop(0)
        else:
            margs.insert(0, c)
        return _MUL._from_args(margs)
    if t.is_Add:
        return sp.Mul(c, t, evaluate=False)
    return mul(c, t)


def mul(*factors: sp.Expr) -> sp.Expr:
    """``sympy.Mul(*factors)`` (the same node; operands are sympy objects), fast for products
    of symbols, applied functions, sums, their rational powers, rational numbers and products
    of these."""
    seq = [f for f in factors if f is not _ONE]
    if len(seq) < 2:
        return seq[0] if seq else _ONE
    if len(seq) == 2:  # sympy's "2-arg hack": a rational times a sum distributes
        a, b = seq
        if b.is_Rational:
            a, b = b, a
        if a.is_Rational and a is not _ZERO and _is_sum_times(b):
            if type(b) is not _ADD or b.is_commutative is not True:
                return sp.Mul(*factors)
            return add(*(_keep_coeff(a, t) for t in b.args))
    coeff = _ONE
    powers: dict[sp.Basic, list] = {}  # base -> [factor, exponent, count], first seen first
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
        be = _base_exp(o)
        if be is None:
            return sp.Mul(*factors)
        entry = powers.get(be[0])
        if entry is None:
            powers[be[0]] = [o, be[1], 1]
        else:
            entry[1] += be[1]
            entry[2] += 1
    c_part: list[sp.Expr] = []
    for b, (o, e, count) in powers.items():
        if count == 1:
            c_part.append(o)  # sympy rebuilds it as Pow(b, e): the same node
        elif e is _ONE:
            c_part.append(b)
        elif e is _ZERO:
            if type(b) is _ADD:
                return sp.Mul(*factors)  # sympy checks (x + oo)**0 for nan
        else:
            p = sp.Pow(b, e)
            if type(p) is not _POW or p.args[0] is not b:
                return sp.Mul(*factors)  # sympy would go on from here
            c_part.append(p)
    if not c_part:
        return coeff
    c_part.sort(key=_ORDER)
    if coeff is not _ONE:
        if len(c_part) == 1 and c_part[0].is_Add:  # sympy distributes 2*(x + y) here too
            return sp.Mul(*factors)
        c_part.insert(0, coeff)
    return _MUL._from_args(c_part, True)


def add(*terms: sp.Expr) -> sp.Expr:
    """``sympy.Add(*terms)`` (the same node; operands are sympy objects), fast for sums of
    rational numbers, sums and terms ``c·s`` (``c`` rational, ``s`` a symbol, applied
    function, power or product of these)."""
    seq = [t for t in terms if t is not _ZERO]
    if len(seq) < 2:
        return seq[0] if seq else _ZERO
    coeff = _ZERO
    collected: dict[object, list] = {}  # key of s -> [term, c, rest of a product], first first
    for o in seq:  # grows: nested sums append their terms, as in Add.flatten
        if o.is_Rational:
            coeff += o
            continue
        t = type(o)
        if t is _ADD:
            if o.is_commutative is not True:
                return sp.Add(*terms)
            seq.extend(o.args)
            continue
        if t is _MUL:
            args = o.args
            if o.is_commutative is not True:
                return sp.Add(*terms)
            if args[0].is_Number:
                # c·s with s no product, sum (c·(x + y) left unevaluated) or other node that
                # sympy's Mul(c, s) might change
                if not args[0].is_Rational or (len(args) == 2 and not _own_term(args[1])):
                    return sp.Add(*terms)
                c, rest = args[0], args[1:]
                key: object = rest[0] if len(rest) == 1 else rest
            else:
                c, rest, key = _ONE, args, args
        elif _plain(o) or (t is _POW and not o.args[0].is_Number and o.is_commutative is True):
            c, rest, key = _ONE, (o,), o
        else:
            return sp.Add(*terms)
        entry = collected.get(key)
        if entry is None:
            collected[key] = [o, c, rest]
        else:
            entry[0] = None  # combined: rebuilt below
            entry[1] += c
    newseq: list[sp.Expr] = []
    for o, c, rest in collected.values():
        if o is not None:
            newseq.append(o)  # sympy rebuilds it as c·s: the same node
        elif c is _ZERO:
            continue
        elif c is _ONE:
            newseq.append(rest[0] if len(rest) == 1 else _MUL._from_args(rest, True))
        elif len(rest) == 1:
            newseq.append(mul(c, rest[0]))
        else:
            newseq.append(_MUL._from_args((c, *rest), True))
    if not newseq:
        return coeff
    newseq.sort(key=_ORDER)
    if coeff is not _ZERO:
        newseq.insert(0, coeff)
    return _ADD._from_args(newseq, True)
