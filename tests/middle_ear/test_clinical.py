"""Clinical measures of the middle-ear model (neweul_py.middle_ear.clinical).

References: closed forms of synthetic tympanograms (a triangle and a Lorentzian peak on a
rigid cavity's admittance ``jωV/(ρc²)``, whose compensated width and peak are known exactly),
and the definitions of ANSI S3.39-1987 / ASHA 1990 (docs/middle-ear-clinical.md).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from neweul_py.analysis.acoustic import MMHO, cavity_admittance
from neweul_py.errors import DataError, NeweulError
from neweul_py.middle_ear.clinical import (
    MAX_PROBE_HZ,
    VEA_MAX_HZ,
    canal_impedance,
    check_frequencies,
    tympanometric_measures,
)
from neweul_py.middle_ear.parameters import MiddleEarParameters

RHO, C, F = 1.2, 343.0, 226.0
#: A 1.2 cm³ ear canal: its admittance at 226 Hz [m³/(Pa s)].
CANAL = cavity_admittance(1.2e-6, F, RHO, C)[0]


def test_triangle_tympanogram_has_its_width_peak_and_canal_volume():
    """A triangular TM admittance (peak 0.7 mmho at −30 daPa, zero beyond ±60 daPa of it)
    on a 1.2 cm³ canal: Ytm = 0.7 mmho, TPP = −30 daPa, TW = 60 daPa (half of the base),
    Vea = 1.2 cm³; the TM's admittance in phase with the canal's, so magnitude and vector
    compensation agree."""
    p = np.arange(200.0, -401.0, -5.0)
    tm = 0.7 * MMHO * np.clip(1 - np.abs(p + 30.0) / 60.0, 0, None)
    y = CANAL + 1j * tm
    for vector in (False, True):
        m = tympanometric_measures(p, y, F, RHO, C, vector=vector)
        assert m.peak_admittance_mmho == pytest.approx(0.7, rel=1e-9)
        assert m.peak_pressure_daPa == pytest.approx(-30.0, abs=1e-9)
        assert m.width_daPa == pytest.approx(60.0, rel=1e-9)
        assert m.half_points_daPa == pytest.approx((-60.0, 0.0), abs=1e-9)
        assert m.ear_canal_volume_cm3 == pytest.approx(1.2, rel=1e-12)


def test_lorentzian_tympanogram_compensated_at_plus_200():
    """``Y_TM = A/(1 + ((P − P0)/w)²)`` on the canal: compensated at +200 daPa the peak is
    ``A (1 − r)`` with ``r = Y_TM(200)/A`` and the width ``2 w √((1 − r)/(1 + r))``
    (closed form of the half-level crossing); sampled every daPa, to 0.1 %."""
    a, p0, w = 0.8 * MMHO, -20.0, 45.0
    p = np.arange(200.0, -401.0, -1.0)
    tm = a / (1 + ((p - p0) / w) ** 2)
    r = 1 / (1 + ((200 - p0) / w) ** 2)
    m = tympanometric_measures(p, CANAL + 1j * tm, F, RHO, C)
    assert m.peak_admittance_mmho == pytest.approx(0.8 * (1 - r), rel=1e-6)
    assert m.peak_pressure_daPa == pytest.approx(p0, abs=0.05)
    assert m.width_daPa == pytest.approx(2 * w * math.sqrt((1 - r) / (1 + r)), rel=1e-3)
    # the same curve given as magnitudes, in increasing pressure order
    m2 = tympanometric_measures(p[::-1], np.abs(CANAL + 1j * tm)[::-1], F, RHO, C)
    assert m2.width_daPa == pytest.approx(m.width_daPa, rel=1e-12)


def test_width_not_reached_is_nan_not_a_number():
    """A TM admittance that is still above half its compensated peak at −400 daPa: TW is
    not defined (``nan``), the positive half point is."""
    p = np.arange(200.0, -401.0, -10.0)
    tm = 0.5 * MMHO * np.clip(1 - p / 200.0, 0, 1)          # flat below 0 daPa
    m = tympanometric_measures(p, CANAL + 1j * tm, F, RHO, C)
    assert math.isnan(m.width_daPa) and math.isnan(m.half_points_daPa[0])
    assert m.half_points_daPa[1] == pytest.approx(100.0)
    assert "not reached" in m.summary()


def test_a_curve_without_a_peak_has_no_tpp_nor_width():
    """A sweep on the positive side only of a TM that stiffens away from 0 daPa: the
    compensated admittance never rises above its value at +200 daPa, so there is no peak
    (``TPP``, ``TW`` ``nan``), not "Ytm 0, TW 0"."""
    p = np.linspace(400.0, 200.0, 21)
    tm = 0.5 * MMHO * np.clip(1 - p / 400.0, 0, 1)           # largest at +200
    m = tympanometric_measures(p, CANAL + 1j * tm, F, RHO, C)
    assert math.isnan(m.peak_pressure_daPa) and math.isnan(m.width_daPa)
    assert m.peak_admittance_mmho == 0.0 and "no peak" in m.summary()


def test_vea_is_printed_at_low_probe_tones_only():
    """``|Y| ρc²/ω`` is the rigid canal's volume at 226 Hz; at 1000 Hz it is not reported."""
    p = np.arange(200.0, -401.0, -10.0)
    tm = 0.5 * MMHO * np.clip(1 - np.abs(p + 30.0) / 60.0, 0, 1)
    low = tympanometric_measures(p, CANAL + 1j * tm, F, RHO, C)
    high = tympanometric_measures(p, CANAL + 1j * tm, 1000.0, RHO, C)
    assert "Vea 1.20 cm³" in low.summary() and "Vea" not in high.summary()
    assert F <= VEA_MAX_HZ < 678.0


@pytest.mark.parametrize(("f", "match"), [
    ([0.0], "0 Hz is not a probe frequency"),
    ([226.0, 2 * MAX_PROBE_HZ], "is not a probe frequency"),
    ([float("nan")], "nan Hz"),
    ([226.0, 226.00000000001], "repeated probe frequencies"),
    ([], "no frequency"),
])
def test_probe_frequencies_are_checked(f, match):
    """In (0, 20 kHz], finite, and distinct to the digits their CSV columns carry."""
    with pytest.raises(NeweulError, match=match):
        check_frequencies(f)
    with pytest.raises(NeweulError, match="at most 2"):
        check_frequencies([226.0, 678.0, 1000.0], most=2)


@pytest.mark.parametrize(("name", "text", "match"), [
    ("build.json", "{garbage", "not a build record"),
    ("build.json", "[]", "a JSON object was expected"),
    ("build.json", '{"module": "m.py"}', "samples_Pa"),
    ("build.json", '{"samples_Pa": []}', "samples_Pa"),
    ("build.json", '{"samples_Pa": ["a"]}', "samples_Pa"),
    ("build.json", '{"samples_Pa": [true, 1]}', "samples_Pa"),
])
def test_a_corrupt_build_record_is_one_error_naming_the_file(tmp_path, name, text, match):
    """``build.json`` of a build that is not one: one DataError naming the file (and the
    key), no traceback."""
    from neweul_py.middle_ear.clinical import build_model

    (tmp_path / name).write_text(text)
    with pytest.raises(DataError, match=match) as info:
        build_model(tmp_path, 0.0)
    assert "build.json" in str(info.value)


def test_a_corrupt_sweep_record_is_one_error_naming_the_key(tmp_path):
    """The FE sweep's ``parameters``: an unknown name or a value the model refuses names
    ``fem/sweep.json`` and the key."""
    from neweul_py.middle_ear.study import build_parameters

    (tmp_path / "fem").mkdir()
    record = tmp_path / "fem" / "sweep.json"
    record.write_text('{"parameters": {"tm_E": "soft"}}')
    with pytest.raises(DataError, match=r"sweep\.json.*parameters\.tm_E"):
        build_parameters(tmp_path)
    record.write_text('{"parameters": {"no_such": 1}}')
    with pytest.raises(DataError, match="unknown middle-ear parameter"):
        build_parameters(tmp_path)
    record.write_text("\x00\x01")
    with pytest.raises(DataError, match="not a build record"):
        build_parameters(tmp_path)


def test_canal_characteristic_impedance():
    """``Z₀ = ρc/A`` with the 7.5 mm entrance: 44.18 mm², 9.32 MPa s/m³."""
    z0 = canal_impedance(MiddleEarParameters())
    assert z0 == pytest.approx(1.2 * 343.0 / (math.pi * 7.5e-3**2 / 4), rel=1e-12)
    assert z0 == pytest.approx(9.32e6, rel=1e-3)


@pytest.mark.parametrize(("p", "y", "kw", "match"), [
    ([0.0, -100.0], [1.0, 2.0], {}, "at least three"),
    ([200.0, 0.0, 0.0], [1.0, 2.0, 3.0], {}, "repeated"),
    ([100.0, 0.0, -100.0], [1.0, 2.0, 3.0], {}, "compensation pressure"),
    ([200.0, 0.0, -100.0], [1.0, np.nan, 3.0], {}, "finite"),
    ([200.0, 0.0, -100.0], [1.0, 2.0, 3.0], {"vector": True}, "complex"),
])
def test_bad_tympanograms_are_one_clear_error(p, y, kw, match):
    """Too few points, repeated or non-finite values, no +200 daPa sample, a vector
    compensation of magnitudes."""
    with pytest.raises(NeweulError, match=match):
        tympanometric_measures(p, y, F, **kw)


@pytest.fixture(scope="module")
def embs(tmp_path_factory):
    """A refine-0 build over the tympanogram's range (−4000 … +2000 Pa), with its module."""
    from neweul_py.middle_ear.build import BuildOptions, build
    from neweul_py.middle_ear.clinical import build_model

    out = tmp_path_factory.mktemp("me_clinical") / "build"
    build(out, BuildOptions(refine=0, pressures=(-4000.0, -2000.0, 0.0, 2000.0), tol=0.0))
    return (out, *build_model(out, 0.0))


@pytest.mark.slow
def test_the_probe_sees_the_tm_through_the_canal(embs):
    """At 226 Hz the probe tip sees the TM through the canal, a duct of length ``L`` and
    the mean cross-section ``A = V/L`` of its mesh: the transmission line
    ``Y = (Y_TM + j tan(kL)/Z₀)/(1 + j Z₀ Y_TM tan(kL))``, ``Z₀ = ρc/A`` (closed form of
    plane waves; to 0.6 %: the canal widens towards the TM, 7.5 → 8.7 mm). The compact
    limit ``jωV/(ρc²) + Y_TM`` is 1 % off, (kL)²/3 and the TM seen through the air mass."""
    from neweul_py.middle_ear.clinical import eardrum_volume, immittance
    from neweul_py.middle_ear.model import build_middle_ear

    out, mod, params = embs
    drum = eardrum_volume(out, mod)
    v, length = build_middle_ear(params, refine=0).info["canal_volume_m3"], params.canal_length
    z0 = params.rho_air * params.c_air * length / v
    t = np.tan(2 * np.pi * 226.0 / params.c_air * length)
    for dp in (0.0, 2000.0):
        im = immittance(mod, params, dp, [226.0], eardrum=drum)
        y_tm = im.y_tm[0]
        line = (y_tm + 1j * t / z0) / (1 + 1j * z0 * y_tm * t)
        np.testing.assert_allclose(im.y_probe[0], line, rtol=6e-3)
        compact = cavity_admittance(v, 226.0, params.rho_air, params.c_air)[0] + y_tm
        assert abs(im.y_probe[0] / compact - 1) < 2e-2


@pytest.mark.slow
def test_the_probe_impedance_is_passive(embs):
    """A passive ear: ``Re Z ≥ 0`` at the probe tip, so ``|R| ≤ 1`` and the absorbance in
    [0, 1], at 100 Hz–8 kHz and Δp = −4, 0, +2 kPa."""
    from neweul_py.middle_ear.clinical import immittance

    _out, mod, params = embs
    f = np.geomspace(100.0, 8000.0, 60)
    for dp in (-4000.0, 0.0, 2000.0):
        im = immittance(mod, params, dp, f)
        assert np.all(im.z_probe.real >= 0), dp
        assert np.all((im.absorbance >= 0) & (im.absorbance <= 1)), dp


@pytest.mark.slow
def test_tympanogram_command_writes_measures_csv_and_plot(embs, tmp_path, capsys):
    """``neweul middle-ear tympanogram``: one line of measures per frequency, the CSV with
    the swept pressures in sweep order (+200 → −400 daPa) and the plot; the compensated
    curve is zero at +200 daPa by definition."""
    from neweul_py.cli import main

    out, _mod, _params = embs
    csv, png = tmp_path / "t.csv", tmp_path / "t.png"
    assert main(["middle-ear", "tympanogram", "--dir", str(out), "--f", "226,1000",
                 "--pressures", "200:-400:61", "-o", str(csv), "--plot", str(png),
                 "-q"]) == 0
    text = capsys.readouterr().out
    assert "226 Hz: Ytm" in text and "1000 Hz: Ytm" in text
    d = np.genfromtxt(csv, delimiter=",", names=True)
    assert d["ear_canal_pressure_daPa"][0] == 200.0 and d["ear_canal_pressure_daPa"][-1] == -400
    np.testing.assert_allclose(d["dp_Pa"], 10 * d["ear_canal_pressure_daPa"])
    assert png.stat().st_size > 0
    assert main(["middle-ear", "absorbance", "--dir", str(out), "--dp", "0", "--f",
                 "200:8000:20", "-o", str(tmp_path / "a.csv")]) == 0
    a = np.genfromtxt(tmp_path / "a.csv", delimiter=",", names=True, skip_header=1)
    assert a["frequency_hz"].size == 20 and np.all(a["absorbance"] <= 1)
