"""What a force element sees of the kinematics, and what it returns: its loads.

:class:`KinematicsView` is the part of :class:`neweul_py.kinematics.Kinematics` that force
elements use (points, frames, the transformation of vectors, the intermediates' workspace);
the equations layer passes the kinematics in, so the model layer imports no other layer.
:class:`Loads` is sympy's ``ActuatorBase.to_loads`` in generalized form: forces on points and
torques on frames enter through the transposed Jacobians (:meth:`Loads.force_at`,
:meth:`Loads.torque_on`), generalized forces directly (docs/equations.md §1).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import sympy as sp

from ..algebra import Vec3, dot, is_zero, sub
from ..symbols import INERTIAL

__all__ = [
    "FrameMotion",
    "KinematicsView",
    "Loads",
    "LossTerms",
    "PointMotion",
    "WorkspaceView",
    "relative_angular_velocity",
    "relative_rotation",
]

#: Entries ``(j, k) → terms`` of the hysteretic matrix ``G`` (only the nonzero ones).
LossTerms = dict[tuple[int, int], list[sp.Expr]]


class WorkspaceView(Protocol):
    """Names intermediate expressions (recursive form) or returns them (closed form)."""

    def let(self, expr: sp.Expr, name: str) -> sp.Expr: ...
    def let_vec(self, v: Sequence[sp.Expr], name: str) -> tuple[sp.Expr, ...]: ...


class PointMotion(Protocol):
    """A point's Jacobian ``J`` (one 3-vector per coordinate) and ``v̄``, so that
    ``v = J ẏ + v̄`` (components of its frame)."""

    @property
    def J(self) -> tuple[Vec3, ...]: ...
    @property
    def vbar(self) -> Vec3: ...


class FrameMotion(Protocol):
    """A frame's rotational Jacobian ``J_R``, angular velocity ``ω`` and ``ω̄`` (its own
    components)."""

    @property
    def JR(self) -> tuple[Vec3, ...]: ...
    @property
    def omega(self) -> Vec3: ...
    @property
    def wbar(self) -> Vec3: ...


class KinematicsView(Protocol):
    """The kinematics a force element's loads are written against (equations.md §1)."""

    #: Number of coordinates.
    n: int
    #: ``y`` and ``ẏ``.
    coordinates: tuple[sp.Symbol, ...]
    velocities: tuple[sp.Symbol, ...]

    @property
    def workspace(self) -> WorkspaceView: ...
    @property
    def frames(self) -> Mapping[str, FrameMotion]: ...

    def coordinate_index(self, name: str) -> int:
        """The position of a coordinate in ``y``."""
        ...

    def express(self, v: Sequence[sp.Expr], from_frame: str, to_frame: str) -> Vec3:
        """A vector's components in another frame."""
        ...

    def point(self, frame: str, point: Sequence[sp.Expr], where: str = "") -> PointMotion:
        """Jacobian and ``v̄`` of a point of a frame."""
        ...

    def point_position(self, frame: str, point: Sequence[sp.Expr],
                       in_frame: str = INERTIAL) -> Vec3:
        """Absolute position of a point, in ``in_frame`` components."""
        ...

    def relative_position(self, frame: str, point: Sequence[sp.Expr], ancestor: str) -> Vec3:
        """Position of a point relative to an ancestor frame's origin, its components."""
        ...

    def common_ancestor(self, a: str, b: str) -> str:
        """The deepest frame on both frames' chains."""
        ...

    def partials(self, expr: sp.Expr) -> tuple[list[sp.Expr], sp.Expr]:
        """``∂expr/∂y_j`` for all j and ``∂expr/∂t`` (through inputs)."""
        ...

    def bar_rate(self, expr: sp.Expr) -> sp.Expr:
        """``Σ_j ∂expr/∂y_j ẏ_j + ∂expr/∂t``."""
        ...


@dataclass
class Loads:
    """What a force element exerts: per coordinate ``j`` the terms of its generalized force
    ``q_j``, the quantities it reports (:attr:`ForceElement.components
    <neweul_py.model.ForceElement.components>` → expression) and its entries of the hysteretic
    matrix ``G`` (docs/equations.md §1.1), all before its ``enabled`` factor."""

    generalized: list[list[sp.Expr]]
    reported: dict[str, sp.Expr] = field(default_factory=dict)
    loss: LossTerms = field(default_factory=dict)

    @classmethod
    def empty(cls, n: int) -> Loads:
        """No loads on ``n`` coordinates."""
        return cls([[] for _ in range(n)])

    def force_at(self, point: PointMotion, force: Sequence[sp.Expr]) -> None:
        """A force on a point (components of the point's frame): ``q_j += J_P,j · f``."""
        for j, col in enumerate(point.J):
            self.generalized[j].append(dot(col, force))

    def torque_on(self, frame: FrameMotion, torque: Sequence[sp.Expr]) -> None:
        """A torque on a frame (its components): ``q_j += J_R,j · l``."""
        for j, col in enumerate(frame.JR):
            self.generalized[j].append(dot(col, torque))

    def along(self, force: sp.Expr, rates: Sequence[sp.Expr]) -> None:
        """A scalar force ``F`` against the rate of a scalar measure ``s``:
        ``q_j += −F ∂s/∂y_j`` (``rates[j] = ∂s/∂y_j``; zeros left out)."""
        for j, ds in enumerate(rates):
            if not is_zero(ds):
                self.generalized[j].append(-force * ds)

    def add_loss(self, eta_k: object, rows: Sequence[sp.Expr],
                 cols: Sequence[sp.Expr] | None = None) -> None:
        """``G[j, k] += eta_k · rows[j] · cols[k]`` for the nonzero entries."""
        cols = rows if cols is None else cols
        for j, a in enumerate(rows):
            if is_zero(a):
                continue
            for k, b in enumerate(cols):
                if not is_zero(b):
                    self.loss.setdefault((j, k), []).append(eta_k * a * b)

    def add_matrix_loss(self, eta: object, K: Sequence[Sequence[object]],
                        cols: Sequence[Sequence[sp.Expr]]) -> None:
        """``G += η Σ_ab K_ab c_a c_bᵀ`` for a 3×3 stiffness ``K`` acting on a relative
        displacement (or rotation) whose Jacobian columns are ``cols``."""
        for a in range(3):
            for b in range(3):
                if not is_zero(K[a][b]):
                    self.add_loss(eta * K[a][b], [c[a] for c in cols], [c[b] for c in cols])


def relative_rotation(kin: KinematicsView, frame_a: str, frame_b: str) -> tuple[Vec3, Vec3, Vec3]:
    """Rows of ``R = S_Aᵀ S_B`` (B components → A components)."""
    cols = [kin.express(tuple(sp.Integer(int(i == k)) for i in range(3)), frame_b, frame_a)
            for k in range(3)]
    return tuple(tuple(cols[k][i] for k in range(3)) for i in range(3))  # type: ignore[return-value]


def relative_angular_velocity(kin: KinematicsView, frame_a: str, frame_b: str, name: str
                              ) -> tuple[tuple[sp.Expr, ...], list[tuple[sp.Expr, ...]]]:
    """``ω_rel`` of B relative to A and its Jacobian columns, in A components (intermediates
    ``wr_NAME``, ``JRr_NAME_j``)."""
    ws = kin.workspace
    fa, fb = kin.frames[frame_a], kin.frames[frame_b]
    w_rel = ws.let_vec(sub(kin.express(fb.omega, frame_b, frame_a), fa.omega), f"wr_{name}")
    jr = [
        ws.let_vec(sub(kin.express(fb.JR[j], frame_b, frame_a), fa.JR[j]), f"JRr_{name}_{j}")
        for j in range(kin.n)
    ]
    return w_rel, jr
