"""Structure-preserving second-order Krylov reduction (moment matching).

For an expansion point ``s0`` write ``K̃ = K + s0 D + s0² M`` and ``D̃ = D + 2 s0 M``; the
transfer function ``H(s) = C (K + sD + s²M)⁻¹ B`` expands in ``σ = s − s0`` as
``H = Σ C Pᵢ σⁱ`` with the second-order moment vectors
``P₀ = K̃⁻¹ B``, ``P₁ = −K̃⁻¹ D̃ P₀``, ``Pᵢ = −K̃⁻¹ (D̃ Pᵢ₋₁ + M Pᵢ₋₂)``.
A right basis ``V`` spanning ``{P₀ … P_{q−1}}`` (the second-order Krylov subspace) gives a
projected second-order model ``Wᵀ M V, Wᵀ D V, Wᵀ K V`` matching ``q`` moments about ``s0``
for any ``W``; a left basis spanning the dual subspace built from ``K̃⁻ᵀ Cᵀ`` with the
transposed matrices matches ``2q`` moments (two-sided).

The basis is built by the second-order Arnoldi procedure SOAR (Bai & Su, *SIAM J. Matrix
Anal. Appl.* 26 (2005) 640–659), which orthogonalizes only the n-dimensional part of the
linearized Krylov sequence; the moment-matching property of the structure-preserving
projection is Salimbahrami & Lohmann, *Linear Algebra Appl.* 415 (2006) 385–405. Complex
expansion points (``s0 = 2πj f``) give complex vectors; their real and imaginary parts are
both kept (which also matches the moments at ``s0̄``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.sparse as sps

from ...errors import DataError
from ...progress import report
from ..bodies.reduced import ReducedBody
from ..fe_model import FEModel
from .eigen import ShiftInvert, default_shift
from .projection import Progress, build_reduced_body, orthonormal_append

__all__ = ["reduce_krylov", "soar"]


def _factor(fe: FEModel, s0: complex) -> ShiftInvert:
    if fe.D is None:  # K + s0² M = K − σM with σ = −s0²
        return ShiftInvert(fe.K, fe.M, -(s0**2), fe.source)
    return ShiftInvert(fe.K, fe.M, s0, fe.source, D=fe.D)


def soar(
    si: ShiftInvert,
    Dt: sps.spmatrix,
    M: sps.spmatrix,
    start: np.ndarray,
    order: int,
    transpose: bool = False,
    rtol: float = 1e-12,
) -> np.ndarray:
    """Orthonormal (complex) basis of the second-order Krylov subspace (SOAR).

    Parameters
    ----------
    si
        Factorization of ``K̃ = K + s0 D + s0² M``.
    Dt, M
        ``D̃ = D + 2 s0 M`` and ``M`` (transposed internally when ``transpose``).
    start
        (n, m) right-hand side: ``B`` (right) or ``Cᵀ`` (left, with ``transpose``).
    order
        Number of block moments ``q``; the basis has at most ``q·m`` columns.
    transpose
        Build the left (dual) subspace with ``K̃ᵀ, D̃ᵀ, Mᵀ``.

    Returns
    -------
    numpy.ndarray
        (n, ≤ q·m) orthonormal columns, in moment order (deflated directions dropped).

    References
    ----------
    Bai & Su (2005), Algorithm 2 (SOAR).
    """
    if transpose:
        Dt, M = Dt.T.tocsr(), M.T.tocsr()
    P0 = si.solve(start, transpose)
    dtype = np.result_type(P0, np.complex128 if np.iscomplexobj(P0) else np.float64)
    n, m = P0.shape
    want = order * m
    Q = np.zeros((n, 0), dtype)  # columns may be zero after deflation (Bai & Su, §4)
    P = np.zeros((n, 0), dtype)

    def add(r: np.ndarray, s: np.ndarray) -> None:
        nonlocal Q, P
        ref = np.linalg.norm(r)
        for _ in range(2):
            h = Q.conj().T @ r
            r, s = r - Q @ h, s - P @ h
        nr = np.linalg.norm(r)
        if nr > rtol * ref and nr > 0:
            Q, P = np.column_stack([Q, r / nr]), np.column_stack([P, s / nr])
        elif np.linalg.norm(s) > 0:  # deflation: keep the auxiliary part, zero basis vector
            ns = np.linalg.norm(s)
            Q, P = np.column_stack([Q, np.zeros(n, dtype)]), np.column_stack([P, s / ns])

    for j in range(m):
        if np.linalg.norm(P0[:, j]) > 0:
            add(P0[:, j].astype(dtype), np.zeros(n, dtype))
    j = 0
    nonzero = np.linalg.norm(Q, axis=0) > 0
    while nonzero.sum() < want and j < Q.shape[1] and j < 3 * want:
        r = -si.solve(Dt @ Q[:, j] + M @ P[:, j], transpose)
        add(r, Q[:, j].copy())
        j += 1
        nonzero = np.linalg.norm(Q, axis=0) > 0
    return Q[:, nonzero][:, :want]


def _real_basis(blocks: list[np.ndarray]) -> np.ndarray:
    """Real orthonormal basis of the spans of complex blocks, keeping the column order."""
    cols = []
    for Q in blocks:
        if np.iscomplexobj(Q):
            inter = np.empty((Q.shape[0], 2 * Q.shape[1]))
            inter[:, 0::2], inter[:, 1::2] = Q.real, Q.imag
            cols.append(inter)
        else:
            cols.append(Q)
    X = np.concatenate(cols, axis=1)
    return orthonormal_append(np.zeros((X.shape[0], 0)), X)


def reduce_krylov(
    fe: FEModel,
    points: Sequence[complex],
    order: int = 4,
    two_sided: bool = True,
    static_correction: bool = False,
    keep_nodes: Sequence[int] | None = None,
    store_bases: bool = False,
    progress: Progress = None,
) -> ReducedBody:
    """Second-order Krylov (moment-matching) reduction, structure preserving.

    ``V`` spans the second-order Krylov subspaces of ``(K̃⁻¹D̃, K̃⁻¹M; K̃⁻¹B)`` at every
    expansion point, ``W`` those of the transposed problem started with ``K̃⁻ᵀCᵀ``
    (two-sided) or ``W = V`` (one-sided); both are orthonormal (Euclidean, as pyMOR's
    ``projection='orth'``) and the model is projected with
    :func:`~neweul_py.elastic.reductors.projection.project`, so ``M_r = Wᵀ M V`` is not the
    identity.
    (Biorthonormalizing ``Wᵀ M V = I`` would change nothing in the transfer function and is
    numerically fragile when the u and p blocks of ``M`` differ by many orders of magnitude.)

    Parameters
    ----------
    fe
        The FE model.
    points
        Expansion points ``s0`` in the Laplace domain (rad/s), e.g. ``2j*np.pi*f`` for a
        frequency ``f`` in Hz, or real values. ``s0 = 0`` needs a regular ``K``.
    order
        Block moments per point ``q`` (per input). Two-sided matches ``2q`` moments of each
        point (for equal numbers of inputs and outputs), one-sided ``q``.
    two_sided
        Petrov–Galerkin (``True``) or Galerkin (``False``).
    static_correction
        Also append static (attachment) vectors ``(K − σM)⁻¹[B, Cᵀ]`` (right) and
        ``(K − σM)⁻ᵀ[Cᵀ, B]`` (left) at the default small shift σ (exact in the limit σ → 0).
    keep_nodes, store_bases, progress
        As in :func:`~neweul_py.elastic.reductors.modal.reduce_modal`.

    Returns
    -------
    ReducedBody
        ``method="krylov"``. When the left and right subspaces of a point differ in
        dimension (unequal numbers of inputs and outputs, or deflation) both are truncated to
        the smaller one, keeping the lowest moments.

    References
    ----------
    Salimbahrami & Lohmann (2006); Bai & Su (2005); Freund (2005), *Padé-type model
    reduction of second-order and higher-order linear dynamical systems*.
    """
    points = [complex(p) for p in points]
    if not points:
        raise DataError("at least one expansion point is needed", fe.source, "points")
    if order < 1:
        raise DataError(f"order must be ≥ 1, got {order}", fe.source, "order")
    B, C = fe.B(), fe.C()
    if B.shape[1] == 0 or C.shape[0] == 0:
        raise DataError("Krylov reduction needs at least one input and one output",
                        fe.source, "inputs")
    right, left = [], []
    for i, s0 in enumerate(points):
        s0 = s0.real if s0.imag == 0 else s0
        report(progress, f"factorizing K + s0·D + s0²·M at s0={s0:.4g} (n={fe.n_dofs})", i,
               len(points))
        si = _factor(fe, s0)
        Dt = (2 * s0) * fe.M if fe.D is None else fe.D + (2 * s0) * fe.M
        right.append(soar(si, Dt, fe.M, B, order))
        if two_sided:  # equal widths per point, so every point keeps its lowest moments
            left.append(soar(si, Dt, fe.M, C.T, order, transpose=True))
            k = min(right[-1].shape[1], left[-1].shape[1])
            right[-1], left[-1] = right[-1][:, :k], left[-1][:, :k]
    if static_correction:  # attachment vectors = moments at s² = σ ≈ 0 (shifted if K singular)
        si0 = ShiftInvert(fe.K, fe.M, default_shift(fe), fe.source)
        rhs = np.hstack([B, C.T])
        right.append(si0.solve(rhs))
        left.append(si0.solve(np.hstack([C.T, B]), transpose=True))
    V = _real_basis(right)
    if two_sided:
        W = _real_basis(left)
        r = min(V.shape[1], W.shape[1])
        V, W = V[:, :r], W[:, :r]
    else:
        W = V
    settings = {
        "points": [[p.real, p.imag] for p in points], "order": order,
        "two_sided": two_sided, "static_correction": static_correction,
    }
    return build_reduced_body(fe, V, W, "krylov", settings, keep_nodes, store_bases)
