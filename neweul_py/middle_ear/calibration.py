"""The middle ear's calibration set and the forward model of its identification.

docs/middle-ear-clinical.md §5. For a parameter set (:class:`MiddleEarParameters`) the FE
static states and working-point models over the pressures needed
(:func:`~neweul_py.middle_ear.sweep.pressure_sweep`), each coupled directly with the build's
3-D chain (:func:`~neweul_py.middle_ear.validation.linear_chain`, the build's description with
the TM body replaced by free node translations), its stiffening factor ``φ`` set so that the
chain's static stiffness at the umbo is the tangent of its static characteristic at that
working point (docs/equations-middle-ear.md §7), solved in the loss-factor form ``K + iG``
(:func:`~neweul_py.middle_ear.coupled.coupled_frf`). From it (:func:`calibration_measures`):

* the 226 Hz tympanogram at the probe tip, +200 → −400 daPa every 20 daPa, and its ``Ytm``,
  ``TW``, ``TPP``, ``Vea`` (:func:`~neweul_py.middle_ear.tympanometry.tympanometric_measures`);
* the middle-ear resonance: the lowest frequency at which the compensated susceptance
  ``B(0) − B(+200 daPa)`` at the probe tip changes sign from + to − (Shanks 1984);
* the low-frequency change (mean over 100–1000 Hz, dB re Δp = 0) of the umbo (the TM node at
  the umbo), malleus and stapes velocity per probe pressure at ±1, ±2, ±3 kPa;
* the stapes velocity per probe pressure at Δp = 0: its peak, where, and the stapes volume
  displacement below 1 kHz.

The residuals (:func:`calibration_residuals`) are ``(model − mean)/SD`` of
:data:`CALIBRATION`, and the one-sided residuals of :data:`MURAKAMI_DB` (either sign of
``Δp`` loses, ``Δp > 0`` more); :func:`held_out` compares the model with the measurements
that are not fitted (:data:`HELD_OUT`). A fit on a coarse mesh may add the mesh's
discretization error measured at one parameter set (:func:`mesh_offsets`: the finer mesh's
values minus the coarse mesh's, an additive output correction) to the values it compares.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..analysis.acoustic import MMHO
from ..elastic.quality.frf_sweep import frequency_form
from ..errors import SolverError
from .coupled import coupled_frf
from .embs import PHI, calibration_module, node_positions, umbo_stiffness
from .parameters import MiddleEarParameters
from .sweep import pressure_sweep
from .tympanometry import tympanometric_measures
from .validation import linear_chain

__all__ = [
    "CALIBRATION",
    "FIT_BOUNDS",
    "HELD_OUT",
    "MURAKAMI_DB",
    "PENALTY",
    "CalibrationChain",
    "Datum",
    "calibrated_values",
    "calibration_measures",
    "calibration_residuals",
    "evaluate",
    "held_out",
    "log_parabolic_peak",
    "mesh_offsets",
    "residual_labels",
]


@dataclass(frozen=True)
class Datum:
    """A measured mean and standard deviation, with the source."""

    mean: float
    sd: float
    unit: str
    source: str


#: The calibration set (docs/middle-ear-measurements.md §2, §7). ``ytm`` in ln(mmho): Margolis
#: & Heller's 90 % range taken as log-normal (the range is ±1.645 SD).
CALIBRATION: dict[str, Datum] = {
    "tw": Datum(82.5, 19.1, "daPa", "Margolis & Heller 1987: TW 51-114 daPa (90 % range)"),
    "ytm": Datum(float(np.log(np.sqrt(0.37 * 1.66))), float(np.log(1.66 / 0.37) / (2 * 1.645)),
                 "ln mmho", "Margolis & Heller 1987: Ytm 0.37-1.66 mmho (90 % range)"),
    "umbo+1kPa": Datum(-5.0, 1.0, "dB", "Gyo & Goode 1987: umbo at -100 mmH2O"),
    "umbo+2kPa": Datum(-9.2, 1.3, "dB", "Gyo & Goode 1987: umbo at -200 mmH2O"),
    "umbo+3kPa": Datum(-13.1, 1.8, "dB", "Gyo & Goode 1987: umbo at -300 mmH2O"),
    "f_res": Datum(1049.0, 261.0, "Hz", "Valvik et al. 1994: middle-ear resonance, 100 ears"),
    "stapes_peak": Datum(float(np.log(np.sqrt(600.0 * 1500.0))),
                         float(np.log(1500.0 / 600.0) / (2 * 1.645)), "ln Hz",
                         "ASTM F2504 criterion (Rosowski et al. 2007): stapes velocity peak "
                         "0.6-1.5 kHz, taken as a 90 % range"),
}
#: Murakami et al. 1997 (either sign of Δp loses at low frequencies, Δp > 0 more): one-sided
#: residuals in units of this [dB] — the umbo's gain at −k kPa, and the excess of its change at
#: +k kPa over that at −k kPa (both zero when the model does as measured).
MURAKAMI_DB = 1.0
#: The residual of every entry where the model cannot be evaluated (a static state beyond the
#: model's validity): far outside the data, so that the optimizer steps back.
PENALTY = 10.0
#: The held-out measurements (not fitted), docs/middle-ear-measurements.md §1, §2.
HELD_OUT: dict[str, Datum] = {
    "stapes_less_than_umbo": Datum(0.0, float("nan"), "dB", "Murakami et al. 1997: the stapes "
                                   "changes less than the umbo at low frequencies (> 0 dB)"),
    "stapes_volume_low": Datum(6.8e-5, float("nan"), "mm3/Pa", "Kringlebotn & Gundersen 1985: "
                               "stapes volume displacement below 1 kHz, 68 temporal bones"),
    "stapes_peak": Datum(0.2, float("nan"), "mm/s/Pa", "Aibara et al. 2001, Goode 1994, "
                         "Rosowski et al. 2007: peak stapes velocity 0.1-0.3 mm/s/Pa"),
}
#: The fitted parameters: name → (low, high, why), bounds from the literature range of each
#: (docs/middle-ear-measurements.md §4–§6).
FIT_BOUNDS: dict[str, tuple[float, float, str]] = {
    "tm_E_static": (2.0e6, 15.1e6, "TM modulus of the static state: 2.1-4.4 MPa in situ at "
                    "0.2 Hz (Aernouts et al. 2012) to 15.1 MPa on strips at 1 Hz (Zhang & Gan "
                    "2013)"),
    "chain_limit_medial": (40e-6, 2e-3, "s+ of the chain characteristic (not measured)"),
    "chain_limit_lateral": (40e-6, 2e-3, "s- of the chain characteristic (not measured)"),
    "k_chain": (800.0, 3000.0, "chain stiffness at the umbo: 1683 N/m from LVATB1's ligaments "
                "and joints; about a factor 2 either way (estimate)"),
    "tm_thickness": (40e-6, 120e-6, "TM thickness: 40, 50 and 120 um in three ears (Kuypers "
                     "et al. 2006)"),
    "mastoid_volume": (1.0e-6, 8.0e-6, "antrum + mastoid air: middle-ear air 2-6 cm3 (Molvaer "
                       "et al. 1978), mastoid 0.7-21 cm3 (Swarts et al. 2011)"),
    "pf_compliance": (1e-14, 2e-11, "pars flaccida compliance at 0 Pa: a membrane of 2-8 mm2 "
                      "and tension 0.1-10 N/m, pi a^4/(8 T) (not measured in human ears)"),
    "pf_stiffening_pressure": (20.0, 2000.0, "pressure at which the pars flaccida's compliance "
                               "has fallen to a quarter (estimate: it moves with pressures of "
                               "a few daPa, Hellstrom & Stenfors 1983, in rat)"),
    "pf_surface_density": (0.03, 0.3, "mass per area of the pars flaccida: 25-250 um of tissue "
                           "(estimate)"),
    "tm_E": (20e6, 30e6, "TM storage modulus: 22.5 MPa at 226 Hz to 27.6 MPa at 3.8 kHz "
             "(Zhang & Gan 2013, power law)"),
}
#: The stapes footplate area [m²] (Hudde & Engel 1998): volume displacement from velocity.
FOOTPLATE_AREA = 3.2e-6

TYMPANOGRAM_DAPA = np.arange(200.0, -401.0, -20.0)
STATIC_PA = (-3000.0, -2000.0, -1000.0, 1000.0, 2000.0, 3000.0)
F_LOW = np.geomspace(100.0, 1000.0, 8)
F_RES = np.geomspace(300.0, 3000.0, 36)
F_STAPES = np.geomspace(200.0, 4000.0, 48)
FE_OUTPUTS = ("probe_pressure", "entrance_pressure", "umbo_uz", "tm_volume_displacement")


class CalibrationChain:
    """The build's 3-D chain with ``φ`` as a parameter; ``φ(k_t)`` tabulated once.

    Parameters
    ----------
    build
        A middle-ear build (``neweul middle-ear build``): its ``middle_ear.yaml`` and the
        manubrium nodes of its ``fem`` sweep.
    work
        Where the chain module is generated.
    """

    def __init__(self, build: Path, work: Path) -> None:
        text = (Path(build) / "middle_ear.yaml").read_text(encoding="utf-8")
        self.module = calibration_module(text, node_positions(Path(build) / "fem"), Path(work))
        self.names = list(self.module.PARAMETERS)
        self.p0 = np.array(self.module.default_parameters(), dtype=float)
        i = self.names.index(PHI)
        phis = np.geomspace(0.05, 200.0, 60)
        ks = []
        for phi in phis:
            p = self.p0.copy()
            p[i] = phi
            ks.append(umbo_stiffness(self.module, p)["k"])
        self.log_k, self.log_phi = np.log(ks), np.log(phis)

    def parameters(self, k_t: float) -> np.ndarray:
        """The chain's parameter vector at the static tangent ``k_t`` [N/m] at the umbo."""
        p = self.p0.copy()
        p[self.names.index(PHI)] = float(np.exp(np.interp(np.log(k_t), self.log_k,
                                                          self.log_phi)))
        return p


def coupled_response(fe: Any, G: Any, f_ref: float, chain: CalibrationChain, k_t: float,
                     freqs: np.ndarray) -> dict[str, np.ndarray]:
    """The FE outputs :data:`FE_OUTPUTS` and the malleus (``m_z``) and stapes (``s_z``)
    velocities per unit canal volume acceleration of one working point with the chain."""
    fe = frequency_form(dataclasses.replace(fe, G=G, loss_reference_frequency=f_ref), "loss")
    mats, own, dofs = linear_chain(chain.module, fe, chain.parameters(k_t), "loss")
    res = coupled_frf(fe, mats, dofs, freqs, "canal_volume_acceleration", FE_OUTPUTS,
                      [own.index("m_z"), own.index("s_z")])
    res["m_z"] = res.pop(f"chain{own.index('m_z')}")
    res["s_z"] = res.pop(f"chain{own.index('s_z')}")
    return res


def _bands(dp: float) -> list[str]:
    return (["226"] + (["low"] if dp in STATIC_PA or dp == 0.0 else [])
            + (["res"] if dp in (0.0, 10.0 * TYMPANOGRAM_DAPA[0]) else [])
            + (["stapes"] if dp == 0.0 else []))


def calibration_measures(params: MiddleEarParameters, chain: CalibrationChain,
                         refine: int = 0) -> dict[str, Any]:
    """The model's measures (module docstring) for ``params`` at mesh refinement ``refine``.

    Returns
    -------
    dict
        ``tw``, ``tpp`` [daPa], ``ytm_mmho``, ``vea_cm3``, ``f_res`` [Hz] (``nan`` where not
        reached), ``loss`` (``umbo``/``malleus``/``stapes`` → Δp [Pa] → dB), ``tympanogram``
        (``pressure_daPa``, ``admittance_mmho``), ``stapes`` (``frequency_hz``,
        ``velocity_mm_s_Pa``), ``stapes_peak_hz``, ``stapes_peak_mm_s_Pa``,
        ``stapes_volume_low_mm3_Pa`` (mean magnitude 200–800 Hz).

    Raises
    ------
    SolverError
        A static state beyond the model's validity or Newton convergence.
    """
    dps = sorted({*(10.0 * TYMPANOGRAM_DAPA), *STATIC_PA, 0.0})
    sweep = pressure_sweep(dps, params, refine=refine)
    bands = {"226": np.array([226.0]), "low": F_LOW, "res": F_RES, "stapes": F_STAPES}
    h: dict[float, dict[str, dict[str, np.ndarray]]] = {}
    for dp, fe, G, grp in zip(dps, sweep.models, sweep.damping, sweep.static_groups,
                              strict=True):
        need = _bands(dp)
        freqs = np.concatenate([bands[b] for b in need])
        out = coupled_response(fe, G, params.f_ref, chain, float(grp["chain_tangent"][2, 2]),
                               freqs)
        edges = np.cumsum([0] + [bands[b].size for b in need])
        h[dp] = {b: {k: v[edges[i]:edges[i + 1]] for k, v in out.items()}
                 for i, b in enumerate(need)}

    def per_probe(dp: float, band: str, key: str) -> np.ndarray:
        """Admittance at the probe tip, or a velocity per probe pressure."""
        w, out = 2 * np.pi * bands[band], h[dp][band]
        if key == "y_probe":
            return 1 / (1j * w * out["entrance_pressure"])
        v = 1j * w * out["umbo_uz"] if key == "umbo" else out[{"malleus": "m_z",
                                                                "stapes": "s_z"}[key]]
        return v / out["probe_pressure"]

    y = np.array([per_probe(10.0 * p, "226", "y_probe")[0] for p in TYMPANOGRAM_DAPA])
    m = tympanometric_measures(TYMPANOGRAM_DAPA, y, 226.0, params.rho_air, params.c_air)
    loss = {}
    for key in ("umbo", "malleus", "stapes"):
        ref = per_probe(0.0, "low", key)
        loss[key] = {dp: float(np.mean(20 * np.log10(np.abs(per_probe(dp, "low", key) / ref))))
                     for dp in STATIC_PA}
    db = (per_probe(0.0, "res", "y_probe")
          - per_probe(10.0 * TYMPANOGRAM_DAPA[0], "res", "y_probe")).imag
    cross = np.flatnonzero((db[:-1] > 0) & (db[1:] <= 0))
    f_res = float("nan")
    if cross.size:
        i = cross[0]
        f_res = float(F_RES[i] - db[i] * (F_RES[i + 1] - F_RES[i]) / (db[i + 1] - db[i]))
    st = np.abs(per_probe(0.0, "stapes", "stapes"))
    k = int(np.argmax(st))
    peak_hz = log_parabolic_peak(F_STAPES, st, k)
    low = (F_STAPES >= 200.0) & (F_STAPES <= 800.0)
    volume = st[low] / (2 * np.pi * F_STAPES[low]) * FOOTPLATE_AREA * 1e9     # mm³/Pa
    return {"tw": m.width_daPa, "ytm_mmho": m.peak_admittance_mmho, "tpp": m.peak_pressure_daPa,
            "vea_cm3": m.ear_canal_volume_cm3, "f_res": f_res, "loss": loss,
            "tympanogram": {"pressure_daPa": TYMPANOGRAM_DAPA.tolist(),
                            "admittance_mmho": (np.abs(y) / MMHO).tolist()},
            "stapes": {"frequency_hz": F_STAPES.tolist(),
                       "velocity_mm_s_Pa": (1e3 * st).tolist()},
            "stapes_peak_hz": peak_hz, "stapes_peak_mm_s_Pa": 1e3 * float(st[k]),
            "stapes_volume_low_mm3_Pa": float(np.mean(volume))}


def log_parabolic_peak(freqs: np.ndarray, mag: np.ndarray, k: int) -> float:
    """The peak frequency: the vertex of the parabola through the largest sample ``k`` and
    its neighbours in ``(ln f, ln |v|)``, so that the measure moves smoothly with the parameters
    (the sample itself where ``k`` is at an end of the band)."""
    if k == 0 or k == freqs.size - 1:
        return float(freqs[k])
    x, y = np.log(freqs[k - 1 : k + 2]), np.log(mag[k - 1 : k + 2])
    den = (x[0] - x[1]) * (x[0] - x[2]) * (x[1] - x[2])
    a = (x[2] * (y[1] - y[0]) + x[1] * (y[0] - y[2]) + x[0] * (y[2] - y[1])) / den
    b = (x[2] ** 2 * (y[0] - y[1]) + x[1] ** 2 * (y[2] - y[0]) + x[0] ** 2 * (y[1] - y[2])) / den
    return float(np.exp(-b / (2 * a))) if a < 0 else float(freqs[k])


def residual_labels(keys: Sequence[str]) -> list[str]:
    """The name of each residual of :func:`calibration_residuals` for ``keys``."""
    out = [k for k in keys if k != "murakami"]
    if "murakami" in keys:
        for k in (1, 2, 3):
            out += [f"gain-{k}kPa", f"excess-{k}kPa"]
    return out


def calibrated_values(measures: dict[str, Any]) -> dict[str, float]:
    """The values :func:`calibration_residuals` compares, in the units of :data:`CALIBRATION`
    (``ytm`` and ``stapes_peak`` in ln), and the umbo's change at ``±k kPa`` as
    ``umbo±kkPa`` [dB]; a ``TW`` or resonance that does not exist counts as 400 daPa or
    3 kHz."""
    umbo = {float(k): float(v) for k, v in measures["loss"]["umbo"].items()}
    out = {"tw": measures["tw"] if np.isfinite(measures["tw"]) else 400.0,
           "ytm": float(np.log(max(measures["ytm_mmho"], 1e-3))),
           "f_res": measures["f_res"] if np.isfinite(measures["f_res"]) else 3000.0,
           "stapes_peak": float(np.log(measures["stapes_peak_hz"]))}
    out.update({f"umbo{dp / 1e3:+.0f}kPa": umbo[dp] for dp in STATIC_PA})
    return {k: float(v) for k, v in out.items()}


def mesh_offsets(coarse: dict[str, Any], fine: dict[str, Any]) -> dict[str, float]:
    """``fine − coarse`` of :func:`calibrated_values`: the measures of one parameter set on a
    finer mesh minus those on the coarse one — the coarse mesh's discretization error,
    which a fit on the coarse mesh adds to its values (an additive output correction; the
    difference is taken as constant over the fit's neighbourhood)."""
    a, b = calibrated_values(coarse), calibrated_values(fine)
    return {k: b[k] - a[k] for k in a}


def calibration_residuals(measures: dict[str, Any] | None, keys: Sequence[str],
                          offsets: dict[str, float] | None = None) -> np.ndarray:
    """``(model − mean)/SD`` per key of :data:`CALIBRATION` in ``keys``; ``"murakami"`` adds
    the six one-sided residuals of :data:`MURAKAMI_DB`; ``offsets`` (:func:`mesh_offsets`)
    are added to the model's values first. ``measures=None`` (the model could not be
    evaluated): :data:`PENALTY` everywhere."""
    n = len(residual_labels(keys))
    if measures is None:
        return np.full(n, PENALTY)
    value = calibrated_values(measures)
    value = {k: v + (offsets or {}).get(k, 0.0) for k, v in value.items()}
    out = [(value[k] - CALIBRATION[k].mean) / CALIBRATION[k].sd for k in keys
           if k != "murakami"]
    if "murakami" in keys:
        for k in (1, 2, 3):
            out.append(max(0.0, value[f"umbo-{k}kPa"]) / MURAKAMI_DB)
            out.append(max(0.0, value[f"umbo+{k}kPa"] - value[f"umbo-{k}kPa"]) / MURAKAMI_DB)
    return np.array(out)


def evaluate(params: MiddleEarParameters, chain: CalibrationChain, refine: int = 0
             ) -> dict[str, Any] | None:
    """:func:`calibration_measures`, or ``None`` where the static state leaves the model's
    validity or Newton does not converge."""
    try:
        return calibration_measures(params, chain, refine)
    except SolverError:
        return None


def held_out(measures: dict[str, Any]) -> dict[str, Any]:
    """The model against :data:`HELD_OUT`: per Δp the stapes loss minus the umbo loss [dB]
    (measured > 0), the stapes volume displacement below 1 kHz against Kringlebotn &
    Gundersen's level average [dB], and the peak stapes velocity against 0.1–0.3 mm/s/Pa."""
    lo = measures["loss"]
    diff = {dp: lo["stapes"][dp] - lo["umbo"][dp] for dp in STATIC_PA}
    vol = measures["stapes_volume_low_mm3_Pa"]
    peak = measures["stapes_peak_mm_s_Pa"]
    return {"stapes_minus_umbo_dB": diff,
            "stapes_less_than_umbo": all(v > 0 for v in diff.values()),
            "stapes_volume_low_dB": float(20 * np.log10(vol / HELD_OUT["stapes_volume_low"].mean)),
            "stapes_peak_in_band": bool(0.1 <= peak <= 0.3)}
