"""Parameter sensitivities of equilibria, modes, frequency responses and simulations
(analysis/sensitivity.py, analysis/sensitivity_time.py; docs/sensitivity.md).

References: closed forms — the pendulum's ``f ∝ √(g/l)`` (∂ln f/∂ln l = −½, ∂ln f/∂ln g = ½,
∂ln f/∂ln m = 0), the oscillator's ``H = 1/(k − mω² + jcω)`` (``∂ln H/∂ln k = −k/(k − mω² +
jcω)`` …), the preloaded pendulum's ``dφ₀/dT = 1/(k + m g l cos φ₀)`` — and central
differences of the analyses themselves (the equilibrium solved again at each point).
"""

from __future__ import annotations

from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import pytest

from neweul_py.analysis import sensitivity as sens
from neweul_py.analysis.equilibrium import equilibrium
from neweul_py.analysis.frf import frequency_response
from neweul_py.analysis.linearize import linearize
from neweul_py.analysis.modes import modes
from neweul_py.analysis.module import load_generated
from neweul_py.analysis.sensitivity_time import simulate_sensitivity
from neweul_py.analysis.simulate import simulate
from neweul_py.api import generate
from neweul_py.errors import NeweulError

ROOT = Path(__file__).resolve().parents[2]

OSCILLATOR = """\
name: oscillator
parameters: {m: 2.0, k: 800.0, c: 4.0}
coordinates: {x: 0.0}
inputs: {F: 0}
frames:
  cart: {translation: [x, 0, 0]}
bodies:
  mass: {frame: cart, mass: m}
forces:
  spring: {type: generalized, coordinate: x, value: -k*x - c*d_x + F}
"""

#: A pendulum under gravity with a torsion spring and a constant torque T: its equilibrium
#: angle, and through it the stiffness k + m g l cos φ₀, depend on T.
PRELOADED = """\
name: preloaded
parameters: {m: 1.5, l: 0.4, g: 9.81, k: 3.0, T: 2.0, d: 0.05}
gravity: [0, 0, -g]
coordinates: {phi: 0.0}
inputs: {M: 0}
frames:
  rod: {rotation: [[y, phi]]}
bodies:
  bob: {frame: rod, mass: m, center_of_mass: [0, 0, -l]}
forces:
  spring: {type: generalized, coordinate: phi, value: -k*phi - d*d_phi + T + M}
outputs:
  x_bob: {position: rod, point: [0, 0, -l], component: x}
"""


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    """The modules of the test descriptions and of two examples, generated with the
    directional derivatives (``sensitivities=True``)."""
    tmp = tmp_path_factory.mktemp("sens")
    (tmp / "osc.yaml").write_text(OSCILLATOR)
    (tmp / "pre.yaml").write_text(PRELOADED)
    paths = {"oscillator": tmp / "osc.yaml", "preloaded": tmp / "pre.yaml",
             "pendulum": ROOT / "examples" / "pendulum.yaml",
             "quarter_car": ROOT / "examples" / "quarter_car.yaml"}
    return {k: load_generated(generate(v, tmp / k, sensitivities=True))
            for k, v in paths.items()}


@pytest.fixture
def oscillator(models):
    return models["oscillator"]


@pytest.fixture
def preloaded(models):
    return models["preloaded"]


def test_pendulum_frequency_scales_with_root_of_g_over_l(models) -> None:
    """Closed form: f = √(g/l)/2π, so ∂ln f/∂ln l = −½, ∂ln f/∂ln g = ½, ∂ln f/∂ln m = 0."""
    mod = models["pendulum"]
    lin = linearize(mod, equilibrium(mod))
    ders, method = sens.linear_model_derivatives(mod, lin)
    res = sens.modal_sensitivity(lin, ders)
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
    res = sens.frequency_response_sensitivity(lin, ders, f, "F", "x")
    w = 2 * np.pi * f
    m, k, c = 2.0, 800.0, 4.0
    Z = k - m * w**2 + 1j * c * w
    want = {"k": -k / Z, "m": m * w**2 / Z, "c": -1j * c * w / Z}
    cols = res.columns()
    for name, rel in want.items():
        np.testing.assert_allclose(cols[f"dlogmag_dlog_{name}"], rel.real, atol=1e-10)
        np.testing.assert_allclose(cols[f"dphase_deg_dlog_{name}"], np.degrees(rel.imag),
                                   atol=1e-8)


def test_equilibrium_sensitivity_equals_the_closed_form(preloaded) -> None:
    """k φ₀ + m g l sin φ₀ = T gives dφ₀/dT = 1/(k + m g l cos φ₀) and
    dφ₀/dk = −φ₀/(k + m g l cos φ₀)."""
    mod = preloaded
    eq = equilibrium(mod)
    res = sens.equilibrium_sensitivity(mod, eq, ["T", "k"])
    m, l, g, k = 1.5, 0.4, 9.81, 3.0
    phi = eq.y[0]
    K = k + m * g * l * np.cos(phi)
    assert res.dy_dp[0, 0] == pytest.approx(1.0 / K, rel=1e-12)
    assert res.dy_dp[0, 1] == pytest.approx(-phi / K, rel=1e-12)


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
def test_frf_sensitivity_equals_central_differences(models, name, inputs, outputs) -> None:
    """Through the moving equilibrium (preloaded pendulum: T, l, m change φ₀ and with it the
    stiffness and C) and through the rates of a kinematic excitation (quarter car, input
    zr with d_zr): ∂H/∂p equals central differences of the frequency response (relative step
    1e-6, the equilibrium solved again)."""
    mod = models[name]
    lin = linearize(mod, equilibrium(mod))
    ders, method = sens.linear_model_derivatives(mod, lin)
    assert method == sens.ANALYTIC
    f = np.geomspace(0.3, 30.0, 9)
    res = sens.frequency_response_sensitivity(lin, ders, f, inputs, outputs)
    for j, nm in enumerate(res.parameters):
        ref = _frf_difference(mod, nm, f, inputs, outputs)
        scale = np.abs(res.H).max() / abs(mod.default_parameters()[j])
        np.testing.assert_allclose(res.dH[j], ref, rtol=0, atol=2e-6 * scale, err_msg=nm)


def test_modal_sensitivity_equals_central_differences(models) -> None:
    """Damped modes of the quarter car: dλ/dp from the left and right eigenvectors equals
    central differences of the eigenvalues (relative step 1e-4: the eigenvalues' round-off
    of ~1e-13·|λ| would dominate smaller steps)."""
    mod = models["quarter_car"]
    lin = linearize(mod, equilibrium(mod))
    ders, _ = sens.linear_model_derivatives(mod, lin, ["mb", "ks", "cs", "kt"])
    res = sens.modal_sensitivity(lin, ders)
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


def test_differences_fallback_equals_the_analytic_derivatives(preloaded) -> None:
    """A module without the directional functions (generated without sensitivities, or with
    elastic bodies) gets the linear model's derivatives as central differences; they equal
    the analytic ones."""
    mod = preloaded
    lin = linearize(mod, equilibrium(mod))
    analytic, _ = sens.linear_model_derivatives(mod, lin)
    bare = replace(mod, **{f.name: None for f in fields(mod) if f.name.endswith("_directional")})
    numeric, method = sens.linear_model_derivatives(bare, lin)
    assert method == sens.DIFFERENCES
    for a, b in zip(analytic, numeric, strict=True):
        for key in ("M0", "P", "Q", "B", "C", "D"):
            x, y = getattr(a, key), getattr(b, key)
            np.testing.assert_allclose(y, x, rtol=0, atol=1e-6 * max(1.0, np.abs(x).max()),
                                       err_msg=f"{a.parameter} {key}")


@pytest.mark.parametrize(("name", "wrt"), [("pendulum", ["l", "g"]),
                                           ("quarter_car", ["ks", "cs", "A", "v"])])
def test_simulation_sensitivity_equals_central_differences(name, wrt) -> None:
    """∂x/∂p and ∂out/∂p of the variational equations equal central differences of two
    simulations (DOP853, rtol 1e-12; relative step 1e-6); the quarter car's A and v enter only
    through the default road excitation (the chain ∂rhs/∂u · ∂u₀/∂p)."""
    mod = load_generated(ROOT / "generated" / f"{name}.py")
    res = simulate_sensitivity(mod, 1.0, wrt, n_out=11, rtol=1e-10, atol=1e-12)
    p = mod.default_parameters()
    for j, nm in enumerate(wrt):
        v = p[list(mod.PARAMETERS).index(nm)]
        h = 1e-6 * abs(v)
        runs = [simulate(mod, 1.0, n_out=11, p={nm: v + s * h}, method="DOP853", rtol=1e-12,
                         atol=1e-14) for s in (1.0, -1.0)]
        dx = (np.hstack([runs[0].y, runs[0].yd]) - np.hstack([runs[1].y, runs[1].yd])) / (2 * h)
        dout = (runs[0].outputs - runs[1].outputs) / (2 * h)
        np.testing.assert_allclose(res.dx_dp[:, :, j], dx, rtol=0,
                                   atol=1e-6 * np.abs(dx).max(), err_msg=nm)
        np.testing.assert_allclose(res.dout_dp[:, :, j], dout, rtol=0,
                                   atol=1e-6 * np.abs(dout).max(), err_msg=nm)


def test_bad_names_and_values_are_one_error(oscillator) -> None:
    """An unknown parameter (listing the valid ones), a repeated one, a zero value and a
    constrained model each give one NeweulError."""
    mod = oscillator
    lin = linearize(mod, equilibrium(mod))
    with pytest.raises(NeweulError, match=r"unknown parameter 'q'.*m, k, c"):
        sens.linear_model_derivatives(mod, lin, ["q"])
    with pytest.raises(NeweulError, match="named twice"):
        sens.parameter_indices(mod, ["k", "k"])
    with pytest.raises(NeweulError, match="are 0"):
        sens.parameter_indices(mod, ["k"], np.array([1.0, 0.0, 1.0]))
    crank = load_generated(ROOT / "generated" / "slider_crank.py")
    with pytest.raises(NeweulError, match="constraints"):
        simulate_sensitivity(crank, 0.1)
