"""Overlay plot of a :class:`~neweul_py.analysis.compare.Comparison`: ours solid, the reference
dashed, one row per signal (at most :data:`MAX_AXES`, failing signals titled in red), each
axis labelled with its unit, and beside the overlay the error curve — ``|a − b|`` in the
signal's unit for time histories (with the tolerance ``atol + rtol·max|b|`` as a line), the
pointwise relative error ``|H − H_ref| / |H_ref|`` for frequency responses (with ``rtol``).
A constrained layout keeps every label inside the figure."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from .plot import check_plot_path, new_figure, save_figure

__all__ = ["ERROR_FLOOR", "MAX_AXES", "comparison_figure", "plot_comparison"]

#: Signals drawn (the worst ones first when there are more).
MAX_AXES = 8


def _ordered(cmp: Any) -> list[Any]:
    errs = sorted(cmp.errors, key=lambda e: (e.passed, -e.max_rel_error))
    return errs[:MAX_AXES]


#: Errors are drawn down to this fraction of the larger of their maximum and the tolerance
#: (exact agreement, at the start of a run, would stretch a log axis to 1e-300).
ERROR_FLOOR = 1e-6


def _floored(err: np.ndarray, tol: float) -> np.ndarray:
    top = max(float(np.max(err, initial=0.0)), float(tol), np.finfo(float).tiny)
    return np.maximum(err, ERROR_FLOOR * top)


def _with_unit(label: str, unit: str) -> str:
    return f"{label} [{unit}]" if unit else label


def plot_comparison(cmp: Any, path: str | os.PathLike[str], dpi: int = 120) -> Path:
    """Write the overlay plot of ``cmp`` to ``path`` (format by suffix, atomically)."""
    path = check_plot_path(path)
    if cmp.kind in ("equilibrium", "modes"):
        return _points(cmp, path, dpi)
    return save_figure(comparison_figure(cmp), path, dpi)


def comparison_figure(cmp: Any) -> Any:
    """The figure of :func:`plot_comparison` for time histories and frequency responses
    (Agg canvas, not saved): per signal the overlay (and phase) and the error curve."""
    errs = [e for e in _ordered(cmp) if e.name in cmp.values]
    freq = cmp.kind == "frequency"
    units = getattr(cmp, "units", {}) or {}
    cols = 3 if freq else 2
    fig = new_figure(figsize=(3.6 * cols + 0.8, 2.3 * len(errs) + 0.6),
                     layout="constrained")
    axes = fig.subplots(len(errs), cols, squeeze=False, sharex=True)
    for row, e in zip(axes, errs, strict=True):
        ours, ref = cmp.values[e.name]
        unit = units.get(e.name, "")
        color = "black" if e.passed else "tab:red"
        if freq:
            row[0].loglog(cmp.x, np.abs(ours), label="result")
            row[0].loglog(cmp.x, np.abs(ref), "--", label="reference")
            row[0].set_ylabel(_with_unit(f"|{e.name}|", unit))
            row[1].semilogx(cmp.x, np.degrees(np.unwrap(np.angle(ours))), label="result")
            row[1].semilogx(cmp.x, np.degrees(np.unwrap(np.angle(ref))), "--", label="reference")
            row[1].set_ylabel("phase [deg]")
            rel = np.abs(ours - ref) / np.maximum(np.abs(ref), np.finfo(float).tiny)
            row[2].loglog(cmp.x, _floored(rel, e.rtol), color="tab:purple", label="error")
            row[2].axhline(e.rtol, color="0.5", linestyle=":", label="rtol")
            row[2].set_ylabel(f"|Δ{e.name}| / |{e.name}_ref|")
        else:
            row[0].plot(cmp.x, ours.real, label="result")
            row[0].plot(cmp.x, ref.real, "--", label="reference")
            row[0].set_ylabel(_with_unit(e.name, unit))
            err = np.abs(ours.real - ref.real)
            tol = e.atol + e.rtol * float(np.max(np.abs(ref.real)))
            row[1].semilogy(cmp.x, _floored(err, tol), color="tab:purple", label="error")
            row[1].axhline(tol, color="0.5", linestyle=":", label="tolerance")
            row[1].set_ylabel(_with_unit(f"|Δ{e.name}|", unit))
        row[0].set_title(f"{e.name}: max rel. error {e.max_rel_error:.3g} "
                         f"({'ok' if e.passed else 'FAIL'})", color=color, fontsize="small")
        for ax in row:
            ax.grid(True, which="both", alpha=0.3)
    axes[0, 0].legend(loc="best", fontsize="small")
    axes[0, -1].legend(loc="best", fontsize="small")
    for ax in axes[-1]:
        ax.set_xlabel("frequency f [Hz]" if freq else "time t [s]")
    return fig


def _points(cmp: Any, path: Path, dpi: int) -> Path:
    fig = new_figure(figsize=(7, 4), layout="constrained")
    ax = fig.subplots()
    names = [e.name for e in cmp.errors]
    if cmp.kind == "modes":
        ours, ref = cmp.values["f_hz"]
        ax.plot(ref, ours, "o")
        lim = [np.nanmin([ref.min(), np.nanmin(ours)]), np.nanmax([ref.max(), np.nanmax(ours)])]
        ax.plot(lim, lim, "--", color="gray", label="equal")
        ax.set_xlabel("reference frequency [Hz]")
        ax.set_ylabel("our frequency [Hz]")
        for e, x, y in zip(cmp.errors, ref, ours, strict=True):
            ax.annotate(e.name, (x, y), fontsize="x-small",
                        color="black" if e.passed else "tab:red")
    else:
        idx = np.arange(len(names))
        ours = [cmp.values[n][0][0] for n in names]
        ref = [cmp.values[n][1][0] for n in names]
        ax.bar(idx - 0.2, ours, 0.4, label="result")
        ax.bar(idx + 0.2, ref, 0.4, label="reference")
        ax.set_xticks(idx, names, rotation=45, ha="right", fontsize="small")
        found = {getattr(cmp, "units", {}).get(n, "") for n in names}
        ax.set_ylabel(_with_unit("value", found.pop() if len(found) == 1 else ""))
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    ax.set_title(cmp.summary(), fontsize="small")
    return save_figure(fig, path, dpi)
