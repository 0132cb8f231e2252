"""The fast canonical ``Mul``/``Add`` against sympy's own constructors.

Reference: ``sympy.Mul(*factors)`` and ``sympy.Add(*terms)`` themselves. For random operands
drawn from symbols (with and without assumptions, ``Dummy``), applied functions (``exp``
included, which is ``E**x`` in a product), powers, numbers of every kind (rational, float,
``pi``, ``I``, infinities, ``nan``), sums and products of these, :func:`mul` and :func:`add`
must give the same node as sympy: the same classes, the same arguments in the same order at
every level, the same commutativity — so printed code cannot differ.
"""

from __future__ import annotations

import random

import pytest
import sympy as sp

from neweul_py.model import symbol
from neweul_py.model.canonical import add, mul

x, y, z, w = (symbol(n) for n in ("x", "y", "z", "w"))
p = sp.Symbol("p", positive=True)
u = sp.Symbol("u")  # no assumptions
d = sp.Dummy("d")
f = sp.Function("f")(symbol("t"))
nc = sp.Symbol("A", commutative=False)

ATOMS = [x, y, z, w, p, u, d, sp.cos(x), sp.sin(y), f, sp.exp(z), sp.Abs(u), sp.sign(y),
         sp.Heaviside(x, 1), sp.Min(x, y), sp.Piecewise((x, y > 0), (z, True)),
         x**2, y**-1, sp.sqrt(p), z**sp.Rational(3, 2), (x + y)**2, sp.Integer(2)**x, sp.pi]
NUMBERS = [sp.S.One, sp.S.Zero, sp.S.NegativeOne, sp.Integer(2), sp.Integer(-3),
           sp.Rational(1, 2), sp.Rational(-2, 3), sp.Float(1.5), sp.Float(0.0)]
RARE = [sp.I, sp.oo, -sp.oo, sp.zoo, sp.nan, nc]


def same(a: sp.Basic, b: sp.Basic) -> bool:
    """Structurally identical: class, commutativity and arguments in order, recursively."""
    if type(a) is not type(b) or a.is_commutative != b.is_commutative:
        return False
    if not a.args:
        return a == b
    return len(a.args) == len(b.args) and all(
        same(s, t) for s, t in zip(a.args, b.args, strict=True))


#: Operands the fast paths accept (and products and sums of them): most lists built from
#: these take them, combining like terms and equal bases on the way; a few go to sympy.
_S = [symbol(f"s{i}") for i in range(6)]
SIMPLE = [*_S, p, d, sp.cos(x), sp.sin(y), f, x**2, y**-1, sp.sqrt(p), _S[0] + _S[1],
          2 * _S[2] - _S[3], _S[0] + 1, (_S[4] - _S[5])**2, sp.Integer(2), sp.Rational(-1, 2),
          sp.S.NegativeOne, sp.Rational(1, 3)]


def raw(rng: random.Random, depth: int = 0) -> sp.Expr:
    """Nodes as code generation rebuilds them: arguments in any order, nested, unevaluated
    powers (``_from_args``, ``evaluate=False``)."""
    r = rng.random()
    if r < 0.5 or depth > 1:
        return rng.choice(SIMPLE)
    if r < 0.6:
        return sp.Pow(rng.choice(_S), rng.choice([2, -1, sp.Rational(1, 2)]), evaluate=False)
    parts = [raw(rng, depth + 1) for _ in range(rng.randint(2, 3))]
    rng.shuffle(parts)
    cls = sp.Mul if r < 0.8 else sp.Add
    return cls._from_args(parts, True)


def operand(rng: random.Random, depth: int = 0, simple: bool | str = False) -> sp.Expr:
    r = rng.random()
    if simple == "raw":
        return raw(rng)
    if simple:
        if r < 0.6 or depth > 1:
            return rng.choice(SIMPLE)
        parts = [operand(rng, depth + 1, True) for _ in range(rng.randint(2, 3))]
        return sp.Mul(*parts) if r < 0.8 else sp.Add(*parts)
    if r < 0.45 or depth > 1:
        return rng.choice(ATOMS)
    if r < 0.65:
        return rng.choice(NUMBERS)
    if r < 0.67:
        return rng.choice(RARE)
    parts = [operand(rng, depth + 1) for _ in range(rng.randint(2, 4))]
    return sp.Mul(*parts) if r < 0.85 else sp.Add(*parts)


@pytest.mark.parametrize("simple", [False, True, "raw"])
@pytest.mark.parametrize("seed", range(3))
def test_mul_is_sympys_mul(seed: int, simple: bool | str) -> None:
    """``mul`` = ``sympy.Mul`` on 1500 random operand lists (1–5 operands)."""
    rng = random.Random(seed)
    for _ in range(1500):
        ops = [operand(rng, simple=simple) for _ in range(rng.randint(1, 5))]
        assert same(mul(*ops), sp.Mul(*ops)), ops


@pytest.mark.parametrize("simple", [False, True, "raw"])
@pytest.mark.parametrize("seed", range(3))
def test_add_is_sympys_add(seed: int, simple: bool | str) -> None:
    """``add`` = ``sympy.Add`` on 1500 random operand lists (1–5 operands)."""
    rng = random.Random(100 + seed)
    for _ in range(1500):
        ops = [operand(rng, simple=simple) for _ in range(rng.randint(1, 5))]
        assert same(add(*ops), sp.Add(*ops)), ops


def test_typical_products_take_the_fast_path() -> None:
    """Distinct symbols and their products are built without sympy's constructor (a node
    sympy builds is cached: the same call returns the identical object; the fast path
    makes a new one), and still equal sympy's."""
    for ops in [(x, y), (sp.Mul(2, x, y), z), (sp.Rational(-1, 2), x, y**2)]:
        fast = mul(*ops)
        assert fast is not sp.Mul(*ops) and same(fast, sp.Mul(*ops))
    for ops in [(x, y), (sp.Mul(2, x, y), z, sp.Integer(3)),
                (sp.Mul(-1, x), sp.Mul(x, y), sp.cos(x))]:
        fast = add(*ops)
        assert fast is not sp.Add(*ops) and same(fast, sp.Add(*ops))


def test_combining_operands() -> None:
    """Equal bases and like terms combine, rationals distribute over a sum, as in sympy:
    ``x·x``, ``x·x⁻¹``, ``x − x``, ``2x + x``, ``2 (x + y)``, ``(x + y) + (z − y)``."""
    assert same(mul(x, x), x**2) and mul(x, 1 / x) is sp.S.One
    assert add(x, -x) is sp.S.Zero
    assert same(add(2 * x, x), 3 * x)
    assert same(mul(sp.Integer(2), x + y), 2 * x + 2 * y)
    assert same(add(x + y, z - y), x + z)


def test_other_operands_go_to_sympy() -> None:
    """Floats, ``pi``, ``exp``, non-commutative symbols, ``2*(x + y)`` kept as a product:
    sympy's constructor (its cached node: the identical object)."""
    for ops in [(sp.Float(1.5), x), (sp.pi, x), (sp.exp(x), sp.exp(y)), (nc, x)]:
        assert mul(*ops) is sp.Mul(*ops)
        assert add(*ops) is sp.Add(*ops)
    twice = sp.Mul(2, x + y, evaluate=False)
    assert add(twice, z) is sp.Add(twice, z)
