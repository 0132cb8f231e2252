"""The transposed u–p dynamic stiffness as a similarity
(neweul_py/elastic/reductors/up_transpose.py) and the adjoint snapshots taken from it
(neweul_py/elastic/parametric/snapshot_basis.py).

References: direct sparse solves of ``A(ω)ᵀ y = c`` (SciPy ``spsolve``) and central
differences of them in ``ω``, on the string–cavity u–p model (``fe_builders.membrane_cavity``,
Eq. (2) with stiffness-proportional structural damping).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sps
import scipy.sparse.linalg as spla
from fe_builders import membrane_cavity, piston_duct

import neweul_py.elastic.parametric.snapshot_basis as snapshot_basis
from neweul_py.elastic.parametric.snapshot_basis import frequency_snapshots
from neweul_py.elastic.reductors.up_transpose import (
    adjoint_from_primal,
    mirrored_loads,
    up_similarity,
)


@pytest.fixture(scope="module")
def cavity():
    return membrane_cavity(tension=40.0, n_x=12, n_z=8)


def _A(fe, w, Kx=None):
    K = fe.K if Kx is None else fe.K + Kx
    return (K + 1j * w * fe.D - w * w * fe.M).tocsc()


def test_the_transpose_is_the_scaled_matrix(cavity) -> None:
    """``Aᵀ = S A S⁻¹`` with ``S = diag(I, I/(ω²ρ))`` entry for entry (reference: the
    assembled sparse matrices)."""
    rho = up_similarity(cavity, cavity.K, cavity.D)
    assert rho == cavity.density
    w = 2 * np.pi * 700.0
    s = np.where(cavity.dof_kind == "p", 1.0 / (w * w * rho), 1.0)
    A = _A(cavity, w)
    lhs, rhs = A.T.toarray(), (sps.diags(s) @ A @ sps.diags(1.0 / s)).toarray()
    assert np.abs(lhs - rhs).max() <= 1e-13 * np.abs(lhs).max()


def test_coupled_losses_or_a_structural_model_have_no_similarity(cavity) -> None:
    """A loss term between u and p, an unsymmetric block or a model without pressures: no
    ``ρ`` (the adjoint responses are then solved)."""
    is_p = cavity.dof_kind == "p"
    u, p = np.flatnonzero(~is_p)[0], np.flatnonzero(is_p)[0]
    n = cavity.n_dofs
    coupled = sps.csr_matrix(([1e-9], ([u], [p])), shape=(n, n))
    assert up_similarity(cavity, cavity.K, cavity.D + coupled) is None
    lopsided = sps.csr_matrix(([1.0], ([u], [u + 1])), shape=(n, n))
    assert up_similarity(cavity, cavity.K + lopsided, cavity.D) is None
    assert up_similarity(piston_duct(n_el=10), piston_duct(n_el=10).K, None) == 1.2
    structural = membrane_cavity(tension=40.0, n_x=12, n_z=8)
    object.__setattr__(structural, "kind", "structural")
    assert up_similarity(structural, structural.K, structural.D) is None


def test_mirrored_loads_are_primal_loads_without_pressure_rows(cavity) -> None:
    """Only an adjoint load equal to a primal one and zero on the pressure rows is taken from
    the primal responses."""
    is_p = cavity.dof_kind == "p"
    F = np.column_stack([cavity.B("force")[:, 0], np.where(is_p, 1.0, 0.0)])
    c = np.column_stack([cavity.C("probe")[0], F[:, 1], 2 * cavity.C("umbo")[0], F[:, 0],
                         cavity.C("umbo")[0]])
    assert mirrored_loads(F, c, is_p) == {3: 0, 4: 0}      # the umbo is the force's DOF


@pytest.mark.parametrize(("f0", "tol"), [(20.0, 1e-5), (900.0, 1e-8)])
def test_adjoint_responses_from_primal_ones(cavity, f0: float, tol: float) -> None:
    """``S X``, ``(S X)′``, ``(S X)″/2`` equal ``y = A⁻ᵀ c`` and its ω-derivatives for a load
    without pressure rows (reference: direct solves with ``A`` and ``Aᵀ``, the derivatives by
    differentiating ``A y = c``: ``A y′ = −A′ y``, ``A y″/2 = −A′ y′ − ½A″ y`` with
    ``A′ = iD − 2ωM``, ``A″ = −2M``). The closed cavity's constant pressure makes ``A`` nearly
    singular at low frequency (condition 1.4e14 at 20 Hz, 6.8e10 at 900 Hz), so that two
    solves agree to round-off of that size only (measured: 1.5e-6 and 7e-10)."""
    is_p = cavity.dof_kind == "p"
    c = cavity.B("force")[:, 0].astype(complex)
    w = 2 * np.pi * f0
    A = _A(cavity, w)
    A1, A2 = (1j * cavity.D - 2 * w * cavity.M).tocsc(), (-2 * cavity.M).tocsc()

    def chain(A, A1, A2):
        y0 = spla.spsolve(A, c)
        y1 = spla.spsolve(A, -(A1 @ y0))
        return [y0, y1, spla.spsolve(A, -(A1 @ y1) - 0.5 * (A2 @ y0))]

    X = chain(A, A1, A2)
    Y = chain(A.T.tocsc(), A1.T.tocsc(), A2.T.tocsc())
    got = adjoint_from_primal(X, w, cavity.density, is_p)
    for g, ref in zip(got, Y, strict=True):
        for rows in (is_p, ~is_p):
            assert np.abs(g[rows] - ref[rows]).max() <= tol * np.abs(ref[rows]).max()


def test_snapshots_of_mirrored_loads_equal_transposed_solves(cavity) -> None:
    """``frequency_snapshots`` with an adjoint load that is also a primal load gives the same
    snapshots, to round-off, as with the similarity switched off (every adjoint solved with
    ``Aᵀ``; reference: those transposed solves)."""
    Kx = sps.diags(np.where(cavity.dof_kind == "p", 0.0, 5.0)).tocsr()
    F = np.column_stack([cavity.B("force")[:, 0], np.where(cavity.dof_kind == "p", 0, 1.0)])
    c = np.column_stack([cavity.C("probe")[0], cavity.C("umbo")[0], F[:, 1]])
    f = [30.0, 600.0]
    fast = list(frequency_snapshots([cavity], [F], f, Kx, adjoint=[c], moments=3))
    saved = snapshot_basis.up_similarity
    snapshot_basis.up_similarity = lambda *args: None
    try:
        slow = list(frequency_snapshots([cavity], [F], f, Kx, adjoint=[c], moments=3))
    finally:
        snapshot_basis.up_similarity = saved
    is_p = cavity.dof_kind == "p"
    for (xa, ya, wa), (xb, yb, wb) in zip(fast, slow, strict=True):
        assert wa == wb
        np.testing.assert_array_equal(xa, xb)
        for rows in (is_p, ~is_p):
            assert np.abs(ya[rows, :2] - yb[rows, :2]).max() <= 1e-12 * np.abs(yb[rows]).max()
            assert np.abs(ya[rows, 2] - yb[rows, 2]).max() <= 1e-6 * np.abs(yb[rows, 2]).max()
