"""Static equilibrium by Newton's method with the analytic stiffness (equations.md §1).

At rest (``ẏ = 0``) the equations of motion reduce to ``F(y) = (q − k)(y, 0, u) = 0``; with
holonomic constraints to ``F(y) + G(y)ᵀ λ = 0``, ``g(y) = 0`` (``M ÿ + k = q + Gᵀ λ`` at
``ÿ = ẏ = 0``).
Newton's method uses the symbolically generated ``∂F/∂y`` (``force_jacobians``); the curvature term
``∂(Gᵀλ)/∂y`` of constrained systems is a central difference of the analytic ``G``. Steps are
limited to ``max_step`` per coordinate and damped by a backtracking line search on ``½‖R‖²``.

A singular Jacobian is analysed: the null space of the stiffness (restricted to the motions the
constraints allow) names the coordinates without stiffness; a rank-deficient ``G`` names the
redundant constraints. Such coordinates can be held at their start values with ``fixed``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import SolverError
from . import _protocol as proto

__all__ = ["EquilibriumResult", "equilibrium"]


@dataclass(frozen=True)
class EquilibriumResult:
    """A static equilibrium.

    Attributes
    ----------
    y : ndarray (n,)
        Coordinates at equilibrium.
    lambda_ : ndarray (nc,)
        Constraint multipliers (the generalized constraint forces are ``Gᵀ λ``).
    residual : float
        ``max |R|`` of the equilibrium equations at ``y``.
    iterations : int
        Newton iterations used.
    coordinates, constraints : tuple of str
    p, u : ndarray
        Parameters and inputs the equilibrium holds for.
    t : float
    """

    y: np.ndarray
    lambda_: np.ndarray
    residual: float
    iterations: int
    coordinates: tuple[str, ...]
    constraints: tuple[str, ...]
    p: np.ndarray
    u: np.ndarray
    t: float = 0.0

    @property
    def state(self) -> np.ndarray:
        """First-order state ``[y, 0]``."""
        return np.concatenate([self.y, np.zeros_like(self.y)])

    def as_dict(self) -> dict[str, float]:
        """Coordinate (and ``lambda_<constraint>``) name → value."""
        out = {c: float(v) for c, v in zip(self.coordinates, self.y, strict=True)}
        out.update(
            {f"lambda_{c}": float(v) for c, v in zip(self.constraints, self.lambda_, strict=True)}
        )
        return out

    def table(self) -> str:
        """A two-column text table of :meth:`as_dict`."""
        items = self.as_dict()
        width = max((len(k) for k in items), default=4)
        lines = [f"{k:<{width}}  {v: .12g}" for k, v in items.items()]
        lines.append(f"# residual {self.residual:.3g} after {self.iterations} Newton iteration(s)")
        return "\n".join(lines)


def _diagnose(
    module: Any,
    names: Sequence[str],
    cnames: Sequence[str],
    free: np.ndarray,
    k_mat: np.ndarray,
    g_free: np.ndarray,
) -> str:
    """Why the equilibrium Jacobian is singular: redundant constraints or missing stiffness."""
    if len(cnames):
        redundant = proto.redundant_constraints(g_free, list(cnames))
        if redundant:
            return "redundant constraints: " + "; ".join(redundant)
        basis, _ = proto.null_space(g_free)
    else:
        basis = np.eye(free.size)
    kr = basis.T @ k_mat @ basis
    ns, _ = proto.null_space(kr, rtol=1e-10)
    who = proto.participating_names(basis @ ns, [names[i] for i in free])
    return (
        "singular stiffness matrix: no stiffness in the motion of coordinate(s) "
        + ", ".join(who)
        + " (hold them with fixed=[...] / --fix, or add springs)"
    )


def equilibrium(
    module: Any,
    p: proto.ParameterLike = None,
    u: Mapping[str, float] | Sequence[float] | None = None,
    y0: Mapping[str, float] | Sequence[float] | np.ndarray | None = None,
    t: float = 0.0,
    *,
    fixed: Sequence[str] = (),
    xtol: float = 1e-11,
    maxiter: int = 50,
    max_step: float = 1.0,
) -> EquilibriumResult:
    """Static equilibrium of a generated module (equations.md §1).

    Solves ``F(y) = (q − k)(y, ẏ = 0, u) = 0`` — and, with constraints, ``F + Gᵀ λ = 0``,
    ``g(y) = 0`` — by damped Newton iterations with the analytic stiffness ``∂F/∂y``.

    Parameters
    ----------
    module
        A generated module (or its path).
    p
        Parameters (``None``: defaults; mapping: overrides by name; array).
    u
        Inputs held constant (``None``: ``default_inputs(t, p)``).
    y0
        Start of the iteration (default: the module's initial coordinates); mapping or array.
    t
        Time at which forces and constraints are evaluated.
    fixed
        Coordinates held at their start values (their equations are dropped: the force that holds
        them is not part of the result).
    xtol
        Converged when a full Newton step is below ``xtol · (1 + ‖y‖∞)``, or the residual is at
        round-off level.
    maxiter
        Maximum number of Newton iterations.
    max_step
        Largest change of any coordinate in one iteration (longer Newton steps are shortened,
        keeping their direction), so that e.g. a pendulum started near the horizontal does not
        jump several revolutions.

    Returns
    -------
    EquilibriumResult

    Raises
    ------
    SolverError
        On non-convergence (carrying the last iterate, the residual and the coordinate names) or a
        singular Jacobian (naming coordinates without stiffness or redundant constraints).
    """
    module = proto.load_module(module)
    names = proto.coordinate_names(module)
    n = len(names)
    cnames = list(getattr(module, "CONSTRAINTS", []) or [])
    nc = len(cnames)
    pv = proto.resolve_parameters(module, p)
    uv = proto.resolve_inputs(module, t, pv, u)
    y_init = np.asarray(module.INITIAL_STATE, dtype=float)[:n].copy()
    y = proto.override_vector(y_init, names, y0, "coordinate").copy()
    fixed_idx = {proto.name_index(names, nm, "coordinate") for nm in fixed}
    free = np.array([i for i in range(n) if i not in fixed_idx], dtype=int)
    nf = free.size
    zero = np.zeros(n)

    def residual(yv: np.ndarray, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        force = np.asarray(module.force_vector(t, yv, zero, pv, uv), dtype=float)
        if nc:
            gj = np.asarray(module.constraint_jacobian(t, yv, pv), dtype=float).reshape(nc, n)
            g = np.asarray(module.constraints(t, yv, pv), dtype=float)
            return np.concatenate([(force + gj.T @ lam)[free], g]), force
        return force[free], force

    def jacobian(yv: np.ndarray, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        f_y = np.asarray(module.force_jacobians(t, yv, zero, pv, uv)[0], dtype=float)
        if not nc:
            return f_y[np.ix_(free, free)], f_y, np.zeros((0, nf))
        gj = np.asarray(module.constraint_jacobian(t, yv, pv), dtype=float).reshape(nc, n)
        k_full = f_y + proto.constraint_force_jacobian(module, t, yv, pv, lam)
        jac = np.zeros((nf + nc, nf + nc))
        jac[:nf, :nf] = k_full[np.ix_(free, free)]
        jac[:nf, nf:] = gj[:, free].T
        jac[nf:, :nf] = gj[:, free]
        return jac, k_full, gj[:, free]

    lam = np.zeros(nc)
    if nc:  # least-squares multipliers at the start point
        force = np.asarray(module.force_vector(t, y, zero, pv, uv), dtype=float)
        gj = np.asarray(module.constraint_jacobian(t, y, pv), dtype=float).reshape(nc, n)
        lam = np.linalg.lstsq(gj[:, free].T, -force[free], rcond=None)[0]

    r, _ = residual(y, lam)
    iterations = 0
    stalled = 0
    converged = False
    for _ in range(maxiter + 1):
        jac, k_full, g_free = jacobian(y, lam)
        scale = max(np.abs(jac).max(initial=0.0), 1e-300)
        size = 1.0 + np.abs(np.concatenate([y, lam])).max(initial=0.0)
        roundoff = 1e3 * np.finfo(float).eps * scale * size
        if np.abs(r).max(initial=0.0) <= roundoff:
            converged = True
            break
        if iterations == maxiter:
            break
        iterations += 1
        sv = np.linalg.svd(jac, compute_uv=False)
        if not sv.size or sv[0] == 0 or sv[-1] <= 1e-12 * sv[0]:
            raise SolverError(
                "equilibrium: " + _diagnose(module, names, cnames, free, k_full, g_free),
                last_iterate=y.copy(),
                residual=float(np.abs(r).max(initial=0.0)),
                names=names,
            )
        step = np.linalg.solve(jac, -r)
        longest = np.abs(step[:nf]).max(initial=0.0)
        alpha = 1.0 if longest <= max_step else max_step / longest
        merit = 0.5 * r @ r
        while True:
            y_try = y.copy()
            y_try[free] += alpha * step[:nf]
            lam_try = lam + alpha * step[nf:]
            r_try, _ = residual(y_try, lam_try)
            if 0.5 * r_try @ r_try <= (1 - 1e-4 * alpha) * merit or alpha < 1e-8:
                break
            alpha *= 0.5
        y, lam, r = y_try, lam_try, r_try
        stalled = stalled + 1 if 0.5 * r @ r > 0.99 * merit else 0
        if stalled >= 5:
            break
        if alpha == 1.0 and np.abs(step[:nf]).max(initial=0.0) <= xtol * (
            1.0 + np.abs(y).max(initial=0.0)
        ):
            converged = True
            break
    if not converged:
        worst = int(np.argmax(np.abs(r)))
        eq_names = [names[i] for i in free] + [f"constraint {c}" for c in cnames]
        why = (
            "the line search stalled at a local minimum of the residual (no equilibrium near "
            "the start? try another y0)"
            if stalled >= 5
            else f"no convergence in {maxiter} iterations"
        )
        raise SolverError(
            f"equilibrium: Newton failed, {why}; residual "
            f"{np.abs(r).max():.3g} (largest in the equation of {eq_names[worst]}); last iterate "
            + ", ".join(f"{nm}={v:.6g}" for nm, v in zip(names, y, strict=True)),
            last_iterate=y.copy(),
            residual=float(np.abs(r).max()),
            names=names,
        )
    return EquilibriumResult(
        y=y,
        lambda_=lam,
        residual=float(np.abs(r).max(initial=0.0)),
        iterations=iterations,
        coordinates=tuple(names),
        constraints=tuple(cnames),
        p=pv,
        u=uv,
        t=float(t),
    )
