"""Sparse shift-invert eigensolvers for the (possibly unsymmetric) undamped pencil ``(K, M)``.

``K x = λ M x`` is solved through the standard problem of the shift-inverted operator
``(K − σM)⁻¹ M x = θ x``, ``λ = σ + 1/θ`` (ARPACK via :func:`scipy.sparse.linalg.eigs` on a
:class:`~scipy.sparse.linalg.LinearOperator`; ``eigs(K, M=M, sigma=…)`` is *not* used since it
assumes a symmetric ``M``). Left eigenvectors ``(K − λM)ᵀ w = 0`` come from the transposed
operator ``(K − σM)⁻ᵀ Mᵀ`` with the *same* sparse LU, or — for u–p coupled models of Eq. (2) —
from the right ones for free: ``w = [ρλu; p]`` (``docs/equations.md`` §3), also at
``λ = 0`` (closed-cavity constant pressure: ``[0; p]``, :func:`up_left_null`) when the structure
is supported; other ``λ = 0`` modes (free structures) get their left vectors from the
transposed problem by subspace iteration. Symmetric pencils (``M``, ``K`` symmetric: structural and
acoustic models) take the left vectors equal to the right ones (:func:`symmetric_pencil`).

Degenerate clusters (the 6-fold ``λ = 0`` of a free body, repeated frequencies of symmetric
structures, identical sub-structures) are handled as invariant subspaces, never vector by
vector: a right cluster is paired with the span of all left eigenvectors of (numerically)
the same eigenvalue, and the pair is bi-orthonormalized as a block
(:func:`~neweul_py.elastic.reductors.modal.modal_bases`).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np
import pymetis
import scipy.sparse as sps
import scipy.sparse.linalg as spla

from ...errors import DataError, SolverError
from ..fe_model import SYMMETRY_RTOL, FEModel, asymmetry

__all__ = [
    "PERMC_SPEC",
    "EigenBlock",
    "ShiftInvert",
    "SparseLU",
    "default_shift",
    "frequencies_hz",
    "left_blocks",
    "right_blocks",
    "symmetric_pencil",
    "up_left_null",
]

#: Relative tolerance (of ``max |λ|``) below which an imaginary part is numerical noise.
REAL_RTOL = 1e-7
#: Relative distance (of ``max |λ|``) within which eigenvalues form one (degenerate) cluster.
CLUSTER_RTOL = 1e-8
#: Relative tolerance (of the spectrum scale, e.g. ``max(|σ|, λ_max)``) within which a real
#: eigenvalue is indistinguishable from a band edge or from zero: shift-invert eigenvalues
#: carry absolute errors of about ``eps·σ²/dist`` (a zero mode computed at σ = 7.9e9 came
#: out as −0.39), so band membership and "λ = 0" are decided with this margin.
ZERO_RTOL = CLUSTER_RTOL
#: Fill-reducing ordering of SuperLU: minimum degree on the pattern of ``Aᵀ + A`` suits FE
#: matrices (structurally symmetric up to the u–p blocks); on a 100 000-DOF 3-D acoustic grid
#: it needed about half the time and fill of the default COLAMD.
PERMC_SPEC = "MMD_AT_PLUS_A"


#: Matrices from this many rows on are ordered by nested dissection (:func:`nested_dissection`);
#: smaller ones by SuperLU's :data:`PERMC_SPEC`.
ND_MIN_ROWS = 2000

#: Threshold of SuperLU's diagonal pivoting: the diagonal entry is the pivot unless it is
#: smaller than this fraction of the largest entry of its column (threshold partial
#: pivoting, as in UMFPACK's symmetric strategy; SciPy's default 1.0 is plain partial
#: pivoting, which undoes the fill-reducing symmetric ordering). On the refine-1 middle-ear
#: ``K + iωD − ω²M`` (6 584 DOFs, nested dissection): 0.18 s instead of 0.28 s, 2.09·10⁶
#: factor entries instead of 2.5–2.7·10⁶, the same backward error (about 1e-21 of
#: ‖A‖·‖x‖).
DIAG_PIVOT_THRESHOLD = 0.1

#: Nested-dissection orderings by sparsity pattern (the factorizations of a frequency sweep
#: or of the working points of one mesh share their pattern: one ordering serves them all).
_ORDERINGS: dict[str, np.ndarray] = {}


def nested_dissection(A: sps.spmatrix) -> np.ndarray:
    """The nested-dissection ordering (METIS, George 1973; Karypis & Kumar 1998) of the
    pattern of ``A + Aᵀ``: ``A[perm][:, perm]`` factorizes with less fill than minimum degree
    on 3-D meshes — on the middle-ear u–p model ``K + iωD − ω²M`` at 33 210 DOFs
    23·10⁶ factor entries in 4.0 s against 37·10⁶ in 10 s (``MMD_AT_PLUS_A``)."""
    P = sps.csr_matrix(A, copy=True)
    P.data = np.ones_like(P.data, dtype=np.int8)
    P = (P + P.T).tocsr()
    P.setdiag(0)
    P.eliminate_zeros()
    P.sort_indices()
    key = hashlib.sha256(P.indptr.tobytes() + P.indices.tobytes()).hexdigest()
    if key not in _ORDERINGS:
        if len(_ORDERINGS) >= 8:
            _ORDERINGS.clear()
        adjacency = pymetis.CSRAdjacency(adj_starts=P.indptr.astype(np.int32),
                                         adjacent=P.indices.astype(np.int32))
        perm, _ = pymetis.nested_dissection(adjacency)
        _ORDERINGS[key] = np.asarray(perm, dtype=np.int64)
    return _ORDERINGS[key]


class SparseLU:
    """Sparse LU (SuperLU) of a real or complex square matrix with ``solve(b, transpose)``.

    Ordering: from :data:`ND_MIN_ROWS` rows on, the symmetric nested-dissection permutation of
    :func:`nested_dissection` (then SuperLU's natural order), below minimum degree on
    ``Aᵀ + A``; both with SuperLU's symmetric mode and threshold pivoting on the diagonal
    (:data:`DIAG_PIVOT_THRESHOLD`), for real and complex matrices alike. On the middle-ear u–p
    model (33 210 DOFs, ``K + iωD − ω²M``) with partial pivoting the complex factorization
    took 4.0 s with nested dissection, 9.5 s with minimum degree, 23 s with COLAMD and 35 s
    for the equivalent real form ``[[Ar, −Ai], [Ai, Ar]]``.

    Raises
    ------
    RuntimeError
        From SuperLU when ``A`` is exactly singular.
    """

    def __init__(self, A: sps.spmatrix) -> None:
        self.complex = np.iscomplexobj(A.data if sps.issparse(A) else A)
        self.n = A.shape[0]
        A = sps.csc_matrix(A)
        self.perm = nested_dissection(A) if self.n >= ND_MIN_ROWS else None
        if self.perm is not None:
            A = A[self.perm][:, self.perm].tocsc()
        self.lu = spla.splu(A, permc_spec=PERMC_SPEC if self.perm is None else "NATURAL",
                            options={"SymmetricMode": True,
                                     "DiagPivotThresh": DIAG_PIVOT_THRESHOLD})

    def condition_estimate(self, A: sps.spmatrix) -> float:
        """Cheap lower bound of ``cond₁(A)``: ``‖A‖₁ ‖A⁻¹r‖ / ‖r‖`` for a random ``r``.

        A random vector has a component along any (near-)null vector, so a numerically
        singular ``A`` shows up as a huge value (or inf/NaN); one solve, no copy of the factors
        (``SuperLU.U`` would copy them).
        """
        r = np.random.default_rng(7).standard_normal(self.n)
        x = self.solve(r)
        if not np.all(np.isfinite(x)):
            return float("inf")
        return float(spla.norm(A, 1) * np.linalg.norm(x) / np.linalg.norm(r))

    def solve(self, b: np.ndarray, transpose: bool = False) -> np.ndarray:
        """``A⁻¹ b`` or ``A⁻ᵀ b`` (column-wise for 2-D ``b``)."""
        if not self.complex and np.iscomplexobj(b):
            return self.solve(b.real, transpose) + 1j * self.solve(b.imag, transpose)
        b = np.asarray(b, dtype=np.complex128 if self.complex else np.float64)
        if self.perm is None:
            return self.lu.solve(b, trans="T" if transpose else "N")
        y = self.lu.solve(b[self.perm], trans="T" if transpose else "N")
        x = np.empty_like(y)
        x[self.perm] = y
        return x


class ShiftInvert:
    """Sparse LU of ``K − σM`` and the operators ``(K − σM)⁻¹ M`` and ``(K − σM)⁻ᵀ Mᵀ``.

    Parameters
    ----------
    K, M
        Sparse n×n matrices.
    sigma
        The shift (real or complex).
    source
        File named in errors.

    Raises
    ------
    DataError
        ``K − σM`` is (numerically) singular at this shift (item ``"K − σM"``).
    """

    def __init__(self, K: sps.spmatrix, M: sps.spmatrix, sigma: complex,
                 source: str | None = None, D: sps.spmatrix | None = None) -> None:
        self.sigma = sigma
        self.M = M.tocsr()
        self.MT = M.T.tocsr()
        A = K - sigma * M if D is None else K + sigma * D + sigma**2 * M
        what = "K − σM" if D is None else "K + s0·D + s0²·M"
        try:
            self.lu = SparseLU(A)
        except RuntimeError as exc:
            raise DataError(f"shift {sigma:g} makes the matrix singular ({exc}); choose "
                            "another shift", source, what) from None
        cond = self.lu.condition_estimate(A)
        if not cond < 1e14:
            raise DataError(f"shift {sigma:g} makes the matrix numerically singular "
                            f"(condition ≥ {cond:.2g}); choose another shift", source, what)
        self.n = A.shape[0]
        self.dtype = np.result_type(A.dtype, np.float64)

    def solve(self, b: np.ndarray, transpose: bool = False) -> np.ndarray:
        """``(K − σM)⁻¹ b`` or ``(K − σM)⁻ᵀ b`` (column-wise for 2-D ``b``)."""
        return self.lu.solve(b, transpose)

    def operator(self, transpose: bool = False) -> spla.LinearOperator:
        """The shift-inverted operator ``(K − σM)⁻¹ M`` (or ``(K − σM)⁻ᵀ Mᵀ``)."""
        m = self.MT if transpose else self.M

        def mv(x: np.ndarray) -> np.ndarray:
            return self.solve(m @ x, transpose)

        return spla.LinearOperator((self.n, self.n), matvec=mv, matmat=mv, dtype=self.dtype)


def frequencies_hz(lam: np.ndarray, scale: float | None = None,
                   rtol: float = ZERO_RTOL) -> np.ndarray:
    """Natural frequencies ``f = √λ / 2π`` of undamped eigenvalues ``λ = ω²``.

    The undamped pencils of this package (structural, acoustic, u–p coupled, Eq. (2)) have a
    real non-negative spectrum; a zero mode (rigid body, closed-cavity constant pressure)
    comes out as round-off of either sign. Values with ``|λ| ≤ rtol·scale`` are therefore
    reported at ``0 Hz``; larger negative values (a genuinely indefinite ``K``) give
    ``√|λ| / 2π``, as before.

    Parameters
    ----------
    lam
        Eigenvalues (the real part is used).
    scale
        Spectrum scale of the computation (default ``max |λ|``).
    rtol
        Relative tolerance (:data:`ZERO_RTOL`).

    Examples
    --------
    >>> frequencies_hz(np.array([-3e-7, 2e-7, (2 * np.pi * 50.0) ** 2])).tolist()
    [0.0, 0.0, 50.0]
    """
    lam = np.real(np.asarray(lam, dtype=complex if np.iscomplexobj(lam) else float))
    if scale is None:
        scale = float(np.max(np.abs(lam))) if lam.size else 0.0
    lam = np.where(np.abs(lam) <= rtol * scale, 0.0, lam)
    return np.sqrt(np.abs(lam)) / (2 * np.pi)


def default_shift(fe: FEModel) -> float:
    """A small negative shift ``σ = −10⁻⁶ λ_est`` below the spectrum.

    ``λ_est = max(diag K / diag M)`` estimates the top of the spectrum ``λ = ω² ≥ 0``; the
    shift keeps ``K − σM`` regular when ``K`` is singular (constant-pressure mode of a closed
    cavity, rigid-body modes) while leaving the nearest eigenvalues the lowest ones.
    A compromise: the closer σ is to a zero eigenvalue, the more the Arnoldi process's
    round-off (relative to the largest ``θ = 1/(λ − σ)``) spoils the relative accuracy of the
    higher modes (≈ ``eps · λ_k / |σ|``); the farther below the lowest modes, the slower the
    convergence (``θ`` of wanted and unwanted modes approach each other). For very wide
    spectra (bending-dominated structures, ``λ_max/λ_1 ≫ 10⁶``) pass a shift of the order
    of ``−λ_1``.
    """
    dk, dm = np.abs(fe.K.diagonal()), np.abs(fe.M.diagonal())
    ok = dm > 0
    est = float(np.max(dk[ok] / dm[ok])) if ok.any() else 1.0
    return -1e-6 * (est if est > 0 else 1.0)


@dataclass(frozen=True)
class EigenBlock:
    """Eigenvalue(s) and a real basis of the matching invariant subspace.

    ``values`` has one entry per column of ``basis``: ``m`` copies of a real eigenvalue
    (cluster of multiplicity m), or ``λ, λ̄`` alternating for a complex pair whose real basis
    is ``[Re x, Im x]``.
    """

    values: np.ndarray
    basis: np.ndarray

    @property
    def center(self) -> complex:
        return complex(np.mean(self.values[:: 2 if self.is_complex else 1]))

    @property
    def is_complex(self) -> bool:
        return bool(np.iscomplexobj(self.values) and np.any(self.values.imag != 0))


def _arpack(op: spla.LinearOperator, k: int, n: int, source: str | None) -> tuple:
    if k >= n - 1:
        raise DataError(f"{k} eigenpairs requested but the model has only {n} DOFs (the "
                        "sparse eigensolver needs fewer than n − 1)", source, "modes")
    ncv = min(n, max(2 * k + 1, 20))
    rng = np.random.default_rng(12345)
    v0 = rng.standard_normal(n)
    try:
        return spla.eigs(op, k=k, which="LM", ncv=ncv, v0=v0, maxiter=max(1000, 10 * n))
    except spla.ArpackNoConvergence as exc:
        raise SolverError(f"ARPACK did not converge ({len(exc.eigenvalues)} of {k} "
                          "eigenpairs)", last_iterate=exc.eigenvalues) from None


def _blocks(lam: np.ndarray, X: np.ndarray, sigma: complex) -> list[EigenBlock]:
    """Group eigenpairs into clusters and give each a real basis, nearest to σ first.

    The cluster tolerance is relative to ``max(|σ|, |λ|)``: when every computed λ is a
    zero mode (a free body, few modes) ``max |λ|`` alone is round-off and would split the
    zero cluster into single vectors.
    """
    scale = max(float(np.max(np.abs(lam))), abs(sigma), np.finfo(float).tiny)
    lam = np.where(np.abs(lam.imag) <= REAL_RTOL * scale, lam.real + 0j, lam)
    keep = lam.imag >= 0  # a complex pair is represented by its upper member
    lower = np.flatnonzero(~keep)
    for i in lower:  # lone lower members (partner not computed) are conjugated
        if not np.any(np.abs(lam[keep] - np.conj(lam[i])) <= CLUSTER_RTOL * scale * 10):
            lam[i], X[:, i], keep[i] = np.conj(lam[i]), np.conj(X[:, i]), True
    lam, X = lam[keep], X[:, keep]
    order = np.lexsort((lam.imag, lam.real))
    lam, X = lam[order], X[:, order]
    cut = np.flatnonzero(np.abs(np.diff(lam)) > CLUSTER_RTOL * scale) + 1
    blocks = []
    for idx in np.split(np.arange(lam.size), cut):
        values, xs = lam[idx], X[:, idx]
        m = idx.size
        real = np.all(values.imag == 0)
        Y = np.concatenate([xs.real, xs.imag], axis=1)
        U = np.linalg.svd(Y, full_matrices=False)[0]
        if real:
            basis, vals = U[:, :m], np.full(m, values.real.mean())
        else:
            basis = U[:, : 2 * m]
            c = values.mean()
            vals = np.tile(np.array([c, np.conj(c)]), m)
        blocks.append(EigenBlock(vals, basis))
    blocks.sort(key=lambda b: abs(b.center - sigma))
    return blocks


def right_blocks(si: ShiftInvert, k: int, source: str | None = None) -> list[EigenBlock]:
    """The ``k`` eigenpairs of ``K x = λ M x`` nearest ``σ``, as real blocks (nearest first).

    References
    ----------
    Ericsson & Ruhe (1980), the spectral transformation Lanczos/Arnoldi method; ARPACK
    (Lehoucq, Sorensen & Yang 1998) mode 1 on ``(K − σM)⁻¹ M``.
    """
    theta, X = _arpack(si.operator(), k, si.n, source)
    return _blocks(si.sigma + 1.0 / theta, X, si.sigma)


def _null_shift_invert(fe: FEModel, si: ShiftInvert, right: list[EigenBlock],
                       zero_tol: float) -> ShiftInvert:
    """A factorization whose eigenvalues nearest the shift are the zero ones.

    Subspace iteration on ``(K − σM)⁻ᵀ Mᵀ`` converges to the left vectors of the eigenvalues
    *nearest σ*; that is the null space only when σ is much closer to 0 than to every nonzero
    eigenvalue. A band selection shifts to the middle of the band, so a zero mode in the
    band needs its own small negative shift (:func:`default_shift`, one more sparse LU).
    """
    sigma = complex(si.sigma)
    nonzero = [abs(b.center - sigma) for b in right if abs(b.center) > zero_tol]
    if sigma.imag == 0 and sigma.real <= 0 and all(d >= 10 * abs(sigma) for d in nonzero):
        return si
    return ShiftInvert(fe.K, fe.M, default_shift(fe), fe.source)


def _left_null(si: ShiftInvert, m: int, K: sps.spmatrix | None = None,
               rtol: float = 1e-10) -> np.ndarray:
    """Left null space of ``K`` (dimension m): subspace iteration on ``(K − σM)⁻ᵀ Mᵀ``.

    Each step contracts the unwanted components by ``|σ| / |λ_1 − σ|`` (``λ_1`` the lowest
    nonzero eigenvalue; ~1e-6 for the default shift), so a few steps suffice. It stops when
    the subspace no longer changes (``< 1e-13``) or, given ``K``, when the residual
    ``‖Kᵀ Z‖_F ≤ rtol ‖K‖₁ √m`` is reached and the change has stagnated (round-off keeps
    the change of large models near 1e-12, which the bare change test never accepted:
    refine-2 middle-ear models failed with it).
    """
    rng = np.random.default_rng(2024)
    Z, _ = np.linalg.qr(rng.standard_normal((si.n, m)))
    KT = None if K is None else sps.csr_matrix(K).T.tocsr()
    knorm = None if K is None else float(spla.norm(K, 1))
    last = np.inf
    for it in range(300):
        Znew, _ = np.linalg.qr(np.real(si.solve(si.MT @ Z, transpose=True)))
        change = np.linalg.norm(Znew - Z @ (Z.T @ Znew))
        Z = Znew
        if change < 1e-13:
            return Z
        if KT is not None and it >= 2 and change >= 0.5 * last:
            res = np.linalg.norm(KT @ Z) / (knorm * np.sqrt(m))
            if res <= rtol:
                return Z
        last = change
    raise SolverError("left null vectors (λ = 0) did not converge by subspace iteration; "
                      "use a shift closer to 0", residual=change)


def up_left_null(fe: FEModel, right_null: np.ndarray, rtol: float = 1e-10
                 ) -> np.ndarray | None:
    """Left null vectors of a u–p ``K`` from the right ones, analytically (§3).

    ``Kᵀ = [Ksᵀ 0; −Cᵀ Kf]``: with a regular structural stiffness ``Ks`` (a supported
    structure) the left null vectors are ``[0; p]`` for the right null vectors ``[u; p]``
    (``Kf p = 0``) — the u–p relation ``[ρλu; p]`` at ``λ = 0``. Returns ``None`` when the
    residual ``‖Kᵀ w‖ ≤ rtol ‖K‖₁ ‖w‖`` is not met (a free structure: then ``Ks`` is
    singular and the structural rows of the left vectors do not vanish).
    """
    W = np.where(fe.pressure_dofs[:, None], np.real(right_null), 0.0)
    norms = np.linalg.norm(W, axis=0)
    if np.any(norms == 0):
        return None
    W = np.linalg.qr(W / norms)[0]
    res = np.linalg.norm(fe.K.T @ W, axis=0)
    if np.all(res <= rtol * float(spla.norm(fe.K, 1))):
        return W
    return None


def symmetric_pencil(fe: FEModel) -> bool:
    """Whether ``M`` and ``K`` are symmetric, so that left eigenvectors equal right ones.

    True when the model declares both symmetric (``fe.symmetric``, checked on construction)
    or when both are symmetric to :data:`~neweul_py.elastic.fe_model.SYMMETRY_RTOL` (one
    sparse ``A − Aᵀ`` each, no densification). ``D`` does not enter the undamped pencil.
    """
    if fe.symmetric.get("M") and fe.symmetric.get("K"):
        return True
    return asymmetry(fe.M) <= SYMMETRY_RTOL and asymmetry(fe.K) <= SYMMETRY_RTOL


def _match_subspace(fe: FEModel, b: EigenBlock, cands: list[EigenBlock]) -> EigenBlock:
    """The left invariant subspace of the right cluster ``b`` from candidate left blocks.

    The candidates (all left clusters of numerically the same eigenvalue — the left and the
    right clustering may cut a near-degenerate group differently) are stacked and the
    ``m``-dimensional subspace that pairs best with ``b`` under ``M`` is taken: left singular
    vectors of the small block ``Qᵀ M V_c`` (``Q`` orthonormal basis of the candidates).
    Left vectors of other eigenvalues are M-orthogonal to ``V_c`` and drop out.
    """
    m = b.basis.shape[1]
    L = np.concatenate([np.real(c.basis) for c in cands], axis=1)
    if L.shape[1] == m:
        return EigenBlock(b.values, L)
    Q, _ = np.linalg.qr(L)
    U, s, _ = np.linalg.svd(Q.T @ (fe.M @ b.basis), full_matrices=False)
    if s[-1] <= 1e-8 * s[0]:
        raise SolverError(f"the left eigenvectors near λ = {b.center:.6g} do not pair with "
                          f"the right {m}-dimensional invariant subspace", residual=s[-1] / s[0])
    return EigenBlock(b.values, Q @ U[:, :m])


def left_blocks(fe: FEModel, si: ShiftInvert, right: list[EigenBlock], k_ext: int,
                up_relation: bool = True, use_symmetry: bool = True) -> list[EigenBlock]:
    """Left eigenvector blocks matching ``right`` block by block (invariant subspaces).

    Symmetric pencils (:func:`symmetric_pencil`, and ``use_symmetry``) return ``right``
    itself: ``W = V``. For ``up-coupled`` models (and ``up_relation``) each real nonzero
    block uses the u–p relation ``w = [ρλu; p]`` (§3), which maps a cluster basis to a left
    cluster basis; blocks with ``λ ≈ 0`` (``|λ| ≤ 10⁻⁶ max(|σ|, |λ|)``) use the transposed
    problem (left null space). Otherwise the transposed problem ``(K − σM)⁻ᵀ Mᵀ`` is solved
    with ARPACK (``k_ext`` eigenpairs, same LU); every left cluster within
    ``10³·CLUSTER_RTOL`` of the spectrum scale ``max(|σ|, |λ|)`` of a right cluster joins
    its left subspace, and the best-pairing subspace of the right dimension is kept
    (:func:`_match_subspace`) — a degenerate cluster such as the 6-fold ``λ = 0`` of a free
    body is matched as a whole, not vector by vector.

    Raises
    ------
    SolverError
        A right cluster has fewer left eigenvectors of its eigenvalue than its dimension, or
        their span does not pair with it.
    """
    if use_symmetry and symmetric_pencil(fe):
        return list(right)
    # the scale of the computation, not of the kept blocks: with only the λ = 0 cluster kept
    # (modes ≤ 6 of a free body), max |λ| of the kept blocks is round-off itself
    scale = max([abs(si.sigma)] + [abs(b.center) for b in right]) or 1.0
    zero_tol = 1e-6 * scale
    if (fe.kind == "up-coupled" and up_relation
            and not any(b.is_complex for b in right)):
        out = []
        scale_u = fe.density * np.where(fe.pressure_dofs, 0.0, 1.0)
        null_si = None
        for b in right:
            lam = b.values[0].real
            if abs(lam) <= zero_tol:
                w = up_left_null(fe, b.basis)
                if w is None:  # free structure: the transposed problem
                    if null_si is None:
                        null_si = _null_shift_invert(fe, si, right, zero_tol)
                    w = _left_null(null_si, b.values.size, fe.K)
                out.append(EigenBlock(b.values, w))
            else:
                w = b.basis * np.where(fe.pressure_dofs, 1.0, scale_u * lam)[:, None]
                out.append(EigenBlock(b.values, w))
        return out
    theta, X = _arpack(si.operator(transpose=True), k_ext, si.n, fe.source)
    lefts = _blocks(si.sigma + 1.0 / theta, X, si.sigma)
    scale = max([scale] + [abs(lb.center) for lb in lefts])
    tol = 1e3 * CLUSTER_RTOL * scale
    out = []
    for b in right:
        cands = [lb for lb in lefts if abs(lb.center - b.center) <= tol
                 and lb.is_complex == b.is_complex]
        found = sum(c.basis.shape[1] for c in cands)
        if found < b.basis.shape[1]:
            raise SolverError(f"no left eigenvector cluster matches λ = {b.center:.6g} "
                              f"(multiplicity {b.basis.shape[1]}, {found} left vectors "
                              "found)")
        out.append(_match_subspace(fe, b, cands))
    return out
