"""Unreduced nonlinear reference for the spin-up of a beam on a driven hub (planar).

An independent model of the Kane–Ryan–Banerjee (1987) beam, not built from the floating-frame
invariants of :mod:`neweul_py.elastic`: a cantilever clamped to a hub turning about z by a
prescribed angle θ(t), discretized by its own planar finite elements (axial ``u`` linear,
chordwise ``v`` cubic Hermite, DOFs ``u, v, v'`` per node, 5-point Gauss quadrature) and
written in the rotating frame with the full inertia terms (relative, Coriolis, Euler and
centrifugal accelerations of the point ``(x + u, v)``) and the von Kármán strain
``ε = u' + v'²/2`` (strain energy ``½∫EA ε² + EI v''² dx``), so that centrifugal stiffening
comes from the axial stretch itself rather than from a precomputed geometric stiffness. The
membrane strain is taken constant per element (``u'`` plus the element mean of ``v'²/2``),
which avoids membrane locking of linear-``u``/cubic-``v`` elements. All FE DOFs are integrated
(no modal reduction) with Radau and the exact Jacobian.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sps
from scipy.integrate import solve_ivp


def _shapes(h: float) -> tuple[np.ndarray, ...]:
    """Rows at the Gauss points of one element (local DOFs u1 v1 θ1 u2 v2 θ2): u, u', v, v',
    v'' and the weights × h and the points ξ."""
    xi, w = np.polynomial.legendre.leggauss(5)
    xi, w = (xi + 1) / 2, w / 2
    z = np.zeros_like(xi)
    nu = np.stack([1 - xi, z, z, xi, z, z], axis=1)
    nux = np.stack([-np.ones_like(xi), z, z, np.ones_like(xi), z, z], axis=1) / h
    nv = np.stack([z, 1 - 3 * xi**2 + 2 * xi**3, h * (xi - 2 * xi**2 + xi**3), z,
                   3 * xi**2 - 2 * xi**3, h * (-xi**2 + xi**3)], axis=1)
    nvx = np.stack([z, -6 * xi + 6 * xi**2, h * (1 - 4 * xi + 3 * xi**2), z,
                    6 * xi - 6 * xi**2, h * (-2 * xi + 3 * xi**2)], axis=1) / h
    nvxx = np.stack([z, -6 + 12 * xi, h * (-4 + 6 * xi), z, 6 - 12 * xi,
                     h * (-2 + 6 * xi)], axis=1) / h**2
    return nu, nux, nv, nvx, nvxx, w * h, xi


def spin_up_tip(
    theta: Callable[[float], tuple[float, float, float]],
    t_end: float,
    t_eval: np.ndarray,
    *,
    n_el: int = 20,
    length: float = 10.0,
    EA: float = 2.8e7,
    EI: float = 1.4e4,
    rhoA: float = 1.2,
    rtol: float = 1e-8,
    atol: float = 1e-10,
) -> np.ndarray:
    """Chordwise tip deflection ``v(L, t)`` in the rotating frame at ``t_eval``.

    Parameters
    ----------
    theta
        ``t -> (θ, Ω, Ω̇)`` of the hub (only Ω and Ω̇ enter).
    t_end, t_eval
        End time and output times.
    n_el, length, EA, EI, rhoA
        Mesh and section data.
    rtol, atol
        Radau tolerances.

    Returns
    -------
    numpy.ndarray
        Tip deflection at ``t_eval``.
    """
    h = length / n_el
    nu, nux, nv, nvx, nvxx, wh, xi = _shapes(h)
    ndof = 3 * (n_el + 1)
    edofs = np.array([[3 * e + k for k in range(6)] for e in range(n_el)])
    xg = (np.arange(n_el)[:, None] + xi[None, :]) * h          # (n_el, ng)

    def assemble(a: np.ndarray, b: np.ndarray, wgt: np.ndarray) -> np.ndarray:
        ke = np.einsum("g,gi,gj->ij", wgt, a, b)
        rows = np.repeat(edofs, 6, axis=1).ravel()
        cols = np.tile(edofs, (1, 6)).ravel()
        return sps.csr_matrix((np.tile(ke.ravel(), n_el), (rows, cols)),
                              shape=(ndof, ndof)).toarray()

    Mu = assemble(nu, nu, rhoA * wh)
    Mv = assemble(nv, nv, rhoA * wh)
    Muv = assemble(nu, nv, rhoA * wh)
    fx = np.zeros(ndof)
    fy = np.zeros(ndof)
    np.add.at(fx, edofs, rhoA * np.einsum("g,gi,eg->ei", wh, nu, xg))
    np.add.at(fy, edofs, rhoA * np.einsum("g,gi,eg->ei", wh, nv, xg))
    free = np.arange(3, ndof)                                  # node 0 clamped
    M = (Mu + Mv)[np.ix_(free, free)]
    S = (Muv.T - Muv)[np.ix_(free, free)]                      # skew coupling
    fx, fy = fx[free], fy[free]
    Minv = np.linalg.inv(M)
    n = len(free)

    Kb = assemble(nvxx, nvxx, EI * wh)[np.ix_(free, free)]
    ux_row = nux[0]                                            # u' is constant per element

    def full(d: np.ndarray) -> np.ndarray:
        out = np.zeros(ndof)
        out[free] = d
        return out[edofs]                                      # (n_el, 6)

    def membrane(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Element axial forces N_e and strain gradients b_e = ∂ε_e/∂d_e (n_el, 6)."""
        vx = full(d) @ nvx.T                                   # (n_el, ng)
        eps = full(d) @ ux_row + 0.5 * (vx**2 @ wh) / h
        b = ux_row[None, :] + np.einsum("eg,g,gi->ei", vx, wh, nvx) / h
        return EA * eps, b

    def scatter(fe: np.ndarray) -> np.ndarray:
        out = np.zeros(ndof)
        np.add.at(out, edofs, fe)
        return out[free]

    def internal(d: np.ndarray) -> np.ndarray:
        N, b = membrane(d)
        return scatter(h * N[:, None] * b) + Kb @ d

    g_vv = np.einsum("g,gi,gj->ij", wh, nvx, nvx)              # ∫ N_v'ᵀ N_v' (one element)
    rows = np.repeat(edofs, 6, axis=1).ravel()
    cols = np.tile(edofs, (1, 6)).ravel()

    def stiffness(d: np.ndarray) -> np.ndarray:
        N, b = membrane(d)
        ke = EA * h * np.einsum("ei,ej->eij", b, b) + N[:, None, None] * g_vv[None]
        K = sps.csr_matrix((ke.ravel(), (rows, cols)), shape=(ndof, ndof)).toarray()
        return K[np.ix_(free, free)] + Kb

    def rhs(t: float, x: np.ndarray) -> np.ndarray:
        d, dd = x[:n], x[n:]
        _, om, al = theta(t)
        force = (om**2 * (M @ d + fx) - al * fy - 2 * om * S @ dd - al * S @ d
                 - internal(d))
        return np.concatenate([dd, Minv @ force])

    def jac(t: float, x: np.ndarray) -> np.ndarray:
        _, om, al = theta(t)
        J = np.zeros((2 * n, 2 * n))
        J[:n, n:] = np.eye(n)
        J[n:, :n] = Minv @ (om**2 * M - al * S - stiffness(x[:n]))
        J[n:, n:] = Minv @ (-2 * om * S)
        return J

    res = solve_ivp(rhs, (0.0, t_end), np.zeros(2 * n), method="Radau", t_eval=t_eval, jac=jac,
                    rtol=rtol, atol=atol)
    if not res.success:
        raise RuntimeError(res.message)
    tip_v = 3 * n_el + 1 - 3                                  # v of the last node in free
    return res.y[tip_v]
