"""The Petrov–Galerkin projection (``neweul_py.elastic.reductors.projection``).

Reference: the projection ``Wᵀ X V`` computed densely here.
"""

from __future__ import annotations

import numpy as np
from fe_builders import membrane_cavity

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
