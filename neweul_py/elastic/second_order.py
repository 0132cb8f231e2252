"""The second-order displacement field of a stress-stiffened body (``docs/equations.md`` §2.3).

Geometric stiffening is the work of the inertia loads through the second-order part of the
displacement, ``u = Φ q + ½ Ψ(q, q)`` (Schwertassek & Wallrapp 1999, ch. 6; the quadratic
modes of Wallrapp 1994): for every load ``f`` of a unit inertia case ``c``,
``f·Ψ_kl = −(Φᵀ K_G,c Φ)_kl``. This module builds ``Ψ`` in the span ``Y`` of the static
responses ``u_c`` of those cases (:func:`~neweul_py.elastic.invariants.inertia_responses`),
``K``-orthonormalized, ``Y = U C`` with ``Yᵀ K Y = I``::

    Ψ_kl = Σ_j Y_j A_j[k, l],   A_j = −Σ_c C[c, j] Φᵀ K_G,c Φ,

which reproduces ``f_c·Ψ = −Φᵀ K_G,c Φ`` for every case exactly (``Cᵀ (Uᵀ K U) C = I``). With
``z = [q; y]``, ``y_j = ½ qᵀ A_j q`` the body is the consistent FFRF body of the extended
basis ``[Φ, Y]`` seen through ``z(q)``: its kinetic energy is exact for the field, so
``M_b(q) = Tᵀ M_b,z T`` (``T = ∂z/∂q``) is a Gram matrix — positive definite for every ``q``
and mode count — and the stiffening, its reactions on the rigid rows and gravity's share
follow from one Lagrangian. The truncated form (``Oe¹``, ``Ct¹``, ``−K_G`` folded into
``C2``) is its expansion to second order, which turns the mass matrix indefinite when the
clamped modes nearly contain the rigid rotation of the frame (≥ 10 modes of a pendulum).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import scipy.sparse as sps

from ..errors import DataError
from .invariants import LOAD_CASES, Invariants, QuadraticField, compute_invariants

__all__ = ["second_order_field", "with_second_order"]


def second_order_field(fe, V: np.ndarray, geometric_stiffness: Mapping[str, object],
                       responses: Mapping[str, np.ndarray], *,
                       rtol: float = 1e-10) -> QuadraticField:
    """The second-order field of the module docstring.

    Parameters
    ----------
    fe
        The FE model (``M``, ``K``).
    V
        (n, nq) the body's (one-sided) basis ``Φ``.
    geometric_stiffness
        Case → ``K_G,c`` (n×n), as for ``compute_invariants``.
    responses
        Case → static displacement ``u_c`` (n,) of the same case
        (:func:`~neweul_py.elastic.invariants.inertia_responses`).
    rtol
        Responses whose ``K``-energy falls below ``rtol`` times the largest are dependent
        and dropped (e.g. the out-of-plane cases of a planar beam).

    Raises
    ------
    DataError
        No case with both a stiffness and a response, or arrays of the wrong shape.
    """
    V = np.asarray(V, dtype=np.float64)
    n = V.shape[0]
    cases = [c for c in LOAD_CASES if c in geometric_stiffness and c in responses]
    if not cases:
        raise DataError("no load case has both a geometric stiffness and a static response",
                        fe.source, "stiffening")
    U = np.column_stack([np.asarray(responses[c], dtype=np.float64) for c in cases])
    if U.shape[0] != n:
        raise DataError(f"static responses have {U.shape[0]} rows, the basis {n}", fe.source,
                        "stiffening")
    K = sps.csr_matrix(fe.K)
    gram = U.T @ (K @ U)
    lam, E = np.linalg.eigh(0.5 * (gram + gram.T))
    keep = lam > rtol * max(float(lam.max()), 1e-300)
    C = E[:, keep] / np.sqrt(lam[keep])                 # (nc, ny): Y = U C, Yᵀ K Y = I
    G = []
    for c in cases:
        g = V.T @ (sps.csr_matrix(geometric_stiffness[c]) @ V)
        G.append(0.5 * (g + g.T))
    A = -np.einsum("cj,ckl->jkl", C, np.array(G))
    extended = compute_invariants(fe, np.hstack((V, U @ C)))
    return QuadraticField(extended, A)


def with_second_order(inv: Invariants, fe, V: np.ndarray,
                      geometric_stiffness: Mapping[str, object],
                      responses: Mapping[str, np.ndarray]) -> Invariants:
    """``inv`` with its :class:`~neweul_py.elastic.invariants.QuadraticField` (one-sided
    bodies only; two-sided bodies keep the first-order stiffening terms)."""
    from dataclasses import replace

    if inv.two_sided:
        return inv
    return replace(inv, quadratic=second_order_field(fe, V, geometric_stiffness, responses))
