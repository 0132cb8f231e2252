"""A unilateral point–plane contact: a penalty spring with Hunt–Crossley damping."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import sympy as sp

from ...errors import ModelError
from ..algebra import cross, dot, is_zero, sub, total
from ..canonical import mul
from ..functions import Max
from .base import ForceElement, Key
from .loads import KinematicsView, Loads

__all__ = ["PlaneContact"]

_ZERO = sp.Integer(0)
_ONE = sp.Integer(1)


def _zero3() -> sp.ImmutableMatrix:
    return sp.ImmutableMatrix.zeros(3, 1)


def _ez() -> sp.ImmutableMatrix:
    return sp.ImmutableMatrix([0, 0, 1])


@dataclass(frozen=True)
class PlaneContact(ForceElement):
    """A point of ``frame_b`` against a plane fixed in ``frame_a``, pushed out of the plane
    while it penetrates. Damping after Hunt & Crossley 1975 (*J. Appl. Mech.* 42(2):440–445).

    The plane passes through ``point_a`` with the outward ``normal`` ``n`` (A components,
    normalized here); ``point_b`` is the contact point of B. With ``Δr`` the position of
    ``point_b`` relative to ``point_a`` in A components, the penetration and its rate are

    ``δ = −n·Δr``,  ``δ̇ = −n·Δṙ`` (``Δṙ`` the rate of ``Δr`` seen in A),

    and the normal force on B, along ``n`` (its reaction on A at the point of A that coincides
    with ``point_b``), is

    ``F = p^e · max(0, k + λ δ̇)``,  ``p = max(δ, 0)``

    with ``stiffness`` ``k``, ``exponent`` ``e ≥ 1`` (1: linear penalty, 3/2: Hertz) and
    Hunt–Crossley ``damping`` ``λ``: zero while the point is out of the plane, continuous at
    first touch (no jump of the damping force, unlike ``k δ + c δ̇``), never pulling. Its
    generalized forces are ``q_j = −F ∂δ/∂y_j``. It reports ``F`` (``force``) and has the
    potential ``V = k p^(e+1)/(e+1)``. No friction: the tangential force is zero.
    """

    type_name = "plane_contact"
    keys = (
        Key("between", "frames", ("frame_a", "frame_b"), required=True),
        Key("points", "points", ("point_a", "point_b"), scope="kinematic"),
        Key("normal", "vector", scope="constant"),
        Key("stiffness", "expression", scope="constant", required=True),
        Key("exponent", "expression", scope="constant"),
        Key("damping", "expression", scope="constant"),
    )
    components = ("force",)

    name: str
    frame_a: str
    frame_b: str
    stiffness: sp.Expr
    normal: sp.ImmutableMatrix = field(default_factory=_ez)
    exponent: sp.Expr = _ONE
    damping: sp.Expr = _ZERO
    point_a: sp.ImmutableMatrix = field(default_factory=_zero3)
    point_b: sp.ImmutableMatrix = field(default_factory=_zero3)
    enabled: sp.Expr = _ONE

    def check(self, at_defaults: Callable[[sp.Basic], object]) -> None:
        """At the parameter defaults: a nonzero normal, ``exponent ≥ 1`` (a finite force
        derivative at first touch), ``stiffness ≥ 0`` and ``damping ≥ 0``."""
        normal = at_defaults(self.normal)
        if isinstance(normal, list) and not any(v for row in normal for v in row):
            raise ModelError("the plane's normal must not be zero", f"{self.path}.normal")
        for attr, least in (("exponent", 1.0), ("stiffness", 0.0), ("damping", 0.0)):
            value = at_defaults(getattr(self, attr))
            if isinstance(value, float) and not value >= least:
                raise ModelError(f"{attr} must be at least {least:g}, got {value:g}",
                                 f"{self.path}.{attr}")

    def _unit_normal(self) -> tuple[sp.Expr, ...]:
        n = tuple(self.normal)
        length = sp.sqrt(sum(c**2 for c in n))
        return n if length == 1 else tuple(c / length for c in n)

    def loads(self, kin: KinematicsView, omega_ref: sp.Expr | float) -> Loads:
        """``Δr`` and its Jacobian columns ``c_j = J_PB,j − J_PA,j − J_RA,j × Δr`` (A
        components; ``Δṙ = Σ c_j ẏ_j + c̄``, as for the bushing), ``∂δ/∂y_j = −n·c_j``,
        ``δ̇ = Σ ∂δ/∂y_j ẏ_j − n·c̄``, ``q_j += −F ∂δ/∂y_j``."""
        ws = kin.workspace
        name, path = self.name, self.path
        A, B = self.frame_a, self.frame_b
        out = Loads.empty(kin.n)
        anc = kin.common_ancestor(A, B)
        pa = kin.relative_position(A, tuple(self.point_a), anc)
        pb = kin.relative_position(B, tuple(self.point_b), anc)
        dr = ws.let_vec(kin.express(sub(pb, pa), anc, A), f"dr_{name}")
        ka = kin.point(A, tuple(self.point_a), f"{path}.points[0]")
        kb = kin.point(B, tuple(self.point_b), f"{path}.points[1]")
        fa = kin.frames[A]
        cols = [sub(sub(kin.express(kb.J[j], B, A), ka.J[j]), cross(fa.JR[j], dr))
                for j in range(kin.n)]
        cbar = sub(sub(kin.express(kb.vbar, B, A), ka.vbar), cross(fa.wbar, dr))
        n = self._unit_normal()
        depth = ws.let(-dot(n, dr), f"pen_{name}")
        rates = [ws.let(-dot(n, c), f"dpen_{name}_{j}") for j, c in enumerate(cols)]
        rate = ws.let(total([*(mul(d, v) for d, v in zip(rates, kin.velocities, strict=True)
                               if not is_zero(d)), -dot(n, cbar)]), f"vpen_{name}")
        law = self.stiffness if is_zero(self.damping) else Max(self.stiffness
                                                               + self.damping * rate, 0)
        force = ws.let(Max(depth, 0) ** self.exponent * law, f"f_{name}")
        out.along(force, rates)
        out.reported = {"force": force}
        return out

    def potential(self, kin: KinematicsView) -> sp.Expr:
        """``V = k p^(e+1)/(e+1)`` with ``p = max(δ, 0)``."""
        ra = kin.point_position(self.frame_a, tuple(self.point_a), self.frame_a)
        rb = kin.point_position(self.frame_b, tuple(self.point_b), self.frame_a)
        depth = -dot(self._unit_normal(), sub(rb, ra))
        e = self.exponent + 1
        return self.stiffness * Max(depth, 0) ** e / e

