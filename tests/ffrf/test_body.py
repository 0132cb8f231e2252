"""The floating-frame kernel (neweul_py/ffrf/body.py, equations.md §2).

Reference: Newton's second law summed over the mass points of a body (each point at
``x_n + Φ_n q`` in the moving frame), written out directly in the test with the textbook
relative-motion acceleration ``a + α × c + ω × (ω × c) + 2 ω × ċ + c̈`` — nothing of the
invariants or the kernel is used for it.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sps

from neweul_py.elastic.fe_model import FEModel
from neweul_py.elastic.reductors.invariants import compute_invariants
from neweul_py.ffrf import (
    ffrf_body_mass,
    ffrf_kinetic_energy,
    ffrf_mass_blocks,
    ffrf_prepare,
    ffrf_velocity_terms,
)


def _cloud(n: int = 9, nq: int = 4, seed: int = 3):
    """A cloud of point masses (lumped FE mass matrix) with random deformation modes."""
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(n, 3))
    m = rng.uniform(0.5, 2.0, n)
    ids = np.arange(1, n + 1)
    fe = FEModel(M=sps.diags(np.repeat(m, 3)).tocsr(), K=sps.identity(3 * n, format="csr"),
                 D=None, nodes=np.column_stack([ids, x]), dof_node=np.repeat(ids, 3),
                 dof_kind=np.tile(np.array(["ux", "uy", "uz"]), n))
    V = rng.normal(size=(3 * n, nq)) * 0.3
    return fe, x, m, V, rng


def _point_mass_sum(x, m, V, q, qd, qdd, a, alpha, w):
    """``Σ_n Y_nᵀ m_n acc_n`` with the test fields ``Y_n = [I, c̃_nᵀ, Φ_n]`` (virtual work of
    the frame translation, rotation and the modes)."""
    n, nq = x.shape[0], V.shape[1]
    phi = V.reshape(n, 3, nq)
    c = x + phi @ q
    cd = phi @ qd
    cdd = phi @ qdd
    acc = (a + np.cross(alpha, c) + np.cross(w, np.cross(w, c)) + 2 * np.cross(w, cd) + cdd)
    f = m[:, None] * acc
    return np.concatenate([f.sum(axis=0), np.cross(c, f).sum(axis=0),
                           np.einsum("nak,na->k", phi, f)])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_consistent_body_equations_are_newtons_law_of_the_mass_points(seed: int) -> None:
    """Lumped masses: ``M_b(q) [a; α; q̈] + h_ω`` of the kernel (invariants from
    compute_invariants, second-order inertia included) equals the point-mass sum to
    round-off, at a deformation of 30 % of the body size."""
    fe, x, m, V, rng = _cloud(seed=seed)
    b = ffrf_prepare(compute_invariants(fe, V).to_flat())
    q, qd, qdd = (rng.normal(size=V.shape[1]) for _ in range(3))
    a, alpha, w = (rng.normal(size=3) for _ in range(3))
    hr, he = ffrf_velocity_terms(b, q, qd, w, ffrf_mass_blocks(b, q))
    lhs = ffrf_body_mass(b, q) @ np.concatenate([a, alpha, qdd]) + np.concatenate([hr, he])
    ref = _point_mass_sum(x, m, V, q, qd, qdd, a, alpha, w)
    assert np.allclose(lhs, ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max())


def test_sid_truncation_misses_the_second_order_terms() -> None:
    """Without ``J.m2`` (SID truncation) the rotational rows differ from the point-mass sum
    by terms of second order in q — the defect that makes a flexible pendulum gain energy."""
    fe, x, m, V, _rng = _cloud(seed=5)
    b = ffrf_prepare(compute_invariants(fe, V).to_flat(), inertia="sid")
    errs = []
    for scale in (1e-2, 2e-2):
        q = scale * np.ones(V.shape[1])
        qd = qdd = np.zeros(V.shape[1])
        a = alpha = np.zeros(3)
        w = np.array([0.3, -0.2, 0.5])
        hr, _he = ffrf_velocity_terms(b, q, qd, w, ffrf_mass_blocks(b, q))
        ref = _point_mass_sum(x, m, V, q, qd, qdd, a, alpha, w)
        errs.append(np.abs(hr[3:] - ref[3:6]).max())
    assert errs[0] > 1e-8
    assert errs[1] / errs[0] == pytest.approx(4.0, rel=0.05)


def test_kinetic_energy_is_that_of_the_mass_points() -> None:
    """``½ zᵀ M_b z`` equals ``Σ ½ m_n |v + ω × c_n + ċ_n|²``."""
    fe, x, m, V, rng = _cloud(seed=7)
    b = ffrf_prepare(compute_invariants(fe, V).to_flat())
    q, qd = rng.normal(size=V.shape[1]), rng.normal(size=V.shape[1])
    v, w = rng.normal(size=3), rng.normal(size=3)
    phi = V.reshape(x.shape[0], 3, -1)
    vel = v + np.cross(w, x + phi @ q) + phi @ qd
    ref = 0.5 * np.sum(m * np.einsum("na,na->n", vel, vel))
    assert ffrf_kinetic_energy(b, v, w, q, qd) == pytest.approx(ref, rel=1e-12)
