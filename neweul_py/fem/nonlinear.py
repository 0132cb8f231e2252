"""Newton's method with adaptive load stepping for static FE equilibria ``R(u, λ) = 0``.

The load parameter ``λ`` (here the static pressure difference ``Δp``) is increased from 0 to each
requested value in steps; a step whose Newton iteration fails (non-finite residual, divergence,
too many iterations) is halved and retried from the last converged state. When the step falls
below ``min_step`` a :class:`~neweul_py.errors.SolverError` is raised that names the last
converged load and carries its state — an unconverged state is never returned as converged.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sps

from ..elastic.reductors.eigen import SparseLU
from ..errors import SolverError

__all__ = ["NewtonOptions", "StaticState", "load_path"]

#: ``residual(u, load) -> (R, K, f_scale)`` with the tangent ``K = ∂R/∂u`` and a force scale.
Residual = Callable[[np.ndarray, float], tuple[np.ndarray, sps.spmatrix, float]]


@dataclass(frozen=True)
class NewtonOptions:
    """Options of :func:`load_path`.

    Parameters
    ----------
    rtol, utol
        Converged when the last Newton correction is small, ``‖Δu‖ ≤ utol · ‖u‖``, and the
        residual is small, ``‖R‖ ≤ rtol · f_scale`` (the residual of stiff membranes stalls at a
        round-off floor well above machine precision times the load, hence the two tests);
        or when ``‖R‖ ≤ 10⁻¹⁰ f_scale`` and ``‖Δu‖ ≤ 10⁻⁶ ‖u‖``.
    max_iter
        Newton iterations per load step.
    first_step, max_step, min_step
        Load increments (same unit as the load).
    """

    rtol: float = 1e-4
    utol: float = 1e-9
    max_iter: int = 25
    first_step: float = 250.0
    max_step: float = 1000.0
    min_step: float = 1.0


@dataclass(frozen=True)
class StaticState:
    """A converged equilibrium: ``load``, free-DOF vector ``u``, ``iterations``, ``residual``;
    ``lowest_eigenvalue``: the eigenvalue nearest 0 of its tangent where a stability check
    computed it (``None`` otherwise)."""

    load: float
    u: np.ndarray
    iterations: int
    residual: float
    lowest_eigenvalue: float | None = None


def _newton(
    residual: Residual, u0: np.ndarray, load: float, opts: NewtonOptions
) -> tuple[np.ndarray, int, float] | None:
    """One Newton solve at fixed load; ``None`` when it does not converge."""
    u = u0.copy()
    r, k, scale = residual(u, load)
    rn0 = np.linalg.norm(r)
    for it in range(1, opts.max_iter + 1):
        if not np.all(np.isfinite(r)):
            return None
        try:    # the tangent's symmetric ordering, cached by pattern (SparseLU)
            du = SparseLU(k).solve(-r)
        except RuntimeError:  # singular factor
            return None
        if not np.all(np.isfinite(du)):
            return None
        u = u + du
        r, k, scale = residual(u, load)
        rn = np.linalg.norm(r)
        if not np.isfinite(rn) or rn > 1e6 * max(rn0, scale):
            return None
        rel_du = np.linalg.norm(du) / max(np.linalg.norm(u), 1e-300)
        if (rel_du <= opts.utol and rn <= opts.rtol * scale) or (
            rel_du <= 1e-6 and rn <= 1e-10 * scale
        ):
            return u, it, float(rn)
    return None


def load_path(
    residual: Residual,
    n: int,
    targets: Sequence[float],
    options: NewtonOptions | None = None,
    on_step: Callable[[StaticState], None] | None = None,
) -> list[StaticState]:
    """Equilibria at the requested loads, following the load path from ``u = 0`` at load 0.

    Parameters
    ----------
    residual
        ``residual(u, load) -> (R, K, f_scale)``: residual ``R = f_int(u) − f_ext(u, load)``, its
        consistent tangent ``K`` and a force scale for the convergence test.
    n
        Number of unknowns.
    targets
        Loads of one sign (zero allowed), reached in increasing ``|load|``.
    options
        Newton and stepping options.
    on_step
        Called with every converged load step (intermediate steps included), before the next
        one: for progress output and for checks of the state along the load path — an
        exception it raises stops the path there.

    Returns
    -------
    list of StaticState
        One converged state per target, in the order of ``targets``.

    Raises
    ------
    SolverError
        When a load cannot be reached (the step fell below ``min_step``); ``last_iterate`` is the
        last converged state (a :class:`StaticState`), the message names its load.

    Examples
    --------
    A hardening spring ``u + u³ = λ``:

    >>> def res(u, lam):
    ...     return u + u**3 - lam, sps.csr_matrix([[1 + 3 * u[0] ** 2]]), max(abs(lam), 1.0)
    >>> [round(float(s.u[0]), 6) for s in load_path(res, 1, [2.0, 10.0])]
    [1.0, 2.0]
    """
    opts = options or NewtonOptions()
    t = np.asarray(targets, dtype=float)
    if np.any(t > 0) and np.any(t < 0):
        raise ValueError("load_path: targets must have one sign; call it once per branch")
    sign = -1.0 if np.any(t < 0) else 1.0
    order = np.argsort(np.abs(t))
    state = StaticState(0.0, np.zeros(n), 0, 0.0)
    out: dict[int, StaticState] = {}
    step = opts.first_step
    for idx in order:
        goal = float(t[idx])
        while abs(goal) - abs(state.load) > 1e-12 * max(1.0, abs(goal)):
            trial = state.load + sign * min(step, abs(goal) - abs(state.load))
            res = _newton(residual, state.u, trial, opts)
            if res is None:
                step *= 0.5
                if step < opts.min_step:
                    raise SolverError(
                        f"Newton did not converge beyond a load of {state.load:g} "
                        f"(last converged load step; failed at {trial:g}, step < "
                        f"{opts.min_step:g})",
                        last_iterate=state,
                        residual=state.residual,
                    )
                continue
            u, its, rn = res
            state = StaticState(trial, u, its, rn)
            if on_step is not None:
                on_step(state)
            if its <= 4:
                step = min(step * 1.5, opts.max_step)
        if idx not in out:
            out[int(idx)] = state  # goal 0: the unloaded reference state
    return [out[i] for i in range(len(t))]
