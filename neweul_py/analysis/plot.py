"""Plots of simulation results (needs the optional extra ``plot``: matplotlib)."""

from __future__ import annotations

import io
import os
from pathlib import Path

from ..atomic import atomic_write
from ..errors import NeweulError
from .results import SimulationResult

__all__ = ["plot_result"]


def _label(name: str, unit: str) -> str:
    return f"{name} [{unit}]" if unit and unit != "-" else name


def plot_result(result: SimulationResult, path: str | os.PathLike[str], dpi: int = 120) -> Path:
    """Plot coordinates (top) and outputs (bottom, if any) over time into an image file.

    The format follows the suffix (``.png``, ``.pdf``, ``.svg``); the file is written atomically.
    Uses matplotlib's object API (no global backend switch, no window).
    """
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:
        raise NeweulError(
            "plotting needs matplotlib: pip install 'neweul-py[plot]'"
        ) from None
    path = Path(path)
    fmt = path.suffix.lstrip(".").lower() or "png"
    rows = 2 if result.output_names else 1
    fig = Figure(figsize=(8, 3.2 * rows), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(rows, 1, sharex=True, squeeze=False)[:, 0]
    units = result.units
    n = len(result.coordinates)
    for j, name in enumerate(result.coordinates):
        axes[0].plot(result.t, result.y[:, j], label=_label(name, units[1 + j]))
    axes[0].set_ylabel("coordinates")
    axes[0].set_title(f"{result.model_name}: simulation ({result.method})")
    if result.output_names:
        for j, name in enumerate(result.output_names):
            axes[1].plot(result.t, result.outputs[:, j],
                         label=_label(name, units[1 + 2 * n + j]))
        axes[1].set_ylabel("outputs")
    for ax in axes:
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper right", fontsize="small", ncol=min(4, max(1, len(ax.lines) // 6 + 1)))
    axes[-1].set_xlabel("t [s]")
    buf = io.BytesIO()
    try:
        fig.savefig(buf, format=fmt, dpi=dpi)
    except ValueError as exc:
        raise NeweulError(f"{path}: cannot write a plot in this format ({exc})") from None
    return atomic_write(path, buf.getvalue())
