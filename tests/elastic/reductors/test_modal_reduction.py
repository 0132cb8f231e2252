"""Modal truncation, two-sided and one-sided.

References: analytic duct resonances ``n c / 2L``; closed-form coupled frequencies of a
spring–mass piston closing a duct (transcendental equation in ``fe_builders``); dense
eigen-solutions and direct frequency responses of the unreduced FE models.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse.linalg as spla
from fe_builders import duct, piston_duct, piston_duct_frequencies, random_up, spring_chain

from neweul_py.elastic import frf_full, frf_reduced, max_relative_error, reduce_modal, stability
from neweul_py.elastic.quality.measures import reduced_eigenvalues
from neweul_py.elastic.reductors.eigen import (
    ShiftInvert,
    default_shift,
    frequencies_hz,
    left_blocks,
    right_blocks,
)
from neweul_py.elastic.reductors.modal import modal_bases
from neweul_py.errors import DataError


def _dense_eigenvalues(fe, count):
    lam = sla.eigvals(fe.K.toarray(), fe.M.toarray())
    assert np.abs(lam.imag).max() < 1e-6 * np.abs(lam).max()  # real spectrum (§3)
    return np.sort(lam.real)[:count]


def _backward_error(A, B, lam, X):
    """Normwise backward error ``‖(A − λB) x‖ / ((‖A‖ + |λ|‖B‖) ‖x‖)`` per column."""
    r = A @ X - (B @ X) * lam
    na, nb = spla.norm(A, 1), spla.norm(B, 1)
    return np.linalg.norm(r, axis=0) / ((na + np.abs(lam) * nb) * np.linalg.norm(X, axis=0))


def test_duct_resonances_match_n_c_over_2L():
    """Closed–closed duct: f_n = n c / (2L), n = 0, 1, … (λ = 0: constant pressure)."""
    c, L = 343.0, 1.0
    body = reduce_modal(duct(400, L, c), modes=8)
    f = np.sqrt(np.abs(body.eigenvalues)) / (2 * np.pi)
    exact = np.arange(8) * c / (2 * L)
    assert f[0] < 1e-3
    # linear elements, consistent mass: relative dispersion error ≈ (k h)² / 24 < 2e-4 here
    np.testing.assert_allclose(f[1:], exact[1:], rtol=2e-4)


def test_piston_duct_matches_closed_form_coupled_frequencies():
    """u–p coupled, unsymmetric: roots of k sin kL (k_s − mω²) + ρAω² cos kL = 0."""
    fe = piston_duct(n_el=400)
    body = reduce_modal(fe, modes=9)
    f = np.sort(np.sqrt(np.abs(body.eigenvalues)) / (2 * np.pi))
    exact = piston_duct_frequencies(8)
    assert f[0] < 1e-3  # closed cavity: constant-pressure mode at λ = 0 (singular K)
    np.testing.assert_allclose(f[1:], exact, rtol=3e-4)


@pytest.mark.parametrize("build,tol", [
    (random_up, 1e-13),
    (lambda: random_up(seed=3, rho=40.0), 1e-13),
    (duct, 1e-12),
    # the u–p relation scales the u rows of the right residual by ρλ (here ρλ ≈ 1e8 against
    # a pressure-dominated w), so round-off of ARPACK's right vectors shows up amplified
    (piston_duct, 1e-9),
])
def test_left_eigenvectors_satisfy_the_transposed_problem(build, tol):
    """(K − λM)ᵀ w = 0 and Kx = λMx for every retained pair; Wᵀ M V = I."""
    fe = build()
    V, W, lam, _ = modal_bases(fe, modes=10)
    assert _backward_error(fe.K, fe.M, lam, V).max() < 1e-13
    assert _backward_error(fe.K.T, fe.M.T, lam, W).max() < tol
    np.testing.assert_allclose(W.T @ (fe.M @ V), np.eye(10), atol=1e-12)


def test_up_relation_and_transposed_problem_give_the_same_left_vectors():
    """Left vectors for free ([ρλu; p], §3) agree with ARPACK on the transposed operator."""
    fe = random_up(seed=5)
    si = ShiftInvert(fe.K, fe.M, default_shift(fe))
    right = right_blocks(si, 8)
    up = left_blocks(fe, si, right, 12, up_relation=True)
    tr = left_blocks(fe, si, right, 12, up_relation=False)
    for a, b in zip(up, tr, strict=True):
        cos = abs(a.basis[:, 0] @ b.basis[:, 0]) / (np.linalg.norm(a.basis) *
                                                    np.linalg.norm(b.basis))
        assert cos == pytest.approx(1.0, abs=1e-10)


@pytest.mark.parametrize("build", [lambda: random_up(damping=1e-3), piston_duct])
@pytest.mark.parametrize("static", [False, True])
def test_two_sided_reduction_keeps_the_retained_eigenvalues(build, static):
    """Eigenvalues of (K_r, M_r) contain the lowest full eigenvalues (dense reference)."""
    fe = build()
    body = reduce_modal(fe, modes=12, static_correction=static)
    full = _dense_eigenvalues(fe, 12)
    red = reduced_eigenvalues(body).real
    scale = np.abs(full).max()
    for lam in full:  # every retained eigenvalue is an eigenvalue of the reduced pencil
        assert np.min(np.abs(red - lam)) < 1e-10 * scale
    np.testing.assert_allclose(body.eigenvalues, full, atol=1e-10 * scale)
    if not static:
        np.testing.assert_allclose(body.M, np.eye(12), atol=1e-12)
        # off-diagonal Wᵀ K V carries the eigenvector error (≈ 1e-9 relative for the piston)
        np.testing.assert_allclose(body.K, np.diag(body.eigenvalues), atol=1e-8 * scale)


def test_frf_error_is_tiny_well_below_cut_off_and_decreases_with_modes():
    """Reduced vs. unreduced FRF (sparse direct) of the damped piston–duct, 10–600 Hz."""
    fe = piston_duct(damping=5.0)
    f = np.linspace(10.0, 600.0, 60)
    H = frf_full(fe, f)
    errors = []
    for modes in (10, 20, 40):
        body = reduce_modal(fe, modes=modes, static_correction=True)
        assert stability(body).stable
        errors.append(max_relative_error(f, H, frf_reduced(body, f)))
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 1e-6  # 40 modes: cut-off ≈ 6 kHz, ten times above the band
    plain = [max_relative_error(f, H, frf_reduced(reduce_modal(fe, modes=m), f))
             for m in (10, 20, 40)]
    assert plain[0] > plain[1] > plain[2]  # without static correction: slower, still monotone


def test_one_sided_reduction_of_unsymmetric_model_is_unstable_two_sided_is_not():
    """Galerkin projection of the u–p model with static correction loses stability."""
    fe = piston_duct(damping=5.0)
    one = reduce_modal(fe, modes=4, static_correction=True, two_sided=False)
    two = reduce_modal(fe, modes=4, static_correction=True, two_sided=True)
    assert not stability(one).stable and stability(one).max_real_part > 1.0
    assert stability(two).stable


def test_one_and_two_sided_agree_for_a_symmetric_model():
    """Spring–mass chain (symmetric): left = right eigenvectors, identical FRFs."""
    fe = spring_chain(80, damping=1e-4)
    f = np.linspace(1.0, 20.0, 30)
    one = reduce_modal(fe, modes=15, two_sided=False)
    two = reduce_modal(fe, modes=15)
    np.testing.assert_allclose(frf_reduced(one, f), frf_reduced(two, f), rtol=1e-9)
    assert stability(one).stable and stability(two).stable


def test_band_selection_keeps_exactly_the_modes_in_the_band():
    fe = piston_duct()
    body = reduce_modal(fe, band=(100.0, 700.0))
    full = np.sqrt(np.abs(_dense_eigenvalues(fe, 30))) / (2 * np.pi)
    expected = full[(full >= 100.0) & (full <= 700.0)]
    got = np.sort(np.sqrt(body.eigenvalues) / (2 * np.pi))
    np.testing.assert_allclose(got, expected, rtol=1e-9)
    assert body.settings["band"] == [100.0, 700.0] and body.method == "modal"


def test_kept_nodes_store_the_basis_rows():
    fe = piston_duct(40)
    body = reduce_modal(fe, modes=6, keep_nodes=[1, 5], store_bases=True)
    assert body.nodes[:, 0].tolist() == [1.0, 5.0]
    np.testing.assert_array_equal(body.V_kept, body.V[body.kept_dofs])
    np.testing.assert_array_equal(body.W_kept, body.W[body.kept_dofs])
    assert sorted(set(body.dof_node.tolist())) == [1, 5]
    default = reduce_modal(fe, modes=6)  # input/output nodes: piston (1) and far end (41)
    assert default.nodes[:, 0].tolist() == [1.0, 41.0]


@pytest.mark.parametrize("kwargs,item,text", [
    (dict(band=(1.0, 50.0)), "band", "no modes in the band"),
    (dict(modes=500), "modes", "500 modes requested"),
    (dict(modes=5, shift=0.0), "K − σM", "singular"),  # closed cavity: K is singular
    (dict(), "modes", "exactly one"),
    (dict(modes=3, band=(0, 100)), "modes", "exactly one"),
    (dict(band=(50.0, 10.0)), "band", "fmin < fmax"),
])
def test_bad_requests_are_clear_errors(kwargs, item, text):
    fe = piston_duct(n_el=100).with_(source="pd.json")
    with pytest.raises(DataError, match=text) as exc:
        reduce_modal(fe, **kwargs)
    assert exc.value.item == item and exc.value.file == "pd.json"


def test_shift_on_an_eigenvalue_is_a_clear_error():
    """A shift equal (to round-off) to an eigenvalue makes K − σM numerically singular."""
    fe = spring_chain(40).with_(source="chain.json")
    lam = np.sort(sla.eigvalsh(fe.K.toarray(), fe.M.toarray()))[3]
    with pytest.raises(DataError, match="singular") as exc:
        reduce_modal(fe, modes=5, shift=lam)
    assert exc.value.item == "K − σM" and exc.value.file == "chain.json"


@pytest.mark.parametrize("build,band", [
    (duct, (0.0, 300.0)),                  # acoustic, closed–closed: constant pressure
    (piston_duct, (0.0, 300.0)),           # u–p coupled, unsymmetric, closed cavity
    (piston_duct, (0.0, 20000.0)),         # wide band: shift far from the zero mode
    (piston_duct, (1.0, 20000.0)),         # from 1 Hz: the zero mode stays out
])
def test_band_membership_of_the_zero_mode(build, band):
    """Band membership does not depend on round-off: with the shift in the middle of the
    band the computed zero mode comes out slightly negative (−3e-7 … −0.4), yet a band from
    0 Hz keeps it (and one from 1 Hz does not). Reference: the dense eigenvalues of the
    full pencil (scipy.linalg.eigvals); the left vector of the zero mode solves the
    transposed problem (it needs its own shift)."""
    fe = build()
    lo, hi = ((2 * np.pi * f) ** 2 for f in band)
    dense = _dense_eigenvalues(fe, fe.n_dofs)
    assert abs(dense[0]) < 1e-12 * dense.max() < dense[1]   # the model has a zero mode
    zero = band[0] == 0
    expected = dense[(dense <= hi) & ((dense >= lo) | zero)]
    assert expected.size < dense.size and dense[expected.size + (not zero)] > (1 + 1e-6) * hi
    body = reduce_modal(fe, band=band, store_bases=True)
    lam = body.eigenvalues
    order = np.argsort(lam)
    assert lam.size == expected.size
    np.testing.assert_allclose(lam[order][zero:], expected[zero:], rtol=1e-9)
    if not zero:
        return
    assert abs(lam[order][0]) < 1e-12 * dense.max()
    # two-sided: the retained eigenvalues are the reduced pencil's, incl. the zero mode
    red = np.sort(reduced_eigenvalues(body).real)
    np.testing.assert_allclose(red[1:], expected[1:], rtol=1e-9)
    assert abs(red[0]) < 1e-12 * dense.max()
    # left zero-mode vector: a subspace iteration at the mid-band shift would converge to
    # the mode nearest the shift instead (backward error 0.1–1); the remaining 1e-7 is the
    # accuracy of all low modes' left vectors in a band this wide (u–p relation, see above)
    w0 = body.W[:, order[:1]]
    assert _backward_error(fe.K.T, fe.M.T, lam[order[:1]], w0)[0] < 1e-6
    f = frequencies_hz(lam, scale=hi)
    assert np.all(np.isfinite(f)) and f[order[0]] < 1e-3


def test_frequencies_clamp_only_round_off_negatives():
    """f = √λ/2π; λ within 1e-8·scale below zero is 0 Hz, a larger negative λ keeps √|λ|."""
    lam = np.array([-1e-3, (2 * np.pi * 50.0) ** 2, -4.0e2])
    f = frequencies_hz(lam, scale=1e6)
    np.testing.assert_allclose(f, [0.0, 50.0, np.sqrt(4.0e2) / (2 * np.pi)], rtol=1e-14)
