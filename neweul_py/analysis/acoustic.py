"""Acoustic immittance of a linear model at a port: impedance, admittance, reflectance.

A *port* is a surface through which a source drives the model with the volume velocity ``U``
(or the volume acceleration ``U̇``) and over which the model reports the pressure ``p``
(docs/analysis.md, "Acoustic immittance"). With the frequency response ``H = p/u`` of the
pressure output to the source input (:func:`~neweul_py.analysis.frf.frequency_response`)::

    Z(ω) = p/U = H            (source: volume velocity)
    Z(ω) = p/U = jω H         (source: volume acceleration, U = U̇/(jω))
    Y(ω) = 1/Z(ω)

and of a moving surface whose volume displacement ``V`` is an output (a membrane, a piston)::

    Y_s(ω) = jω V/p           (its volume velocity per pressure)

The plane-wave quantities of a duct of cross-section ``A`` (Keefe et al. 1993; Allen et al.
2005): the characteristic impedance ``Z₀ = ρc/A``, the pressure reflectance
``R = (Z − Z₀)/(Z + Z₀)`` and the absorbance (energy absorbed per incident energy)
``𝒜 = 1 − |R|²``. A compact rigid-walled cavity of volume ``V`` has the admittance
``jωV/(ρc²)`` (an acoustic compliance ``V/(ρc²)``); its inverse gives a measured admittance
the *equivalent volume* ``|Y| ρc²/ω`` of clinical tympanometry.

Units are SI: ``Z`` in Pa s/m³, ``Y`` in m³/(Pa s). Clinical admittance is quoted in acoustic
millimhos of the cgs system: :data:`MMHO` = 1 mmho = 10⁻⁸ m³/(Pa s).

References
----------
Keefe DH, Bulen JC, Arehart KH, Burns EM (1993) Ear-canal impedance and reflection coefficient
in human infants and adults. *J. Acoust. Soc. Am.* 94:2617–2638.
Allen JB, Jeng PS, Levitt H (2005) Evaluation of human middle ear function via an acoustic
power assessment. *J. Rehabil. Res. Dev.* 42:63–78.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..errors import NeweulError
from .frf import frequency_response
from .linearize import LinearModel, linearize

__all__ = [
    "MMHO",
    "SOURCE_KINDS",
    "absorbance",
    "cavity_admittance",
    "characteristic_impedance",
    "equivalent_volume",
    "port_admittance",
    "port_impedance",
    "reflectance",
    "surface_admittance",
]

#: One acoustic millimho (cgs: 10⁻³ cm³/(dyn s)) in SI units [m³/(Pa s)].
MMHO = 1e-8
#: What a port's source input is: its volume acceleration [m³/s²] or volume velocity [m³/s].
SOURCE_KINDS = ("volume_acceleration", "volume_velocity")


def _frequencies(f: Sequence[float] | np.ndarray) -> np.ndarray:
    freq = np.asarray(f, dtype=float).reshape(-1)
    if freq.size == 0 or not np.all(np.isfinite(freq)) or np.any(freq <= 0):
        raise NeweulError("acoustic immittance: frequencies must be finite and > 0 Hz, got "
                          f"{freq.tolist()[:5]}")
    return freq


def _linear(model: LinearModel | Any, kwargs: dict[str, Any]) -> LinearModel:
    return model if isinstance(model, LinearModel) else linearize(model, **kwargs)


def port_impedance(model: LinearModel | Any, f: Sequence[float] | np.ndarray, source: str,
                   pressure: str, *, source_kind: str = "volume_acceleration",
                   damping: str = "loss", **linearize_kwargs: Any) -> np.ndarray:
    """Acoustic impedance ``Z = p/U`` [Pa s/m³] at a port (module docstring).

    Parameters
    ----------
    model
        A :class:`~neweul_py.analysis.linearize.LinearModel`, or a generated module
        (linearized first with ``linearize_kwargs``).
    f
        Frequencies [Hz], all > 0.
    source
        The input that drives the port.
    pressure
        The output that is the pressure over the port's surface [Pa] (for a port that is
        a driven plane: its area-weighted mean, the work conjugate of the source).
    source_kind
        ``"volume_acceleration"`` (default; ``U = u/(jω)``) or ``"volume_velocity"``.
    damping
        ``"loss"`` (loss factors as ``K + iG``) or ``"viscous"``
        (:func:`~neweul_py.analysis.frf.frequency_response`).

    Returns
    -------
    ndarray (nf,) complex

    Examples
    --------
    >>> z = port_impedance(lin, [226.0], "Q", "p_entrance")   # doctest: +SKIP
    """
    if source_kind not in SOURCE_KINDS:
        raise NeweulError(f"unknown source kind {source_kind!r}; valid: "
                          f"{', '.join(SOURCE_KINDS)}")
    freq = _frequencies(f)
    h = frequency_response(_linear(model, linearize_kwargs), freq, source, pressure,
                           damping=damping).H[:, 0, 0]
    return h * (2j * np.pi * freq) if source_kind == "volume_acceleration" else h


def port_admittance(model: LinearModel | Any, f: Sequence[float] | np.ndarray, source: str,
                    pressure: str, **kwargs: Any) -> np.ndarray:
    """Acoustic admittance ``Y = U/p = 1/Z`` [m³/(Pa s)] at a port (:func:`port_impedance`,
    same arguments)."""
    return 1.0 / port_impedance(model, f, source, pressure, **kwargs)


def surface_admittance(model: LinearModel | Any, f: Sequence[float] | np.ndarray, source: str,
                       volume: str, pressure: str, *, damping: str = "loss",
                       **linearize_kwargs: Any) -> np.ndarray:
    """Admittance ``Y_s = jω V/p`` [m³/(Pa s)] of a moving surface: its volume velocity per
    the pressure on it, both driven by ``source`` (module docstring).

    ``volume`` is the output of the surface's volume displacement [m³] and ``pressure`` the
    output of the pressure acting on it [Pa]; the ratio does not depend on what ``source``
    is, as long as it drives the surface through that pressure.
    """
    freq = _frequencies(f)
    h = frequency_response(_linear(model, linearize_kwargs), freq, source, [volume, pressure],
                           damping=damping).H[:, :, 0]
    return 2j * np.pi * freq * h[:, 0] / h[:, 1]


def characteristic_impedance(rho: float, c: float, area: float) -> float:
    """Plane-wave characteristic impedance ``Z₀ = ρc/A`` [Pa s/m³] of a duct of cross-section
    ``area`` [m²]."""
    for name, v in (("rho", rho), ("c", c), ("area", area)):
        if not (np.isfinite(v) and v > 0):
            raise NeweulError(f"characteristic impedance: {name} must be finite and > 0, "
                              f"got {v!r}")
    return float(rho * c / area)


def reflectance(z: np.ndarray, z0: float) -> np.ndarray:
    """Pressure reflectance ``R = (Z − Z₀)/(Z + Z₀)`` of the impedance ``z`` seen from a duct
    of characteristic impedance ``z0`` (Keefe et al. 1993)."""
    z = np.asarray(z, dtype=complex)
    return (z - z0) / (z + z0)


def absorbance(z: np.ndarray, z0: float) -> np.ndarray:
    """Absorbance ``𝒜 = 1 − |R|²``: the fraction of the incident plane-wave power that the
    impedance ``z`` absorbs (Allen et al. 2005; 1 for ``z = z0``, 0 for a lossless load)."""
    return 1.0 - np.abs(reflectance(z, z0)) ** 2


def cavity_admittance(volume: float, f: Sequence[float] | np.ndarray, rho: float,
                      c: float) -> np.ndarray:
    """Admittance ``jωV/(ρc²)`` of a compact rigid-walled cavity of ``volume`` [m³] (its
    acoustic compliance ``V/(ρc²)``; valid while the cavity is small against the
    wavelength)."""
    return 2j * np.pi * _frequencies(f) * volume / (rho * c**2)


def equivalent_volume(y: np.ndarray, f: Sequence[float] | np.ndarray, rho: float,
                      c: float) -> np.ndarray:
    """The volume [m³] of the compact rigid cavity of the same admittance magnitude,
    ``|Y| ρc²/ω`` (the inverse of :func:`cavity_admittance`; at 226 Hz and ρc² =
    1.41·10⁵ Pa, 1 mmho ≈ 1 cm³)."""
    return np.abs(y) * rho * c**2 / (2 * np.pi * _frequencies(f))
