"""The analysis sub-commands: files written, one-line errors with exit code 1.

References: the same numbers through the Python API (which the other tests check against closed
forms), and the file formats the issue prescribes.
"""

from __future__ import annotations

import csv

import numpy as np
import pytest
from _analysis_helpers import FIXTURES, load_fixture

from neweul_py.analysis.equilibrium import equilibrium
from neweul_py.analysis.linearize import LinearModel, linearize
from neweul_py.analysis.modes import modes
from neweul_py.cli import main


def _run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_equilibrium_command(capsys, tmp_path):
    code, out, _ = _run(capsys, "equilibrium", str(FIXTURES / "spring_pendulum.py"),
                        "-o", str(tmp_path / "eq.csv"))
    assert code == 0
    ref = equilibrium(load_fixture("spring_pendulum")).y[0]
    rows = list(csv.reader((tmp_path / "eq.csv").open()))
    assert rows[0] == ["name", "value"]
    assert float(rows[1][1]) == pytest.approx(ref, abs=1e-14)
    assert "phi" in out


def test_linearize_command_writes_npz(capsys, tmp_path):
    code, _, _ = _run(capsys, "linearize", str(FIXTURES / "cartesian_pendulum.py"),
                      "--at", "equilibrium", "-o", str(tmp_path / "lin.npz"))
    assert code == 0
    lin = LinearModel.load(tmp_path / "lin.npz")
    mod = load_fixture("cartesian_pendulum")
    ref = linearize(mod, equilibrium(mod))
    np.testing.assert_allclose(lin.Q, ref.Q, rtol=1e-12)
    assert lin.coordinates == ("x",)


def test_modes_command_csv(capsys, tmp_path):
    code, _, _ = _run(capsys, "modes", str(FIXTURES / "two_mass.py"), "--at", "initial",
                        "-o", str(tmp_path / "modes.csv"))
    assert code == 0
    rows = list(csv.reader((tmp_path / "modes.csv").open()))
    assert rows[0][:2] == ["frequency_hz", "damping_ratio"]
    ref = modes(load_fixture("two_mass"), y0=[0.0, 0.0])
    np.testing.assert_allclose([float(r[0]) for r in rows[1:]], ref.frequency_hz, rtol=1e-12)


def test_frf_command_csv_and_plot(capsys, tmp_path):
    pytest.importorskip("matplotlib")
    code, _, _ = _run(capsys, "frf", str(FIXTURES / "two_mass.py"), "--input", "F1",
                      "--output", "pos2", "--f", "10:10000:400", "--log",
                      "--plot", str(tmp_path / "bode.png"), "-o", str(tmp_path / "frf.csv"))
    assert code == 0
    rows = list(csv.reader((tmp_path / "frf.csv").open()))
    assert rows[0] == ["frequency_hz", "magnitude", "phase_deg"]
    assert len(rows) == 401
    assert (tmp_path / "bode.png").stat().st_size > 0


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["frf", "two_mass.py", "--input", "F9", "--output", "pos2", "--f", "1:2:3"],
         "unknown input 'F9'; valid inputs: F1, F2"),
        (["frf", "two_mass.py", "--input", "F1", "--output", "nope", "--f", "1:2:3"],
         "unknown output 'nope'"),
        (["frf", "two_mass.py", "--f", "1:x:3"], "expected start:stop:count"),
        (["equilibrium", "cart_pendulum.py", "-p", "c=0", "-u", "F=0"],
         "no stiffness in the motion of coordinate(s) x"),
        (["modes", "slider_crank.py"], "line search stalled"),
        (["linearize", "slider_crank.py", "--at", "initial"], "rest points"),
        (["equilibrium", "missing.py"], "missing.py"),
    ],
)
def test_errors_are_one_line_exit_1(capsys, argv, message):
    argv = [argv[0], str(FIXTURES / argv[1]), *argv[2:]]
    code, _, err = _run(capsys, *argv)
    assert code == 1
    assert err.count("\n") == 1
    assert message in err
