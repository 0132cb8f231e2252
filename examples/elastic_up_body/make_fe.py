"""Write the u–p coupled FE model of this example: ``python make_fe.py duct.npz``.

A spring–mass piston (DOF 0, ``ux`` of node 1) closes one end of a 1-D air duct (length
1 m, unit area, pressure DOFs on 101 nodes, rigid far end), coupled after Eq. (2) of
``docs/equations.md`` §3: ``[m 0; ρCᵀ Mf] ẍ + [k −C; 0 Kf] x = f`` with
``C = −A e₀`` — unsymmetric, so a two-sided (Petrov–Galerkin) reduction is needed.
``reference_frf`` gives the FRF of the unreduced model with the rigid mass and spring of
``model.yaml`` assembled directly (used by the test).
"""

from __future__ import annotations

import sys

import numpy as np
import scipy.sparse as sps

from neweul_py.elastic import FEModel, write_fe_model

N_EL, LENGTH, C_AIR, RHO_AIR = 100, 1.0, 343.0, 1.2
PISTON_MASS, PISTON_SPRING = 0.05, 2.0e5


def piston_duct() -> FEModel:
    """The u–p coupled piston–duct model (102 DOFs)."""
    n = N_EL + 1
    h = LENGTH / N_EL
    conn = np.stack([np.arange(N_EL), np.arange(1, n)], axis=1)
    rows, cols = np.repeat(conn, 2, axis=1).ravel(), np.tile(conn, (1, 2)).ravel()
    me = h / 6 * np.array([[2.0, 1.0], [1.0, 2.0]])
    ke = 1 / h * np.array([[1.0, -1.0], [-1.0, 1.0]])
    Mf = sps.csr_matrix((np.tile(me.ravel(), N_EL), (rows, cols)), shape=(n, n)) / C_AIR**2
    Kf = sps.csr_matrix((np.tile(ke.ravel(), N_EL), (rows, cols)), shape=(n, n))
    Cc = sps.csr_matrix(([-1.0], ([0], [0])), shape=(1, n))
    M = sps.bmat([[sps.csr_matrix([[PISTON_MASS]]), None], [RHO_AIR * Cc.T, Mf]], format="csr")
    K = sps.bmat([[sps.csr_matrix([[PISTON_SPRING]]), -Cc], [None, Kf]], format="csr")
    x = np.linspace(0.0, LENGTH, n)
    nodes = np.column_stack([np.arange(1, n + 1), x, np.zeros(n), np.zeros(n)])
    return FEModel(M=M, K=K, D=None, nodes=nodes,
                   dof_node=np.concatenate([[1], np.arange(1, n + 1)]),
                   dof_kind=np.array(["ux"] + ["p"] * n),
                   inputs={"force": ((0, 1.0),)}, outputs={"x_piston": ((0, 1.0),)},
                   kind="up-coupled", density=RHO_AIR, name="piston-duct")


def reference_frf(f: np.ndarray, m2: float, k2: float, d2: float) -> np.ndarray:
    """Mass displacement per unit force on the mass, unreduced FE model + spring–damper
    (piston DOF ↔ mass) + mass assembled directly."""
    fe = piston_duct()
    n = fe.M.shape[0]
    M = sps.block_diag([fe.M, sps.csr_matrix([[m2]])]).toarray()
    K = sps.block_diag([fe.K, sps.csr_matrix([[0.0]])]).toarray()
    D = np.zeros_like(K)
    for A, c in ((K, k2), (D, d2)):
        A[[0, n], [0, n]] += c
        A[0, n] -= c
        A[n, 0] -= c
    b = np.zeros(n + 1)
    b[n] = 1.0
    w = 2 * np.pi * np.asarray(f, dtype=float)
    return np.array([np.linalg.solve(K - wi**2 * M + 1j * wi * D, b)[n] for wi in w])


if __name__ == "__main__":
    write_fe_model(piston_duct(), sys.argv[1] if len(sys.argv) > 1 else "duct.npz")
