"""``neweul identify`` (commands/identify.py, docs/cli.md, docs/howto/identify.md).

References: the data are the model's own frequency response (``neweul frf -o``) and
simulation (``neweul simulate -o``) at known parameters, which the fit must give back; a
stiffness written as the product ``k1*k2`` must leave both factors undetermined (``null``).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from neweul_py.cli import main

OSCILLATOR = """\
name: oscillator
parameters: {m: 2.0, k1: 20.0, k2: 40.0, c: 4.0}
coordinates: {x: 0.0}
inputs: {F: 0}
frames:
  cart: {translation: [x, 0, 0]}
bodies:
  mass: {frame: cart, mass: m}
forces:
  spring: {type: generalized, coordinate: x, value: -k1*k2*x - c*d_x + F}
"""


@pytest.fixture
def measured(tmp_path: Path, monkeypatch) -> Path:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "osc.yaml").write_text(OSCILLATOR)
    assert main(["frf", "osc.yaml", "--input", "F", "--response", "x", "--f", "0.5:30:60",
                 "-o", "data.csv"]) == 0
    return tmp_path


def test_frf_fit_writes_the_report_and_the_plot(measured, capsys) -> None:
    """m, k1 and c (k2 held at its value) come back from the model's own FRF."""
    assert main(["identify", "osc.yaml", "--data", "data.csv", "--task", "frf", "--input",
                 "F", "--response", "x", "--param", "m=0.1:20:0.5", "--param", "k1=1:1000:5",
                 "--param", "c=0.01:100:1", "-o", "fit.json", "--plot", "fit.png"]) == 0
    report = json.loads((measured / "fit.json").read_text())
    for key in ("parameters", "standard_errors", "correlation", "cost", "iterations"):
        assert key in report
    assert report["converged"] is True
    assert report["parameters"]["k1"] == pytest.approx(20.0, rel=1e-8)
    assert report["parameters"]["m"] == pytest.approx(2.0, rel=1e-8)
    assert (measured / "fit.png").stat().st_size > 0


def test_a_product_pair_is_null_with_a_reason(measured) -> None:
    assert main(["identify", "osc.yaml", "--data", "data.csv", "--task", "frf", "--input",
                 "F", "--response", "x", "--param", "k1=1:1000:5", "--param", "k2=1:1000:5",
                 "-o", "fit.json"]) == 0
    report = json.loads((measured / "fit.json").read_text())
    assert report["parameters"] == {"k1": None, "k2": None}
    assert report["standard_errors"] == {"k1": None, "k2": None}
    assert "combination" in report["undetermined"]["k1"]


def test_simulation_fit_from_simulate_output(measured) -> None:
    assert main(["simulate", "osc.yaml", "--t-end", "2", "-u", "F=1", "--n-out", "81", "-o",
                 "sim.csv"]) == 0
    assert main(["identify", "osc.yaml", "--data", "sim.csv", "--task", "simulate",
                 "--t-end", "2", "-u", "F=1", "--response", "x", "--param", "k1=1:1000:10",
                 "-o", "fit.json"]) == 0
    report = json.loads((measured / "fit.json").read_text())
    assert report["parameters"]["k1"] == pytest.approx(20.0, rel=1e-6)


@pytest.mark.parametrize(("words", "message"), [
    (["--task", "simulate", "--t-end", "1", "--param", "k1=1:100"],
     "it looks like a frequency response: use --task frf"),
    (["--task", "frf", "--param", "k1=1:100"], "--task frf needs --input U"),
    (["--task", "frf", "--input", "F", "--response", "x", "--param", "k1=100:1"],
     "LO (100) must be below HI (1)"),
    (["--task", "frf", "--input", "F", "--response", "x", "--param", "k1=1:100:500"],
     "START 500 is outside"),
    (["--task", "frf", "--input", "F", "--response", "x", "--param", "kk=1:100"],
     "unknown parameter 'kk'"),
    (["--task", "frf", "--input", "F", "--response", "x", "--param", "k1=1:100", "-o",
      "fit.txt"], "written as .json"),
    (["--task", "frf", "--input", "F", "--response", "x", "--param", "k1=1:100", "--set",
      "k1=3"], "k1: fitted (--param) and held (--set) at once"),
    (["--task", "frf", "--input", "F", "--response", "x", "--param", "k1=1:100", "--plot",
      "data.csv/fit.png"], "data.csv is a file, not a directory"),
])
def test_bad_input_is_one_error_and_writes_nothing(measured, capsys, words, message) -> None:
    assert main(["identify", "osc.yaml", "--data", "data.csv", *words]) == 1
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert sorted(p.name for p in measured.iterdir()) == ["data.csv", "osc.yaml"]


def test_a_failed_run_keeps_the_previous_report(measured, capsys) -> None:
    """A plot path below a file fails before the fit: the report of an earlier run stays
    byte for byte."""
    (measured / "fit.json").write_text("earlier")
    assert main(["identify", "osc.yaml", "--data", "data.csv", "--task", "frf", "--input", "F",
                 "--response", "x", "--param", "k1=1:100", "-o", "fit.json", "--plot",
                 "osc.yaml/fit.png"]) == 1
    assert (measured / "fit.json").read_text() == "earlier"


def test_a_fit_that_does_not_converge_is_reported(measured, capsys) -> None:
    """Two evaluations: exit 1, one error line, and a report that says converged: false."""
    assert main(["identify", "osc.yaml", "--data", "data.csv", "--task", "frf", "--input",
                 "F", "--response", "x", "--param", "k1=1:1000:2", "--max-nfev", "2", "-o",
                 "fit.json"]) == 1
    assert "did not converge" in capsys.readouterr().err
    assert json.loads((measured / "fit.json").read_text())["converged"] is False


def test_the_howto_runs_and_prints_what_it_shows(tmp_path) -> None:
    """docs/howto/identify.md: every ``bash`` and ``python`` block runs as shown (in a copy of
    the examples), and the estimates it quotes are the ones printed."""
    import os
    import re
    import shutil
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[2]
    text = (root / "docs" / "howto" / "identify.md").read_text()
    shutil.copytree(root / "examples", tmp_path / "examples",
                    ignore=shutil.ignore_patterns("middle_ear", "elastic_up_body"))
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
           "NEWEUL_CACHE": str(tmp_path / "cache")}
    printed = ""
    for lang, block in re.findall(r"```(bash|python)\n(.*?)```", text, re.DOTALL):
        cmd = ["bash", "-e", "-c", block] if lang == "bash" else [sys.executable, "-c", block]
        out = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True,
                             check=True)
        printed += out.stdout
    for line in ("mb  279.79413 ± 1.13", "ks  18940.224 ± 91.1", "cs  1292.1894 ± 6.87",
                 "ls  undetermined: the data do not determine it"):
        assert line in text and line in printed, line
    assert (tmp_path / "fit.png").stat().st_size > 0
