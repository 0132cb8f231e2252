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

from neweul_py.kinematics.canonical import add, mul
from neweul_py.model import symbol

x, y, z, w = (symbol(n) for n in ("x", "y", "z", "w"))
p = sp.Symbol("p", positive=True)
u = sp.Symbol("u")  # no assumptions
d = sp.Dummy("d")
f = sp.Function("f")(symbol("t"))
nc = sp.Symbol("A", commutative=False)

ATOMS = [x, y, z, w, p, u, d, sp.cos(x), sp.sin(y), f, sp.exp(z), sp.Abs(u),
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


#: Operands the fast paths accept (and products of them): most lists built from these take
#: them, the rest (equal bases, like terms) go to sympy.
SIMPLE = [*(symbol(f"s{i}") for i in range(8)), p, d, sp.cos(x), sp.sin(y), f, x**2, y**-1,
          sp.sqrt(p), sp.Integer(2), sp.Rational(-1, 2), sp.S.NegativeOne]


def operand(rng: random.Random, depth: int = 0, simple: bool = False) -> sp.Expr:
    r = rng.random()
    if simple:
        if r < 0.7 or depth > 1:
            return rng.choice(SIMPLE)
        return sp.Mul(*(operand(rng, depth + 1, True) for _ in range(rng.randint(2, 3))))
    if r < 0.45 or depth > 1:
        return rng.choice(ATOMS)
    if r < 0.65:
        return rng.choice(NUMBERS)
    if r < 0.67:
        return rng.choice(RARE)
    parts = [operand(rng, depth + 1) for _ in range(rng.randint(2, 4))]
    return sp.Mul(*parts) if r < 0.85 else sp.Add(*parts)


@pytest.mark.parametrize("simple", [False, True])
@pytest.mark.parametrize("seed", range(3))
def test_mul_is_sympys_mul(seed: int, simple: bool) -> None:
    """``mul`` = ``sympy.Mul`` on 1500 random operand lists (1–5 operands)."""
    rng = random.Random(seed)
    for _ in range(1500):
        ops = [operand(rng, simple=simple) for _ in range(rng.randint(1, 5))]
        assert same(mul(*ops), sp.Mul(*ops)), ops


@pytest.mark.parametrize("simple", [False, True])
@pytest.mark.parametrize("seed", range(3))
def test_add_is_sympys_add(seed: int, simple: bool) -> None:
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


def test_combining_operands_go_to_sympy() -> None:
    """Operands that combine are sympy's business: ``x·x``, ``x − x``, ``2x + x``."""
    assert mul(x, x) == x**2
    assert add(x, -x) is sp.S.Zero
    assert same(add(2 * x, x), 3 * x)
    assert same(mul(sp.Integer(2), x + y), 2 * x + 2 * y)
