"""Holonomic constraints of closed kinematic loops: ``g``, ``G = ∂g/∂y``, ``∂g/∂t`` and ``γ``
(equations.md §1).

```
M ÿ + k = q + Gᵀ λ,     G ÿ + γ = 0,
γ = ∂(G ẏ + ∂g/∂t)/∂y · ẏ + ∂(G ẏ + ∂g/∂t)/∂t
```
The constraints are derived in closed form (fully substituted kinematics of the points they
involve) and differentiated symbolically; explicit time dependence through inputs follows the
chain rule ``∂/∂t + (∂/∂u) u̇ + (∂/∂u̇) ü`` (inputs ``d_<u>``, ``dd_<u>``). Code generation
eliminates the common subexpressions.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import sympy as sp

from ..errors import ModelError
from ..kinematics.algebra import ZERO3, Mat3, Vec3, add, mat_mul, mat_t_vec, mat_vec
from ..kinematics.rotations import IDENTITY, rotation_product
from ..model import (
    AXES,
    INERTIAL,
    CoincidenceConstraint,
    ExpressionConstraint,
    System,
    as_expr,
    input_rate_name,
    symbol,
    time,
)

if TYPE_CHECKING:
    import numpy as np

__all__ = ["ConstraintEquations", "check_constraints", "derive_constraints"]


@dataclass(frozen=True)
class ConstraintEquations:
    """Symbolic constraint quantities (all in closed form, no intermediates).

    Attributes
    ----------
    names
        Names of the scalar constraints (``CONSTRAINTS``).
    g
        ``g(y, t, u)`` (nc×1).
    G
        ``∂g/∂y`` (nc×n).
    g_t
        ``∂g/∂t`` (explicit, through inputs by the chain rule) (nc×1).
    gamma
        ``γ(y, ẏ, t, u)`` with ``G ÿ + γ = 0`` (nc×1).
    """

    names: tuple[str, ...]
    g: sp.ImmutableMatrix
    G: sp.ImmutableMatrix
    g_t: sp.ImmutableMatrix
    gamma: sp.ImmutableMatrix

    @property
    def nc(self) -> int:
        return len(self.names)


def _time_rates(system: System) -> dict[sp.Symbol, sp.Symbol | None]:
    rates: dict[sp.Symbol, sp.Symbol | None] = {}
    for u in system.inputs:
        d1, d2 = (symbol(input_rate_name(u.name, k)) for k in (1, 2))
        rates.update({u.symbol: d1, d1: d2, d2: None})
    return rates


def _dt(expr: sp.Expr, rates: Mapping[sp.Symbol, sp.Symbol | None], path: str) -> sp.Expr:
    """Explicit time derivative, through inputs by the chain rule."""
    free = expr.free_symbols
    out = expr.diff(time) if time in free else sp.S.Zero
    for u in sorted(free & rates.keys(), key=str):
        du = expr.diff(u)
        if du == 0:
            continue
        rate = rates[u]
        if rate is None:
            raise ModelError(
                f"γ would need the third time derivative of input {str(u)[3:]!r}", path
            )
        out += du * rate
    return out


class _Poses:
    """Absolute rotation ``S`` (frame → ISYS) and origin ``r_O`` (ISYS components) of frames,
    composed from the relative ones along the frame chain (closed form, only the frames
    needed; no velocities or Jacobians)."""

    def __init__(self, system: System) -> None:
        self.system = system
        self._cache: dict[str, tuple[Mat3, Vec3]] = {INERTIAL: (IDENTITY, ZERO3)}

    def pose(self, name: str) -> tuple[Mat3, Vec3]:
        if name not in self._cache:
            frame = self.system.frame_map[name]
            s_parent, r_parent = self.pose(frame.parent)
            a = rotation_product(tuple((axis, as_expr(angle))
                                       for axis, angle in frame.rotation))
            self._cache[name] = (
                mat_mul(s_parent, a),
                add(r_parent, mat_vec(s_parent, tuple(frame.translation))),
            )
        return self._cache[name]

    def position(self, frame: str, point: tuple, in_frame: str) -> Vec3:
        """``r_O + S p`` of a point in ISYS components, then resolved in ``in_frame``."""
        s_f, r_f = self.pose(frame)
        r = add(r_f, mat_vec(s_f, point))
        if in_frame == INERTIAL:
            return r
        return mat_t_vec(self.pose(in_frame)[0], r)


def derive_constraints(system: System) -> ConstraintEquations:
    """``g``, ``G``, ``∂g/∂t`` and ``γ`` of the system's constraints (equations.md §1).

    Coincidence constraints ``(r_B − r_A)·e_c`` use the absolute positions of the two points
    (``r_O + S p``, composed along the frame chains) resolved in the constraint's frame.

    Examples
    --------
    A point on a circle of radius 1 (``x² + z² − 1 = 0``): ``G = [2x, 2z]``,
    ``γ = 2ẋ² + 2ż²``.
    """
    names = system.constraint_names
    y = system.coordinate_symbols
    yd = system.velocity_symbols
    n = len(y)
    if not names:
        z = sp.ImmutableMatrix.zeros(0, 1)
        return ConstraintEquations((), z, sp.ImmutableMatrix.zeros(0, n), z, z)
    poses: _Poses | None = None
    rows: list[sp.Expr] = []
    for con in system.constraints:
        if isinstance(con, ExpressionConstraint):
            rows.append(con.expr)
        elif isinstance(con, CoincidenceConstraint):
            if poses is None:
                poses = _Poses(system)
            ra = poses.position(con.frame_a, tuple(con.point_a), con.in_frame)
            rb = poses.position(con.frame_b, tuple(con.point_b), con.in_frame)
            for c in con.components:
                i = AXES.index(c)
                rows.append(rb[i] - ra[i])
        else:  # pragma: no cover - System validation rejects other types
            raise ModelError(f"unsupported constraint {type(con).__name__}",
                             f"constraints.{con.name}")
    rates = _time_rates(system)
    g = sp.ImmutableMatrix(len(rows), 1, rows)
    G = g.jacobian(list(y)) if n else sp.zeros(len(rows), 0)
    paths = {nm: f"constraints.{c.name}" for c in system.constraints for nm in c.names}
    g_t = [_dt(e, rates, paths[nm]) for e, nm in zip(rows, names, strict=True)]
    gamma = []
    for i, nm in enumerate(names):
        gdot = sum((G[i, j] * yd[j] for j in range(n)), sp.S.Zero) + g_t[i]
        value = sum((gdot.diff(y[j]) * yd[j] for j in range(n)), sp.S.Zero)
        gamma.append(value + _dt(gdot, rates, paths[nm]))
    return ConstraintEquations(
        names,
        g,
        sp.ImmutableMatrix(G),
        sp.ImmutableMatrix(len(rows), 1, g_t),
        sp.ImmutableMatrix(len(rows), 1, gamma),
    )


def check_constraints(
    system: System, ce: ConstraintEquations, rtol: float = 1e-9
) -> None:
    """Check that the constraints are independent at the initial state.

    ``G`` is evaluated at the description's initial coordinates, the default parameters,
    ``t = 0`` and the default inputs; its rows must be linearly independent (rank ``nc``).

    Raises
    ------
    ModelError
        Naming each constraint whose row of ``G`` is a combination of the others (or zero):
        *redundant* if its residual ``g`` is the same combination of theirs (it adds no
        information), *inconsistent* otherwise (it contradicts them, no motion satisfies all).
    """
    if ce.nc == 0:
        return
    import numpy as np  # here: an unconstrained model is derived without NumPy

    values: dict[sp.Symbol, float] = {c.symbol: c.initial for c in system.coordinates}
    values.update({p.symbol: p.default for p in system.parameters})
    values[time] = 0.0
    for sym, expr in zip(system.input_symbols, system.input_defaults, strict=True):
        values[sym] = float(expr.xreplace(values).evalf())

    def num(m: sp.ImmutableMatrix) -> np.ndarray:
        try:
            return np.array(m.xreplace(values).evalf(), dtype=float).reshape(m.shape)
        except (TypeError, ValueError):
            return np.full(m.shape, np.nan)

    G, g = num(ce.G), num(ce.g).reshape(-1)
    if not (np.all(np.isfinite(G)) and np.all(np.isfinite(g))):
        return  # not evaluable at the initial state (e.g. outside a square root's domain)
    scale = max(float(np.abs(G).max()), 1e-300)
    report: list[str] = []
    first: list[str] = []
    item = {nm: c.name for c in system.constraints for nm in c.names}
    independent: list[int] = []
    for i in range(ce.nc):
        trial = [*independent, i]
        sv = np.linalg.svd(G[trial], compute_uv=False)
        if sv.size and sv[-1] > rtol * scale:
            independent.append(i)
            continue
        if not independent or not np.any(np.abs(G[i]) > rtol * scale):
            kind = "redundant" if abs(g[i]) <= 1e-9 * max(1.0, np.abs(g).max()) else "inconsistent"
            report.append(f"{ce.names[i]} ({kind}: zero Jacobian row)")
            first.append(item[ce.names[i]])
            continue
        coef, *_ = np.linalg.lstsq(G[independent].T, G[i], rcond=None)
        partners = [ce.names[k] for k, c in zip(independent, coef, strict=True)
                    if abs(c) > 1e-8 * np.abs(coef).max()]
        mismatch = abs(g[i] - coef @ g[independent])
        kind = "redundant" if mismatch <= 1e-9 * max(1.0, np.abs(g).max()) else "inconsistent"
        report.append(f"{ce.names[i]} ({kind}: its Jacobian row is a combination of "
                      f"{', '.join(partners)})")
        first.append(item[ce.names[i]])
    if report:
        raise ModelError(
            "the constraints are not independent at the initial state: " + "; ".join(report)
            + ". Remove the redundant constraints (list only independent ones) or fix the "
            "geometry",
            f"constraints.{first[0]}",
        )
