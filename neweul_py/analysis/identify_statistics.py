"""The statistics of a fit at its optimum: standard errors, correlations, and what the data
leave undetermined (docs/sensitivity.md §7).

At the optimum ``θ*`` the Jacobian ``J = U S Vᵀ`` gives the covariance
``Σ = s² V S⁻² Vᵀ`` (``s² = 2·cost/(m − k)``, ``m`` the residuals that carry weight) and the
standard errors (``p·σ_θ`` for log parameters). A direction ``v_i`` with
``S_i < RCOND·S_0`` is one the data do not determine: every parameter with a component above
:data:`NULL_COMPONENT` in it is reported as undetermined (value, standard error and
correlations ``None``, with the reason), and so is a parameter whose correlation with another
exceeds :data:`MAX_CORRELATION`. The Jacobian sees only the neighbourhood of ``θ*``: where the
data determine a curved combination, another start may end elsewhere with the same cost
(:func:`equal_cost_spread`), and every parameter that differs there beyond
:data:`SPREAD_ERRORS` standard errors is undetermined too.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = ["EQUAL_COST", "MAX_CORRELATION", "NULL_COMPONENT", "RCOND", "SPREAD_ERRORS",
           "equal_cost_spread", "fit_statistics"]

#: Singular values of ``J`` below ``RCOND`` times the largest are null directions
#: (``cond(JᵀJ) > 1e12``).
RCOND = 1e-6
#: Components of a null direction above this make a parameter undetermined.
NULL_COMPONENT = 0.1
#: Correlations above this (in magnitude) make both parameters undetermined.
MAX_CORRELATION = 0.9999


#: Two starts end with equal cost when their costs differ by less than this fraction of the
#: larger (the optimizer stops at a relative change of 1e-10) plus ``EQUAL_COST_FLOOR``.
EQUAL_COST = 1e-6
#: Costs below this count as equal (exact data: ½Σr² of round-off).
EQUAL_COST_FLOOR = 1e-12
#: End points of equal cost that differ by more than this many standard errors (and by more
#: than ``1e-6`` in ``θ``) make a parameter undetermined.
SPREAD_ERRORS = 4.0


def fit_statistics(problem: Any, theta: np.ndarray, r: np.ndarray, J: np.ndarray,
                   variance: float | None = None, m: int | None = None
                   ) -> tuple[dict, dict, dict]:
    """Standard errors, correlations and the undetermined parameters (module docstring).

    Parameters
    ----------
    problem
        The fit's ``names``, ``log`` (per parameter: fitted as ``ln p``) and ``values(θ)``.
    theta, r, J
        The optimum ``θ*``, the residuals and their Jacobian ``∂r/∂θ`` there.
    variance
        The residuals' variance ``s²`` when it is known (residuals already divided by their
        measured standard deviations: ``1``); ``None`` estimates it as ``2·cost/(m − k)``.
    m
        The number of residuals that carry weight (default: every row of ``J``); rows of
        weight zero are not data.
    """
    names = list(problem.names)
    k = J.shape[1]
    m = J.shape[0] if m is None else int(m)
    values = problem.values(theta)
    undetermined: dict[str, str] = {}
    U, S, Vt = np.linalg.svd(J, full_matrices=False)
    del U
    top = S[0] if S.size and S[0] > 0 else 0.0
    null = [i for i in range(k) if top == 0.0 or S[i] < RCOND * top]
    for i in null:
        v = Vt[i]
        involved = [j for j in range(k) if abs(v[j]) > NULL_COMPONENT]
        combo = " ".join(f"{v[j]:+.2f}·d{'ln ' if problem.log[j] else ''}{names[j]}"
                         for j in involved)
        ratio = S[i] / top if top else 0.0
        if len(involved) == 1:
            why = ("the data do not determine it: the residuals do not change with it "
                   f"(singular value ratio {ratio:.1e})")
        else:
            why = ("the data do not determine it: the residuals do not change along "
                   f"{combo} (singular value ratio {ratio:.1e}), only a combination of "
                   f"{', '.join(names[q] for q in involved)} is determined")
        for j in involved:
            undetermined.setdefault(names[j], why)
    keep = [i for i in range(k) if i not in null]
    if variance is not None:
        s2 = float(variance)
    else:
        s2 = 2.0 * 0.5 * float(r @ r) / (m - k) if m > k else np.nan
    cov = (Vt[keep].T / S[keep] ** 2) @ Vt[keep] * s2
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd)
    for a in range(k):
        for b in range(a + 1, k):
            if names[a] in undetermined or names[b] in undetermined:
                continue
            if np.isfinite(corr[a, b]) and abs(corr[a, b]) > MAX_CORRELATION:
                why = (f"correlated with {{}} (ρ = {corr[a, b]:.6f}): the data determine "
                       "only a combination")
                undetermined[names[a]] = why.format(names[b])
                undetermined[names[b]] = why.format(names[a])
    errors: dict[str, float | None] = {}
    correlation: dict[str, dict[str, float | None] | None] = {}
    for j, nm in enumerate(names):
        if nm in undetermined or not np.isfinite(sd[j]):
            errors[nm] = None
            correlation[nm] = None
            continue
        errors[nm] = float(values[j] * sd[j] if problem.log[j] else sd[j])
        correlation[nm] = {other: (None if other in undetermined else float(corr[j, q]))
                           for q, other in enumerate(names)}
    return errors, correlation, undetermined


def equal_cost_spread(problem: Any, best: dict[str, Any], runs: Sequence[dict[str, Any]],
                      errors: dict[str, float | None]) -> dict[str, str]:
    """The parameters that other starts ending with the best start's cost put elsewhere.

    Parameters
    ----------
    problem
        As for :func:`fit_statistics`.
    best
        The best start's run: ``theta`` (its end point ``θ*``) and ``cost``.
    runs
        Every start's run (``theta``, ``cost``, ``status``; or ``error``).
    errors
        The standard errors of :func:`fit_statistics` at ``θ*`` (``None``: undetermined).

    Returns
    -------
    dict of str to str
        Name → why: a converged start whose cost equals the best one's within
        ``EQUAL_COST·cost + EQUAL_COST_FLOOR`` and whose end point differs in that parameter
        by more than :data:`SPREAD_ERRORS` standard errors (and ``1e-6`` in ``θ``): the data
        cannot tell the two apart.
    """
    names = list(problem.names)
    theta = np.asarray(best["theta"], dtype=float)
    values = problem.values(theta)
    sd = np.array([np.nan if errors.get(nm) is None else
                   (errors[nm] / values[j] if problem.log[j] else errors[nm])
                   for j, nm in enumerate(names)], dtype=float)
    spread: dict[str, list[float]] = {}
    for run in runs:
        if "error" in run or run is best or run.get("status", 0) <= 0:
            continue
        if abs(run["cost"] - best["cost"]) > (EQUAL_COST * max(run["cost"], best["cost"])
                                              + EQUAL_COST_FLOOR):
            continue
        other = np.asarray(run["theta"], dtype=float)
        far = np.abs(other - theta) > np.maximum(
            SPREAD_ERRORS * np.nan_to_num(sd, nan=0.0), 1e-6 * np.maximum(1.0, np.abs(theta)))
        ends = problem.values(other)
        for j in np.flatnonzero(far):
            spread.setdefault(names[j], [float(values[j])]).append(float(ends[j]))
    return {nm: (f"the data do not determine it: starts ending with the same cost "
                 f"(½Σr² = {best['cost']:.6g}) put it at {min(v):.6g} … {max(v):.6g}")
            for nm, v in spread.items()}


