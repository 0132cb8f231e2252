"""Plots a researcher would publish: rendered with matplotlib's Agg canvas
into PNG files, then checked programmatically — every axis labelled with its unit, log axes
where asked, one axis per unit group (a 300 rad spin does not share an axis with a 0.1 rad
oscillation), legends outside the data area and y labels inside the figure."""

from __future__ import annotations

import numpy as np
import pytest

from neweul_py.analysis.frf import FrequencyResponse
from neweul_py.analysis.plot import (
    frf_comparison_figure,
    group_signals,
    plot_frf_comparison,
    plot_result,
    result_figure,
    save_figure,
)
from neweul_py.analysis.results import SimulationResult

T = np.linspace(0.0, 10.0, 201)


def _result() -> SimulationResult:
    spin = 30.0 * T  # 300 rad at the end
    wobble = 0.1 * np.sin(5 * T)
    x = 0.02 * np.cos(3 * T)
    y = np.column_stack([spin, wobble, x])
    outputs = np.column_stack([5 * np.sin(T), 0.01 * np.sin(T)])
    return SimulationResult(
        t=T, y=y, yd=np.gradient(y, T, axis=0), outputs=outputs,
        coordinates=("hub", "wobble", "x"), output_names=("force", "tip"),
        coordinate_units=("rad", "rad", "m"), output_units=("N", "m"), model_name="demo",
        method="RK45",
    )


def _inside_figure(fig, ax) -> bool:
    renderer = fig.canvas.get_renderer()
    box = ax.yaxis.label.get_window_extent(renderer)
    return box.x0 >= 0 and box.x1 <= fig.bbox.width


def _legends_outside(fig, ax) -> bool:
    legend = ax.get_legend()
    if legend is None:
        return True
    renderer = fig.canvas.get_renderer()
    return legend.get_window_extent(renderer).x0 >= ax.get_window_extent(renderer).x1


def test_unit_groups_split_by_scale() -> None:
    """Reference: by hand — rad signals of 300 and 0.1 go apart, m stays alone."""
    r = _result()
    assert group_signals(["rad", "rad", "m"], r.y) == [[0], [1], [2]]
    assert group_signals(["rad", "rad"], np.column_stack([np.sin(T), 0.5 * np.cos(T)])) == [[0, 1]]


def test_simulation_plot_one_axis_per_unit_group(tmp_path) -> None:
    """Each axis: one unit, labelled ``name [unit]``; x label with unit; PNG written."""
    r = _result()
    fig = result_figure(r)
    fig.canvas.draw()
    axes = fig.axes
    labels = [ax.get_ylabel() for ax in axes]
    assert labels == ["hub [rad]", "wobble [rad]", "x [m]", "force [N]", "tip [m]"]
    assert axes[-1].get_xlabel() == "time t [s]"
    for ax in axes:
        assert _inside_figure(fig, ax) and _legends_outside(fig, ax)
    spin_axis = axes[1]
    low, high = spin_axis.get_ylim()
    assert high - low < 1.0  # the wobble is not flattened by the spin
    path = plot_result(r, tmp_path / "sim.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_bode_magnitude_has_its_unit_and_log_axes(tmp_path) -> None:
    """|H| labelled ``[m/N]`` from the output/input units, log magnitude and frequency."""
    f = np.geomspace(1, 1000, 50)
    H = (1 / (1 - (f / 100) ** 2 + 0.02j * f / 100)).reshape(-1, 1, 1)
    fr = FrequencyResponse(f, H, ("x",), ("F",))
    path = tmp_path / "bode.png"
    fig = fr.plot(path, output_units={"x": "m"}, input_units={"F": "N"})
    ax_m, ax_p = fig.axes
    assert ax_m.get_ylabel() == "|x/F| [m/N]" and ax_m.get_yscale() == "log"
    assert ax_p.get_xscale() == "log" and ax_p.get_xlabel() == "frequency f [Hz]"
    assert ax_p.get_ylabel() == "phase [deg]"
    fig.canvas.draw()
    assert all(_inside_figure(fig, ax) for ax in fig.axes)
    assert path.read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize("log", [True, False])
def test_compare_frf_plot_honours_log_and_units(tmp_path, log) -> None:
    """compare-frf: --log gives a log frequency axis, |H| carries its unit, labels fit."""
    f = np.geomspace(10, 20000, 60)
    full = 1e-6 / (1 - (f / 1000) ** 2 + 0.05j)
    reduced = full * (1 + 1e-4 * f / 1000)
    err = np.abs(full - reduced) / np.abs(full)
    fig = frf_comparison_figure(f, full, reduced, err, output="umbo", input="p_ec", unit="m/Pa",
                                log_frequency=log)
    fig.canvas.draw()
    top, bottom = fig.axes
    assert top.get_ylabel() == "|umbo/p_ec| [m/Pa]"
    assert bottom.get_xscale() == ("log" if log else "linear")
    assert all(_inside_figure(fig, ax) and _legends_outside(fig, ax) for ax in fig.axes)
    path = plot_frf_comparison(f, full, reduced, err, tmp_path / "cmp.png", output="umbo",
                               input="p_ec", unit="m/Pa", log_frequency=log)
    assert path.stat().st_size > 1000
    save_figure(fig, tmp_path / "again.png")


@pytest.mark.parametrize(("model", "words", "label"), [
    ("quarter_car", ["--input", "zr", "--response", "tire_force"], "|tire_force/zr| [N/m]"),
    ("quarter_car", ["--input", "zr", "--response", "body_height"], "|body_height/zr| [1]"),
    ("four_bar", ["--input", "Md", "--response", "coupler_tip_z"], "|coupler_tip_z/Md| [m/(N m)]"),
])
def test_cli_bode_magnitude_carries_output_per_input_units(tmp_path, monkeypatch, model, words,
                                                          label) -> None:
    """``neweul frf --plot``: the magnitude's unit is the output's per the input's, from the
    module's ``OUTPUT_UNITS`` (a spring's reported force: N) and ``INPUT_UNITS`` (a road
    height moving a frame: m; a generalized torque on an angle: N m); equal units cancel."""
    import importlib
    from pathlib import Path

    from neweul_py.cli import main

    frf_module = importlib.import_module("neweul_py.analysis.frf")

    monkeypatch.setenv("NEWEUL_CACHE", str(tmp_path / "cache"))
    shown = []
    monkeypatch.setattr(frf_module, "save_figure",
                        lambda fig, path, dpi=120: shown.append(fig) or Path(path))
    examples = Path(__file__).resolve().parents[2] / "examples"
    assert main(["frf", str(examples / f"{model}.yaml"), *words, "--f", "1:30:5", "--plot",
                 str(tmp_path / "bode.png")]) == 0
    [fig] = shown
    assert fig.axes[0].get_ylabel() == label
