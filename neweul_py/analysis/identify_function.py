"""Parameter identification of a model that is not one generated module (docs/sensitivity.md §7).

:func:`identify_function` fits parameters to data through a residual function: any forward
model (an FE model coupled with a generated chain, a set of derived measures such as a
tympanogram's width) maps a dict of parameter values to residuals ``r_i = (y_i − ȳ_i)/σ_i``,
the model's value against a measured mean in units of its standard deviation. The fit is the
bounded nonlinear least squares of :func:`~neweul_py.analysis.identify.identify` (trust-region
reflective, ``θ = ln p`` for positive bounds) with a forward-difference Jacobian of absolute
step ``h`` in ``θ`` (a relative step in ``p`` for log parameters), stepping inwards at an upper
bound. Its standard errors, correlations and undetermined parameters are those of
:func:`~neweul_py.analysis.identify_statistics.fit_statistics`, with the residuals' variance known
(``s² = 1``: the residuals are in units of their standard deviations) or estimated; a log
parameter whose ``σ(ln p)`` exceeds ``max_log_sd`` is reported undetermined as well (the data
bound it only within a factor ``e^σ``: a number with that error says nothing).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from ..errors import NeweulError, SolverError
from .identify import Bound, FitResult
from .identify_model import FitProblem
from .identify_statistics import fit_statistics

__all__ = ["identify_function"]

ResidualFunction = Callable[[Mapping[str, float]], Sequence[float] | np.ndarray]


class _Cached:
    """The residual function in ``θ``, each point evaluated once."""

    def __init__(self, fun: ResidualFunction, problem: FitProblem) -> None:
        self.fun, self.problem = fun, problem
        self.seen: dict[bytes, np.ndarray] = {}

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        key = np.asarray(theta, dtype=float).tobytes()
        if key not in self.seen:
            values = self.problem.values(theta)
            r = np.asarray(self.fun(dict(zip(self.problem.names, values.tolist(), strict=True))),
                           dtype=float)
            if r.ndim != 1 or not np.all(np.isfinite(r)):
                raise SolverError("identify: the residual function must return a finite 1-D "
                                  f"array, got {r!r} at "
                                  + ", ".join(f"{n} = {v:.6g}" for n, v in
                                              zip(self.problem.names, values, strict=True)))
            self.seen[key] = r
        return self.seen[key]

    def jacobian(self, theta: np.ndarray, step: float) -> np.ndarray:
        """Forward differences of absolute step ``step`` in ``θ`` (backward at the upper
        bound)."""
        theta = np.asarray(theta, dtype=float)
        r0 = self(theta)
        cols = []
        for j in range(theta.size):
            h = step if theta[j] + step <= self.problem.upper[j] else -step
            t = theta.copy()
            t[j] += h
            cols.append((self(t) - r0) / h)
        return np.column_stack(cols)


def identify_function(
    residuals: ResidualFunction, bounds: Sequence[Bound | str], *,
    labels: Sequence[str] | None = None, known_variance: bool = True,
    max_log_sd: float | None = 1.0, step: float = 0.05,
    max_nfev: int = 60, tolerance: float = 1e-6, model_name: str = "",
    data_name: str = "",
) -> FitResult:
    """Fit parameters through a residual function (module docstring).

    Parameters
    ----------
    residuals
        ``residuals(values) → r``: ``values`` maps each fitted parameter's name to its value;
        ``r`` the residuals (same length at every call), in units of the data's standard
        deviations when ``known_variance``. Raise a :class:`~neweul_py.errors.NeweulError`
        where the model cannot be evaluated; a fit whose start cannot be evaluated fails with
        that error.
    bounds
        :class:`~neweul_py.analysis.identify.Bound` per parameter or ``"NAME=LO:HI[:START]"``
        (default start: the geometric (log) or arithmetic middle of the bounds).
    labels
        A name per residual (for the plot and the JSON curve).
    known_variance
        The residuals are already divided by their standard deviations (``s² = 1``);
        otherwise ``s²`` is estimated from the residuals at the optimum.
    max_log_sd
        A log parameter whose standard error of ``ln p`` exceeds this (1: the data bound it
        only within a factor ``e`` either way) is reported undetermined, with its
        ``σ(ln p)`` in the reason; ``None`` reports every parameter the statistics leave.
    step
        Forward-difference step in ``θ`` (0.05: 5 % of ``p`` for a log parameter).
    max_nfev, tolerance
        Iteration limit and ``ftol``/``xtol``/``gtol`` of
        :func:`scipy.optimize.least_squares`.
    model_name, data_name
        Recorded in the result.

    Returns
    -------
    FitResult
        ``task == "function"``; ``curve`` holds ``labels``, ``residuals`` and ``jacobian``
        (``∂r/∂θ``, rows per residual) at the optimum.

    Raises
    ------
    NeweulError
        For bounds with ``LO ≥ HI``, a start outside them, a parameter given twice, fewer
        residuals than parameters, or a start the model cannot evaluate.
    """
    from scipy.optimize import least_squares

    bounds = [b if isinstance(b, Bound) else Bound.parse(b) for b in bounds]
    if not bounds:
        raise NeweulError("no parameters to fit (NAME=LO:HI[:START])")
    for b in bounds:
        b.check()
    names = tuple(b.name for b in bounds)
    if len(set(names)) < len(names):
        raise NeweulError("a parameter is fitted twice: " + ", ".join(names))
    if not (np.isfinite(step) and step > 0):
        raise NeweulError(f"step must be a positive number, got {step!r}")
    problem = FitProblem(names, tuple(b.log for b in bounds),
                         np.array([b.theta(b.lo) for b in bounds]),
                         np.array([b.theta(b.hi) for b in bounds]), np.zeros(0), None)
    theta0 = np.array([b.theta(b.start) if b.start is not None
                       else 0.5 * (b.theta(b.lo) + b.theta(b.hi)) for b in bounds])
    fun = _Cached(residuals, problem)
    r0 = fun(theta0)
    if r0.size <= len(names):
        raise NeweulError(f"{r0.size} residuals cannot determine {len(names)} parameters and "
                          "their standard errors")
    if labels is not None and len(labels) != r0.size:
        raise NeweulError(f"{len(labels)} labels for {r0.size} residuals")
    res = least_squares(fun, theta0, jac=lambda t: fun.jacobian(t, step),
                        bounds=(problem.lower, problem.upper), method="trf", x_scale=1.0,
                        max_nfev=int(max_nfev), ftol=tolerance, xtol=tolerance, gtol=tolerance)
    r = fun(res.x)
    J = fun.jacobian(res.x, step)
    errors, correlation, undetermined = fit_statistics(problem, res.x, r, J,
                                                       1.0 if known_variance else None)
    values = problem.values(res.x)
    end = {nm: float(v) for nm, v in zip(names, values, strict=True)}
    if max_log_sd is not None:
        for nm, lg in zip(names, problem.log, strict=True):
            sd = errors.get(nm)
            if lg and sd is not None and sd / end[nm] > max_log_sd:
                undetermined[nm] = (f"the data bound it only within a factor "
                                    f"{np.exp(sd / end[nm]):.3g} either way (σ(ln p) = "
                                    f"{sd / end[nm]:.3g} > {max_log_sd:g})")
                errors[nm] = None
                correlation[nm] = None
        for nm, row in correlation.items():
            if row is not None:
                correlation[nm] = {o: (None if o in undetermined else v) for o, v in row.items()}
    tol = 1e-6 * np.maximum(1.0, np.abs(problem.upper - problem.lower))
    at_bounds = tuple(nm for j, nm in enumerate(names)
                      if min(res.x[j] - problem.lower[j], problem.upper[j] - res.x[j]) <= tol[j])
    start = {nm: float(v) for nm, v in zip(names, problem.values(theta0), strict=True)}
    curve: dict[str, Any] = {"labels": list(labels) if labels is not None
                             else [f"r{i}" for i in range(r.size)], "residuals": r.tolist(),
                             "jacobian": J.tolist()}
    return FitResult(
        task="function",
        parameters={nm: (None if nm in undetermined else end[nm]) for nm in names},
        standard_errors=errors, undetermined=undetermined, correlation=correlation,
        cost=float(0.5 * r @ r), iterations=int(res.njev), evaluations=len(fun.seen),
        converged=res.status > 0, message=str(res.message), end_point=end,
        scale={nm: "log" if lg else "linear" for nm, lg in zip(names, problem.log,
                                                                 strict=True)},
        at_bounds=at_bounds,
        starts=[{"start": start, "end": end, "cost": float(res.cost),
                 "converged": res.status > 0}],
        residual_rms=float(np.sqrt(np.mean(r**2))), n_residuals=int(r.size),
        model_name=model_name, data_file=data_name, curve=curve)
