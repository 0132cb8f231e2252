"""Public beam builders (neweul_py.fem.beam): Euler–Bernoulli and Timoshenko, 2-D and 3-D.

Independent references: Euler–Bernoulli cantilever eigenvalues βL = 1.875104, 4.694091,
7.854757 (e.g. Blevins, *Formulas for Natural Frequency and Mode Shape*, table 8-1); the
Timoshenko cantilever tip deflection ``PL³/(3EI) + PL/(κGA)`` (exact for the interdependent
element); the closed-form Timoshenko frequency equation of a simply supported beam
(Timoshenko 1921: ``(κGAk² − ρAω²)(EIk² + κGA − ρIω²) = (κGAk)²``, ``k = nπ/L``); Euler's
pinned column load ``π²EI/L²`` and Engesser's shear-flexible ``P_E/(1 + P_E/κGA)``; and the
former test-helper beam (tests/support/beam_fe.py at 262ed33, its closed-form element matrices).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla

from neweul_py.cli import main
from neweul_py.elastic import read_fe_model
from neweul_py.elastic.io.fe_files import read_node_sets, read_stiffening
from neweul_py.errors import ModelError
from neweul_py.fem.beam import BeamSection, beam_model

BETA_L = np.array([1.875104069, 4.694091133, 7.854757438])


def clamped(b, count: int, extra_fixed=()):
    """Lowest eigenvalues with node 0 clamped (and ``extra_fixed`` DOFs)."""
    fixed = np.union1d(b.node_dofs(0), np.asarray(extra_fixed, dtype=int))
    free = np.setdiff1d(np.arange(b.fe.n_dofs), fixed)
    K = b.fe.K.toarray()[np.ix_(free, free)]
    M = b.fe.M.toarray()[np.ix_(free, free)]
    return sla.eigh(K, M, eigvals_only=True, subset_by_index=[0, count - 1]), free


@pytest.mark.parametrize("planar", [False, True])
def test_euler_bernoulli_cantilever_frequencies(planar):
    """ω_k = (β_k L)² √(EI/(ρA L⁴)) for both bending planes (Iz = 4 Iy: chordwise 2× flap)."""
    sec = BeamSection(E=7.0e10, G=2.6e10, rho=2700.0, A=1e-4, Iy=1e-10, Iz=4e-10)
    b = beam_model(0.8, 40, sec, planar=planar)
    lam, _ = clamped(b, 6)
    w = np.sqrt(lam)
    ref = lambda I: BETA_L**2 * np.sqrt(sec.E * I / (sec.rho * sec.A * 0.8**4))  # noqa: E731
    if planar:
        np.testing.assert_allclose(w[:3], ref(sec.Iz), rtol=1e-5)
    else:
        np.testing.assert_allclose(np.sort(w)[[0, 2]], ref(sec.Iy)[:2], rtol=1e-5)
        np.testing.assert_allclose(np.sort(w)[1], ref(sec.Iz)[0], rtol=1e-5)


@pytest.mark.parametrize("planar", [False, True])
def test_timoshenko_tip_deflection_exact(planar):
    """A tip load P on a thick cantilever: δ = PL³/(3EI) + PL/(κGA), exact with 3 elements."""
    sec = BeamSection.rectangle(0.1, 0.2, E=2.0e11, nu=0.3, rho=7800.0)
    L, P = 0.5, 1.0e3
    b = beam_model(L, 3, sec, theory="timoshenko", planar=planar)
    kind = "uy"
    I = sec.Iz
    tip = b.dof(3, kind)
    fixed = b.node_dofs(0)
    free = np.setdiff1d(np.arange(b.fe.n_dofs), fixed)
    f = np.zeros(b.fe.n_dofs)
    f[tip] = P
    u = np.zeros(b.fe.n_dofs)
    u[free] = np.linalg.solve(b.fe.K.toarray()[np.ix_(free, free)], f[free])
    ref = P * L**3 / (3 * sec.E * I) + P * L / (sec.shear_factor * sec.G * sec.A)
    assert u[tip] == pytest.approx(ref, rel=1e-10)
    eb = beam_model(L, 3, sec, planar=planar)
    u[free] = np.linalg.solve(eb.fe.K.toarray()[np.ix_(free, free)], f[free])
    assert u[tip] == pytest.approx(P * L**3 / (3 * sec.E * I), rel=1e-10)


def test_timoshenko_simply_supported_frequencies():
    """2-D pinned-pinned thick beam (L/h = 5) against Timoshenko's frequency equation; the
    Euler–Bernoulli model of the same beam is clearly stiffer (> 4 % on mode 2)."""
    sec = BeamSection.rectangle(0.1, 0.2, E=2.0e11, nu=0.3, rho=7800.0)
    L, n = 1.0, 80
    b = beam_model(L, n, sec, theory="timoshenko", planar=True)
    fixed = [b.dof(0, "ux"), b.dof(0, "uy"), b.dof(n, "uy")]
    free = np.setdiff1d(np.arange(b.fe.n_dofs), fixed)
    K, M = b.fe.K.toarray()[np.ix_(free, free)], b.fe.M.toarray()[np.ix_(free, free)]
    lam, X = sla.eigh(K, M, subset_by_index=[0, 7])
    axial = np.isin(free, np.arange(0, b.fe.n_dofs, 3))      # ux rows
    kGA, EI, rA, rI = sec.shear_factor * sec.G * sec.A, sec.E * sec.Iz, sec.rho * sec.A, \
        sec.rho * sec.Iz
    ref = []
    for m in (1, 2, 3):
        k = m * np.pi / L
        # (kGA k² − rA x)(EI k² + kGA − rI x) − (kGA k)² = 0, x = ω²: lower root
        a2, a1 = rA * rI, -(rA * (EI * k**2 + kGA) + rI * kGA * k**2)
        a0 = kGA * k**2 * (EI * k**2 + kGA) - (kGA * k) ** 2
        ref.append(min(np.roots([a2, a1, a0]).real))
    share = np.einsum("ij,ij->j", X[axial], (M @ X)[axial])       # ux part of modal mass
    bending = lam[share < 0.5]
    np.testing.assert_allclose(bending[:3], ref, rtol=3e-4)
    eb = beam_model(L, n, sec, planar=True)
    lam_eb = sla.eigh(eb.fe.K.toarray()[np.ix_(free, free)],
                      eb.fe.M.toarray()[np.ix_(free, free)], eigvals_only=True,
                      subset_by_index=[0, 2])
    assert lam_eb[1] > 1.04**2 * ref[1]


@pytest.mark.parametrize("theory", ["euler-bernoulli", "timoshenko"])
def test_buckling_from_geometric_stiffness(theory):
    """Pinned column under the compression of an axial displacement field u: the buckling
    factor of K + μ K_G(u) is Euler's π²EI/L² (Engesser's P_E/(1 + P_E/κGA) for Timoshenko)."""
    sec = BeamSection(E=1.0, G=0.4, rho=1.0, A=1.0, Iy=1e-3, Iz=1e-3)
    L, n = 1.0, 40
    b = beam_model(L, n, sec, theory=theory, planar=True)
    u = np.zeros(b.fe.n_dofs)
    u[0::3] = -b.positions / (sec.E * sec.A)            # N = −1 in every element
    np.testing.assert_allclose(b.axial_forces(u), -1.0)
    KG = b.geometric_stiffness(u).toarray()
    fixed = [b.dof(0, "ux"), b.dof(0, "uy"), b.dof(n, "uy")]
    free = np.setdiff1d(np.arange(b.fe.n_dofs), fixed)
    K = b.fe.K.toarray()[np.ix_(free, free)]
    mu = sla.eigvals(K, -KG[np.ix_(free, free)]).real
    mu = np.min(mu[np.isfinite(mu) & (mu > 0)])
    PE = np.pi**2 * sec.E * sec.Iz / L**2
    ref = PE if theory == "euler-bernoulli" else PE / (1 + PE / (sec.shear_factor * sec.G))
    assert mu == pytest.approx(ref, rel=1e-4)


def test_former_test_helper_matrices():
    """The public 3-D Euler–Bernoulli beam equals the closed-form element matrices of the
    former test helper (stiffness EI/h³[12 6h …], mass ρAh/420[156 22h …], rotary ρI/(30h),
    geometric N/(30h)[36 3h …]) assembled by hand for one element."""
    h, E, G, rho, A, Iy, Iz = 0.5, 3.0, 1.2, 2.0, 0.1, 1e-3, 2e-3
    b = beam_model(h, 1, BeamSection(E=E, G=G, rho=rho, A=A, Iy=Iy, Iz=Iz), rotary=True)
    k = np.array([[12, 6 * h, -12, 6 * h], [6 * h, 4 * h**2, -6 * h, 2 * h**2],
                  [-12, -6 * h, 12, -6 * h], [6 * h, 2 * h**2, -6 * h, 4 * h**2]]) / h**3
    m = np.array([[156, 22 * h, 54, -13 * h], [22 * h, 4 * h**2, 13 * h, -3 * h**2],
                  [54, 13 * h, 156, -22 * h], [-13 * h, -3 * h**2, -22 * h, 4 * h**2]]) * h / 420
    g = np.array([[36, 3 * h, -36, 3 * h], [3 * h, 4 * h**2, -3 * h, -h**2],
                  [-36, -3 * h, 36, -3 * h], [3 * h, -h**2, -3 * h, 4 * h**2]]) / (30 * h)
    xy, xz, flip = [1, 5, 7, 11], [2, 4, 8, 10], np.diag([1.0, -1.0, 1.0, -1.0])
    K, M = b.fe.K.toarray(), b.fe.M.toarray()
    np.testing.assert_allclose(K[np.ix_(xy, xy)], E * Iz * k, rtol=1e-12)
    np.testing.assert_allclose(K[np.ix_(xz, xz)], E * Iy * flip @ k @ flip, rtol=1e-12)
    np.testing.assert_allclose(M[np.ix_(xy, xy)], rho * A * m + rho * Iz * g, rtol=1e-12,
                               atol=1e-15)
    np.testing.assert_allclose(K[np.ix_([3, 9], [3, 9])],
                               G * (Iy + Iz) / h * np.array([[1, -1], [-1, 1]]), rtol=1e-12)
    KG = b.geometric_stiffness_of_forces(np.array([2.5])).toarray()
    np.testing.assert_allclose(KG[np.ix_(xy, xy)], 2.5 * g, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(KG[np.ix_(xz, xz)], 2.5 * flip @ g @ flip, rtol=1e-12,
                               atol=1e-14)
    # rigid-body motions are exact null vectors of K
    x = b.fe.nodes[:, 1]
    rot_z = np.zeros(12)
    rot_z[[1, 7]], rot_z[[5, 11]] = x, 1.0
    np.testing.assert_allclose(K @ rot_z, 0.0, atol=1e-12)


def test_bad_input():
    """Unknown theory, non-increasing positions, bad section values: one ModelError each."""
    with pytest.raises(ModelError, match="unknown beam theory"):
        beam_model(theory="rayleigh")
    with pytest.raises(ModelError, match="increase"):
        beam_model(positions=[0.0, 0.5, 0.5])
    with pytest.raises(ModelError, match=r"section\.E"):
        BeamSection(E=-1.0)


def test_fem_beam_command(tmp_path, capsys):
    """`neweul fem beam` writes the same FE model as beam_model, its node sets and (with
    --stiffening) the 12 K_G,c of the root-clamped beam (= BeamModel.stiffening())."""
    out = tmp_path / "b.npz"
    assert main(["fem", "beam", "--length", "2", "--elements", "8", "--theory", "timoshenko",
                 "--E", "100", "--A", "0.5", "--Iy", "0.01", "--Iz", "0.02", "--stiffening",
                 "-o", str(out)]) == 0
    assert "54 DOFs" in capsys.readouterr().out
    fe = read_fe_model(out)
    ref = beam_model(2.0, 8, BeamSection(E=100.0, G=100 / 2.6, A=0.5, Iy=0.01, Iz=0.02),
                     theory="timoshenko")
    assert abs(fe.K - ref.fe.K).max() < 1e-12 * abs(ref.fe.K).max()
    sets = read_node_sets(out)
    assert sets["root"].tolist() == [1] and sets["tip"].tolist() == [9]
    KG = read_stiffening(out)
    assert sorted(KG) == sorted(ref.stiffening())
    np.testing.assert_allclose(KG["wzz"].toarray(), ref.stiffening(cases=["wzz"])["wzz"]
                               .toarray(), atol=1e-12)
    assert main(["fem", "beam", "--stiffening", "-o", str(tmp_path / "b.json")]) == 1
    assert "npz files only" in capsys.readouterr().err
