"""``neweul simulate -u NAME=EXPR``: inputs driven by expressions of t, against closed-form
motions of a free mass (forced: m ẍ = F(t); kinematically excited: ẍ = −s̈(t))."""

from __future__ import annotations

import numpy as np
import pytest

from neweul_py.analysis.results import load_npz
from neweul_py.cli import main

MODEL = """\
name: driven
parameters: {m: 2.0}
coordinates: {x: 0.0}
inputs: {F: 0, s: 0}
frames:
  cart: {translation: [x + s, 0, 0]}
bodies:
  b: {frame: cart, mass: m}
forces:
  push: {type: generalized, coordinate: x, value: F}
"""


@pytest.fixture
def description(tmp_path):
    path = tmp_path / "driven.yaml"
    path.write_text(MODEL)
    return path


def test_expression_inputs_drive_force_and_kinematics(description, tmp_path, monkeypatch) -> None:
    """Reference: m(ẍ + s̈) = F with x(0) = ẋ(0) = 0 and s(0) = ṡ(0) = 0, so
    x(t) = ∫∫F/m − s(t) = t³/(2m) − s(t) for F = 3t and the ramp s (a corner in s̈ at t = 1,
    whose rates d_s, dd_s come from the analytic time derivatives)."""
    monkeypatch.setenv("NEWEUL_CACHE", str(tmp_path / "cache"))
    out = tmp_path / "r.npz"
    code = main(["simulate", str(description), "--t-end", "2", "--rtol", "1e-10", "--atol",
                 "1e-12", "-u", "F=3*t", "-u", "s=piecewise(t < 1, t**2/2, t - 1/2)*m",
                 "-o", str(out)])
    assert code == 0
    res = load_npz(out)
    t = res.t
    s = np.where(t < 1, t**2 / 2, t - 0.5) * 2.0
    expected = t**3 / (2 * 2.0) - s
    assert np.allclose(res.column("x"), expected, atol=1e-7)


def test_bad_input_expressions_are_one_line_errors(description, tmp_path, monkeypatch, capsys
                                                   ) -> None:
    """An unknown name, an unknown input and a rate name are refused with one line, exit 1."""
    monkeypatch.setenv("NEWEUL_CACHE", str(tmp_path / "cache"))
    for option, message in [("F=sin(x)", "unknown name 'x'"), ("G=1", "unknown input 'G'"),
                            ("d_s=1", "unknown input 'd_s'")]:
        assert main(["simulate", str(description), "--t-end", "1", "-u", option]) == 1
        err = capsys.readouterr().err
        assert message in err and err.count("\n") == 1
