"""The standard measures of a tympanogram (ANSI S3.39-1987; ASHA 1990;
docs/middle-ear-clinical.md §3): from the admittance at the probe against the ear-canal
static pressure ``P`` [daPa], swept from +200 to −400 daPa as a tympanometer does:

* ``Vea`` — equivalent ear-canal volume: ``|Y(+200 daPa)|`` as the volume of a rigid
  cavity of that admittance, ``|Y| ρc²/ω`` (1 mmho ≈ 1 cm³ at 226 Hz); a low-frequency
  measure, printed only for probe tones up to :data:`VEA_MAX_HZ`;
* ``Ytm`` — peak compensated static acoustic admittance: the peak of
  ``Y_c(P) = |Y(P)| − |Y(+200 daPa)|`` (``vector=True``: ``|Y(P) − Y(+200 daPa)|``), the
  vertex of the parabola through the largest sample and its neighbours (never below the
  largest sample: the peak between the sampled pressures);
* ``TPP`` — tympanometric peak pressure, where that parabola peaks;
* ``TW`` — tympanometric width, the pressure interval over which ``Y_c ≥ Ytm/2``.

A curve whose compensated admittance never rises above zero (a flat tympanogram, or a sweep
that ends at +200 daPa's side) has no peak: ``TPP`` and ``TW`` are ``nan``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..analysis.acoustic import MMHO, equivalent_volume
from ..errors import NeweulError

__all__ = ["COMPENSATION_DAPA", "VEA_MAX_HZ", "TympanometricMeasures", "tympanometric_measures"]

#: Ear-canal pressure of the compensation and of ``Vea`` [daPa] (ANSI S3.39; ASHA 1990).
COMPENSATION_DAPA = 200.0
#: ``Vea`` is printed for probe tones up to this [Hz] (``|Y| ρc²/ω`` is a volume only where
#: the canal is small against the wavelength and the TM is stiff: the 226 Hz measure).
VEA_MAX_HZ = 300.0


@dataclass(frozen=True)
class TympanometricMeasures:
    """The standard measures of one tympanogram (module docstring).

    Attributes
    ----------
    frequency_hz : float
    peak_admittance_mmho : float
        ``Ytm``, peak compensated static acoustic admittance.
    peak_pressure_daPa : float
        ``TPP``; ``nan`` without a peak.
    width_daPa : float
        ``TW``; ``nan`` without a peak, or when the compensated curve does not fall to half
        its peak on both sides within the sweep.
    half_points_daPa : tuple of float
        The pressures (negative side, positive side) where ``Y_c = Ytm/2`` (``nan`` where
        not reached).
    ear_canal_volume_cm3 : float
        ``Vea``, ``|Y(+200 daPa)|`` as a volume.
    reference_mmho : float
        ``|Y(+200 daPa)|``.
    compensation : str
        ``"magnitude"`` or ``"vector"``.
    """

    frequency_hz: float
    peak_admittance_mmho: float
    peak_pressure_daPa: float
    width_daPa: float
    half_points_daPa: tuple[float, float]
    ear_canal_volume_cm3: float
    reference_mmho: float
    compensation: str = "magnitude"

    def summary(self) -> str:
        """One line: ``Ytm``, ``TPP``, ``TW``, and ``Vea`` at low probe frequencies."""
        vea = (f", Vea {self.ear_canal_volume_cm3:.2f} cm³"
               if self.frequency_hz <= VEA_MAX_HZ else "")
        if math.isnan(self.peak_pressure_daPa):
            return (f"{self.frequency_hz:g} Hz: no peak (the compensated admittance does not "
                    f"rise above its value at {COMPENSATION_DAPA:+g} daPa){vea}")
        tw = ("not reached on both sides" if math.isnan(self.width_daPa)
              else f"{self.width_daPa:.0f} daPa")
        return (f"{self.frequency_hz:g} Hz: Ytm {self.peak_admittance_mmho:.3f} mmho, "
                f"TPP {self.peak_pressure_daPa + 0.0:+.0f} daPa, TW {tw}{vea}")


def _crossing(p: np.ndarray, y: np.ndarray, level: float) -> float:
    """The first pressure along ``p`` (from the peak outwards) where ``y`` falls to
    ``level`` (linear interpolation), ``nan`` if it does not."""
    below = np.flatnonzero(y <= level)
    if below.size == 0:
        return float("nan")
    k = int(below[0])
    if k == 0:
        return float(p[0])
    y0, y1 = y[k - 1], y[k]
    return float(p[k - 1] + (level - y0) * (p[k] - p[k - 1]) / (y1 - y0))


def tympanometric_measures(pressure_dapa: Sequence[float] | np.ndarray,
                           admittance: Sequence[complex] | np.ndarray, frequency_hz: float,
                           rho: float = 1.2, c: float = 343.0,
                           compensation_dapa: float = COMPENSATION_DAPA,
                           vector: bool = False) -> TympanometricMeasures:
    """``Ytm``, ``TPP``, ``TW`` and ``Vea`` of a tympanogram (module docstring).

    Parameters
    ----------
    pressure_dapa
        Ear-canal static pressures [daPa], in any order, distinct.
    admittance
        The admittance at the probe [m³/(Pa s)] (complex, or its magnitude) at each pressure.
    frequency_hz
        The probe frequency (for ``Vea``).
    rho, c
        Air (for ``Vea``).
    compensation_dapa
        The pressure whose admittance is taken as the canal's (+200 daPa); it must be one
        of ``pressure_dapa``.
    vector
        Compensate the complex admittance (``|Y − Y_ref|``) instead of its magnitude.

    Raises
    ------
    NeweulError
        Fewer than three pressures, repeated or non-finite values, no sample at
        ``compensation_dapa``, or ``vector`` with magnitudes only.
    """
    p = np.asarray(pressure_dapa, dtype=float).reshape(-1)
    y = np.asarray(admittance).reshape(-1)
    if p.size < 3 or y.shape != p.shape:
        raise NeweulError(f"tympanogram: at least three pressures with one admittance each, "
                          f"got {p.size} pressures and {y.size} admittances")
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(y))):
        raise NeweulError("tympanogram: pressures and admittances must be finite")
    order = np.argsort(p)
    p, y = p[order], y[order]
    if np.any(np.diff(p) == 0):
        raise NeweulError("tympanogram: repeated pressures")
    ref = np.flatnonzero(np.isclose(p, compensation_dapa, rtol=0, atol=1e-9))
    if ref.size == 0:
        raise NeweulError(f"tympanogram: no admittance at the compensation pressure "
                          f"{compensation_dapa:+g} daPa (swept {p[0]:+g} … {p[-1]:+g})")
    if vector and not np.iscomplexobj(y):
        raise NeweulError("tympanogram: vector compensation needs the complex admittance")
    y_ref = y[ref[0]]
    yc = np.abs(y - y_ref) if vector else np.abs(y) - np.abs(y_ref)
    k = int(np.argmax(yc))
    peak, tpp = float(yc[k]), float(p[k])
    if 0 < k < p.size - 1:                     # parabola through the peak and its neighbours
        x, v = p[k - 1 : k + 2], yc[k - 1 : k + 2]
        a, b, c2 = np.polyfit(x, v, 2)
        if a < 0:
            tpp = float(np.clip(-b / (2 * a), x[0], x[2]))
            peak = float(max(peak, c2 - b * b / (4 * a)))
    lo = _crossing(p[k::-1], yc[k::-1], peak / 2)
    hi = _crossing(p[k:], yc[k:], peak / 2)
    if not peak > 0:                             # no peak: nothing rises above the reference
        peak, tpp, lo, hi = 0.0, float("nan"), float("nan"), float("nan")
    vea = float(equivalent_volume(np.abs(y_ref), frequency_hz, rho, c)[0]) * 1e6
    return TympanometricMeasures(
        frequency_hz=float(frequency_hz), peak_admittance_mmho=peak / MMHO,
        peak_pressure_daPa=tpp, width_daPa=hi - lo, half_points_daPa=(lo, hi),
        ear_canal_volume_cm3=vea, reference_mmho=float(np.abs(y_ref)) / MMHO,
        compensation="vector" if vector else "magnitude")
