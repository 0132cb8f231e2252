"""Modes and frequency responses of the damped two-mass oscillator (fixtures/two_mass.py).

Reference: the analytic transfer functions of the two-mass oscillator by Cramer's rule on the
2×2 dynamic stiffness Z(s) = [[m1 s² + (d1+d2) s + k1+k2, −(d2 s + k2)],
[−(d2 s + k2), m2 s² + d2 s + k2]], and its poles, the roots of det Z(s) (a quartic).
"""

from __future__ import annotations

import csv

import numpy as np
import pytest

from neweul_py.analysis.frf import frequency_response, frequency_vector
from neweul_py.analysis.linearize import linearize
from neweul_py.analysis.modes import modes
from neweul_py.errors import NeweulError


def _analytic(p, f):
    m1, m2, k1, k2, d1, d2 = p
    s = 2j * np.pi * np.asarray(f)
    z11 = m1 * s**2 + (d1 + d2) * s + k1 + k2
    z22 = m2 * s**2 + d2 * s + k2
    c = d2 * s + k2
    det = z11 * z22 - c**2
    # X = Z^-1 F: columns F1, F2
    return {"x1/F1": z22 / det, "x2/F1": c / det, "x1/F2": c / det, "x2/F2": z11 / det, "s": s}


def _poles(p):
    m1, m2, k1, k2, d1, d2 = p
    z11 = np.array([m1, d1 + d2, k1 + k2])
    z22 = np.array([m2, d2, k2])
    c = np.array([d2, k2])
    return np.roots(np.polysub(np.polymul(z11, z22), np.polymul(c, c)))


F = np.unique(np.concatenate([np.logspace(0, 3, 300), [13.34, 13.345, 26.69, 26.70]]))


@pytest.mark.parametrize(
    ("method", "rtol"), [("solve", 1e-10), ("hessenberg", 1e-8), ("eig", 1e-8)]
)
def test_frf_against_analytic_transfer_function(two_mass, method, rtol):
    """All output kinds (module outputs incl. feed-through, coordinates, d_, dd_) vs Cramer.

    The default second-order ``solve`` meets 1e-10; the first-order methods lose digits where
    the response is a small difference of large state responses (x2/F1 ~ 1/ω⁴ at 1 kHz while
    the velocity states are ~ 1/ω), and are held to 1e-8.
    """
    p = two_mass.default_parameters()
    lin = linearize(two_mass, [0.0, 0.0])
    ref = _analytic(p, F)
    s = ref["s"]
    k2, d2 = p[3], p[5]
    fr = frequency_response(
        lin, F, ["F1", "F2"], ["pos2", "vel1", "spring2_force", "load2", "x1", "d_x2", "dd_x1"],
        method=method,
    )
    expect = np.empty((F.size, 7, 2), dtype=complex)
    for j, u in enumerate(["F1", "F2"]):
        x1, x2 = ref[f"x1/{u}"], ref[f"x2/{u}"]
        expect[:, 0, j] = x2
        expect[:, 1, j] = s * x1
        expect[:, 2, j] = (k2 + d2 * s) * (x2 - x1)
        expect[:, 3, j] = 1.0 if u == "F2" else 0.0
        expect[:, 4, j] = x1
        expect[:, 5, j] = s * x2
        expect[:, 6, j] = s**2 * x1
    err = np.abs(fr.H - expect) / np.maximum(np.abs(expect), 1e-300)
    err[expect == 0] = np.abs(fr.H[expect == 0])
    assert err.max() <= rtol, (method, err.max())


def test_eigenvalues_against_poles(two_mass):
    """Eigenvalues of the first-order pencil = roots of det Z(s); f = |λ|/2π, ζ = −Re λ/|λ|."""
    res = modes(two_mass, y0=[0.0, 0.0])
    poles = _poles(two_mass.default_parameters())
    upper = poles[poles.imag > 0]
    upper = upper[np.argsort(np.abs(upper))]
    assert res.kind == ("oscillating", "oscillating")
    np.testing.assert_allclose(res.eigenvalues, upper, rtol=1e-10)
    np.testing.assert_allclose(res.frequency_hz, np.abs(upper) / (2 * np.pi), rtol=1e-10)
    np.testing.assert_allclose(res.damping_ratio, -upper.real / np.abs(upper), rtol=1e-9)
    # mode shapes: Z(λ) v = 0, largest entry 1
    m1, m2, k1, k2, d1, d2 = two_mass.default_parameters()
    for lam, v in zip(res.eigenvalues, res.shapes.T, strict=True):
        z = np.array([[m1 * lam**2 + (d1 + d2) * lam + k1 + k2, -(d2 * lam + k2)],
                      [-(d2 * lam + k2), m2 * lam**2 + d2 * lam + k2]])
        assert np.linalg.norm(z @ v) <= 1e-9 * np.linalg.norm(z)
        assert np.isclose(np.abs(v).max(), 1.0)


def test_modes_csv_and_table(two_mass, tmp_path):
    res = modes(two_mass, y0=[0.0, 0.0])
    path = tmp_path / "modes.csv"
    res.to_csv(path)
    rows = list(csv.reader(path.open()))
    assert rows[0][:2] == ["frequency_hz", "damping_ratio"]
    assert len(rows) == 3
    assert float(rows[1][0]) == pytest.approx(res.frequency_hz[0], rel=1e-15)
    assert "oscillating" in res.table()


def test_frf_csv_and_plot(two_mass, tmp_path):
    fr = frequency_response(two_mass, frequency_vector("10:1000:50", log=True), "F2", "pos2",
                            y0=[0.0, 0.0])
    fr.to_csv(tmp_path / "frf.csv")
    rows = list(csv.reader((tmp_path / "frf.csv").open()))
    assert rows[0] == ["frequency_hz", "magnitude", "phase_deg"]
    assert len(rows) == 51
    fr.plot(tmp_path / "bode.png")
    assert (tmp_path / "bode.png").stat().st_size > 0


def test_unknown_names_list_valid_ones(two_mass):
    lin = linearize(two_mass, [0.0, 0.0])
    with pytest.raises(NeweulError, match=r"unknown input 'F3'; valid inputs: F1, F2"):
        frequency_response(lin, [1.0], "F3", "pos2")
    with pytest.raises(NeweulError, match=r"unknown output 'pos3'.*pos2.*d_x1"):
        frequency_response(lin, [1.0], "F1", "pos3")


def test_frequency_vector_spec():
    np.testing.assert_allclose(frequency_vector("10:10000:4", log=True), [10, 100, 1000, 10000])
    np.testing.assert_allclose(frequency_vector("0:3:4"), [0, 1, 2, 3])
    with pytest.raises(NeweulError, match="start:stop:count"):
        frequency_vector("10:x:3")


def test_unsymmetric_mass_matrix(two_mass):
    """Premultiplying all equations by a non-symmetric regular T (as two-sided elastic data does
    to M) changes neither the eigenvalues nor the frequency response."""
    import dataclasses

    lin = linearize(two_mass, [0.0, 0.0])
    t = np.array([[1.0, 0.7], [-0.3, 2.0]])
    skew = dataclasses.replace(lin, M0=t @ lin.M0, P=t @ lin.P, Q=t @ lin.Q, B=t @ lin.B)
    assert not np.allclose(skew.M0, skew.M0.T)
    np.testing.assert_allclose(modes(skew).eigenvalues, modes(lin).eigenvalues, rtol=1e-12)
    for method in ("solve", "hessenberg", "eig"):
        np.testing.assert_allclose(
            frequency_response(skew, F, method=method).H,
            frequency_response(lin, F, method=method).H,
            rtol=1e-8,
        )


def test_modes_and_frf_npz_files_round_trip(two_mass, tmp_path):
    """``.npz`` holds all modes and the complex H: read back they equal the analytic poles
    (roots of det Z) and Cramer's transfer function; missing directories are created."""
    p = two_mass.default_parameters()
    res = modes(two_mass, y0=[0.0, 0.0])
    back = type(res).load(res.save(tmp_path / "new" / "dir" / "modes.npz"))
    ref = sorted(_poles(p)[_poles(p).imag > 0], key=abs)
    np.testing.assert_allclose(back.eigenvalues, ref, rtol=1e-10)
    assert back.kind == ("oscillating", "oscillating")
    assert back.coordinates == ("x1", "x2")
    f = np.logspace(0, 3, 40)
    fr = frequency_response(two_mass, f, ["F1", "F2"], ["x1", "x2"], y0=[0.0, 0.0])
    back = type(fr).load(fr.save(tmp_path / "other" / "frf.npz"))
    h = _analytic(p, f)
    np.testing.assert_allclose(back.H[:, 1, 0], h["x2/F1"], rtol=1e-10)
    np.testing.assert_allclose(back.H[:, 0, 1], h["x1/F2"], rtol=1e-10)
    assert back.outputs == ("x1", "x2") and back.inputs == ("F1", "F2")
    with pytest.raises(NeweulError, match=r"frf.txt: frequency responses are written as .csv "
                                          r"or .npz, not .txt"):
        fr.save(tmp_path / "frf.txt")
    with pytest.raises(NeweulError, match=r"m.dat: modes are written as .csv or .npz"):
        res.save(tmp_path / "m.dat")


def test_rates_of_a_kinematic_input_are_not_inputs():
    """The quarter car's road input zr enters with its rates d_zr, dd_zr (INPUT_RATES); they
    are folded into zr, so asking for d_zr is an error naming the valid inputs, and the default
    input set is zr alone."""
    from pathlib import Path

    from neweul_py.analysis.module import load_generated

    mod = load_generated(Path(__file__).resolve().parents[2] / "generated" / "quarter_car.py")
    assert mod.INPUT_RATES == {"zr": ["d_zr", "dd_zr"]}
    lin = linearize(mod)
    with pytest.raises(NeweulError, match=r"input 'd_zr' is a time derivative of the input "
                                          r"'zr': rates are folded in automatically .*; valid "
                                          r"inputs: zr$"):
        frequency_response(lin, [1.0], "d_zr", "body_height")
    with pytest.raises(NeweulError, match=r"unknown input 'road'; valid inputs: zr$"):
        frequency_response(lin, [1.0], "road", "body_height")
    assert frequency_response(lin, [1.0], outputs="body_height").inputs == ("zr",)


def test_unstable_operating_point_is_named(spring_pendulum):
    """The spring pendulum's second equilibrium, φ_s + π with tan φ_s = k a / (m g − k b), is
    inverted: m l² λ² + d λ + k_eff = 0 with k_eff = k l (a sin φ − b cos φ) + m g l cos φ < 0
    has the real root λ+ = (−d + √(d² − 4 m l² k_eff)) / (2 m l²) > 0, which the warning names."""
    from neweul_py.analysis.equilibrium import equilibrium

    m, l, g, k, a, b, d = spring_pendulum.default_parameters()
    phi = np.arctan2(k * a, m * g - k * b) + np.pi
    eq = equilibrium(spring_pendulum, y0=[phi + 0.05])
    assert eq.y[0] == pytest.approx(phi, abs=1e-12)
    k_eff = k * l * (a * np.sin(phi) - b * np.cos(phi)) + m * g * l * np.cos(phi)
    lam = (-d + np.sqrt(d * d - 4 * m * l * l * k_eff)) / (2 * m * l * l)
    res = modes(linearize(spring_pendulum, eq))
    assert res.unstable.tolist() == [True, False] or res.unstable.tolist() == [False, True]
    warning = res.stability_warning()
    assert warning.startswith("the operating point is unstable: eigenvalue(s) with positive "
                              f"real part {lam:+.6g} (aperiodic, dominant phi)")
    assert modes(linearize(spring_pendulum, equilibrium(spring_pendulum))).stability_warning() \
        is None


def test_an_undamped_resonance_is_one_error_naming_the_frequency(two_mass):
    """With ``M = I``, ``P = 0`` and ``Q = diag((2π)², (4π)²)`` the dynamic stiffness
    ``Q − ω² M`` is exactly singular at 1 Hz and 2 Hz (closed form ``f = √q / 2π``): the
    response there is infinite, one error names the first such frequency."""
    from dataclasses import replace

    from neweul_py.errors import SolverError

    lin = linearize(two_mass, [0.0, 0.0])
    w = 2 * np.pi
    undamped = replace(lin, M0=np.eye(2), P=np.zeros((2, 2)), Q=np.diag([w * w, 4 * w * w]))
    with pytest.raises(SolverError, match=r"singular at f = 2 Hz"):
        frequency_response(undamped, [0.5, 2.0, 3.0], "F1", "x1")
    assert np.isfinite(frequency_response(undamped, [0.5, 1.5], "F1", "x1").H).all()
