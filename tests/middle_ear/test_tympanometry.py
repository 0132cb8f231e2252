"""The standard measures of a tympanogram (neweul_py.middle_ear.tympanometry).

References: closed forms of synthetic tympanograms (a triangle and a Lorentzian peak on a
rigid cavity's admittance ``jωV/(ρc²)``, whose compensated width and peak are known exactly),
and the definitions of ANSI S3.39-1987 / ASHA 1990 (docs/middle-ear-clinical.md §3).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from neweul_py.analysis.acoustic import MMHO, cavity_admittance
from neweul_py.errors import NeweulError
from neweul_py.middle_ear.tympanometry import VEA_MAX_HZ, tympanometric_measures

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
