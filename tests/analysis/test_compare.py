"""Comparison against references (neweul_py/analysis/compare.py, compare_io.py,
compare_plot.py; ``neweul compare``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from neweul_py.analysis import (
    equilibrium,
    frequency_response,
    linearize,
    load_generated,
    modes,
    simulate,
)
from neweul_py.cli import main
from neweul_py.compare import compare, mac_matrix, read_table
from neweul_py.errors import DataError

GENERATED = Path(__file__).resolve().parents[2] / "generated"
CHAIN = GENERATED / "middle_ear_chain.py"


def _pendulum_linear(t: np.ndarray) -> dict[str, np.ndarray]:
    """Closed form of the linear pendulum phi'' = −(g/l) phi from phi0 (reference)."""
    mod = load_generated(GENERATED / "pendulum.py")
    g, l = mod.PARAMETERS["g"], mod.PARAMETERS["l"]
    w = np.sqrt(g / l)
    return {"t": t, "phi": 1e-3 * np.cos(w * t), "d_phi": -1e-3 * w * np.sin(w * t)}


def test_time_history_against_a_closed_form_on_other_times(tmp_path):
    """Reference: the closed-form small-amplitude pendulum, written by 'another tool' as a CSV
    with units in its header and coarser times; a wrong reference fails with exit code 1."""
    res = simulate(GENERATED / "pendulum.py", 3.0, x0={"phi": 1e-3}, n_out=601, rtol=1e-10,
                   atol=1e-14)
    ours = res.save(tmp_path / "ours.csv")
    ref = _pendulum_linear(np.linspace(0.0, 3.0, 151))
    path = tmp_path / "other.csv"
    np.savetxt(path, np.column_stack(list(ref.values())), delimiter=",", comments="",
               header="time [s],phi [rad],d_phi [rad/s]")
    cmp = compare(ours, path, rtol=1e-4, atol=0.0)
    assert cmp.passed and [e.name for e in cmp.errors] == ["phi", "d_phi"]
    assert cmp.x.size == 151  # onto the coarser grid
    assert cmp.errors[0].max_rel_error < 1e-5  # nonlinearity at 1e-3 rad: ~1e-7
    assert main(["compare", str(ours), str(path), "--rtol", "1e-4"]) == 0
    wrong = dict(ref, phi=ref["phi"] * 1.01)
    np.savetxt(path, np.column_stack(list(wrong.values())), delimiter=",", comments="",
               header="t,phi,d_phi")
    assert main(["compare", str(ours), str(path), "--rtol", "1e-4",
                 "--rtol", "phi=2e-2"]) == 0  # per-signal tolerance
    assert main(["compare", str(ours), str(path), "--rtol", "1e-4"]) == 3  # a failed check


def test_frequency_response_is_phase_aware():
    """Reference: our own FRF, and the same with the phase shifted by 5° (magnitude equal):
    a magnitude-only check would pass it, the complex criterion does not."""
    lin = linearize(load_generated(CHAIN))
    f = np.geomspace(100, 10000, 50)
    fr = frequency_response(lin, f, "p_ec", "stapes_velocity")
    h = fr.H[:, 0, 0]
    assert compare(fr, {"frequency_hz": f, "H": h}).passed
    shifted = compare(fr, {"frequency_hz": f, "H": h * np.exp(1j * np.radians(5))}, rtol=1e-2)
    assert not shifted.passed and "|phase| 5 deg" in shifted.errors[0].note
    assert compare(fr, {"frequency_hz": f, "H": h * 1.001}, rtol=1e-2).passed


def test_frf_csv_files_round_trip_into_complex_signals(tmp_path):
    """Reference: the complex H of the FrequencyResponse written as CSV (magnitude/phase)."""
    lin = linearize(load_generated(CHAIN))
    fr = frequency_response(lin, np.geomspace(100, 10000, 20), "p_ec")
    table = read_table(fr.save(tmp_path / "frf.csv"))
    assert table.kind == "frequency"
    np.testing.assert_allclose(table.signals["stapes_velocity__p_ec"], fr.H[:, 0, 0],
                               rtol=1e-12)
    assert compare(tmp_path / "frf.csv", fr.save(tmp_path / "frf.npz"), rtol=1e-12).passed


def test_modes_matched_by_mac_whatever_their_order(tmp_path):
    """Reference: the chain's undamped modes, listed by another tool in reverse order with
    their shapes; MAC of a mode with itself is 1 (Allemang 2003)."""
    lin = linearize(load_generated(CHAIN))
    ours = modes(lin, undamped=True)
    ref = tmp_path / "ref_modes.csv"
    rows = ["frequency_hz,damping_ratio," + ",".join(f"shape_{c}" for c in ours.coordinates)]
    for i in reversed(range(4)):
        rows.append(f"{ours.frequency_hz[i]},0," + ",".join(str(v) for v in
                                                            ours.shapes[:, i].real))
    ref.write_text("\n".join(rows) + "\n")
    cmp = compare(ours, ref, rtol=1e-9)
    assert cmp.passed, cmp.table()
    assert [e.note.split(":")[0] for e in cmp.errors] == ["ours #4", "ours #3", "ours #2",
                                                          "ours #1"]
    off = ref.read_text().replace(f"{ours.frequency_hz[2]},", f"{ours.frequency_hz[2] * 1.01},")
    ref.write_text(off)
    cmp = compare(ours, ref, rtol=1e-3)  # mode 3 of ours 1 % off: only that one fails
    assert [e.passed for e in cmp.errors] == [True, False, True, True]
    m = mac_matrix(ours.shapes, ours.shapes)
    np.testing.assert_allclose(np.diag(m), 1.0)


def test_equilibria_and_the_overlay_plot(tmp_path):
    """Reference: the equilibrium of the double pendulum (hanging: both angles 0) and itself
    from its CSV file."""
    eq = equilibrium(load_generated(GENERATED / "double_pendulum.py"))
    path = eq.save(tmp_path / "eq.csv")
    cmp = compare(eq, path)
    assert cmp.kind == "equilibrium" and cmp.passed
    assert cmp.plot(tmp_path / "eq.png").read_bytes()[:4] == b"\x89PNG"
    res = simulate(GENERATED / "pendulum.py", 1.0, n_out=21)
    assert compare(res, res).plot(tmp_path / "t.png").read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("t,phi\n0,1\n0.2,2\n0.1,3\n", r"must increase strictly: 0.1 at line 4 follows 0.2"),
        ("t,phi\n0,1\n0.1,nan\n", r"column 'phi', line 3: 'nan' is not a finite number"),
        ("t,phi\n0,1\n0.1,\n", r"column 'phi', line 3: '\(empty\)'"),
        ("t,theta\n0,1\n0.1,2\n", r"no signal in common"),
    ],
)
def test_bad_reference_files_are_one_clear_error(tmp_path, text, message):
    """Reference: the documented messages naming file, line and column."""
    res = simulate(GENERATED / "pendulum.py", 1.0, n_out=11)
    path = tmp_path / "ref.csv"
    path.write_text(text)
    with pytest.raises(DataError, match=message) as err:
        compare(res, path)
    assert "ref.csv" in str(err.value)
    with pytest.raises(DataError, match=r"no column 'psi'"):
        compare(res, res, signals=["psi"])


def test_cli_reports_a_bad_reference_in_one_line(tmp_path, capsys):
    """Reference: the CLI's one-line error format (no traceback), exit code 1."""
    ours = simulate(GENERATED / "pendulum.py", 1.0, n_out=11).save(tmp_path / "a.csv")
    (tmp_path / "bad.csv").write_text("t,phi\n0,1\n0,2\n")
    assert main(["compare", str(ours), str(tmp_path / "bad.csv")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("neweul compare: error:") and "bad.csv" in err[0]


def test_overlay_plot_has_units_and_an_error_curve(tmp_path):
    """Artist-level: the overlay's y label carries the unit (from our CSV's units sidecar, or a
    ``[unit]`` header of another tool's CSV), the error axis beside it plots |a − b| in the
    same unit with the tolerance line, frequency responses get magnitude, phase and relative
    error, and every label stays inside the figure."""
    from neweul_py.analysis.compare_plot import comparison_figure

    res = simulate(GENERATED / "pendulum.py", 3.0, x0={"phi": 1e-3}, n_out=601, rtol=1e-10,
                   atol=1e-14)
    ours = res.save(tmp_path / "ours.csv")
    ref = _pendulum_linear(np.linspace(0.0, 3.0, 151))
    path = tmp_path / "other.csv"
    np.savetxt(path, np.column_stack(list(ref.values())), delimiter=",", comments="",
               header="time [s],phi [rad],d_phi [rad/s]")
    cmp = compare(ours, path, rtol=1e-4, atol=0.0)
    assert cmp.units["phi"] == "rad" and cmp.units["d_phi"] == "rad/s"
    fig = comparison_figure(cmp)
    fig.canvas.draw()
    labels = [[ax.get_ylabel() for ax in row] for row in np.reshape(fig.axes, (-1, 2))]
    assert sorted(labels) == [["d_phi [rad/s]", "|Δd_phi| [rad/s]"], ["phi [rad]", "|Δphi| [rad]"]]
    error_axis = next(ax for ax in fig.axes if ax.get_ylabel() == "|Δphi| [rad]")
    curve, tolerance = error_axis.get_lines()
    a, b = cmp.values["phi"]
    np.testing.assert_allclose(curve.get_ydata(), np.maximum(np.abs(a.real - b.real),
                                                            curve.get_ydata().min()))
    assert tolerance.get_ydata()[0] == pytest.approx(1e-4 * np.abs(b).max())
    renderer = fig.canvas.get_renderer()
    for ax in fig.axes:
        box = ax.yaxis.label.get_window_extent(renderer)
        assert box.x0 >= 0 and box.x1 <= fig.bbox.width
    mod = load_generated(CHAIN)
    fr = frequency_response(linearize(mod), np.geomspace(100, 5000, 40))
    freq = comparison_figure(compare(fr, fr))
    name = "stapes_velocity__p_ec"
    assert [ax.get_ylabel() for ax in freq.axes[:3]] == [
        f"|{name}|", "phase [deg]", f"|Δ{name}| / |{name}_ref|"]


def test_a_reference_that_is_not_utf8_is_one_clear_error(tmp_path, capsys):
    """A CSV saved as Latin-1 (``t [°C]`` in its header) raised UnicodeDecodeError; it is one
    DataError naming the file, the byte, its offset and line. Reference: the bytes written."""
    ours = simulate(GENERATED / "pendulum.py", 1.0, n_out=11).save(tmp_path / "a.csv")
    bad = tmp_path / "latin1.csv"
    bad.write_bytes("t,phi [\u00b0]\n0,1\n0.1,2\n".encode("latin-1"))
    with pytest.raises(DataError, match=r"not UTF-8 text \(byte 0xb0 at offset 7, line 1\)"):
        compare(ours, bad)
    assert main(["compare", str(ours), str(bad)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "latin1.csv" in err[0] and "not UTF-8" in err[0]
