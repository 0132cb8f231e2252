"""Unreduced *nonlinear* reference for a spinning solid: total-Lagrangian St. Venant–Kirchhoff.

Independent of :mod:`neweul_py.elastic` and of the initial-stress matrix of
:mod:`neweul_py.fem.solid`: the internal forces ``∫ P : ∇v dV`` with ``P = F S``,
``S = λ tr(E) I + 2μ E``, ``E = ½ (FᵀF − I)``, ``F = I + ∇u`` and their exact tangent are
assembled with scikit-fem on the basis of a :class:`~neweul_py.fem.solid.SolidModel`; the
rotating-frame equilibrium ``f_int(u) = Ω² M D (X + u)`` (centrifugal load of a spin Ω about
z through the origin, ``D = diag(1, 1, 0)`` per node, consistent mass) is solved by Newton's
method with the root face clamped, and the small vibrations about it are the eigenvalues of
``(K_T(u*) − Ω² M D, M)`` (Bonet & Wood, *Nonlinear Continuum Mechanics for FE Analysis*,
ch. 6–7; the geometric stiffening then comes from the large-deformation strain itself).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sps
import scipy.sparse.linalg as spla


def _svk(H: np.ndarray, lam: float, mu: float):
    eye = np.einsum("ij,...->ij...", np.eye(3), np.ones(H.shape[2:]))
    F = eye + H
    E = 0.5 * (np.einsum("ki...,kj...->ij...", F, F) - eye)
    S = lam * np.einsum("ij...,...->ij...", eye, np.einsum("ii...->...", E)) + 2 * mu * E
    return eye, F, S


def spinning_eigenvalues(solid, omegas, count: int = 1, tol: float = 1e-11) -> np.ndarray:
    """Lowest ``count`` ω² of the linearized vibrations about the nonlinear rotating-frame
    equilibrium, for each spin speed in ``omegas`` (rows)."""
    from skfem import BilinearForm, LinearForm, asm

    lam, mu = solid.material.lame
    basis, fe = solid.basis, solid.fe

    @LinearForm
    def internal(v, w):
        _, F, S = _svk(w["u"].grad, lam, mu)
        return np.einsum("ik...,kj...,ij...->...", F, S, v.grad)

    @BilinearForm
    def tangent(du, v, w):
        eye, F, S = _svk(w["u"].grad, lam, mu)
        dH = du.grad
        dE = 0.5 * (np.einsum("ki...,kj...->ij...", F, dH) + np.einsum("ki...,kj...->ij...",
                                                                       dH, F))
        dS = lam * np.einsum("ij...,...->ij...", eye, np.einsum("ii...->...", dE)) + 2 * mu * dE
        dP = np.einsum("ik...,kj...->ij...", dH, S) + np.einsum("ik...,kj...->ij...", F, dS)
        return np.einsum("ij...,ij...->...", dP, v.grad)

    n = fe.n_dofs
    free = np.setdiff1d(np.arange(n), fe.dofs_of_nodes(solid.node_sets["root"]))
    X = fe.nodes[:, 1:4].ravel()
    Dm = sps.diags(np.tile([1.0, 1.0, 0.0], n // 3))
    MD = (fe.M @ Dm).tocsr()
    Mf = fe.M.tocsc()[free][:, free]
    out = []
    u = np.zeros(n)
    for Om in omegas:
        for _ in range(30):
            field = basis.interpolate(u)
            r = asm(internal, basis, u=field) - Om**2 * (MD @ (X + u))
            if np.linalg.norm(r[free]) <= tol * max(1.0, np.linalg.norm(Om**2 * (MD @ X))):
                break
            KT = (asm(tangent, basis, u=field) - Om**2 * MD).tocsc()[free][:, free]
            u[free] -= spla.spsolve(KT, r[free])
        else:
            raise RuntimeError("Newton did not converge")
        KT = (asm(tangent, basis, u=basis.interpolate(u)) - Om**2 * MD).tocsc()[free][:, free]
        KT = 0.5 * (KT + KT.T)
        out.append(np.sort(spla.eigsh(KT, k=count, M=Mf, sigma=-1e-6)[0]))
    return np.array(out)
