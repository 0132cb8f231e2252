"""Models whose only coordinates are elastic (a body fixed to the ground, no node frames) in
every command.

Reference: the eigenfrequencies the FE code wrote into the SID file's mode names
(``Eigen Mode 7 : 51.626 Hz`` … ``Eigen Mode 17 : 1932.967 Hz``).
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from neweul_py.cli import main

DATA = Path(__file__).resolve().parents[1] / "data"

MODEL = """
name: clamped_only
elastic_bodies:
  beam: {frame: ISYS, data: beam.SID_FEM, inertia: sid}
"""


@pytest.fixture
def model(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    shutil.copy(DATA / "beam.SID_FEM", tmp_path / "beam.SID_FEM")
    (tmp_path / "m.yaml").write_text(MODEL)
    monkeypatch.setenv("NEWEUL_CACHE", str(tmp_path / "cache"))
    monkeypatch.chdir(tmp_path)
    return tmp_path / "m.yaml"


def _file_frequencies() -> np.ndarray:
    text = (DATA / "beam.SID_FEM").read_text()
    return np.array([float(f) for f in re.findall(r"Eigen Mode\s+\d+\s*:\s*([\d.]+) Hz", text)])


def test_modes_of_a_clamped_sid_beam_without_node_frames(model: Path, capsys) -> None:
    """``neweul modes --undamped`` of the SID beam fixed to ISYS: the file's 11 frequencies."""
    assert main(["modes", str(model), "--undamped", "-o", "modes.csv"]) == 0
    rows = np.genfromtxt("modes.csv", delimiter=",", names=True)
    ref = _file_frequencies()
    assert ref.size == 11
    f = np.sort(rows["frequency_hz"])
    assert np.allclose(f, ref, rtol=2e-5)


@pytest.mark.parametrize("command", [["generate"], ["linearize"], ["equilibrium"],
                                     ["simulate", "--t-end", "0.002", "-o", "s.csv"]])
def test_every_command_runs_on_an_elastic_only_model(model: Path, command, capsys) -> None:
    """generate, linearize, equilibrium and simulate accept the model (no 'model has no
    coordinates'); the equilibrium of the unloaded clamped beam is q = 0."""
    assert main([command[0], str(model), *command[1:]]) == 0
    out = capsys.readouterr()
    assert "no coordinates" not in out.err
    if command[0] == "equilibrium":
        values = [float(line.split()[-1]) for line in out.out.splitlines()
                  if line.startswith("beam_q")]
        assert len(values) == 11 and max(map(abs, values)) == 0.0
