"""Clinical measures of the middle-ear model (neweul_py.middle_ear.clinical).

References: plane-wave closed forms of the canal (its characteristic impedance, the
transmission line to the TM), passivity (``Re Z ≥ 0``), the definitions of
docs/middle-ear-clinical.md, and the file rules of the build records.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from neweul_py.analysis.acoustic import cavity_admittance
from neweul_py.errors import DataError, NeweulError
from neweul_py.middle_ear.clinical import (
    MAX_PROBE_HZ,
    canal_impedance,
    check_frequencies,
)
from neweul_py.middle_ear.parameters import MiddleEarParameters


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
    from neweul_py.middle_ear.clinical import eardrum_volume, immittance

    out, mod, params = embs
    f = np.geomspace(100.0, 8000.0, 60)
    drum = eardrum_volume(out, mod)
    for dp in (-4000.0, 0.0, 2000.0):
        im = immittance(mod, params, dp, f, eardrum=drum)
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
