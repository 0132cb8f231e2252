"""Static equilibrium of a body carrying its static state, tied to a rigid part.

A check of a working-point body against its FE model: the body (about its static state) tied by
springs to a rigid part held by a restoring force must come to rest where the unreduced model
does (``docs/equations-middle-ear.md`` §5).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ...errors import DataError, SolverError
from ..bodies.static import node_rows

__all__ = [
    "FLOOR_RTOL",
    "FLOOR_STALLS",
    "rigid_map",
    "tied_static_equilibrium",
]


def rigid_map(nodes: np.ndarray, node_ids: np.ndarray, origin: np.ndarray) -> np.ndarray:
    """(3m, 6) displacement of the points ``x_i`` of a rigid body at the nodes ``node_ids``
    for its translation and small rotation ``(t, θ)`` about ``origin``:
    ``u_i = t + θ × (x_i − origin)`` (rows ``ux, uy, uz`` of node 1, node 2, …)."""
    xyz = {int(r[0]): np.asarray(r[1:4], dtype=np.float64) for r in np.asarray(nodes)}
    T = np.zeros((3 * len(node_ids), 6))
    for j, nid in enumerate(node_ids):
        r = xyz[int(nid)] - np.asarray(origin, dtype=np.float64)
        T[3 * j:3 * j + 3, :3] = np.eye(3)
        T[3 * j:3 * j + 3, 3:] = -np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]],
                                            [-r[1], r[0], 0.0]])   # θ × r = −r̃ θ
    return T


#: Round-off floor of :func:`tied_static_equilibrium`: a Newton step below this fraction of
#: the translation that has stopped shrinking for this many steps ends the iteration.
FLOOR_RTOL = 1e-3
FLOOR_STALLS = 3


def tied_static_equilibrium(body: Any, node_ids: np.ndarray, k: float,
                            restoring: Any, origin: np.ndarray, *, tol: float = 1e-8,
                            max_iter: int = 50) -> dict[str, np.ndarray]:
    """Static equilibrium of a body carrying its static state, tied to a rigid part.

    The rigid part (translation and small rotation ``y = (t, θ)`` about ``origin``, from the
    reference configuration) is tied to the body's nodes ``node_ids`` by isotropic springs
    ``k`` each, and held by the restoring force ``F_c(y)`` (``restoring(y) → (F_c, K_c)``, a
    force/moment (6,) and its tangent (6, 6)). With the node displacements
    ``x_n = u_s + Φ_n q`` (static node displacements + the body's motion) and the spring
    forces on the body ``f = −k (x_n − T y)`` (:func:`rigid_map`), the equations are::

        K q − Φ_Wᵀ (f − f_s) = 0        (the body about its static state, f_s its static
                                         interface forces; equilibrium at q = 0 when f = f_s)
        F_c(y) + Tᵀ f = 0               (the rigid part)

    solved by Newton's method (least-squares steps: the constant-pressure ``λ = 0`` modes of
    closed air volumes leave ``K`` singular, and the static state does not excite them) from
    the body's static state: ``q = 0`` and the rigid part where
    the static interface forces put it, ``T y₀ = u_s + f_s/k`` (least squares; exact when
    ``f_s`` came from such springs). The linear body about a state of large deflection may
    have other, spurious equilibria far from it (its tangent is not that of the
    nonlinear structure there), so the start matters (docs/equations-middle-ear.md §7).

    Converged when the step of the translation ``t`` is below ``tol`` times ``|t|``, or below
    :data:`FLOOR_RTOL` ``|t|`` and no smaller than half the smallest step so far for
    :data:`FLOOR_STALLS` steps in a row (Newton stalls at the round-off floor: the tangent of
    a u–p body is ill-conditioned, cond ≈ 1e14 for the middle ear at refine 1, and the floor
    is absolute — about 1e-10 m there — so at the small displacements next to Δp = 0 it is
    1e-4 of ``|t|``: −60 Pa with the chain's table characteristic).

    Returns
    -------
    dict
        ``q`` (r,), ``y`` (6,), ``node_u`` (m, 3) the node displacements ``x_n``, ``outputs``
        the static outputs ``y_s + C q``, ``iterations``.

    Raises
    ------
    DataError
        The body carries no static state or lacks one of the nodes (a translation a node
        lacks carries no spring).
    SolverError
        No convergence in ``max_iter`` steps.
    """
    st = body.static
    if st is None:
        raise DataError("the body carries no static state", None, "static")
    ids = [int(n) for n in body.nodes[:, 0]]
    missing = [int(n) for n in node_ids if int(n) not in ids]
    if missing:
        raise DataError(f"nodes {missing} are not kept nodes of the body {ids}", None, "nodes")
    sel = [ids.index(int(n)) for n in node_ids]
    rows = node_rows(body.nodes, body.dof_node, body.dof_kind)[sel].ravel()
    has = rows >= 0             # translations a node lacks carry no spring
    phi, phi_w = body.V_kept[rows[has]], body.W_kept[rows[has]]
    us, fs = st.node_u[sel].ravel()[has], st.node_force[sel].ravel()[has]
    T = rigid_map(body.nodes, node_ids, origin)[has]
    r = body.order
    q, y = np.zeros(r), np.linalg.lstsq(T, us + fs / k, rcond=None)[0]
    iterations, best, stalls = 0, np.inf, 0
    while iterations < max_iter:
        iterations += 1
        f = -k * (us + phi @ q - T @ y)
        Fc, Kc = restoring(y)
        res = np.r_[body.K @ q - phi_w.T @ (f - fs), Fc + T.T @ f]
        J = np.block([[body.K + k * phi_w.T @ phi, -k * phi_w.T @ T],
                      [-k * T.T @ phi, np.asarray(Kc) + k * T.T @ T]])
        dz = np.linalg.lstsq(J, -res, rcond=None)[0]   # K of closed air volumes: λ = 0
        q, y = q + dz[:r], y + dz[r:]
        scale = max(np.abs(y[:3]).max(), 1e-30)
        step = np.abs(dz[r:r + 3]).max()
        stalls = stalls + 1 if step >= 0.5 * best else 0
        best = min(best, step)
        if step <= tol * scale or (step <= FLOOR_RTOL * scale and stalls >= FLOOR_STALLS):
            break                   # converged, or the round-off floor reached
    else:
        raise SolverError(f"the tied static problem did not converge in {max_iter} Newton "
                          "steps", residual=float(np.abs(res).max()))
    node_u = np.zeros(3 * len(sel))
    node_u[has] = us + phi @ q
    node_u = node_u.reshape(-1, 3)
    return {"q": q, "y": y, "node_u": node_u, "outputs": st.outputs + body.C @ q,
            "iterations": iterations}
