"""The point-to-point spring–damper with a (possibly nonlinear or tabulated) characteristic."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import sympy as sp

from ...errors import ModelError
from ..algebra import dot, is_zero, scale, sub, total
from ..symbols import INERTIAL
from .base import LOSS_FACTOR, ForceElement, Key
from .characteristic import (
    ELONGATION,
    ELONGATION_RATE,
    force_law,
    has_linear_spring,
    tangent_stiffness,
)
from .loads import KinematicsView, Loads

__all__ = ["SpringDamper"]

_ZERO = sp.Integer(0)
_ONE = sp.Integer(1)


def _zero3() -> sp.ImmutableMatrix:
    return sp.ImmutableMatrix.zeros(3, 1)


@dataclass(frozen=True)
class SpringDamper(ForceElement):
    """A point-to-point spring–damper between ``point_a`` of ``frame_a`` and ``point_b`` of
    ``frame_b`` (points in their frames' components).

    Its tensile force is ``stiffness (s − length) + damping ṡ`` with ``s`` the distance of the
    points; it pulls the points together when positive.

    Nonlinear characteristics: ``stiffness`` and ``damping`` may use the elongation
    :data:`~neweul_py.model.ELONGATION` (``s − length``) and its rate
    :data:`~neweul_py.model.ELONGATION_RATE`; ``spring_force`` / ``damper_force``, when given,
    are characteristic curves (tables, :func:`~neweul_py.model.table_characteristic`) that
    replace ``stiffness·(s − length)`` / ``damping·ṡ``
    (:func:`~neweul_py.model.characteristic_force`).

    ``loss_factor`` η ≥ 0 (parameters only): hysteretic damping ``K(1 + iη)`` in the
    frequency domain on the spring's tangent stiffness ``∂F/∂s``; in the time domain its
    viscous equivalent ``(η/ω_ref) ∂F/∂s`` acts on ``ṡ`` (equations.md §1.1, ``ω_ref`` from the
    model's ``loss_reference_frequency``).
    """

    type_name = "spring_damper"
    keys = (
        Key("between", "frames", ("frame_a", "frame_b"), required=True),
        Key("points", "points", ("point_a", "point_b"), scope="kinematic"),
        Key("stiffness", "characteristic", ("stiffness", "spring_force"), scope="dynamic",
            required=True, variable="s"),
        Key("damping", "characteristic", ("damping", "damper_force"), scope="dynamic",
            variable="sd"),
        Key("length", "expression", scope="dynamic"),
        LOSS_FACTOR,
    )
    components = ("force",)

    name: str
    frame_a: str
    frame_b: str
    stiffness: sp.Expr
    damping: sp.Expr = _ZERO
    length: sp.Expr = _ZERO
    point_a: sp.ImmutableMatrix = field(default_factory=_zero3)
    point_b: sp.ImmutableMatrix = field(default_factory=_zero3)
    spring_force: sp.Expr | None = None
    damper_force: sp.Expr | None = None
    enabled: sp.Expr = _ONE
    loss_factor: sp.Expr = _ZERO

    def nonnegative(self) -> tuple[sp.Expr, ...]:
        """The rest length (a distance)."""
        return (self.length,)

    def check(self, at_defaults: Callable[[sp.Basic], object]) -> None:
        """The rest length is a distance: not negative at the parameter defaults."""
        length = at_defaults(self.length)
        if isinstance(length, float) and length < 0:
            raise ModelError(
                f"the rest length is a distance and must not be negative (it is {length:g})",
                f"{self.path}.length",
            )

    def _needs_no_direction(self) -> bool:
        """A linear spring of rest length 0 without damping: ``F e = k d`` is defined at
        ``d = 0``."""
        return (is_zero(self.length) and is_zero(self.damping) and is_zero(self.loss_factor)
                and self.spring_force is None
                and self.damper_force is None
                and not ({ELONGATION, ELONGATION_RATE} & self.stiffness.free_symbols))

    def loads(self, kin: KinematicsView, omega_ref: sp.Expr | float) -> Loads:
        """With ``d = r_B − r_A``, distance ``ℓ = |d|``, ``e = d/ℓ``, elongation
        ``s = ℓ − length`` and ``sd = ∂ℓ/∂y ẏ + e·(v̄_B − v̄_A)``, the tensile force
        ``F(s, sd)`` pulls the points together: ``q += −F ∂ℓ/∂y`` with
        ``∂ℓ/∂y_j = e·J_B,j − e·J_A,j``. Reports ``F``.

        Two coinciding points have no direction ``e`` (docs/description-format.md,
        "Zero-length springs"): a linear spring of rest length 0 without damping needs none
        (``F e = k d``, sympy cancels ``ℓ/ℓ``), anything else divides by ``ℓ = 0``. Points
        that coincide in every configuration are refused here (:class:`ModelError`); points
        that meet at some state make the generated module raise ``ZeroDivisionError`` there,
        which the analysis reports as an error.
        """
        ws = kin.workspace
        name, path = self.name, self.path
        out = Loads.empty(kin.n)
        anc = kin.common_ancestor(self.frame_a, self.frame_b)
        pa = kin.relative_position(self.frame_a, tuple(self.point_a), anc)
        pb = kin.relative_position(self.frame_b, tuple(self.point_b), anc)
        raw = sub(pb, pa)
        if all(is_zero(sp.expand(c)) for c in raw) and not self._needs_no_direction():
            raise ModelError(
                "the two points of the spring_damper coincide in every configuration, so its "
                "force has no direction; with a rest length, damping or a characteristic curve "
                "it needs distinct points (see docs/description-format.md, zero-length springs)",
                f"{path}.points",
            )
        d = ws.let_vec(raw, f"d_{name}")
        dist = ws.let(sp.sqrt(dot(d, d)), f"s_{name}")
        e = ws.let_vec(scale(1 / dist, d), f"e_{name}")
        e_a = kin.express(e, anc, self.frame_a)
        e_b = kin.express(e, anc, self.frame_b)
        ka = kin.point(self.frame_a, tuple(self.point_a), f"{path}.points[0]")
        kb = kin.point(self.frame_b, tuple(self.point_b), f"{path}.points[1]")
        ds = [ws.let(dot(kb.J[j], e_b) - dot(ka.J[j], e_a), f"ds_{name}_{j}")
              for j in range(kin.n)]
        sdot = ws.let(
            total(
                [
                    *(sp.Mul(dj, v) for dj, v in zip(ds, kin.velocities, strict=True)
                      if not is_zero(dj)),
                    dot(kb.vbar, e_b),
                    -dot(ka.vbar, e_a),
                ]
            ),
            f"sd_{name}",
        )
        elongation = ws.let(dist - self.length, f"el_{name}")
        law = force_law(self, elongation, sdot)
        if not is_zero(self.loss_factor):
            kt = ws.let(self.loss_factor * tangent_stiffness(self, elongation, sdot),
                        f"kl_{name}")
            law = law + kt / omega_ref * sdot
            out.add_loss(kt, ds)
        force = ws.let(law, f"f_{name}")
        out.along(force, ds)
        out.reported = {"force": force}
        return out

    def potential(self, kin: KinematicsView) -> sp.Expr | None:
        """``½ k (ℓ − length)²`` of a linear spring (``stiffness·s``), else none."""
        if not has_linear_spring(self):
            return None
        ra = kin.point_position(self.frame_a, tuple(self.point_a), INERTIAL)
        rb = kin.point_position(self.frame_b, tuple(self.point_b), INERTIAL)
        d = sub(rb, ra)
        s = sp.sqrt(dot(d, d)) - self.length
        return self.stiffness * s**2 / 2
