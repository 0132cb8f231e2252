"""Static equilibrium by Newton's method with the analytic stiffness (equations.md §1).

At rest (``ẏ = 0``) the equations of motion reduce to ``F(y) = (q − k)(y, 0, u) = 0``; with
holonomic constraints to ``F(y) + G_R(y)ᵀ λ = 0``, ``g(y) = 0`` (``M ÿ + k = q + G_Rᵀ λ`` at
``ÿ = ẏ = 0``; ``G_R`` the reaction Jacobian, ``= G = ∂g/∂y`` but for constraints on node
frames of two-sided elastic bodies:
:func:`~neweul_py.analysis.protocol.constraint_reaction_jacobian`).
Newton's method uses the symbolically generated ``∂F/∂y`` (``force_jacobians``); the curvature term
``∂(G_Rᵀλ)/∂y`` of constrained systems is a central difference of the analytic ``G_R``. Steps are
limited to ``max_step`` per coordinate and damped by a backtracking line search on ``½‖R‖²``.

When Newton's method stalls (a local minimum of ``‖R‖`` that is no equilibrium), meets a singular
Jacobian or runs out of iterations, the search is globalized by pseudo-transient continuation
(Kelley & Keyes 1998) from the start: backward-Euler steps of the fictitious damped motion
``M dy/dτ = F + G_Rᵀλ`` (kinetic metric ``M``, constraints solved at every step), the pseudo-time
step growing by switched evolution relaxation until the iteration is plain Newton. The motion
settles in a stable equilibrium — the one the start falls into.

A singular Jacobian is analysed: the null space of the stiffness (restricted to the motions the
constraints allow) names the coordinates without stiffness; a rank-deficient ``G`` names the
redundant constraints. Such coordinates can be held at their start values with ``fixed``.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..atomic import atomic_savez, atomic_write
from ..errors import SolverError
from . import protocol as proto
from .module import GeneratedModel, ModelLike, as_model
from .results import ResultDisplay, check_output_path

__all__ = ["SUFFIXES", "EquilibriumResult", "equilibrium"]

#: Suffixes of equilibrium files (:meth:`EquilibriumResult.save`).
SUFFIXES: tuple[str, ...] = (".csv", ".npz")


@dataclass(frozen=True, repr=False)
class EquilibriumResult(ResultDisplay):
    """A static equilibrium.

    Attributes
    ----------
    y : ndarray (n,)
        Coordinates at equilibrium.
    lambda_ : ndarray (nc,)
        Constraint multipliers (the generalized constraint forces are ``G_Rᵀ λ``).
    residual : float
        ``max |R|`` of the equilibrium equations at ``y``.
    iterations : int
        Iterations used (Newton, plus pseudo-transient continuation steps where needed).
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

    def columns(self) -> dict[str, np.ndarray]:
        """``name`` and ``value`` columns of :meth:`as_dict` (the CSV columns)."""
        items = self.as_dict()
        return {"name": np.array(list(items), dtype=str),
                "value": np.array(list(items.values()), dtype=float)}

    def summary(self) -> str:
        """One line: the coordinates at equilibrium and the residual."""
        vals = ", ".join(f"{c} = {v:.6g}" for c, v in zip(self.coordinates[:6], self.y,
                                                          strict=False))
        more = ", …" if len(self.coordinates) > 6 else ""
        return (f"EquilibriumResult({vals}{more}; residual {self.residual:.3g}, "
                f"{self.iterations} iterations)")

    def to_csv(self, path: str | os.PathLike[str]) -> Path:
        """Write ``name,value`` rows (coordinates, then ``lambda_<constraint>``), atomically."""
        rows = [["name", "value"], *([k, repr(v)] for k, v in self.as_dict().items())]
        return atomic_write(path, "".join(",".join(r) + "\n" for r in rows))

    def to_npz(self, path: str | os.PathLike[str]) -> Path:
        """Write an uncompressed ``.npz`` (no pickles), atomically: ``y``, ``lambda_``, ``p``,
        ``u``, ``t``, ``residual``, ``iterations`` and the names ``coordinates``,
        ``constraints``."""
        return atomic_savez(
            path,
            y=self.y,
            lambda_=self.lambda_,
            p=self.p,
            u=self.u,
            t=np.array(self.t),
            residual=np.array(self.residual),
            iterations=np.array(self.iterations),
            coordinates=np.array(self.coordinates, dtype=str),
            constraints=np.array(self.constraints, dtype=str),
        )

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write ``.csv`` (:meth:`to_csv`) or ``.npz`` (:meth:`to_npz`) by the suffix."""
        path = check_output_path(path, SUFFIXES, "equilibria")
        return self.to_npz(path) if path.suffix.lower() == ".npz" else self.to_csv(path)

    def table(self) -> str:
        """A two-column text table of :meth:`as_dict`."""
        items = self.as_dict()
        width = max((len(k) for k in items), default=4)
        lines = [f"{k:<{width}}  {v: .12g}" for k, v in items.items()]
        lines.append(f"# residual {self.residual:.3g} after {self.iterations} iteration(s)")
        return "\n".join(lines)


def _diagnose(
    names: Sequence[str],
    cnames: Sequence[str],
    free: np.ndarray,
    k_mat: np.ndarray,
    g_free: np.ndarray,
    r_free: np.ndarray,
) -> str:
    """Why the equilibrium Jacobian is singular: redundant constraints (or reactions) or
    missing stiffness."""
    if len(cnames):
        redundant = proto.redundant_constraints(g_free, list(cnames))
        if redundant:
            return "redundant constraints: " + "; ".join(redundant)
        redundant = proto.redundant_constraints(r_free, list(cnames))
        if redundant:
            return "redundant constraints (their reactions): " + "; ".join(redundant)
        basis, _ = proto.null_space(g_free)
        left, _ = proto.null_space(r_free)
    else:
        basis = left = np.eye(free.size)
    kr = left.T @ k_mat[np.ix_(free, free)] @ basis
    ns, _ = proto.null_space(kr, rtol=1e-10)
    who = proto.participating_names(basis @ ns, [names[i] for i in free])
    return (
        "singular stiffness matrix: no stiffness in the motion of coordinate(s) "
        + ", ".join(who)
        + " (hold them with fixed=[...] / --fix, or add springs)"
    )


def _singular(jac: np.ndarray) -> bool:
    sv = np.linalg.svd(jac, compute_uv=False)
    return not sv.size or sv[0] == 0 or sv[-1] <= 1e-12 * sv[0]


class _Problem:
    """The equilibrium equations ``R(y, λ) = [F(y) + G_Rᵀλ; g(y)] = 0`` on the free coordinates,
    their Jacobian and the kinetic metric, for one module, time, parameter and input vector."""

    def __init__(self, module: GeneratedModel, t: float, pv: np.ndarray, uv: np.ndarray,
                 names: list[str], cnames: list[str], free: np.ndarray) -> None:
        self.module, self.t, self.pv, self.uv = module, t, pv, uv
        self.names, self.cnames, self.free = names, cnames, free
        self.n, self.nc, self.nf = len(names), len(cnames), free.size
        self.zero = np.zeros(self.n)
        self.separate_reactions = module.separate_reactions

    def force(self, y: np.ndarray) -> np.ndarray:
        return np.asarray(self.module.force_vector(self.t, y, self.zero, self.pv, self.uv),
                          dtype=float)

    def g_jac(self, y: np.ndarray) -> np.ndarray:
        return np.asarray(self.module.constraint_jacobian(self.t, y, self.pv),
                          dtype=float).reshape(self.nc, self.n)

    def r_jac(self, y: np.ndarray, g: np.ndarray | None = None) -> np.ndarray:
        """The reaction Jacobian ``G_R``; ``G`` (``g`` itself when given) for modules without
        ``constraint_reaction_jacobian``."""
        if g is not None and not self.separate_reactions:
            return g
        return proto.constraint_reaction_jacobian(self.module, self.t, y, self.pv)

    def residual(self, y: np.ndarray, lam: np.ndarray) -> np.ndarray:
        force = self.force(y)
        if not self.nc:
            return force[self.free]
        g = np.asarray(self.module.constraints(self.t, y, self.pv), dtype=float)
        return np.concatenate([(force + self.r_jac(y).T @ lam)[self.free], g])

    def start_multipliers(self, y: np.ndarray) -> np.ndarray:
        """Least-squares ``λ`` of ``F + G_Rᵀλ = 0`` at ``y``."""
        if not self.nc:
            return np.zeros(0)
        rj = self.r_jac(y)
        return np.linalg.lstsq(rj[:, self.free].T, -self.force(y)[self.free], rcond=None)[0]

    def motion_multipliers(self, y: np.ndarray, w: np.ndarray) -> np.ndarray:
        """``λ`` of the constrained motion in the metric ``w``: ``G w⁻¹ (F + G_Rᵀλ) = 0``."""
        if not self.nc:
            return np.zeros(0)
        gf = self.g_jac(y)[:, self.free]
        rf = self.r_jac(y)[:, self.free] if self.separate_reactions else gf
        f = self.force(y)[self.free]
        wg = np.linalg.solve(w, gf.T)
        wr = wg if rf is gf else np.linalg.solve(w, rf.T)
        return np.linalg.lstsq(gf @ wr, -(wg.T @ f), rcond=None)[0]

    def jacobian(self, y: np.ndarray, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray,
                                                                 np.ndarray, np.ndarray]:
        """``∂R/∂(y_free, λ)``, the full stiffness ``∂(F + G_Rᵀλ)/∂y``, ``G[:, free]`` and
        ``G_R[:, free]``."""
        m = self.module
        f_y = np.asarray(m.force_jacobians(self.t, y, self.zero, self.pv, self.uv)[0],
                         dtype=float)
        free, nf = self.free, self.nf
        if not self.nc:
            none = np.zeros((0, nf))
            return f_y[np.ix_(free, free)], f_y, none, none
        gj = self.g_jac(y)
        rj = self.r_jac(y, gj)
        k_full = f_y + proto.constraint_force_jacobian(m, self.t, y, self.pv, lam)
        jac = np.zeros((nf + self.nc, nf + self.nc))
        jac[:nf, :nf] = k_full[np.ix_(free, free)]
        jac[:nf, nf:] = rj[:, free].T
        jac[nf:, :nf] = gj[:, free]
        return jac, k_full, gj[:, free], rj[:, free]

    def metric(self, y: np.ndarray) -> np.ndarray:
        """The kinetic metric ``M[free, free]``: its symmetric part with the eigenvalues floored
        at ``1e-8`` of the largest (a massless coordinate still gets a small pseudo-mass)."""
        mm = np.asarray(self.module.mass_matrix(self.t, y, self.pv), dtype=float)
        w = mm[np.ix_(self.free, self.free)]
        w = 0.5 * (w + w.T)
        ev, vec = np.linalg.eigh(w)
        top = ev.max(initial=0.0)
        if not np.isfinite(top) or top <= 0:
            return np.eye(self.nf)
        return (vec * np.maximum(ev, 1e-8 * top)) @ vec.T

    def project(self, y: np.ndarray, w: np.ndarray, maxiter: int = 30) -> np.ndarray:
        """``y`` moved onto ``g(y) = 0`` by the least change in the metric ``w`` (Gauss–Newton;
        the last finite iterate when the constraints cannot be met — the continuation then
        reports them through its residual)."""
        tol = 1e-14 * (1.0 + np.abs(y).max(initial=0.0))
        return proto.project_onto_constraints(
            lambda yv: self.module.constraints(self.t, yv, self.pv), self.g_jac, y, tol,
            moved=self.free, winv=np.linalg.inv(w), maxiter=maxiter,
        )[0]

    def roundoff(self, jac: np.ndarray, y: np.ndarray, lam: np.ndarray) -> float:
        """Residual level that counts as zero: round-off of ``R`` near ``(y, λ)``."""
        scale = max(np.abs(jac).max(initial=0.0), 1e-300)
        size = 1.0 + np.abs(np.concatenate([y, lam])).max(initial=0.0)
        return 1e3 * np.finfo(float).eps * scale * size

    def step_to(self, y: np.ndarray, lam: np.ndarray, step: np.ndarray,
                alpha: float) -> tuple[np.ndarray, np.ndarray]:
        y_new = y.copy()
        y_new[self.free] += alpha * step[: self.nf]
        return y_new, lam + alpha * step[self.nf :]


@dataclass
class _Outcome:
    """State of one solver phase: the iterate, its residual and how the phase ended."""

    y: np.ndarray
    lam: np.ndarray
    r: np.ndarray
    iterations: int = 0
    status: str = "maxiter"  # converged | singular | redundant | stalled | maxiter | stagnated
    singular: str = ""  # diagnosis of a singular Jacobian, when one was met


def _newton(prob: _Problem, y: np.ndarray, lam: np.ndarray, *, xtol: float, maxiter: int,
            max_step: float) -> _Outcome:
    """Newton's method with the analytic Jacobian, steps limited to ``max_step`` per
    coordinate and damped by a backtracking line search on ``½‖R‖²``."""
    nf = prob.nf
    out = _Outcome(y, lam, prob.residual(y, lam))
    stalled = 0
    for _ in range(maxiter + 1):
        jac, k_full, g_free, r_free = prob.jacobian(out.y, out.lam)
        if np.abs(out.r).max(initial=0.0) <= prob.roundoff(jac, out.y, out.lam):
            out.status = "converged"
            return out
        if out.iterations == maxiter:
            return out
        out.iterations += 1
        if _singular(jac):
            out.singular = _diagnose(prob.names, prob.cnames, prob.free, k_full,
                                     g_free, r_free)
            out.status = "redundant" if out.singular.startswith("redundant") else "singular"
            return out
        step = np.linalg.solve(jac, -out.r)
        longest = np.abs(step[:nf]).max(initial=0.0)
        alpha = 1.0 if longest <= max_step else max_step / longest
        merit = 0.5 * out.r @ out.r
        while True:
            y_try, lam_try = prob.step_to(out.y, out.lam, step, alpha)
            r_try = prob.residual(y_try, lam_try)
            if 0.5 * r_try @ r_try <= (1 - 1e-4 * alpha) * merit or alpha < 1e-8:
                break
            alpha *= 0.5
        out.y, out.lam, out.r = y_try, lam_try, r_try
        stalled = stalled + 1 if 0.5 * out.r @ out.r > 0.99 * merit else 0
        if stalled >= 5:
            out.status = "stalled"
            return out
        if alpha == 1.0 and np.abs(step[:nf]).max(initial=0.0) <= xtol * (
            1.0 + np.abs(out.y).max(initial=0.0)
        ):
            out.status = "converged"
            return out
    return out


def _continuation(prob: _Problem, y: np.ndarray, *, xtol: float, maxiter: int,
                  max_step: float) -> _Outcome:
    """Pseudo-transient continuation (Kelley & Keyes 1998) in the kinetic metric ``M``.

    Each step is one backward-Euler step of the fictitious motion ``M dy/dτ = F + G_Rᵀλ`` (the
    damped dynamics, which settle in a stable equilibrium), with the constraints solved at every
    step::

        [ K − M/Δτ   G_Rᵀ ] [ δy ]     [ F + G_Rᵀλ ]
        [ G          0    ] [ δλ ] = − [ g         ]

    The multipliers are those of the motion, ``G M⁻¹ (F + G_Rᵀλ) = 0`` (the residual is then the
    force that drives the constrained motion, and ``‖R‖`` is measured in ``M⁻¹``). ``Δτ`` starts
    small against the mass/stiffness scale (``‖M‖/Δτ₀ = 10 ‖K‖``, and the first step no
    longer than ``max_step / 10``) and grows by switched evolution relaxation,
    ``Δτ_{k+1} = Δτ_k ‖R_{k−1}‖ / ‖R_k‖``; once ``M/Δτ`` is below the round-off of ``K`` the
    iteration is plain Newton (quadratic convergence). A step whose residual is not finite or
    grows more than tenfold is retried with ``Δτ/4``.
    """
    nf = prob.nf
    w = prob.metric(y)
    if prob.nc:  # start on the constraint manifold (else the first step is an impulse)
        y = prob.project(y, w)

    def state(yv: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        wv = prob.metric(yv)
        lam = prob.motion_multipliers(yv, wv)
        r = prob.residual(yv, lam)
        rf = r[:nf]
        return lam, r, wv, float(np.sqrt(max(rf @ np.linalg.solve(wv, rf), 0.0)))

    lam, r, w, norm = state(y)
    out = _Outcome(y, lam, r)
    dtau = dtau_min = 0.0
    for _ in range(maxiter + 1):
        jac, k_full, g_free, r_free = prob.jacobian(out.y, out.lam)
        if np.abs(out.r).max(initial=0.0) <= prob.roundoff(jac, out.y, out.lam):
            if _singular(jac):  # not an isolated equilibrium: name the free motion
                out.status = "singular"
                out.singular = _diagnose(prob.names, prob.cnames, prob.free, k_full,
                                         g_free, r_free)
            else:
                out.status = "converged"
            return out
        if out.iterations == maxiter:
            return out
        out.iterations += 1
        k_norm = np.abs(jac[:nf, :nf]).max(initial=0.0)
        w_norm = np.abs(w).max()
        if dtau == 0.0:
            dtau = 0.1 * w_norm / k_norm if k_norm > 0 else np.inf
            force = np.abs(np.linalg.solve(w, out.r[:nf])).max(initial=0.0)
            if force > 0:  # first step δy ≈ Δτ M⁻¹ R no longer than max_step / 10
                dtau = min(dtau, 0.1 * max_step / force)
            if not np.isfinite(dtau) or dtau <= 0:
                dtau = 1.0
            dtau_min = 1e-12 * dtau
        newton = dtau * k_norm > 1e12 * w_norm  # M/Δτ below round-off of K: plain Newton
        while True:
            shifted = jac.copy()
            if not newton:
                shifted[:nf, :nf] -= w / dtau
            try:
                step = np.linalg.solve(shifted, -out.r)
                longest = np.abs(step[:nf]).max(initial=0.0)
            except np.linalg.LinAlgError:
                longest = np.inf
            if np.isfinite(longest):
                alpha = 1.0 if longest <= max_step else max_step / longest
                y_try = out.y.copy()
                y_try[prob.free] += alpha * step[:nf]
                with np.errstate(all="ignore"):
                    lam_try, r_try, w_try, norm_try = state(y_try)
                if np.isfinite(norm_try) and norm_try <= 10.0 * norm:
                    break
            newton = False
            dtau /= 4.0
            if dtau < dtau_min:
                out.status = "stagnated"
                return out
        full = alpha == 1.0 and longest <= xtol * (1.0 + np.abs(y_try).max(initial=0.0))
        out.y, out.lam, out.r, w = y_try, lam_try, r_try, w_try
        if newton and full:
            out.status = "converged"
            return out
        if norm_try > 0:  # switched evolution relaxation
            dtau *= norm / norm_try
        norm = norm_try
    return out


def equilibrium(
    module: ModelLike,
    p: proto.ParameterLike = None,
    u: Mapping[str, float] | Sequence[float] | None = None,
    y0: Mapping[str, float] | Sequence[float] | np.ndarray | None = None,
    t: float = 0.0,
    *,
    fixed: Sequence[str] = (),
    xtol: float = 1e-11,
    maxiter: int = 50,
    max_step: float = 1.0,
    max_continuation: int = 2000,
) -> EquilibriumResult:
    """Static equilibrium of a generated module (equations.md §1).

    Solves ``F(y) = (q − k)(y, ẏ = 0, u) = 0`` — and, with constraints, ``F + G_Rᵀ λ = 0``,
    ``g(y) = 0`` — by damped Newton iterations with the analytic stiffness ``∂F/∂y``. When
    Newton's method stalls, meets a singular Jacobian or does not converge, the search is
    globalized by pseudo-transient continuation from the start (Kelley & Keyes 1998): it
    follows the damped motion ``M dy/dτ = F + G_Rᵀλ`` in the kinetic metric ``M`` and ends in plain
    Newton, so it finds the *stable* equilibrium the start falls into.

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
        Largest change of any coordinate in one iteration (longer steps are shortened, keeping
        their direction), so that e.g. a pendulum started near the horizontal does not jump
        several revolutions.
    max_continuation
        Maximum number of pseudo-transient continuation steps (0: Newton only).

    Returns
    -------
    EquilibriumResult

    Raises
    ------
    SolverError
        On non-convergence (carrying the last iterate, the residual and the coordinate names) or a
        singular Jacobian at the equilibrium (naming coordinates without stiffness or redundant
        constraints).

    References
    ----------
    C. T. Kelley, D. E. Keyes: Convergence analysis of pseudo-transient continuation. SIAM J.
    Numer. Anal. 35 (1998) 508–523.

    Examples
    --------
    >>> eq = equilibrium(mod, p={"k": 20.0})                         # doctest: +SKIP
    >>> print(eq.table())                                            # doctest: +SKIP
    """
    module = as_model(module)
    names = list(module.COORDINATES)
    n = len(names)
    cnames = list(module.CONSTRAINTS)
    pv = proto.resolve_parameters(module, p)
    uv = proto.resolve_inputs(module, t, pv, u)
    y_init = np.asarray(module.INITIAL_STATE, dtype=float)[:n].copy()
    y = proto.override_vector(y_init, names, y0, "coordinate").copy()
    fixed_idx = {proto.name_index(names, nm, "coordinate") for nm in fixed}
    free = np.array([i for i in range(n) if i not in fixed_idx], dtype=int)
    prob = _Problem(module, t, pv, uv, names, cnames, free)
    lam = prob.start_multipliers(y)

    first = _newton(prob, y, lam, xtol=xtol, maxiter=maxiter, max_step=max_step)
    result = first
    if first.status not in ("converged", "redundant") and max_continuation > 0:
        second = _continuation(prob, y, xtol=xtol, maxiter=max_continuation,
                               max_step=max_step)
        second.iterations += first.iterations
        result = second
    if result.status == "converged":
        return EquilibriumResult(
            y=result.y,
            lambda_=result.lam,
            residual=float(np.abs(result.r).max(initial=0.0)),
            iterations=result.iterations,
            coordinates=tuple(names),
            constraints=tuple(cnames),
            p=pv,
            u=uv,
            t=float(t),
        )
    res = float(np.abs(result.r).max(initial=0.0))
    if result.status in ("singular", "redundant"):  # not isolated: name the free motion
        raise SolverError("equilibrium: " + result.singular, last_iterate=result.y.copy(),
                          residual=res, names=names)
    if result is first:
        what = "Newton failed, " + {
            "stalled": "the line search stalled at a local minimum of the residual (no "
            "equilibrium near the start? try another y0)",
            "maxiter": f"no convergence in {maxiter} iterations",
        }[first.status]
    else:
        newton = {
            "stalled": "stalled at a local minimum of the residual",
            "singular": "met a singular Jacobian",
            "maxiter": f"did not converge in {maxiter} iterations",
        }[first.status]
        ptc = {
            "maxiter": f"did not settle in {max_continuation} steps",
            "stagnated": "stagnated (its pseudo-time step collapsed)",
        }[result.status]
        what = (f"no convergence: Newton's method {newton}, and pseudo-transient continuation "
                f"(the damped motion from the start) {ptc} — is there an equilibrium the start "
                "falls into?")
        if first.singular:
            what += f" ({first.singular.split(' (hold')[0]})"
    worst = int(np.argmax(np.abs(result.r)))
    eq_names = [names[i] for i in free] + [f"constraint {c}" for c in cnames]
    raise SolverError(
        f"equilibrium: {what}; residual {res:.3g} (largest in the equation of "
        f"{eq_names[worst]}); last iterate "
        + ", ".join(f"{nm}={v:.6g}" for nm, v in zip(names, result.y, strict=True)),
        last_iterate=result.y.copy(),
        residual=res,
        names=names,
    )
