"""A two-sided (Petrov–Galerkin) global basis from primal and adjoint snapshots: balanced POD.

The u–p model of Eq. (2) is unsymmetric: its right and left eigenvectors differ
(``[u; p]`` and ``[ρλu; p]``, ``docs/equations.md`` §3), and so do the responses to the
loads, ``X_ij = A_ij⁻¹ F`` (primal), and to the outputs, ``Y_ij = A_ij⁻ᵀ c`` (adjoint), of
:func:`~neweul_py.elastic.parametric.snapshot_basis.frequency_snapshots` (``A_ij = K_i + K_x
+ iω_j D_i − ω_j² M_i`` at every sample ``i`` and snapshot frequency ``ω_j``). A projection
whose right basis ``V`` holds the primal and whose left basis ``W`` holds the adjoint
snapshots matches the transfer function and its derivative at every ``(i, ω_j)`` (Grimme 1997;
Baur, Beattie, Benner & Gugercin 2011, *SIAM J. Sci. Comput.* 33, §3): each side needs only
its own snapshots, where a Galerkin basis (``W = V``) must hold both.

The two snapshot sets are compressed together by **balanced POD** (Willcox & Peraire 2002,
*AIAA J.* 40, 2323–2330; Rowley 2005, *Int. J. Bifurcation Chaos* 15, 997–1013): with the
snapshot matrices ``X̂``, ``Ŷ`` (columns: real and imaginary parts) and the mean mass matrix
``M̄`` of the samples,

    Ŷᵀ M̄ X̂ = U Σ Zᵀ,     V = X̂ Z_r Σ_r^{-1/2},     W = Ŷ U_r Σ_r^{-1/2},     Wᵀ M̄ V = I_r,

keeping the ``r`` pairs of largest ``σ``: the directions that are both driven by the loads
and seen by the outputs, paired so that the reduced mass matrix is ``I`` on average. The
columns are scaled to unit energy first, so that every snapshot counts alike (as in the
Galerkin :func:`~neweul_py.elastic.parametric.snapshot_basis.snapshot_basis`): a primal
snapshot ``x`` in ``xᵀḠx`` (:func:`~neweul_py.elastic.parametric.global_basis.energy_metric`,
Joules), an adjoint snapshot ``y`` in the same norm of its primal equivalent: for ``D = 0``
and symmetric ``Ms, Ks, Mf, Kf``,

    A(ω)ᵀ S_ω = S_ω A(ω),     S_ω = diag(ρω² on the u rows, 1 on the p rows),

so ``y = A⁻ᵀ c`` is ``S_ω ŷ`` with ``ŷ = A⁻¹ S_ω⁻¹ c`` a primal response, normed as such.
The scaling decides what is kept, not what the kept vectors span.

**Stability.** A Petrov–Galerkin projection of the u–p model keeps neither its symmetric
blocks nor the energy of its ``(u, ψ = ∫p dt)`` form, so stability is not guaranteed at any
order — unlike the block-diagonal Galerkin basis of
:mod:`~neweul_py.elastic.parametric.global_basis`. The weak spot is ``λ = 0``: the constant
pressure of a closed air volume is a zero mode of the u–p model (right eigenvector
``[K_s⁻¹ C p₀; p₀]``, left ``[0; p₀]``), which the frequency-response snapshots (ω > 0)
barely see; projected obliquely it becomes ``λ_r < 0``, a real pole in the right half plane
(on the middle ear at refine 0: ``λ_r ≈ −2·10⁵ s⁻²`` at every working point, a real pole
``s ≈ +630 s⁻¹`` of the coupled EMBS). The zero modes of every sample
(:func:`zero_mode_pairs`) are therefore kept first as right/left pairs (``pairs``) and the
snapshots balanced in the rest: a projection
whose ``V`` holds a right null vector of ``K_i`` reproduces ``λ = 0`` at that sample for
any ``W``. Check the reduced (and the coupled) model with
:func:`~neweul_py.elastic.quality.measures.right_half_plane_poles`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sps

from ...errors import DataError
from ..fe_model import FEModel
from ..reductors.modal import reduce_modal
from ..reductors.projection import Progress
from .global_basis import energy_metric
from .snapshot_basis import frequency_snapshots

__all__ = ["TwoSidedBasis", "balanced_snapshot_basis", "balanced_truncation",
           "zero_mode_pairs"]

#: Modes below this frequency [Hz] count as zero modes (:func:`zero_mode_pairs`).
ZERO_MODE_HZ = 1.0
#: The most zero modes looked for per FE model (closed air volumes, free rigid motions).
MAX_ZERO_MODES = 8


@dataclass(frozen=True)
class TwoSidedBasis:
    """Right and left bases with ``Wᵀ M̄ V = I`` and the singular values of the pairing.

    Attributes
    ----------
    V, W
        (n, r) right and left bases.
    singular_values
        Every singular value ``σ`` of the scaled cross Gram matrix ``Ŷᵀ M̄ X̂``, descending
        (the first ``r`` belong to the kept pairs).
    """

    V: np.ndarray
    W: np.ndarray
    singular_values: np.ndarray

    @property
    def order(self) -> int:
        """Number of kept pairs ``r``."""
        return int(self.V.shape[1])

    def truncated(self, order: int) -> TwoSidedBasis:
        """The first ``order`` pairs (the basis of a smaller ``order`` or ``rtol``, without
        new snapshots; ``Wᵀ M̄ V = I`` holds for any leading block)."""
        r = int(order)
        if not 1 <= r <= self.order:
            raise DataError(f"order must be in 1 … {self.order}, got {order}", None, "order")
        return TwoSidedBasis(self.V[:, :r], self.W[:, :r], self.singular_values)


def balanced_truncation(X: np.ndarray, Y: np.ndarray, M: sps.spmatrix | np.ndarray,
                        rtol: float = 1e-10, order: int | None = None) -> TwoSidedBasis:
    """Balanced POD of right snapshots ``X`` and left snapshots ``Y`` (module docstring).

    Parameters
    ----------
    X, Y
        (n, m) and (n, l) real snapshot matrices, each column already scaled to the weight
        it should have.
    M
        The pairing matrix (n × n): the bases satisfy ``Wᵀ M V = I``.
    rtol
        Pairs with ``σ < rtol · σ_1`` are dropped.
    order
        Keep at most this many pairs.

    Returns
    -------
    TwoSidedBasis

    Examples
    --------
    >>> import numpy as np
    >>> X = np.eye(4)[:, :2]
    >>> b = balanced_truncation(X, X, np.eye(4))
    >>> np.allclose(b.W.T @ b.V, np.eye(2))
    True
    """
    H = np.asarray(Y.T @ (M @ X))
    U, sv, Zt = np.linalg.svd(H, full_matrices=False)
    if not sv.size or sv[0] <= 0:
        raise DataError("the left and right snapshots are M-orthogonal: no two-sided basis "
                        "pairs them", None, "snapshots")
    r = int(np.count_nonzero(sv >= rtol * sv[0]))
    r = r if order is None else min(r, int(order))
    scale = 1.0 / np.sqrt(sv[:r])
    V = X @ (Zt[:r].T * scale)
    W = Y @ (U[:, :r] * scale)
    return TwoSidedBasis(V, W, sv)


def balanced_snapshot_basis(fes: Sequence[FEModel], loads: Sequence[np.ndarray],
                            outputs: Sequence[np.ndarray], freqs_hz: Sequence[float],
                            extra_stiffness: sps.spmatrix | None = None,
                            rtol: float = 1e-10, order: int | None = None,
                            pairs: Sequence[tuple[np.ndarray, np.ndarray]] = (),
                            progress: Progress = None, workers: int = 1) -> TwoSidedBasis:
    """The two-sided global basis of the samples ``fes`` (module docstring).

    Parameters
    ----------
    fes
        The FE model of every sample (one discretization).
    loads
        Per sample the (n, k) loads ``F_i`` (the primal snapshots' right-hand sides).
    outputs
        Per sample the (n, l) output rows, transposed (the adjoint snapshots' right-hand
        sides): the outputs and, for a body coupled at nodes, the node loads' work
        conjugates (the malleus of the middle ear: ``K_x T``, like the loads).
    freqs_hz
        Snapshot frequencies [Hz] (> 0).
    extra_stiffness
        ``K_x`` added for the snapshots only (the stiffness the body will be attached
        with); the reduced body is the projection of the FE models themselves.
    rtol, order
        Truncation (:func:`balanced_truncation`).
    pairs
        Right and left columns ``(X₀, Y₀)`` (e.g. the zero modes of every sample,
        :func:`zero_mode_pairs`) kept first, whatever the snapshots: their own balanced
        truncation ``(V₀, W₀)`` (same ``rtol``; the zero modes of all samples share their
        pressure part), the snapshots deflated obliquely, ``X − V₀W₀ᵀM̄X`` and
        ``Y − W₀V₀ᵀM̄ᵀY``, and ``V = [V₀ V₁]``, ``W = [W₀ W₁]`` with ``Wᵀ M̄ V = I`` (module
        docstring, "Stability"); their singular values are reported as the largest one.
    progress
        Called with short messages.
    workers
        Processes solving the samples
        (:func:`~neweul_py.elastic.parametric.snapshot_basis.frequency_snapshots`).

    Returns
    -------
    TwoSidedBasis
        With ``Wᵀ M̄ V = I``, ``M̄`` the mean of the samples' mass matrices.

    References
    ----------
    Willcox & Peraire (2002); Rowley (2005); ``docs/equations.md`` §3;
    ``docs/equations-middle-ear.md``, "Choice of reduction".
    """
    if len(outputs) != len(fes):
        raise DataError(f"{len(outputs)} output sets for {len(fes)} FE models", None,
                        "outputs")
    is_u = fes[0].dof_kind != "p"
    rho = fes[0].density if fes[0].kind == "up-coupled" else None
    if fes[0].kind == "up-coupled" and not (rho and rho > 0):
        raise DataError("the u–p adjoint scaling needs the fluid density", fes[0].source,
                        "density")
    G = energy_metric(fes)
    X, Y = [], []
    for x, y, w in frequency_snapshots(fes, loads, freqs_hz, extra_stiffness, outputs,
                                       progress, workers):
        for part in (x.real, x.imag):
            X.append(_unit_energy(part, G))
        for part in (y.real, y.imag):
            equivalent = part.copy()
            if rho is not None:
                equivalent[is_u] /= rho * w * w
            norm = np.sqrt(np.maximum(np.einsum("ij,ij->j", equivalent, G @ equivalent), 0))
            Y.append(part[:, norm > 0] / norm[norm > 0])
    M = sum(fe.M for fe in fes) / len(fes)
    X, Y = np.hstack(X), np.hstack(Y)
    X0 = np.hstack([np.zeros((M.shape[0], 0)), *(a for a, _ in pairs)])
    Y0 = np.hstack([np.zeros((M.shape[0], 0)), *(b for _, b in pairs)])
    if X0.shape != Y0.shape:
        raise DataError(f"{X0.shape[1]} right and {Y0.shape[1]} left columns in the pairs",
                        None, "pairs")
    if X0.shape[1]:
        kept = balanced_truncation(X0, Y0, M, rtol)          # Wₖᵀ M̄ Vₖ = I
        X = X - kept.V @ (kept.W.T @ (M @ X))                # deflated: Wₖᵀ M̄ X = 0
        Y = Y - kept.W @ (kept.V.T @ (M.T @ Y))              # Yᵀ M̄ Vₖ = 0
    basis = balanced_truncation(X, Y, M, rtol, None if order is None else
                                int(order) - (kept.order if X0.shape[1] else 0))
    if X0.shape[1]:
        basis = TwoSidedBasis(np.hstack([kept.V, basis.V]), np.hstack([kept.W, basis.W]),
                              np.r_[np.full(kept.order, basis.singular_values[0]),
                                    basis.singular_values])
    if progress is not None:
        progress(f"two-sided basis: {basis.order} pairs from {X.shape[1]} right and "
                 f"{Y.shape[1]} left columns")
    return basis


def zero_mode_pairs(fe: FEModel, f_max: float = ZERO_MODE_HZ
                    ) -> tuple[np.ndarray, np.ndarray]:
    """The right and left eigenvectors ``(V₀, W₀)`` of the modes of ``fe`` below ``f_max``
    [Hz] (``λ < (2π f_max)²``; at most :data:`MAX_ZERO_MODES`): the zero modes of the
    two-sided basis (module docstring, "Stability"), two-sided modal
    (:func:`~neweul_py.elastic.reductors.modal.reduce_modal`, ``W₀ᵀ M V₀ = I``). ``(n, 0)``
    arrays when there is none."""
    count = min(MAX_ZERO_MODES, fe.n_dofs - 2)
    body = reduce_modal(fe, modes=count, two_sided=True, store_bases=True)
    keep = np.flatnonzero(np.diag(body.K) < (2 * np.pi * f_max) ** 2)
    return body.V[:, keep], body.W[:, keep]


def _unit_energy(X: np.ndarray, G: sps.spmatrix) -> np.ndarray:
    """The nonzero columns of ``X`` scaled to ``xᵀGx = 1``."""
    norm = np.sqrt(np.maximum(np.einsum("ij,ij->j", X, G @ X), 0.0))
    return X[:, norm > 0] / norm[norm > 0]
