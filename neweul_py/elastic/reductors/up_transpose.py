"""The transposed u–p dynamic stiffness as a diagonal similarity of itself (equations.md §3).

The pressure-based u–p model of Eq. (2) has the dynamic stiffness

    A(ω) = K + iωD − ω²M = [A_uu, −C; −ω²ρCᵀ, A_pp]

(``M_up = 0``, ``K_pu = 0``, ``M_pu = ρCᵀ = −ρK_upᵀ``, no loss coupling ``D_up = D_pu = 0``,
symmetric diagonal blocks ``A_uu``, ``A_pp``). Then

    Aᵀ = S A S⁻¹,     S(ω) = diag(I_u, I_p / (ω²ρ)),

so the adjoint response of a load ``c`` without pressure rows (``S⁻¹c = c``) is the scaled
primal one, ``A⁻ᵀc = S A⁻¹c``, and its derivatives in ``ω`` follow from those of the primal
response and of ``S`` (:func:`adjoint_from_primal`). An adjoint snapshot of a load the primal
snapshots already hold thus needs no transposed solve.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sps

from ..fe_model import FEModel, up_block_deviations

__all__ = ["EXACT_RTOL", "adjoint_from_primal", "mirrored_loads", "up_similarity"]

#: Largest relative deviation from the block structure for which the similarity is used: the
#: adjoint responses it gives then differ from transposed solves by round-off only.
EXACT_RTOL = 1e-13


def up_similarity(fe: FEModel, K: sps.spmatrix, D: sps.spmatrix | None) -> float | None:
    """The fluid density ``ρ`` when ``A(ω) = K + iωD − ω²M`` of the u–p model ``fe`` (with
    the stiffness ``K`` and damping ``D`` used, e.g. with springs added) satisfies
    ``Aᵀ = S A S⁻¹`` (module docstring) to :data:`EXACT_RTOL` in every deviation of
    :func:`~neweul_py.elastic.fe_model.up_block_deviations`; ``None`` otherwise (another
    kind of model, loss coupling between u and p, an unsymmetric block)."""
    if fe.kind != "up-coupled" or not fe.density or fe.density <= 0:
        return None
    rho = float(fe.density)
    dev = up_block_deviations(fe.M, K, D, fe.dof_kind == "p", rho)
    return rho if max(dev.values()) <= EXACT_RTOL else None


def mirrored_loads(F: np.ndarray, c: np.ndarray, is_p: np.ndarray) -> dict[int, int]:
    """``{j: k}``: the adjoint loads ``c[:, j]`` without pressure rows that equal a primal
    load ``F[:, k]`` (their adjoint responses are ``S`` times the primal ones)."""
    out = {}
    for j in range(c.shape[1]):
        if np.any(c[is_p, j]):
            continue
        k = next((k for k in range(F.shape[1]) if np.array_equal(F[:, k], c[:, j])), None)
        if k is not None:
            out[j] = k
    return out


def adjoint_from_primal(X: list[np.ndarray], w: float, rho: float,
                        is_p: np.ndarray) -> list[np.ndarray]:
    """The adjoint response ``Y = A⁻ᵀc = S X`` of a load without pressure rows and its
    derivatives ``Y′`` and ``Y″/2`` in ``ω`` (as many as given), from the primal response
    ``X = A⁻¹c`` and its ``X′``, ``X″/2`` (Leibniz on ``Y = S X`` with
    ``S_p = 1/(ω²ρ)``, ``S_p′ = −2/(ω³ρ)``, ``S_p″/2 = 3/(ω⁴ρ)``)::

        Y_p = X_p/(ω²ρ),  Y′_p = (X′_p − 2X_p/ω)/(ω²ρ),
        Y″_p/2 = (X″_p/2 − 2X′_p/ω + 3X_p/ω²)/(ω²ρ),   and Y_u = X_u etc.
    """
    s = 1.0 / (w * w * rho)
    combos = ([1.0], [-2.0 / w, 1.0], [3.0 / (w * w), -2.0 / w, 1.0])
    out = []
    for m in range(len(X)):
        Y = np.array(X[m], copy=True)
        Y[is_p] = s * sum(a * X[i][is_p] for i, a in enumerate(combos[m]))
        out.append(Y)
    return out
