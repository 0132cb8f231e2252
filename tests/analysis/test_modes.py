"""Undamped modes and the note for all-overdamped models (neweul_py/analysis/modes.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from neweul_py.analysis import linearize, load_generated, modes
from neweul_py.analysis.linearize import LinearModel
from neweul_py.cli import main

GENERATED = Path(__file__).resolve().parents[2] / "generated"


def _linear(m: np.ndarray, p: np.ndarray, q: np.ndarray) -> LinearModel:
    n = m.shape[0]
    return LinearModel(
        M0=m, P=p, Q=q, B=np.zeros((n, 0)), C=np.zeros((0, 2 * n)), D=np.zeros((0, 0)),
        coordinates=tuple(f"y{i}" for i in range(n)), inputs=(), outputs=(), basis=np.eye(n),
        all_coordinates=tuple(f"y{i}" for i in range(n)), y0=np.zeros(n), yd0=np.zeros(n),
        u0=np.zeros(0), p=np.zeros(0),
    )


def test_undamped_modes_of_the_middle_ear_chain():
    """Reference: the undamped natural frequencies the description states (795, 3961, 12995,
    13644 Hz, from det(K − ω² M) = 0 of the LVATB1 values), independent of the damping."""
    mod = load_generated(GENERATED / "middle_ear_chain.py")
    res = modes(linearize(mod), undamped=True)
    np.testing.assert_allclose(res.frequency_hz, [795, 3961, 12995, 13644], rtol=5e-4)
    assert np.all(res.damping_ratio == 0.0) and res.undamped
    assert res.table().startswith("# undamped pencil")


def test_undamped_pencil_drops_damping_closed_form():
    """Reference: closed form ω0² = eigenvalues of M⁻¹K for a two-mass chain, damping far
    above critical (all damped modes overdamped, the note says so)."""
    m = np.diag([1.0, 2.0])
    k = np.array([[3.0, -1.0], [-1.0, 1.0]])
    lin = _linear(m, 100.0 * k, k)
    damped = modes(lin)
    assert set(damped.kind) == {"aperiodic"}
    note = damped.overdamped_note()
    assert note is not None and "overdamped" in note and "--undamped" in note
    w0 = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(m, k)).real))
    und = modes(lin, undamped=True)
    np.testing.assert_allclose(und.frequency_hz, w0 / (2 * np.pi), rtol=1e-12)
    assert und.overdamped_note() is None


def test_cli_modes_undamped_and_overdamped_note(capsys):
    """Reference: the same undamped frequencies through the CLI; lightly damped models print
    no note."""
    assert main(["modes", str(GENERATED / "middle_ear_chain.py"), "--undamped"]) == 0
    out, err = capsys.readouterr()
    assert "undamped pencil" in out and "note" not in err
    assert float(out.splitlines()[2].split()[1]) == pytest.approx(794.85, rel=1e-4)
