"""Elementary rotations and the relative rotation of a frame (equations.md §1).

Convention of the model layer: a frame's ``rotation = ((a1, φ1), (a2, φ2), …)`` means
``A = R_a1(φ1) · R_a2(φ2) · …`` mapping child components to parent components, each rotation
about the *current* (already rotated) axis.
"""

from __future__ import annotations

from collections.abc import Sequence

import sympy as sp

from ..model.algebra import ZERO, Mat3, Vec3, add, mat_mul, mat_t_vec, scale

__all__ = [
    "IDENTITY",
    "UNIT",
    "elementary_rotation",
    "rotation_axes",
    "rotation_product",
    "rotation_rates",
]

IDENTITY: Mat3 = ((sp.S.One, ZERO, ZERO), (ZERO, sp.S.One, ZERO), (ZERO, ZERO, sp.S.One))

#: Unit vectors of the axes.
UNIT: dict[str, Vec3] = {
    "x": (sp.S.One, ZERO, ZERO),
    "y": (ZERO, sp.S.One, ZERO),
    "z": (ZERO, ZERO, sp.S.One),
}


def elementary_rotation(axis: str, angle: sp.Expr) -> Mat3:
    """The rotation matrix ``R_axis(angle)`` (child → parent components).

    Examples
    --------
    >>> import sympy as sp
    >>> elementary_rotation("z", sp.Symbol("a"))[0]
    (cos(a), -sin(a), 0)
    """
    c, s = sp.cos(angle), sp.sin(angle)
    one, z = sp.S.One, ZERO
    if axis == "x":
        return ((one, z, z), (z, c, -s), (z, s, c))
    if axis == "y":
        return ((c, z, s), (z, one, z), (-s, z, c))
    if axis == "z":
        return ((c, -s, z), (s, c, z), (z, z, one))
    raise ValueError(f"axis must be x, y or z, not {axis!r}")


def rotation_product(rotation: Sequence[tuple[str, sp.Expr]]) -> Mat3:
    """``A = R_a1(φ1) · R_a2(φ2) · …`` (child → parent), the identity for no rotations."""
    result = IDENTITY
    for axis, angle in rotation:
        result = elementary_rotation(axis, angle) if result is IDENTITY else mat_mul(
            result, elementary_rotation(axis, angle)
        )
    return result


def rotation_axes(rotation: Sequence[tuple[str, sp.Expr]]) -> tuple[Vec3, ...]:
    """The rotation axes in *child* components, ``u_i = (R_i+1 ⋯ R_n)ᵀ e_ai``.

    The relative angular velocity in child components is ``ω_rel = Σ_i u_i φ̇_i``
    (equations.md §1: ``J_R = ∂ω/∂ẏ``).
    """
    axes: list[Vec3] = []
    b: Mat3 | None = None  # R_i+1 ⋯ R_n, walking backwards
    for axis, angle in reversed(rotation):
        e = UNIT[axis]
        axes.append(e if b is None else mat_t_vec(b, e))
        r = elementary_rotation(axis, angle)
        b = r if b is None else mat_mul(r, b)
    return tuple(reversed(axes))


def rotation_rates(rotation: Sequence[tuple[str, sp.Expr]], rates: Sequence[sp.Expr]) -> Vec3:
    """Relative angular velocity in *child* components, ``Σ_i u_i φ̇_i`` (see
    :func:`rotation_axes`)."""
    return add(*(scale(rate, u) for u, rate in zip(rotation_axes(rotation), rates, strict=True)))
