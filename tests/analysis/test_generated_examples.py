"""The analysis tools on generated example modules (examples/*.yaml through the generator).

References: the slider–crank example describes the same mechanism as the hand-written fixture, so
its constrained trajectory is checked against the independent minimal-coordinate model of
``_slider_crank_reference.py``; the LVATB1 middle-ear chain is checked for consistency between
its modes and its frequency response (resonance peaks at the damped eigenfrequencies).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from _slider_crank_reference import build, trajectory

from neweul_py.analysis.dae import simulate_constrained
from neweul_py.analysis.equilibrium import equilibrium
from neweul_py.analysis.linearize import linearize
from neweul_py.analysis.modes import modes
from neweul_py.analysis.module import load_generated

EXAMPLES = Path(__file__).parents[2] / "examples"


def _generated(name: str, cache: Path):
    from neweul_py.api import generated_module

    return load_generated(generated_module(EXAMPLES / f"{name}.yaml", cache=cache))


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("generated")


def test_generated_slider_crank_against_minimal_model(cache):
    mod = _generated("slider_crank", cache)
    assert mod.CONSTRAINTS == ["pin_x", "pin_z", "slide_x", "slide_z"]
    prm = dict(zip(mod.PARAMETERS, mod.default_parameters(), strict=True))
    prm["Jc"] = prm["mc"] * prm["r"] ** 2 / 3
    prm["Ir"] = prm["mr"] * prm["l"] ** 2 / 12
    ref_model = build(prm)
    run = simulate_constrained(mod, 2.0, n_out=201, independent=["phi"])
    ref = trajectory(ref_model, 0.5, 8.0, run.t)
    assert np.abs(run.y[:, 0] - ref[:, 0]).max() < 1e-7
    assert run.max_drift < 1e-8
    s = np.array([ref_model.coordinates(ph)[4] for ph in ref[:, 0]], dtype=float)
    assert np.abs(run.y[:, mod.COORDINATES.index("s")] - s).max() < 1e-7
    # equilibrium near phi = -1 and the eigenvalue of the linearization on the manifold
    eq = equilibrium(mod, y0=dict(zip(mod.COORDINATES, ref_model.coordinates(-1.0), strict=True)))
    phi = eq.y[0]
    assert ref_model.generalized_force(phi, 0.0, 0.0) == pytest.approx(0.0, abs=1e-10)
    lam = modes(linearize(mod, eq)).eigenvalues[0]
    char = np.roots([ref_model.mass(phi), ref_model.damping(phi), ref_model.stiffness(phi)])
    assert lam == pytest.approx(char[char.imag > 0][0], rel=1e-7)


def test_generated_middle_ear_modes_match_frf_peaks(cache):
    mod = _generated("middle_ear_chain", cache)
    assert mod.INPUTS == ["p_ec"]
    lin = linearize(mod, equilibrium(mod))
    res = modes(lin)
    assert res.kind and all(k == "oscillating" for k in res.kind)
    # |det Z(jω)| has its minima near the damped eigenfrequencies of lightly damped modes
    light = [i for i in range(len(res.kind)) if res.damping_ratio[i] < 0.05]
    for i in light:
        fd = res.damped_frequency_hz[i]
        f = np.linspace(0.97 * fd, 1.03 * fd, 601)
        w = 2 * np.pi * f[:, None, None]
        det = np.abs(np.linalg.det(-(w**2) * lin.M0 + 1j * w * lin.P + lin.Q))
        assert abs(f[np.argmin(det)] - fd) <= 0.01 * fd
