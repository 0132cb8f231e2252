"""The rotational spring–damper, on a coordinate or between two frames about an axis."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import sympy as sp

from ...errors import ModelError
from ..algebra import is_zero
from ..elements import AXES
from ..symbols import symbol
from .base import LOSS_FACTOR, ForceElement, Key
from .characteristic import force_law, has_linear_spring, tangent_stiffness
from .loads import KinematicsView, Loads, relative_angular_velocity, relative_rotation

__all__ = ["RotationalSpringDamper"]

_ZERO = sp.Integer(0)
_ONE = sp.Integer(1)


@dataclass(frozen=True)
class RotationalSpringDamper(ForceElement):
    """A rotational spring–damper, either on a generalized ``coordinate`` (generalized force
    ``−F(s, sd)`` with ``s = coordinate − angle``, ``sd`` its rate) or between ``frame_a`` and
    ``frame_b`` about ``axis`` (x, y or z of frame A; ``s`` = relative rotation angle about it
    minus ``angle``, ``atan2`` of the relative rotation matrix, ``sd = ω_rel · axis``), with the
    torque ``−F(s, sd)`` about the axis acting on B and its reaction on A.

    ``F`` is :func:`~neweul_py.model.characteristic_force` of ``stiffness``, ``damping`` and
    the optional table curves; ``loss_factor`` as for :class:`~neweul_py.model.SpringDamper`
    (on ``∂F/∂s``).
    """

    type_name = "rotational_spring_damper"
    keys = (
        Key("coordinate", "coordinate"),
        Key("between", "frames", ("frame_a", "frame_b")),
        Key("axis", "axis"),
        Key("stiffness", "characteristic", ("stiffness", "spring_force"), scope="dynamic",
            variable="s"),
        Key("damping", "characteristic", ("damping", "damper_force"), scope="dynamic",
            variable="sd"),
        Key("angle", "expression", scope="dynamic"),
        LOSS_FACTOR,
    )
    components = ("force",)

    name: str
    stiffness: sp.Expr = _ZERO
    damping: sp.Expr = _ZERO
    angle: sp.Expr = _ZERO
    coordinate: str | None = None
    frame_a: str | None = None
    frame_b: str | None = None
    axis: Literal["x", "y", "z"] = "z"
    spring_force: sp.Expr | None = None
    damper_force: sp.Expr | None = None
    enabled: sp.Expr = _ONE
    loss_factor: sp.Expr = _ZERO

    def __post_init__(self) -> None:
        path = self.path
        on_coordinate = self.coordinate is not None
        on_frames = self.frame_a is not None or self.frame_b is not None
        if on_coordinate == on_frames:
            raise ModelError(
                "a rotational spring–damper needs exactly one of 'coordinate' or 'between'", path
            )
        if on_frames and (self.frame_a is None or self.frame_b is None):
            raise ModelError("'between' needs two frames", f"{path}.between")
        if self.axis not in AXES:
            raise ModelError(f"axis must be one of x, y, z, not {self.axis!r}", f"{path}.axis")

    def loads(self, kin: KinematicsView, omega_ref: sp.Expr | float) -> Loads:
        """On a coordinate ``c``: ``s = c − angle``, ``sd = ċ − anglė``,
        ``q_j += −F ∂s/∂y_j``. Between frames A, B about axis ``a`` of A:
        ``s = atan2(R_cb − R_bc, R_bb + R_cc) − angle`` (``R = S_Aᵀ S_B``, (a, b, c) cyclic;
        exact for rotations about ``a``, within ``(−π, π]``), ``sd = ω_rel·e_a``; the torque
        ``−F e_a`` acts on B and ``+F e_a`` on A: ``q_j += −F (J_R,B,j − J_R,A,j)·e_a``
        (A components). Reports ``F``.
        """
        ws = kin.workspace
        name = self.name
        out = Loads.empty(kin.n)
        if self.coordinate is not None:
            c = kin.coordinate_index(self.coordinate)
            dang, _ = kin.partials(self.angle)
            ds = [sp.Integer(int(j == c)) - dang[j] for j in range(kin.n)]
            s = ws.let(kin.coordinates[c] - self.angle, f"el_{name}")
            sd = ws.let(kin.velocities[c] - kin.bar_rate(self.angle), f"sd_{name}")
        else:
            a = AXES.index(self.axis)
            b, cc = (a + 1) % 3, (a + 2) % 3
            assert self.frame_a is not None and self.frame_b is not None
            R = relative_rotation(kin, self.frame_a, self.frame_b)
            w_rel, jr = relative_angular_velocity(kin, self.frame_a, self.frame_b, name)
            s = ws.let(sp.atan2(R[cc][b] - R[b][cc], R[b][b] + R[cc][cc]) - self.angle,
                       f"el_{name}")
            ds = [col[a] for col in jr]
            sd = ws.let(w_rel[a] - kin.bar_rate(self.angle), f"sd_{name}")
        law = force_law(self, s, sd)
        if not is_zero(self.loss_factor):
            kt = ws.let(self.loss_factor * tangent_stiffness(self, s, sd), f"kl_{name}")
            law = law + kt / omega_ref * sd
            out.add_loss(kt, list(ds))
        force = ws.let(law, f"f_{name}")
        out.along(force, ds)
        out.reported = {"force": force}
        return out

    def potential(self, kin: KinematicsView) -> sp.Expr | None:
        """``½ k (coordinate − angle)²`` of a linear spring on a coordinate, else none."""
        if not has_linear_spring(self) or self.coordinate is None:
            return None
        s = symbol(self.coordinate) - self.angle
        return self.stiffness * s**2 / 2
