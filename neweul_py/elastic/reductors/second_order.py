"""The second-order displacement field of a stress-stiffened body (``docs/equations.md`` §2.3).

Geometric stiffening is the work of the inertia loads through the second-order part of the
displacement, ``u = Φ q + ½ Ψ(q, q)`` (Schwertassek & Wallrapp 1999, ch. 6; the quadratic
modes of Wallrapp 1994): for every load ``f_c`` of a unit inertia case ``c``,
``f_c·Ψ_kl = −(Φᵀ K_G,c Φ)_kl``. This module builds ``Ψ`` in the span of the static
responses ``u_c`` of those cases
(:func:`~neweul_py.elastic.reductors.invariants.inertia_responses`),
on the basis dual to the loads, ``Y = U (Fᵀ U)⁺`` (``Fᵀ Y = I`` on the independent cases)::

    Ψ_kl = Σ_c Y_c A_c[k, l],   A_c = −sym(Φᵀ K_G,c Φ),   y_c(q) = ½ qᵀ A_c q,

which reproduces ``f_c·Ψ = −Φᵀ K_G,c Φ`` for every case exactly. ``y_c`` is a physical
quantity (the displacement conjugate to the unit load ``c``), the same in every sample of a
parametric body, so that samples mix consistently; ``Fᵀ U`` is equilibrated before its
pseudo-inverse, so that the result does not depend on units or slenderness. With
``z = [q; y]`` the body is the consistent FFRF body of the extended basis ``[Φ, Y]`` seen
through ``z(q)``: its kinetic energy is exact for the field, so ``M_b(q) = Tᵀ M_b,z T``
(``T = ∂z/∂q``) is a Gram matrix — positive definite for every ``q`` and mode count — and the
stiffening, its reactions on the rigid rows and gravity's share follow from one Lagrangian.
The truncated form (``Oe¹``, ``Ct¹``, ``−K_G`` folded into ``C2``) is its expansion to second
order, which turns the mass matrix indefinite when the clamped modes nearly contain the rigid
rotation of the frame (≥ 10 modes of a pendulum).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

import numpy as np
import scipy.sparse as sps

from ...errors import DataError
from ..bodies.invariants import LOAD_CASES, Invariants, QuadraticField
from .invariants import compute_invariants, inertia_loads

__all__ = ["second_order_field", "with_second_order"]


def second_order_field(fe, V: np.ndarray, geometric_stiffness: Mapping[str, object],
                       responses: Mapping[str, np.ndarray], *, rtol: float = 1e-10,
                       source: str | None = None) -> QuadraticField:
    """The second-order field of the module docstring.

    Parameters
    ----------
    fe
        The FE model (``M``, ``K``; its inertia loads, :func:`inertia_loads`).
    V
        (n, nq) the body's (one-sided) basis ``Φ``.
    geometric_stiffness
        Case → ``K_G,c`` (n×n), as for ``compute_invariants``.
    responses
        Case → static displacement ``u_c`` (n,) of the same case, support clamped
        (:func:`~neweul_py.elastic.reductors.invariants.inertia_responses`, FE file ``UG.<case>``).
    rtol
        Relative tolerance of the pseudo-inverse of the equilibrated ``Fᵀ U`` (dependent
        responses, e.g. the out-of-plane cases of a planar beam, carry no new direction).
    source
        Named in errors (default ``fe.source``).

    Returns
    -------
    QuadraticField
        The extended body ``[Φ, Y]`` and ``A`` (one ``A_c`` per case with a response).

    Raises
    ------
    DataError
        No case with both a stiffness and a nonzero response, responses of the wrong length,
        or responses that do not solve ``K u_c = f_c`` (``Fᵀ U ≠ Uᵀ K U``: another model's or
        scaled responses), naming ``UG.<case>``.
    """
    src = fe.source if source is None else source
    V = np.asarray(V, dtype=np.float64)
    n = V.shape[0]
    cases = [c for c in LOAD_CASES if c in geometric_stiffness and c in responses]
    if not cases:
        raise DataError("no load case has both a geometric stiffness and a static response",
                        src, "stiffening")
    for c in cases:
        if np.shape(responses[c]) != (n,):
            raise DataError(f"static response has shape {np.shape(responses[c])}, the basis "
                            f"{n} rows", src, f"UG.{c}")
    U = np.column_stack([np.asarray(responses[c], dtype=np.float64) for c in cases])
    loads = inertia_loads(fe)
    F = np.column_stack([loads[c] for c in cases])
    B = F.T @ U                                          # = Uᵀ K U for true responses
    BK = U.T @ (sps.csr_matrix(fe.K) @ U)
    scale = float(np.abs(B).max()) if B.size else 0.0
    d = np.sqrt(np.clip(np.diag(B), 0.0, None))
    keep = d > 1e-30 * max(float(d.max()), 1e-300)       # zero: no DOFs for that case
    if not keep.any() or not np.isfinite(scale) or scale == 0.0:
        raise DataError("the static responses are zero or not finite: no second-order field",
                        src, "UG")
    miss = np.abs(B - BK).max(axis=0) / scale
    if miss.max() > 1e-6:
        worst = cases[int(np.argmax(miss))]
        raise DataError(f"the static responses do not solve K u = f of the unit inertia loads "
                        f"(f·u and uᵀ K u differ by {miss.max():.2g} relative): responses of "
                        "another model, scaled or in other units", src, f"UG.{worst}")
    cases = [c for c, k in zip(cases, keep, strict=True) if k]
    d, U = d[keep], U[:, keep]
    Bn = B[np.ix_(keep, keep)] / np.outer(d, d)          # equilibrated: unit diagonal
    pinv = np.linalg.pinv(0.5 * (Bn + Bn.T), rcond=rtol, hermitian=True) / np.outer(d, d)
    G = []
    for c in cases:
        g = V.T @ (sps.csr_matrix(geometric_stiffness[c]) @ V)
        G.append(-0.5 * (g + g.T))
    extended = compute_invariants(fe, np.hstack((V, U @ pinv)))
    return QuadraticField(extended, np.array(G))


def with_second_order(inv: Invariants, fe, V: np.ndarray,
                      geometric_stiffness: Mapping[str, object],
                      responses: Mapping[str, np.ndarray],
                      source: str | None = None) -> Invariants:
    """``inv`` with its :class:`~neweul_py.elastic.bodies.invariants.QuadraticField`.

    Parameters
    ----------
    inv
        The body's invariants (with or without the first-order stiffening terms).
    fe, V, geometric_stiffness, responses, source
        As for :func:`second_order_field`.

    Returns
    -------
    Invariants
        ``inv`` with ``quadratic`` set; two-sided bodies are returned unchanged (they keep
        the first-order stiffening terms).
    """
    if inv.two_sided:
        return inv
    return replace(inv, quadratic=second_order_field(fe, V, geometric_stiffness, responses,
                                                     source=source))
