"""examples/elastic_up_body end to end: FE model → ``neweul reduce --two-sided
--invariants`` → description with an elastic body, a spring and a rigid mass → ``neweul frf``,
run in a temporary directory; the FRF equals that of the unreduced FE model with the same
spring, damper and mass assembled directly (``make_fe.reference_frf``) below the cut-off, and
the two-sided body beats the one-sided one."""

from __future__ import annotations

import csv
import importlib.util
import shutil
from pathlib import Path

import numpy as np
import pytest

from neweul_py.cli import main

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "elastic_up_body"


def _make_fe():
    spec = importlib.util.spec_from_file_location("elastic_up_make_fe", EXAMPLE / "make_fe.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _frf(tmp_path: Path, side: str, monkeypatch: pytest.MonkeyPatch) -> np.ndarray:
    monkeypatch.chdir(tmp_path)
    assert main(["reduce", "duct.npz", side, "--modes", "12", "--keep-nodes", "1",
                 "--invariants", "-o", "body.npz"]) == 0
    assert main(["frf", "model.yaml", "--input", "F", "--output", "mass_x",
                 "--f", "20:900:45", "-o", "frf.csv"]) == 0
    with open("frf.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    mag = np.array([float(r["magnitude"]) for r in rows])
    ph = np.deg2rad([float(r["phase_deg"]) for r in rows])
    return mag * np.exp(1j * ph)


def test_elastic_up_body_example(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    make_fe = _make_fe()
    shutil.copy(EXAMPLE / "model.yaml", tmp_path / "model.yaml")
    make_fe.write_fe_model(make_fe.piston_duct(), tmp_path / "duct.npz")
    ref = make_fe.reference_frf(np.linspace(20.0, 900.0, 45), 0.02, 5.0e4, 2.0)
    err = {}
    for side in ("--two-sided", "--one-sided"):
        H = _frf(tmp_path, side, monkeypatch)
        err[side] = np.abs(H - ref) / np.abs(ref)
    assert err["--two-sided"].max() < 0.03
    assert np.median(err["--two-sided"]) < 1e-3
    assert err["--one-sided"].max() > 10 * err["--two-sided"].max()
