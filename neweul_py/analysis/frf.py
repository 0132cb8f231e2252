"""Frequency responses of a linear model (equations.md §1).

``H(jω) = (Cy + jω Cyd − ω² Cydd) (−ω² M0 + jω P + Q)⁻¹ B + D`` for the selected outputs
(module outputs split into their position and velocity parts, coordinates ``y``, velocities
``d_y`` and accelerations ``dd_y``) and inputs, evaluated for all frequencies at once:

- ``"solve"``: one batched :func:`numpy.linalg.solve` on the stack of dynamic stiffness matrices
  (nf, n, n) — second-order form, backward stable, the default;
- ``"hessenberg"``: the first-order ``A`` is reduced once to Hessenberg form ``A = U H Uᵀ``; each
  frequency then costs ``O(N²)`` (``N = 2n``) by an elimination vectorized over frequencies;
- ``"eig"``: modal superposition ``H = C V (jω − Λ)⁻¹ V⁻¹ B + D``, ``O(N)`` per frequency, but
  only as accurate as the eigenvector matrix is well conditioned (not for defective systems).

``benchmarks/bench_frf.py`` compares them with a Python loop of ``numpy.linalg.solve`` calls.

Loss factors (equations.md §1.1): a model with a hysteretic matrix ``G`` is solved in the
loss-factor form ``(−ω² M0 + jω (P − G/ω_ref) + Q + jG)`` by default (``damping="loss"``,
``"solve"`` only: the form is not a constant first-order pencil); ``damping="viscous"`` gives
the time-domain equivalent ``−ω² M0 + jω P + Q``.
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..atomic import atomic_savez, atomic_write
from ..errors import DataError, NeweulError, SolverError
from ..files import load_npz
from . import protocol as proto
from .linearize import DAMPING_FORMS, LinearModel, linearize
from .plot import check_plot_path, new_figure, plot_bode, save_figure
from .results import ResultDisplay, check_output_path

__all__ = ["SUFFIXES", "FrequencyResponse", "dynamic_solve", "frequency_response",
           "frequency_vector", "frf"]

#: Suffixes of frequency-response files (:meth:`FrequencyResponse.save`).
SUFFIXES: tuple[str, ...] = (".csv", ".npz")

_CHUNK_BYTES = 64 * 2**20


@dataclass(frozen=True, repr=False)
class FrequencyResponse(ResultDisplay):
    """Frequency response ``H`` (nf, ny, nu) of outputs to inputs.

    Attributes
    ----------
    frequency_hz : ndarray (nf,)
    H : ndarray (nf, ny, nu) complex
    outputs, inputs : tuple of str
    """

    frequency_hz: np.ndarray
    H: np.ndarray
    outputs: tuple[str, ...]
    inputs: tuple[str, ...]

    @property
    def magnitude(self) -> np.ndarray:
        """``|H|`` (nf, ny, nu)."""
        return np.abs(self.H)

    @property
    def phase_deg(self) -> np.ndarray:
        """Phase in degrees, unwrapped along the frequency axis (nf, ny, nu)."""
        return np.degrees(np.unwrap(np.angle(self.H), axis=0))

    def _pairs(self) -> list[tuple[int, int, str]]:
        single = len(self.outputs) == 1 and len(self.inputs) == 1
        return [
            (i, j, "" if single else f"__{o}__{u}")
            for i, o in enumerate(self.outputs)
            for j, u in enumerate(self.inputs)
        ]

    def columns(self) -> dict[str, np.ndarray]:
        """``frequency_hz``, then ``magnitude``/``phase_deg`` per pair (the CSV columns)."""
        mag, ph = self.magnitude, self.phase_deg
        cols = {"frequency_hz": np.asarray(self.frequency_hz, dtype=float)}
        for i, j, sfx in self._pairs():
            cols[f"magnitude{sfx}"] = mag[:, i, j]
            cols[f"phase_deg{sfx}"] = ph[:, i, j]
        return cols

    def summary(self) -> str:
        """One line: sizes and frequency range."""
        f = np.asarray(self.frequency_hz)
        span = f"{f.min():g} … {f.max():g} Hz" if f.size else "no frequencies"
        return (f"FrequencyResponse({f.size} frequencies, {span}; outputs "
                f"{', '.join(self.outputs)}; inputs {', '.join(self.inputs)})")

    def _csv_text(self) -> str:
        pairs = self._pairs()
        mag, ph = self.magnitude, self.phase_deg
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        header = ["frequency_hz"]
        for _, _, sfx in pairs:
            header += [f"magnitude{sfx}", f"phase_deg{sfx}"]
        w.writerow(header)
        for k, f in enumerate(self.frequency_hz):
            row = [repr(float(f))]
            for i, j, _ in pairs:
                row += [repr(float(mag[k, i, j])), repr(float(ph[k, i, j]))]
            w.writerow(row)
        return buf.getvalue()

    def to_csv(self, path: str | os.PathLike[str]) -> Path:
        """Write ``frequency_hz, magnitude, phase_deg`` (one output and input), atomically.

        With several outputs or inputs the columns are ``magnitude__<output>__<input>`` and
        ``phase_deg__<output>__<input>`` for each pair (names that ``numpy.genfromtxt`` keeps
        as they are).
        """
        return atomic_write(path, self._csv_text())

    def to_npz(self, path: str | os.PathLike[str]) -> Path:
        """Write an uncompressed ``.npz`` (no pickles), atomically: ``frequency_hz`` (nf,),
        the complex ``H`` (nf, ny, nu), ``magnitude`` and ``phase_deg`` (unwrapped), and the
        string arrays ``outputs`` and ``inputs``. :meth:`load` reads it back."""
        return atomic_savez(
            path,
            frequency_hz=self.frequency_hz,
            H=self.H,
            magnitude=self.magnitude,
            phase_deg=self.phase_deg,
            outputs=np.array(self.outputs, dtype=str),
            inputs=np.array(self.inputs, dtype=str),
        )

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write ``.csv`` (:meth:`to_csv`) or ``.npz`` (:meth:`to_npz`) by the suffix."""
        path = check_output_path(path, SUFFIXES, "frequency responses")
        return self.to_npz(path) if path.suffix.lower() == ".npz" else self.to_csv(path)

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> FrequencyResponse:
        """Read a ``.npz`` written by :meth:`to_npz`."""
        f = load_npz(path, "frequency response file")
        try:
            return cls(
                frequency_hz=f["frequency_hz"],
                H=f["H"],
                outputs=tuple(str(s) for s in f["outputs"]),
                inputs=tuple(str(s) for s in f["inputs"]),
            )
        except (ValueError, KeyError) as exc:
            raise DataError(f"cannot read a frequency response: {exc}", file=str(path)) from None

    def plot(
        self, path: str | os.PathLike[str] | None = None, *, log_frequency: bool = True,
        output_units: dict[str, str] | None = None, input_units: dict[str, str] | None = None,
    ) -> Any:
        """Bode plot (magnitude with the unit output/input where the units are given, phase)
        with matplotlib (:func:`~neweul_py.analysis.plot.plot_bode`).

        With ``path`` the figure is built with the object API and written atomically in the
        format of the suffix (checked first, :func:`~neweul_py.analysis.plot.check_plot_path`);
        without, a pyplot figure is returned for interactive use.

        Raises
        ------
        NeweulError
            When matplotlib (the ``plot`` extra) is not installed, or the suffix is not a format
            it writes.
        """
        if path is not None:
            path = check_plot_path(path)
            fig = new_figure(figsize=(8, 6), layout="constrained")
        else:
            try:
                import matplotlib.pyplot as plt
            except ImportError:
                raise NeweulError(
                    "plotting needs matplotlib: pip install 'neweul-py[plot]'"
                ) from None
            fig = plt.figure(figsize=(8, 6), layout="constrained")
        plot_bode(self.frequency_hz, self.H, self.outputs, self.inputs, fig,
                  output_units=output_units, input_units=input_units,
                  log_frequency=log_frequency)
        if path is not None:
            save_figure(fig, path)
        return fig


def frequency_vector(spec: str, log: bool = False) -> np.ndarray:
    """Frequencies in Hz from ``"start:stop:count"`` (linear, or logarithmic with ``log``).

    A comma-separated list of values is also accepted.
    """
    try:
        if ":" in spec:
            start, stop, count = spec.split(":")
            a, b, k = float(start), float(stop), int(count)
            if k < 1 or b < a:
                raise ValueError
            if log:
                if a <= 0:
                    raise NeweulError(f"--log needs a positive start frequency, got {a:g}")
                return np.logspace(np.log10(a), np.log10(b), k)
            return np.linspace(a, b, k)
        return np.array([float(v) for v in spec.split(",")])
    except ValueError:
        raise NeweulError(
            f"frequency specification {spec!r}: expected start:stop:count (e.g. 10:10000:400) "
            "or a comma-separated list"
        ) from None


def _as_names(value: str | Sequence[str] | None, default: Sequence[str]) -> list[str]:
    if value is None:
        return list(default)
    if isinstance(value, str):
        return [value]
    return list(value)


def dynamic_solve(z: np.ndarray, rhs: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``Z(ω)⁻¹ rhs`` for a stack of dynamic stiffness matrices ``z`` (nf, m, m) at the angular
    frequencies ``w`` (nf,) (one batched :func:`numpy.linalg.solve`).

    Raises
    ------
    SolverError
        Naming the first frequency where ``Z(ω)`` is singular: an undamped resonance, or a
        free rigid-body motion at 0 Hz, where the response is infinite.
    """
    try:
        return np.linalg.solve(z, rhs)
    except np.linalg.LinAlgError:
        for k in range(z.shape[0]):
            try:
                np.linalg.solve(z[k], rhs[k])
            except np.linalg.LinAlgError:
                raise SolverError(
                    f"the dynamic stiffness is singular at f = {w[k] / (2 * np.pi):.10g} Hz: "
                    "an undamped resonance (or a free motion at 0 Hz), where the response "
                    "is infinite; add damping or leave that frequency out") from None
        raise


def _solve_second_order(lin, w, cy, cyd, cydd, d, b, damping="loss") -> np.ndarray:
    m = lin.n
    nf = w.size
    h = np.empty((nf, cy.shape[0], b.shape[1]), dtype=complex)
    chunk = max(1, _CHUNK_BYTES // max(1, 16 * m * m))
    for lo in range(0, nf, chunk):
        ww = w[lo : lo + chunk, None, None]
        z = lin.dynamic_stiffness(ww[:, 0, 0], damping)
        x = dynamic_solve(z, np.broadcast_to(b, (z.shape[0], m, b.shape[1])), ww[:, 0, 0])
        c = cy + 1j * ww * cyd - ww**2 * cydd
        h[lo : lo + chunk] = c @ x + d
    return h


def _first_order(lin, cy, cyd, cydd, b, basis):
    """First-order ``A``, ``B`` and, for outputs ``C_a x + jω C_b x + D`` in the coordinates
    ``x = basis · x̃``, the matrices ``C_a = [Cy, Cyd] · basis`` and ``C_b = Cydd · basis[m:]``
    (accelerations as ``jω`` times velocities, which avoids the cancellation of ``M⁻¹(B − Q x …)``
    at low frequencies)."""
    a, _, _, _ = lin.to_first_order()
    m = lin.n
    b1 = np.zeros((2 * m, b.shape[1]))
    b1[m:] = np.linalg.solve(lin.M0, b)
    ca = np.hstack([cy, cyd]) @ basis
    cb = cydd @ basis[m:]
    return a, b1, ca, cb


def _solve_eig(lin, w, cy, cyd, cydd, d, b) -> np.ndarray:
    a, _, _, _ = lin.to_first_order()
    lam, vec = np.linalg.eig(a)
    _, b1, ca, cb = _first_order(lin, cy, cyd, cydd, b, vec)
    vb = np.linalg.solve(vec, b1)
    res = 1.0 / (1j * w[:, None] - lam[None, :])
    h = np.einsum("ok,fk,ki->foi", ca, res, vb)
    if np.any(cb):
        h += 1j * w[:, None, None] * np.einsum("ok,fk,ki->foi", cb, res, vb)
    return h + d


def _solve_hessenberg(lin, w, cy, cyd, cydd, d, b) -> np.ndarray:
    a, _, _, _ = lin.to_first_order()
    import scipy.linalg as sla  # ~0.2 s of import: only here

    hmat, u = sla.hessenberg(a, calc_q=True)
    _, b1, ca, cb = _first_order(lin, cy, cyd, cydd, b, u)
    bt = u.T @ b1
    big_n = a.shape[0]
    nf = w.size
    out = np.empty((nf, ca.shape[0], b1.shape[1]), dtype=complex)
    chunk = max(1, _CHUNK_BYTES // max(1, 16 * big_n * big_n))
    for lo in range(0, nf, chunk):
        ww = w[lo : lo + chunk, None, None]
        x = _hessenberg_shifted_solve(hmat, 1j * ww[:, 0, 0], bt)
        out[lo : lo + chunk] = ca @ x + 1j * ww * (cb @ x) + d
    return out


def _hessenberg_shifted_solve(hmat: np.ndarray, s: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Solve ``(s_k I − H) X_k = R`` for all shifts ``s_k`` (H upper Hessenberg); (nf, N, k).

    Gaussian elimination with partial pivoting between neighbouring rows (the only non-zero
    below the diagonal), vectorized over the shifts: ``O(N²)`` per shift. The shifts are the
    last (contiguous) axis of the work arrays.
    """
    big_n = hmat.shape[0]
    nf = s.size
    t = np.empty((big_n, big_n, nf), dtype=complex)
    t[...] = -hmat[:, :, None]
    idx = np.arange(big_n)
    t[idx, idx, :] += s[None, :]
    r = np.empty((big_n, rhs.shape[1], nf), dtype=complex)
    r[...] = rhs[:, :, None]
    for j in range(big_n - 1):
        top, bot = t[j, j:], t[j + 1, j:]
        swap = np.abs(bot[0]) > np.abs(top[0])
        new_top = np.where(swap, bot, top)
        new_bot = np.where(swap, top, bot)
        piv = new_top[0]
        if np.any(piv == 0):
            raise NeweulError("frequency response: singular dynamic matrix at a frequency")
        factor = new_bot[0] / piv
        t[j, j:] = new_top
        t[j + 1, j:] = new_bot - factor * new_top
        r_top = np.where(swap, r[j + 1], r[j])
        r_bot = np.where(swap, r[j], r[j + 1])
        r[j] = r_top
        r[j + 1] = r_bot - factor * r_top
    x = np.empty_like(r)
    for j in range(big_n - 1, -1, -1):
        acc = r[j] - np.einsum("kf,kif->if", t[j, j + 1 :], x[j + 1 :])
        x[j] = acc / t[j, j]
    return np.moveaxis(x, -1, 0)


_METHODS = {"solve": _solve_second_order, "eig": _solve_eig, "hessenberg": _solve_hessenberg}


def frequency_response(
    model: LinearModel | Any,
    f: Sequence[float] | np.ndarray,
    inputs: str | Sequence[str] | None = None,
    outputs: str | Sequence[str] | None = None,
    *,
    method: str = "solve",
    damping: str = "loss",
    **linearize_kwargs: Any,
) -> FrequencyResponse:
    """Frequency response of outputs to inputs over the frequencies ``f`` (Hz).

    Parameters
    ----------
    model
        A :class:`~neweul_py.analysis.linearize.LinearModel`, or a generated module (linearized
        first with ``linearize_kwargs``).
    f
        Frequencies in Hz.
    inputs
        Input name(s) (default: all inputs of the model). The entries of ``INPUT_RATES`` (the
        time derivatives of a kinematic excitation) are not inputs of their own: they enter
        through their input and are rejected here.
    outputs
        Output name(s): module outputs, coordinates, ``d_<coordinate>`` or ``dd_<coordinate>``
        (default: all module outputs, or all coordinates when the module has none).
    method
        ``"solve"`` (default), ``"hessenberg"`` or ``"eig"`` (see the module docstring).
    damping
        ``"loss"`` (default): the loss factors of a model with a hysteretic matrix ``G`` as
        ``K + iG`` (module docstring; ``"solve"`` only); ``"viscous"``: the time-domain
        equivalent ``G/ω_ref``. Models without loss factors give the same either way.

    Returns
    -------
    FrequencyResponse
        ``H(jω) = C(−ω² M0 + jω P + Q)⁻¹ B + D`` (equations.md §1; with loss factors
        ``C(−ω² M0 + jω (P − G/ω_ref) + Q + jG)⁻¹ B + D``, §1.1) for every frequency;
        for an input that moves frames (``INPUT_RATES``), ``B = B_u + jω B_du − ω² B_ddu``
        and likewise ``D``.

    Examples
    --------
    >>> fr = frequency_response(lin, np.logspace(1, 4, 400), "p_ec", "d_stapes")  # doctest: +SKIP
    >>> fr.to_csv("frf.csv")                                                     # doctest: +SKIP
    """
    lin = model if isinstance(model, LinearModel) else linearize(model, **linearize_kwargs)
    if method not in _METHODS:
        raise NeweulError(f"unknown frequency-response method {method!r}; valid: solve, "
                          "hessenberg, eig")
    rates = dict(lin.input_rates)
    rate_of = {r: nm for nm, rs in rates.items() for r in rs}
    valid = [nm for nm in lin.inputs if nm not in rate_of]
    in_names = _as_names(inputs, valid)
    out_names = _as_names(outputs, lin.outputs or lin.all_coordinates)
    if not in_names:
        raise NeweulError("frequency response: the model has no inputs")
    for nm in in_names:
        if nm in rate_of:
            raise NeweulError(
                f"input {nm!r} is a time derivative of the input {rate_of[nm]!r}: rates are "
                f"folded in automatically (B_u + jω B_du − ω² B_ddu); valid inputs: "
                f"{', '.join(valid)}"
            )
        proto.name_index(valid, nm, "input")
    cols = lin.input_columns(in_names)
    cy, cyd, cydd, d_all = lin.output_rows(out_names)
    freq = np.asarray(f, dtype=float).reshape(-1)
    w = 2 * np.pi * freq
    if damping not in DAMPING_FORMS:
        raise NeweulError(f"unknown damping form {damping!r}; valid: {', '.join(DAMPING_FORMS)}")
    if damping == "loss" and lin.has_loss:
        if method != "solve":
            raise NeweulError(f"the loss-factor form (K + iG) needs the method 'solve', not "
                              f"{method!r} (or damping 'viscous', the time-domain equivalent)")

        def solve(lin, w, cy, cyd, cydd, d, b):
            return _solve_second_order(lin, w, cy, cyd, cydd, d, b, "loss")
    elif method == "solve":
        def solve(lin, w, cy, cyd, cydd, d, b):
            return _solve_second_order(lin, w, cy, cyd, cydd, d, b, "viscous")
    else:
        solve = _METHODS[method]
    h = solve(lin, w, cy, cyd, cydd, d_all[:, cols], lin.B[:, cols])
    # Kinematic excitation: an input u with rate entries d_u, dd_u acts harmonically through
    # B_u + jω B_du − ω² B_ddu (and likewise D); H is linear in B, so add (jω)^k H_k.
    for order in (1, 2):
        rate_cols = [
            lin.input_columns([rates[nm][order - 1]])[0] if len(rates.get(nm, ())) >= order
            else -1
            for nm in in_names
        ]
        if all(c < 0 for c in rate_cols):
            continue
        b_k = np.zeros((lin.n, len(in_names)))
        d_k = np.zeros((d_all.shape[0], len(in_names)))
        for i, c in enumerate(rate_cols):
            if c >= 0:
                b_k[:, i] = lin.B[:, c]
                d_k[:, i] = d_all[:, c]
        h = h + (1j * w[:, None, None]) ** order * solve(lin, w, cy, cyd, cydd, d_k, b_k)
    return FrequencyResponse(
        frequency_hz=freq, H=h, outputs=tuple(out_names), inputs=tuple(in_names)
    )


#: Short alias of :func:`frequency_response`.
frf = frequency_response
