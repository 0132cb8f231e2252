"""Acousto-structural coupling in the pressure-based u–p form (Eq. (2) of the seed paper).

::

    [ Ms    0  ] [ü]   [ Ds  0  ] [u̇]   [ Ks  −C ] [u]   [ f_ex ]
    [ ρ Cᵀ  Mf ] [p̈] + [ 0   Df ] [ṗ] + [ 0   Kf ] [p] = [ p_ex ]

with ``C = ∫_Γ N_uᵀ n N_p dΓ`` and ``n`` the interface normal pointing *out of the fluid, into the
structure* (``equations.md`` §3). Derivation of the sign: the weak form of the wave equation has
the boundary term ``−∫ N ∂p/∂n dΓ`` and the fluid momentum equation on a moving wall gives
``∂p/∂n = −ρ ü·n``, so ``ρ Cᵀ ü`` enters the fluid rows with a plus sign; the fluid pushes the
structure with the traction ``p n``, i.e. ``f = C p`` on the right, ``−C p`` on the left.
Both are checked by the piston closing a tube (``tests/fem/test_coupling.py``).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sps

__all__ = ["assemble_up", "coupling_matrix"]


def coupling_matrix(
    x: np.ndarray,
    triangles: np.ndarray,
    u_nodes: np.ndarray,
    p_dofs: np.ndarray,
    n_u: int,
    n_p: int,
    sign: float = 1.0,
) -> sps.csr_matrix:
    """``C = ∫_Γ N_uᵀ n N_p dΓ`` on a P1 triangulated interface (vectorized).

    Parameters
    ----------
    x
        (ns, 3) coordinates of the interface nodes (reference or current configuration).
    triangles
        (nt, 3) interface triangles in local node numbers; their orientation
        ``(x1 − x0) × (x2 − x0)`` times ``sign`` is the normal out of the fluid.
    u_nodes
        (ns,) structural node index of each interface node (DOFs ``3·node + k``).
    p_dofs
        (ns,) pressure DOF index of each interface node.
    n_u, n_p
        Numbers of structural nodes and pressure DOFs.
    sign
        +1 or −1 (which side of the surface the fluid lies on).

    Returns
    -------
    C
        (3·n_u, n_p) CSR matrix; per triangle ``C_ij = sign · A n (1 + δ_ij) / 12``.

    Examples
    --------
    A unit right triangle in the plane z = 0, fluid below it (normal out of the fluid = +z):

    >>> x = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> c = coupling_matrix(x, np.array([[0, 1, 2]]), np.arange(3), np.arange(3), 3, 3)
    >>> round(float(c.sum()), 12), round(float(c[2::3].sum()), 12)  # the area, all along z
    (0.5, 0.5)
    """
    xe = x[triangles]
    an = 0.5 * sign * np.cross(xe[:, 1] - xe[:, 0], xe[:, 2] - xe[:, 0])  # A n, (nt, 3)
    w = (np.ones((3, 3)) + np.eye(3)) / 12.0
    vals = np.einsum("ij,ek->eikj", w, an)  # (nt, i node, k comp, j node)
    rows = 3 * u_nodes[triangles][:, :, None, None] + np.arange(3)[None, None, :, None]
    cols = p_dofs[triangles][:, None, None, :]
    rows, cols = np.broadcast_arrays(rows, cols)
    return sps.csr_matrix((vals.ravel(), (rows.ravel(), cols.ravel())), shape=(3 * n_u, n_p))


def assemble_up(
    ms: sps.spmatrix,
    ks: sps.spmatrix,
    mf: sps.spmatrix,
    kf: sps.spmatrix,
    c: sps.spmatrix,
    rho: float,
    ds: sps.spmatrix | None = None,
    df: sps.spmatrix | None = None,
) -> tuple[sps.csr_matrix, sps.csr_matrix, sps.csr_matrix]:
    """The unsymmetric matrices ``M, D, K`` of Eq. (2) for DOFs ``[u; p]``.

    Returns
    -------
    M, D, K
        ``M = [Ms 0; ρCᵀ Mf]``, ``D = blockdiag(Ds, Df)``, ``K = [Ks −C; 0 Kf]`` (CSR).

    Examples
    --------
    >>> one = sps.csr_matrix([[1.0]])
    >>> m, d, k = assemble_up(one, one, one, one, sps.csr_matrix([[2.0]]), rho=1.2)
    >>> m.toarray().tolist(), k.toarray().tolist()
    ([[1.0, 0.0], [2.4, 1.0]], [[1.0, -2.0], [0.0, 1.0]])
    """
    ns, nf = ms.shape[0], mf.shape[0]
    ds = ds if ds is not None else sps.csr_matrix((ns, ns))
    df = df if df is not None else sps.csr_matrix((nf, nf))
    m = sps.block_array([[ms, None], [rho * c.T, mf]], format="csr")
    d = sps.block_array([[ds, None], [None, df]], format="csr")
    k = sps.block_array([[ks, -c], [None, kf]], format="csr")
    return sps.csr_matrix(m), sps.csr_matrix(d), sps.csr_matrix(k)
