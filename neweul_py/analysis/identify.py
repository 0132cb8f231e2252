"""Parameter identification: bounded nonlinear least squares with the analytic sensitivities
as Jacobian (docs/sensitivity.md §7, docs/howto/identify.md).

:func:`identify` fits parameters of a generated module to a measured frequency response or
time history (:mod:`.identify_data`) with :func:`scipy.optimize.least_squares` (trust-region
reflective, bounds), the residuals and Jacobian of :mod:`.identify_model`, from one start or
several (a Latin hypercube in the bounds; on Dask with ``workers`` or ``scheduler``).

The standard errors, correlations and undetermined parameters at the optimum are those of
:mod:`.identify_statistics`: of the Jacobian there, and of the starts that end with the same
cost elsewhere.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..atomic import atomic_write
from ..errors import NeweulError, SolverError
from . import protocol as proto
from .identify_data import FrequencyData, TimeData, read_frequency_data, read_time_data
from .identify_model import FitProblem, Residuals, column_index
from .identify_statistics import equal_cost_spread, fit_statistics
from .module import GeneratedModel, ModelLike, as_model
from .results import check_output_path

__all__ = ["Bound", "FitResult", "fit_start", "identify"]


@dataclass(frozen=True)
class Bound:
    """A fitted parameter: ``LO ≤ p ≤ HI``, an optional start, and its scale.

    ``scale``: ``"log"`` fits ``ln p`` (needs ``LO > 0``), ``"linear"`` fits ``p``,
    ``"auto"`` (default) is log where ``LO > 0``.
    """

    name: str
    lo: float
    hi: float
    start: float | None = None
    scale: str = "auto"

    @classmethod
    def parse(cls, text: str, scale: str = "auto") -> Bound:
        """``NAME=LO:HI[:START]`` (the CLI's ``--param``)."""
        name, sep, rest = text.partition("=")
        parts = rest.split(":")
        if not sep or not name.strip() or len(parts) not in (2, 3):
            raise NeweulError(f"--param {text!r}: expected NAME=LO:HI[:START]")
        try:
            values = [float(v) for v in parts]
        except ValueError:
            raise NeweulError(f"--param {text!r}: LO, HI and START must be numbers") from None
        return cls(name.strip(), values[0], values[1], values[2] if len(values) == 3 else None,
                   scale)

    @property
    def log(self) -> bool:
        return self.scale == "log" or (self.scale == "auto" and self.lo > 0)

    def check(self) -> None:
        """One error for bounds that are not finite, ``LO ≥ HI``, a start outside them, a
        log scale with ``LO ≤ 0`` or an unknown scale."""
        where = f"--param {self.name}"
        if self.scale not in ("auto", "log", "linear"):
            raise NeweulError(f"{where}: unknown scale {self.scale!r} (auto, log, linear)")
        values = [self.lo, self.hi] + ([] if self.start is None else [self.start])
        if not all(np.isfinite(values)):
            raise NeweulError(f"{where}: bounds and start must be finite numbers")
        if self.lo >= self.hi:
            raise NeweulError(f"{where}: LO ({self.lo:g}) must be below HI ({self.hi:g})")
        if self.start is not None and not self.lo <= self.start <= self.hi:
            raise NeweulError(f"{where}: START {self.start:g} is outside [{self.lo:g}, "
                              f"{self.hi:g}]")
        if self.scale == "log" and self.lo <= 0:
            raise NeweulError(f"{where}: a log scale needs LO > 0 (got {self.lo:g})")

    def theta(self, value: float) -> float:
        return float(np.log(value)) if self.log else float(value)


@dataclass(frozen=True, repr=False)
class FitResult:
    """The outcome of :func:`identify`.

    Attributes
    ----------
    task : str
        ``"frf"``, ``"simulate"`` or ``"function"`` (:func:`~.identify_function.identify_function`).
    parameters, standard_errors : dict of str to float or None
        The estimates and their standard errors (``None`` where undetermined).
    undetermined : dict of str to str
        Why a parameter is not determined by the data.
    correlation : dict of str to dict of str to float or None
        Correlations of the estimates (``None`` for undetermined ones).
    cost : float
        ``½ Σ r²`` at the optimum.
    iterations, evaluations : int
        Iterations (Jacobian evaluations) of the best start; model evaluations of all starts.
    converged : bool
    message : str
        The optimizer's message (of the best start).
    end_point : dict of str to float
        Where the optimizer stopped, every parameter (also undetermined ones).
    scale : dict of str to str
        ``"log"`` or ``"linear"`` per parameter.
    at_bounds : tuple of str
        Parameters that end on a bound (their standard errors assume an interior optimum).
    starts : list of dict
        Per start: ``start``, ``end``, ``cost``, ``converged`` (or ``error``).
    residual_rms : float
    n_residuals : int
    model_name, data_file : str
    curve : dict
        The data and the fitted model at the data's frequencies or times (for :meth:`plot`).
    """

    task: str
    parameters: dict[str, float | None]
    standard_errors: dict[str, float | None]
    undetermined: dict[str, str]
    correlation: dict[str, dict[str, float | None] | None]
    cost: float
    iterations: int
    evaluations: int
    converged: bool
    message: str
    end_point: dict[str, float]
    scale: dict[str, str]
    at_bounds: tuple[str, ...]
    starts: list[dict[str, Any]]
    residual_rms: float
    n_residuals: int
    model_name: str = ""
    data_file: str = ""
    curve: dict[str, Any] = field(default_factory=dict)

    def __repr__(self) -> str:
        vals = ", ".join(f"{k} = {v:.6g}" if v is not None else f"{k} undetermined"
                         for k, v in self.parameters.items())
        return (f"FitResult({self.task}: {vals}; cost {self.cost:.3g}, "
                f"{'converged' if self.converged else 'NOT converged'})")

    def to_dict(self) -> dict[str, Any]:
        """The JSON content (docs/cli.md, ``neweul identify -o``)."""
        return {
            "model": self.model_name, "data": self.data_file, "task": self.task,
            "parameters": self.parameters, "standard_errors": self.standard_errors,
            "undetermined": self.undetermined, "correlation": self.correlation,
            "cost": self.cost, "iterations": self.iterations,
            "evaluations": self.evaluations, "converged": self.converged,
            "message": self.message, "residual_rms": self.residual_rms,
            "n_residuals": self.n_residuals, "scale": self.scale,
            "at_bounds": list(self.at_bounds), "end_point": self.end_point,
            "starts": self.starts,
        }

    def to_json(self, path: str | os.PathLike[str]) -> Path:
        """Write :meth:`to_dict` as JSON (``null`` for undetermined values), atomically."""
        path = check_output_path(path, (".json",), "fits")
        return atomic_write(path, json.dumps(self.to_dict(), indent=1, allow_nan=False) + "\n")

    def plot(self, path: str | os.PathLike[str]) -> Path:
        """Data and fitted model: Bode magnitude and phase, or each fitted signal over time
        (matplotlib; written atomically in the format of the suffix)."""
        from .plot import check_plot_path, new_figure, save_figure

        path = check_plot_path(path)
        c = self.curve
        if self.task == "frf":
            fig = new_figure(figsize=(8, 6), layout="constrained")
            ax_m, ax_p = fig.subplots(2, 1, sharex=True)
            f, data, fit = c["frequency_hz"], c["data"], c["fit"]
            ax_m.loglog(f, np.abs(data), "o", ms=3, label="data")
            ax_m.loglog(f, np.abs(fit), "-", label="fit")
            ax_p.semilogx(f, np.degrees(np.unwrap(np.angle(data))), "o", ms=3)
            ax_p.semilogx(f, np.degrees(np.unwrap(np.angle(fit))), "-")
            ax_m.set_ylabel(f"|{c['response']}/{c['input']}|")
            ax_p.set_ylabel("phase [deg]")
            ax_p.set_xlabel("frequency [Hz]")
            ax_m.legend()
        elif self.task == "function":
            fig = new_figure(figsize=(8, 4), layout="constrained")
            ax = fig.subplots()
            labels, res = c["labels"], np.asarray(c["residuals"])
            ax.bar(np.arange(res.size), res)
            ax.axhspan(-1.0, 1.0, color="0.9", zorder=0)
            ax.set_xticks(np.arange(res.size), labels, rotation=45, ha="right")
            ax.set_ylabel("residual [its standard deviation]")
        else:
            names = list(c["signals"])
            fig = new_figure(figsize=(8, 2.2 * len(names) + 1), layout="constrained")
            axes = np.atleast_1d(fig.subplots(len(names), 1, sharex=True))
            for ax, nm in zip(axes, names, strict=True):
                data, fit = c["signals"][nm]
                ax.plot(c["t"], data, "o", ms=3, label="data")
                ax.plot(c["t"], fit, "-", label="fit")
                ax.set_ylabel(nm)
            axes[0].legend()
            axes[-1].set_xlabel("t [s]")
        fig.suptitle(f"{self.model_name}: " + ", ".join(
            f"{k} = {v:.4g}" if v is not None else f"{k} undetermined"
            for k, v in self.parameters.items()))
        return save_figure(fig, path)


def _problem(module: GeneratedModel, data: Any, bounds: Sequence[Bound], task: str,
             p: proto.ParameterLike, options: dict[str, Any]) -> FitProblem:
    """Check the bounds and the data against the module; the :class:`FitProblem`."""
    names = list(module.PARAMETERS)
    if not bounds:
        raise NeweulError("no parameters to fit (--param NAME=LO:HI[:START])")
    for b in bounds:
        proto.name_index(names, b.name, "parameter")
        b.check()
    for b in bounds:
        lo, hi = module.PARAMETER_RANGES.get(b.name, (None, None))
        if (lo is not None and b.lo < lo) or (hi is not None and b.hi > hi):
            admissible = ("≥ " + f"{lo:g}" if hi is None else "≤ " + f"{hi:g}" if lo is None
                          else f"{lo:g} … {hi:g}")
            raise NeweulError(f"--param {b.name}: the bounds {b.lo:g} … {b.hi:g} leave its "
                              f"range {admissible} (the description's)")
    if len({b.name for b in bounds}) < len(bounds):
        raise NeweulError("a parameter is fitted twice: "
                          + ", ".join(b.name for b in bounds))
    if task == "frf":
        if not isinstance(data, FrequencyData):
            raise NeweulError("--task frf fits a frequency response (frequency_hz, magnitude, "
                              "phase_deg, as neweul frf -o writes it)")
        proto.name_index(list(module.INPUTS), data.input, "input")
        valid = [*module.OUTPUTS, *module.COORDINATES,
                 *(f"{d}_{c}" for d in ("d", "dd") for c in module.COORDINATES)]
        proto.name_index(valid, data.response, "response")
    elif task == "simulate":
        if not isinstance(data, TimeData):
            raise NeweulError("--task simulate fits a time history (t and signals, as neweul "
                              "simulate -o writes it)")
        t_end = options.get("t_end")
        if t_end is None or t_end <= 0:
            raise NeweulError("--task simulate needs the final time --t-end T > 0")
        if data.t[-1] > t_end:
            raise NeweulError(f"the data reach t = {data.t[-1]:g}, beyond --t-end {t_end:g}")
        column_index(module, list(data.columns))
    else:
        raise NeweulError(f"unknown task {task!r}; tasks are: frf, simulate")
    pv = proto.resolve_parameters(module, p)
    problem = FitProblem(tuple(b.name for b in bounds), tuple(b.log for b in bounds),
                         np.array([b.theta(b.lo) for b in bounds]),
                         np.array([b.theta(b.hi) for b in bounds]), pv, data, options)
    m = problem.counted_residuals()
    if m <= len(bounds):
        raise NeweulError(f"{m} residuals of nonzero weight cannot determine {len(bounds)} "
                          "parameters and their standard errors (more data points are needed)")
    return problem


def _starts(module: GeneratedModel, bounds: Sequence[Bound], problem: FitProblem, n: int,
            seed: int) -> np.ndarray:
    """``n`` starts in ``θ``: the given starts (else the model's values where they are inside
    the bounds, else the middle of the bounds in ``θ``), then a Latin hypercube in the
    bounds."""
    names = list(module.PARAMETERS)
    first = []
    for b, lo, hi in zip(bounds, problem.lower, problem.upper, strict=True):
        value = problem.p[names.index(b.name)]
        start = b.start if b.start is not None else value if b.lo <= value <= b.hi else None
        first.append(b.theta(start) if start is not None else 0.5 * (lo + hi))
    first = np.array(first)
    if n <= 1:
        return first[None, :]
    from scipy.stats import qmc

    sample = qmc.LatinHypercube(d=first.size, seed=seed).random(n - 1)
    rest = problem.lower + sample * (problem.upper - problem.lower)
    return np.vstack([first, rest])


def fit_start(module: GeneratedModel, problem: FitProblem, theta0: np.ndarray, max_nfev: int,
              tolerance: float) -> dict[str, Any]:
    """One least-squares run from ``theta0``: ``theta``, ``cost``, ``njev``, ``nfev``,
    ``status``, ``message`` (or ``error``: its one-line message, the run failed)."""
    from scipy.optimize import least_squares

    model = Residuals(module, problem)
    try:
        with np.errstate(all="ignore"):
            res = least_squares(model.residuals, theta0, jac=model.jacobian,
                                bounds=(problem.lower, problem.upper), method="trf",
                                x_scale="jac", max_nfev=max_nfev, ftol=tolerance,
                                xtol=tolerance, gtol=tolerance)
    except (NeweulError, ArithmeticError, np.linalg.LinAlgError, ValueError) as exc:
        return {"theta0": theta0, "error": " ".join(str(exc).split()) or type(exc).__name__,
                "nfev": model.evaluations}
    return {"theta0": theta0, "theta": res.x, "cost": float(res.cost), "njev": int(res.njev),
            "nfev": model.evaluations, "status": int(res.status), "message": str(res.message)}


def fit_on_worker(source: str, problem: FitProblem, theta0: np.ndarray, max_nfev: int,
                  tolerance: float) -> dict[str, Any]:
    """:func:`fit_start` on a Dask worker (the module shipped as its source text)."""
    from .sweep_tasks import module_from_source

    return fit_start(module_from_source(source), problem, theta0, max_nfev, tolerance)


def _run_starts(module: GeneratedModel, problem: FitProblem, starts: np.ndarray, max_nfev: int,
                tolerance: float, workers: int, scheduler: str | None, client: Any
                ) -> list[dict[str, Any]]:
    if len(starts) == 1 or (workers <= 0 and not scheduler and client is None):
        return [fit_start(module, problem, s, max_nfev, tolerance) for s in starts]
    from .sweep import connect

    path = module.path
    if not path:
        raise NeweulError("identify: the module has no file to ship to the Dask workers")
    source = Path(path).read_text(encoding="utf-8")
    own = client is None
    cluster = None
    if own:
        client, cluster = connect(scheduler, workers=max(workers, 1))
    try:
        shipped = client.scatter(source, broadcast=True, hash=False)
        futures = [client.submit(fit_on_worker, shipped, problem, s, max_nfev, tolerance,
                                 pure=False) for s in starts]
        return client.gather(futures)
    finally:
        if own:
            client.close()
            if cluster is not None:
                cluster.close()


def identify(
    module: ModelLike, data: Any, bounds: Sequence[Bound | str], task: str = "frf", *,
    input: str | None = None, response: str | None = None,
    columns: Sequence[str] | None = None, t_end: float | None = None,
    p: proto.ParameterLike = None, u: Mapping[str, float] | None = None,
    at: str = "equilibrium", fixed: Sequence[str] = (),
    start: Mapping[str, float] | None = None, damping: str = "loss",
    phase_weight: float = 1.0, method: str = "RK45", rtol: float = 1e-8,
    atol: float = 1e-10, starts: int = 1, seed: int = 0, workers: int = 0,
    scheduler: str | None = None, client: Any = None, max_nfev: int = 100,
    tolerance: float = 1e-10,
) -> FitResult:
    """Fit parameters of a generated module to measured data (module docstring).

    Parameters
    ----------
    module
        A generated module (or its path).
    data
        The data file (a CSV as ``neweul frf -o`` or ``neweul simulate -o`` writes it) or a
        :class:`~neweul_py.analysis.identify_data.FrequencyData` /
        :class:`~neweul_py.analysis.identify_data.TimeData`.
    bounds
        :class:`Bound` per fitted parameter, or ``"NAME=LO:HI[:START]"`` texts.
    task
        ``"frf"`` or ``"simulate"``.
    input, response
        ``frf``: the model's input and output of the data.
    columns
        ``simulate``: the fitted signals (default: every signal column of the data).
    t_end
        ``simulate``: the final time of the simulation (≥ the data's last time).
    p
        The parameters that are not fitted (and the default starts' parents).
    u, at, fixed, start, damping
        ``frf``: the inputs held, the operating point (``"equilibrium"`` — found again for
        every trial — or ``"initial"``), coordinates held, the equilibrium search's start,
        the damping form (as :func:`~neweul_py.analysis.frf.frequency_response`);
        ``simulate``: ``u`` holds inputs.
    phase_weight
        ``frf``: weight of the phase residuals [rad] against the log-magnitude ones
        (0: magnitude only).
    method, rtol, atol
        ``simulate``: the integrator of the state and its sensitivities.
    starts, seed
        Number of starts: the given ones (else the values of ``p`` where they are inside the
        bounds, else the middle of the bounds), then a Latin hypercube in the bounds
        (seeded).
    workers, scheduler, client
        Run the starts on Dask: a local cluster of ``workers`` processes (free ports, no
        dashboard), a scheduler's address, or a ``dask.distributed.Client`` (left open; the
        ``sweep`` extra); sequential otherwise.
    max_nfev, tolerance
        Largest number of model evaluations per start; ``ftol``, ``xtol`` and ``gtol`` of
        :func:`scipy.optimize.least_squares`.

    Returns
    -------
    FitResult

    Raises
    ------
    NeweulError, DataError
        For parameters the model lacks, bounds with ``LO ≥ HI`` or beyond the parameter's
        declared range (``PARAMETER_RANGES``), a start outside them, data of the other task or
        with missing, non-finite or non-monotone columns.
    SolverError
        When no start could evaluate the model.
    """
    module = as_model(module)
    bounds = [b if isinstance(b, Bound) else Bound.parse(b) for b in bounds]
    if isinstance(data, str | os.PathLike):
        data = (read_frequency_data(data, response, input) if task == "frf"
                else read_time_data(data, columns) if task == "simulate" else data)
    if isinstance(data, FrequencyData) and (input or response):
        data = FrequencyData(data.frequency_hz, data.H, data.weight, response or data.response,
                             input or data.input, data.file)
    if at not in ("equilibrium", "initial"):
        raise NeweulError(f"unknown operating point {at!r} (equilibrium, initial)")
    if not (np.isfinite(phase_weight) and phase_weight >= 0):
        raise NeweulError(f"phase_weight must be a number ≥ 0, got {phase_weight!r}")
    if int(starts) < 1:
        raise NeweulError(f"starts must be at least 1, got {starts}")
    options = {"at": at, "u": u, "fixed": tuple(fixed), "start": start, "damping": damping,
               "phase_weight": float(phase_weight), "t_end": t_end, "method": method,
               "rtol": rtol, "atol": atol}
    problem = _problem(module, data, bounds, task, p, options)
    runs = _run_starts(module, problem, _starts(module, bounds, problem, int(starts), seed),
                       int(max_nfev), float(tolerance), int(workers), scheduler, client)
    good = [r for r in runs if "error" not in r]
    if not good:
        raise SolverError(f"identify: no start could evaluate the model: {runs[0]['error']}")
    best = min(good, key=lambda r: r["cost"])
    model = Residuals(module, problem)
    r, J, curve = model.evaluate(best["theta"])
    counted = problem.counted_residuals()
    errors, correlation, undetermined = fit_statistics(problem, best["theta"], r, J, m=counted)
    for name, why in equal_cost_spread(problem, best, good, errors).items():
        undetermined.setdefault(name, why)
        errors[name] = correlation[name] = None
    for row in correlation.values():
        if row is not None:
            row.update({nm: None for nm in undetermined if nm in row})
    values = problem.values(best["theta"])
    names = list(problem.names)
    end = {nm: float(v) for nm, v in zip(names, values, strict=True)}
    tol = 1e-8 * np.maximum(1.0, np.abs(problem.upper - problem.lower))
    at_bounds = tuple(nm for j, nm in enumerate(names)
                      if min(best["theta"][j] - problem.lower[j],
                             problem.upper[j] - best["theta"][j]) <= tol[j])
    summary = []
    for run in runs:
        entry: dict[str, Any] = {"start": {nm: float(v) for nm, v in zip(
            names, problem.values(run["theta0"]), strict=True)}}
        if "error" in run:
            entry["error"] = run["error"]
        else:
            entry.update(end={nm: float(v) for nm, v in zip(
                names, problem.values(run["theta"]), strict=True)}, cost=run["cost"],
                converged=run["status"] > 0)
        summary.append(entry)
    if isinstance(data, FrequencyData):
        curve_out = {"frequency_hz": data.frequency_hz, "data": data.H, "fit": curve,
                     "response": data.response, "input": data.input}
    else:
        curve_out = {"t": data.t, "signals": {nm: (data.columns[nm], curve[nm])
                                              for nm in data.columns}}
    return FitResult(
        task=task,
        parameters={nm: (None if nm in undetermined else end[nm]) for nm in names},
        standard_errors=errors, undetermined=undetermined, correlation=correlation,
        cost=float(0.5 * r @ r), iterations=best["njev"],
        evaluations=sum(int(run.get("nfev", 0)) for run in runs),
        converged=best["status"] > 0, message=best["message"], end_point=end,
        scale={nm: "log" if lg else "linear" for nm, lg in zip(names, problem.log,
                                                                 strict=True)},
        at_bounds=at_bounds, starts=summary,
        residual_rms=float(np.sqrt(float(r @ r) / counted)) if counted else 0.0,
        n_residuals=counted,
        model_name=str(module.MODEL_NAME),
        data_file=data.file, curve=curve_out)
