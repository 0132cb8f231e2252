"""The sparse LU of the reductors (``neweul_py.elastic.reductors.eigen.SparseLU``).

Reference: the residual ``A x − b`` of the linear system (and of its transpose) the
factorization solves, for both orderings (minimum degree below ``ND_MIN_ROWS`` rows, nested
dissection from there on).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sps
from fe_builders import membrane_cavity

from neweul_py.elastic.reductors.eigen import ND_MIN_ROWS, SparseLU, nested_dissection


@pytest.mark.parametrize("size", [(24, 16), (60, 40)])
def test_sparse_lu_solves_complex_systems_and_their_transposes(size) -> None:
    """``A x = b`` and ``Aᵀ y = c`` for the complex ``K + iωD − ω²M`` of a u–p model: the
    residuals are at round-off of ``‖A‖ ‖x‖``; the larger model takes the nested-dissection
    path, whose ordering is a permutation."""
    fe = membrane_cavity(0.3, n_x=size[0], n_z=size[1])
    w = 2 * np.pi * 700.0
    D = fe.D if fe.D is not None else sps.csr_matrix(fe.K.shape)
    A = sps.csr_matrix(fe.K + 1j * w * D - w * w * fe.M + 1e-3j * sps.eye(fe.n_dofs))
    rng = np.random.default_rng(5)
    b = rng.standard_normal((fe.n_dofs, 3)) + 1j * rng.standard_normal((fe.n_dofs, 3))
    lu = SparseLU(A)
    assert (lu.perm is not None) == (fe.n_dofs >= ND_MIN_ROWS)
    if lu.perm is not None:
        assert np.array_equal(np.sort(nested_dissection(A)), np.arange(fe.n_dofs))
    x, y = lu.solve(b), lu.solve(b, transpose=True)
    scale = abs(A).max()
    assert np.abs(A @ x - b).max() <= 1e-9 * scale * np.abs(x).max()
    assert np.abs(A.T @ y - b).max() <= 1e-9 * scale * np.abs(y).max()
    real = SparseLU(sps.csr_matrix(A.real))
    r = rng.standard_normal(fe.n_dofs)
    assert np.abs(A.real @ real.solve(r) - r).max() <= 1e-6 * np.abs(r).max()


@pytest.mark.parametrize("n", [40, ND_MIN_ROWS + 10])
def test_a_small_diagonal_is_pivoted_away(n) -> None:
    """Threshold pivoting prefers the diagonal but leaves one smaller than the threshold times
    its column's largest entry: a saddle-point matrix ``[[εI, I], [I, 0]]``-like (diagonal
    1e-14 or 0 against off-diagonal 1) is solved to round-off. Reference: the dense solve of
    NumPy (LAPACK ``gesv``, partial pivoting)."""
    m = n // 2
    eye = sps.identity(m, format="csr")
    chain = sps.diags([np.full(m - 1, 0.3)], [1], shape=(m, m))
    A = sps.bmat([[1e-14 * eye, eye + chain], [(eye + chain).T, None]], format="csr")
    b = np.random.default_rng(1).standard_normal(2 * m)
    x = SparseLU(A).solve(b)
    ref = np.linalg.solve(A.toarray(), b)
    np.testing.assert_allclose(x, ref, rtol=1e-10, atol=1e-10 * np.abs(ref).max())
