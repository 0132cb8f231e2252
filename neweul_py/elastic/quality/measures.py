"""Error and quality measures of reduced models: FRFs, relative errors, eigenvalues, stability.

Frequency response (``docs/equations.md`` §1, last line, for the second-order form)::

    H(jω) = C (K + jωD − ω²M)⁻¹ B

Full model (``method``): ``"sweep"`` (default for more than a handful of frequencies) —
adaptive two-sided rational interpolation whose error is measured by full solves
(:func:`~neweul_py.elastic.quality.frf_sweep.frf_sweep`: the middle-ear model at refine 1, 200
frequencies 100 Hz–10 kHz, 14 sparse LUs and about 9 s CPU instead of 200 LUs and 375 s CPU,
error ≤ 1e-6 against the direct solves at every frequency); ``"direct"`` — one sparse LU per
frequency (the pattern of ``K + jωD − ω²M`` is fixed, so only the values are recombined),
reused for all input columns — or, with fewer outputs than inputs, the transposed solve with
``Cᵀ``. Reduced model: all frequencies at once
with one batched dense solve (``numpy.linalg.solve`` on an (nf, r, r) stack).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sps

from ...errors import DataError
from ...ffrf.loss_form import DAMPING_FORMS, loss_form
from ...progress import report
from ..bodies.reduced import ReducedBody
from ..fe_model import FEModel
from ..io.npz import atomic_write
from ..reductors.eigen import ShiftInvert, SparseLU, default_shift, frequencies_hz, right_blocks
from ..reductors.projection import Progress
from .frf_sweep import SweepResult, frequency_form, frf_sweep

__all__ = [
    "FRF_METHODS",
    "FRFComparison",
    "Stability",
    "check_source",
    "compare_eigenvalues",
    "compare_frf",
    "frf_full",
    "frf_full_checked",
    "frf_reduced",
    "max_relative_error",
    "reduced_eigenvalues",
    "relative_error",
    "retained_band_hz",
    "right_half_plane_poles",
    "second_order_poles",
    "stability",
]


#: Methods of :func:`frf_full` (module docstring).
FRF_METHODS = ("auto", "sweep", "direct")
#: Target relative error of the checked sweep.
SWEEP_RTOL = 1e-6


def _common_pattern(mats: Sequence[sps.spmatrix]) -> tuple[sps.csc_matrix, list[np.ndarray]]:
    """A CSC pattern (sorted) holding all ``mats``, and each matrix's values on it."""
    n = mats[0].shape[0]
    coos = [sps.coo_matrix(a) for a in mats]
    keys = [c.col.astype(np.int64) * n + c.row for c in coos]  # CSC order: column, then row
    union = np.unique(np.concatenate(keys))
    indptr = np.searchsorted(union // n, np.arange(n + 1))
    pattern = sps.csc_matrix((np.ones(union.size), union % n, indptr), shape=(n, n))
    values = []
    for c, k in zip(coos, keys, strict=True):
        v = np.zeros(union.size, dtype=np.result_type(c.data, np.float64))
        np.add.at(v, np.searchsorted(union, k), c.data)
        values.append(v)
    return pattern, values


def frf_full(
    fe: FEModel,
    frequencies_hz: np.ndarray,
    inputs: Sequence[str] | str | None = None,
    outputs: Sequence[str] | str | None = None,
    progress: Progress = None,
    method: str = "auto",
    rtol: float = SWEEP_RTOL,
    damping: str = "loss",
) -> np.ndarray:
    """Frequency response of the full FE model (checked fast sweep or direct solves).

    Parameters
    ----------
    fe
        The FE model.
    frequencies_hz
        (nf,) frequencies in Hz.
    inputs, outputs
        Names (default: all).
    progress
        Called every ~10 % (direct) or after every full solve (sweep) with a message.
    method
        ``"sweep"``, ``"direct"`` or ``"auto"`` (module docstring); :func:`frf_full_checked`
        also returns the measured errors of the sweep.
    rtol
        Target relative error of the sweep.
    damping
        ``"loss"`` (default): ``K + iG + jω(D − G/ω_ref) − ω²M`` for a model with a hysteretic
        matrix ``G`` (loss factors, ``docs/equations.md`` §1.1); ``"viscous"``: ``K + jωD −
        ω²M`` (the time-domain equivalent). Without ``G`` both are the same.

    Returns
    -------
    numpy.ndarray
        (nf, n_out, n_in) complex ``H(j2πf)``.
    """
    return frf_full_checked(fe, frequencies_hz, inputs, outputs, progress, method, rtol,
                            damping)[0]


def frf_full_checked(
    fe: FEModel,
    frequencies_hz: np.ndarray,
    inputs: Sequence[str] | str | None = None,
    outputs: Sequence[str] | str | None = None,
    progress: Progress = None,
    method: str = "auto",
    rtol: float = SWEEP_RTOL,
    damping: str = "loss",
) -> tuple[np.ndarray, SweepResult | None]:
    """:func:`frf_full` and the :class:`~neweul_py.elastic.quality.frf_sweep.SweepResult` of a sweep
    (``None`` for direct solves)."""
    if method not in FRF_METHODS:
        raise DataError(f"must be one of {', '.join(FRF_METHODS)}, got {method!r}", None,
                        "method")
    fe = frequency_form(fe, damping)
    f = np.atleast_1d(np.asarray(frequencies_hz, dtype=np.float64))
    if method != "direct" and f.size > 5:
        res = frf_sweep(fe, f, inputs, outputs, rtol=rtol, progress=progress)
        return res.H, res
    return _frf_direct(fe, f, inputs, outputs, progress), None


def _frf_direct(fe: FEModel, f: np.ndarray, inputs: Sequence[str] | str | None,
                outputs: Sequence[str] | str | None, progress: Progress) -> np.ndarray:
    B, C = fe.B(inputs), fe.C(outputs)
    mats = [fe.K, fe.M] + ([fe.D] if fe.D is not None else [])
    pattern, vals = _common_pattern(mats)
    H = np.empty((f.size, C.shape[0], B.shape[1]), dtype=np.complex128)
    step = max(1, f.size // 10)
    for i, w in enumerate(2 * np.pi * f):  # one sparse factorization per frequency
        data = vals[0] - w**2 * vals[1]
        if fe.D is not None:
            data = data + 1j * w * vals[2]
        A = sps.csc_matrix((data, pattern.indices, pattern.indptr), shape=pattern.shape)
        try:
            lu = SparseLU(A)
        except RuntimeError:
            raise DataError(f"K + jωD − ω²M is singular at {f[i]:g} Hz (an undamped "
                            "resonance?)", fe.source, "K") from None
        if B.shape[1] <= C.shape[0]:
            H[i] = C @ lu.solve(B)
        else:
            H[i] = lu.solve(C.T, transpose=True).T @ B
        if (i + 1) % step == 0:
            report(progress, f"full FRF: {i + 1}/{f.size} frequencies", i + 1, f.size)
    return H


def frf_reduced(
    body: ReducedBody,
    frequencies_hz: np.ndarray,
    inputs: Sequence[str] | str | None = None,
    outputs: Sequence[str] | str | None = None,
    damping: str = "loss",
) -> np.ndarray:
    """Frequency response of a reduced body, all frequencies in one batched solve.

    ``damping`` as in :func:`frf_full`: for a body with a hysteretic matrix ``G_r`` the
    default is the loss-factor form ``K_r + iG_r + jω(D_r − G_r/ω_ref) − ω²M_r``.

    Returns
    -------
    numpy.ndarray
        (nf, n_out, n_in) complex ``C_r (K_r + jωD_r − ω²M_r)⁻¹ B_r``.
    """
    f = np.atleast_1d(np.asarray(frequencies_hz, dtype=np.float64))
    bi = _pick(body.input_names, inputs, "inputs")
    co = _pick(body.output_names, outputs, "outputs")
    if damping not in DAMPING_FORMS:
        raise DataError(f"must be one of {', '.join(DAMPING_FORMS)}, got {damping!r}", None,
                        "damping")
    K, D = body.K, body.D
    if damping == "loss" and body.G is not None:        # K + iG + jω(D − G/ω_ref)
        K, D = loss_form(K, D, body.G, body.loss_reference_frequency)
    w = 2 * np.pi * f[:, None, None]
    A = K[None] + 1j * w * D[None] - w**2 * body.M[None]
    X = np.linalg.solve(A, np.broadcast_to(body.B[:, bi], (f.size, *body.B[:, bi].shape)))
    return body.C[co] @ X


def _pick(names: tuple[str, ...], want: Sequence[str] | str | None, what: str) -> list[int]:
    if want is None:
        return list(range(len(names)))
    want = [want] if isinstance(want, str) else list(want)
    missing = [n for n in want if n not in names]
    if missing:
        raise DataError(f"unknown {what} {missing} (known: {', '.join(names)})", None, what)
    return [names.index(n) for n in want]


def relative_error(H_full: np.ndarray, H_red: np.ndarray) -> np.ndarray:
    """Relative error per frequency ``‖H − H_r‖_F / ‖H‖_F`` over the (out, in) block."""
    num = np.linalg.norm((H_full - H_red).reshape(H_full.shape[0], -1), axis=1)
    den = np.linalg.norm(H_full.reshape(H_full.shape[0], -1), axis=1)
    return num / np.where(den > 0, den, 1.0)


def max_relative_error(frequencies_hz: np.ndarray, H_full: np.ndarray, H_red: np.ndarray,
                       band: tuple[float, float] | None = None) -> float:
    """Maximum of :func:`relative_error` over the frequencies in ``band`` (default: all)."""
    f = np.asarray(frequencies_hz)
    err = relative_error(H_full, H_red)
    if band is not None:
        err = err[(f >= band[0]) & (f <= band[1])]
    return float(err.max()) if err.size else 0.0


def reduced_eigenvalues(body: ReducedBody) -> np.ndarray:
    """Eigenvalues ``λ = ω²`` of the reduced undamped pencil ``(K_r, M_r)``, sorted."""
    lam = sla.eigvals(body.K, body.M)
    return lam[np.lexsort((lam.imag, lam.real))]


def compare_eigenvalues(fe: FEModel, body: ReducedBody, count: int | None = None,
                        shift: float | None = None) -> dict[str, np.ndarray]:
    """Lowest eigenvalues of the full pencil vs. the reduced one.

    Returns
    -------
    dict
        ``full``, ``reduced`` (both ``λ``, the lowest ``count``, default the reduced order),
        ``frequency_full_hz``, ``frequency_reduced_hz`` and ``relative_error``
        ``|λ_r − λ| / max(|λ|, ·)``.
    """
    count = count or body.order
    si = ShiftInvert(fe.K, fe.M, default_shift(fe) if shift is None else shift, fe.source)
    blocks = right_blocks(si, min(count + 2, fe.n_dofs - 2), fe.source)
    full = np.sort(np.concatenate([b.values for b in blocks]).real)[:count]
    red = reduced_eigenvalues(body)[:count]
    scale = np.maximum(np.abs(full), 1e-12 * np.abs(full).max())
    return {
        "full": full, "reduced": red,
        "frequency_full_hz": frequencies_hz(full),
        "frequency_reduced_hz": frequencies_hz(red),
        "relative_error": np.abs(red[: full.size] - full[: red.size]) / scale[: red.size],
    }


@dataclass(frozen=True)
class Stability:
    """Result of :func:`stability`: poles of the first-order form and the verdict."""

    poles: np.ndarray
    max_real_part: float
    stable: bool


def second_order_poles(M: np.ndarray, D: np.ndarray | None, K: np.ndarray) -> np.ndarray:
    """Finite poles ``s`` of ``M q̈ + D q̇ + K q = 0`` (any square dense matrices).

    The coordinates are first scaled to ``diag M = 1`` (``q = S q̂``, a congruence: the
    poles are unchanged); with a well-conditioned ``M̂`` the poles are the eigenvalues of the
    standard first-order matrix ``[[0, I], [−M̂⁻¹K̂, −M̂⁻¹D̂]]`` (LAPACK ``geev``, which
    balances), else of the generalized problem ``[[I,0],[0,M]] s z = [[0,I],[−K,−D]] z``
    (QZ; a singular ``M`` gives infinite eigenvalues, which are dropped). Reduced u–p bodies
    span many decades (structural rows in strain-energy units, pressure rows in acoustic
    ones): there QZ on the unscaled pencil returned right-half-plane poles of round-off
    (``Re s = 2.8e4`` at ``|s| = 3e6`` on the string–cavity test model) where the scaled standard
    form gives −3e-9, as the energy argument of the u–p form requires.
    """
    M, K = np.asarray(M, dtype=np.float64), np.asarray(K, dtype=np.float64)
    r = M.shape[0]
    D = np.zeros((r, r)) if D is None else np.asarray(D, dtype=np.float64)
    d = np.abs(np.diag(M))
    d = np.where(d > 0, 1.0 / np.sqrt(np.where(d > 0, d, 1.0)), 1.0)
    Ms, Ds, Ks = (d[:, None] * X * d[None, :] for X in (M, D, K))
    eye, zero = np.eye(r), np.zeros((r, r))
    if r and np.linalg.cond(Ms) < 1e12:
        A = np.block([[zero, eye], [-np.linalg.solve(Ms, Ks), -np.linalg.solve(Ms, Ds)]])
        s = np.linalg.eigvals(A)
    else:
        A = np.block([[zero, eye], [-Ks, -Ds]])
        E = np.block([[eye, zero], [zero, Ms]])
        s = sla.eigvals(A, E)
    return s[np.isfinite(s)]


#: Poles with ``|s| ≤ ZERO_POLE_RTOL · max|s|`` belong to ``λ = 0`` modes (free rigid motion,
#: constant pressure of a closed air volume): their double pole ``s = 0`` (a Jordan block,
#: no restoring force and no damping of that mode) splits under round-off ``ε`` into
#: ``±√ε``-sized real poles (measured: +0.0026 1/s with ``max|s|`` = 1e5 on the string–cavity
#: model), which are marginal, not unstable.
ZERO_POLE_RTOL = 1e-6


def _unstable(s: np.ndarray, rtol: float) -> np.ndarray:
    scale = float(np.abs(s).max()) if s.size else 1.0
    return (s.real > rtol * scale) & (np.abs(s) > ZERO_POLE_RTOL * scale)


def right_half_plane_poles(M: np.ndarray, D: np.ndarray | None, K: np.ndarray,
                           rtol: float = 1e-8) -> np.ndarray:
    """Poles with ``Re s > rtol · max|s|`` of ``M q̈ + D q̇ + K q = 0``, largest real part
    first — for a reduced body (``body.M, body.D, body.K``) or a coupled linearized EMBS
    (its mass, damping and stiffness matrices, e.g. from ``analysis.linearize``).
    Undamped poles on the imaginary axis (within ``rtol``) and the round-off split of the
    double zero poles of ``λ = 0`` modes (:data:`ZERO_POLE_RTOL`) do not count."""
    s = second_order_poles(M, D, K)
    if not s.size:
        return s
    bad = s[_unstable(s, rtol)]
    return bad[np.argsort(-bad.real)]


def stability(body: ReducedBody, rtol: float = 1e-8) -> Stability:
    """Stability of ``M_r q̈ + D_r q̇ + K_r q = 0`` from the poles of its first-order form.

    Poles ``s`` from :func:`second_order_poles`. The model counts as stable when no pole
    has ``Re s > rtol · max|s|`` (undamped models have poles on the imaginary axis, which is
    accepted; any pole clearly in the right half plane is not), except the round-off split
    of the double zero poles of ``λ = 0`` modes (:data:`ZERO_POLE_RTOL`; ``max_real_part``
    still reports them).
    """
    s = second_order_poles(body.M, body.D, body.K)
    mx = float(s.real.max()) if s.size else -np.inf
    return Stability(s, mx, not bool(_unstable(s, rtol).any()))


@dataclass(frozen=True, eq=False)
class FRFComparison:
    """Full vs. reduced frequency response of one input–output pair (:func:`compare_frf`).

    ``band_hz`` is the top of the reduced body's retained band (its highest retained
    eigenfrequency, ``None`` when the body records no eigenvalues): above it the reduced
    model is not meant to be accurate, so errors there are reported apart (``in_band``).
    ``full_checked_error`` is the largest relative error of the full FRF that the sweep
    measured by full solves (``None`` for direct solves).
    """

    frequencies_hz: np.ndarray
    full: np.ndarray
    reduced: np.ndarray
    input: str
    output: str
    band_hz: float | None = None
    full_checked_error: float | None = None

    @property
    def relative_error(self) -> np.ndarray:
        """``|H − H_r| / |H|`` per frequency."""
        return relative_error(self.full[:, None, None], self.reduced[:, None, None])

    @property
    def max_relative_error(self) -> float:
        return float(self.relative_error.max()) if self.full.size else 0.0

    @property
    def in_band(self) -> np.ndarray:
        """(nf,) bool: the frequency lies inside the retained band (all, without a band)."""
        if self.band_hz is None:
            return np.ones(self.frequencies_hz.size, dtype=bool)
        return self.frequencies_hz <= self.band_hz

    @property
    def max_error_in_band(self) -> float:
        err = self.relative_error[self.in_band]
        return float(err.max()) if err.size else 0.0

    def to_csv(self, path: str | os.PathLike) -> None:
        """Write ``frequency_hz, full_magnitude, reduced_magnitude, relative_error,
        in_band`` (atomic; ``in_band`` 1 inside the retained band, 0 above it)."""
        table = np.column_stack([self.frequencies_hz, np.abs(self.full), np.abs(self.reduced),
                                 self.relative_error, self.in_band.astype(float)])
        header = "frequency_hz,full_magnitude,reduced_magnitude,relative_error,in_band"

        def write(fh) -> None:
            np.savetxt(fh, table, delimiter=",", header=header, comments="",
                       fmt=["%.17g"] * 4 + ["%d"])

        atomic_write(path, write)


def retained_band_hz(body: ReducedBody) -> float | None:
    """Highest retained eigenfrequency [Hz] of a body (``None`` without eigenvalues)."""
    lam = body.eigenvalues
    if lam is None or not np.size(lam):
        return None
    return float(np.max(frequencies_hz(np.asarray(lam))))


def check_source(fe: FEModel, body: ReducedBody, file: str | None = None) -> None:
    """Refuse a body that was not reduced from ``fe``: comparing them would be meaningless.

    Compared with what the body records in ``source`` (absent entries are not checked, e.g.
    bodies of older files): the number of DOFs, the structure kind, the FE-model
    fingerprint (:attr:`FEModel.fingerprint`: matrices, nodes, DOF map, inputs, outputs,
    density); and always the kept DOFs' node ids and kinds against the model's DOF map.
    The model's name and file may differ (a renamed or moved model is the same model).

    Raises
    ------
    DataError
        Naming ``file`` (the body's file, if given) and the item ``source``.
    """
    src, model = body.source, fe.source or "the FE model"
    n = src.get("n_dofs")
    if n is not None and n != fe.n_dofs:
        raise DataError(f"the body was reduced from a model with {n} DOFs, {model} has "
                        f"{fe.n_dofs}", file, "source")
    kind = src.get("kind")
    if kind is not None and kind != fe.kind:
        raise DataError(f"the body was reduced from a {kind!r} model, {model} is "
                        f"{fe.kind!r}", file, "source")
    k = body.kept_dofs
    if k.size and (k.min() < 0 or k.max() >= fe.n_dofs
                   or not np.array_equal(fe.dof_node[k], body.dof_node)
                   or not np.array_equal(fe.dof_kind[k], body.dof_kind)):
        raise DataError(f"the body's kept DOFs (node, kind) do not match the DOF map of "
                        f"{model}", file, "source")
    fp = src.get("fingerprint")
    if fp is not None and fp != fe.fingerprint:
        raise DataError(f"the body was reduced from a different FE model (matrices, nodes, "
                        f"DOF map, inputs/outputs or density differ: fingerprint "
                        f"{str(fp)[:12]}… vs {fe.fingerprint[:12]}… of {model})", file,
                        "source")


def compare_frf(
    fe: FEModel,
    body: ReducedBody,
    frequencies_hz: np.ndarray,
    input: str,
    output: str,
    progress: Progress = None,
    check: bool = True,
    method: str = "auto",
    damping: str = "loss",
) -> FRFComparison:
    """FRF of ``fe`` (:func:`frf_full` with ``method``) and of ``body`` (batched dense) for
    one input/output.

    ``check`` (default): first :func:`check_source` — a body reduced from another model is
    refused. ``damping``: ``"loss"`` (default; ``K + iG`` on both sides where they have a
    hysteretic matrix, ``docs/equations.md`` §1.1) or ``"viscous"``.

    Examples
    --------
    >>> cmp = compare_frf(fe, body, np.linspace(10, 2000, 200), "force", "p_end")  # doctest: +SKIP
    >>> cmp.max_relative_error                                                     # doctest: +SKIP
    """
    if check:
        check_source(fe, body)
    full, sweep = frf_full_checked(fe, frequencies_hz, input, output, progress, method,
                                   damping=damping)
    red = frf_reduced(body, frequencies_hz, input, output, damping)[:, 0, 0]
    return FRFComparison(np.asarray(frequencies_hz, dtype=np.float64), full[:, 0, 0], red,
                         input, output, retained_band_hz(body),
                         None if sweep is None else sweep.max_checked_error)
