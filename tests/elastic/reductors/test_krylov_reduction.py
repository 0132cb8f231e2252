"""Second-order Krylov reduction: moment matching, structure, errors.

Reference: the moments ``C Pᵢ`` of the unreduced FE model about ``s0``, computed here with dense
solves from the recursion ``P₀ = K̃⁻¹B``, ``Pᵢ = −K̃⁻¹(D̃ Pᵢ₋₁ + M Pᵢ₋₂)``
(Salimbahrami & Lohmann 2006): one-sided projection matches q of them, two-sided 2q.
"""

from __future__ import annotations

import numpy as np
import pytest
from fe_builders import duct, random_up, spring_chain

from neweul_py.elastic import reduce_krylov
from neweul_py.errors import DataError


def _moments(M, D, K, B, C, s0, count):
    Kt = K + s0 * D + s0**2 * M
    Dt = D + 2 * s0 * M
    P = [np.linalg.solve(Kt, B)]
    P.append(-np.linalg.solve(Kt, Dt @ P[0]))
    for _ in range(2, count):
        P.append(-np.linalg.solve(Kt, Dt @ P[-1] + M @ P[-2]))
    return np.array([C @ p for p in P[:count]])


def _full_moments(fe, s0, count):
    D = fe.D.toarray() if fe.D is not None else np.zeros(fe.M.shape)
    return _moments(fe.M.toarray(), D, fe.K.toarray(), fe.B(), fe.C(), s0, count)


def _reduced_moments(body, s0, count):
    return _moments(body.M, body.D, body.K, body.B, body.C, s0, count)


def _matched(full, red, rtol=1e-8):
    """Number of leading moments that agree (relative to each moment's size)."""
    k = 0
    for f, r in zip(full, red, strict=True):
        if np.abs(f - r).max() > rtol * np.abs(f).max():
            break
        k += 1
    return k


@pytest.mark.parametrize("s0", [0.3j, 0.25])
@pytest.mark.parametrize("order", [1, 2, 3])
def test_moment_matching_one_and_two_sided(s0, order):
    fe = random_up(damping=1e-3)
    fe = fe.with_(outputs={"p": fe.outputs["p"]})  # one input, one output
    full = _full_moments(fe, s0, 2 * order + 1)
    one = reduce_krylov(fe, points=[s0], order=order, two_sided=False)
    two = reduce_krylov(fe, points=[s0], order=order)
    assert _matched(full, _reduced_moments(one, s0, 2 * order + 1)) >= order
    assert _matched(full, _reduced_moments(two, s0, 2 * order + 1)) == 2 * order


def test_several_real_points_without_damping():
    """Undamped symmetric chain: moments matched at every real expansion point."""
    fe = spring_chain(60)
    points = [10.0, 40.0]
    body = reduce_krylov(fe, points=points, order=2)
    for s0 in points:
        full = _full_moments(fe, s0, 3)
        assert _matched(full, _reduced_moments(body, s0, 3)) >= 3


def test_projection_keeps_the_second_order_structure():
    fe = random_up(damping=1e-3)
    body = reduce_krylov(fe, points=[0.2j], order=2, store_bases=True)
    V, W = body.V, body.W
    np.testing.assert_allclose(body.M, W.T @ (fe.M @ V), atol=1e-14)
    np.testing.assert_allclose(body.D, W.T @ (fe.D @ V), atol=1e-14)
    np.testing.assert_allclose(body.K, W.T @ (fe.K @ V), atol=1e-13)
    np.testing.assert_allclose(body.B, W.T @ fe.B(), atol=1e-14)
    np.testing.assert_allclose(body.C, fe.C() @ V, atol=1e-14)
    assert body.settings["points"] == [[0.0, 0.2]] and body.method == "krylov"


def test_static_correction_matches_the_static_moment():
    fe = spring_chain(60)
    body = reduce_krylov(fe, points=[30.0], order=1, static_correction=True)
    full = _full_moments(fe, 0.0, 1)
    np.testing.assert_allclose(_reduced_moments(body, 0.0, 1), full, rtol=1e-4)


def test_bad_requests():
    fe = duct(50).with_(source="duct.json")
    with pytest.raises(DataError, match="singular") as exc:  # closed cavity: K singular
        reduce_krylov(fe, points=[0.0])
    assert exc.value.file == "duct.json"
    with pytest.raises(DataError, match="expansion point"):
        reduce_krylov(fe, points=[])
    with pytest.raises(DataError, match="order"):
        reduce_krylov(fe, points=[1.0], order=0)
