"""Zero-aware 3-vector and 3×3-matrix algebra on plain tuples of sympy expressions.

sympy's ``Matrix`` arithmetic is general but slow and builds ``0*x`` terms that evaluate away only
at the end; the kinematics of long chains is mostly sparse (planar chains, single-axis joints), so
these helpers skip exact zeros and build each entry with one ``Add`` of the nonzero products.
Vectors are ``tuple[Expr, Expr, Expr]``, matrices tuples of three row tuples.

The kinematics, the equations and the loads of the force elements
(:mod:`neweul_py.model.forces`) all build their expressions with these helpers.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import sympy as sp

from .canonical import add as _add
from .canonical import mul as _mul2
from .symbols import as_expr

__all__ = [
    "ZERO",
    "ZERO3",
    "Mat3",
    "Vec3",
    "add",
    "cross",
    "dot",
    "is_zero",
    "mat_mul",
    "mat_t_vec",
    "mat_vec",
    "scale",
    "sub",
    "total",
    "transpose",
    "vec_is_zero",
]

Vec3 = tuple[sp.Expr, sp.Expr, sp.Expr]
Mat3 = tuple[Vec3, Vec3, Vec3]

ZERO = sp.S.Zero
ZERO3: Vec3 = (ZERO, ZERO, ZERO)


def is_zero(x: sp.Expr) -> bool:
    """True for an exact numeric zero (``0``, ``0.0``); never queries assumptions."""
    return x is ZERO or (x.is_Number and not x)


def vec_is_zero(v: Sequence[sp.Expr]) -> bool:
    """True when every entry is an exact zero."""
    return all(is_zero(x) for x in v)


def _mul(a: sp.Expr, b: sp.Expr) -> sp.Expr | None:
    if is_zero(a) or is_zero(b):
        return None
    if a is sp.S.One:
        return b
    if b is sp.S.One:
        return a
    return _mul2(a, b)


def total(terms: Iterable[sp.Expr | None]) -> sp.Expr:
    """Sum of the terms that are not ``None`` and not exactly zero."""
    kept = [t for t in terms if t is not None and not is_zero(t)]
    if not kept:
        return ZERO
    if len(kept) == 1:
        return kept[0]
    return _add(*kept)


def dot(a: Sequence[sp.Expr], b: Sequence[sp.Expr]) -> sp.Expr:
    """``aᵀ b``."""
    return total(_mul(x, y) for x, y in zip(a, b, strict=True))


def add(*vs: Sequence[sp.Expr]) -> Vec3:
    """Entrywise sum of 3-vectors."""
    return tuple(total(v[i] for v in vs) for i in range(3))  # type: ignore[return-value]


def sub(a: Sequence[sp.Expr], b: Sequence[sp.Expr]) -> Vec3:
    """``a − b``."""
    return tuple(total((x, scale_one(-1, y))) for x, y in zip(a, b, strict=True))  # type: ignore


def scale_one(c: sp.Expr | int, x: sp.Expr) -> sp.Expr:
    if is_zero(x):
        return ZERO
    if c == 1:
        return x
    return _mul2(as_expr(c), x)


def scale(c: sp.Expr | int, v: Sequence[sp.Expr]) -> Vec3:
    """``c v``."""
    c = as_expr(c)
    if is_zero(c):
        return ZERO3
    return tuple(scale_one(c, x) for x in v)  # type: ignore[return-value]


def cross(a: Sequence[sp.Expr], b: Sequence[sp.Expr]) -> Vec3:
    """``a × b = ã b``."""
    return (
        total((_mul(a[1], b[2]), _neg(_mul(a[2], b[1])))),
        total((_mul(a[2], b[0]), _neg(_mul(a[0], b[2])))),
        total((_mul(a[0], b[1]), _neg(_mul(a[1], b[0])))),
    )


def _neg(x: sp.Expr | None) -> sp.Expr | None:
    return None if x is None else _mul2(sp.S.NegativeOne, x)


def mat_vec(m: Mat3, v: Sequence[sp.Expr]) -> Vec3:
    """``m v``."""
    return tuple(dot(row, v) for row in m)  # type: ignore[return-value]


def mat_t_vec(m: Mat3, v: Sequence[sp.Expr]) -> Vec3:
    """``mᵀ v``."""
    return tuple(dot((m[0][j], m[1][j], m[2][j]), v) for j in range(3))  # type: ignore


def transpose(m: Mat3) -> Mat3:
    return tuple(tuple(m[i][j] for i in range(3)) for j in range(3))  # type: ignore


def mat_mul(a: Mat3, b: Mat3) -> Mat3:
    """``a b``."""
    bt = transpose(b)
    return tuple(tuple(dot(row, col) for col in bt) for row in a)  # type: ignore
