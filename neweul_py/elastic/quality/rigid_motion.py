"""Rigid-body motion of an FE model and of a reduced basis (structural fields only).

A floating-frame body must not carry the rigid motion of its reference frame in its
elastic coordinates (the body mass matrix of ``reference/equations.md`` §2 would be
singular). Only the *structural* rigid fields matter: the six translation/rotation fields
``r_j`` of the structural DOFs (``ux uy uz`` at node positions ``x``: ``e_j`` and
``e_j × x``; ``rx ry rz``: ``e_j``), zero on the pressure DOFs. The ``λ = 0`` modes of a
closed air volume (constant pressure, ``u = Ks⁻¹ C p``) are not rigid motion, and a
supported structure (the TM clamped at the annulus) has no rigid motion at all
(:func:`free_rigid_fields` is empty), so no basis can repeat it.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sps

from ..fe_model import FEModel

__all__ = ["NULL_RTOL", "REPEAT_RTOL", "free_rigid_fields", "repeated_rigid_fields",
           "rigid_fields"]

#: A rigid field ``r`` with ``‖Ks r‖ ≤ NULL_RTOL · ‖Ks‖₁ ‖r‖`` is a null vector of the
#: structural stiffness (a free rigid motion); a clamped TM gives ~1e-2, a free beam 1e-15.
NULL_RTOL = 1e-8
#: A free rigid field lies in the span of a basis when its Ms-orthogonal remainder is below
#: this fraction of its Ms-norm.
REPEAT_RTOL = 1e-6

_AXIS = {"ux": 0, "uy": 1, "uz": 2, "rx": 0, "ry": 1, "rz": 2}


def rigid_fields(fe: FEModel) -> np.ndarray:
    """(n, 6) translations x, y, z and rotations about x, y, z (about the origin) on the
    structural DOFs; zero rows for pressure DOFs."""
    n = fe.n_dofs
    R = np.zeros((n, 6))
    ids = fe.nodes[:, 0].astype(np.int64)
    order = np.argsort(ids)
    xyz = fe.nodes[order, 1:4][np.searchsorted(ids[order], fe.dof_node)]
    kinds = fe.dof_kind
    for kind, a in _AXIS.items():
        rows = np.flatnonzero(kinds == kind)
        if not rows.size:
            continue
        if kind.startswith("u"):
            R[rows, a] = 1.0
            for j in range(3):  # (e_j × x)_a
                e = np.zeros(3)
                e[j] = 1.0
                R[rows, 3 + j] = np.cross(e, xyz[rows])[:, a]
        else:
            R[rows, 3 + a] = 1.0
    return R


def _structural(fe: FEModel) -> np.ndarray:
    return fe.dof_kind != "p"


def free_rigid_fields(fe: FEModel) -> np.ndarray:
    """The rigid fields (columns of :func:`rigid_fields`) that the structural stiffness
    leaves free (``Ks r ≈ 0``, :data:`NULL_RTOL`): empty for a supported structure and for
    a model without structural DOFs."""
    s = _structural(fe)
    if not s.any():
        return np.zeros((fe.n_dofs, 0))
    R = rigid_fields(fe)
    Ks = sps.csr_matrix(fe.K)[s][:, s]
    scale = float(abs(Ks).sum(axis=0).max()) or 1.0
    Rs = R[s]
    norms = np.linalg.norm(Rs, axis=0)
    res = np.linalg.norm(Ks @ Rs, axis=0)
    free = (norms > 0) & (res <= NULL_RTOL * scale * np.where(norms > 0, norms, 1.0))
    return R[:, free]


def repeated_rigid_fields(fe: FEModel, V: np.ndarray) -> int:
    """How many independent free rigid fields lie in the span of the structural rows of
    ``V`` (in the structural mass metric): 0 means the basis repeats no rigid motion."""
    R = free_rigid_fields(fe)
    if not R.shape[1]:
        return 0
    s = _structural(fe)
    Ms = sps.csr_matrix(fe.M)[s][:, s]
    Ms = 0.5 * (Ms + Ms.T)
    Vs, Rs = V[s], R[s]
    G = Vs.T @ (Ms @ Vs)
    lam, U = np.linalg.eigh(0.5 * (G + G.T))
    keep = lam > 1e-12 * max(lam.max(), 0.0) if lam.size else lam > 0
    if not np.any(keep):
        return 0
    Q = Vs @ (U[:, keep] / np.sqrt(lam[keep]))        # Ms-orthonormal basis of span Vs
    # Ms-orthonormal rigid fields, then the cosines of the principal angles to span Q
    GR = Rs.T @ (Ms @ Rs)
    lr, Ur = np.linalg.eigh(0.5 * (GR + GR.T))
    ok = lr > 1e-12 * lr.max()
    P = Rs @ (Ur[:, ok] / np.sqrt(lr[ok]))
    cos = np.linalg.svd(Q.T @ (Ms @ P), compute_uv=False)
    return int(np.sum(cos >= 1.0 - REPEAT_RTOL))
