"""Stress stiffening of reduced bodies from any FE model (neweul_py.elastic.reductors.stiffening).

Independent references: Southwell's centrifugal coefficient of a uniform clamped-free beam's
first bending mode with zero hub radius, α₁ = 1.1932 (flapwise ω² = ω₀² + α Ω², chordwise
ω₀² + (α − 1) Ω²; Wright, Smith, Thresher & Wang, J. Appl. Mech. 49 (1982) 197–202); and
the unreduced solid FE model in the rotating frame, ``(K + Ω² (K_G,ωz² − P_zᵀ M P_z)) x =
ω² M x`` (assembled initial-stress matrix of the centrifugal state and spin softening).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sps
import scipy.sparse.linalg as spla

from neweul_py.cli import main
from neweul_py.elastic import read_fe_model, write_fe_model
from neweul_py.elastic.bodies.invariants import body_invariants
from neweul_py.elastic.io.body_files import load_reduced_body
from neweul_py.elastic.reductors.craig_bampton import reduce_craig_bampton
from neweul_py.elastic.reductors.stiffening import (
    attach_stiffening,
    check_stiffening,
    load_stiffening,
    spin_stiffness,
)
from neweul_py.errors import DataError
from neweul_py.fem.beam import BeamSection, beam_model
from neweul_py.fem.solid import SolidMaterial, solid_box

SOUTHWELL_1 = 1.1932


def spin_omega2(inv, Om: float) -> np.ndarray:
    """Sorted ω² of (Ke + Ω² Oe¹_ωz², Me)."""
    return np.sort(sla.eigvals(spin_stiffness(inv, [0.0, 0.0, Om]), inv.Me.m0).real)


@pytest.mark.parametrize("theory", ["euler-bernoulli", "timoshenko"])
def test_southwell_rotating_beam(theory):
    """Public beam (slender: Timoshenko ≈ Euler–Bernoulli), clamped-interface body at the
    root, stiffening from BeamModel.stiffening(): α₁ = 1.1932 flapwise, α₁ − 1 chordwise."""
    b = beam_model(1.0, 20, BeamSection(E=1e4, G=4e3, A=1.0, Iy=1e-4, Iz=4e-4),
                   theory=theory, rotary=False)
    body = reduce_craig_bampton(b.fe, b.node_sets["root"], 8, skip_rigid=True,
                                store_bases=True)
    assert body.order == 8                      # a clamped node leaves no constraint modes
    inv = body_invariants(attach_stiffening(body, b.fe, b.stiffening()))
    lam0 = spin_omega2(inv, 0.0)
    Om = 0.3 * np.sqrt(lam0[0])
    alpha = (spin_omega2(inv, Om)[:2] - lam0[:2]) / Om**2
    rel = 2e-3 if theory == "euler-bernoulli" else 6e-3
    assert alpha[0] == pytest.approx(SOUTHWELL_1, rel=rel)
    assert alpha[1] == pytest.approx(SOUTHWELL_1 - 1, abs=3e-3)


def spin_softening(fe) -> sps.csr_matrix:
    """P_zᵀ M P_z with P_z: u ↦ e_z × u on the nodal translations."""
    n = fe.n_dofs
    P = sps.lil_matrix((n, n))
    ux, uy = np.flatnonzero(fe.dof_kind == "ux"), np.flatnonzero(fe.dof_kind == "uy")
    P[uy, ux] = 1.0                     # (e_z × u)_y = u_x
    P[ux, uy] = -1.0                    # (e_z × u)_x = −u_y
    P = sps.csr_matrix(P)
    return P.T @ fe.M @ P


def test_solid_cantilever_against_unreduced_fe():
    """Hex20 cantilever spun about z through its clamped root face: the first (flapwise) ω²
    of the clamped-interface body (12 fixed-interface modes) from its invariants
    (Ke + Ω² Oe¹) follows the unreduced stress-stiffened FE eigenvalue over Ω = 0 … 2 ω₀, and
    its Southwell coefficient is near the beam's 1.193."""
    s = solid_box((1.0, 0.1, 0.04), (10, 2, 1), SolidMaterial(E=1e4, nu=0.3), element="hex20")
    fe, root = s.fe, s.node_sets["root"]
    KG = s.stiffening(cases=["wzz"])["wzz"]
    body = reduce_craig_bampton(fe, root, 12, store_bases=True, constraint_modes=False)
    V = body.V
    inv = body_invariants(attach_stiffening(body, fe, {"wzz": KG}))
    free = np.setdiff1d(np.arange(fe.n_dofs), fe.dofs_of_nodes(root))
    S = spin_softening(fe)
    M = fe.M.tocsc()[free][:, free]
    w0 = None
    for ratio in (0.0, 0.5, 1.0, 2.0):
        lam_red = spin_omega2(inv, ratio * (w0 or 0.0))[0]
        Om = ratio * (w0 or 0.0)
        A = (fe.K + Om**2 * (KG - S)).tocsc()[free][:, free]
        lam_full = spla.eigsh(A, k=1, M=M, sigma=-1e-3 * abs(lam_red))[0][0]
        if w0 is None:
            w0 = np.sqrt(lam_full)
            lam_ref0 = lam_full
        # the invariants are the exact projection of the rotating-frame FE operator; what
        # is left is modal truncation (2.9e-3 with 6 modes, 8.6e-4 with 12, 1e-4 with 24)
        proj = np.sort(sla.eigvals(V.T @ ((fe.K + Om**2 * (KG - S)) @ V),
                                   V.T @ (fe.M @ V)).real)[0]
        assert lam_red == pytest.approx(proj, rel=1e-8)
        assert lam_red == pytest.approx(lam_full, rel=1e-3)
    alpha = (lam_full - lam_ref0) / Om**2
    assert alpha == pytest.approx(SOUTHWELL_1, rel=0.03)


def test_file_stiffening_and_bad_shapes(tmp_path, capsys):
    """KG.<case> matrices in an FE file reach the invariants through `reduce --stiffening`
    exactly as through the Python API; a matrix of the wrong shape is one error naming the
    file and the item; a file without stiffening data is refused."""
    b = beam_model(1.0, 10)
    KG = b.stiffening()
    path = tmp_path / "b.npz"
    write_fe_model(b.fe, path, node_sets=b.node_sets, stiffening=KG)
    out = tmp_path / "body.npz"
    assert main(["reduce", str(path), "--method", "craig-bampton", "--interface", "root",
                 "--modes", "4", "--skip-rigid", "--stiffening", "-o", str(out)]) == 0
    body = load_reduced_body(out)
    ref = reduce_craig_bampton(b.fe, [1], 4, skip_rigid=True, store_bases=True)
    ref = body_invariants(attach_stiffening(ref, b.fe, KG))
    got = body_invariants(body)
    np.testing.assert_allclose(got.Oe.m1, ref.Oe.m1, atol=1e-12 * abs(ref.Oe.m1).max())
    assert np.abs(got.Ct.m1).max() > 0
    # wrong shape: written by hand (write_fe_model itself refuses it)
    data = dict(np.load(path, allow_pickle=False))
    small = sps.csr_matrix(np.eye(5))
    data.update({"KG.wzz_data": small.data, "KG.wzz_indices": small.indices.astype(np.int64),
                 "KG.wzz_indptr": small.indptr.astype(np.int64),
                 "KG.wzz_shape": np.array([5, 5])})
    bad = tmp_path / "bad.npz"
    np.savez(bad, **data)
    assert main(["reduce", str(bad), "--method", "craig-bampton", "--interface", "root",
                 "--modes", "4", "--skip-rigid", "--stiffening", "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert "bad.npz" in err and "KG.wzz" in err and "(5, 5)" in err
    with pytest.raises(DataError, match=r"KG\.ax"):
        write_fe_model(b.fe, tmp_path / "x.npz", stiffening={"ax": small})
    plain = tmp_path / "plain.npz"
    write_fe_model(b.fe, plain)
    with pytest.raises(DataError, match="no geometric-stiffness"):
        load_stiffening(plain, read_fe_model(plain))
    with pytest.raises(DataError, match="unknown load case"):
        check_stiffening({"spin": small}, 5)


def test_manifest_stiffening_group(tmp_path):
    """A manifest's "stiffening" group names Matrix Market files (models built elsewhere)."""
    import json

    import scipy.io

    b = beam_model(1.0, 4)
    man = tmp_path / "b.json"
    write_fe_model(b.fe, man)
    KG = b.stiffening(cases=["wzz"])["wzz"]
    scipy.io.mmwrite(str(tmp_path / "kg.mtx"), KG)
    meta = json.loads(man.read_text())
    meta["stiffening"] = {"wzz": "kg.mtx"}
    man.write_text(json.dumps(meta))
    got = load_stiffening(man, read_fe_model(man))
    np.testing.assert_allclose(got["wzz"].toarray(), KG.toarray(), atol=1e-14)
    meta["stiffening"] = {"wzz": "missing.mtx"}
    man.write_text(json.dumps(meta))
    with pytest.raises(DataError, match=r"KG\.wzz"):
        load_stiffening(man, read_fe_model(man))


@pytest.mark.slow
def test_solid_stiffening_against_nonlinear_fe():
    """The stress-stiffened rotating-frame model K + Ω²(K_G,ωz² − P_zᵀMP_z) of a Hex20
    cantilever (K_G from SolidModel.stiffening) against the unreduced nonlinear FE model
    (total-Lagrangian St. Venant–Kirchhoff, Newton equilibrium in the rotating frame,
    tests/support/svk_solid_reference.py): first ω² within 1e-3 up to Ω = ω₀ (the difference
    is of order Ω⁴: 4e-4 at ω₀, 2e-3 at 2ω₀), and the clamped-interface body's ω² from its
    invariants within 2e-3 (plus modal truncation)."""
    from svk_solid_reference import spinning_eigenvalues

    s = solid_box((1.0, 0.1, 0.04), (8, 2, 1), SolidMaterial(E=1e4, nu=0.3), element="hex20")
    fe, root = s.fe, s.node_sets["root"]
    KG = s.stiffening(cases=["wzz"])["wzz"]
    body = reduce_craig_bampton(fe, root, 12, store_bases=True, constraint_modes=False)
    inv = body_invariants(attach_stiffening(body, fe, {"wzz": KG}))
    w0 = np.sqrt(spin_omega2(inv, 0.0)[0])
    omegas = (0.5 * w0, w0)
    nonlinear = spinning_eigenvalues(s, omegas)[:, 0]
    free = np.setdiff1d(np.arange(fe.n_dofs), fe.dofs_of_nodes(root))
    S = spin_softening(fe)
    for Om, ref in zip(omegas, nonlinear, strict=True):
        A = (fe.K + Om**2 * (KG - S)).tocsc()[free][:, free]
        lin = spla.eigsh(A, k=1, M=fe.M.tocsc()[free][:, free], sigma=-1e-6)[0][0]
        assert lin == pytest.approx(ref, rel=1e-3)
        assert spin_omega2(inv, Om)[0] == pytest.approx(ref, rel=2e-3)


def test_southwell_planar_beam():
    """2-D beam (ux, uy, rz) spinning about z in its plane: the first in-plane bending mode
    has ω² = ω₀² + (α₁ − 1) Ω² (centrifugal stiffening minus spin softening)."""
    b = beam_model(1.0, 20, BeamSection(E=1e4, A=1.0, Iz=1e-4), planar=True)
    body = reduce_craig_bampton(b.fe, b.node_sets["root"], 4, skip_rigid=True,
                                store_bases=True)
    assert body.order == 4
    inv = body_invariants(attach_stiffening(body, b.fe, b.stiffening()))
    lam0 = spin_omega2(inv, 0.0)
    Om = 0.3 * np.sqrt(lam0[0])
    alpha = (spin_omega2(inv, Om)[0] - lam0[0]) / Om**2
    assert alpha == pytest.approx(SOUTHWELL_1 - 1, abs=3e-3)
