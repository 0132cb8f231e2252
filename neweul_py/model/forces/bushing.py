"""The linear 6-DOF spring–damper (bushing) between two frames."""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from ...errors import ModelError
from ..algebra import ZERO, add, cross, dot, is_zero, mat_vec, scale, sub
from .base import LOSS_FACTOR, ForceElement, Key
from .loads import KinematicsView, Loads, relative_angular_velocity, relative_rotation

__all__ = ["Bushing"]

_ZERO = sp.Integer(0)
_ONE = sp.Integer(1)


def _zero3() -> sp.ImmutableMatrix:
    return sp.ImmutableMatrix.zeros(3, 1)


def _zero33() -> sp.ImmutableMatrix:
    return sp.ImmutableMatrix.zeros(3, 3)


def _rows(m: sp.ImmutableMatrix) -> tuple[tuple[sp.Expr, ...], ...]:
    return tuple(tuple(m[i, j] for j in range(3)) for i in range(3))


def _is_zero_matrix(m: tuple[tuple[sp.Expr, ...], ...]) -> bool:
    return all(is_zero(x) for row in m for x in row)


def _plus(d: tuple[tuple[sp.Expr, ...], ...], c: sp.Expr, k: tuple[tuple[sp.Expr, ...], ...]
          ) -> tuple[tuple[sp.Expr, ...], ...]:
    """``D + c K`` entry by entry."""
    return tuple(tuple(dd + c * kk for dd, kk in zip(dr, kr, strict=True))
                 for dr, kr in zip(d, k, strict=True))


@dataclass(frozen=True)
class Bushing(ForceElement):
    """A linear 6-DOF spring–damper (bushing) between ``point_a`` of ``frame_a`` and
    ``point_b`` of ``frame_b``.

    With ``Δr`` the position of B's point relative to A's point and ``θ`` the small-rotation
    measure of ``R = S_Aᵀ S_B`` (``θ = ½ vex(R − Rᵀ)``), both in frame A's components, and
    ``ω_rel`` the angular velocity of B relative to A (A components), the element acts on B
    with the force and torque (A components)

    ``f = −(K_t Δr + D_t Δṙ)``, ``l = −(K_r θ + D_r ω_rel)``

    (``Δṙ`` the derivative of ``Δr`` as seen in A); reactions act on A. The translational
    part is derived from its potential ``½ Δrᵀ K_t Δr`` exactly (generalized force
    ``−(∂Δr/∂y)ᵀ (K_t Δr + D_t Δṙ)``); the rotational part is the small-rotation law. It is at
    rest where the two points coincide and the frames are parallel.

    ``loss_factor`` η ≥ 0 (parameters only): hysteretic damping ``K(1 + iη)`` on both
    stiffness matrices in the frequency domain; in the time domain the viscous equivalent
    ``(η/ω_ref) K_t``, ``(η/ω_ref) K_r`` is added to ``D_t``, ``D_r`` (equations.md §1.1).
    """

    type_name = "bushing"
    keys = (
        Key("between", "frames", ("frame_a", "frame_b"), required=True),
        Key("points", "points", ("point_a", "point_b"), scope="kinematic"),
        Key("stiffness", "matrix", scope="dynamic"),
        Key("damping", "matrix", scope="dynamic"),
        Key("rotational_stiffness", "matrix", scope="dynamic"),
        Key("rotational_damping", "matrix", scope="dynamic"),
        LOSS_FACTOR,
    )
    components = ("fx", "fy", "fz", "mx", "my", "mz")

    name: str
    frame_a: str
    frame_b: str
    stiffness: sp.ImmutableMatrix = field(default_factory=_zero33)
    damping: sp.ImmutableMatrix = field(default_factory=_zero33)
    rotational_stiffness: sp.ImmutableMatrix = field(default_factory=_zero33)
    rotational_damping: sp.ImmutableMatrix = field(default_factory=_zero33)
    point_a: sp.ImmutableMatrix = field(default_factory=_zero3)
    point_b: sp.ImmutableMatrix = field(default_factory=_zero3)
    enabled: sp.Expr = _ONE
    loss_factor: sp.Expr = _ZERO

    def __post_init__(self) -> None:
        for attr in ("stiffness", "damping", "rotational_stiffness", "rotational_damping"):
            m = getattr(self, attr)
            if not isinstance(m, sp.MatrixBase) or m.shape != (3, 3):
                raise ModelError(
                    f"expected a 3×3 matrix, got {getattr(m, 'shape', type(m).__name__)}",
                    f"{self.path}.{attr}",
                )

    def loads(self, kin: KinematicsView, omega_ref: sp.Expr | float) -> Loads:
        """All in A components. Translation: ``Δr = S_Aᵀ (r_PB − r_PA)``; its Jacobian
        columns ``c_j = J_PB,j − J_PA,j − J_RA,j × Δr`` (so that ``Δṙ = Σ c_j ẏ_j + c̄`` is the
        rate of ``Δr`` seen in A); ``f = K_t Δr + D_t Δṙ``, ``q_j += −c_j·f``.
        Rotation: ``θ = ½ (R_21 − R_12, R_02 − R_20, R_10 − R_01)`` of ``R = S_Aᵀ S_B``,
        ``l = −(K_r θ + D_r ω_rel)`` on B, ``q_j += (J_RB,j − J_RA,j)·l``.
        Reports ``fx … mz``: the force and torque on B.
        """
        ws = kin.workspace
        name, path = self.name, self.path
        A, B = self.frame_a, self.frame_b
        n = kin.n
        out = Loads.empty(n)
        Kt, Dt = _rows(self.stiffness), _rows(self.damping)
        Kr, Dr = _rows(self.rotational_stiffness), _rows(self.rotational_damping)
        eta = self.loss_factor
        if not is_zero(eta):        # the viscous equivalent (η/ω_ref) K of the loss factor
            Dt = _plus(Dt, eta / omega_ref, Kt)
            Dr = _plus(Dr, eta / omega_ref, Kr)

        if not (_is_zero_matrix(Kt) and _is_zero_matrix(Dt)):
            anc = kin.common_ancestor(A, B)
            pa = kin.relative_position(A, tuple(self.point_a), anc)
            pb = kin.relative_position(B, tuple(self.point_b), anc)
            dr = ws.let_vec(kin.express(sub(pb, pa), anc, A), f"dr_{name}")
            ka = kin.point(A, tuple(self.point_a), f"{path}.points[0]")
            kb = kin.point(B, tuple(self.point_b), f"{path}.points[1]")
            fa = kin.frames[A]
            cols = [
                ws.let_vec(
                    sub(sub(kin.express(kb.J[j], B, A), ka.J[j]), cross(fa.JR[j], dr)),
                    f"cb_{name}_{j}",
                )
                for j in range(n)
            ]
            cbar = sub(sub(kin.express(kb.vbar, B, A), ka.vbar), cross(fa.wbar, dr))
            rate = ws.let_vec(
                add(*(scale(v, cols[j]) for j, v in enumerate(kin.velocities)), cbar),
                f"drd_{name}",
            )
            f = ws.let_vec(add(mat_vec(Kt, dr), mat_vec(Dt, rate)), f"fb_{name}")
            if not is_zero(eta) and not _is_zero_matrix(Kt):
                out.add_matrix_loss(eta, Kt, cols)
            for j in range(n):
                term = dot(cols[j], f)
                if not is_zero(term):
                    out.generalized[j].append(-term)
            out.reported.update({"fx": -f[0], "fy": -f[1], "fz": -f[2]})
        else:
            out.reported.update({"fx": ZERO, "fy": ZERO, "fz": ZERO})

        if not (_is_zero_matrix(Kr) and _is_zero_matrix(Dr)):
            R = relative_rotation(kin, A, B)
            theta = ws.let_vec(
                tuple((R[c][b] - R[b][c]) / 2 for b, c in ((1, 2), (2, 0), (0, 1))),
                f"th_{name}",
            )
            w_rel, jr = relative_angular_velocity(kin, A, B, name)
            if not is_zero(eta) and not _is_zero_matrix(Kr):
                out.add_matrix_loss(eta, Kr, jr)
            torque = ws.let_vec(
                scale(-1, add(mat_vec(Kr, theta), mat_vec(Dr, w_rel))), f"lb_{name}"
            )
            for j in range(n):
                term = dot(jr[j], torque)
                if not is_zero(term):
                    out.generalized[j].append(term)
            out.reported.update({"mx": torque[0], "my": torque[1], "mz": torque[2]})
        else:
            out.reported.update({"mx": ZERO, "my": ZERO, "mz": ZERO})
        return out
