"""What a sweep worker runs: import the generated module from its source text (once per
worker), then one task per case, each failure recorded with its message.

Tasks map ``(module, parameters, options)`` to one row of named numbers:

- ``simulate``: ``final_<column>`` (and ``max_``/``min_``/``rms_`` with ``stats``) of every
  column of the :class:`~neweul_py.analysis.results.SimulationResult`, and ``nfev``;
- ``equilibrium``: the coordinates (and ``lambda_<constraint>``), ``residual``, ``iterations``;
- ``modes``: ``f<i>_hz`` and ``zeta<i>`` of the first ``n_modes`` oscillating modes (default:
  as many as there are modes, at most 6; NaN where there are fewer), ``n_oscillating``,
  ``n_unstable``;
- ``frf``: ``peak_frequency_hz`` and ``peak_magnitude`` (per output/input pair:
  ``..._<output>__<input>``) over the frequencies ``f``;
- a callable ``task(module, p) -> mapping`` (a module-level function, so that it pickles).
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..atomic import atomic_write
from ..errors import NeweulError
from .module import load_generated

__all__ = ["STATS", "TASKS", "module_from_source", "run_case", "run_cases"]

#: Statistics of a simulated column offered by the ``simulate`` task.
STATS: tuple[str, ...] = ("final", "max", "min", "rms")

Row = dict[str, float]


def _simulate(module: Any, p: Mapping[str, float], opt: Mapping[str, Any]) -> Row:
    from .simulate import simulate

    kw = {k: opt[k] for k in ("t_start", "method", "rtol", "atol", "n_out", "u", "x0")
          if k in opt}
    res = simulate(module, opt["t_end"], p=p, **kw)
    table = res.table
    row: Row = {}
    for stat in opt.get("stats", ("final",)):
        values = {"final": table[-1], "max": table.max(axis=0), "min": table.min(axis=0),
                  "rms": np.sqrt(np.mean(table**2, axis=0))}[stat]
        row.update({f"{stat}_{n}": float(v) for n, v in zip(res.names[1:], values[1:],
                                                             strict=True)})
    row["nfev"] = float(res.nfev)
    return row


def _operating_point(module: Any, p: Mapping[str, float], opt: Mapping[str, Any]) -> Any:
    from .equilibrium import equilibrium
    from .linearize import linearize

    if opt.get("at", "equilibrium") == "initial":
        return linearize(module, p=p, u0=opt.get("u"))
    eq = equilibrium(module, p=p, u=opt.get("u"), y0=opt.get("y0"))
    return linearize(module, eq, p=eq.p, u0=eq.u)


def _equilibrium(module: Any, p: Mapping[str, float], opt: Mapping[str, Any]) -> Row:
    from .equilibrium import equilibrium

    eq = equilibrium(module, p=p, u=opt.get("u"), y0=opt.get("y0"),
                     fixed=opt.get("fixed", ()))
    return {**eq.as_dict(), "residual": float(eq.residual), "iterations": float(eq.iterations)}


def _modes(module: Any, p: Mapping[str, float], opt: Mapping[str, Any]) -> Row:
    from .modes import modes

    res = modes(_operating_point(module, p, opt), undamped=bool(opt.get("undamped", False)))
    osc = np.flatnonzero(res.oscillating)
    n_modes = int(opt.get("n_modes") or min(6, len(res.kind)))
    row: Row = {}
    for i in range(n_modes):
        found = i < osc.size
        row[f"f{i + 1}_hz"] = float(res.frequency_hz[osc[i]]) if found else np.nan
        row[f"zeta{i + 1}"] = float(res.damping_ratio[osc[i]]) if found else np.nan
    row["n_oscillating"] = float(osc.size)
    row["n_unstable"] = float(res.unstable.sum())
    return row


def _frf(module: Any, p: Mapping[str, float], opt: Mapping[str, Any]) -> Row:
    from .frf import frequency_response

    f = np.asarray(opt["f"], dtype=float)
    fr = frequency_response(_operating_point(module, p, opt), f, opt.get("inputs"),
                            opt.get("outputs"))
    mag = fr.magnitude
    single = mag.shape[1] == 1 and mag.shape[2] == 1
    row: Row = {}
    for i, o in enumerate(fr.outputs):
        for j, u in enumerate(fr.inputs):
            sfx = "" if single else f"_{o}__{u}"
            k = int(np.argmax(mag[:, i, j]))
            row[f"peak_frequency_hz{sfx}"] = float(f[k])
            row[f"peak_magnitude{sfx}"] = float(mag[k, i, j])
    return row


#: The built-in tasks by name.
TASKS: dict[str, Callable[[Any, Mapping[str, float], Mapping[str, Any]], Row]] = {
    "simulate": _simulate,
    "equilibrium": _equilibrium,
    "modes": _modes,
    "frf": _frf,
}


def module_from_source(source: str) -> Any:
    """Import a generated module from its source text on this machine (a worker).

    The text is written once to ``<tmp>/neweul-sweep-<uid>/module_<sha>.py`` and imported with
    :func:`~neweul_py.analysis.module.load_generated`, which keeps it in ``sys.modules`` under a
    name derived from the content: later chunks of the same sweep reuse the import.
    """
    digest = hashlib.sha256(source.encode("utf-8")).hexdigest()[:20]
    uid = os.getuid() if hasattr(os, "getuid") else "user"
    path = Path(tempfile.gettempdir()) / f"neweul-sweep-{uid}" / f"module_{digest}.py"
    if not path.is_file():
        atomic_write(path, source)
    return load_generated(path)


def _message(exc: BaseException) -> str:
    text = " ".join(str(exc).split())  # one line
    return f"{type(exc).__name__}: {text}" if not isinstance(exc, NeweulError) else text


def run_case(
    module: Any,
    task: str | Callable[..., Mapping[str, float]],
    options: Mapping[str, Any],
    case: Mapping[str, float],
) -> dict[str, Any]:
    """One case: ``{"ok": True, "error": "", **row}`` or ``{"ok": False, "error": message}``.

    Every exception of the case is caught and recorded (a singular model, a failed
    integration, a bug in a user task): one case never aborts a sweep.
    """
    try:
        with np.errstate(all="ignore"):
            if callable(task):
                row = task(module, dict(case))
            else:
                row = TASKS[task](module, dict(case), options)
        return {"ok": True, "error": "", **{str(k): float(v) for k, v in row.items()}}
    except Exception as exc:  # recorded per case by design (see docstring)
        return {"ok": False, "error": _message(exc)}


def run_cases(
    source: str,
    task: str | Callable[..., Mapping[str, float]],
    options: Mapping[str, Any],
    cases: Sequence[Mapping[str, float]],
) -> list[dict[str, Any]]:
    """A chunk of cases on one worker: import the module (:func:`module_from_source`), then
    :func:`run_case` for each."""
    try:
        module = module_from_source(source)
    except Exception as exc:  # the module cannot be imported here: every case records why
        return [{"ok": False, "error": f"worker could not import the module: {_message(exc)}"}
                for _ in cases]
    return [run_case(module, task, options, c) for c in cases]
