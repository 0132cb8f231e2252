"""Modal reduction of free (unsupported) models and of degenerate eigenvalue clusters.

References: dense eigen-solutions of the full pencils (``scipy.linalg.eigh`` / ``eigvals``);
the analytic free-free Euler–Bernoulli frequencies ``ω_n = (β_n L)² √(EI / ρA L⁴)`` with
``cos βL cosh βL = 1`` (β_n L = 4.7300, 7.8532, 10.9956, …), axial ``n c / 2L``, ``c = √(E/ρ)``,
and torsion ``n √(G/ρ) / 2L`` (Blevins, *Formulas for Natural Frequency and Mode Shape*,
tables 8-1, 8-16); the rigid-body fields of the beam (translations, rotations about the
origin), which span the null space of its stiffness matrix.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.optimize as so
from beam_fe import beam
from fe_builders import piston_duct, random_up, twin

from neweul_py.cli import main
from neweul_py.elastic import reduce_modal, write_fe_model
from neweul_py.elastic.bodies.invariants import body_invariants
from neweul_py.elastic.io.body_files import load_reduced_body
from neweul_py.elastic.quality.measures import reduced_eigenvalues
from neweul_py.elastic.reductors.eigen import (
    ShiftInvert,
    default_shift,
    frequencies_hz,
    left_blocks,
    right_blocks,
    symmetric_pencil,
)
from neweul_py.elastic.reductors.invariants import compute_invariants
from neweul_py.elastic.reductors.modal import _pair, _select, modal_bases
from neweul_py.errors import DataError

N_EL = 20


def _beta_l(count: int) -> np.ndarray:
    """Roots of ``cos x cosh x = 1`` (free-free beam), x > 0."""
    g = lambda x: np.cos(x) * np.cosh(x) - 1.0  # noqa: E731
    return np.array([so.brentq(g, (n + 0.5) * np.pi - 0.3, (n + 0.5) * np.pi + 0.3,
                               xtol=1e-14) for n in range(1, count + 1)])


def _analytic_elastic_hz(b, count: int) -> np.ndarray:
    """Lowest free-free frequencies: bending in both planes, axial, torsion."""
    bl = _beta_l(count)
    f = []
    for EI in (b.E * b.Iy, b.E * b.Iz):
        f += list(bl**2 * np.sqrt(EI / (b.rho * b.A * b.length**4)) / (2 * np.pi))
    n = np.arange(1, count + 1)
    f += list(n * np.sqrt(b.E / b.rho) / (2 * b.length))
    f += list(n * np.sqrt(b.G / b.rho) / (2 * b.length))   # Jt = Iy + Iz, polar inertia alike
    return np.sort(f)[:count]


@pytest.fixture(scope="module")
def free_beam():
    b = beam(N_EL)
    dense = sla.eigh(b.fe.K.toarray(), b.fe.M.toarray(), eigvals_only=True)
    return b, dense


def _check_against_dense(lam, dense, count, skipped=0):
    """Zero modes at round-off level, the others equal to the dense eigenvalues."""
    lam = np.sort(np.real(lam))
    ref = dense[skipped:skipped + count]
    zero = np.abs(ref) < 1e-12 * dense.max()
    assert zero.sum() == max(0, min(count, 6 - skipped))
    assert np.all(np.abs(lam[zero]) < 1e-12 * dense.max())
    np.testing.assert_allclose(lam[~zero], ref[~zero], rtol=1e-10)


@pytest.mark.parametrize("two_sided", [True, False])
@pytest.mark.parametrize("modes", [1, 4, 6, 10])
def test_free_free_beam_keeps_rigid_and_elastic_modes(free_beam, two_sided, modes):
    """Free-free beam, 6 rigid-body modes at λ = 0: count includes them, they come out at
    0 Hz, the elastic ones equal the dense eigenvalues and the analytic Euler–Bernoulli
    frequencies (within the mesh error, from above: consistent mass is Rayleigh–Ritz)."""
    b, dense = free_beam
    body = reduce_modal(b.fe, modes=modes, two_sided=two_sided, store_bases=True)
    lam = body.eigenvalues
    assert lam.shape == (modes,)
    _check_against_dense(lam, dense, modes)
    f = np.sort(frequencies_hz(lam, scale=dense[modes]))
    n_rigid = min(modes, 6)
    assert np.all(f[:n_rigid] == 0.0)
    if modes > 6:
        exact = _analytic_elastic_hz(b, modes - 6)
        err = f[6:] / exact - 1
        assert np.all(err > 0) and np.all(err < 1e-4), err
    # the reduced pencil has exactly these eigenvalues
    _check_against_dense(reduced_eigenvalues(body), dense, modes)
    V, W, M = body.V, body.W, b.fe.M
    if two_sided:
        np.testing.assert_allclose(W.T @ (M @ V), np.eye(modes), atol=1e-12)
        np.testing.assert_allclose(body.M, np.eye(modes), atol=1e-12)
        np.testing.assert_allclose(body.K, np.diag(lam), atol=1e-9 * dense[6])
        # symmetric pencil: the left basis is the right one (up to column scaling)
        cos = np.abs(np.einsum("ij,ij->j", W, V)) / (np.linalg.norm(W, axis=0) *
                                                    np.linalg.norm(V, axis=0))
        np.testing.assert_allclose(cos, 1.0, atol=1e-12)
    else:
        np.testing.assert_allclose(V.T @ V, np.eye(modes), atol=1e-12)
    # every retained vector is an eigenvector: Kv = λMv (the rigid ones: Kv = 0)
    R = b.fe.K @ V - (M @ V) * lam if two_sided else None
    if R is not None:
        scale = np.abs(b.fe.K).max()
        assert np.linalg.norm(R, axis=0).max() < 1e-9 * scale


def test_symmetric_shortcut_is_taken_for_the_beam(free_beam):
    """M and K of the beam are symmetric (not declared): left blocks are the right ones."""
    b, _ = free_beam
    assert symmetric_pencil(b.fe)
    assert symmetric_pencil(b.fe.with_(symmetric={"M": True, "K": True}))
    assert not symmetric_pencil(random_up())
    si = ShiftInvert(b.fe.K, b.fe.M, default_shift(b.fe))
    right = right_blocks(si, 12)
    assert right[0].basis.shape[1] == 6         # one 6-fold cluster at λ = 0
    assert all(x is y for x, y in zip(left_blocks(b.fe, si, right, 12), right, strict=True))


@pytest.mark.parametrize("equal_inertia", [False, True])
def test_transposed_problem_matches_degenerate_clusters_as_subspaces(equal_inertia):
    """Without the symmetric shortcut, the left vectors come from ARPACK on the transposed
    operator: the 6-fold zero cluster (and, with Iy = Iz, the double bending frequencies)
    are matched as invariant subspaces — same span as the right ones (symmetric pencil),
    and the cluster blocks pair to Wᵀ M V = I. Reference: dense eigh."""
    b = beam(12, Iy=4.0e-4) if equal_inertia else beam(12)
    fe = b.fe
    dense = sla.eigh(fe.K.toarray(), fe.M.toarray(), eigvals_only=True)
    si = ShiftInvert(fe.K, fe.M, default_shift(fe))
    right = right_blocks(si, 16)
    dims = [x.basis.shape[1] for x in right]
    assert dims[0] == 6 and (not equal_inertia or dims[1] == 2)
    left = left_blocks(fe, si, right, 16, use_symmetry=False)
    for r, lb in zip(right, left, strict=True):
        # principal angles between the right and left cluster spans vanish
        s = sla.subspace_angles(r.basis, lb.basis)
        assert s.max() < 1e-6
    V, W, lam = _pair(right, left, fe, False, si.sigma)
    k = V.shape[1]
    G = W.T @ (fe.M @ V)
    start = 0
    for r in right:   # each cluster block pairs exactly; across clusters: eigenvector error
        sl = slice(start, start + r.basis.shape[1])
        np.testing.assert_allclose(G[sl, sl], np.eye(sl.stop - start), atol=1e-12)
        start = sl.stop
    np.testing.assert_allclose(G, np.eye(k), atol=1e-8)
    lam = np.sort(np.einsum("ij,ij->j", W, fe.K @ V))
    zero = np.arange(k) < 6
    assert np.all(np.abs(lam[zero]) < 1e-12 * dense.max())
    np.testing.assert_allclose(lam[~zero], dense[6:k], rtol=1e-10)


@pytest.mark.parametrize("modes", [1, 4])
def test_a_count_inside_the_zero_cluster_computes_the_whole_cluster(free_beam, modes):
    """modes < 6: ARPACK's first k = modes + 4 pairs cut the 6-fold zero cluster, so k grows
    until the cluster is complete; its left subspace (transposed problem, no symmetric
    shortcut) pairs with it, and the kept part is bi-orthonormal."""
    b, dense = free_beam
    fe = b.fe
    si = ShiftInvert(fe.K, fe.M, default_shift(fe))
    right, k, _tol = _select(fe, si, modes, None, False, None)
    assert [r.basis.shape[1] for r in right] == [6] and k > 6
    left = left_blocks(fe, si, right, k, use_symmetry=False)
    assert sla.subspace_angles(right[0].basis, left[0].basis).max() < 1e-6
    V, W, lam = _pair(right, left, fe, False, si.sigma)
    V, W = V[:, :modes], W[:, :modes]
    np.testing.assert_allclose(W.T @ (fe.M @ V), np.eye(modes), atol=1e-12)
    assert np.abs(fe.K @ V).max() < 1e-12 * np.abs(fe.K).max()    # rigid-body fields
    assert np.all(np.abs(lam) < 1e-12 * dense.max())


def test_skip_rigid_drops_the_zero_cluster(free_beam):
    """skip_rigid: modes counts elastic modes only; a band from 0 Hz keeps no λ = 0 mode."""
    b, dense = free_beam
    for two_sided in (True, False):
        body = reduce_modal(b.fe, modes=4, skip_rigid=True, two_sided=two_sided)
        _check_against_dense(body.eigenvalues, dense, 4, skipped=6)
        assert body.settings["skip_rigid"] is True
    f1, f2 = _analytic_elastic_hz(b, 2)
    band = (0.0, 0.5 * (f2 + _analytic_elastic_hz(b, 3)[2]))       # 2 elastic modes
    with_rigid = reduce_modal(b.fe, band=band)
    without = reduce_modal(b.fe, band=band, skip_rigid=True)
    assert with_rigid.eigenvalues.size == 8 and without.eigenvalues.size == 2
    assert np.sum(frequencies_hz(with_rigid.eigenvalues, scale=dense[8]) == 0.0) == 6
    np.testing.assert_allclose(np.sort(without.eigenvalues), dense[6:8], rtol=1e-10)
    assert "skip_rigid" not in with_rigid.settings
    with pytest.raises(DataError, match="no modes in the band"):
        reduce_modal(b.fe, band=(0.0, 0.5 * f1), skip_rigid=True)


def test_ffrf_invariants_need_the_rigid_modes_skipped(free_beam):
    """Free-free elastic modes satisfy the mean-axis conditions (Ct⁰ = 0, Cr⁰ = 0) and give
    a regular body mass matrix (§2); with the rigid-body modes kept as elastic coordinates
    it is singular (they duplicate the reference frame's motion)."""
    b, _ = free_beam
    V, W, _lam, _ = modal_bases(b.fe, modes=6, skip_rigid=True)
    inv = compute_invariants(b.fe, V, W)
    np.testing.assert_allclose(inv.Ct.m0, 0.0, atol=1e-10)
    np.testing.assert_allclose(inv.Cr.m0, 0.0, atol=1e-10)
    assert np.linalg.cond(inv.mass_matrix()) < 1e6
    V, W, _lam, _ = modal_bases(b.fe, modes=12)
    assert np.linalg.cond(compute_invariants(b.fe, V, W).mass_matrix()) > 1e12


@pytest.mark.parametrize("build", [lambda: twin(random_up(nu=30, npr=40)),
                                   lambda: twin(piston_duct(60))])
@pytest.mark.parametrize("modes", [9, 10])
def test_unsymmetric_repeated_pairs_two_sided(build, modes):
    """Two identical uncoupled u–p sub-models: every eigenvalue is double (the piston–duct
    twin also has a double λ = 0, two closed cavities). Two-sided reduction reproduces both
    members of each pair (dense eigvals), Wᵀ M V = I, and the left vectors solve the
    transposed problem; modes = 9 cuts a pair and stays bi-orthonormal."""
    fe = build()
    dense = np.sort(sla.eigvals(fe.K.toarray(), fe.M.toarray()).real)
    assert abs(dense[1] - dense[0]) <= 1e-9 * dense[2] or abs(dense[1]) < 1e-9 * dense[2]
    V, W, lam, _ = modal_bases(fe, modes=modes)
    lam = np.real(lam)
    scale = dense[modes]
    zero = np.abs(dense[:modes]) < 1e-9 * scale
    got = np.sort(lam)
    assert np.all(np.abs(got[zero]) < 1e-9 * scale)
    np.testing.assert_allclose(got[~zero], dense[:modes][~zero], rtol=1e-9)
    np.testing.assert_allclose(W.T @ (fe.M @ V), np.eye(modes), atol=1e-10)
    Kt, Mt = fe.K.T, fe.M.T
    res = np.linalg.norm(Kt @ W - (Mt @ W) * lam, axis=0)
    ref = (np.abs(fe.K).max() + np.abs(lam) * np.abs(fe.M).max()) * np.linalg.norm(W, axis=0)
    assert (res / ref).max() < 1e-8
    body = reduce_modal(fe, modes=modes)
    np.testing.assert_allclose(body.M, np.eye(modes), atol=1e-10)
    red = np.sort(reduced_eigenvalues(body).real)
    assert np.all(np.abs(red[zero]) < 1e-9 * scale)
    np.testing.assert_allclose(red[~zero], dense[:modes][~zero], rtol=1e-9)


@pytest.mark.parametrize("build", [lambda: twin(random_up(nu=30, npr=40)),
                                   lambda: twin(piston_duct(60))])
def test_repeated_pairs_transposed_problem_agrees_with_up_relation(build):
    """The u–p relation [ρλu; p] and ARPACK on the transposed operator give the same left
    invariant subspace of every (double) cluster."""
    fe = build()
    si = ShiftInvert(fe.K, fe.M, default_shift(fe))
    right = right_blocks(si, 10)
    assert all(x.basis.shape[1] == 2 for x in right[:4])
    up = left_blocks(fe, si, right, 14, up_relation=True)
    tr = left_blocks(fe, si, right, 14, up_relation=False)
    for a, c in zip(up, tr, strict=True):
        assert sla.subspace_angles(a.basis, c.basis).max() < 1e-6
    V, W, _lam = _pair(right, tr, fe, False, si.sigma)
    np.testing.assert_allclose(W.T @ (fe.M @ V), np.eye(V.shape[1]), atol=1e-10)


def test_cli_modes_and_band_from_zero_on_a_free_beam(tmp_path, capsys, free_beam):
    """`neweul reduce --modes 8` and `--band 0:F` on the free beam: 0 Hz modes included."""
    b, dense = free_beam
    model = tmp_path / "beam.npz"
    write_fe_model(b.fe, model)
    out = tmp_path / "m.npz"
    assert main(["reduce", str(model), "--modes", "8", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "retained frequencies [Hz]: 0 …" in text
    _check_against_dense(load_reduced_body(out).eigenvalues, dense, 8)
    f3 = _analytic_elastic_hz(b, 3)
    assert main(["reduce", str(model), "--band", f"0:{0.5 * (f3[1] + f3[2])}",
                 "-o", str(out)]) == 0
    capsys.readouterr()
    _check_against_dense(load_reduced_body(out).eigenvalues, dense, 8)


def test_cli_floating_body_needs_skip_rigid(tmp_path, capsys, free_beam):
    """`neweul reduce --invariants` of the free beam: with its rigid-body modes kept as elastic
    coordinates the (6+nq)² floating-frame mass matrix is singular and the command refuses
    (naming --skip-rigid, writing nothing); with `--skip-rigid` the 4 elastic modes are the
    first analytic free-free bending frequencies and the body mass matrix is regular."""
    b, dense = free_beam
    model = tmp_path / "beam.npz"
    write_fe_model(b.fe, model)
    out = tmp_path / "body.npz"
    assert main(["reduce", str(model), "--modes", "10", "--invariants", "-o", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "repeat the rigid motion" in err and "--skip-rigid" in err and not out.exists()
    assert main(["reduce", str(model), "--modes", "4", "--skip-rigid", "--invariants",
                 "-o", str(out)]) == 0
    capsys.readouterr()
    body = load_reduced_body(out)
    hz = np.sqrt(np.asarray(body.eigenvalues).real) / (2 * np.pi)
    assert hz.min() > 0.0
    np.testing.assert_allclose(np.sort(hz), _analytic_elastic_hz(b, 4), rtol=1e-3)
    _check_against_dense(body.eigenvalues, dense, 4, skipped=6)
    mass = np.linalg.svd(body_invariants(body).mass_matrix(), compute_uv=False)
    assert mass[-1] > 1e-6 * mass[0]
