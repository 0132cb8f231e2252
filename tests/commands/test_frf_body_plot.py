"""The Bode plot of ``neweul frf-body`` (commands/frf_body.py): one magnitude axis per
response, so a displacement and a pressure never share one, and no label cut.

Reference: the responses themselves (each axis plots one ``|H|``), and the figure's bounding
box for every label."""

from __future__ import annotations

import numpy as np
import pytest

from neweul_py.commands.frf_body import body_frf_figure


@pytest.mark.parametrize("log", [True, False])
def test_one_magnitude_axis_per_response(log):
    f = np.geomspace(100.0, 8000.0, 60)
    umbo = 1e-8 / (1 - (f / 1000) ** 2 + 0.1j * f / 1000)      # m per Pa
    probe = 0.3 / (1 - (f / 3000) ** 2 + 0.2j * f / 3000)      # Pa per Pa
    H = np.column_stack([umbo, probe])
    fig = body_frf_figure(f, H, ["umbo_ux", "probe_pressure"], "p_ec", log)
    fig.canvas.draw()
    mag_umbo, mag_probe, phase = fig.axes
    assert mag_umbo.get_ylabel().startswith("|umbo_ux/p_ec|")
    assert mag_probe.get_ylabel().startswith("|probe_pressure/p_ec|")
    assert phase.get_ylabel() == "phase [deg]" and phase.get_xlabel() == "frequency f [Hz]"
    np.testing.assert_allclose(mag_umbo.get_lines()[0].get_ydata(), np.abs(umbo))
    np.testing.assert_allclose(mag_probe.get_lines()[0].get_ydata(), np.abs(probe))
    assert len(phase.get_lines()) == 2
    assert phase.get_xscale() == ("log" if log else "linear")
    renderer = fig.canvas.get_renderer()
    for ax in fig.axes:
        for text in (ax.yaxis.label, ax.xaxis.label):
            box = text.get_window_extent(renderer)
            assert box.x0 >= 0 and box.x1 <= fig.bbox.width and box.y0 >= 0
    legend = phase.get_legend().get_window_extent(renderer)
    assert legend.x1 <= fig.bbox.width
