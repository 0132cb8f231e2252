"""Absolute kinematics of the frame tree, computed recursively parent → child in body-fixed
components (equations.md §1).

For a frame K with parent P, relative rotation ``A`` (K → P components) and relative origin
``r`` (P components), everything in K components:

```
J_T,K = Aᵀ (J_T,P + J_R,P × r + ∂r/∂y)          v̄_K = Aᵀ (v̄_P + ω̄_P × r + ∂r/∂t)
J_R,K = Aᵀ J_R,P + ∂ω_rel/∂ẏ                    ω̄_K = Aᵀ ω̄_P + ω̄_rel
ω_K   = Aᵀ ω_P + ω_rel
ā_K   = Aᵀ (ā_P + ᾱ_P × r + ω_P × (ω_P × r) + 2 ω_P × ṙ + r̈̄)
ᾱ_K   = Aᵀ ᾱ_P + (Aᵀ ω_P) × ω_rel + ω̇̄_rel
g_K   = Aᵀ g_P                                    (gravity in K components)
```
with ``ω_rel = Σ_i u_i φ̇_i`` (:func:`~neweul_py.kinematics.rotations.rotation_axes`),
``ṙ = ∂r/∂y ẏ + ∂r/∂t`` and the bars the parts without ÿ: ``r̈̄ = ∂ṙ/∂y ẏ + ∂ṙ/∂t``,
``ω̇̄_rel = ∂ω_rel/∂y ẏ + ∂ω_rel/∂t``. Then ``v_K = J_T,K ẏ + v̄_K``,
``a_K = J_T,K ÿ + ā_K`` etc., all in K components.

Frame kinematics may depend on coordinates and explicitly on time ``t`` (prescribed motion),
directly or through inputs ``u(t)`` (kinematic excitation): the explicit time
derivative is then taken by the chain rule, ``∂/∂t + Σ_u (∂/∂u) u̇ + (∂/∂u̇) ü``, with ``u̇``,
``ü`` the input-vector entries ``d_<u>``, ``dd_<u>`` (:attr:`~neweul_py.model.System.input_names`).
A third derivative of an input is never needed by rigid kinematics (positions may use ``u``
only); a model that would need one raises :class:`~neweul_py.errors.ModelError`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import sympy as sp

from ..errors import ModelError
from ..model import INERTIAL, Frame, System, as_expr, input_rate_name, symbol, time
from ..model.algebra import (
    ZERO,
    ZERO3,
    Mat3,
    Vec3,
    add,
    cross,
    is_zero,
    mat_mul,
    mat_t_vec,
    mat_vec,
    scale,
    total,
    vec_is_zero,
)
from ..model.canonical import mul
from ..progress import StagedProgress, Steps
from .rotations import IDENTITY, rotation_axes, rotation_product
from .workspace import Workspace

__all__ = ["FrameKinematics", "Kinematics", "PointKinematics", "absolute_kinematics"]

Form = Literal["closed", "recursive"]


@dataclass(frozen=True)
class FrameKinematics:
    """Absolute kinematics of one frame, all vectors in the frame's own components.

    Attributes
    ----------
    name, parent
        The frame and its parent.
    relative_rotation
        ``A`` (frame → parent components).
    relative_translation
        ``r`` (origin in parent components).
    JT, JR
        Translational and rotational Jacobians ``J_T``, ``J_R``: one 3-vector per coordinate.
    vbar, wbar
        ``v̄``, ``ω̄`` (the velocity parts not proportional to ẏ, from explicit time dependence).
    omega
        ``ω`` (full angular velocity, depends on ẏ).
    abar, alphabar
        ``ā``, ``ᾱ``.
    gravity
        The gravitational acceleration in frame components.
    local_JT, local_JR
        The frame's own part of the Jacobians, ``∂r/∂y_j`` (*parent* components) and
        ``∂ω_rel/∂ẏ_j`` (frame components), one 3-vector per coordinate (zero where the
        relative kinematics does not depend on ``y_j``). With them ``J_K = X_K J_P + H_K``;
        ``J_Kᵀ (f, n) = J_Pᵀ (A f, A n + r × A f) + (∂r/∂y)ᵀ A f + J_R,relᵀ n`` lets
        products ``Jᵀ(·)`` be evaluated by a backward recursion over the tree.
    """

    name: str
    parent: str
    relative_rotation: Mat3
    relative_translation: Vec3
    JT: tuple[Vec3, ...]
    JR: tuple[Vec3, ...]
    vbar: Vec3
    wbar: Vec3
    omega: Vec3
    abar: Vec3
    alphabar: Vec3
    gravity: Vec3
    local_JT: tuple[Vec3, ...] = ()
    local_JR: tuple[Vec3, ...] = ()


@dataclass(frozen=True)
class PointKinematics:
    """Jacobian and velocity of a point fixed (or prescribed) in a frame, frame components:
    ``v_P = J ẏ + v̄``."""

    frame: str
    J: tuple[Vec3, ...]
    vbar: Vec3


class Kinematics:
    """Absolute kinematics of every frame of a system (equations.md §1).

    Create it with :func:`absolute_kinematics`. Quantities that are not needed by every
    derivation (rotation matrices to ISYS, positions, transformations between frames, point
    kinematics) are computed on request; in recursive form their intermediates are appended to
    :attr:`workspace` at that moment, after everything they depend on.
    """

    def __init__(self, system: System, workspace: Workspace,
                 progress: StagedProgress = None) -> None:
        self.system = system
        self.workspace = workspace
        self.coordinates = system.coordinate_symbols
        self.velocities = system.velocity_symbols
        self.n = len(self.coordinates)
        self._index = {c.name: j for j, c in enumerate(system.coordinates)}
        self._inputs = frozenset(u.symbol for u in system.inputs)
        # explicit time dependence through inputs: u → d_u → dd_u (→ not available)
        self._input_rates: dict[sp.Symbol, sp.Symbol | None] = {}
        for u in system.inputs:
            d1, d2 = (symbol(input_rate_name(u.name, k)) for k in (1, 2))
            self._input_rates.update({u.symbol: d1, d1: d2, d2: None})
        self.frames: dict[str, FrameKinematics] = {}
        self._own_origin: dict[str, Vec3] = {}
        self._rotation: dict[str, Mat3] = {}
        self._position: dict[str, Vec3] = {}
        g = tuple(system.gravity)
        zero_j = tuple(ZERO3 for _ in range(self.n))
        self.frames[INERTIAL] = FrameKinematics(
            INERTIAL, "", IDENTITY, ZERO3, zero_j, zero_j, ZERO3, ZERO3, ZERO3, ZERO3, ZERO3, g
        )
        step = Steps(progress, "kinematics", len(system.frames))
        for frame in system.frames_topological:
            self.frames[frame.name] = self._frame(frame)
            step()

    # ------------------------------------------------------------------ helpers
    @property
    def intermediates(self) -> tuple[tuple[sp.Symbol, sp.Expr], ...]:
        """The ordered intermediate assignments emitted so far (empty in closed form)."""
        return tuple(self.workspace.assignments)

    def coordinate_index(self, name: str) -> int:
        """The position ``j`` of the coordinate ``name`` in ``y``."""
        return self._index[name]

    def _check_no_inputs(self, exprs: Sequence[sp.Expr], where: str) -> None:
        """Inputs may appear in kinematics (kinematic excitation); their derivatives, which
        only force laws and outputs may use, must not."""
        for e in exprs:
            bad = sorted(
                str(s) for s in e.free_symbols if s in self._input_rates and s not in self._inputs
            )
            if bad:
                raise ModelError(
                    f"time derivative(s) {', '.join(bad)} of inputs appear in kinematics; "
                    "positions and angles may use the inputs themselves only",
                    where,
                )

    def partials(self, expr: sp.Expr) -> tuple[list[sp.Expr], sp.Expr]:
        """``∂expr/∂y_j`` for all j and the explicit time derivative ``∂expr/∂t``, through
        inputs by the chain rule (zeros where expr does not depend)."""
        free = expr.free_symbols
        dy = [expr.diff(y) if y in free else ZERO for y in self.coordinates]
        dt = expr.diff(time) if time in free else ZERO
        for u in sorted(free & self._input_rates.keys(), key=str):
            rate = self._input_rates[u]
            du = expr.diff(u)
            if is_zero(du):
                continue
            if rate is None:
                raise ModelError(
                    f"the kinematics would need the third time derivative of input "
                    f"{str(u)[3:]!r}; positions and angles may use inputs, not their derivatives"
                )
            dt = dt + du * rate
        return dy, dt

    def _rate(self, dy: Sequence[sp.Expr], dt: sp.Expr) -> sp.Expr:
        """``Σ_j dy_j ẏ_j + dt``."""
        terms = [mul(d, v) for d, v in zip(dy, self.velocities, strict=True) if not is_zero(d)]
        return total([*terms, dt])

    def bar_rate(self, expr: sp.Expr) -> sp.Expr:
        """Time derivative without ÿ terms: ``Σ_j ∂expr/∂y_j ẏ_j + ∂expr/∂t``."""
        dy, dt = self.partials(expr)
        return self._rate(dy, dt)

    # ------------------------------------------------------------------ recursion
    def _frame(self, frame: Frame) -> FrameKinematics:
        ws = self.workspace
        name = frame.name
        parent = self.frames[frame.parent]
        rotation = tuple((axis, as_expr(angle)) for axis, angle in frame.rotation)
        translation: Vec3 = tuple(frame.translation)  # type: ignore[assignment]
        self._check_no_inputs([a for _, a in rotation] + list(translation), f"frames.{name}")
        n = self.n

        # -- relative kinematics, model-level expressions (small; differentiated directly)
        A = rotation_product(rotation)
        axes = rotation_axes(rotation)
        dphi = [self.partials(angle) for _, angle in rotation]
        JR_rel = [
            add(*(scale(dphi[i][0][j], axes[i]) for i in range(len(rotation))))
            for j in range(n)
        ]
        wbar_rel = add(*(scale(dphi[i][1], axes[i]) for i in range(len(rotation))))
        w_rel = add(*(scale(v, JR_rel[j]) for j, v in enumerate(self.velocities)), wbar_rel)
        wdot_rel = tuple(self.bar_rate(x) for x in w_rel)
        dr = [self.partials(x) for x in translation]
        dr_dy = [tuple(dr[i][0][j] for i in range(3)) for j in range(n)]
        dr_dt = tuple(dr[i][1] for i in range(3))
        rdot = tuple(self._rate(dr[i][0], dr[i][1]) for i in range(3))
        rddot = tuple(self.bar_rate(x) for x in rdot)

        if ws.recursive:
            # name cos/sin of the joint angles once, and use the names in everything relative
            trig: dict[sp.Expr, sp.Expr] = {}
            for k, (_axis, angle) in enumerate(rotation):
                for fn, tag in ((sp.cos, "c"), (sp.sin, "s")):
                    value = fn(angle)
                    if not value.is_Number and value not in trig:
                        trig[value] = ws.let(value, f"{tag}_{name}_{k}")

            def rep(v: Sequence[sp.Expr]) -> tuple[sp.Expr, ...]:
                return tuple(x.xreplace(trig) for x in v) if trig else tuple(v)

            A = ws.let_mat(tuple(rep(row) for row in A), f"A_{name}")  # type: ignore[assignment]
            JR_rel = [rep(c) for c in JR_rel]
            wbar_rel, w_rel, wdot_rel = rep(wbar_rel), rep(w_rel), rep(wdot_rel)
            translation = ws.let_vec(translation, f"r_{name}")  # type: ignore[assignment]
            dr_dy = [rep(c) for c in dr_dy]
            dr_dt, rdot, rddot = rep(dr_dt), rep(rdot), rep(rddot)
            w_rel = ws.let_vec(w_rel, f"wrel_{name}")

        r = translation

        def at(v: Sequence[sp.Expr]) -> Vec3:
            return mat_t_vec(A, v)

        JT = tuple(
            ws.let_vec(at(add(parent.JT[j], cross(parent.JR[j], r), dr_dy[j])), f"JT_{name}_{j}")
            for j in range(n)
        )
        JR = tuple(
            ws.let_vec(add(at(parent.JR[j]), JR_rel[j]), f"JR_{name}_{j}") for j in range(n)
        )
        vbar = ws.let_vec(at(add(parent.vbar, cross(parent.wbar, r), dr_dt)), f"vb_{name}")
        wbar = ws.let_vec(add(at(parent.wbar), wbar_rel), f"wb_{name}")
        w_par = ws.let_vec(at(parent.omega), f"wp_{name}")
        omega = ws.let_vec(add(w_par, w_rel), f"w_{name}")
        alphabar = ws.let_vec(
            add(at(parent.alphabar), cross(w_par, w_rel), wdot_rel), f"alb_{name}"
        )
        wp = parent.omega
        abar_parent = add(
            parent.abar,
            cross(parent.alphabar, r),
            cross(wp, cross(wp, r)),
            scale(2, cross(wp, rdot)),
            rddot,
        )
        abar = ws.let_vec(at(abar_parent), f"ab_{name}")
        gravity = ws.let_vec(at(parent.gravity), f"g_{name}")
        return FrameKinematics(
            name, frame.parent, A, r, JT, JR, vbar, wbar, omega, abar, alphabar, gravity,
            tuple(dr_dy), tuple(JR_rel),  # type: ignore[arg-type]
        )

    # ------------------------------------------------------------------ frames and vectors
    def chain(self, name: str) -> tuple[str, ...]:
        """Frame names from ISYS down to ``name`` (inclusive)."""
        return (INERTIAL, *(f.name for f in self.system.frame_chain(name)))

    def express(self, v: Sequence[sp.Expr], from_frame: str, to_frame: str) -> Vec3:
        """The components in ``to_frame`` of a vector given in ``from_frame`` components,
        through the frames' common ancestor (relative rotations only)."""
        v = tuple(v)
        if from_frame == to_frame:
            return v  # type: ignore[return-value]
        up, down = self.chain(from_frame), self.chain(to_frame)
        k = 0
        while k < min(len(up), len(down)) and up[k] == down[k]:
            k += 1
        ws = self.workspace
        for name in reversed(up[k:]):  # from_frame up to the common ancestor
            v = ws.let_vec(mat_vec(self.frames[name].relative_rotation, v), f"x_{name}")
        for name in down[k:]:  # then down to to_frame
            v = ws.let_vec(mat_t_vec(self.frames[name].relative_rotation, v), f"x_{name}")
        return v  # type: ignore[return-value]

    def rotation_matrix(self, name: str) -> Mat3:
        """``S`` of the frame: its components → ISYS components."""
        if name == INERTIAL:
            return IDENTITY
        if name not in self._rotation:
            fk = self.frames[name]
            s = mat_mul(self.rotation_matrix(fk.parent), fk.relative_rotation)
            self._rotation[name] = self.workspace.let_mat(s, f"S_{name}")  # type: ignore
        return self._rotation[name]

    def origin_in_frame(self, name: str) -> Vec3:
        """Position of the frame's origin relative to ISYS's, in the frame's own components."""
        if name == INERTIAL:
            return ZERO3
        if name not in self._own_origin:
            fk = self.frames[name]
            v = mat_t_vec(
                fk.relative_rotation, add(self.origin_in_frame(fk.parent), fk.relative_translation)
            )
            self._own_origin[name] = self.workspace.let_vec(v, f"o_{name}")  # type: ignore
        return self._own_origin[name]

    def origin(self, name: str) -> Vec3:
        """``r`` of the frame: position of its origin in ISYS components."""
        if name == INERTIAL:
            return ZERO3
        if name not in self._position:
            fk = self.frames[name]
            v = add(
                self.origin(fk.parent),
                mat_vec(self.rotation_matrix(fk.parent), fk.relative_translation),
            )
            self._position[name] = self.workspace.let_vec(v, f"r0_{name}")  # type: ignore
        return self._position[name]

    # ------------------------------------------------------------------ points
    def point_position(
        self, frame: str, point: Sequence[sp.Expr], in_frame: str = INERTIAL
    ) -> Vec3:
        """Absolute position (from ISYS's origin) of ``point`` (``frame`` components) in
        ``in_frame`` components."""
        return self.express(add(self.origin_in_frame(frame), tuple(point)), frame, in_frame)

    def relative_position(
        self, frame: str, point: Sequence[sp.Expr], ancestor: str
    ) -> Vec3:
        """Position of ``point`` of ``frame`` relative to the origin of ``ancestor`` (which must
        be on the frame's chain), in ``ancestor`` components."""
        v: Vec3 = tuple(point)  # type: ignore[assignment]
        name = frame
        while name != ancestor:
            fk = self.frames[name]
            v = self.workspace.let_vec(
                add(fk.relative_translation, mat_vec(fk.relative_rotation, v)), f"p_{name}"
            )  # type: ignore[assignment]
            name = fk.parent
        return v

    def point(self, frame: str, point: Sequence[sp.Expr], where: str = "") -> PointKinematics:
        """Jacobian and ``v̄`` of a point of a frame, in the frame's components:
        ``J_P = J_T − p̃ J_R + ∂p/∂y``, ``v̄_P = v̄ + ω̄ × p + ∂p/∂t``."""
        p: Vec3 = tuple(point)  # type: ignore[assignment]
        self._check_no_inputs(p, where or f"frames.{frame}")
        fk = self.frames[frame]
        d = [self.partials(x) for x in p]
        ws = self.workspace
        if vec_is_zero(p):
            return PointKinematics(frame, fk.JT, fk.vbar)
        J = tuple(
            ws.let_vec(
                add(fk.JT[j], cross(fk.JR[j], p), tuple(d[i][0][j] for i in range(3))),
                f"JP_{frame}_{j}",
            )
            for j in range(self.n)
        )
        vbar = ws.let_vec(
            add(fk.vbar, cross(fk.wbar, p), tuple(d[i][1] for i in range(3))), f"vP_{frame}"
        )
        return PointKinematics(frame, J, vbar)  # type: ignore[arg-type]

    def velocity(self, pk: PointKinematics) -> Vec3:
        """``J ẏ + v̄`` (components of the point's frame)."""
        return tuple(
            total([*(mul(c[i], v) for c, v in zip(pk.J, self.velocities, strict=True)
                     if not is_zero(c[i])), pk.vbar[i]])
            for i in range(3)
        )  # type: ignore[return-value]

    def common_ancestor(self, a: str, b: str) -> str:
        """The deepest frame on both chains (ISYS at least)."""
        ca, cb = self.chain(a), self.chain(b)
        k = 0
        while k < min(len(ca), len(cb)) and ca[k] == cb[k]:
            k += 1
        return ca[k - 1]


def absolute_kinematics(system: System, form: Form = "closed",
                        progress: StagedProgress = None) -> Kinematics:
    """Absolute kinematics of all frames of ``system`` (equations.md §1).

    Parameters
    ----------
    system
        The model.
    form
        ``"closed"``: every quantity fully substituted; ``"recursive"``: intermediates emitted
        into ``Kinematics.workspace`` (``docs/architecture.md``, "Rigid bodies").
    progress
        ``progress("kinematics", done, total)`` after each frame (:mod:`neweul_py.progress`).

    Returns
    -------
    Kinematics
        ``frames[name]`` holds the :class:`FrameKinematics` of each frame (and ISYS).

    Raises
    ------
    ModelError
        If a time derivative of an input appears in a frame's translation or rotation.

    Examples
    --------
    >>> import sympy as sp
    >>> from neweul_py.model import Coordinate, Frame, System, symbol
    >>> s = System("p", coordinates=(Coordinate("a"),),
    ...            frames=(Frame("f", rotation=(("z", symbol("a")),)),))
    >>> absolute_kinematics(s).frames["f"].JR[0]
    (0, 0, 1)
    """
    if form not in ("closed", "recursive"):
        raise ValueError(f"form must be 'closed' or 'recursive', not {form!r}")
    reserved = {str(s) for s in (*system.coordinate_symbols, *system.velocity_symbols)}
    return Kinematics(system, Workspace(form == "recursive", reserved), progress)

