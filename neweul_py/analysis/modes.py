"""Eigenvalues, eigenfrequencies, damping ratios and mode shapes (equations.md §1).

The eigenvalues ``λ`` come from the first-order pencil of the linear model,
``E ẋ = Ã x`` with ``E = diag(I, M0)``, ``Ã = [[0, I], [−Q, −P]]``, solved as a *generalized*
eigenproblem (QZ; ``M0`` need not be symmetric). For an oscillating mode
``λ = −ζ ω0 ± j ω0 √(1 − ζ²)``: the natural frequency is ``f = |λ| / 2π`` (Hz), the damping ratio
``ζ = −Re λ / |λ|`` and the damped frequency ``f_d = Im λ / 2π``. Each complex-conjugate pair is
reported once (``Im λ > 0``); real eigenvalues are aperiodic modes, eigenvalues with
``|λ| ≤ zero_tol · max|λ|`` rigid-body modes.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import scipy.linalg as sla

from ..errors import NeweulError
from .linearize import LinearModel, linearize

__all__ = ["ModalResult", "modes"]


@dataclass(frozen=True)
class ModalResult:
    """Modes of a linear model, sorted by natural frequency.

    Attributes
    ----------
    eigenvalues : ndarray (k,) complex
        One eigenvalue per mode (the one with ``Im λ ≥ 0`` for a conjugate pair).
    frequency_hz : ndarray (k,)
        Natural frequencies ``|λ| / 2π``.
    damped_frequency_hz : ndarray (k,)
        ``Im λ / 2π``.
    damping_ratio : ndarray (k,)
        ``−Re λ / |λ|`` (NaN for rigid-body modes).
    kind : tuple of str
        ``"oscillating"``, ``"aperiodic"`` or ``"rigid"`` per mode.
    shapes : ndarray (n, k) complex
        Mode shapes in the module's full coordinates, scaled so that the largest entry is 1.
    coordinates : tuple of str
        Row names of ``shapes``.
    """

    eigenvalues: np.ndarray
    frequency_hz: np.ndarray
    damped_frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    kind: tuple[str, ...]
    shapes: np.ndarray
    coordinates: tuple[str, ...]

    @property
    def oscillating(self) -> np.ndarray:
        """Boolean mask of the oscillating modes."""
        return np.array([k == "oscillating" for k in self.kind], dtype=bool)

    def dominant_coordinate(self, i: int) -> str:
        """Name of the coordinate with the largest amplitude in mode ``i``."""
        return self.coordinates[int(np.argmax(np.abs(self.shapes[:, i])))]

    def table(self) -> str:
        """A text table of all modes."""
        head = (
            f"{'mode':>4}  {'f [Hz]':>13}  {'f_d [Hz]':>13}  {'zeta':>10}  "
            f"{'Re(lambda)':>13}  {'Im(lambda)':>13}  {'kind':<11}  dominant"
        )
        rows = [head]
        for i, lam in enumerate(self.eigenvalues):
            rows.append(
                f"{i + 1:>4}  {self.frequency_hz[i]:>13.6g}  {self.damped_frequency_hz[i]:>13.6g}"
                f"  {self.damping_ratio[i]:>10.4g}  {lam.real:>13.6g}  {lam.imag:>13.6g}  "
                f"{self.kind[i]:<11}  {self.dominant_coordinate(i)}"
            )
        return "\n".join(rows)

    def to_csv(self, path: str | Path) -> None:
        """Write one row per oscillating mode.

        Columns: ``frequency_hz, damping_ratio, damped_frequency_hz, real_part, imag_part,
        dominant_coordinate``, then ``shape_<coordinate>`` (real part of the normalized shape).
        """
        with open(path, "w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh)
            w.writerow(
                [
                    "frequency_hz",
                    "damping_ratio",
                    "damped_frequency_hz",
                    "real_part",
                    "imag_part",
                    "dominant_coordinate",
                    *(f"shape_{c}" for c in self.coordinates),
                ]
            )
            for i in np.flatnonzero(self.oscillating):
                lam = self.eigenvalues[i]
                w.writerow(
                    [
                        repr(float(self.frequency_hz[i])),
                        repr(float(self.damping_ratio[i])),
                        repr(float(self.damped_frequency_hz[i])),
                        repr(float(lam.real)),
                        repr(float(lam.imag)),
                        self.dominant_coordinate(i),
                        *(repr(float(v)) for v in self.shapes[:, i].real),
                    ]
                )


def modes(
    model: LinearModel | Any, *, zero_tol: float = 1e-7, **linearize_kwargs: Any
) -> ModalResult:
    """Modes of a linear model, or of a generated module linearized first.

    Parameters
    ----------
    model
        A :class:`~neweul_py.analysis.linearize.LinearModel`, or a generated module (then
        :func:`~neweul_py.analysis.linearize.linearize` is called with ``linearize_kwargs``).
    zero_tol
        Eigenvalues with ``|λ| ≤ zero_tol · max|λ|`` are rigid-body modes.

    Returns
    -------
    ModalResult
        Modes sorted by natural frequency (equations.md §1, first-order form).

    Examples
    --------
    >>> print(modes(linearize(mod, equilibrium(mod))).table())      # doctest: +SKIP
    """
    lin = model if isinstance(model, LinearModel) else linearize(model, **linearize_kwargs)
    m = lin.n
    if m == 0:
        raise NeweulError("modes: the model has no degrees of freedom")
    a, e = lin.first_order_pencil()
    lam, vec = sla.eig(a, e)
    finite = np.isfinite(lam)
    lam, vec = lam[finite], vec[:, finite]
    scale = np.abs(lam).max() if lam.size else 0.0
    mag = np.abs(lam)
    rigid = mag <= zero_tol * scale
    osc = ~rigid & (lam.imag > 1e-12 * mag)
    aper = ~rigid & (np.abs(lam.imag) <= 1e-12 * mag)
    keep = rigid | osc | aper
    lam, vec, mag = lam[keep], vec[:, keep], mag[keep]
    kind = np.where(rigid[keep], "rigid", np.where(osc[keep], "oscillating", "aperiodic"))
    order = np.lexsort((lam.imag, mag))
    lam, vec, mag, kind = lam[order], vec[:, order], mag[order], kind[order]
    shapes = lin.basis @ vec[:m]
    big = np.argmax(np.abs(shapes), axis=0)
    pivot = shapes[big, np.arange(shapes.shape[1])]
    pivot = np.where(np.abs(pivot) > 0, pivot, 1.0)
    shapes = shapes / pivot
    with np.errstate(invalid="ignore", divide="ignore"):
        zeta = np.where(kind == "rigid", np.nan, -lam.real / np.where(mag > 0, mag, 1.0)) + 0.0
    return ModalResult(
        eigenvalues=lam,
        frequency_hz=mag / (2 * np.pi),
        damped_frequency_hz=np.abs(lam.imag) / (2 * np.pi),
        damping_ratio=zeta,
        kind=tuple(str(k) for k in kind),
        shapes=shapes,
        coordinates=lin.all_coordinates,
    )
