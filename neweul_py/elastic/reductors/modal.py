"""Modal truncation of FE models, two-sided (Petrov–Galerkin) or one-sided (Galerkin).

``docs/equations.md`` §3: ``V`` = selected right eigenvectors of the undamped pencil
``K x = λ M x``, ``W`` = the matching left ones, scaled so that ``Wᵀ M V = I``; then
``M_r = I``, ``K_r = Λ`` (the retained eigenvalues, exactly), ``D_r = Wᵀ D V``,
``B_r = Wᵀ B``, ``C_r = C V``. Optional static correction (attachment / residual-flexibility
vectors) adds ``K⁻¹ B`` on the right and ``K⁻ᵀ Cᵀ`` on the left.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.linalg as sla

from ...errors import DataError, SolverError
from ..bodies.reduced import ReducedBody
from ..fe_model import FEModel
from .eigen import (
    ZERO_RTOL,
    EigenBlock,
    ShiftInvert,
    default_shift,
    left_blocks,
    right_blocks,
    symmetric_pencil,
)
from .projection import Progress, biorthonormalize, build_reduced_body, orthonormal_append

__all__ = ["add_static_correction", "modal_bases", "reduce_modal", "zero_modes"]


def _say(progress: Progress, msg: str) -> None:
    if progress is not None:
        progress(msg)


def _is_zero(b: EigenBlock, tol: float) -> bool:
    """A real cluster at ``λ = 0`` (rigid-body modes, constant pressure), within ``tol``."""
    return not b.is_complex and abs(b.center.real) <= tol


def _select(fe: FEModel, si: ShiftInvert, modes: int | None,
            band: tuple[float, float] | None, skip_zero: bool,
            progress: Progress) -> tuple[list, int, float]:
    """Right blocks by count (nearest σ) or by band; returns (blocks, k used, tolerance).

    The tolerance ``ZERO_RTOL · max(|σ|, |λ| computed or the band top)`` decides which
    eigenvalues are zero (rigid-body / constant-pressure modes).

    Every kept cluster is complete: ARPACK's k eigenpairs may cut a degenerate cluster at
    the far end, so k grows until a computed block lies beyond the kept ones. With
    ``skip_zero`` the λ ≈ 0 clusters are dropped before counting.
    """
    n = fe.n_dofs
    if modes is not None:
        if modes < 1:
            raise DataError(f"modes must be ≥ 1, got {modes}", fe.source, "modes")
        if modes > n - 2:
            raise DataError(f"{modes} modes requested but the model has {n} DOFs (at most "
                            f"{n - 2} with the sparse eigensolver)", fe.source, "modes")
        # a free 3-D body has 6 zero modes; room for them when they are skipped
        k = min(modes + max(4, modes // 10) + (6 if skip_zero else 0), n - 2)
        while True:
            _say(progress, f"eigensolver: {k} eigenpairs of a {n}-DOF pencil near "
                           f"σ={si.sigma:.4g}")
            blocks = right_blocks(si, k, fe.source)
            tol = ZERO_RTOL * max([abs(si.sigma)] + [abs(b.center) for b in blocks])
            kept, count = [], 0
            for b in blocks:
                if count >= modes:
                    break
                if skip_zero and _is_zero(b, tol):
                    continue
                kept.append(b)
                count += b.basis.shape[1]
            complete = count >= modes and kept[-1] is not blocks[-1]
            if complete or k >= n - 2:
                break
            k = min(2 * k, n - 2)
        if count < modes:
            raise DataError(f"{modes} modes requested but the model has only {count} with "
                            "λ ≠ 0 within the sparse eigensolver's reach", fe.source, "modes")
        return kept, k, tol
    lo, hi = (2 * np.pi * band[0]) ** 2, (2 * np.pi * band[1]) ** 2
    # Membership must not depend on round-off: a zero mode (closed cavity, rigid body) comes
    # out as λ ≈ ±eps·σ²/dist (−0.39 at σ = 7.9e9), so λ within ZERO_RTOL of the spectrum
    # scale below 0 counts as 0 (the real non-negative spectrum of the undamped pencil), and
    # each band edge gets a margin of ZERO_RTOL relative to itself (a band from 1 Hz still
    # excludes the 0-Hz mode).
    tol = ZERO_RTOL * max(abs(si.sigma), hi)

    def in_band(b: EigenBlock) -> bool:
        lam = b.center.real
        lam = 0.0 if -tol <= lam < 0 else lam
        return not b.is_complex and lo * (1 - ZERO_RTOL) <= lam <= hi * (1 + ZERO_RTOL)

    k = min(20, n - 2)
    while True:
        _say(progress, f"eigensolver: {k} eigenpairs of a {n}-DOF pencil near σ={si.sigma:.4g}")
        blocks = right_blocks(si, k, fe.source)
        inside = [b for b in blocks if in_band(b)]
        if len(inside) < len(blocks) or k >= n - 2:
            break
        k = min(2 * k, n - 2)
    if skip_zero:
        inside = [b for b in inside if not _is_zero(b, tol)]
    if not inside:
        raise DataError(f"no modes in the band {band[0]:g}–{band[1]:g} Hz"
                        + (" (λ = 0 modes skipped)" if skip_zero else ""), fe.source, "band")
    return inside, k, tol


def _pair(right: list[EigenBlock], left: list[EigenBlock], fe: FEModel,
          symmetric: bool, sigma: complex) -> tuple:
    """Cluster-block biorthonormalization ``W_cᵀ M V_c = I`` and Rayleigh–Ritz per cluster.

    Each right cluster ``V_c`` (unit columns) and its left subspace ``W_c`` (``W_c = V_c``
    for one-sided or symmetric data) are paired as blocks: ``W_c ← W_c G⁻ᵀ`` with the small
    ``G = W_cᵀ M V_c`` (an LU solve; a singular ``G`` means the subspaces do not pair), then
    the small ``K_c = W_cᵀ K V_c`` is diagonalized inside the cluster — by ``eigh(V_cᵀKV_c,
    V_cᵀMV_c)`` for symmetric pencils (then ``W_c = V_c``, M-orthonormal), else by
    ``eig(K_c)`` with ``V_c ← V_c S``, ``W_c ← W_c S⁻ᵀ`` when its eigenvalues are real and
    ``S`` is well conditioned. The columns of a cluster are ordered nearest σ first, so a
    mode count that cuts a cluster keeps its part nearest σ (for an exactly degenerate
    cluster any subspace is as good: the choice is then arbitrary).

    Returns
    -------
    V, W, lam
        With ``Wᵀ M V`` block-diagonal per cluster (identity blocks) and ``lam`` the
        Rayleigh–Ritz values of each cluster.
    """
    M, K = fe.M, fe.K
    sigma = float(np.real(sigma))
    Vs, Ws, lams = [], [], []
    for b, lb in zip(right, left, strict=True):
        V = b.basis / np.linalg.norm(b.basis, axis=0)
        vals = np.asarray(b.values)
        if symmetric and lb is b and not b.is_complex:
            G, Kc = V.T @ (M @ V), V.T @ (K @ V)
            try:
                mu, S = sla.eigh(0.5 * (Kc + Kc.T), 0.5 * (G + G.T))
            except (np.linalg.LinAlgError, ValueError):
                pass
            else:
                order = np.argsort(np.abs(mu - sigma), kind="stable")
                V = V @ S[:, order]
                Vs.append(V)
                Ws.append(V)
                lams.append(mu[order])
                continue
        W = V if lb is b else np.real(lb.basis)
        G = W.T @ (M @ V)
        cond = np.linalg.cond(G)
        if not np.isfinite(cond) or cond > 1e12:
            raise SolverError(f"the left and right invariant subspaces of the cluster at "
                              f"λ = {b.center:.6g} (dimension {V.shape[1]}) do not pair: "
                              f"Wᵀ M V has condition number {cond:.3g}", residual=cond)
        W = np.linalg.solve(G, W.T).T
        if not b.is_complex:
            Kc = W.T @ (K @ V)
            mu, S = np.linalg.eig(Kc)
            # a (near-)degenerate cluster may give a complex pair of round-off size: its
            # eigenvectors are complex, no real rotation diagonalizes it — leave it as is
            if np.all(mu.imag == 0) and np.linalg.cond(S) < 1e4:
                mu, S = mu.real, S.real
                order = np.argsort(np.abs(mu - sigma), kind="stable")
                mu, S = mu[order], S[:, order]
                V, W = V @ S, np.linalg.solve(S, W.T).T
                vals = mu
        Vs.append(V)
        Ws.append(W)
        lams.append(vals)
    return np.concatenate(Vs, axis=1), np.concatenate(Ws, axis=1), np.concatenate(lams)


def modal_bases(
    fe: FEModel,
    modes: int | None = None,
    band: tuple[float, float] | None = None,
    two_sided: bool = True,
    shift: float | None = None,
    progress: Progress = None,
    skip_rigid: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, ShiftInvert]:
    """Right and left modal bases of the undamped pencil ``(K, M)``.

    Parameters
    ----------
    fe
        The FE model.
    modes, band
        Exactly one: the number of modes nearest the shift (the lowest ones with the default
        shift), or a frequency band ``(fmin, fmax)`` in Hz (``λ = (2πf)²``). A computed
        ``λ`` less than :data:`~neweul_py.elastic.reductors.eigen.ZERO_RTOL` ``· max(|σ|, λ_max)``
        below 0 counts as a zero mode (kept in a band from 0 Hz), and the band edges get a
        relative margin of ``ZERO_RTOL``. Zero modes (rigid-body modes of a free structure,
        the constant pressure of a closed cavity) are ordinary modes at 0 Hz: they are part
        of the count and of a band from 0 Hz unless ``skip_rigid``. A count that cuts a
        degenerate cluster (``modes=4`` of a free body's six zero modes) keeps an arbitrary
        subspace of it.
    two_sided
        Compute left eigenvectors (else ``W = V``, orthonormalized). Symmetric pencils
        (:func:`~neweul_py.elastic.reductors.eigen.symmetric_pencil`) take the left vectors equal to
        the right ones; degenerate clusters are paired as invariant subspaces
        (:func:`_pair`).
    shift
        Shift σ of the spectral transformation (in ``λ = ω²`` units). Default: a small
        negative value (:func:`~neweul_py.elastic.reductors.eigen.default_shift`) for ``modes``, the
        middle of the band for ``band``.
    progress
        Called with short messages on long steps.
    skip_rigid
        Drop the ``λ ≈ 0`` clusters (within ``ZERO_RTOL · max(|σ|, |λ|)``) before counting
        or band selection: ``modes=N`` then gives ``N`` modes with ``λ ≠ 0``. Meant for free
        bodies whose floating frame carries the rigid motion; it also drops the
        constant-pressure modes of closed air volumes, which carry the cavity compliance of a
        u–p body (a supported body needs no skip: ``neweul reduce --invariants`` checks the
        structural rigid fields only, :mod:`~neweul_py.elastic.quality.rigid_motion`). Use it for
        bodies in the floating frame of reference, whose reference frame carries the
        rigid-body motion (see :func:`reduce_modal`).

    Returns
    -------
    V, W, lam, si
        (n, r) bases with ``Wᵀ M V = I`` (two-sided), the eigenvalues ``λ`` per column
        (two-sided Rayleigh quotients ``wᵢᵀ K vᵢ``, one-sided Rayleigh–Ritz values; those
        within ``ZERO_RTOL · max(|σ|, |λ|)`` of 0 are set to exactly 0) and the
        shift-invert factorization (reused by :func:`add_static_correction`).
    """
    if (modes is None) == (band is None):
        raise DataError("give exactly one of modes=N or band=(fmin, fmax)", fe.source,
                        "modes")
    if band is not None:
        fmin, fmax = (float(x) for x in band)
        if not (np.isfinite(fmin) and np.isfinite(fmax) and 0 <= fmin < fmax):
            raise DataError(f"band must satisfy 0 ≤ fmin < fmax, got {band}", fe.source,
                            "band")
        band = (fmin, fmax)
        if shift is None:
            shift = 0.5 * ((2 * np.pi * fmin) ** 2 + (2 * np.pi * fmax) ** 2)
    if shift is None:
        shift = default_shift(fe)
    _say(progress, f"factorizing K − σM (n={fe.n_dofs}, σ={shift:.4g})")
    si = ShiftInvert(fe.K, fe.M, float(shift), fe.source)
    right, k, zero_tol = _select(fe, si, modes, band, skip_rigid, progress)
    symmetric = symmetric_pencil(fe)
    if two_sided:
        _say(progress, "left eigenvectors")
        left = left_blocks(fe, si, right, k)
        V, W, lam = _pair(right, left, fe, symmetric, si.sigma)
    else:  # Galerkin: Rayleigh–Ritz inside each cluster (W_c = V_c)
        V, _, lam = _pair(right, right, fe, symmetric, si.sigma)
    if modes is not None:
        V, lam = V[:, :modes], lam[:modes]
        if two_sided:
            W = W[:, :modes]
    if two_sided:
        V, W = biorthonormalize(V, W, fe.M)
        if not np.iscomplexobj(lam):  # two-sided Rayleigh quotients: more accurate than
            lam = np.einsum("ij,ij->j", W, fe.K @ V)  # σ + 1/θ (second-order errors)
    else:
        V, _ = np.linalg.qr(V)
        W = V
    if not np.iscomplexobj(lam):  # zero modes are 0 (their computed λ is round-off)
        lam = np.where(np.abs(lam) <= zero_tol, 0.0, lam)
    return V, W, lam, si


def zero_modes(fe: FEModel, si: ShiftInvert, two_sided: bool = True
               ) -> tuple[np.ndarray, np.ndarray]:
    """Right and left bases ``(V0, W0)`` of the ``λ = 0`` modes (rigid motion, constant
    pressure of closed volumes), ``(n, 0)`` when there are none: the eigenpairs nearest the
    (small negative) shift of ``si`` within ``ZERO_RTOL``, left vectors as in
    :func:`~neweul_py.elastic.reductors.eigen.left_blocks` (analytic for supported u–p models)."""
    k = min(12, fe.n_dofs - 2)
    blocks = right_blocks(si, k, fe.source)
    tol = ZERO_RTOL * max([abs(si.sigma)] + [abs(b.center) for b in blocks])
    zero = [b for b in blocks if _is_zero(b, tol)]
    if not zero:
        empty = np.zeros((fe.n_dofs, 0))
        return empty, empty
    V0 = np.hstack([np.real(b.basis) for b in zero])
    if not two_sided or symmetric_pencil(fe):
        return V0, V0
    W0 = np.hstack([np.real(b.basis) for b in left_blocks(fe, si, zero, k)])
    return V0, W0


def add_static_correction(
    fe: FEModel, V: np.ndarray, W: np.ndarray, si: ShiftInvert, two_sided: bool = True,
    deflate: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Append static (attachment) vectors to bases with ``Wᵀ M V = I``.

    Right: ``(K − σM)⁻¹ B``, left: ``(K − σM)⁻ᵀ Cᵀ`` (``docs/equations.md`` §3; Craig &
    Kurdila, *Fundamentals of Structural Dynamics*, 2006, §17.3 "residual flexibility").
    The shift σ is the one of the factorization ``si``: ``σ = 0`` gives the classical
    ``K⁻¹B``; the default small negative σ makes the correction work with a singular ``K``
    (closed cavity, free structure) – it is then exact at ``s² = σ`` instead of ``s = 0``.
    The new vectors are made M-biorthogonal to the existing ones by the oblique projection
    ``X ← X − V (Wᵀ M X)``, ``Y ← Y − W (Vᵀ Mᵀ Y)`` (for eigenvector bases this removes
    exactly the retained modes' share ``Σ vᵢ wᵢᵀ B / (λᵢ − σ)``, including the ``1/σ`` part
    of zero modes: the residual flexibility), then biorthonormalized among themselves, so
    that ``Wᵀ M V = I`` holds for the extended bases and the reduced ``K`` stays block
    diagonal (retained eigenvalues unchanged). Both sides get both blocks — right
    ``(K − σM)⁻¹ [B, Cᵀ]``, left ``(K − σM)⁻ᵀ [Cᵀ, B]`` — which keeps ``V`` and ``W`` equally
    wide for any numbers of inputs and outputs and, for unsymmetric (u–p) models, avoids the
    indefinite 1×1 static blocks that the minimal choice ``K⁻¹B`` / ``K⁻ᵀCᵀ`` can produce
    (negative or complex extra eigenvalues, i.e. an unstable reduced model: observed on
    random u–p models, see ``tests/elastic/reductors``). This is an empirical safeguard, not a
    guarantee; check :func:`~neweul_py.elastic.quality.measures.stability`.

    ``deflate = (V0, W0)``: the skipped ``λ = 0`` modes (``skip_rigid``, :func:`zero_modes`)
    are not in ``V``, so the shifted solves keep their ``1/σ``-large share; it is projected
    out as well, ``X ← X − V0 (W0ᵀMV0)⁻¹ W0ᵀM X``, ``Y ← Y − W0 (V0ᵀMᵀW0)⁻¹ V0ᵀMᵀ Y``
    (inertia-relief attachment vectors, Craig & Kurdila 2006 §17.4). Without it the static
    vectors carry the skipped modes back in: a rigid motion of a free beam, and for the
    middle ear (λ = 0 air modes skipped, refine 1, 30 modes) an unstable body with a real
    pole at +1.19e4 1/s (measured).

    Returns
    -------
    V, W
        Extended bases (one-sided: ``W = V``, orthonormal).
    """
    B, C = fe.B(), fe.C()
    V0, W0 = deflate if deflate is not None else (np.zeros((fe.n_dofs, 0)),) * 2
    has0 = V0.shape[1] > 0
    if not two_sided:
        X = np.real(si.solve(B))
        if has0:
            X = X - V0 @ np.linalg.solve(V0.T @ (fe.M @ V0), V0.T @ (fe.M @ X))
        Q = orthonormal_append(V, X)
        return Q, Q
    right_rhs, left_rhs = np.hstack([B, C.T]), np.hstack([C.T, B])
    X = np.real(si.solve(right_rhs))
    Y = np.real(si.solve(left_rhs, transpose=True))
    empty = np.zeros((fe.n_dofs, 0))
    for _ in range(2):  # oblique projection, repeated once for numerical safety
        X = X - V @ (W.T @ (fe.M @ X))
        Y = Y - W @ (V.T @ (fe.M.T @ Y))
        if has0:
            X = X - V0 @ np.linalg.solve(W0.T @ (fe.M @ V0), W0.T @ (fe.M @ X))
            Y = Y - W0 @ np.linalg.solve(V0.T @ (fe.M.T @ W0), V0.T @ (fe.M.T @ Y))
    X, Y = orthonormal_append(empty, X), orthonormal_append(empty, Y)
    r = min(X.shape[1], Y.shape[1])
    X, Y = biorthonormalize(X[:, :r], Y[:, :r], fe.M)
    return np.hstack([V, X]), np.hstack([W, Y])


def reduce_modal(
    fe: FEModel,
    modes: int | None = None,
    band: tuple[float, float] | None = None,
    two_sided: bool = True,
    static_correction: bool = False,
    shift: float | None = None,
    keep_nodes: Sequence[int] | None = None,
    store_bases: bool = False,
    progress: Progress = None,
    skip_rigid: bool = False,
) -> ReducedBody:
    """Modal truncation: ``x ≈ V q`` with (left/right) eigenvectors of ``(K, M)``.

    Two-sided (default): ``V`` right, ``W`` left eigenvectors (u–p relation ``[ρλu; p]``
    for ``up-coupled`` models), ``Wᵀ M V = I``, so ``M_r = I`` and ``K_r = diag(λ)`` — the
    retained eigenvalues are reproduced exactly and the reduced model of an unsymmetric
    u–p model stays stable. One-sided: ``W = V`` (orthonormal), the classical choice for
    symmetric models (for which the two-sided reduction also takes ``W = V`` up to scaling).

    **Free structures, zero modes.** Free (unsupported) bodies have six rigid-body modes at
    ``λ = 0``, closed cavities a constant-pressure mode; they are computed like any other
    mode (the default shift lies below 0), reported at 0 Hz, counted by ``modes`` and kept
    by a band from 0 Hz. Degenerate clusters — the 6-fold zero, repeated frequencies of
    symmetric structures — are reduced as invariant subspaces, bi-orthonormalized as blocks.
    By default the zero modes are **kept**: the reduced model then reproduces the rigid-body
    (or static-pressure) response, as a frequency response of the free model needs.
    For a body in the **floating frame of reference** (``--invariants``, an elastic body of
    a description) the reference frame already carries the rigid motion, so the elastic
    coordinates must be the elastic modes only: pass ``skip_rigid=True``
    (``modes=N`` then counts the N lowest modes with ``λ ≠ 0``). The free-free elastic modes
    are M-orthogonal to the rigid-body fields, so ``Ct⁰ = (∫Φ dm)ᵀ = 0`` and ``Cr⁰ = 0``
    (Tisserand / mean-axis conditions) — the convention of SID files written from a
    free-free modal analysis (``tests/data/beam.SID_FEM`` holds modes 7–17). Rigid-body
    modes left in ``V`` duplicate the frame's motion and make the body's mass matrix of §2
    singular. Clamped (constrained) modes, the other common FFRF choice, come from a
    supported FE model (remove the support DOFs before reducing).

    Parameters
    ----------
    fe
        The FE model (never densified).
    modes, band
        Exactly one: number of modes (the lowest, with the default shift), or a band
        ``(fmin, fmax)`` in Hz.
    two_sided
        Petrov–Galerkin (``True``) or Galerkin (``False``) projection.
    static_correction
        Add attachment vectors of the inputs/outputs (:func:`add_static_correction`).
    shift
        Shift σ (``λ = ω²`` units) of the spectral transformation; must not make
        ``K − σM`` singular.
    keep_nodes
        Node ids whose basis rows are stored (default: input and output nodes).
    store_bases
        Also store the full ``V`` and ``W`` in the body.
    progress
        Called with messages on long steps (the CLI prints them to stderr).
    skip_rigid
        Drop the ``λ ≈ 0`` modes (rigid-body modes; for u–p models also the constant
        pressure mode) before counting / band selection; recorded as
        ``settings["skip_rigid"]`` when set.

    Returns
    -------
    ReducedBody
        With ``method="modal"`` and ``eigenvalues`` = the retained ``λ``.

    Raises
    ------
    DataError
        No modes in the band, more modes than DOFs, a singular shift.

    References
    ----------
    ``docs/equations.md`` §3; Craig & Kurdila (2006) ch. 11, 17.

    Examples
    --------
    >>> body = reduce_modal(fe, modes=20)                       # doctest: +SKIP
    >>> body = reduce_modal(fe, band=(0, 5000), static_correction=True)  # doctest: +SKIP
    """
    V, W, lam, si = modal_bases(fe, modes, band, two_sided, shift, progress, skip_rigid)
    if static_correction:
        _say(progress, "static correction vectors")
        zero = zero_modes(fe, si, two_sided) if skip_rigid else None
        V, W = add_static_correction(fe, V, W, si, two_sided, deflate=zero)
    settings = {
        "modes": modes, "band": list(band) if band is not None else None,
        "two_sided": two_sided, "static_correction": static_correction,
        "shift": float(si.sigma),
    }
    if skip_rigid:  # only when set: bodies reduced without it keep their metadata unchanged
        settings["skip_rigid"] = True
    _say(progress, f"projecting onto {V.shape[1]} vectors")
    lam = lam.real if np.all(np.imag(lam) == 0) else lam
    return build_reduced_body(fe, V, W, "modal", settings, keep_nodes, store_bases, lam)
