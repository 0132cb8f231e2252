"""``neweul sensitivity`` (commands/sensitivity.py, docs/cli.md).

References: the Python API on the same module (analysis/sensitivity.py, checked against closed
forms and central differences in tests/analysis/test_sensitivity.py) and the pendulum's closed
form ∂ln f/∂ln l = −½.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from neweul_py.analysis import sensitivity as sens
from neweul_py.analysis.equilibrium import equilibrium
from neweul_py.analysis.linearize import linearize
from neweul_py.analysis.sensitivity_response import (
    frequency_response_sensitivity,
)
from neweul_py.api import load_description_module
from neweul_py.cli import main

ROOT = Path(__file__).resolve().parents[2]
QUARTER_CAR = str(ROOT / "examples" / "quarter_car.yaml")
PENDULUM = str(ROOT / "examples" / "pendulum.yaml")


def _read(path: Path) -> dict[str, np.ndarray]:
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    return {name: np.array([float(r[i]) for r in rows[1:]]) for i, name in enumerate(rows[0])}


def test_frf_task_writes_log_sensitivities(tmp_path, capsys) -> None:
    """The columns frequency_hz, dlogmag_dlog_NAME, dphase_deg_dlog_NAME equal the API's on
    the module generated with sensitivities (the analytic path: no note on stderr)."""
    out = tmp_path / "s.csv"
    assert main(["sensitivity", QUARTER_CAR, "--task", "frf", "--input", "zr", "--response",
                 "body_height", "--f", "1:20:5", "--wrt", "ks", "--wrt", "mb", "-o",
                 str(out)]) == 0
    assert "note" not in capsys.readouterr().err
    cols = _read(out)
    assert list(cols) == ["frequency_hz", "dlogmag_dlog_ks", "dphase_deg_dlog_ks",
                          "dlogmag_dlog_mb", "dphase_deg_dlog_mb"]
    mod = load_description_module(QUARTER_CAR, sensitivities=True)
    lin = linearize(mod, equilibrium(mod))
    ders, method = sens.linear_model_derivatives(mod, lin, ["ks", "mb"])
    assert method == sens.ANALYTIC
    ref = frequency_response_sensitivity(lin, ders, np.linspace(1, 20, 5), "zr",
                                              "body_height").columns()
    for name, values in cols.items():
        np.testing.assert_allclose(values, ref[name], rtol=1e-14, atol=1e-300)


def test_a_module_without_second_derivatives_gets_differences_and_a_note(capsys) -> None:
    """A generated module of the default kind (no directional functions): the linear
    model's derivatives are central differences, said on stderr; the pendulum's closed form
    still holds to 1e-6."""
    assert main(["sensitivity", str(ROOT / "generated" / "pendulum.py"), "--task", "modes",
                 "--wrt", "l"]) == 0
    captured = capsys.readouterr()
    assert "central differences" in captured.err
    value = float(captured.out.splitlines()[2].split()[-2])
    assert value == pytest.approx(-0.5, abs=1e-6)


def test_modes_task_prints_the_pendulum_closed_form(capsys) -> None:
    assert main(["sensitivity", PENDULUM, "--task", "modes", "--wrt", "l"]) == 0
    out = capsys.readouterr().out
    assert "dlogf_dlog_l" in out and "-0.5" in out


def test_simulate_task_writes_columns_per_state_output_and_parameter(tmp_path) -> None:
    out = tmp_path / "sim.csv"
    assert main(["sensitivity", PENDULUM, "--task", "simulate", "--t-end", "0.5", "--n-out",
                 "6", "--wrt", "l", "-o", str(out)]) == 0
    cols = _read(out)
    assert cols["t"].size == 6
    for c in ("phi", "d_phi", "x_bob", "z_bob"):
        assert f"{c}__dlog_l" in cols
    assert cols["phi__dlog_l"][0] == 0.0


@pytest.mark.parametrize(("words", "message"), [
    (["--task", "frf"], "--task frf needs --f"),
    (["--task", "simulate"], "--task simulate needs --t-end"),
    (["--task", "modes", "--f", "1:2:3"], "--f do(es) not apply to --task modes"),
    (["--task", "modes", "--wrt", "nope"], "unknown parameter 'nope'"),
    (["--task", "modes", "-o", "s.txt"], "written as .csv"),
])
def test_bad_input_is_one_error_and_writes_nothing(tmp_path, capsys, monkeypatch, words,
                                                   message) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["sensitivity", PENDULUM, *words]) == 1
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert not list(tmp_path.iterdir())
