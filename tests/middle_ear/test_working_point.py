"""The TM tangent of the working point with two moduli (``ear_working_point.tm_tangent``).

References: linear elasticity (without a static state the small motions see the modulus
``tm_E`` alone, i.e. the stiffness of a TM built with that modulus), the consistent tangent
of the static problem (central differences of the internal forces, when both moduli agree),
and the split of docs/equations-middle-ear.md §3 (the prestress of the static state does not
depend on the modulus of the small motions).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from neweul_py.middle_ear.model import build_middle_ear
from neweul_py.middle_ear.parameters import MiddleEarParameters
from neweul_py.middle_ear.static import solve_static, tm_displacements
from neweul_py.middle_ear.working_point import tm_tangent

BASE = MiddleEarParameters()


@pytest.fixture(scope="module")
def loaded():
    me = build_middle_ear(BASE, refine=0)
    (state,) = solve_static(me, [3000.0])
    return me, tm_displacements(me, state).ravel()


def test_without_static_state_the_small_motions_see_the_dynamic_modulus() -> None:
    """At u = 0: ``tm_tangent`` of (E, E_s) equals the stiffness of a TM built with E alone."""
    me = build_middle_ear(BASE, refine=0)
    one = build_middle_ear(replace(BASE, tm_E_static=BASE.tm_E), refine=0)
    u = np.zeros(me.shell.n_dof)
    k, ref = tm_tangent(me, u), tm_tangent(one, u)
    _, _, km = one.shell.membrane(u)
    assert np.allclose((ref - km - one.shell.bending).data, 0.0)
    assert abs(k - ref).max() <= 1e-12 * abs(ref).max()
    assert BASE.tm_E_static < BASE.tm_E


def test_with_one_modulus_it_is_the_consistent_tangent(loaded) -> None:
    """E_s = E: central differences of the membrane forces plus the bending stiffness."""
    me, u = loaded
    one = replace(me, params=replace(me.params, tm_E=me.shell.material.E))
    k = tm_tangent(one, u).toarray()
    rng = np.random.default_rng(3)
    v = rng.standard_normal(u.size) * 1e-9
    fp = one.shell.membrane(u + v, tangent=False)[1]
    fm = one.shell.membrane(u - v, tangent=False)[1]
    fd = (fp - fm) / 2.0 + one.shell.bending @ v
    assert np.linalg.norm(k @ v - fd) <= 1e-6 * np.linalg.norm(fd)


def test_prestress_is_independent_of_the_dynamic_modulus(loaded) -> None:
    """Under a static state, ``tm_tangent`` is affine in E: ``K(E) = K_σ + E/E_s (K_m + K_b)``
    with the same stress stiffening ``K_σ`` (the static stress) for every E; and ``K_σ`` is
    what is left at E → 0, the membrane's geometric stiffness, which is non-zero."""
    me, u = loaded
    es = me.params.tm_E_static

    def k(e: float) -> np.ndarray:
        return tm_tangent(replace(me, params=replace(me.params, tm_E=e)), u).toarray()

    k1, k2, k3 = k(es), k(2.0 * es), k(3.0 * es)
    assert np.allclose(k3 - k2, k2 - k1, atol=1e-9 * abs(k1).max())
    k_sigma = 2.0 * k1 - k2
    assert abs(k_sigma).max() > 1e-6 * abs(k1).max()
    assert np.allclose(k_sigma, k_sigma.T, atol=1e-12 * abs(k1).max())
