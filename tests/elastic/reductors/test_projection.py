"""The Petrov–Galerkin projection (``neweul_py.elastic.reductors.projection``) and the sparse LU
of the reductors (``neweul_py.elastic.reductors.eigen.SparseLU``).

References: the projection ``Wᵀ X V`` computed densely here; the residual ``A x − b`` of the
linear system (and of its transpose) the factorization solves.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sps
from fe_builders import membrane_cavity

from neweul_py.elastic.reductors.eigen import SparseLU
from neweul_py.elastic.reductors.projection import build_reduced_body, project


def _two_models():
    """Two working points of one mesh that differ in the membrane's rows (tension)."""
    return membrane_cavity(tension=0.3), membrane_cavity(tension=0.42)


def test_projection_of_the_difference_to_a_base_equals_the_direct_projection() -> None:
    """``Wᵀ X₀ V + Wᵀ (X − X₀) V`` equals ``Wᵀ X V`` computed densely, for ``W ≠ V``;
    the blocks where ``X = X₀`` come out equal to the base's."""
    fe0, fe1 = _two_models()
    rng = np.random.default_rng(3)
    n = fe0.n_dofs
    V, W = rng.standard_normal((n, 9)), rng.standard_normal((n, 9))
    b0 = build_reduced_body(fe0, V, W, "snapshot", {})
    b1 = build_reduced_body(fe1, V, W, "snapshot", {}, base=(fe0, b0))
    for name in ("M", "K", "D"):
        dense = W.T @ getattr(fe1, name).toarray() @ V
        got = getattr(b1, name)
        assert np.abs(got - dense).max() <= 1e-12 * np.abs(dense).max(), name
    same = project(V, W, {"M": fe1.M}, base=({"M": fe0.M}, {"M": b0.M}))["M"]
    if (fe1.M != fe0.M).nnz == 0:
        assert np.array_equal(same, b0.M)


def test_sparse_lu_solves_complex_systems_and_their_transposes() -> None:
    """``A x = b`` and ``Aᵀ y = c`` for the complex ``K + iωD − ω²M`` of a u–p model: the
    residuals are at round-off of ``‖A‖ ‖x‖``."""
    fe, _ = _two_models()
    w = 2 * np.pi * 700.0
    D = fe.D if fe.D is not None else sps.csr_matrix(fe.K.shape)
    A = sps.csr_matrix(fe.K + 1j * w * D - w * w * fe.M + 1e-3j * sps.eye(fe.n_dofs))
    rng = np.random.default_rng(5)
    b = rng.standard_normal((fe.n_dofs, 3)) + 1j * rng.standard_normal((fe.n_dofs, 3))
    lu = SparseLU(A)
    x, y = lu.solve(b), lu.solve(b, transpose=True)
    scale = abs(A).max()
    assert np.abs(A @ x - b).max() <= 1e-9 * scale * np.abs(x).max()
    assert np.abs(A.T @ y - b).max() <= 1e-9 * scale * np.abs(y).max()
