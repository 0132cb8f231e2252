"""Parameter sensitivities of modes and frequency responses (docs/sensitivity.md §4–5).

From the derivatives of the linear model
(:func:`~neweul_py.analysis.sensitivity.linear_model_derivatives`):

- **modes** of the pencil ``Ã x = λ E x``: ``dλ = wᴴ (dÃ − λ dE) v / (wᴴ E v)`` with the left
  and right eigenvectors ``w``, ``v``;
- **frequency response** ``H = C_ω Z⁻¹ B + D``: ``dH = dC_ω X + C_ω Z⁻¹ (dB − dZ X) + dD``,
  ``X = Z⁻¹ B``, reported as ``∂ln|H|/∂ln p = Re(p dH/H)`` and ``∂φ/∂ln p = Im(p dH/H)``.
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..atomic import atomic_write
from .frf import dynamic_solve, frequency_response
from .linearize import LinearModel
from .modes import ModalResult, modes
from .results import ResultDisplay, check_output_path
from .sensitivity import ANALYTIC, LinearModelDerivative

__all__ = ["FrequencyResponseSensitivity", "ModalSensitivity",
           "frequency_response_sensitivity", "modal_sensitivity"]


# ----------------------------------------------------------------------------- modes
@dataclass(frozen=True, repr=False)
class ModalSensitivity(ResultDisplay):
    """Derivatives of the oscillating modes' frequencies and damping ratios.

    Attributes
    ----------
    modes : ModalResult
    parameters : tuple of str
    values : ndarray (k,)
    deigenvalue : ndarray (m, k) complex
        ``dλ/dp`` of each mode of ``modes`` (rows) and parameter.
    method : str
        :data:`ANALYTIC` or :data:`DIFFERENCES` (of the linear model's matrices).
    """

    modes: ModalResult
    parameters: tuple[str, ...]
    values: np.ndarray
    deigenvalue: np.ndarray
    method: str = ANALYTIC

    @property
    def dlogf_dlogp(self) -> np.ndarray:
        """``∂ln f/∂ln p`` (m, k) of the natural frequencies ``f = |λ|/2π``."""
        lam = self.modes.eigenvalues[:, None]
        mag = np.where(np.abs(lam) > 0, np.abs(lam), np.nan)
        return (np.conj(lam) * self.deigenvalue).real / mag**2 * self.values[None, :]

    @property
    def dzeta_dlogp(self) -> np.ndarray:
        """``∂ζ/∂ln p`` (m, k) of the damping ratios ``ζ = −Re λ/|λ|``."""
        lam = self.modes.eigenvalues[:, None]
        mag = np.where(np.abs(lam) > 0, np.abs(lam), np.nan)
        dmag = (np.conj(lam) * self.deigenvalue).real / mag
        dzeta = -(self.deigenvalue.real * mag - lam.real * dmag) / mag**2
        return dzeta * self.values[None, :]

    def columns(self) -> dict[str, np.ndarray]:
        """One row per oscillating mode: ``frequency_hz``, ``damping_ratio`` and per parameter
        ``dlogf_dlog_NAME``, ``dzeta_dlog_NAME``."""
        keep = self.modes.oscillating
        cols = {"mode": np.arange(1, int(keep.sum()) + 1),
                "frequency_hz": self.modes.frequency_hz[keep],
                "damping_ratio": self.modes.damping_ratio[keep]}
        f, z = self.dlogf_dlogp[keep], self.dzeta_dlogp[keep]
        for j, nm in enumerate(self.parameters):
            cols[f"dlogf_dlog_{nm}"] = f[:, j]
            cols[f"dzeta_dlog_{nm}"] = z[:, j]
        return cols

    def summary(self) -> str:
        return (f"ModalSensitivity({int(self.modes.oscillating.sum())} oscillating modes, "
                f"parameters {', '.join(self.parameters)}; {self.method})")

    def to_csv(self, path: str | os.PathLike[str]) -> Path:
        """Write :meth:`columns` as CSV, atomically."""
        return atomic_write(check_output_path(path, (".csv",), "sensitivities"),
                            _csv(self.columns()))


def modal_sensitivity(lin: LinearModel, derivatives: Sequence[LinearModelDerivative], *,
                      undamped: bool = False, method: str = ANALYTIC,
                      zero_tol: float = 1e-7) -> ModalSensitivity:
    """``dλ/dp = wᴴ (dÃ − λ dE) v / (wᴴ E v)`` for every mode of ``lin``
    (docs/sensitivity.md §3), with ``Ã = [[0, I], [−Q, −P]]``, ``E = diag(I, M0)``.

    Parameters
    ----------
    lin
        The linear model.
    derivatives
        Its matrices' derivatives (:func:`linear_model_derivatives`).
    undamped
        The modes of the undamped pencil (``P = 0``), as
        :func:`~neweul_py.analysis.modes.modes`.
    method, zero_tol
        Recorded in the result; as :func:`~neweul_py.analysis.modes.modes`.
    """
    import scipy.linalg as sla

    base = replace(lin, P=np.zeros_like(lin.P)) if undamped else lin
    result = modes(base, zero_tol=zero_tol, undamped=undamped)
    a, e = base.first_order_pencil()
    lam, left, right = sla.eig(a, e, left=True, right=True)
    finite = np.isfinite(lam)
    lam, left, right = lam[finite], left[:, finite], right[:, finite]
    m = lin.n
    dlam = np.zeros((result.eigenvalues.size, len(derivatives)), dtype=complex)
    for r, target in enumerate(result.eigenvalues):
        k = int(np.argmin(np.abs(lam - target)))
        v, w = right[:, k], left[:, k]
        norm = np.conj(w) @ e @ v
        for j, d in enumerate(derivatives):
            da = np.zeros_like(a)
            da[m:, :m] = -d.Q
            if not undamped:
                da[m:, m:] = -d.P
            de = np.zeros_like(e)
            de[m:, m:] = d.M0
            dlam[r, j] = (np.conj(w) @ (da - target * de) @ v) / norm
    return ModalSensitivity(result, tuple(d.parameter for d in derivatives),
                            np.array([d.value for d in derivatives]), dlam, method)


# ----------------------------------------------------------------------------- frequency response
@dataclass(frozen=True, repr=False)
class FrequencyResponseSensitivity(ResultDisplay):
    """A frequency response and its derivatives with respect to parameters.

    Attributes
    ----------
    frequency_hz : ndarray (nf,)
    H : ndarray (nf, ny, nu) complex
    dH : ndarray (k, nf, ny, nu) complex
        ``∂H/∂p`` per parameter.
    outputs, inputs, parameters : tuple of str
    values : ndarray (k,)
    method : str
        :data:`ANALYTIC` or :data:`DIFFERENCES`.
    """

    frequency_hz: np.ndarray
    H: np.ndarray
    dH: np.ndarray
    outputs: tuple[str, ...]
    inputs: tuple[str, ...]
    parameters: tuple[str, ...]
    values: np.ndarray
    method: str = ANALYTIC

    @property
    def relative(self) -> np.ndarray:
        """``p ∂H/∂p / H`` (k, nf, ny, nu): real part ``∂ln|H|/∂ln p``, imaginary part
        ``∂φ/∂ln p`` [rad]."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.values[:, None, None, None] * self.dH / self.H[None]

    @property
    def dlogmag_dlogp(self) -> np.ndarray:
        """``∂ln|H|/∂ln p`` (k, nf, ny, nu)."""
        return self.relative.real

    @property
    def dphase_deg_dlogp(self) -> np.ndarray:
        """``∂φ/∂ln p`` in degrees (k, nf, ny, nu)."""
        return np.degrees(self.relative.imag)

    def columns(self) -> dict[str, np.ndarray]:
        """``frequency_hz``, then per parameter ``dlogmag_dlog_NAME`` and
        ``dphase_deg_dlog_NAME`` (suffixed ``__OUTPUT__INPUT`` with several pairs)."""
        single = len(self.outputs) == 1 and len(self.inputs) == 1
        cols = {"frequency_hz": np.asarray(self.frequency_hz, dtype=float)}
        mag, ph = self.dlogmag_dlogp, self.dphase_deg_dlogp
        for i, o in enumerate(self.outputs):
            for j, u in enumerate(self.inputs):
                sfx = "" if single else f"__{o}__{u}"
                for k, nm in enumerate(self.parameters):
                    cols[f"dlogmag_dlog_{nm}{sfx}"] = mag[k, :, i, j]
                    cols[f"dphase_deg_dlog_{nm}{sfx}"] = ph[k, :, i, j]
        return cols

    def summary(self) -> str:
        f = np.asarray(self.frequency_hz)
        span = f"{f.min():g} … {f.max():g} Hz" if f.size else "no frequencies"
        return (f"FrequencyResponseSensitivity({f.size} frequencies, {span}; parameters "
                f"{', '.join(self.parameters)}; {self.method})")

    def to_csv(self, path: str | os.PathLike[str]) -> Path:
        """Write :meth:`columns` as CSV, atomically."""
        return atomic_write(check_output_path(path, (".csv",), "sensitivities"),
                            _csv(self.columns()))


def frequency_response_sensitivity(
    lin: LinearModel, derivatives: Sequence[LinearModelDerivative],
    f: Sequence[float] | np.ndarray, inputs: str | Sequence[str] | None = None,
    outputs: str | Sequence[str] | None = None, *, damping: str = "loss",
    method: str = ANALYTIC,
) -> FrequencyResponseSensitivity:
    """``H`` and ``∂H/∂p`` for each derivative of ``lin`` (docs/sensitivity.md §4).

    ``H = C_ω Z⁻¹ B + D`` is linear in ``B``, ``C``, ``D`` and its derivative is
    ``dH = dC_ω X + C_ω Z⁻¹ (dB − dZ X) + dD`` with ``X = Z⁻¹ B``; both are evaluated by
    :func:`~neweul_py.analysis.frf.frequency_response` on linear models whose matrices are
    chosen so that its result is each term (the rates of kinematic excitation, the loss form
    and the output rows are handled there, once).

    Parameters
    ----------
    lin, derivatives
        The linear model and its matrices' derivatives (:func:`linear_model_derivatives`).
    f, inputs, outputs, damping
        As :func:`~neweul_py.analysis.frf.frequency_response`.
    method
        Recorded in the result.
    """
    base = frequency_response(lin, f, inputs, outputs, damping=damping)
    w = 2 * np.pi * np.asarray(base.frequency_hz, dtype=float)
    X = _coordinate_response(lin, base, damping)
    dH = np.empty((len(derivatives), *base.H.shape), dtype=complex)
    for k, d in enumerate(derivatives):
        dlin = d.as_linear_model(lin)
        # dC_ω X + dD: the output rows of the derivative applied to the solution of lin
        part_c = frequency_response(replace(lin, C=dlin.C, D=dlin.D, basis=dlin.basis), f,
                                    base.inputs, base.outputs, damping=damping).H
        # C_ω Z⁻¹ dB (D = 0): the solution with the input matrix dB
        part_b = frequency_response(replace(lin, B=d.B, D=np.zeros_like(lin.D)), f,
                                    base.inputs, base.outputs, damping=damping).H
        # −C_ω Z⁻¹ dZ X: the solution with the inputs dZ X, one frequency at a time
        part_z = _stiffness_term(lin, dlin, w, X, base.outputs, damping)
        dH[k] = part_c + part_b - part_z
    return FrequencyResponseSensitivity(
        base.frequency_hz, base.H, dH, base.outputs, base.inputs,
        tuple(d.parameter for d in derivatives), np.array([d.value for d in derivatives]),
        method)


def _coordinate_response(lin: LinearModel, base: Any, damping: str) -> np.ndarray:
    """``X = Z⁻¹ B(ω)`` (nf, m, nu) in the minimal coordinates, with the rates of kinematic
    excitation folded in as :func:`frequency_response` does."""
    coords = list(lin.all_coordinates)
    nf = len(base.frequency_hz)
    X = frequency_response(replace(lin, C=np.zeros_like(lin.C), D=np.zeros_like(lin.D)),
                           base.frequency_hz, base.inputs, coords, damping=damping).H
    # X in the full coordinates; the equations are in the minimal ones (lin.basis)
    Xm = np.linalg.lstsq(lin.basis, X.transpose(1, 0, 2).reshape(len(coords), -1),
                         rcond=None)[0]
    return Xm.reshape(lin.n, nf, -1).transpose(1, 0, 2)


def _stiffness_term(lin: LinearModel, dlin: LinearModel, w: np.ndarray, X: np.ndarray,
                    outputs: Sequence[str], damping: str) -> np.ndarray:
    """``C_ω Z⁻¹ dZ X`` (nf, ny, nu) for the coordinates' response ``X``
    (:func:`_coordinate_response`)."""
    dZ = dlin.dynamic_stiffness(w, damping if dlin.G is not None else "viscous")
    sol = dynamic_solve(lin.dynamic_stiffness(w, damping), dZ @ X, w)
    cy, cyd, cydd, _d = lin.output_rows(outputs)
    ww = w[:, None, None]
    return (cy + 1j * ww * cyd - ww**2 * cydd) @ sol


def _csv(cols: dict[str, np.ndarray]) -> str:
    buf = io.StringIO()
    wr = csv.writer(buf, lineterminator="\n")
    wr.writerow(list(cols))
    for row in zip(*cols.values(), strict=True):
        wr.writerow([repr(float(v)) if isinstance(v, float | np.floating) else str(v)
                     for v in row])
    return buf.getvalue()
