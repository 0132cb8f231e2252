"""The second-order displacement field of stiffened bodies
(neweul_py.elastic.reductors.second_order,
``docs/equations.md`` §2.3).

Independent references: Newton's second law summed over the mass points of a body whose
points sit at ``x_n + Φ_n q + Y_n y(q)``, ``y_j = ½ qᵀ A_j q`` (written out in the test with the
textbook relative-motion acceleration, nothing of the kernel used); a Gram matrix is positive
definite; Southwell's centrifugal coefficient α₁ = 1.1932 of a clamped-free beam (Wright,
Smith, Thresher & Wang, J. Appl. Mech. 49 (1982) 197–202).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sps

from neweul_py.cli import main
from neweul_py.elastic import write_fe_model
from neweul_py.elastic.bodies.invariants import Invariants, QuadraticField, body_invariants
from neweul_py.elastic.fe_model import FEModel
from neweul_py.elastic.io.body_files import load_reduced_body
from neweul_py.elastic.reductors.invariants import compute_invariants
from neweul_py.elastic.reductors.second_order import second_order_field, with_second_order
from neweul_py.errors import DataError
from neweul_py.fem.beam import BeamSection, beam_model
from neweul_py.ffrf import (
    check_flat,
    ffrf_body_mass,
    ffrf_kinetic_energy,
    ffrf_mass_blocks,
    ffrf_prepare,
    ffrf_velocity_terms,
)

SOUTHWELL_1 = 1.1932


def _cloud(n: int = 8, nq: int = 3, ny: int = 2, seed: int = 4):
    """Point masses (lumped FE mass matrix), random modes Φ, second-order shapes Y and
    symmetric A_j."""
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(n, 3))
    m = rng.uniform(0.5, 2.0, n)
    ids = np.arange(1, n + 1)
    fe = FEModel(M=sps.diags(np.repeat(m, 3)).tocsr(), K=sps.identity(3 * n, format="csr"),
                 D=None, nodes=np.column_stack([ids, x]), dof_node=np.repeat(ids, 3),
                 dof_kind=np.tile(np.array(["ux", "uy", "uz"]), n))
    V = rng.normal(size=(3 * n, nq)) * 0.3
    Y = rng.normal(size=(3 * n, ny)) * 0.3
    A = rng.normal(size=(ny, nq, nq))
    A = A + A.transpose(0, 2, 1)
    inv = replace(compute_invariants(fe, V),
                  quadratic=QuadraticField(compute_invariants(fe, np.hstack((V, Y))), A))
    return x, m, V, Y, A, inv, rng


def _point_mass_sum(x, m, V, Y, A, q, qd, qdd, a, alpha, w):
    """Virtual work ``Σ_n δc_nᵀ m_n acc_n`` of the frame translation, rotation and ``δq``,
    with ``c_n = x_n + Φ_n q + Y_n y(q)``, ``∂c_n/∂q = Φ_n + Y_n A q``."""
    n, nq = x.shape[0], V.shape[1]
    phi, psi = V.reshape(n, 3, nq), Y.reshape(n, 3, -1)
    Aq = np.einsum("jkl,l->jk", A, q)
    y, yd = 0.5 * Aq @ q, Aq @ qd
    ydd = Aq @ qdd + np.einsum("jkl,k,l->j", A, qd, qd)
    c = x + phi @ q + psi @ y
    cd = phi @ qd + psi @ yd
    cdd = phi @ qdd + psi @ ydd
    acc = a + np.cross(alpha, c) + np.cross(w, np.cross(w, c)) + 2 * np.cross(w, cd) + cdd
    f = m[:, None] * acc
    dc = phi + np.einsum("naj,jk->nak", psi, Aq)
    return np.concatenate([f.sum(axis=0), np.cross(c, f).sum(axis=0),
                           np.einsum("nak,na->k", dc, f)])


@pytest.mark.parametrize("seed", [0, 1])
def test_body_equations_are_newtons_law_of_the_quadratic_field(seed: int) -> None:
    """``M_b(q) [a; α; q̈] + h_ω`` of the kernel equals the point-mass sum of the quadratic
    field to round-off, at a deformation of 30 % of the body size; ``½ zᵀ M_b z`` is the
    points' kinetic energy."""
    x, m, V, Y, A, inv, rng = _cloud(seed=seed)
    b = ffrf_prepare(inv.to_flat())
    q, qd, qdd = (0.3 * rng.normal(size=V.shape[1]) for _ in range(3))
    a, alpha, w = (rng.normal(size=3) for _ in range(3))
    hr, he = ffrf_velocity_terms(b, q, qd, w, ffrf_mass_blocks(b, q))
    lhs = ffrf_body_mass(b, q) @ np.concatenate([a, alpha, qdd]) + np.concatenate([hr, he])
    ref = _point_mass_sum(x, m, V, Y, A, q, qd, qdd, a, alpha, w)
    assert np.allclose(lhs, ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max())
    n, nq = x.shape[0], V.shape[1]
    Aq = np.einsum("jkl,l->jk", A, q)
    c = x + V.reshape(n, 3, nq) @ q + Y.reshape(n, 3, -1) @ (0.5 * Aq @ q)
    v = rng.normal(size=3)
    vel = v + np.cross(w, c) + V.reshape(n, 3, nq) @ qd + Y.reshape(n, 3, -1) @ (Aq @ qd)
    T = 0.5 * np.sum(m * np.sum(vel**2, axis=1))
    assert ffrf_kinetic_energy(b, v, w, q, qd) == pytest.approx(T, rel=1e-12)


def _stiffened_beam(modes: int, n_el: int = 20):
    """Public Euler–Bernoulli beam, clamped modes of the in-plane (x–y) bending, stiffening of
    all 12 load cases with the root clamped."""
    b = beam_model(1.0, n_el, BeamSection(E=3e4, G=1e4, A=1.0, Iy=1e-4, Iz=1e-4), planar=True)
    fixed = b.node_dofs(0)
    free = np.setdiff1d(np.arange(b.fe.n_dofs), fixed)
    K, M = b.fe.K.toarray()[np.ix_(free, free)], b.fe.M.toarray()[np.ix_(free, free)]
    lam, X = sla.eigh(K, M)
    V = np.zeros((b.fe.n_dofs, free.size))
    V[free] = X
    bending = [k for k in range(free.size)
               if np.abs(V[1::3, k]).max() > 1e3 * np.abs(V[0::3, k]).max()][:modes]
    V = V[:, bending]
    KG, U = b.stiffening(), b.stiffening_responses()
    inv = compute_invariants(b.fe, V, geometric_stiffness=KG)
    return b, V, inv, with_second_order(inv, b.fe, V, KG, U), lam[bending]


def test_mass_matrix_stays_positive_definite() -> None:
    """20 clamped modes of a hinged beam: they nearly contain the rigid rotation, so the hinge
    inertia left over, ``S0 = J_zz − Crv Me⁻¹ Crvᵀ``, is 6e-6 of ``J_zz``. The truncated
    stiffening (``−K_G`` folded into ``J(q)``) turns it negative at a high-mode deformation of
    1e-5 of the length, the defect that made the many-mode pendulum diverge; the second-order
    field's ``M_b(q)`` is a Gram matrix and stays positive definite there."""
    _b, _V, trunc, quad, _lam = _stiffened_beam(20)
    rows = [5, *range(6, 6 + quad.nq)]            # hinge rotation about z + modes
    M0 = ffrf_body_mass(ffrf_prepare(trunc.to_flat()), np.zeros(quad.nq))[np.ix_(rows, rows)]
    S0 = M0[0, 0] - M0[0, 1:] @ np.linalg.solve(M0[1:, 1:], M0[1:, 0])
    lam, E = np.linalg.eigh(trunc.J2[:, :, 2, 2])
    q = np.sqrt(2.0 * S0 / abs(lam[0])) * E[:, 0]       # qᵀ C2_zz q = −2 S0
    for inv, positive in ((quad, True), (trunc, False)):
        M = ffrf_body_mass(ffrf_prepare(inv.to_flat()), q)[np.ix_(rows, rows)]
        low = np.linalg.eigvalsh(0.5 * (M + M.T)).min()
        assert bool(low > 0) == positive


def _spin_stiffness(inv: Invariants, omega: float) -> np.ndarray:
    """``Ke + ∂h_e/∂q`` at ``q = 0`` for a spin ``ω`` about z (complex step of the kernel)."""
    b = ffrf_prepare(inv.to_flat())
    h, nq = 1e-30, inv.nq
    Kw = np.empty((nq, nq))
    for j in range(nq):
        dq = np.zeros(nq, dtype=complex)
        dq[j] = 1j * h
        _hr, he = ffrf_velocity_terms(b, dq, np.zeros(nq), np.array([0.0, 0.0, omega]),
                                      ffrf_mass_blocks(b, dq))
        Kw[:, j] = he.imag / h
    return inv.Ke.m0 + Kw


def _chordwise_alpha(inv: Invariants, lam0: float) -> float:
    """``(ω₁² − ω₀²)/Ω²`` of the first mode at Ω = 0.3 ω₀ (Southwell: α₁ − 1 chordwise)."""
    om = 0.3 * np.sqrt(lam0)
    return (np.sort(sla.eigvals(_spin_stiffness(inv, om), inv.Me.m0).real)[0] - lam0) / om**2


def test_linearization_is_the_first_order_stiffening() -> None:
    """About ``q = 0`` the field reproduces the stiffening of every load case exactly
    (``f_c·Ψ = −Φᵀ K_G,c Φ``): the elastic-row stiffness of a spin about z gives Southwell's
    chordwise ``α₁ − 1`` and equals the first-order terms."""
    _b, _V, trunc, quad, lam = _stiffened_beam(6)
    w = 0.3 * np.sqrt(lam[0])
    assert _chordwise_alpha(quad, lam[0]) == pytest.approx(SOUTHWELL_1 - 1, abs=3e-3)
    K1 = trunc.Ke.m0 + np.einsum("ikc,c->ik", trunc.Oe.m1, [0, 0, w**2, 0, 0, 0])
    K = _spin_stiffness(quad, w)
    np.testing.assert_allclose(K, K1, atol=1e-9 * np.abs(K1).max())


def _scaled_beam(length: float, slender: float = 100.0, modes: int = 3):
    """A planar cantilever of length ``length`` and slenderness L/r (SI units)."""
    r = length / slender
    area = r * r
    b = beam_model(length, 20, BeamSection(E=1e9, G=4e8, rho=1e3, A=area, Iy=area * r * r,
                                           Iz=area * r * r), planar=True)
    free = np.setdiff1d(np.arange(b.fe.n_dofs), b.node_dofs(0))
    lam, X = sla.eigh(b.fe.K.toarray()[np.ix_(free, free)], b.fe.M.toarray()[np.ix_(free, free)])
    V = np.zeros((b.fe.n_dofs, free.size))
    V[free] = X
    bend = [k for k in range(free.size)
            if np.abs(V[1::3, k]).max() > 1e3 * np.abs(V[0::3, k]).max()][:modes]
    V = V[:, bend] * np.sign(V[b.node_dofs(len(b.fe.nodes) - 1)[1], bend])   # tip up
    KG = b.stiffening()
    inv = compute_invariants(b.fe, V, geometric_stiffness=KG)
    return b, V, KG, inv, lam[bend[0]]


@pytest.mark.parametrize(("length", "slender"), [(1e-3, 100.0), (1e3, 100.0), (1.0, 1e4)])
def test_field_does_not_depend_on_units_or_slenderness(length: float, slender: float) -> None:
    """Southwell's chordwise ``α₁ − 1 = 0.1933`` (dimensionless) from the field of a 1 mm, a
    1 km and an L/r = 10⁴ beam in SI units — the load cases' responses differ by many orders
    of magnitude, the dual basis ``Y = U (Fᵀ U)⁺`` is equilibrated (before, a fixed cut on
    the raw energies lost the stiffening of slender or small beams)."""
    b, V, KG, inv, lam0 = _scaled_beam(length, slender)
    quad = with_second_order(inv, b.fe, V, KG, b.stiffening_responses())
    assert _chordwise_alpha(quad, lam0) == pytest.approx(SOUTHWELL_1 - 1, abs=3e-3)


def test_responses_of_another_model_are_refused() -> None:
    """Responses that do not solve ``K u = f`` of this model's inertia loads (scaled, or of a
    beam with twice the stiffness) would scale the stiffening: one DataError naming
    ``UG.<case>``; zero responses likewise."""
    b, V, KG, inv, _lam0 = _scaled_beam(1.0)
    U = b.stiffening_responses()
    with pytest.raises(DataError, match="do not solve K u = f"):
        with_second_order(inv, b.fe, V, KG, {k: 2.0 * u for k, u in U.items()})
    with pytest.raises(DataError, match="zero"):
        with_second_order(inv, b.fe, V, KG, {k: 0.0 * u for k, u in U.items()})


def test_parametric_samples_mix_consistently() -> None:
    """``y_c`` is the displacement conjugate to the unit load ``c`` in every sample, so two
    samples (beams of length 1 and 1.2 with their own responses) mixed half and half give a
    second-order ``J_zz(q)`` between the samples' and within 5 % of the body built at length
    1.1 (the reference); before, each sample's y axes came from its own eigendecomposition
    and the mix could flip the sign."""
    from neweul_py.ffrf.parametric import ffrf_mix, ffrf_stack

    def sample(length: float):
        b, V, KG, inv, _lam0 = _scaled_beam(length)
        return ffrf_prepare(with_second_order(inv, b.fe, V, KG,
                                              b.stiffening_responses()).to_flat())

    b1, b2, mid = sample(1.0), sample(1.2), sample(1.1)
    mixed = ffrf_mix(ffrf_stack([b1, b2]), np.array([0.5, 0.5]))
    q = np.array([0.02, 0.005, 0.0])
    dj = [ffrf_mass_blocks(bb, q)["Mrr"][5, 5] - ffrf_mass_blocks(bb, 0 * q)["Mrr"][5, 5]
          for bb in (b1, b2, mixed, mid)]
    assert min(dj[0], dj[1]) <= dj[2] <= max(dj[0], dj[1])
    assert dj[2] == pytest.approx(dj[3], rel=0.05)


def test_flat_form_round_trip_and_change_of_coordinates() -> None:
    """``to_flat``/``from_flat`` keep the field; after ``q = R q̃`` the body mass matrix is
    ``diag(I, Rᵀ) M_b(R q̃) diag(I, R)`` (the same body in other coordinates)."""
    _x, _m, V, _Y, _A, inv, rng = _cloud(seed=3)
    flat = inv.to_flat()
    assert not check_flat(flat)
    back = Invariants.from_flat(flat)
    assert back.quadratic is not None
    np.testing.assert_array_equal(back.quadratic.A, inv.quadratic.A)
    R = rng.normal(size=(V.shape[1], V.shape[1]))
    qt = 0.2 * rng.normal(size=V.shape[1])
    Mt = ffrf_body_mass(ffrf_prepare(inv.transformed(R).to_flat()), qt)
    T = sla.block_diag(np.eye(6), R)
    M = ffrf_body_mass(ffrf_prepare(flat), R @ qt)
    np.testing.assert_allclose(Mt, T.T @ M @ T, atol=1e-12 * np.abs(M).max())


def test_bad_field_data() -> None:
    """A ``quad.A`` of the wrong shape is named by the schema check; no case with both a
    stiffness and a response is one error naming the item."""
    _x, _m, _V, _Y, _A, inv, _rng = _cloud(seed=2)
    flat = inv.to_flat()
    flat["quad.A"] = np.zeros((5, 3, 3))
    assert any("quad.A" in p for p in check_flat(flat))
    flat = inv.to_flat()
    flat["quad.A"] = flat["quad.A"] + np.triu(np.ones((3, 3)), 1)[None]     # not symmetric
    assert any("quad.A is not symmetric" in p for p in check_flat(flat))
    flat = inv.to_flat()
    flat["quad.Me.m0"] = flat["quad.Me.m0"] * np.nan
    assert any("quad.Me.m0" in p and "NaN" in p for p in check_flat(flat))
    b = beam_model(1.0, 4)
    with pytest.raises(DataError, match="stiffening"):
        second_order_field(b.fe, np.zeros((b.fe.n_dofs, 2)), {"wzz": sps.eye(b.fe.n_dofs)}, {})


def test_fe_file_responses_reach_the_body(tmp_path) -> None:
    """`neweul fem beam --stiffening` stores the static responses ``UG.<case>`` next to the
    ``KG.<case>``; `reduce --stiffening` gives the (Galerkin: symmetric model) body its
    second-order field; a response of the wrong length is one error naming the file and item."""
    fe_path, out = tmp_path / "b.npz", tmp_path / "body.npz"
    assert main(["fem", "beam", "--elements", "8", "--planar", "--stiffening",
                 "-o", str(fe_path)]) == 0
    assert main(["reduce", str(fe_path), "--method", "craig-bampton", "--interface", "root",
                 "--modes", "3", "--skip-rigid", "--stiffening", "-o", str(out)]) == 0
    inv = body_invariants(load_reduced_body(out))
    assert inv.quadratic is not None and inv.quadratic.A.shape[1:] == (3, 3)
    data = dict(np.load(fe_path, allow_pickle=False))
    data["UG.wzz"] = data["UG.wzz"][:-1]
    np.savez(fe_path, **data)
    assert main(["reduce", str(fe_path), "--method", "craig-bampton", "--interface", "root",
                 "--modes", "3", "--skip-rigid", "--stiffening", "-o", str(out)]) == 1
    with pytest.raises(DataError, match="UG"):
        write_fe_model(beam_model(1.0, 2).fe, tmp_path / "x.npz",
                       stiffening_responses={"wzz": np.zeros(3)})


def test_solid_body_field_matches_the_unreduced_stiffened_model() -> None:
    """Hex8 cantilever (SolidModel.stiffening / stiffening_responses, Craig–Bampton body with
    the root clamped) spinning about z: the second-order field's elastic stiffness about
    ``q = 0`` gives the first ω² of the unreduced stress-stiffened rotating-frame FE model
    ``K + Ω² (K_G,ωz² − P_zᵀ M P_z)`` within the modal truncation (2e-3)."""
    import scipy.sparse.linalg as spla

    from neweul_py.elastic.reductors.craig_bampton import reduce_craig_bampton
    from neweul_py.elastic.reductors.stiffening import attach_stiffening
    from neweul_py.fem.solid import SolidMaterial, solid_box

    s = solid_box((1.0, 0.1, 0.05), (10, 2, 1), SolidMaterial(E=1e4, nu=0.3), element="hex8")
    fe, root = s.fe, s.node_sets["root"]
    body = reduce_craig_bampton(fe, root, 8, store_bases=True, constraint_modes=False)
    inv = body_invariants(attach_stiffening(body, fe, s.stiffening(), responses=(
        s.stiffening_responses())))
    assert inv.quadratic is not None
    free = np.setdiff1d(np.arange(fe.n_dofs), fe.dofs_of_nodes(root))
    M = fe.M.tocsc()[free][:, free]
    w0 = np.sqrt(spla.eigsh(fe.K.tocsc()[free][:, free], k=1, M=M, sigma=-1e-6)[0][0])
    Om = 0.7 * w0
    got = np.sort(sla.eigvals(_spin_stiffness(inv, Om), inv.Me.m0).real)[0]
    n = fe.n_dofs
    P = sps.lil_matrix((n, n))
    ux, uy = np.flatnonzero(fe.dof_kind == "ux"), np.flatnonzero(fe.dof_kind == "uy")
    P[uy, ux], P[ux, uy] = 1.0, -1.0
    P = sps.csr_matrix(P)
    A = (fe.K + Om**2 * (s.stiffening(cases=["wzz"])["wzz"] - P.T @ fe.M @ P)).tocsc()
    ref = spla.eigsh(A[free][:, free], k=1, M=M, sigma=-1e-6)[0][0]
    assert got == pytest.approx(ref, rel=2e-3)


def test_parametric_mixing_mixes_the_field() -> None:
    """``ffrf_mix`` of two prepared samples with second-order fields (the generated module's
    parametric bodies): every array of the extended body and ``A`` is the weighted sum, so
    at the weights (1, 0) the mixed body's ``M_b(q)`` is sample 1's (reference: the sample
    itself)."""
    from neweul_py.ffrf.parametric import ffrf_mix, ffrf_stack

    one = ffrf_prepare(_cloud(seed=5)[5].to_flat())
    two = ffrf_prepare(_cloud(seed=6)[5].to_flat())
    mixed = ffrf_mix(ffrf_stack([one, two]), np.array([0.25, 0.75]))
    np.testing.assert_allclose(mixed["A"], 0.25 * one["A"] + 0.75 * two["A"])
    np.testing.assert_allclose(mixed["quad"]["T1"], 0.25 * one["quad"]["T1"]
                               + 0.75 * two["quad"]["T1"])
    q = np.array([0.1, -0.2, 0.05])
    first = ffrf_mix(ffrf_stack([one, two]), np.array([1.0, 0.0]))
    np.testing.assert_allclose(ffrf_body_mass(first, q), ffrf_body_mass(one, q), rtol=1e-14,
                               atol=1e-14)


def test_a_second_order_field_must_fit_its_body():
    """``A`` (ny, nq, nq) and the extended body of ``nq + ny`` coordinates (equations.md
    §2.3): a field of another size is one DataError naming ``quad.A``."""
    *_, A, inv, _ = _cloud()
    q = inv.quadratic
    with pytest.raises(DataError, match="extended body") as exc:
        QuadraticField(q.body, A[:1])
    assert exc.value.item == "quad.A"
    with pytest.raises(DataError, match="finite"):
        QuadraticField(q.body, A[:, :, :2])
    other = _cloud(nq=2)[5].quadratic            # a field of 2 elastic coordinates
    with pytest.raises(DataError, match="second-order field") as exc:
        replace(inv, quadratic=other)
    assert exc.value.item == "quad.A"
