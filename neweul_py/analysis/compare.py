"""Compare a result against a reference: time histories, frequency responses, equilibria and
modes, per signal, with tolerances and an overlay plot.

Criteria (``rtol``/``atol`` global or per signal):

- **time histories**: both series are brought onto the coarser of the two time grids inside
  their common span (the finer one is interpolated by a cubic spline); a signal passes when
  ``max |a − b| ≤ atol + rtol · max |b|`` (``b`` the reference: the error is relative to the
  signal's scale, so zero crossings do not inflate it);
- **frequency responses**: complex values (magnitude and phase together) on the common
  frequencies, pointwise ``|H − H_ref| ≤ atol + rtol · |H_ref|`` at every frequency — phase
  errors count; the table also gives the largest magnitude error in dB and phase error in
  degrees;
- **equilibria**: ``|a − b| ≤ atol + rtol · |b|`` per coordinate;
- **modes**: each reference mode is matched to one of ours by the assignment that maximizes
  the modal assurance criterion ``MAC = |φ_aᴴ φ_b|² / (φ_aᴴ φ_a · φ_bᴴ φ_b)`` (Allemang 2003)
  over the coordinates both files share and, as a tie-break (or alone, without shapes), the
  closeness of the frequencies; a mode passes when ``|f − f_ref| ≤ atol + rtol · f_ref`` and
  ``MAC ≥ mac_min``.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..atomic import atomic_write
from ..errors import DataError, NeweulError
from .compare_io import Table, as_table
from .results import ResultDisplay

__all__ = ["Comparison", "SignalError", "compare", "mac_matrix"]

Tolerance = float | Mapping[str, float]


@dataclass(frozen=True)
class SignalError:
    """The error of one signal (or mode, or coordinate).

    Attributes
    ----------
    name : str
    max_abs_error : float
        Largest ``|a − b|``.
    max_rel_error : float
        ``max_abs_error / max |b|`` (time histories) or the largest pointwise ``|a − b| / |b|``.
    at : float
        Time or frequency of the largest error (NaN for equilibria and modes).
    rtol, atol : float
        The tolerances applied.
    passed : bool
    note : str
        Extra figures (``"|ΔdB| 0.01, |Δphase| 0.2 deg"``, ``"MAC 0.999, ours #2"``).
    """

    name: str
    max_abs_error: float
    max_rel_error: float
    at: float
    rtol: float
    atol: float
    passed: bool
    note: str = ""


@dataclass(frozen=True, repr=False)
class Comparison(ResultDisplay):
    """A result compared against a reference, signal by signal.

    Attributes
    ----------
    kind : str
        ``time``, ``frequency``, ``equilibrium`` or ``modes``.
    errors : tuple of SignalError
    x : ndarray
        The common times or frequencies (empty for equilibria, mode numbers for modes).
    values : dict of str → (ndarray, ndarray)
        Ours and the reference on ``x``, per signal (for the plot).
    result, reference : str
        Where the two came from.
    units : dict of str → str
        Unit of each signal where either side knows it (the result's first).
    """

    kind: str
    errors: tuple[SignalError, ...]
    x: np.ndarray
    values: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    result: str = ""
    reference: str = ""
    units: dict[str, str] = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        """True when every signal is within its tolerance."""
        return all(e.passed for e in self.errors)

    @property
    def failed(self) -> list[str]:
        """Names of the signals outside their tolerance."""
        return [e.name for e in self.errors if not e.passed]

    def columns(self) -> dict[str, np.ndarray]:
        """The per-signal error table."""
        e = self.errors
        return {
            "signal": np.array([x.name for x in e], dtype=str),
            "max_abs_error": np.array([x.max_abs_error for x in e], dtype=float),
            "max_rel_error": np.array([x.max_rel_error for x in e], dtype=float),
            "at": np.array([x.at for x in e], dtype=float),
            "rtol": np.array([x.rtol for x in e], dtype=float),
            "atol": np.array([x.atol for x in e], dtype=float),
            "passed": np.array([x.passed for x in e], dtype=bool),
            "note": np.array([x.note for x in e], dtype=str),
        }

    def summary(self) -> str:
        """One line: kind, verdict, counts."""
        verdict = "PASS" if self.passed else f"FAIL ({', '.join(self.failed[:5])}" + (
            ", …)" if len(self.failed) > 5 else ")")
        ours = Path(self.result).name or "result"
        ref = Path(self.reference).name or "reference"
        return f"Comparison({self.kind}: {len(self.errors)} signals, {verdict}; {ours} vs {ref})"

    def table(self) -> str:
        """The per-signal error table as aligned text."""
        at = "t [s]" if self.kind == "time" else "f [Hz]"
        width = max([6, *(len(e.name) for e in self.errors)])
        lines = [f"{'signal':<{width}}  {'max |error|':>12}  {'relative':>10}  {'at ' + at:>12}"
                 f"  {'rtol':>8}  {'atol':>8}  verdict"]
        for e in self.errors:
            where = f"{e.at:12.6g}" if np.isfinite(e.at) else f"{'-':>12}"
            lines.append(f"{e.name:<{width}}  {e.max_abs_error:12.4g}  {e.max_rel_error:10.3g}  "
                         f"{where}  {e.rtol:8.2g}  {e.atol:8.2g}  "
                         f"{'ok' if e.passed else 'FAIL'}{'  ' + e.note if e.note else ''}")
        return "\n".join(lines)

    def to_csv(self, path: str | os.PathLike[str]) -> Path:
        """Write the error table (one row per signal; ``passed`` as 1/0), atomically."""
        cols = self.columns()
        names = list(cols)
        lines = [",".join(names)]
        for i in range(len(self.errors)):
            cells = []
            for n in names:
                v = cols[n][i]
                cells.append(str(v).replace(",", ";") if n in ("signal", "note")
                             else str(int(v)) if n == "passed" else f"{float(v):.10g}")
            lines.append(",".join(cells))
        return atomic_write(path, "\n".join(lines) + "\n")

    def plot(self, path: str | os.PathLike[str]) -> Path:
        """Overlay plot (ours solid, reference dashed) written to ``path`` (see
        :mod:`neweul_py.analysis.compare_plot`)."""
        from .compare_plot import plot_comparison

        return plot_comparison(self, path)


def _tol(tol: Tolerance, name: str, default: float) -> float:
    if isinstance(tol, Mapping):
        return float(tol.get(name, tol.get("*", default)))
    return float(tol)


def _select(a: Table, b: Table, signals: Sequence[str] | None) -> list[str]:
    if signals:
        for s in signals:
            for t in (a, b):
                if s not in t.signals:
                    raise DataError(f"no column {s!r}; columns are: {', '.join(t.signals)}",
                                    file=t.source)
        return list(signals)
    common = [s for s in b.signals if s in a.signals]
    if not common:
        raise DataError(f"no signal in common with {a.source} (reference columns: "
                        f"{', '.join(b.signals)}; ours: {', '.join(a.signals)})", file=b.source)
    return common


def _resample(x: np.ndarray, y: np.ndarray, onto: np.ndarray) -> np.ndarray:
    if np.array_equal(x, onto):
        return y
    if x.size >= 4:
        from scipy.interpolate import CubicSpline  # ~0.4 s: only when comparing

        return CubicSpline(x, y)(onto)
    return np.interp(onto, x, y.real) + (1j * np.interp(onto, x, y.imag)
                                         if np.iscomplexobj(y) else 0.0)


def _common_grid(a: Table, b: Table) -> np.ndarray:
    lo, hi = max(a.x[0], b.x[0]), min(a.x[-1], b.x[-1])
    span = max(abs(hi), abs(lo), 1e-300) * 1e-12
    if hi < lo - span:
        raise DataError(f"no common {'times' if a.kind == 'time' else 'frequencies'}: "
                        f"{a.x[0]:g} … {a.x[-1]:g} vs {b.x[0]:g} … {b.x[-1]:g}", file=b.source)
    ina = a.x[(a.x >= lo - span) & (a.x <= hi + span)]
    inb = b.x[(b.x >= lo - span) & (b.x <= hi + span)]
    return ina if ina.size <= inb.size else inb


def _on_grid(t: Table, name: str, grid: np.ndarray) -> np.ndarray:
    x = np.clip(grid, t.x[0], t.x[-1])  # round-off at the ends of the common span
    return _resample(t.x, t.signals[name], x)


def _series(a: Table, b: Table, names: list[str], rtol: Tolerance, atol: Tolerance,
            ) -> tuple[list[SignalError], np.ndarray, dict]:
    grid = _common_grid(a, b)
    out, values = [], {}
    for n in names:
        ya, yb = _on_grid(a, n, grid), _on_grid(b, n, grid)
        r, t = _tol(rtol, n, 1e-3), _tol(atol, n, 1e-12)
        err = np.abs(ya - yb)
        k = int(np.argmax(err))
        values[n] = (ya, yb)
        if a.kind == "time" and not np.iscomplexobj(yb):
            scale = float(np.max(np.abs(yb)))
            rel = err[k] / scale if scale > 0 else (0.0 if err[k] == 0 else np.inf)
            out.append(SignalError(n, float(err[k]), float(rel), float(grid[k]), r, t,
                                   bool(err[k] <= t + r * scale)))
            continue
        mag = np.abs(yb)
        with np.errstate(divide="ignore", invalid="ignore"):
            rel_k = np.where(mag > 0, err / mag, np.where(err == 0, 0.0, np.inf))
        k = int(np.argmax(rel_k))
        note = ""
        if np.iscomplexobj(ya) or np.iscomplexobj(yb):
            with np.errstate(divide="ignore", invalid="ignore"):
                db = np.abs(20 * np.log10(np.abs(ya) / mag))
                dph = np.abs(np.degrees(np.angle(ya / yb)))
            note = f"|dB| {np.nanmax(db):.3g}, |phase| {np.nanmax(dph):.3g} deg"
        out.append(SignalError(n, float(err.max()), float(rel_k[k]), float(grid[k]), r, t,
                               bool(np.all(err <= t + r * mag)), note))
    return out, grid, values


def _equilibrium(a: Table, b: Table, names: list[str], rtol: Tolerance, atol: Tolerance,
                 ) -> tuple[list[SignalError], np.ndarray, dict]:
    out, values = [], {}
    for n in names:
        va, vb = float(a.signals[n][0]), float(b.signals[n][0])
        r, t = _tol(rtol, n, 1e-6), _tol(atol, n, 1e-12)
        err = abs(va - vb)
        rel = err / abs(vb) if vb else (0.0 if err == 0 else np.inf)
        out.append(SignalError(n, err, rel, np.nan, r, t, err <= t + r * abs(vb)))
        values[n] = (np.array([va]), np.array([vb]))
    return out, np.zeros(0), values


def mac_matrix(pa: np.ndarray, pb: np.ndarray) -> np.ndarray:
    """Modal assurance criterion of every pair of columns of ``pa`` (n, ka) and ``pb``
    (n, kb): ``|φ_aᴴ φ_b|² / (φ_aᴴ φ_a · φ_bᴴ φ_b)`` (Allemang 2003), shape (ka, kb)."""
    num = np.abs(pa.conj().T @ pb) ** 2
    den = np.outer(np.sum(np.abs(pa) ** 2, axis=0), np.sum(np.abs(pb) ** 2, axis=0))
    return np.divide(num, den, out=np.zeros_like(num), where=den > 0)


def _modes(a: Table, b: Table, rtol: Tolerance, atol: Tolerance, mac_min: float,
           ) -> tuple[list[SignalError], np.ndarray, dict]:
    fa, fb = a.signals["f_hz"], b.signals["f_hz"]
    if fa.size == 0 or fb.size == 0:
        raise DataError("no oscillating modes to compare", file=(a if fa.size == 0 else b).source)
    with np.errstate(divide="ignore", invalid="ignore"):
        cost = np.abs(np.log(np.maximum(fa[:, None], 1e-300) / np.maximum(fb[None, :], 1e-300)))
    mac = None
    common = [c for c in b.coordinates if c in a.coordinates]
    if a.shapes is not None and b.shapes is not None and common:
        ia = [a.coordinates.index(c) for c in common]
        ib = [b.coordinates.index(c) for c in common]
        mac = mac_matrix(a.shapes[ia], b.shapes[ib])
        cost = (1.0 - mac) + 1e-3 * cost
    from scipy.optimize import linear_sum_assignment

    rows, cols = linear_sum_assignment(cost)
    match = dict(zip(cols.tolist(), rows.tolist(), strict=True))
    out = []
    for j in range(fb.size):
        name = f"mode{j + 1}"
        r, t = _tol(rtol, name, 1e-3), _tol(atol, name, 1e-12)
        if j not in match:
            out.append(SignalError(name, np.inf, np.inf, np.nan, r, t, False,
                                   f"no mode of ours left for {fb[j]:.6g} Hz"))
            continue
        i = match[j]
        err = abs(fa[i] - fb[j])
        ok = err <= t + r * fb[j]
        note = f"ours #{i + 1}: {fa[i]:.6g} Hz vs {fb[j]:.6g} Hz"
        if mac is not None:
            ok = ok and mac[i, j] >= mac_min
            note += f", MAC {mac[i, j]:.4f}"
        out.append(SignalError(name, float(err), float(err / fb[j]), np.nan, r, t, bool(ok),
                               note))
    paired = [match.get(j, -1) for j in range(fb.size)]
    ours = np.array([fa[i] if i >= 0 else np.nan for i in paired])
    return out, np.arange(1, fb.size + 1, dtype=float), {"f_hz": (ours, fb)}


def compare(
    result: Any,
    reference: Any,
    *,
    signals: Sequence[str] | None = None,
    rtol: Tolerance = 1e-3,
    atol: Tolerance = 1e-12,
    mac_min: float = 0.9,
) -> Comparison:
    """Compare ``result`` against ``reference`` signal by signal (criteria: module docstring).

    Parameters
    ----------
    result, reference
        ``.csv``/``.npz`` paths (ours or plain CSV from other tools: a header row of names,
        the first column time or frequency), result objects, or mappings of arrays (see
        :func:`~neweul_py.analysis.compare_io.as_table`).
    signals
        The signals to compare (default: every signal both have).
    rtol, atol
        Tolerances: one number, or a mapping signal → value (``"*"`` for the rest).
    mac_min
        Smallest MAC of a matched mode pair.

    Returns
    -------
    Comparison
        ``passed``, the per-signal ``errors``, ``table()``, ``plot(path)``.

    Raises
    ------
    DataError
        An unreadable file, a non-monotonic time/frequency column, NaN, a missing signal,
        different kinds of results, or no common span.

    Examples
    --------
    >>> cmp = compare("out/run.csv", "neweul_m2_run.csv", rtol={"phi": 1e-2, "*": 1e-3})
    ... # doctest: +SKIP
    >>> assert cmp.passed, cmp.table()                                   # doctest: +SKIP
    """
    a = as_table(result, "result")
    b = as_table(reference, "reference")
    if a.kind != b.kind:
        raise DataError(f"a {b.kind} reference cannot be compared with a {a.kind} result "
                        f"({a.source})", file=b.source)
    if a.kind == "modes":
        errors, x, values = _modes(a, b, rtol, atol, mac_min)
    else:
        names = _select(a, b, signals)
        fn = _equilibrium if a.kind == "equilibrium" else _series
        errors, x, values = fn(a, b, names, rtol, atol)
    if not errors:
        raise NeweulError("nothing to compare")
    return Comparison(kind=a.kind, errors=tuple(errors), x=x, values=values, result=a.source,
                      reference=b.source, units={**b.units, **a.units})
