"""Tabulated input signals from CSV: the generated module's u(t), u'(t), u''(t) against NumPy's
``interp`` and SciPy's natural ``CubicSpline`` (independent implementations), every bad file one
DescriptionError naming the description, the CSV file, its line and the column, and the cache
key following the CSV's content."""

from __future__ import annotations

import os
import pathlib

import numpy as np
import pytest
import sympy as sp
from scipy.interpolate import CubicSpline

from neweul_py.analysis.module import load_generated
from neweul_py.api import _data_fingerprints, generate
from neweul_py.description import load_description, parse_expression
from neweul_py.description.signals import signal_function
from neweul_py.errors import DescriptionError
from neweul_py.model import symbol, time
from neweul_py.yaml_tree import read_description

T = np.linspace(0.0, 2.0, 41)
U = np.sin(3 * T) + 0.2 * T

DESCRIPTION = """\
name: tabled
parameters: {{m: 1.0, k: 4.0}}
coordinates: {{x: 0.0}}
inputs:
  F: {{table: signal.csv, interpolation: {interp}}}
  s: {{table: signal.csv, column: F, interpolation: {interp}}}
frames:
  cart: {{translation: [x + 0.1*s, 0, 0]}}
bodies:
  b: {{frame: cart, mass: m}}
forces:
  f: {{type: generalized, coordinate: x, value: F - k*x}}
"""


def _write_csv(path: pathlib.Path, rows: list[str] | None = None) -> None:
    lines = ["# measured force", "t [s],F [N],other"]
    lines += rows if rows is not None else [f"{t!r},{u!r},0" for t, u in zip(T.tolist(),
                                                                          U.tolist(), strict=True)]
    path.write_text("\n".join(lines) + "\n")


def _model(tmp_path: pathlib.Path, interp: str):
    _write_csv(tmp_path / "signal.csv")
    desc = tmp_path / "tabled.yaml"
    desc.write_text(DESCRIPTION.format(interp=interp))
    return load_generated(generate(desc, tmp_path))


@pytest.mark.parametrize("interp", ["linear", "cubic"])
def test_tabulated_signal_and_its_rates(tmp_path, interp) -> None:
    """Reference: ``numpy.interp`` (linear; slopes of the segments) and
    ``scipy.interpolate.CubicSpline(bc_type='natural')`` with its derivatives (cubic); the
    signal holds its end values outside the table."""
    module = _model(tmp_path, interp)
    assert module.INPUTS == ["F", "s", "d_s", "dd_s"]
    p = module.default_parameters()
    ts = np.concatenate([np.linspace(-0.5, 2.5, 97), T])
    got = np.array([module.default_inputs(t, p) for t in ts])
    inside = (ts >= T[0]) & (ts <= T[-1])
    rates = (ts >= T[0]) & (ts < T[-1])  # right-continuous: the last sample starts the hold
    if interp == "linear":
        ref = np.interp(ts, T, U)
        k = np.searchsorted(T, ts[rates], side="right") - 1
        assert np.allclose(got[rates, 2], (np.diff(U) / np.diff(T))[k])
    else:
        spline = CubicSpline(T, U, bc_type="natural")
        ref = np.where(inside, spline(np.clip(ts, T[0], T[-1])), np.interp(ts, T, U))
        assert np.allclose(got[rates, 2], spline(ts[rates], 1), atol=1e-9)
        assert np.allclose(got[rates, 3], spline(ts[rates], 2), atol=1e-7)
    assert np.allclose(got[:, 0], ref, atol=1e-12)
    assert np.allclose(got[:, 1], ref, atol=1e-12)
    assert np.all(got[~rates, 2:] == 0)


BAD = [
    (["0,1,0", "0.1,nan,0"], ":4: column 'F'", "not a finite number"),
    (["0,1,0", "0.2,1,0", "0.1,2,0"], ":5: column 't'", "increase strictly"),
    (["0,1,0", "0.1,x,0"], ":4: column 'F'", "is not a number"),
    (["0,1", "0.1,2,0"], ":3:", "2 values, the header names 3"),
    (["0,1,0"], "signal.csv", "at least 2 samples"),
]


@pytest.mark.parametrize(("rows", "where", "message"), BAD)
def test_bad_signal_files_name_file_line_and_column(tmp_path, rows, where, message) -> None:
    """Bad signal files: non-monotonic time, NaN, a missing column — one line each."""
    _write_csv(tmp_path / "signal.csv", rows)
    desc = tmp_path / "tabled.yaml"
    desc.write_text(DESCRIPTION.format(interp="linear"))
    with pytest.raises(DescriptionError) as info:
        load_description(desc)
    text = str(info.value)
    assert text.startswith(f"{desc}:5: inputs.F.table: ")
    assert where in text and message in text and "\n" not in text


def test_missing_column_directory_and_fifo(tmp_path) -> None:
    """A missing column lists the columns; a directory or a FIFO is refused before reading."""
    _write_csv(tmp_path / "signal.csv")
    desc = tmp_path / "tabled.yaml"
    desc.write_text(DESCRIPTION.format(interp="linear").replace("column: F", "column: G"))
    with pytest.raises(DescriptionError, match="no column 'G'; columns are: t, F, other"):
        load_description(desc)
    (tmp_path / "signal.csv").unlink()
    os.mkfifo(tmp_path / "signal.csv")
    desc.write_text(DESCRIPTION.format(interp="linear"))
    with pytest.raises(DescriptionError, match="not a regular file"):
        load_description(desc)


def test_cache_key_follows_the_signal_file(tmp_path) -> None:
    """The data fingerprint of the description changes with the CSV's bytes."""
    _write_csv(tmp_path / "signal.csv")
    desc = tmp_path / "tabled.yaml"
    desc.write_text(DESCRIPTION.format(interp="linear"))
    before = _data_fingerprints(read_description(desc.read_bytes()).data, desc)
    _write_csv(tmp_path / "signal.csv", ["0,1,0", "1,2,0"])
    assert _data_fingerprints(read_description(desc.read_bytes()).data, desc) != before


def test_signal_function_evaluates_the_language() -> None:
    """Reference: Python's math on the same formula (piecewise, min, abs, powers)."""
    k = symbol("k")
    expr = parse_expression("piecewise(t < 1 and k > 0, k*t**2, max(abs(sin(t)), 0.5)) + "
                            "step(t - 2)*exp(-t)", {"t": time, "k": k})
    f = signal_function(expr, {k: 3.0})
    for t in (0.5, 1.5, 2.5):
        ref = (3 * t**2 if t < 1 else max(abs(np.sin(t)), 0.5)) + (t >= 2) * np.exp(-t)
        assert f(t) == pytest.approx(ref)
    assert signal_function(sp.Integer(2), {})(0.0) == 2.0
