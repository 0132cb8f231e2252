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

import numpy as np

from ..atomic import atomic_write
from ..errors import NeweulError
from .module import ModelLike, as_model
from .results import SimulationResult

__all__ = [
    "SCALE_SPLIT",
    "check_plot_path",
    "frf_comparison_figure",
    "group_signals",
    "new_figure",
    "plot_bode",
    "plot_frf_comparison",
    "plot_result",
    "result_figure",
    "save_figure",
    "signal_units",
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


#: Signals of one unit whose ranges differ by more than this factor get separate axes.
SCALE_SPLIT = 20.0
_LEGEND = {"loc": "upper left", "bbox_to_anchor": (1.01, 1.0), "borderaxespad": 0.0,
           "fontsize": "small", "frameon": False}


def group_signals(units: list[str], data: np.ndarray, split: float = SCALE_SPLIT
                  ) -> list[list[int]]:
    """Columns of ``data`` (nt, n) grouped for plotting: one group per unit, and within a unit
    separate groups for signals whose ranges (largest magnitude) differ by more than ``split``
    — so a 300 rad spin does not flatten 0.1 rad oscillations. Groups keep the column order of
    their first member; deterministic."""
    with np.errstate(invalid="ignore"):
        scale = np.nanmax(np.abs(data), axis=0) if data.size else np.zeros(len(units))
    scale = np.where(np.isfinite(scale), scale, 0.0)
    groups: list[list[int]] = []
    for unit in dict.fromkeys(units):
        members = sorted((j for j, u in enumerate(units) if u == unit), key=lambda j: -scale[j])
        current: list[int] = []
        for j in members:
            if current and scale[j] * split < scale[current[0]]:
                groups.append(sorted(current))
                current = []
            current.append(j)
        if current:
            groups.append(sorted(current))
    return sorted(groups, key=lambda g: g[0])


def _axis_label(names: list[str], unit: str, what: str) -> str:
    unit = "" if unit in ("", "-") else unit
    if len(names) == 1:
        return _label(names[0], unit)
    return f"{what} [{unit}]" if unit else what


def plot_result(result: SimulationResult, path: str | os.PathLike[str], dpi: int = 120) -> Path:
    """Plot coordinates and outputs over time into an image file, one axis per unit group.

    Coordinates come first, then outputs; each group of one unit (split further where the
    ranges differ by more than :data:`SCALE_SPLIT`, :func:`group_signals`) gets its own axis,
    labelled with the signal (or the kind) and its unit; legends sit outside the axes, on the
    right. The format follows the suffix (``.png``, ``.pdf``, ``.svg``, … — see
    :func:`check_plot_path`); the file is written atomically.
    """
    path = check_plot_path(path)
    return save_figure(result_figure(result), path, dpi)


def result_figure(result: SimulationResult) -> Any:
    """The figure of :func:`plot_result` (Agg canvas, not saved)."""
    units = result.units
    n = len(result.coordinates)
    panels: list[tuple[list[str], np.ndarray, str, str]] = []
    for names, data, unit_list, what in (
        (list(result.coordinates), np.asarray(result.y)[:, :n], units[1:1 + n], "coordinates"),
        (list(result.output_names), np.asarray(result.outputs), units[1 + 2 * n:], "outputs"),
    ):
        if not names:
            continue
        for group in group_signals(list(unit_list), data):
            panels.append(([names[j] for j in group], data[:, group], unit_list[group[0]], what))
    fig = new_figure(figsize=(8.5, 1.2 + 2.0 * len(panels)), layout="constrained")
    axes = fig.subplots(len(panels), 1, sharex=True, squeeze=False)[:, 0]
    for ax, (names, data, unit, what) in zip(axes, panels, strict=True):
        for j, name in enumerate(names):
            ax.plot(result.t, data[:, j], label=name, linewidth=1.2)
        ax.set_ylabel(_axis_label(names, unit, what))
        ax.grid(True, alpha=0.3)
        if len(names) > 1:
            ax.legend(**_LEGEND)
    axes[0].set_title(f"{result.model_name}: simulation ({result.method})")
    axes[-1].set_xlabel("time t [s]")
    return fig


def signal_units(module: ModelLike) -> dict[str, str]:
    """Units of what a frequency response may output — the model outputs (``OUTPUT_UNITS``),
    coordinates (``COORDINATE_UNITS``) and their first and second time derivatives — and of
    its inputs (``INPUT_UNITS``; names are unique across these kinds)."""
    module = as_model(module)
    units: dict[str, str] = {}
    for name, unit in zip(module.COORDINATES, module.COORDINATE_UNITS, strict=False):
        unit = "" if unit in ("", "-") else unit
        units[name] = unit
        units[f"d_{name}"] = f"{unit}/s" if unit else "1/s"
        units[f"dd_{name}"] = f"{unit}/s²" if unit else "1/s²"
    for name, unit in zip(module.OUTPUTS, module.OUTPUT_UNITS, strict=False):
        units[name] = "" if unit in ("", "-") else unit
    for name, unit in zip(module.INPUTS, module.INPUT_UNITS, strict=False):
        units[name] = "" if unit in ("", "-") else unit
    return units


def _ratio_unit(output_unit: str, input_unit: str) -> str:
    out = output_unit if output_unit not in ("", "-") else "1"
    inp = input_unit if input_unit not in ("", "-") else ""
    if inp and out == inp:
        return "1"
    if not inp:
        return "" if out == "1" else out
    if " " in inp or "/" in inp:
        inp = f"({inp})"
    return f"{out}/{inp}" if out != "1" else f"1/{inp}"


def plot_bode(
    frequency_hz: np.ndarray,
    H: np.ndarray,
    outputs: tuple[str, ...] | list[str],
    inputs: tuple[str, ...] | list[str],
    fig: Any,
    *,
    output_units: dict[str, str] | None = None,
    input_units: dict[str, str] | None = None,
    log_frequency: bool = True,
) -> Any:
    """Bode diagram of ``H`` (nf, ny, nu) into ``fig``: magnitude (log) with its unit
    (output unit per input unit) and unwrapped phase in degrees over frequency in Hz (log
    axis unless ``log_frequency`` is false); legends outside the axes."""
    output_units = output_units or {}
    input_units = input_units or {}
    ax_m, ax_p = fig.subplots(2, 1, sharex=True)
    mag = np.abs(H)
    phase = np.degrees(np.unwrap(np.angle(H), axis=0))
    ratio_units = set()
    for i, o in enumerate(outputs):
        for j, u in enumerate(inputs):
            label = f"{o}/{u}"
            ax_m.plot(frequency_hz, mag[:, i, j], label=label)
            ax_p.plot(frequency_hz, phase[:, i, j], label=label)
            ratio_units.add(_ratio_unit(output_units.get(o, ""), input_units.get(u, "")))
    ax_m.set_yscale("log")
    if log_frequency:
        ax_p.set_xscale("log")
    unit = ratio_units.pop() if len(ratio_units) == 1 else ""
    pair = f"{outputs[0]}/{inputs[0]}" if len(outputs) == len(inputs) == 1 else "H"
    ax_m.set_ylabel(f"|{pair}| [{unit}]" if unit else f"|{pair}|")
    ax_p.set_ylabel("phase [deg]")
    ax_p.set_xlabel("frequency f [Hz]")
    for ax in (ax_m, ax_p):
        ax.grid(True, which="both", alpha=0.3)
    if len(outputs) * len(inputs) > 1:
        ax_m.legend(**_LEGEND)
    return fig


def plot_frf_comparison(
    frequency_hz: np.ndarray,
    full: np.ndarray,
    reduced: np.ndarray,
    relative_error: np.ndarray,
    path: str | os.PathLike[str],
    *,
    output: str,
    input: str,
    unit: str = "",
    log_frequency: bool = False,
    dpi: int = 120,
) -> Path:
    """Magnitudes of the full FE model and of the reduced body, and their relative error, over
    frequency (log axis with ``log_frequency``); ``unit`` is the unit of ``|H|``
    (e.g. ``m/N``). Written atomically like :func:`save_figure`."""
    path = check_plot_path(path)
    fig = frf_comparison_figure(frequency_hz, full, reduced, relative_error, output=output,
                                input=input, unit=unit, log_frequency=log_frequency)
    return save_figure(fig, path, dpi)


def frf_comparison_figure(
    frequency_hz: np.ndarray,
    full: np.ndarray,
    reduced: np.ndarray,
    relative_error: np.ndarray,
    *,
    output: str,
    input: str,
    unit: str = "",
    log_frequency: bool = False,
) -> Any:
    """The figure of :func:`plot_frf_comparison` (Agg canvas, not saved)."""
    fig = new_figure(figsize=(8, 6), layout="constrained")
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    ax1.plot(frequency_hz, np.abs(full), label="full FE model")
    ax1.plot(frequency_hz, np.abs(reduced), "--", label="reduced body")
    ax1.set_yscale("log")
    ax1.set_ylabel(f"|{output}/{input}| [{unit}]" if unit else f"|{output}/{input}|")
    ax1.legend(**_LEGEND)
    ax2.plot(frequency_hz, np.maximum(np.asarray(relative_error, dtype=float).reshape(-1),
                                      1e-17))
    ax2.set_yscale("log")
    ax2.set_ylabel("relative error |H − H_r|/|H|")
    ax2.set_xlabel("frequency f [Hz]")
    for ax in (ax1, ax2):
        if log_frequency:
            ax.set_xscale("log")
        ax.grid(True, which="both", alpha=0.3)
    return fig
