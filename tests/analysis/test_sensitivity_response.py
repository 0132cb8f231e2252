"""Parameter sensitivities of modes and frequency responses (analysis/sensitivity_response.py;
docs/sensitivity.md §4–5).

References: closed forms — the pendulum's ``f ∝ √(g/l)`` (∂ln f/∂ln l = −½, ∂ln f/∂ln g = ½,
∂ln f/∂ln m = 0), the oscillator's ``H = 1/(k − mω² + jcω)`` (``∂ln H/∂ln k = −k/(k − mω² +
jcω)`` …) — and central differences of the frequency response and of the eigenvalues (the
equilibrium solved again at each point).
"""

from __future__ import annotations

import numpy as np
import pytest

from neweul_py.analysis import sensitivity as sens
from neweul_py.analysis.equilibrium import equilibrium
from neweul_py.analysis.frf import frequency_response
from neweul_py.analysis.linearize import linearize
from neweul_py.analysis.modes import modes
from neweul_py.analysis.sensitivity_response import (
    frequency_response_sensitivity,
    modal_sensitivity,
)


def test_pendulum_frequency_scales_with_root_of_g_over_l(sensitivity_models) -> None:
    """Closed form: f = √(g/l)/2π, so ∂ln f/∂ln l = −½, ∂ln f/∂ln g = ½, ∂ln f/∂ln m = 0."""
    mod = sensitivity_models["pendulum"]
    lin = linearize(mod, equilibrium(mod))
    ders, method = sens.linear_model_derivatives(mod, lin)
    res = modal_sensitivity(lin, ders)
    assert method == sens.ANALYTIC
    cols = res.columns()
    assert cols["dlogf_dlog_l"][0] == pytest.approx(-0.5, abs=1e-12)
    assert cols["dlogf_dlog_g"][0] == pytest.approx(0.5, abs=1e-12)
    assert cols["dlogf_dlog_m"][0] == pytest.approx(0.0, abs=1e-12)


def test_oscillator_frf_sensitivity_equals_the_closed_form(oscillator) -> None:
    """H = 1/(k − mω² + jcω): ∂ln H/∂ln k = −k/Z, ∂ln H/∂ln m = mω²/Z, ∂ln H/∂ln c = −jcω/Z."""
    mod = oscillator
    lin = linearize(mod, equilibrium(mod))
    ders, _ = sens.linear_model_derivatives(mod, lin)
    f = np.geomspace(1.0, 100.0, 37)
    res = frequency_response_sensitivity(lin, ders, f, "F", "x")
    w = 2 * np.pi * f
    m, k, c = 2.0, 800.0, 4.0
    Z = k - m * w**2 + 1j * c * w
    want = {"k": -k / Z, "m": m * w**2 / Z, "c": -1j * c * w / Z}
    cols = res.columns()
    for name, rel in want.items():
        np.testing.assert_allclose(cols[f"dlogmag_dlog_{name}"], rel.real, atol=1e-10)
        np.testing.assert_allclose(cols[f"dphase_deg_dlog_{name}"], np.degrees(rel.imag),
                                   atol=1e-8)


def _frf_difference(mod, name: str, f, inputs, outputs, h: float = 1e-6):
    p = mod.default_parameters()
    k = list(mod.PARAMETERS).index(name)
    sides = []
    for sign in (1.0, -1.0):
        q = p.copy()
        q[k] *= 1 + sign * h
        lin = linearize(mod, equilibrium(mod, p=q))
        sides.append(frequency_response(lin, f, inputs, outputs).H)
    return (sides[0] - sides[1]) / (2 * h * p[k])


@pytest.mark.parametrize(("name", "inputs", "outputs"),
                         [("preloaded", "M", ["phi", "x_bob", "d_phi"]),
                          ("quarter_car", "zr", ["body_height", "tire_force"])])
def test_frf_sensitivity_equals_central_differences(sensitivity_models, name, inputs,
                                                    outputs) -> None:
    """Through the moving equilibrium (preloaded pendulum: T, l, m change φ₀ and with it the
    stiffness and C) and through the rates of a kinematic excitation (quarter car, input
    zr with d_zr): ∂H/∂p equals central differences of the frequency response (relative step
    1e-6, the equilibrium solved again)."""
    mod = sensitivity_models[name]
    lin = linearize(mod, equilibrium(mod))
    ders, method = sens.linear_model_derivatives(mod, lin)
    assert method == sens.ANALYTIC
    f = np.geomspace(0.3, 30.0, 9)
    res = frequency_response_sensitivity(lin, ders, f, inputs, outputs)
    for j, nm in enumerate(res.parameters):
        ref = _frf_difference(mod, nm, f, inputs, outputs)
        scale = np.abs(res.H).max() / abs(mod.default_parameters()[j])
        np.testing.assert_allclose(res.dH[j], ref, rtol=0, atol=2e-6 * scale, err_msg=nm)


def test_modal_sensitivity_equals_central_differences(sensitivity_models) -> None:
    """Damped modes of the quarter car: dλ/dp from the left and right eigenvectors equals
    central differences of the eigenvalues (relative step 1e-4: the eigenvalues' round-off
    of ~1e-13·|λ| would dominate smaller steps)."""
    mod = sensitivity_models["quarter_car"]
    lin = linearize(mod, equilibrium(mod))
    ders, _ = sens.linear_model_derivatives(mod, lin, ["mb", "ks", "cs", "kt"])
    res = modal_sensitivity(lin, ders)
    p = mod.default_parameters()
    for j, nm in enumerate(res.parameters):
        k = list(mod.PARAMETERS).index(nm)
        lam = []
        for sign in (1.0, -1.0):
            q = p.copy()
            q[k] *= 1 + sign * 1e-4
            lam.append(modes(linearize(mod, equilibrium(mod, p=q))).eigenvalues)
        ref = (lam[0] - lam[1]) / (2e-4 * p[k])
        np.testing.assert_allclose(res.deigenvalue[:, j], ref, rtol=0,
                                   atol=1e-5 * np.abs(ref).max(), err_msg=nm)
