"""The rigid examples with loops, excitation and tables, generated and analysed end to end,
against independent references.

- slider–crank: the generated module against the hand-written protocol module
  ``tests/analysis/fixtures/slider_crank.py``; its constrained simulation (analysis'
  ``simulate_constrained``) against a minimal-coordinate model derived in this file;
- four-bar: constraint drift and energy conservation (hand-written potential) without damping;
- quarter-car on a road input: frequency response against the analytic two-mass transfer
  function (road input entering through the tire spring *and* damper, i.e. through ``zr`` and
  its rate ``d_zr``);
- middle-ear chain (LVATB1): real eigenfrequencies equal to the undamped ones of the script's
  M, K, damping ratios η/2 of the modal damping, stapes velocity per ear-canal pressure in the
  qualitative range of docs/middle-ear-data.md.
"""

from __future__ import annotations

import importlib.util
import pathlib
import sys

import numpy as np
import pytest
import sympy as sp

from neweul_py.analysis.module import load_generated
from neweul_py.api import generate
from neweul_py.compare import compare

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
RNG = np.random.default_rng(4)


@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    """Generate each example once per test module."""
    out = tmp_path_factory.mktemp("issue4_generated")
    cache: dict[str, object] = {}

    def get(name: str):
        if name not in cache:
            cache[name] = load_generated(generate(EXAMPLES / f"{name}.yaml", out))
        return cache[name]

    return get


def _load(path: pathlib.Path, name: str):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


# ----------------------------------------------------------------------------- slider–crank
def test_generated_slider_crank_equals_the_hand_written_module(generated) -> None:
    """M, q − k, its Jacobians, g, G, γ at random states equal the hand-written module's."""
    mod = generated("slider_crank")
    hand = _load(ROOT / "tests" / "analysis" / "fixtures" / "slider_crank.py", "_hand_sc")
    assert mod.CONSTRAINTS == hand.CONSTRAINTS
    assert mod.COORDINATES == hand.COORDINATES
    p = mod.default_parameters()
    P = dict(zip(mod.PARAMETERS, p, strict=True))
    ph = np.array([P["r"], P["l"], P["mc"], P["mc"] * P["r"] ** 2 / 3, P["mr"],
                   P["mr"] * P["l"] ** 2 / 12, P["ms"], P["ks"], P["s0"], P["ds"], P["cc"],
                   P["g"]])
    for _ in range(20):
        y, yd, u = RNG.normal(size=5), RNG.normal(size=5), RNG.normal(size=1)
        np.testing.assert_allclose(mod.mass_matrix(0.0, y, p), hand.mass_matrix(0.0, y, ph),
                                   rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(mod.force_vector(0.0, y, yd, p, u),
                                   hand.force_vector(0.0, y, yd, ph, u), rtol=1e-12, atol=1e-13)
        for ours, theirs in zip(mod.force_jacobians(0.0, y, yd, p, u),
                                hand.force_jacobians(0.0, y, yd, ph, u), strict=True):
            np.testing.assert_allclose(ours, theirs, rtol=1e-12, atol=1e-13)
        np.testing.assert_allclose(mod.constraints(0.0, y, p), hand.constraints(0.0, y, ph),
                                   atol=1e-14)
        np.testing.assert_allclose(mod.constraint_jacobian(0.0, y, p),
                                   hand.constraint_jacobian(0.0, y, ph), atol=1e-14)
        np.testing.assert_allclose(mod.constraint_gamma(0.0, y, yd, p),
                                   hand.constraint_gamma(0.0, y, yd, ph), rtol=1e-12, atol=1e-13)


def _minimal_slider_crank(P: dict[str, float]):
    """Lagrange's equation in the crank angle alone (loop closed by hand):
    sin θ = −r sin φ / l; T = ½ m(φ) φ̇², m = J_O + m_r |∂r_rod/∂φ|² + I_r θ'² + m_s s'²;
    Q = −∂V/∂φ − c φ̇ − d_s s'² φ̇ with V = m_c g (r/2) sin φ + m_r g z_rod + ½ k_s (s − s0)²."""
    phi, om = sp.symbols("phi omega")
    r, l = P["r"], P["l"]
    th = -sp.asin(r * sp.sin(phi) / l)
    xr = r * sp.cos(phi) + l / 2 * sp.cos(th)
    zr = r * sp.sin(phi) + l / 2 * sp.sin(th)
    s = r * sp.cos(phi) + l * sp.cos(th)
    d = lambda e: sp.diff(e, phi)  # noqa: E731
    mass = (P["mc"] * r**2 / 3 + P["mr"] * (d(xr) ** 2 + d(zr) ** 2)
            + P["mr"] * l**2 / 12 * d(th) ** 2 + P["ms"] * d(s) ** 2)
    V = P["mc"] * P["g"] * r / 2 * sp.sin(phi) + P["mr"] * P["g"] * zr \
        + P["ks"] / 2 * (s - P["s0"]) ** 2
    Q = -d(V) - P["cc"] * om - P["ds"] * d(s) ** 2 * om
    acc = sp.lambdify((phi, om), (Q - d(mass) / 2 * om**2) / mass)
    slider = sp.lambdify(phi, s)
    return acc, slider


def test_slider_crank_simulation_matches_the_minimal_coordinate_model(
    generated, tmp_path
) -> None:
    """simulate_constrained (drift control by projection) vs the 1-DOF model: crank angle and
    slider position over 2 s (compared by neweul_py.compare against the reference written as a
    plain CSV), constraint drift below 1e-8."""
    dae = importlib.import_module("neweul_py.analysis.dae")
    from scipy.integrate import solve_ivp

    mod = generated("slider_crank")
    sim = dae.simulate_constrained(mod, 2.0, n_out=201, rtol=1e-11, atol=1e-12)
    P = dict(zip(mod.PARAMETERS, mod.default_parameters(), strict=True))
    acc, slider = _minimal_slider_crank(P)
    i_phi = mod.COORDINATES.index("phi")
    phi0, om0 = sim.y[0, i_phi], sim.yd[0, i_phi]
    ref = solve_ivp(lambda _t, x: [x[1], acc(x[0], x[1])], (0.0, 2.0), [phi0, om0],
                    t_eval=sim.t, method="DOP853", rtol=1e-12, atol=1e-12)
    # the reference as another tool would write it: a plain CSV, time first, units in names
    table = np.column_stack([ref.t, ref.y[0], ref.y[1], slider(ref.y[0])])
    csv = tmp_path / "minimal_model.csv"
    np.savetxt(csv, table, delimiter=",", header="time [s],phi [rad],d_phi [rad/s],s [m]",
               comments="")
    cmp = compare(sim.result, csv, rtol=0.0, atol={"phi": 1e-7, "d_phi": 1e-6, "s": 1e-8})
    assert [e.name for e in cmp.errors] == ["phi", "d_phi", "s"]
    assert cmp.passed, cmp.table()
    assert sim.max_drift < 1e-8
    assert np.max(sim.position_residual) < 1e-10


# ----------------------------------------------------------------------------- four-bar
def test_four_bar_keeps_its_loop_closed_and_conserves_energy(generated) -> None:
    """No damping, no drive: T + V (gravity of three uniform bars + rocker spring, written by
    hand) is conserved and the loop stays closed."""
    dae = importlib.import_module("neweul_py.analysis.dae")
    mod = generated("four_bar")
    p = mod.default_parameters()
    names = list(mod.PARAMETERS)
    p[names.index("cb")] = 0.0
    P = dict(zip(names, p, strict=True))
    sim = dae.simulate_constrained(mod, 2.0, n_out=101, p=p, rtol=1e-11, atol=1e-12)

    def energy(y, yd):
        f1, f2, f3 = y
        T = 0.5 * yd @ mod.mass_matrix(0.0, y, p) @ yd
        z = (P["ma"] * P["a"] / 2 * np.sin(f1)
             + P["mb"] * (P["a"] * np.sin(f1) + P["b"] / 2 * np.sin(f1 + f2))
             + P["mc"] * P["c"] / 2 * np.sin(f3))
        return T + P["g"] * z + 0.5 * P["kr"] * (f3 - P["phi30"]) ** 2

    e = np.array([energy(y, yd) for y, yd in zip(sim.y, sim.yd, strict=True)])
    assert np.ptp(e) < 1e-7 * max(1.0, abs(e[0]))
    g = np.array([mod.constraints(t, y, p) for t, y in zip(sim.t, sim.y, strict=True)])
    assert np.abs(g).max() < 1e-9


# ----------------------------------------------------------------------------- quarter-car
def test_quarter_car_frequency_response_is_the_two_mass_transfer_function(generated) -> None:
    """zb/zr from the linearized module (columns of B for zr, d_zr, dd_zr combined as
    B(jω) = B_zr + jω B_dzr − ω² B_ddzr) against
    Zb/Zr = (cs s + ks)(ct s + kt) / [(mb s² + cs s + ks)(mw s² + (cs + ct) s + ks + kt)
    − (cs s + ks)²]."""
    lin_mod = importlib.import_module("neweul_py.analysis.linearize")
    eq_mod = importlib.import_module("neweul_py.analysis.equilibrium")
    mod = generated("quarter_car")
    assert mod.INPUTS == ["zr", "d_zr", "dd_zr"]
    eq = eq_mod.equilibrium(mod, u=[0.0, 0.0, 0.0])
    lin = lin_mod.linearize(mod, eq)
    P = dict(zip(mod.PARAMETERS, mod.default_parameters(), strict=True))
    f = np.logspace(-1, 2, 200)
    w = 2 * np.pi * f
    i_zb = list(lin.coordinates).index("zb")
    h = np.empty(f.size, dtype=complex)
    for k, wk in enumerate(w):
        b = lin.B[:, 0] + 1j * wk * lin.B[:, 1] - wk**2 * lin.B[:, 2]
        h[k] = np.linalg.solve(-wk**2 * lin.M0 + 1j * wk * lin.P + lin.Q, b)[i_zb]
    s = 1j * w
    mb, mw, ks, cs, kt, ct = (P[n] for n in ("mb", "mw", "ks", "cs", "kt", "ct"))
    a = cs * s + ks
    ref = a * (ct * s + kt) / ((mb * s**2 + a) * (mw * s**2 + (cs + ct) * s + ks + kt) - a**2)
    np.testing.assert_allclose(h, ref, rtol=1e-10)
    # the toolbox folds the rates in itself (INPUT_RATES), for every solver and after a
    # save/load round trip of the linear model
    frf_mod = importlib.import_module("neweul_py.analysis.frf")
    for method in ("solve", "hessenberg", "eig"):
        fr = frf_mod.frequency_response(lin, f, "zr", "zb", method=method)
        cmp = compare(fr, {"frequency_hz": f, "H": ref}, atol=0.0,
                      rtol=1e-10 if method == "solve" else 1e-7)  # complex: phase counts
        assert cmp.kind == "frequency" and cmp.passed, cmp.table()


def test_linear_model_keeps_input_rates_through_save_and_load(generated, tmp_path) -> None:
    """INPUT_RATES survive LinearModel.save/load, so a saved model still answers the road
    input through the tire damper."""
    lin_mod = importlib.import_module("neweul_py.analysis.linearize")
    mod = generated("quarter_car")
    lin = lin_mod.linearize(mod, u0=[0.0, 0.0, 0.0])
    assert dict(lin.input_rates) == {"zr": ("d_zr", "dd_zr")}
    lin.save(tmp_path / "lin.npz")
    assert lin_mod.LinearModel.load(tmp_path / "lin.npz").input_rates == lin.input_rates


# ----------------------------------------------------------------------------- middle ear
def test_middle_ear_chain_modes_and_stapes_velocity(generated) -> None:
    """Undamped eigenfrequencies of the generated M, Q equal those of the script's matrices
    (real, positive); damping ratios are η/2 of the modal loss factors; the stapes velocity per
    ear-canal pressure peaks between 0.6 and 1.2 kHz at 0.1–0.3 mm/s/Pa
    (docs/middle-ear-data.md)."""
    lin_mod = importlib.import_module("neweul_py.analysis.linearize")
    frf_mod = importlib.import_module("neweul_py.analysis.frf")
    sys.path.insert(0, str(EXAMPLES))
    try:
        script = _load(EXAMPLES / "make_middle_ear_chain.py", "_make_me_chain")
    finally:
        sys.path.remove(str(EXAMPLES))
    mod = generated("middle_ear_chain")
    lin = lin_mod.linearize(mod)
    lam = np.linalg.eigvals(np.linalg.solve(lin.M0, lin.Q))
    assert np.all(np.abs(lam.imag) <= 1e-9 * np.abs(lam).max()) and np.all(lam.real > 0)
    _, freqs = script.modal_damping()
    np.testing.assert_allclose(np.sort(np.sqrt(lam.real)) / (2 * np.pi), freqs, rtol=1e-9)
    # damped first-order eigenvalues: ζ = η/2 per mode (modal damping is exact)
    n = lin.M0.shape[0]
    minv = np.linalg.inv(lin.M0)
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ lin.Q, -minv @ lin.P]])
    ev = np.linalg.eigvals(a)
    ev = ev[ev.imag > 0]
    ev = ev[np.argsort(np.abs(ev))]
    zeta = -ev.real / np.abs(ev)
    np.testing.assert_allclose(zeta, np.array(script.LOSS_FACTORS) / 2, rtol=1e-8)
    fr = frf_mod.frequency_response(lin, np.linspace(100.0, 5000.0, 491), "p_ec",
                                    "stapes_velocity")
    mag = np.abs(fr.H).reshape(-1) * 1e3  # mm/s per Pa
    k = int(np.argmax(mag))
    assert 600.0 <= fr.frequency_hz[k] <= 1200.0
    assert 0.1 <= mag[k] <= 0.3
    phase = np.angle(fr.H.reshape(-1), deg=True)
    assert phase[0] > 45.0 and phase[np.searchsorted(fr.frequency_hz, 2000.0)] < -45.0


def test_middle_ear_chain_description_is_what_its_script_writes() -> None:
    """examples/middle_ear_chain.yaml is written by make_middle_ear_chain.py (refresh with
    ``python examples/regenerate.py``)."""
    sys.path.insert(0, str(EXAMPLES))
    try:
        script = _load(EXAMPLES / "make_middle_ear_chain.py", "_make_me_chain_text")
    finally:
        sys.path.remove(str(EXAMPLES))
    assert (EXAMPLES / "middle_ear_chain.yaml").read_text(encoding="utf-8") == \
        script.description()
