"""``neweul_py.sweep``: a sweep of a description file (generated into the cache first)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from neweul_py.sweep import grid, sweep

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_sweep_of_a_description(tmp_path, monkeypatch):
    """Reference: the closed-form natural frequency sqrt(g/l)/(2π) of the pendulum."""
    monkeypatch.setenv("NEWEUL_CACHE", str(tmp_path / "cache"))
    res = sweep(EXAMPLES / "pendulum.yaml", grid({"l": [0.5, 2.0]}), "modes", workers=1,
                processes=False)
    g = 9.81
    np.testing.assert_allclose(res.data["f1_hz"], np.sqrt(g / np.array([0.5, 2.0])) / (2 * np.pi),
                               rtol=1e-10)
    assert res.model_name == "pendulum" and res.ok.all()
