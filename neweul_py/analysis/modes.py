"""Eigenvalues, eigenfrequencies, damping ratios and mode shapes (equations.md §1).

The eigenvalues ``λ`` come from the first-order pencil of the linear model,
``E ẋ = Ã x`` with ``E = diag(I, M0)``, ``Ã = [[0, I], [−Q, −P]]``, solved as a *generalized*
eigenproblem (QZ; ``M0`` need not be symmetric). For an oscillating mode
``λ = −ζ ω0 ± j ω0 √(1 − ζ²)``: the natural frequency is ``f = |λ| / 2π`` (Hz), the damping ratio
``ζ = −Re λ / |λ|`` and the damped frequency ``f_d = Im λ / 2π``. Each complex-conjugate pair is
reported once (``Im λ > 0``); real eigenvalues are aperiodic modes, eigenvalues with
``|λ| ≤ zero_tol · max|λ|`` rigid-body modes.

``undamped=True`` drops the velocity terms ``P`` (damping and gyroscopic): the eigenvalues of
the undamped pencil ``det(Q − ω² M0) = 0`` give the undamped natural frequencies ``ω0 = |λ|``,
also when the damped modes all come out overdamped (e.g. SID data with ``De = 0.01 Ke``, whose
higher modes are damped far beyond critical).
"""

from __future__ import annotations

import csv
import io
import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..atomic import atomic_savez, atomic_write
from ..errors import DataError, NeweulError
from ..files import load_npz
from .linearize import LinearModel, linearize
from .results import ResultDisplay, check_output_path

__all__ = ["SUFFIXES", "ModalResult", "modes"]

#: Suffixes of modal-result files (:meth:`ModalResult.save`).
SUFFIXES: tuple[str, ...] = (".csv", ".npz")


@dataclass(frozen=True, repr=False)
class ModalResult(ResultDisplay):
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
    undamped : bool
        Whether these are the modes of the undamped pencil (``P`` dropped).
    """

    eigenvalues: np.ndarray
    frequency_hz: np.ndarray
    damped_frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    kind: tuple[str, ...]
    shapes: np.ndarray
    coordinates: tuple[str, ...]
    undamped: bool = False

    def columns(self) -> dict[str, np.ndarray]:
        """One row per mode (all kinds): frequencies, damping, eigenvalue, kind, dominant
        coordinate and the real part of each shape entry."""
        cols: dict[str, np.ndarray] = {
            "frequency_hz": np.asarray(self.frequency_hz, dtype=float),
            "damping_ratio": np.asarray(self.damping_ratio, dtype=float),
            "damped_frequency_hz": np.asarray(self.damped_frequency_hz, dtype=float),
            "real_part": self.eigenvalues.real,
            "imag_part": self.eigenvalues.imag,
            "kind": np.array(self.kind, dtype=str),
            "dominant_coordinate": np.array(
                [self.dominant_coordinate(i) for i in range(len(self.kind))], dtype=str),
        }
        for r, c in enumerate(self.coordinates):
            cols[f"shape_{c}"] = self.shapes[r].real
        return cols

    def summary(self) -> str:
        """One line: counts of each kind and the lowest frequencies."""
        counts = ", ".join(f"{self.kind.count(k)} {k}" for k in ("oscillating", "aperiodic",
                                                                  "rigid") if k in self.kind)
        f = self.frequency_hz[self.oscillating][:4]
        more = " …" if self.oscillating.sum() > 4 else ""
        low = f"; f = {', '.join(f'{v:.4g}' for v in f)}{more} Hz" if f.size else ""
        what = "undamped modes" if self.undamped else "modes"
        return f"ModalResult({len(self.kind)} {what}: {counts or 'none'}{low})"

    def overdamped_note(self) -> str | None:
        """A one-line note when no mode oscillates and the aperiodic ones decay (all overdamped),
        so that the CSV (oscillating modes only) would be empty; None otherwise."""
        if self.oscillating.any() or "aperiodic" not in self.kind or self.unstable.any():
            return None  # an unstable point has its own warning (stability_warning)
        n = self.kind.count("aperiodic")
        return (f"all {n} non-rigid eigenvalues are real: every mode is overdamped (damping "
                "above critical), so there are no oscillating modes and the CSV has no rows; "
                "the undamped natural frequencies: --undamped (modes(..., undamped=True))")

    @property
    def oscillating(self) -> np.ndarray:
        """Boolean mask of the oscillating modes."""
        return np.array([k == "oscillating" for k in self.kind], dtype=bool)

    def dominant_coordinate(self, i: int) -> str:
        """Name of the coordinate with the largest amplitude in mode ``i``."""
        return self.coordinates[int(np.argmax(np.abs(self.shapes[:, i])))]

    def table(self) -> str:
        """A text table of all modes (a note line first for the undamped pencil)."""
        head = (
            f"{'mode':>4}  {'f [Hz]':>13}  {'f_d [Hz]':>13}  {'zeta':>10}  "
            f"{'Re(lambda)':>13}  {'Im(lambda)':>13}  {'kind':<11}  dominant"
        )
        rows = [head] if not self.undamped else [
            "# undamped pencil det(Q - w^2 M0) = 0 (damping and gyroscopic terms dropped)", head]
        for i, lam in enumerate(self.eigenvalues):
            rows.append(
                f"{i + 1:>4}  {self.frequency_hz[i]:>13.6g}  {self.damped_frequency_hz[i]:>13.6g}"
                f"  {self.damping_ratio[i]:>10.4g}  {lam.real:>13.6g}  {lam.imag:>13.6g}  "
                f"{self.kind[i]:<11}  {self.dominant_coordinate(i)}"
            )
        return "\n".join(rows)

    @property
    def unstable(self) -> np.ndarray:
        """Boolean mask of the modes that grow: ``Re λ > 0`` (beyond round-off; not rigid)."""
        scale = np.abs(self.eigenvalues).max(initial=0.0)
        return np.array(
            [k != "rigid" and lam.real > 1e-9 * scale
             for k, lam in zip(self.kind, self.eigenvalues, strict=True)],
            dtype=bool,
        )

    def stability_warning(self) -> str | None:
        """A one-line note when the operating point is unstable (None when it is not).

        Names the eigenvalues with positive real part, their kind and dominant coordinate; an
        unstable aperiodic mode has no row in the CSV (which lists oscillating modes only).
        """
        idx = np.flatnonzero(self.unstable)
        if not idx.size:
            return None
        parts = []
        for i in idx:
            lam = self.eigenvalues[i]
            value = f"{lam.real:+.6g}" if self.kind[i] != "oscillating" else (
                f"{lam.real:+.6g} ± {abs(lam.imag):.6g}j")
            parts.append(f"{value} ({self.kind[i]}, dominant {self.dominant_coordinate(i)})")
        return (
            "the operating point is unstable: eigenvalue(s) with positive real part "
            + ", ".join(parts)
            + "; small motions grow (the CSV lists oscillating modes only; another equilibrium: "
            "--start / y0)"
        )

    def _csv_text(self) -> str:
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
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
        return buf.getvalue()

    def to_csv(self, path: str | os.PathLike[str]) -> Path:
        """Write one row per oscillating mode, atomically.

        Columns: ``frequency_hz, damping_ratio, damped_frequency_hz, real_part, imag_part,
        dominant_coordinate``, then ``shape_<coordinate>`` (real part of the normalized shape).
        """
        return atomic_write(path, self._csv_text())

    def to_npz(self, path: str | os.PathLike[str]) -> Path:
        """Write *all* modes (also aperiodic and rigid ones) to an uncompressed ``.npz`` (no
        pickles), atomically: complex ``eigenvalues`` (k,) and ``shapes`` (n, k),
        ``frequency_hz``, ``damped_frequency_hz``, ``damping_ratio`` (NaN for rigid modes), and
        the string arrays ``kind`` and ``coordinates``. :meth:`load` reads it back."""
        return atomic_savez(
            path,
            eigenvalues=self.eigenvalues,
            frequency_hz=self.frequency_hz,
            damped_frequency_hz=self.damped_frequency_hz,
            damping_ratio=self.damping_ratio,
            kind=np.array(self.kind, dtype=str),
            shapes=self.shapes,
            coordinates=np.array(self.coordinates, dtype=str),
            undamped=np.array(self.undamped),
        )

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write ``.csv`` (:meth:`to_csv`, oscillating modes) or ``.npz`` (:meth:`to_npz`, all
        modes) by the suffix."""
        path = check_output_path(path, SUFFIXES, "modes")
        return self.to_npz(path) if path.suffix.lower() == ".npz" else self.to_csv(path)

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> ModalResult:
        """Read a ``.npz`` written by :meth:`to_npz`."""
        f = load_npz(path, "modes file")
        try:
            return cls(
                eigenvalues=f["eigenvalues"],
                frequency_hz=f["frequency_hz"],
                damped_frequency_hz=f["damped_frequency_hz"],
                damping_ratio=f["damping_ratio"],
                kind=tuple(str(k) for k in f["kind"]),
                shapes=f["shapes"],
                coordinates=tuple(str(c) for c in f["coordinates"]),
                undamped=bool(f["undamped"]) if "undamped" in f else False,
            )
        except (ValueError, KeyError) as exc:
            raise DataError(f"cannot read modes: {exc}", file=str(path)) from None


def modes(
    model: LinearModel | Any,
    *,
    zero_tol: float = 1e-7,
    undamped: bool = False,
    **linearize_kwargs: Any,
) -> ModalResult:
    """Modes of a linear model, or of a generated module linearized first.

    Parameters
    ----------
    model
        A :class:`~neweul_py.analysis.linearize.LinearModel`, or a generated module (then
        :func:`~neweul_py.analysis.linearize.linearize` is called with ``linearize_kwargs``).
    zero_tol
        Eigenvalues with ``|λ| ≤ zero_tol · max|λ|`` are rigid-body modes.
    undamped
        Eigenvalues of the undamped pencil (``P = 0``: damping and gyroscopic terms dropped),
        ``λ = ±j ω0`` with ``Q φ = ω0² M0 φ``; damping ratios are then 0.

    Returns
    -------
    ModalResult
        Modes sorted by natural frequency (equations.md §1, first-order form).

    Examples
    --------
    >>> print(modes(linearize(mod, equilibrium(mod))).table())      # doctest: +SKIP
    """
    lin = model if isinstance(model, LinearModel) else linearize(model, **linearize_kwargs)
    if undamped:
        lin = replace(lin, P=np.zeros_like(lin.P))
    m = lin.n
    if m == 0:
        raise NeweulError("modes: the model has no degrees of freedom")
    a, e = lin.first_order_pencil()
    import scipy.linalg as sla  # ~0.2 s of import: only here

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
    if undamped:  # exactly 0 (QZ leaves round-off real parts on the imaginary axis)
        zeta = np.where(kind == "oscillating", 0.0, zeta)
    return ModalResult(
        eigenvalues=lam,
        frequency_hz=mag / (2 * np.pi),
        damped_frequency_hz=np.abs(lam.imag) / (2 * np.pi),
        damping_ratio=zeta,
        kind=tuple(str(k) for k in kind),
        shapes=shapes,
        coordinates=lin.all_coordinates,
        undamped=undamped,
    )
