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

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import sympy as sp

from ..errors import ModelError
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
from ..model.algebra import ZERO3, Mat3, Vec3, add, mat_mul, mat_t_vec, mat_vec

__all__ = ["ConstraintEquations", "check_constraints", "dependent_rows", "derive_constraints"]


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
    Row by row, a row is independent of the rows accepted before it when its distance to
    their span exceeds ``rtol · max|G|`` (:func:`dependent_rows`; plain Python: a model with
    closed loops is derived without NumPy as well).

    Raises
    ------
    ModelError
        Naming each constraint whose row of ``G`` is a combination of the others (or zero):
        *redundant* if its residual ``g`` is the same combination of theirs (it adds no
        information), *inconsistent* otherwise (it contradicts them, no motion satisfies all).
    """
    if ce.nc == 0:
        return
    # sympy numbers, so that a bare symbol (an input default ``t`` or a parameter) becomes a
    # number that evaluates like any expression
    values: dict[sp.Symbol, sp.Expr] = {c.symbol: sp.Float(c.initial)
                                        for c in system.coordinates}
    values.update({p.symbol: sp.Float(p.default) for p in system.parameters})
    values[time] = sp.Float(0.0)
    for sym, expr in zip(system.input_symbols, system.input_defaults, strict=True):
        try:
            values[sym] = sp.Float(float(as_expr(expr).xreplace(values)))
        except (TypeError, ValueError):
            return  # an input not evaluable at t = 0: left to the integrator to report

    def num(m: sp.ImmutableMatrix) -> list[list[float]] | None:
        try:
            rows = [[float(v) for v in row] for row in m.xreplace(values).evalf().tolist()]
        except (TypeError, ValueError):
            return None
        return rows if all(math.isfinite(v) for row in rows for v in row) else None

    G, gm = num(ce.G), num(ce.g)
    if G is None or gm is None:
        return  # not evaluable at the initial state (e.g. outside a square root's domain)
    g = [row[0] for row in gm]
    g_scale = 1e-9 * max(1.0, max(abs(v) for v in g))
    report: list[str] = []
    first: list[str] = []
    item = {nm: c.name for c in system.constraints for nm in c.names}
    for i, combination in dependent_rows(G, rtol):
        if combination is None:
            kind = "redundant" if abs(g[i]) <= g_scale else "inconsistent"
            report.append(f"{ce.names[i]} ({kind}: zero Jacobian row)")
        else:
            largest = max(abs(c) for _, c in combination)
            partners = [ce.names[k] for k, c in combination if abs(c) > 1e-8 * largest]
            mismatch = abs(g[i] - sum(c * g[k] for k, c in combination))
            kind = "redundant" if mismatch <= g_scale else "inconsistent"
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


def dependent_rows(G: Sequence[Sequence[float]], rtol: float = 1e-9
                   ) -> list[tuple[int, list[tuple[int, float]] | None]]:
    """The rows of ``G`` that depend on the rows before them, with the combination.

    Rows are taken in order; row ``i`` is *independent* when its distance to the span of the
    independent rows before it exceeds ``rtol · max|G|``. That distance is the norm of the
    residual of modified Gram–Schmidt, orthogonalized twice (which makes the computed basis
    orthonormal to rounding, "twice is enough": Giraud et al., Numer. Math. 101 (2005)). The
    independent rows are ``G_I = R Q`` (``Q`` orthonormal rows, ``R`` lower triangular); a
    dependent row ``G_i ≈ a Q`` (``a = Q G_iᵀ``) is the combination ``c G_I`` with
    ``Rᵀ cᵀ = aᵀ`` — the least-squares solution of ``G_Iᵀ c = G_i``.

    Returns
    -------
    list
        ``(i, [(k, c_k), …])`` for each dependent row ``i`` (``k``: the independent rows), or
        ``(i, None)`` when the row is zero (below the tolerance) or nothing came before it.
    """
    scale = max((abs(v) for row in G for v in row), default=0.0)
    tol = rtol * max(scale, 1e-300)
    basis: list[list[float]] = []  # Q: orthonormal rows
    r_rows: list[list[float]] = []  # R: row j holds the coefficients of G_I[j] on Q[:j + 1]
    independent: list[int] = []
    out: list[tuple[int, list[tuple[int, float]] | None]] = []
    for i, row in enumerate(G):
        r = [float(v) for v in row]
        a = [0.0] * len(basis)
        for _ in range(2):
            for j, q in enumerate(basis):
                c = sum(qv * rv for qv, rv in zip(q, r, strict=True))
                a[j] += c
                r = [rv - c * qv for rv, qv in zip(r, q, strict=True)]
        norm = math.sqrt(sum(v * v for v in r))
        if norm > tol:
            basis.append([v / norm for v in r])
            r_rows.append([*a, norm])
            independent.append(i)
            continue
        if not independent or not any(abs(v) > tol for v in row):
            out.append((i, None))
            continue
        c = [0.0] * len(independent)  # Rᵀ c = a, R lower triangular: back substitution
        for j in reversed(range(len(independent))):
            c[j] = (a[j] - sum(r_rows[k][j] * c[k] for k in range(j + 1, len(independent)))
                    ) / r_rows[j][j]
        out.append((i, list(zip(independent, c, strict=True))))
    return out
