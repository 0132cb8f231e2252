"""Parameter identification (analysis/identify.py, identify_model.py, identify_data.py).

References: synthetic data of known parameters — a spring–mass–damper's frequency response
and a pendulum's swing, each with seeded noise — must give back those parameters within four
of the fit's own standard errors, and the standard errors must match the noise (the
Cramér–Rao bound of the linearized problem: ``σ_θ² = s² (JᵀJ)⁻¹``); a pair of parameters of
which only the product matters must be reported as undetermined, not as numbers.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from neweul_py.analysis.equilibrium import equilibrium
from neweul_py.analysis.frf import frequency_response
from neweul_py.analysis.identify import Bound, identify
from neweul_py.analysis.identify_data import FrequencyData, read_frequency_data, read_time_data
from neweul_py.analysis.linearize import linearize
from neweul_py.analysis.module import load_generated
from neweul_py.analysis.simulate import simulate
from neweul_py.api import generate
from neweul_py.errors import DataError, NeweulError

ROOT = Path(__file__).resolve().parents[2]

OSCILLATOR = """\
name: oscillator
parameters: {{m: 2.0, k1: 20.0, k2: 40.0, c: 4.0}}
coordinates: {{x: 0.0}}
inputs: {{F: 0}}
frames:
  cart: {{translation: [x, 0, 0]}}
bodies:
  mass: {{frame: cart, mass: m}}
forces:
  spring: {{type: generalized, coordinate: x, value: -{stiffness}*x - c*d_x + F}}
"""
TRUE = {"m": 2.0, "k": 800.0, "c": 4.0}


@pytest.fixture(scope="module")
def oscillators(tmp_path_factory):
    """The oscillator with stiffness ``k1*k2`` (only the product matters) and with ``k1``
    alone (``k1 = 800``)."""
    tmp = tmp_path_factory.mktemp("osc")
    (tmp / "pair.yaml").write_text(OSCILLATOR.format(stiffness="k1*k2"))
    (tmp / "one.yaml").write_text(OSCILLATOR.format(stiffness="k1").replace("k1: 20.0",
                                                                            "k1: 800.0"))
    return (load_generated(generate(tmp / "pair.yaml", tmp / "a", sensitivities=True)),
            load_generated(generate(tmp / "one.yaml", tmp / "b", sensitivities=True)))


def _noisy_frf(mod, noise: float, seed: int = 4) -> FrequencyData:
    f = np.geomspace(0.5, 30.0, 80)
    H = frequency_response(linearize(mod), f, "F", "x").H[:, 0, 0]
    rng = np.random.default_rng(seed)
    H = H * np.exp(noise * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)))
    return FrequencyData(f, H, np.ones(f.size), "x", "F")


def test_spring_mass_damper_from_a_noisy_frf(oscillators) -> None:
    """1 % log-normal noise on |H| and 0.01 rad on the phase: m, k, c come back within four
    standard errors, which are of the size the noise predicts (within a factor 2 of
    σ_noise · √diag((JᵀJ)⁻¹) at the truth)."""
    mod = oscillators[1]
    data = _noisy_frf(mod, 0.01)
    fit = identify(mod, data, [Bound("m", 0.1, 20.0, 0.5), Bound("k1", 10.0, 1e5, 100.0),
                               Bound("c", 0.01, 100.0, 1.0)], "frf")
    assert fit.converged and not fit.undetermined
    for name, true in (("m", 2.0), ("k1", 800.0), ("c", 4.0)):
        est, se = fit.parameters[name], fit.standard_errors[name]
        assert abs(est - true) < 4 * se, (name, est, se)
        assert 0.0005 * true < se < 0.05 * true, (name, se)
    assert fit.residual_rms == pytest.approx(0.01, rel=0.25)


def test_product_of_two_parameters_is_reported_undetermined(oscillators) -> None:
    """Stiffness k1·k2: the residuals depend on ln k1 + ln k2 only, so k1 and k2 are
    undetermined (None, with a reason naming both); m and c are still estimated."""
    mod = oscillators[0]
    data = _noisy_frf(mod, 0.005)
    fit = identify(mod, data, ["m=0.1:20:1", "k1=1:1000:5", "k2=1:1000:5", "c=0.01:100:1"],
                   "frf")
    assert fit.parameters["k1"] is None and fit.parameters["k2"] is None
    assert fit.standard_errors["k1"] is None and fit.correlation["k2"] is None
    assert "k1" in fit.undetermined["k2"] and "combination" in fit.undetermined["k1"]
    assert fit.end_point["k1"] * fit.end_point["k2"] == pytest.approx(800.0, rel=0.02)
    assert fit.parameters["m"] == pytest.approx(2.0, rel=0.02)
    assert fit.correlation["m"]["k1"] is None


def test_rows_of_weight_zero_are_not_data(oscillators) -> None:
    """Weight zero above 10 Hz gives the fit, the standard errors and the residual count of
    the data without those rows (``s² = 2·cost/(m − k)`` counts the residuals that carry
    weight: the Cramér–Rao bound of the rows that remain); so does a phase weight of zero
    for the phase rows."""
    mod = oscillators[1]
    data = _noisy_frf(mod, 0.01)
    low = data.frequency_hz < 10.0
    zero = FrequencyData(data.frequency_hz, data.H, low.astype(float), "x", "F")
    cut = FrequencyData(data.frequency_hz[low], data.H[low], np.ones(low.sum()), "x", "F")
    bounds = ["m=0.1:20:0.5", "k1=10:1e5:100", "c=0.01:100:1"]
    a, b = identify(mod, zero, bounds, "frf"), identify(mod, cut, bounds, "frf")
    assert a.n_residuals == b.n_residuals == 2 * int(low.sum())
    for name in ("m", "k1", "c"):
        assert a.parameters[name] == pytest.approx(b.parameters[name], rel=1e-6)
        assert a.standard_errors[name] == pytest.approx(b.standard_errors[name], rel=1e-6)
    assert a.residual_rms == pytest.approx(b.residual_rms, rel=1e-6)
    magnitude = identify(mod, cut, bounds, "frf", phase_weight=0.0)
    assert magnitude.n_residuals == int(low.sum())


PRELOADED = """\
name: preloaded
parameters: {m: 1.0, l: 0.5, g: 9.81, kt: 3.0, ct: 0.2, T0: 2.0}
gravity: [0, 0, -g]
coordinates: {phi: 0.3}
inputs: {T: T0}
frames:
  rod: {rotation: [[y, phi]]}
bodies:
  bob: {frame: rod, mass: m, center_of_mass: [0, 0, -l]}
forces:
  spring: {type: torque, frame: rod, vector: [0, T - kt*phi - ct*d_phi, 0], in: ISYS}
"""


def test_a_curved_valley_is_reported_undetermined_from_the_starts(tmp_path) -> None:
    """A pendulum on a torsion spring ``kt`` under a constant torque ``T0``, linearized at its
    equilibrium ``kt φ₀ + m g l sin φ₀ = T0``: the response depends on
    ``kt + m g l cos φ₀`` alone, a curved combination of ``kt`` and ``T0``. At the optimum the
    flat direction is almost ``T0`` alone, so the Jacobian keeps ``kt``; starts that end with
    the same cost at other ``kt`` must make it undetermined, not a number with a tiny
    standard error (the truth, kt = 3, lies on the valley, not at its end points)."""
    (tmp_path / "p.yaml").write_text(PRELOADED)
    mod = load_generated(generate(tmp_path / "p.yaml", tmp_path / "g", sensitivities=True))
    f = np.geomspace(0.1, 3.0, 60)
    eq = equilibrium(mod)
    H = frequency_response(linearize(mod, eq, u0=eq.u), f, "T", "phi").H[:, 0, 0]
    rng = np.random.default_rng(2)
    H = H * np.exp(0.01 * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)))
    data = FrequencyData(f, H, np.ones(f.size), "phi", "T")
    fit = identify(mod, data, ["kt=0.01:100:1", "T0=0.1:50:20", "ct=0.01:5"], "frf",
                   starts=5)
    assert fit.parameters["kt"] is None and fit.standard_errors["kt"] is None
    assert fit.parameters["T0"] is None
    assert fit.parameters["ct"] == pytest.approx(0.2, rel=0.05)
    assert fit.correlation["ct"]["kt"] is None
    ends = [s["end"]["kt"] for s in fit.starts if "end" in s
            and abs(s["cost"] - fit.cost) <= 1e-6 * fit.cost]
    assert max(ends) > 1.5 * min(ends)


def test_pendulum_length_from_a_noisy_swing(tmp_path) -> None:
    """The pendulum swinging from 0.3 rad, measured φ with 1 mrad noise: l comes back within
    four standard errors; g, whose effect equals that of 1/l, is held."""
    mod = load_generated(ROOT / "generated" / "pendulum.py")
    res = simulate(mod, 3.0, n_out=121, method="DOP853", rtol=1e-11, atol=1e-13)
    rng = np.random.default_rng(9)
    path = tmp_path / "swing.csv"
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["t", "phi"])
        for t, phi in zip(res.t, res.y[:, 0] + 1e-3 * rng.standard_normal(res.t.size),
                          strict=True):
            w.writerow([repr(float(t)), repr(float(phi))])
    fit = identify(mod, path, ["l=0.1:2:0.35"], "simulate", t_end=3.0)
    assert fit.converged
    assert abs(fit.parameters["l"] - 0.5) < 4 * fit.standard_errors["l"]
    assert fit.standard_errors["l"] < 1e-3


def test_starts_on_dask_find_the_same_optimum(oscillators) -> None:
    """Three starts on a local Dask cluster (threads, free ports, no dashboard) end where the
    sequential fit ends."""
    from dask import distributed

    mod = oscillators[1]
    data = _noisy_frf(mod, 0.01)
    bounds = ["m=0.1:20:0.5", "k1=10:1e5:100", "c=0.01:100:1"]
    seq = identify(mod, data, bounds, "frf", starts=3)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None, scheduler_port=0) as cluster, \
            distributed.Client(cluster) as client:
        par = identify(mod, data, bounds, "frf", starts=3, client=client)
    assert len(par.starts) == 3
    for name in ("m", "k1", "c"):
        assert par.parameters[name] == pytest.approx(seq.parameters[name], rel=1e-8)


@pytest.mark.parametrize(("bound", "message"), [
    ("q=1:2", "unknown parameter 'q'"),
    ("k1=5:1", "LO (5) must be below HI (1)"),
    ("k1=1:5:7", "START 7 is outside"),
    ("k1=1:5:x", "must be numbers"),
])
def test_bad_bounds_are_one_error(oscillators, bound, message) -> None:
    mod = oscillators[1]
    with pytest.raises(NeweulError, match=message.replace("(", r"\(").replace(")", r"\)")):
        identify(mod, _noisy_frf(mod, 0.0), [bound], "frf")


def test_bounds_beyond_a_declared_range_are_one_error(tmp_path) -> None:
    """A parameter declared ``{value: 2, min: 0.5}``: bounds below 0.5 are refused naming the
    range (reference: the range written in the description)."""
    (tmp_path / "r.yaml").write_text(OSCILLATOR.format(stiffness="k1").replace(
        "m: 2.0", "m: {value: 2.0, min: 0.5}"))
    mod = load_generated(generate(tmp_path / "r.yaml", tmp_path))
    with pytest.raises(NeweulError, match=r"--param m: the bounds 0\.1 … 5 leave its range ≥ 0\.5"):
        identify(mod, _noisy_frf(mod, 0.0), ["m=0.1:5"], "frf")


def test_a_fit_that_stops_early_says_so(oscillators) -> None:
    """Two model evaluations cannot reach the optimum: ``converged`` is False."""
    mod = oscillators[1]
    fit = identify(mod, _noisy_frf(mod, 0.0), ["k1=10:1e5:100"], "frf", max_nfev=2)
    assert not fit.converged and fit.to_dict()["converged"] is False


def _write(path: Path, rows: list[list[str]]) -> Path:
    path.write_text("\n".join(",".join(r) for r in rows) + "\n")
    return path


@pytest.mark.parametrize(("rows", "message"), [
    ([["frequency_hz", "magnitude"], ["1", "2"]], "no column 'phase_deg'"),
    ([["frequency_hz", "magnitude", "phase_deg"], ["1", "nan", "0"]],
     "column 'magnitude': 'nan' is not a finite number"),
    ([["frequency_hz", "magnitude", "phase_deg"], ["1", "", "0"]], "column 'magnitude': missing"),
    ([["frequency_hz", "magnitude", "phase_deg"], ["2", "1", "0"], ["1", "1", "0"]],
     "must increase"),
    ([["t", "x"], ["0", "1"]], "it looks like a simulation"),
    ([["frequency_hz", "magnitude", "phase_deg", "weight"], ["1", "1", "0", "-1"]],
     r"d\.csv:2: column 'weight' must hold numbers"),
    ([["frequency_hz", "magnitude", "phase_deg"], ["1", "1", "0"], ["2", "1", "-1", "5"]],
     r"d\.csv:3: 4 fields where the header has 3"),
    ([["frequency_hz", "magnitude", "phase_deg"], ["-1", "1", "0"]],
     r"d\.csv:2: column 'frequency_hz' must be ≥ 0"),
])
def test_bad_frequency_data_is_one_error_naming_the_place(tmp_path, rows, message) -> None:
    with pytest.raises(DataError, match=message):
        read_frequency_data(_write(tmp_path / "d.csv", rows), "x", "F")


def test_frequency_data_as_neweul_frf_writes_it(tmp_path) -> None:
    """What ``neweul frf -o`` writes is read: the static row at 0 Hz, and a byte-order mark
    some editors add; blank lines do not shift the line an error names."""
    path = tmp_path / "d.csv"
    path.write_bytes("\ufefffrequency_hz,magnitude,phase_deg\n0,2,0\n1,1,-10\n".encode())
    data = read_frequency_data(path, "x", "F")
    assert data.frequency_hz.tolist() == [0.0, 1.0] and data.H[0] == 2.0
    path.write_text("frequency_hz,magnitude,phase_deg\n\n1,1,0\n\n2,x,0\n")
    with pytest.raises(DataError, match=r"d\.csv:5: column 'magnitude'"):
        read_frequency_data(path, "x", "F")


def test_bad_time_data_is_one_error_naming_the_place(tmp_path) -> None:
    with pytest.raises(DataError, match="it looks like a frequency response"):
        read_time_data(_write(tmp_path / "d.csv", [["frequency_hz", "x"], ["1", "2"]]))
    with pytest.raises(DataError, match=r"d\.csv:3: column 't' must increase"):
        read_time_data(_write(tmp_path / "d.csv", [["t", "x"], ["1", "2"], ["1", "3"]]))
    with pytest.raises(DataError, match="no column 'y'"):
        read_time_data(_write(tmp_path / "d.csv", [["t", "x"], ["0", "2"]]), ["y"])
