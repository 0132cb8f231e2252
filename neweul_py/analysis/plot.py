"""Plots of analysis results (needs the optional extra ``plot``: matplotlib), and the check of
plot file names that every command makes *before* it computes anything
(:func:`check_plot_path`; result files: :func:`~neweul_py.analysis.results.check_output_path`).

Figures are built with matplotlib's object API (no global backend switch, no window) and written
atomically (:func:`neweul_py.atomic.atomic_write`), so a failed or interrupted write never
leaves a partial file.
"""

from __future__ import annotations

import io
import os
from pathlib import Path
from typing import Any

from ..atomic import atomic_write
from ..errors import NeweulError
from .results import SimulationResult

__all__ = [
    "check_plot_path",
    "new_figure",
    "plot_result",
    "save_figure",
    "supported_plot_formats",
]

_INSTALL_HINT = "plotting needs matplotlib: pip install 'neweul-py[plot]'"


def supported_plot_formats() -> list[str]:
    """File formats matplotlib can write (``png``, ``pdf``, ``svg``, …), sorted.

    Raises
    ------
    NeweulError
        When matplotlib is not installed (with the install hint).
    """
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
    except ImportError:
        raise NeweulError(_INSTALL_HINT) from None
    return sorted(FigureCanvasAgg.get_supported_filetypes())


def check_plot_path(path: str | os.PathLike[str]) -> Path:
    """``path`` if matplotlib is installed and can write its suffix as a plot format.

    Commands call this before computing, so that a typo in ``--plot`` fails at once.

    Raises
    ------
    NeweulError
        Without matplotlib (the install hint), or for a missing or unsupported suffix (listing
        the formats matplotlib writes).
    """
    path = Path(path)
    formats = supported_plot_formats()
    fmt = path.suffix.lower().lstrip(".")
    if fmt not in formats:
        raise NeweulError(
            f"{path}: cannot write a plot as {('.' + fmt) if fmt else '(no suffix)'}; "
            f"formats: {', '.join('.' + f for f in formats)}"
        )
    return path


def save_figure(fig: Any, path: str | os.PathLike[str], dpi: int = 120) -> Path:
    """Render a matplotlib ``Figure`` in the format of the suffix of ``path`` and write it
    atomically (missing parent directories are created)."""
    path = check_plot_path(path)
    buf = io.BytesIO()
    try:
        fig.savefig(buf, format=path.suffix.lower().lstrip("."), dpi=dpi)
    except ValueError as exc:  # a format matplotlib lists but cannot write here
        raise NeweulError(f"{path}: cannot write a plot in this format ({exc})") from None
    return atomic_write(path, buf.getvalue())


def new_figure(**kwargs: Any) -> Any:
    """A matplotlib ``Figure`` on an Agg canvas (object API: no pyplot state, no window)."""
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:
        raise NeweulError(_INSTALL_HINT) from None
    fig = Figure(**kwargs)
    FigureCanvasAgg(fig)
    return fig


def _label(name: str, unit: str) -> str:
    return f"{name} [{unit}]" if unit and unit != "-" else name


def plot_result(result: SimulationResult, path: str | os.PathLike[str], dpi: int = 120) -> Path:
    """Plot coordinates (top) and outputs (bottom, if any) over time into an image file.

    The format follows the suffix (``.png``, ``.pdf``, ``.svg``, … — see
    :func:`check_plot_path`); the file is written atomically.
    """
    path = check_plot_path(path)
    rows = 2 if result.output_names else 1
    fig = new_figure(figsize=(8, 3.2 * rows), layout="constrained")
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
    return save_figure(fig, path, dpi)
