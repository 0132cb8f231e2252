"""Overlay plot of a :class:`~neweul_py.analysis.compare.Comparison`: ours solid, the reference
dashed, one axis per signal (at most :data:`MAX_AXES`), failing signals titled in red."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from .plot import check_plot_path, new_figure, save_figure

__all__ = ["MAX_AXES", "plot_comparison"]

#: Signals drawn (the worst ones first when there are more).
MAX_AXES = 8


def _ordered(cmp: Any) -> list[Any]:
    errs = sorted(cmp.errors, key=lambda e: (e.passed, -e.max_rel_error))
    return errs[:MAX_AXES]


def plot_comparison(cmp: Any, path: str | os.PathLike[str], dpi: int = 120) -> Path:
    """Write the overlay plot of ``cmp`` to ``path`` (format by suffix, atomically)."""
    path = check_plot_path(path)
    if cmp.kind in ("equilibrium", "modes"):
        return _points(cmp, path, dpi)
    errs = [e for e in _ordered(cmp) if e.name in cmp.values]
    freq = cmp.kind == "frequency"
    cols = 2 if freq else 1
    fig = new_figure(figsize=(7 * cols / 1.4 + 1.5, 2.3 * len(errs) + 0.6),
                     layout="constrained")
    axes = fig.subplots(len(errs), cols, squeeze=False, sharex=True)
    for row, e in zip(axes, errs, strict=True):
        ours, ref = cmp.values[e.name]
        color = "black" if e.passed else "tab:red"
        if freq:
            row[0].loglog(cmp.x, np.abs(ours), label="result")
            row[0].loglog(cmp.x, np.abs(ref), "--", label="reference")
            row[0].set_ylabel(f"|{e.name}|")
            row[1].semilogx(cmp.x, np.degrees(np.unwrap(np.angle(ours))), label="result")
            row[1].semilogx(cmp.x, np.degrees(np.unwrap(np.angle(ref))), "--", label="reference")
            row[1].set_ylabel("phase [deg]")
        else:
            row[0].plot(cmp.x, ours.real, label="result")
            row[0].plot(cmp.x, ref.real, "--", label="reference")
            row[0].set_ylabel(e.name)
        row[0].set_title(f"{e.name}: max rel. error {e.max_rel_error:.3g} "
                         f"({'ok' if e.passed else 'FAIL'})", color=color, fontsize="small")
        for ax in row:
            ax.grid(True, which="both", alpha=0.3)
    axes[0, 0].legend(loc="best", fontsize="small")
    for ax in axes[-1]:
        ax.set_xlabel("frequency [Hz]" if freq else "t [s]")
    return save_figure(fig, path, dpi)


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
        ax.set_ylabel("value")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    ax.set_title(cmp.summary(), fontsize="small")
    return save_figure(fig, path, dpi)
