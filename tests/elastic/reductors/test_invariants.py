"""Floating-frame invariants (equations.md §2) from a 3-D Euler–Bernoulli beam FE model.

Independent references: analytic rod mass properties (m = ρAL, md = m c, J = rod + section,
parallel-axis theorem); Euler–Bernoulli cantilever eigenvalues βL = 1.875104, 4.694091,
7.854757; particle sums Σ m_n (…) for a lumped-mass beam; Southwell's centrifugal-stiffening
coefficient of the first bending mode of a uniform cantilever with zero hub radius,
α₁ = 1.1932 (flapwise ω² = ω₀² + α Ω², chordwise ω² = ω₀² + (α − 1) Ω²; Wright, Smith,
Thresher & Wang, J. Appl. Mech. 49 (1982) 197–202), and the unreduced FE model with the
assembled centrifugal geometric stiffness.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
from beam_fe import Beam, beam

from neweul_py.elastic.bodies.invariants import LOAD_CASES, Invariants, omega_products, skew
from neweul_py.elastic.io.body_files import save_reduced_body
from neweul_py.elastic.io.sid import invariants_from_sid, invariants_to_sid, read_sid, write_sid
from neweul_py.elastic.reductors.invariants import (
    compute_invariants,
    inertia_loads,
    stress_stiffening,
)
from neweul_py.errors import DataError

OFFSET = (0.3, 0.2, -0.1)
BETA_L = np.array([1.875104069, 4.694091133, 7.854757438])
SOUTHWELL_1 = 1.1932


def rigid_modes(b: Beam) -> np.ndarray:
    """[T_t | T_r] built from the node table: translations, rotations about the origin."""
    xyz = b.fe.nodes[:, 1:4]
    V = np.zeros((b.n, 6))
    for node, x in enumerate(xyz):
        for a in range(3):
            V[6 * node + a, a] = 1.0
            V[6 * node + a, 3:] = np.cross(np.eye(3), x)[:, a]      # (e_b × x)_a
            V[6 * node + 3 + a, 3 + a] = 1.0
    return V


def random_basis(b: Beam, nq: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).normal(size=(b.n, nq))


def stiffened(b: Beam, cases=("wzz",)) -> dict:
    """Geometric stiffness of the unit load cases, root clamped (Wallrapp's procedure)."""
    return stress_stiffening(b.fe, lambda u: b.geometric_stiffness(b.axial_forces(u)),
                             support=np.arange(6), cases=cases)


def test_stress_stiffening_procedure():
    """stress_stiffening = the hand-made procedure; the ωz² axial force of the root-clamped
    beam is N(x) = ρAΩ²(L² − x²)/2 at the element midpoints; bad supports are reported."""
    b = beam(20)
    loads = inertia_loads(b.fe)
    u = b.clamped_static(loads["wzz"])
    N = b.axial_forces(u)
    xm = (np.arange(20) + 0.5) / 20
    np.testing.assert_allclose(N, 0.5 * (1 - xm**2), atol=2e-3)
    KG = stiffened(b, ("wzz", "ax"))
    np.testing.assert_allclose(KG["wzz"].toarray(), b.geometric_stiffness(N).toarray(),
                               atol=1e-10)
    with pytest.raises(DataError, match="singular"):
        stress_stiffening(b.fe, lambda u: None, support=[0, 1, 2], cases=["ax"])
    with pytest.raises(DataError, match="unknown load cases"):
        stress_stiffening(b.fe, lambda u: None, support=np.arange(6), cases=["spin"])


# ------------------------------------------------------------------- mass properties
@pytest.mark.parametrize("rotary", [False, True])
def test_mass_first_moment_inertia(rotary):
    """m = ρAL, md = m c, J = J_c + m(|c|² I − c cᵀ) with J_c of a slender rod plus its
    section (torsion inertia ρ(Iy+Iz)L always; bending rotary inertia ρIL when modelled)."""
    b = beam(20, offset=OFFSET, rotary=rotary)
    inv = compute_invariants(b.fe, random_basis(b, 3, 0))
    m = b.rho * b.A * b.length
    c = np.array(OFFSET) + np.array([b.length / 2, 0, 0])
    assert inv.m == pytest.approx(m, rel=1e-13)
    np.testing.assert_allclose(inv.md.m0[:, 0], m * c, rtol=1e-13)
    sec = b.rho * b.length * np.array([b.Iy + b.Iz, b.Iy * rotary, b.Iz * rotary])
    Jc = np.diag(sec + np.array([0, m * b.length**2 / 12, m * b.length**2 / 12]))
    J = Jc + m * (c @ c * np.eye(3) - np.outer(c, c))
    np.testing.assert_allclose(inv.J.m0, J, rtol=1e-12, atol=1e-14)


def test_planar_model():
    """A planar beam (ux, uy, rz only): m, the in-plane md and J_zz are still exact."""
    from neweul_py.elastic.fe_model import FEModel

    b = beam(10, offset=(0.3, 0.2, 0.0))
    keep = np.nonzero(np.isin(b.fe.dof_kind, ["ux", "uy", "rz"]))[0]
    fe = FEModel(M=b.fe.M[keep][:, keep], K=b.fe.K[keep][:, keep], D=None,
                 nodes=b.fe.nodes, dof_node=b.fe.dof_node[keep], dof_kind=b.fe.dof_kind[keep])
    inv = compute_invariants(fe, np.random.default_rng(12).normal(size=(keep.size, 3)))
    assert inv.m == pytest.approx(1.0, rel=1e-13)
    np.testing.assert_allclose(inv.md.m0[:, 0], [0.8, 0.2, 0.0], atol=1e-13)
    assert inv.J.m0[2, 2] == pytest.approx(1 / 12 + 0.8**2 + 0.2**2, rel=1e-12)


@pytest.mark.parametrize("lumped", [False, True])
def test_rigid_body_modes(lumped):
    """With V = W = rigid-body modes, Ct, Cr, Me, md¹ are the analytic rigid mass blocks:
    Ct = [mI; m̃d], Cr = [m̃dᵀ; J], Me = [[mI, m̃dᵀ], [m̃d, J]] = the rigid-body mass matrix;
    for the translations J¹_a = −(ẽ_a m̃d + m̃d ẽ_a), Gr_a = −2 m̃d ẽ_a, Oe⁰ = e_aᵀ B_c md."""
    b = beam(10, offset=OFFSET, rotary=True, lumped=lumped)
    V = rigid_modes(b)
    inv = compute_invariants(b.fe, V)
    m, md, J = inv.m, inv.md.m0[:, 0], inv.J.m0
    mdt = skew(md)
    rigid = np.block([[m * np.eye(3), mdt.T], [mdt, J]])
    np.testing.assert_allclose(inv.Me.m0, rigid, atol=1e-12)
    np.testing.assert_allclose(inv.Ct.m0, np.vstack([m * np.eye(3), mdt]), atol=1e-12)
    np.testing.assert_allclose(inv.Cr.m0, np.vstack([mdt.T, J]), atol=1e-12)
    np.testing.assert_allclose(inv.md.m1[:, :, 0], np.hstack([m * np.eye(3), mdt.T]),
                               atol=1e-12)
    np.testing.assert_allclose(inv.mass_matrix()[:6, :6], rigid, atol=1e-12)
    E = skew(np.eye(3))
    for a in range(3):
        np.testing.assert_allclose(inv.J.m1[:, a, :], -(E[a] @ mdt + mdt @ E[a]), atol=1e-12)
        np.testing.assert_allclose(inv.blocks("Gr")[a], -2 * mdt @ E[a], atol=1e-12)
        w = np.random.default_rng(a).normal(size=3)
        np.testing.assert_allclose(inv.Oe.m0[a] @ omega_products(w),
                                   np.cross(w, np.cross(w, md))[a], atol=1e-12)


# ---------------------------------------------------------------- particle reference
def test_lumped_mass_equals_particle_sums():
    """A lumped-mass beam without rotary inertia is a set of particles: every invariant must
    equal its particle sum (Cr¹, Ge, Gr, J¹, Oe⁰, Oe¹ written out per node)."""
    b = beam(6, offset=OFFSET, lumped=True)
    nq = 4
    V = random_basis(b, nq, 1)
    inv = compute_invariants(b.fe, V)
    mn = b.fe.M.diagonal()[0::6]
    x = b.fe.nodes[:, 1:4]
    phi = np.stack([V[a::6] for a in range(3)], axis=-1)       # (node, mode, 3)
    E = np.eye(3)
    Cr1 = np.zeros((nq, nq, 3))
    for i in range(nq):
        for k in range(nq):
            for c in range(3):
                Cr1[i, k, c] = np.sum(mn * np.einsum("na,na->n", phi[:, i],
                                                     np.cross(E[c], phi[:, k])))
    np.testing.assert_allclose(inv.Cr.m1, Cr1, atol=1e-12)
    np.testing.assert_allclose(inv.blocks("Ge"), 2 * Cr1.transpose(1, 0, 2), atol=1e-12)
    xt = skew(x)
    for k in range(nq):
        pt = skew(phi[:, k])
        Gr = -2 * np.einsum("n,nab,nbc->ac", mn, xt, pt)
        J1 = -np.einsum("n,nab,nbc->ac", mn, xt, pt) - np.einsum("n,nab,nbc->ac", mn, pt, xt)
        np.testing.assert_allclose(inv.blocks("Gr")[k], Gr, atol=1e-12)
        np.testing.assert_allclose(inv.J.m1[:, k, :], J1, atol=1e-12)
    rng = np.random.default_rng(2)
    for _ in range(3):
        w, q = rng.normal(size=3), rng.normal(size=nq)
        u = np.einsum("nka,k->na", phi, q)
        cen0 = np.cross(w, np.cross(w, x))
        cen1 = np.cross(w, np.cross(w, u))
        ref0 = np.einsum("n,nia,na->i", mn, phi, cen0)
        ref1 = np.einsum("n,nia,na->i", mn, phi, cen1)
        wq = omega_products(w)
        np.testing.assert_allclose(inv.Oe.m0 @ wq, ref0, atol=1e-12)
        np.testing.assert_allclose(np.einsum("ikc,k,c->i", inv.Oe.m1, q, wq), ref1, atol=1e-11)


@pytest.mark.parametrize("two_sided", [False, True])
def test_equations_match_particle_dynamics(two_sided):
    """mass_matrix · [a, α, q̈] + velocity_terms equals the particle sums
    Σ m [ä_p; p × ä_p; Φᵀ ä_p], ä_p = a + α×p + ω×(ω×p) + 2ω×u̇ + ü, p = x + u: exactly at
    q = 0, and in the first derivative with respect to q (central differences, q̇ = 0; the
    products q·q̇ are second order and not part of §2). Two-sided: the elastic rows are
    Σ m w_iᵀ ä_p with the left basis, the rigid rows are unchanged."""
    b = beam(6, offset=OFFSET, lumped=True)
    nq = 3
    V = random_basis(b, nq, 3)
    W = random_basis(b, nq, 13) if two_sided else V
    inv = compute_invariants(b.fe, V, W if two_sided else None)
    psi = np.stack([W[a::6] for a in range(3)], axis=-1)
    mn = b.fe.M.diagonal()[0::6]
    x = b.fe.nodes[:, 1:4]
    phi = np.stack([V[a::6] for a in range(3)], axis=-1)          # (node, mode, 3)
    rng = np.random.default_rng(4)
    a, al, w = rng.normal(size=(3, 3))
    qd, qdd = rng.normal(size=(2, nq))

    def particles(q, qd):
        u, ud, udd = (np.einsum("nka,k->na", phi, v) for v in (q, qd, qdd))
        p = x + u
        acc = a + np.cross(al, p) + np.cross(w, np.cross(w, p)) + 2 * np.cross(w, ud) + udd
        return np.concatenate([mn @ acc, np.einsum("n,na->a", mn, np.cross(p, acc)),
                               np.einsum("n,nka,na->k", mn, psi, acc)])

    def model(q, qd):
        return inv.mass_matrix(q) @ np.concatenate([a, al, qdd]) + \
            inv.velocity_terms(q, qd, w)

    zero = np.zeros(nq)
    ref = particles(zero, qd)
    np.testing.assert_allclose(model(zero, qd), ref, atol=1e-12 * np.abs(ref).max())
    for j in range(nq):
        h = np.eye(nq)[j]
        d_ref = (particles(h, zero) - particles(-h, zero)) / 2
        d_mod = (model(h, zero) - model(-h, zero)) / 2
        np.testing.assert_allclose(d_mod, d_ref, atol=1e-12 * np.abs(d_ref).max())


# ------------------------------------------------------------------------ structure
@pytest.mark.parametrize("lumped", [False, True])
def test_one_sided_structure(lumped):
    """One-sided invariants keep the structure of the continuum: Ge_k … skew per ω component,
    Cr¹ antisymmetric in (row, mode), Oe¹ symmetric, J¹ = sym Gr, Oe⁰ = −½ J¹ (the SID
    identities the beam file obeys too), md¹ = Ct⁰ᵀ, Crv = Cr."""
    b = beam(8, offset=OFFSET, rotary=True, lumped=lumped)
    inv = compute_invariants(b.fe, random_basis(b, 5, 5))
    Cr1 = inv.Cr.m1
    np.testing.assert_allclose(Cr1, -Cr1.transpose(1, 0, 2), atol=1e-12)
    np.testing.assert_allclose(inv.Oe.m1, inv.Oe.m1.transpose(1, 0, 2), atol=1e-11)
    Gr = inv.blocks("Gr")
    np.testing.assert_allclose(inv.J.m1.transpose(1, 0, 2), 0.5 * (Gr + Gr.transpose(0, 2, 1)),
                               atol=1e-12)
    J1 = inv.J.m1
    pred = -np.stack([J1[0, :, 0] / 2, J1[1, :, 1] / 2, J1[2, :, 2] / 2,
                      J1[0, :, 1], J1[1, :, 2], J1[0, :, 2]], axis=1)
    np.testing.assert_allclose(inv.Oe.m0, pred, atol=1e-11)
    np.testing.assert_allclose(inv.md.m1[:, :, 0], inv.Ct.m0.T, atol=1e-12)
    assert inv.Crv.equals(inv.Cr)


# ------------------------------------------------------------------- eigenfrequencies
def test_clamped_beam_frequencies():
    """Ke, Me of the clamped modes give ω = (βL)² √(EI/(ρA L⁴)) for flap (EIy) and chord
    (EIz) bending (Euler–Bernoulli, 40 elements; the 6th mode is torsion)."""
    b = beam(40)
    lam, V = b.clamped_modes(5)
    inv = compute_invariants(b.fe, V)
    w = np.sqrt(np.sort(sla.eigvals(inv.Ke.m0, inv.Me.m0).real))
    np.testing.assert_allclose(w**2, lam, rtol=1e-6)         # eigensolver accuracy
    s = b.rho * b.A * b.length**4
    flap = BETA_L**2 * np.sqrt(b.E * b.Iy / s)
    chord = BETA_L**2 * np.sqrt(b.E * b.Iz / s)
    ref = np.sort(np.concatenate([flap, chord]))[:5]
    np.testing.assert_allclose(w, ref, rtol=2e-5)


def test_two_sided_same_physics():
    """W = V R with a random nonsingular R: the elastic rows are Rᵀ × the one-sided rows,
    everything describing displacement is unchanged, and the reduced eigenvalues (with and
    without centrifugal stiffening) are those of the one-sided model."""
    b = beam(20)
    _lam, V = b.clamped_modes(6)
    R = np.random.default_rng(6).normal(size=(6, 6)) + 3 * np.eye(6)
    KG = stiffened(b)
    one = compute_invariants(b.fe, V, geometric_stiffness=KG, nodes=[21])
    two = compute_invariants(b.fe, V, V @ R, geometric_stiffness=KG, nodes=[21])
    assert two.two_sided and not one.two_sided
    for name in ("Ct", "Cr", "Me", "Oe", "Ke", "De", "ksigma"):
        assert two.__getattribute__(name).equals(
            one.__getattribute__(name).transformed(left=R.T), rtol=1e-10, atol=1e-9), name
    np.testing.assert_allclose(two.Ge.m0, R.T @ one.Ge.m0, atol=1e-9)
    for name in ("md", "J", "Gr", "Crv"):
        assert two.__getattribute__(name).equals(one.__getattribute__(name), atol=1e-12), name
    n1, n2 = one.node(21), two.node(21)
    assert n2.phi.equals(n1.phi) and n2.origin.equals(n1.origin) and n2.AP.equals(n1.AP)
    np.testing.assert_allclose(n2.load_phi, n1.phi.m0 @ R, atol=1e-12)
    T = np.eye(12)
    T[6:, 6:] = R.T
    q = np.linspace(-1, 1, 6) * 1e-3
    np.testing.assert_allclose(two.mass_matrix(q), T @ one.mass_matrix(q), atol=1e-10)
    for Om in (0.0, 2.0):
        w1 = np.sort(sla.eigvals(one.Ke.m0 + Om**2 * one.Oe.m1_matrix(2), one.Me.m0).real)
        w2 = np.sort(sla.eigvals(two.Ke.m0 + Om**2 * two.Oe.m1_matrix(2), two.Me.m0).real)
        np.testing.assert_allclose(w2, w1, rtol=1e-9)


_ALL = ("md", "J", "Ct", "Cr", "Crv", "Me", "Gr", "Ge", "Oe", "ksigma", "Ke", "De")


def _assert_same(a: Invariants, b: Invariants, tol: float = 1e-10) -> None:
    assert a.two_sided == b.two_sided
    for name in _ALL:
        t, u = getattr(a, name), getattr(b, name)
        scale = max(np.abs(t.m0).max(), 0.0 if t.m1 is None else np.abs(t.m1).max(), 1.0)
        assert t.equals(u, atol=tol * scale), name
    for n1, n2 in zip(a.nodes, b.nodes, strict=True):
        for key in ("origin", "phi", "psi", "AP"):
            assert getattr(n1, key).equals(getattr(n2, key), atol=tol), (n1.id, key)
        np.testing.assert_allclose(n1.load_phi, n2.load_phi, atol=tol)
        np.testing.assert_allclose(n1.load_psi, n2.load_psi, atol=tol)


@pytest.mark.parametrize("two_sided", [False, True])
def test_change_of_basis(two_sided):
    """Invariants of (V R, W S) equal those of (V, W) transformed with right = R,
    left = Sᵀ — every index convention (mode vs row, V vs W) at once; R also rectangular."""
    b = beam(8, offset=OFFSET, rotary=True)
    _, V = b.clamped_modes(5)
    rng = np.random.default_rng(11)
    W = V + 0.3 * rng.normal(size=V.shape) if two_sided else None
    KG = {c: (lambda A: A + A.T)(rng.normal(size=(b.n, b.n))) for c in ("ax", "alphay", "wxz")}
    base = compute_invariants(b.fe, V, W, nodes=[2, 9], geometric_stiffness=KG)
    for R in (rng.normal(size=(5, 5)), rng.normal(size=(5, 3))):
        S = rng.normal(size=R.shape)
        direct = compute_invariants(b.fe, V @ R, None if W is None else W @ S, nodes=[2, 9],
                                    geometric_stiffness=KG)
        _assert_same(direct, base.transformed(R, None if W is None else S.T))
    as_two = base.transformed(left=np.eye(5)) if not two_sided else base
    assert as_two.two_sided


# -------------------------------------------------------------- geometric stiffening
def _reduced_omega(inv: Invariants, Om: float) -> np.ndarray:
    """Frequencies of Me q̈ + (Ke + Ω² Oe¹[:, :, ωz²]) q = 0 (spin about z at the root)."""
    w2 = np.sort(sla.eigvals(inv.Ke.m0 + Om**2 * inv.Oe.m1_matrix(2), inv.Me.m0).real)
    return np.sqrt(w2)


def test_southwell_centrifugal_stiffening():
    """Cantilever along x spinning about z through its root: flapwise (z) first mode
    ω² = ω₀² + α Ω², chordwise (y) ω² = ω₀² + (α − 1) Ω², α = 1.1932; without the
    stiffening terms the flapwise frequency does not rise at all."""
    b = beam(20)
    lam, V = b.clamped_modes(8)                 # flap1, chord1, flap2, chord2, …
    inv = compute_invariants(b.fe, V, geometric_stiffness=stiffened(b))
    bare = compute_invariants(b.fe, V)
    Om = 0.3 * np.sqrt(lam[0])
    w = _reduced_omega(inv, Om)
    alpha = (w[:2] ** 2 - lam[:2]) / Om**2
    assert alpha[0] == pytest.approx(SOUTHWELL_1, rel=2e-3)
    assert alpha[1] == pytest.approx(SOUTHWELL_1 - 1, abs=2e-3)
    w0 = _reduced_omega(bare, Om)
    assert (w0[0] ** 2 - lam[0]) / Om**2 == pytest.approx(0.0, abs=1e-6)
    # chordwise: pure spin softening −Ω²; the consistent-mass cross-product evaluation is
    # O(h²) off (4e-4 with 20 elements), see the invariants module docstring
    assert (w0[1] ** 2 - lam[1]) / Om**2 == pytest.approx(-1.0, abs=1e-3)


def test_stiffening_matches_unreduced_fe():
    """Reduced Ke + Ω²·Oe¹ equals the unreduced clamped FE model K + Ω²(K_G − P_zᵀ M P_z)
    (assembled centrifugal geometric stiffness and spin softening), also at large Ω."""
    b = beam(20)
    _lam, V = b.clamped_modes(8)
    KG = stiffened(b)["wzz"]
    inv = compute_invariants(b.fe, V, geometric_stiffness={"wzz": KG})
    P = b.cross_operator(2).toarray()
    M = b.fe.M.toarray()
    fr = b.free
    for Om in (1.0, 3.0, 10.0):
        A = (b.fe.K.toarray() + Om**2 * (KG.toarray() - P.T @ M @ P))[np.ix_(fr, fr)]
        full = np.sqrt(sla.eigh(A, M[np.ix_(fr, fr)], eigvals_only=True)[:3])
        np.testing.assert_allclose(_reduced_omega(inv, Om)[:3], full, rtol=2e-3)
        if Om == 1.0:
            np.testing.assert_allclose(_reduced_omega(inv, Om)[:3], full, rtol=1e-6)


def test_greenhill_self_weight_buckling():
    """A column along x standing on a frame that accelerates with a_x (equivalent to gravity
    g = a_x) buckles when det(Ke + a_x Ct¹_x) = 0, at a_x = 7.837 EI/(ρA L³) (Greenhill 1881;
    Timoshenko & Gere, Theory of Elastic Stability, ch. 2) — flapwise (EIy) and 4× that
    chordwise (EIz = 4 EIy)."""
    b = beam(20)
    _, V = b.clamped_modes(8)
    inv = compute_invariants(b.fe, V, geometric_stiffness=stiffened(b, ("ax",)))
    ev = sla.eigvals(inv.Ke.m0, -inv.Ct.m1_matrix(0)).real
    ev = np.sort(ev[ev > 0])
    crit = 7.8373 * b.E * b.Iy / (b.rho * b.A * b.length**3)
    assert ev[0] == pytest.approx(crit, rel=2e-3)
    assert ev[1] == pytest.approx(4 * crit, rel=2e-3)


def test_stiffening_slots():
    """Each load case lands in its slot: a → Ct¹, α → Cr¹, ω_q → Oe¹ (as Wᵀ K_G V)."""
    b = beam(6)
    _lam, V = b.clamped_modes(4)
    rng = np.random.default_rng(7)
    KG = {}
    for c in LOAD_CASES:
        A = rng.normal(size=(b.n, b.n))
        KG[c] = A + A.T
    inv = compute_invariants(b.fe, V, geometric_stiffness=KG)
    bare = compute_invariants(b.fe, V)
    for a in range(3):
        np.testing.assert_allclose(inv.Ct.m1[:, :, a], V.T @ KG[LOAD_CASES[a]] @ V)
        np.testing.assert_allclose(inv.Cr.m1[:, :, a] - bare.Cr.m1[:, :, a],
                                   V.T @ KG[LOAD_CASES[3 + a]] @ V, atol=1e-10)
    for c in range(6):
        np.testing.assert_allclose(inv.Oe.m1[:, :, c] - bare.Oe.m1[:, :, c],
                                   V.T @ KG[LOAD_CASES[6 + c]] @ V, atol=1e-10)
    assert inv.Crv.equals(bare.Crv) and inv.Ge.equals(bare.Ge)


@pytest.mark.parametrize("lumped", [False, True])
def test_inertia_loads(lumped):
    """Unit load cases: −M T_t sums to −m e_a; the ωz² load of a beam along x is the
    outward centrifugal force Σ f_x = m c_x; the modal loads Wᵀ f are exactly minus the
    order-0 elastic-row terms Ct⁰, Cr⁰, Oe⁰ (the prestress and the reduced model see the
    same load)."""
    b = beam(10, offset=OFFSET, lumped=lumped, rotary=True)
    f = inertia_loads(b.fe)
    W = random_basis(b, 3, 14)
    inv = compute_invariants(b.fe, random_basis(b, 3, 15), W)
    for k, name in enumerate(LOAD_CASES):
        t = (inv.Ct.m0, inv.Cr.m0, inv.Oe.m0)[0 if k < 3 else 1 if k < 6 else 2]
        np.testing.assert_allclose(W.T @ f[name], -t[:, k if k < 3 else k - 3 if k < 6
                                                     else k - 6], atol=1e-12)
    m = b.rho * b.A * b.length
    assert set(f) == set(LOAD_CASES)
    assert f["ax"][0::6].sum() == pytest.approx(-m)
    assert f["wzz"][0::6].sum() == pytest.approx(m * (OFFSET[0] + b.length / 2))
    assert f["wzz"][1::6].sum() == pytest.approx(m * OFFSET[1])
    assert f["wzz"][2::6].sum() == pytest.approx(0.0, abs=1e-14)


# ---------------------------------------------------------------------- node frames
def test_node_frames():
    """origin(q) = x_P + Φ_P q, Ψ from the rotational DOFs, AP(q) = (I + Σ ψ̃_k q_k) AP⁰."""
    b = beam(6, offset=OFFSET)
    V = random_basis(b, 3, 8)
    rot = sla.expm(skew([0.1, -0.2, 0.3]))
    inv = compute_invariants(b.fe, V, nodes=[4, 1], node_orientations={4: rot})
    n = inv.node(4)
    np.testing.assert_array_equal(n.origin.m0[:, 0], b.fe.nodes[3, 1:4])
    np.testing.assert_array_equal(n.phi.m0, V[18:21])
    np.testing.assert_array_equal(n.psi.m0, V[21:24])
    q = np.array([0.01, -0.02, 0.03])
    np.testing.assert_allclose(n.origin.evaluate(q)[:, 0], b.fe.nodes[3, 1:4] + V[18:21] @ q)
    np.testing.assert_allclose(n.AP.evaluate(q), (np.eye(3) + skew(V[21:24] @ q)) @ rot)
    assert [m.id for m in inv.nodes] == [4, 1]
    assert np.array_equal(inv.node(1).AP.m0, np.eye(3))


# -------------------------------------------------------------- storage and SID
def test_flat_roundtrip(tmp_path):
    """to_flat → npz (no pickles) → from_flat is exact, for two-sided data with nodes."""
    b = beam(8)
    _lam, V = b.clamped_modes(4)
    W = V @ (np.eye(4) + 0.1 * np.random.default_rng(9).normal(size=(4, 4)))
    inv = compute_invariants(b.fe, V, W, nodes=[9, 3], geometric_stiffness=stiffened(b),
                             names=["a", "b", "c", "d"])
    flat = inv.to_flat()
    assert all(a.dtype != object for a in flat.values())
    np.savez(tmp_path / "inv.npz", **flat)
    with np.load(tmp_path / "inv.npz", allow_pickle=False) as data:
        back = Invariants.from_flat(dict(data))
    assert back.names == inv.names and back.two_sided and back.m == inv.m
    for name in ("md", "J", "Ct", "Cr", "Crv", "Me", "Gr", "Ge", "Oe", "ksigma", "Ke", "De"):
        assert getattr(back, name).equals(getattr(inv, name)), name
    for n1, n2 in zip(inv.nodes, back.nodes, strict=True):
        assert n1.id == n2.id
        for key in ("origin", "phi", "psi", "AP"):
            assert getattr(n1, key).equals(getattr(n2, key))
        np.testing.assert_array_equal(n1.load_phi, n2.load_phi)
    flat["format"] = np.array("other")
    with pytest.raises(DataError, match="format"):
        Invariants.from_flat(flat)


def test_sid_beam_as_invariants(tmp_path):
    """The SID beam file loads into the same Invariants object: Ge is detected in its
    per-component layout and brought to the per-mode convention (Ge_k = 2 Cr¹_k); eig of
    (Ke, Me) gives the named frequencies; to_sid → write → read → from_sid is exact."""
    from test_sid import BEAM

    body = read_sid(BEAM)
    inv = invariants_from_sid(body)
    np.testing.assert_allclose(inv.blocks("Ge"), 2 * inv.Cr.m1.transpose(1, 0, 2), atol=1e-10)
    f = np.sqrt(np.sort(sla.eigvals(inv.Ke.m0, inv.Me.m0).real)) / (2 * np.pi)
    np.testing.assert_allclose(f, body.frequencies_from_names(), atol=5e-4)
    assert inv.names == body.ielastq and inv.m == body.mass
    assert len(inv.nodes) == 6 and inv.node(1861).phi.equals(body.node(1861).phi)
    write_sid(inv, tmp_path / "b.SID_FEM")
    again = invariants_from_sid(read_sid(tmp_path / "b.SID_FEM"))
    for name in ("md", "J", "Ct", "Cr", "Me", "Gr", "Ge", "Oe", "ksigma", "Ke", "De"):
        assert getattr(again, name).equals(getattr(inv, name)), name
    np.testing.assert_array_equal(inv.Gr.m0, body["Gr"].m0)         # Gr: per mode in file
    forced = invariants_from_sid(body, ge_layout="mode")
    np.testing.assert_array_equal(forced.Ge.m0, body["Ge"].m0)


@pytest.mark.parametrize("layout", ["mode", "component"])
def test_sid_gyroscopic_layouts(layout, tmp_path):
    """Gr/Ge written in either column layout are recognized on reading ("auto")."""
    b = beam(8, offset=OFFSET)
    _, V = b.clamped_modes(4)
    inv = compute_invariants(b.fe, V)
    sid = invariants_to_sid(inv, layout=layout)
    blocks = inv.blocks("Gr")
    col = (lambda k, j: 3 * k + j) if layout == "mode" else (lambda k, j: j * 4 + k)
    assert sid["Gr"].m0[2, col(3, 1)] == blocks[3, 2, 1]
    write_sid(sid, tmp_path / "g.SID_FEM")
    back = invariants_from_sid(read_sid(tmp_path / "g.SID_FEM"))
    for name in ("Gr", "Ge"):
        assert back.__getattribute__(name).equals(inv.__getattribute__(name), rtol=1e-10,
                                                  atol=1e-12), name


def test_computed_invariants_through_sid(tmp_path):
    """compute_invariants → write_sid → read_sid → from_sid reproduces the invariants to
    the printed precision (12 digits)."""
    b = beam(10, offset=OFFSET, rotary=True)
    _lam, V = b.clamped_modes(5)
    inv = compute_invariants(b.fe, V, nodes=[1, 6, 11], geometric_stiffness=stiffened(b))
    write_sid(inv, tmp_path / "c.SID_FEM")
    back = invariants_from_sid(read_sid(tmp_path / "c.SID_FEM"))
    for name in ("md", "J", "Ct", "Cr", "Me", "Gr", "Ge", "Oe", "ksigma", "Ke", "De"):
        t, u = getattr(inv, name), getattr(back, name)
        scale = max(np.abs(t.m0).max(), 1.0 if t.m1 is None else np.abs(t.m1).max(), 1e-300)
        assert t.equals(u, rtol=1e-10, atol=1e-11 * scale), name
    assert back.node(6).psi.equals(inv.node(6).psi, rtol=1e-10, atol=1e-12)
    assert back.Crv.equals(inv.Crv, rtol=1e-10, atol=1e-11)     # stiffening split off


def test_one_sided_mass_matrix_symmetric():
    """Without stiffening a one-sided body's mass matrix is symmetric for any q; with it the
    elastic rows change, and the rigid rows only by the reaction of the acceleration
    prestress, ``½ s̃(q)`` with ``s_a = qᵀ Ct¹_a q`` in the rotational rows (equations.md
    §2.1; the kinematic md(q), Crv(q) stay)."""
    b = beam(8, offset=OFFSET, rotary=True)
    _, V = b.clamped_modes(4)
    q = np.array([0.01, -0.02, 0.005, 0.03])
    plain = compute_invariants(b.fe, V).mass_matrix(q)
    np.testing.assert_allclose(plain, plain.T, atol=1e-12)
    stiff = compute_invariants(b.fe, V, geometric_stiffness=stiffened(b, ("ax", "alphaz")))
    diff = stiff.mass_matrix(q) - plain
    s = np.einsum("i,ika,k->a", q, stiff.Ct.m1, q)
    reaction = 0.5 * np.array([[0, -s[2], s[1]], [s[2], 0, -s[0]], [-s[1], s[0], 0]])
    np.testing.assert_allclose(diff[3:6, :3], reaction, rtol=1e-12, atol=1e-18)
    diff[3:6, :3] = 0.0
    assert np.abs(diff[:6]).max() < 1e-14 and np.abs(diff[6:, :6]).max() > 1e-6


# ------------------------------------------------------------------------- bad input
def test_bad_input():
    b = beam(4)
    V = random_basis(b, 2, 10)
    with pytest.raises(DataError, match="unknown node ids"):
        compute_invariants(b.fe, V, nodes=[99])
    with pytest.raises(DataError, match="shape"):
        compute_invariants(b.fe, V[:-1])
    with pytest.raises(DataError, match="W has shape"):
        compute_invariants(b.fe, V, V[:, :1])
    with pytest.raises(DataError, match="unknown load case"):
        compute_invariants(b.fe, V, geometric_stiffness={"spin": np.eye(b.n)})
    with pytest.raises(DataError, match="not finite"):
        compute_invariants(b.fe, V * np.nan)
    two = compute_invariants(b.fe, V, 2 * V)
    with pytest.raises(DataError, match="two-sided"):
        invariants_to_sid(two)


def test_reduced_body_slot(tmp_path):
    """attach_invariants fills a ReducedBody's invariants slot from the reductor's full
    bases; it survives the reduced-body file and matches the body's own M, K (two-sided
    modal reduction of the beam and of the u–p piston-duct model)."""
    from fe_builders import piston_duct

    from neweul_py.elastic import load_reduced_body, reduce_modal
    from neweul_py.elastic.bodies.invariants import body_invariants
    from neweul_py.elastic.reductors.invariants import attach_invariants

    b = beam(10)
    for fe, kw in ((b.fe, {"keep_nodes": [11]}), (piston_duct(40), {})):
        rb = reduce_modal(fe, modes=8 if fe is b.fe else 4, store_bases=True, **kw)
        assert body_invariants(rb) is None
        rb = attach_invariants(rb, fe)
        save_reduced_body(rb, tmp_path / "body.npz")
        inv = body_invariants(load_reduced_body(tmp_path / "body.npz"))
        np.testing.assert_allclose(inv.Me.m0, rb.M, atol=1e-12 * np.abs(rb.M).max())
        np.testing.assert_allclose(inv.Ke.m0, rb.K, atol=1e-12 * np.abs(rb.K).max())
        assert [n.id for n in inv.nodes] == [int(i) for i in rb.nodes[:, 0]]
        assert inv.two_sided == rb.two_sided
    with pytest.raises(DataError, match="store_bases"):
        attach_invariants(reduce_modal(b.fe, modes=8), b.fe)


def test_bad_invariants_files_name_the_file(tmp_path):
    """Errors of the invariants' own checks, read through read_elastic_data from a bare
    invariants .npz or a reduced body's slot, name the file (and the block)."""
    from fe_builders import piston_duct

    from neweul_py.elastic import reduce_modal
    from neweul_py.elastic.io.reader import read_elastic_data
    from neweul_py.elastic.reductors.invariants import attach_invariants

    b = beam(8)
    _lam, V = b.clamped_modes(4)
    flat = compute_invariants(b.fe, V, nodes=[9, 3]).to_flat()
    cases = [({"Ke.m0": np.eye(3)}, "Ke", "size 3×3, expected 4×4"),
             ({"nodes.id": np.array([9, 3, 5])}, "invariants", "inconsistent arrays"),
             ({"m": np.array("heavy")}, "invariants", "inconsistent arrays")]
    for change, item, text in cases:
        path = tmp_path / "inv.npz"
        np.savez(path, **{**flat, **change})
        with pytest.raises(DataError, match=text) as exc:
            read_elastic_data(path)
        assert exc.value.file == str(path) and exc.value.item == item
    fe = piston_duct(20)
    rb = attach_invariants(reduce_modal(fe, modes=4, store_bases=True), fe)
    save_reduced_body(rb.with_(invariants={**rb.invariants, "Ke.m0": np.eye(3)}),
                      tmp_path / "body.npz")
    with pytest.raises(DataError, match="size 3×3") as exc:
        read_elastic_data(tmp_path / "body.npz")
    assert exc.value.file == str(tmp_path / "body.npz") and exc.value.item == "Ke"
    (tmp_path / "text.npz").write_text("not an archive")
    with pytest.raises(DataError, match=r"not a valid \.npz") as exc:
        read_elastic_data(tmp_path / "text.npz")
    assert exc.value.file == str(tmp_path / "text.npz")
