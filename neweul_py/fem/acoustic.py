"""Linear acoustic pressure elements (linear tetrahedra, assembled with scikit-fem).

Helmholtz/wave equation in the pressure ``p`` (Eq. (2) of the seed paper, fluid rows; see
``equations.md`` §3)::

    Mf p̈ + Df ṗ + Kf p = p_ex,   Mf = (1/c²) ∫ Nᵀ N dV,   Kf = ∫ ∇Nᵀ ∇N dV,

with rigid walls as the natural boundary condition. A boundary moving with the inward normal
acceleration ``a_n`` adds ``ρ ∫ Nᵀ a_n dΓ`` to ``p_ex`` (a volume-acceleration source).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sps
from skfem import Basis, BilinearForm, ElementTetP1, MeshTet
from skfem.helpers import dot, grad

from .mesh import TetMesh, triangle_areas

__all__ = ["acoustic_matrices", "surface_load"]


@BilinearForm
def _mass(u, v, w):
    return u * v


@BilinearForm
def _laplace(u, v, w):
    return dot(grad(u), grad(v))


def acoustic_matrices(mesh: TetMesh, c: float) -> tuple[sps.csr_matrix, sps.csr_matrix]:
    """``Mf = (1/c²) ∫ NᵀN dV`` and ``Kf = ∫ ∇Nᵀ∇N dV`` on a P1 tetrahedral mesh.

    Parameters
    ----------
    mesh
        The air volume; the node order of ``mesh.points`` is the DOF order.
    c
        Speed of sound.

    Returns
    -------
    Mf, Kf
        Symmetric CSR matrices (``Kf`` singular: constant pressure is a rigid-wall mode).

    References
    ----------
    ``equations.md`` §3 (Eq. (2) of the seed paper).
    """
    basis = Basis(MeshTet(mesh.points.T.copy(), mesh.tets.T.copy()), ElementTetP1())
    mf = _mass.assemble(basis).tocsr() / c**2
    kf = _laplace.assemble(basis).tocsr()
    return mf, kf


def surface_load(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """The consistent nodal vector ``∫_Γ N dΓ`` of a P1 surface (each triangle gives A/3 a node)."""
    a = triangle_areas(points, triangles)
    return np.bincount(triangles.ravel(), weights=np.repeat(a / 3.0, 3), minlength=points.shape[0])
