"""The chain characteristic and the condensed malleus support."""

from __future__ import annotations

import numpy as np
import pytest

from neweul_py.middle_ear.chain import (
    chain_force,
    chain_tangent_matrix,
    condensed_support,
    malleus_map,
)


@pytest.mark.parametrize("s", [-1.5e-4, -3e-5, 0.0, 2e-5, 7e-5])
def test_chain_tangent_is_the_derivative(s):
    """The tangent equals the central difference of the force (closed-form derivative), and
    equals ``k₀ exp(|F|/(k₀ s±))`` (the load-exponential stiffening)."""
    k0, sp, sm = 1683.0, 1e-4, 2e-4
    f, k = chain_force(s, k0, sp, sm)
    h = 1e-10
    fd = (chain_force(s + h, k0, sp, sm)[0] - chain_force(s - h, k0, sp, sm)[0]) / (2 * h)
    assert k == pytest.approx(fd, rel=1e-6)
    lim = sp if s >= 0 else sm
    assert k == pytest.approx(k0 * np.exp(abs(f) / (k0 * lim)), rel=1e-12)
    assert np.sign(f) == np.sign(s)


def test_chain_beyond_the_limit_is_nan():
    """Beyond the limit displacement the characteristic is undefined (NaN, so Newton halves
    the load step) — never a silently wrong force."""
    assert np.isnan(chain_force(1e-4, 1.0, 1e-4, 1e-4)[0])
    assert np.isnan(chain_force(-3e-4, 1.0, 1e-4, 2e-4)[1])


def test_condensed_support_equals_eliminating_the_malleus():
    """``k I − k² T (k TᵀT + K_c)⁻¹ Tᵀ`` is the Schur complement of the assembled
    manubrium–malleus stiffness (direct elimination, independent computation)."""
    rng = np.random.default_rng(0)
    pts = np.column_stack([np.linspace(0, 3e-3, 5), np.zeros(5), np.linspace(2e-3, 1.5e-3, 5)])
    t = malleus_map(pts, np.arange(5), pts[0])
    _, kc = chain_tangent_matrix(rng.normal(0, 1e-5, 6), 1683.0, 4.4e-3, 1e-4, 2e-4)
    k_att = 36933.0
    k = k_att / 5
    full = np.block([[k * np.eye(15), -k * t], [-k * t.T, k * t.T @ t + kc]])
    schur = full[:15, :15] - full[:15, 15:] @ np.linalg.solve(full[15:, 15:], full[15:, :15])
    np.testing.assert_allclose(condensed_support(t, k_att, kc), schur, rtol=1e-9, atol=1e-6)
