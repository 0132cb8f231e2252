"""The middle ear as a clinic measures it: immittance at the probe and at the TM, absorbance,
and the tympanogram with its standard measures (docs/middle-ear-clinical.md).

The probe of a clinical instrument seals the ear canal; its tip carries the sound source and
the microphone. In the model the probe tip is the canal entrance: the source is the piston of
volume acceleration ``Q`` there and the pressure is its mean, ``p_entrance``, so that the
probe's acoustic impedance is ``Z = p_entrance/U`` with ``U = Q/(jω)``
(:func:`~neweul_py.analysis.acoustic.port_impedance`). The TM's admittance is its volume
velocity per the pressure in front of it, ``Y_TM = jω V_TM/p_probe`` (the probe microphone of
the model, 3 mm lateral of the TM rim plane). ``V_TM`` is the whole eardrum's, the pars
tensa's and a pars flaccida's volume displacement from the build's body
(:func:`eardrum_volume`): its output rows at ``Δp`` (``C(σ)``, mixed with the weights of its
matrices: the rows change by 3 % over ±4 kPa, as the static state turns the membrane). A
description's outputs have constant coefficients, so the module has no such output.

**Absorbance** at the probe: ``𝒜 = 1 − |R|²``, ``R = (Z − Z₀)/(Z + Z₀)``, ``Z₀ = ρc/A`` with
``A`` the canal's cross-section at the entrance, ``π d²/4`` (``canal_diameter`` = 7.5 mm:
44.2 mm², Rosowski 1993).

**Tympanogram.** The admittance at a probe frequency (226 Hz; 678 and 1000 Hz) against the
ear-canal static pressure ``P``, swept from +200 to −400 daPa as a tympanometer does. With the
middle-ear cavity at ambient pressure ``Δp = p_canal − p_cavity = 10 P`` [Pa] for ``P`` in
daPa. The EMBS is elastic and frozen in ``Δp`` (docs/equations-middle-ear.md §7): the sweep's
direction, its speed and the hysteresis of living ears do not enter. The measures are those
of :mod:`.tympanometry`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..analysis import load_generated
from ..analysis.acoustic import (
    MMHO,
    absorbance,
    characteristic_impedance,
    port_impedance,
    reflectance,
)
from ..analysis.frf import frequency_response
from ..analysis.linearize import linearize
from ..analysis.plot import new_figure, save_figure
from ..atomic import atomic_write
from ..elastic.io.body_files import load_parametric_body
from ..errors import DataError, NeweulError
from .embs import parameters_at
from .parameters import MiddleEarParameters
from .study import build_parameters, build_record
from .tympanometry import COMPENSATION_DAPA, TympanometricMeasures, tympanometric_measures

__all__ = [
    "DAPA",
    "MAX_PROBE_HZ",
    "MAX_PROBE_TONES",
    "PROBE_OUTPUT",
    "TYMPANOMETRY_HZ",
    "EardrumVolume",
    "Immittance",
    "Tympanogram",
    "build_model",
    "canal_impedance",
    "check_frequencies",
    "eardrum_volume",
    "immittance",
    "tympanogram",
]

#: Pascals per decapascal (the clinical unit of static pressure).
DAPA = 10.0
#: Probe-tone frequencies of tympanometry [Hz].
TYMPANOMETRY_HZ = (226.0, 678.0, 1000.0)
#: The output of the pressure at the probe tip (the canal entrance).
PROBE_OUTPUT = "p_entrance"
#: The default sweep [daPa]: +200 → −400 in steps of 5.
SWEEP_DAPA = np.linspace(200.0, -400.0, 121)
#: The body outputs whose sum is the eardrum's volume displacement [m³] (pars tensa, and the
#: pars flaccida where the model has one).
EARDRUM_OUTPUTS = ("tm_volume_displacement", "pf_volume_displacement")
#: Highest probe frequency [Hz]: the audible range (the FE meshes resolve the TM's modes to
#: about 8 kHz at refine 1).
MAX_PROBE_HZ = 20000.0
#: Most probe tones of one tympanogram (clinical multifrequency tympanometry sweeps 0.2–2 kHz
#: in about 20 steps).
MAX_PROBE_TONES = 64

Progress = Callable[..., None]


def canal_impedance(params: MiddleEarParameters) -> float:
    """``Z₀ = ρc/A`` [Pa s/m³] of the canal at the probe tip, ``A = π d²/4`` with the canal
    diameter at the entrance (44.2 mm² for 7.5 mm)."""
    return characteristic_impedance(params.rho_air, params.c_air,
                                    math.pi * params.canal_diameter**2 / 4)


def check_frequencies(f: Sequence[float] | np.ndarray, option: str = "--f",
                      most: int | None = None) -> np.ndarray:
    """``f`` [Hz] as an array of probe frequencies: finite, in ``(0, MAX_PROBE_HZ]``, at most
    ``most`` of them, distinct to the 10 digits their CSV columns are named by.

    Raises
    ------
    NeweulError
        Naming ``option`` and the first value at fault.
    """
    freq = np.asarray(f, dtype=float).reshape(-1)
    if freq.size == 0:
        raise NeweulError(f"{option}: no frequency")
    if most is not None and freq.size > most:
        raise NeweulError(f"{option}: {freq.size} probe frequencies, at most {most}")
    bad = ~(np.isfinite(freq) & (freq > 0) & (freq <= MAX_PROBE_HZ))
    if bad.any():
        raise NeweulError(f"{option}: {freq[bad][0]:g} Hz is not a probe frequency in "
                          f"(0, {MAX_PROBE_HZ:g}] Hz")
    names = [f"{v:.10g}" for v in freq]
    if len(set(names)) < len(names):
        raise NeweulError(f"{option}: repeated probe frequencies "
                          f"({', '.join(n for n in names if names.count(n) > 1)} Hz)")
    return freq


@dataclass(frozen=True)
class Immittance:
    """Acoustic immittance of the middle-ear model at one static pressure difference.

    Attributes
    ----------
    frequency_hz : ndarray (nf,)
    dp : float
        ``Δp = p_canal − p_cavity`` [Pa].
    z_probe : ndarray (nf,) complex
        Impedance at the probe tip, ``p_entrance/U`` [Pa s/m³].
    y_tm : ndarray (nf,) complex
        The TM's admittance ``jω V_TM/p_probe`` [m³/(Pa s)] (module docstring).
    z0 : float
        The canal's characteristic impedance at the probe tip [Pa s/m³].
    """

    frequency_hz: np.ndarray
    dp: float
    z_probe: np.ndarray
    y_tm: np.ndarray
    z0: float

    @property
    def y_probe(self) -> np.ndarray:
        """Admittance at the probe tip ``1/z_probe`` [m³/(Pa s)]."""
        return 1.0 / self.z_probe

    @property
    def reflectance(self) -> np.ndarray:
        """Pressure reflectance at the probe tip ``(Z − Z₀)/(Z + Z₀)``."""
        return reflectance(self.z_probe, self.z0)

    @property
    def absorbance(self) -> np.ndarray:
        """``1 − |R|²`` at the probe tip."""
        return absorbance(self.z_probe, self.z0)

    def columns(self) -> dict[str, np.ndarray]:
        """The CSV columns (name with unit → values)."""
        r = self.reflectance
        return {"frequency_hz": self.frequency_hz,
                "absorbance": self.absorbance,
                "reflectance_mag": np.abs(r),
                "reflectance_phase_deg": np.degrees(np.angle(r)),
                "z_probe_re_Pa_s_per_m3": self.z_probe.real,
                "z_probe_im_Pa_s_per_m3": self.z_probe.imag,
                "y_probe_re_mmho": self.y_probe.real / MMHO,
                "y_probe_im_mmho": self.y_probe.imag / MMHO,
                "y_tm_re_mmho": self.y_tm.real / MMHO,
                "y_tm_im_mmho": self.y_tm.imag / MMHO}

    def to_csv(self, path: str | Path) -> Path:
        """Write :meth:`columns` (atomically), a header line naming ``Δp`` and ``Z₀``."""
        cols = self.columns()
        lines = [f"# dp_Pa={self.dp!r} z0_Pa_s_per_m3={self.z0!r}", ",".join(cols)]
        lines += [",".join(repr(float(v)) for v in row) for row in zip(*cols.values(),
                                                                          strict=True)]
        atomic_write(Path(path), "\n".join(lines) + "\n")
        return Path(path)

    def plot(self, path: str | Path) -> Path:
        """Absorbance and ``|Y|`` at the probe and the TM against frequency (matplotlib)."""
        f = self.frequency_hz
        fig = new_figure(figsize=(6, 6), layout="constrained")
        ax = fig.subplots(2, 1, sharex=True)
        ax[0].semilogx(f, self.absorbance)
        ax[0].set_ylim(0, 1)
        ax[0].set_ylabel("absorbance 1 − |R|²")
        ax[0].set_title(f"probe tip, Δp = {self.dp:+.0f} Pa, Z₀ = ρc/A = "
                        f"{self.z0 / 1e6:.2f} MPa s/m³")
        ax[1].loglog(f, np.abs(self.y_probe) / MMHO, label="probe tip")
        ax[1].loglog(f, np.abs(self.y_tm) / MMHO, label="TM")
        ax[1].set_ylabel("|Y| [mmho]")
        ax[1].set_xlabel("frequency [Hz]")
        ax[1].legend()
        for a in ax:
            a.grid(True, which="both", lw=0.3)
        return save_figure(fig, path)


def build_model(directory: str | Path, *dps: float) -> tuple[Any, MiddleEarParameters]:
    """The generated EMBS of a build and the physical data of its FE sweep.

    Raises
    ------
    DataError
        No complete build in ``directory``, a ``Δp`` of ``dps`` outside its samples, a build
        without a generated module, or a module without the probe-tip pressure
        :data:`PROBE_OUTPUT`.
    """
    d = Path(directory)
    info = build_record(d, *dps)
    if not info.get("module") or not (d / info["module"]).is_file():
        raise DataError("the build has no generated module (built with --no-generate)",
                        str(d), "module")
    mod = load_generated(d / info["module"])
    if PROBE_OUTPUT not in mod.OUTPUTS:
        raise DataError(f"the module has no output {PROBE_OUTPUT!r} (the pressure at the canal "
                        "entrance, the probe tip): rebuild with neweul middle-ear build",
                        str(d / info["module"]), "OUTPUTS")
    return mod, build_parameters(d)


@dataclass(frozen=True)
class EardrumVolume:
    """The eardrum's volume-displacement row of a build's parametric body.

    Attributes
    ----------
    body : ParametricBody
        The build's elastic body (``build.json``'s ``body``).
    coordinates : tuple of str
        The module's coordinates of the body, in the body's order.
    """

    body: Any
    coordinates: tuple[str, ...]

    def row(self, dp: float) -> np.ndarray:
        """``Σ C_o(σ(Δp))`` over :data:`EARDRUM_OUTPUTS`: the body's output rows mixed with
        its matrices' weights at ``dp``
        (:meth:`~neweul_py.elastic.bodies.parametric.ParametricBody.mix`)."""
        C = self.body.mix("C", self.body.weights(float(dp)))
        names = list(self.body.output_names)
        return sum(np.asarray(C[names.index(n)], dtype=float) for n in EARDRUM_OUTPUTS
                   if n in names)


def eardrum_volume(directory: str | Path, mod: Any) -> EardrumVolume:
    """The eardrum's volume row of the build in ``directory`` for its module ``mod``.

    Raises
    ------
    DataError
        The build's body file is missing or unreadable, lacks the output
        ``tm_volume_displacement``, or its order differs from the module's ``tm_q…``
        coordinates.
    """
    d = Path(directory)
    info = build_record(d)
    path = d / str(info.get("body", ""))
    if not path.is_file():
        raise DataError("the build's body file is missing", str(path), "body")
    body = load_parametric_body(path)
    coords = tuple(c for c in mod.COORDINATES if c.startswith("tm_q"))
    if EARDRUM_OUTPUTS[0] not in body.output_names or len(coords) != body.order:
        raise DataError(f"not the body of this module (order {body.order}, the module has "
                        f"{len(coords)} tm_q coordinates; outputs must include "
                        f"{EARDRUM_OUTPUTS[0]!r})", str(path))
    return EardrumVolume(body, coords)


def immittance(mod: Any, params: MiddleEarParameters, dp: float,
               f: Sequence[float] | np.ndarray, damping: str = "loss", *,
               eardrum: EardrumVolume) -> Immittance:
    """The immittance of the EMBS ``mod`` linearized at ``dp`` (module docstring); the TM's
    admittance is the whole eardrum's, from the rows of ``eardrum`` (the build's body) at
    ``dp``."""
    lin = linearize(mod, p=parameters_at(mod, dp))
    freq = check_frequencies(f)
    z = port_impedance(lin, freq, "Q", PROBE_OUTPUT, damping=damping)
    h = frequency_response(lin, freq, "Q", [*eardrum.coordinates, "p_probe"],
                           damping=damping).H[:, :, 0]
    y_tm = 2j * np.pi * freq * (h[:, :-1] @ eardrum.row(dp)) / h[:, -1]
    return Immittance(freq, float(dp), z, y_tm, canal_impedance(params))


@dataclass(frozen=True)
class Tympanogram:
    """Admittance against ear-canal static pressure at probe frequencies.

    Attributes
    ----------
    pressure_daPa : ndarray (np,)
        Ear-canal static pressure in sweep order (+ → −).
    frequency_hz : ndarray (nf,)
    y_probe : ndarray (np, nf) complex
        Admittance at the probe tip [m³/(Pa s)].
    y_tm : ndarray (np, nf) complex
        The TM's admittance [m³/(Pa s)].
    rho, c : float
        Air.
    """

    pressure_daPa: np.ndarray
    frequency_hz: np.ndarray
    y_probe: np.ndarray
    y_tm: np.ndarray
    rho: float = 1.2
    c: float = 343.0

    def measures(self, vector: bool = False) -> list[TympanometricMeasures]:
        """:func:`tympanometric_measures` at every frequency."""
        return [tympanometric_measures(self.pressure_daPa, self.y_probe[:, j], f, self.rho,
                                       self.c, vector=vector)
                for j, f in enumerate(self.frequency_hz)]

    def columns(self) -> dict[str, np.ndarray]:
        """CSV columns: the pressure, then per frequency ``|Y|``, ``B``, ``G`` at the probe
        tip and ``|Y_TM|`` [mmho]."""
        cols = {"ear_canal_pressure_daPa": self.pressure_daPa,
                "dp_Pa": DAPA * self.pressure_daPa}
        for j, f in enumerate(self.frequency_hz):
            y, t = self.y_probe[:, j] / MMHO, self.y_tm[:, j] / MMHO
            hz = f"{f:.10g}Hz"
            cols |= {f"Y_probe_{hz}_mmho": np.abs(y), f"B_probe_{hz}_mmho": y.imag,
                     f"G_probe_{hz}_mmho": y.real, f"Y_tm_{hz}_mmho": np.abs(t)}
        return cols

    def to_csv(self, path: str | Path) -> Path:
        """Write :meth:`columns` (atomically)."""
        cols = self.columns()
        lines = [",".join(cols)]
        lines += [",".join(repr(float(v)) for v in row) for row in zip(*cols.values(),
                                                                          strict=True)]
        atomic_write(Path(path), "\n".join(lines) + "\n")
        return Path(path)

    def plot(self, path: str | Path, vector: bool = False) -> Path:
        """``|Y|`` at the probe tip (and compensated as :meth:`measures` with ``vector``)
        against pressure, increasing to the right as tympanograms are drawn, one panel per
        frequency (at most four in a row), the measures in the titles (matplotlib)."""
        nf = self.frequency_hz.size
        cols = min(nf, 4)
        rows = -(-nf // cols)
        fig = new_figure(figsize=(4.5 * cols, 3.6 * rows), layout="constrained")
        axes = fig.subplots(rows, cols, squeeze=False).ravel()
        ref = int(np.flatnonzero(np.isclose(self.pressure_daPa, COMPENSATION_DAPA))[0])
        for ax, m, j in zip(axes, self.measures(vector), range(nf), strict=False):
            y = self.y_probe[:, j] / MMHO
            yc = np.abs(y - y[ref]) if vector else np.abs(y) - np.abs(y[ref])
            ax.plot(self.pressure_daPa, np.abs(y), label="|Y| probe tip")
            kind = "vector" if vector else "magnitude"
            ax.plot(self.pressure_daPa, yc,
                    label=f"compensated ({kind}, {COMPENSATION_DAPA:+g} daPa)")
            ax.plot(self.pressure_daPa, np.abs(self.y_tm[:, j]) / MMHO, ":", label="|Y_TM|")
            if not math.isnan(m.width_daPa):
                ax.hlines(m.peak_admittance_mmho / 2, *m.half_points_daPa, colors="k",
                          lw=0.8, label=f"TW {m.width_daPa:.0f} daPa")
            title = (f"{m.frequency_hz:g} Hz: no peak" if math.isnan(m.peak_pressure_daPa)
                     else f"{m.frequency_hz:g} Hz: Ytm {m.peak_admittance_mmho:.2f} mmho, "
                     f"TPP {m.peak_pressure_daPa + 0.0:+.0f} daPa")
            ax.set_title(title, fontsize=9)
            ax.set_xlabel("ear-canal pressure [daPa]")
            ax.set_ylabel("admittance [mmho]")
            ax.grid(True, lw=0.3)
            ax.legend(fontsize=7)
        for ax in axes[nf:]:
            ax.set_visible(False)
        return save_figure(fig, path)


def tympanogram(mod: Any, params: MiddleEarParameters,
                frequencies: Sequence[float] = (TYMPANOMETRY_HZ[0],),
                pressures_dapa: Sequence[float] | np.ndarray = SWEEP_DAPA,
                damping: str = "loss", progress: Progress | None = None, *,
                eardrum: EardrumVolume) -> Tympanogram:
    """The tympanogram of the EMBS ``mod``: at each ear-canal pressure (in the order given,
    +200 → −400 daPa by default) the model linearized at ``Δp = 10 P`` and its admittance at
    the probe tip and at the TM at ``frequencies`` (module docstring).

    Raises
    ------
    NeweulError
        No pressure, a non-finite one, or frequencies :func:`check_frequencies` refuses (at
        most :data:`MAX_PROBE_TONES`).
    """
    say = progress or (lambda *_a, **_k: None)
    p = np.asarray(pressures_dapa, dtype=float).reshape(-1)
    if p.size == 0 or not np.all(np.isfinite(p)):
        raise NeweulError("tympanogram: the pressures must be finite, at least one")
    f = check_frequencies(frequencies, most=MAX_PROBE_TONES)
    yp = np.zeros((p.size, f.size), dtype=complex)
    yt = np.zeros_like(yp)
    for i, pi in enumerate(p):
        say("tympanogram", i + 1, p.size)
        im = immittance(mod, params, DAPA * pi, f, damping, eardrum=eardrum)
        yp[i], yt[i] = im.y_probe, im.y_tm
    return Tympanogram(p, f, yp, yt, params.rho_air, params.c_air)
