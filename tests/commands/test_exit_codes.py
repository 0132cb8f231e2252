"""The exit-code contract of every ``neweul`` command (neweul_py/cli.py, docs/cli.md): 0
success; 1 an error of the input or the model; 2 a malformed command line (argparse); 3 a
check that ran and failed (``compare`` beyond its tolerances, ``sweep`` with failed cases
unless ``--allow-failures``) — so that a CI job can tell "the model changed" from "the
command was wrong".

Reference: the contract as docs/cli.md states it, for each sub-command the parser registers.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from neweul_py.cli import COMMAND_MODULES, main

ROOT = Path(__file__).resolve().parents[2]
PENDULUM = str(ROOT / "examples" / "pendulum.yaml")
GENERATED = ROOT / "generated"
COMMANDS = [m.replace("_", "-") for m in COMMAND_MODULES]


@pytest.fixture(autouse=True)
def _isolated(tmp_path, monkeypatch):
    monkeypatch.setenv("NEWEUL_CACHE", str(tmp_path / "cache"))
    monkeypatch.chdir(tmp_path)


def _run(capsys, *argv: str) -> tuple[int, str, str]:
    try:
        code = main(list(argv))
    except SystemExit as exc:
        code = int(exc.code or 0)
    out, err = capsys.readouterr()
    return code, out, err


def test_every_command_is_covered():
    """The lists below name every sub-command (a new command needs its cases here)."""
    assert sorted(BAD_INPUT) == sorted(COMMANDS)
    assert sorted([*SUCCESS, *SUCCESS_ELSEWHERE]) == sorted(COMMANDS)


@pytest.mark.parametrize("command", COMMANDS)
def test_a_malformed_command_line_exits_2(capsys, command):
    code, _, err = _run(capsys, command, "--no-such-option")
    assert code == 2 and "usage:" in err


BAD_INPUT = {
    "generate": ["generate", "missing.yaml"],
    "simulate": ["simulate", "missing.yaml", "--t-end", "1"],
    "equilibrium": ["equilibrium", "missing.yaml"],
    "linearize": ["linearize", "missing.yaml"],
    "modes": ["modes", "missing.yaml"],
    "frf": ["frf", "missing.yaml", "--input", "u", "--f", "1:2:2"],
    "reduce": ["reduce", "missing.npz", "--modes", "2", "-o", "body.npz"],
    "compare-frf": ["compare-frf", "missing.json", "missing.npz", "--input", "a",
                    "--response", "b"],
    "frf-body": ["frf-body", "missing.npz", "--input", "a", "--response", "b"],
    "body-info": ["body-info", "missing.npz"],
    "interpolate": ["interpolate", "a.npz", "b.npz", "--parameter", "p", "-o", "p.npz"],
    "fem": ["fem", "beam", "--stiffening", "-o", "beam.json"],
    "sweep": ["sweep", "missing.yaml", "--param", "m=1,2", "--task", "equilibrium"],
    "compare": ["compare", "missing.csv", "other.csv"],
    "middle-ear": ["middle-ear", "build", "--dir", "x", "-q", "--pressures=1000,0"],
    "export": ["export", "missing.yaml", "--fmu", "model.fmu"],
    "sensitivity": ["sensitivity", "missing.yaml", "--task", "modes"],
    "identify": ["identify", "missing.yaml", "--data", "missing.csv", "--task", "frf",
                 "--param", "m"],
}


@pytest.mark.parametrize("command", sorted(BAD_INPUT))
def test_an_input_or_model_error_exits_1(capsys, command):
    """One error line (after any progress lines) naming the command, no traceback."""
    code, _, err = _run(capsys, *BAD_INPUT[command])
    assert code == 1 and err.count("error:") == 1 and "Traceback" not in err
    assert err.strip().splitlines()[-1].startswith(f"neweul {command}: error:")


SUCCESS = {
    "generate": ["generate", PENDULUM, "-o", "gen"],
    "simulate": ["simulate", PENDULUM, "--t-end", "0.1"],
    "equilibrium": ["equilibrium", PENDULUM],
    "linearize": ["linearize", PENDULUM],
    "modes": ["modes", PENDULUM],
    "frf": ["frf", str(GENERATED / "quarter_car.py"), "--input", "zr", "--f", "1:10:3"],
    "fem": ["fem", "beam", "--elements", "4", "-o", "beam.npz"],
    "reduce": ["reduce", "beam.npz", "--modes", "3", "--one-sided", "-o", "body.npz"],
    "body-info": ["body-info", "body.npz"],
    "sweep": ["sweep", PENDULUM, "--param", "l=0.5,1", "--task", "modes", "--workers", "1"],
}
#: Their success (exit 0) is tested with the FE models and tools they need: compare-frf,
#: frf-body and interpolate in tests/elastic, middle-ear in tests/middle_ear, export in
#: tests/commands/test_export.py, sensitivity and identify in tests/commands/test_cli_*.py,
#: compare below.
SUCCESS_ELSEWHERE = ("compare-frf", "frf-body", "interpolate", "middle-ear", "export",
                     "sensitivity", "identify", "compare")


def test_success_exits_0(capsys):
    """In this order: the FE model of fem beam is what reduce reads, and its body what
    body-info reads."""
    for command, argv in SUCCESS.items():
        code, _, err = _run(capsys, *argv)
        assert code == 0, f"{command}: {err}"


def test_compare_beyond_its_tolerances_exits_3(capsys, tmp_path):
    """The same run compared with itself passes (0); with the time axis shifted the check
    runs and fails (3); a reference without a common signal is an input error (1)."""
    assert _run(capsys, "simulate", PENDULUM, "--t-end", "1", "-o", "a.csv")[0] == 0
    text = (tmp_path / "a.csv").read_text().splitlines()
    shifted = [text[0]] + [",".join([str(float(r.split(",")[0]) + 0.05), *r.split(",")[1:]])
                           for r in text[1:]]
    (tmp_path / "b.csv").write_text("\n".join(shifted) + "\n")
    (tmp_path / "c.csv").write_text("t,theta\n0,1\n1,2\n")
    assert _run(capsys, "compare", "a.csv", "a.csv")[0] == 0
    code, out, _ = _run(capsys, "compare", "a.csv", "b.csv")
    assert code == 3 and "FAILED" in out
    assert _run(capsys, "compare", "a.csv", "c.csv")[0] == 1


def test_sweep_with_failed_cases_exits_3_unless_allowed(capsys):
    """m = 0 makes the pendulum's mass matrix singular: that case fails in the worker (the
    parameter check admits m = 0, a massless bob is not negative), the others run."""
    argv = ["sweep", PENDULUM, "--param", "m=0,1", "--task", "modes", "--workers", "1"]
    code, out, err = _run(capsys, *argv)
    assert code == 3 and "1 ok, 1 failed" in out and "case 0 failed" in err
    code, out, _ = _run(capsys, *argv, "--allow-failures")
    assert code == 0 and "1 ok, 1 failed" in out


def test_a_reader_that_leaves_early_ends_the_command_silently_with_141(tmp_path):
    """``neweul frf … | head -1``: the closed pipe ends the command with 128 + SIGPIPE and no
    "Broken pipe" message (reference: the shell's status of a process ended by SIGPIPE)."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "NEWEUL_CACHE": str(tmp_path / "cache")}
    proc = subprocess.Popen([sys.executable, "-m", "neweul_py.cli", "frf",
                             str(ROOT / "examples" / "quarter_car.yaml"), "--f",
                             "0.1:10:200000"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            cwd=tmp_path, env=env)
    assert proc.stdout.readline().split()[0] == b"frequency_hz"
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait() == 141 and "Broken pipe" not in err and "Traceback" not in err, err
