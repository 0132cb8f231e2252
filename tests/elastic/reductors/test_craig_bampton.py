"""Craig–Bampton reduction (neweul_py.elastic.reductors.craig_bampton), one- and two-sided.

Independent references: the clamped beam's eigenvalues from the unreduced FE model with the
root DOFs removed (fixed-interface modes are exactly these); Rayleigh–Ritz bounds and
convergence against the unreduced free-free beam; exact static condensation (a static load at
interface DOFs gives the unreduced static solution, Craig & Kurdila 2006 §19.3); the piston-
duct closed-form frequencies (tests/support/fe_builders.py, unsymmetric u–p model); the total
mass ρAL (the interface mass is kept).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
from fe_builders import piston_duct, piston_duct_frequencies

from neweul_py.cli import main
from neweul_py.elastic import write_fe_model
from neweul_py.elastic.bodies.invariants import body_invariants
from neweul_py.elastic.io.body_files import load_reduced_body
from neweul_py.elastic.reductors.craig_bampton import craig_bampton_bases, reduce_craig_bampton
from neweul_py.elastic.reductors.invariants import attach_invariants
from neweul_py.errors import DataError
from neweul_py.fem.beam import BeamSection, beam_model
from neweul_py.fem.solid import solid_box

SEC = BeamSection(E=1e4, G=4e3, A=1.0, Iy=1e-4, Iz=4e-4)


def test_clamped_interface_is_the_clamped_model():
    """Interface = root node, rigid part skipped: the basis is the fixed-interface modes, whose
    eigenvalues are the unreduced clamped beam's; the invariants keep the root node's mass
    (m = ρAL exactly) because the full mass matrix is projected."""
    b = beam_model(1.0, 20, SEC)
    body = reduce_craig_bampton(b.fe, [1], 8, skip_rigid=True, store_bases=True)
    free = np.arange(6, b.fe.n_dofs)
    ref = sla.eigh(b.fe.K.toarray()[np.ix_(free, free)], b.fe.M.toarray()[np.ix_(free, free)],
                   eigvals_only=True, subset_by_index=[0, 7])
    np.testing.assert_allclose(np.sort(sla.eigvals(body.K, body.M).real), ref, rtol=1e-7)
    np.testing.assert_allclose(np.sort(body.eigenvalues), ref, rtol=1e-7)
    inv = body_invariants(attach_invariants(body, b.fe))
    assert inv.m == pytest.approx(SEC.rho * SEC.A * 1.0, rel=1e-12)
    np.testing.assert_allclose(body.V[:6], 0.0)


def test_two_interfaces_static_exact_and_converging():
    """Interface = root and tip nodes of a free beam: with the root coordinates held, a tip
    load gives the unreduced static solution exactly; the reduced free-free eigenvalues are
    6 zeros and upper bounds that converge to the unreduced ones."""
    b = beam_model(1.0, 30, SEC)
    body = reduce_craig_bampton(b.fe, [1, 31], 10, store_bases=True)
    assert body.order == 12 + 10
    f = np.zeros(b.fe.n_dofs)
    f[b.dof(30, "uz")] = 1.0
    free = np.arange(6, b.fe.n_dofs)
    u = np.zeros(b.fe.n_dofs)
    u[free] = np.linalg.solve(b.fe.K.toarray()[np.ix_(free, free)], f[free])
    keep = np.arange(6, body.order)                  # root interface coordinates held
    q = np.zeros(body.order)
    fr = body.V.T @ f
    q[keep] = np.linalg.solve(body.K[np.ix_(keep, keep)], fr[keep])
    np.testing.assert_allclose(body.V @ q, u, atol=1e-12 * abs(u).max())
    red = np.sort(sla.eigvals(body.K, body.M).real)
    full = sla.eigh(b.fe.K.toarray(), b.fe.M.toarray(), eigvals_only=True)
    np.testing.assert_allclose(red[:6], 0.0, atol=1e-8 * full[6])
    assert np.all(red[6:12] >= full[6:12] * (1 - 1e-10))
    err10 = red[6:10] / full[6:10] - 1
    fine = reduce_craig_bampton(b.fe, [1, 31], 30)
    red30 = np.sort(sla.eigvals(fine.K, fine.M).real)
    err30 = red30[6:10] / full[6:10] - 1
    assert np.all(err10 < 3e-3) and np.all((err30 >= -1e-10) & (err30 < err10 / 5))


def test_two_sided_unsymmetric_up_model():
    """Piston-duct u–p model (unsymmetric M), interface = the piston node (ux and p):
    two-sided constraint modes and left fixed-interface vectors give the closed-form coupled
    frequencies (here the coupling lives in the interface block, so W = V on the interior)."""
    fe = piston_duct(200)
    ref = piston_duct_frequencies(3)
    body = reduce_craig_bampton(fe, [1], 12, store_bases=True)
    lam = np.sort(sla.eigvals(body.K, body.M).real)
    f = np.sqrt(lam[lam > 0]) / (2 * np.pi)
    np.testing.assert_allclose(f[:3], ref, rtol=2e-3)
    V, W, _ = craig_bampton_bases(fe, [1], 12, two_sided=False)
    np.testing.assert_array_equal(V, W)


def test_bad_interfaces(tmp_path, capsys):
    """Empty or unknown interface sets, and an interface that leaves the body free (one solid
    node: its rotations stay free) are one DataError naming the file and the item; the CLI
    prints one line."""
    b = beam_model(1.0, 6, SEC)
    with pytest.raises(DataError, match="empty"):
        reduce_craig_bampton(b.fe, [], 4)
    with pytest.raises(DataError, match=r"unknown node ids \[99\]"):
        reduce_craig_bampton(b.fe, [99], 4)
    s = solid_box((1.0, 0.1, 0.1), (3, 1, 1), element="hex8")
    path = tmp_path / "s.npz"
    write_fe_model(s.fe, path, node_sets=s.node_sets)
    assert main(["reduce", str(path), "--method", "craig-bampton", "--interface", "1",
                 "--modes", "4", "-o", str(tmp_path / "x.npz")]) == 1
    err = capsys.readouterr().err
    assert "s.npz" in err and "interface" in err and "does not fix the body" in err
    for spec, msg in (("nope", "no node set 'nope'"), ("500:600", "is empty")):
        assert main(["reduce", str(path), "--method", "craig-bampton", "--interface", spec,
                     "--modes", "4", "-o", str(tmp_path / "x.npz")]) == 1
        assert msg in capsys.readouterr().err
    assert main(["reduce", str(path), "--method", "craig-bampton", "--modes", "4",
                 "-o", str(tmp_path / "x.npz")]) == 1
    assert "needs --interface" in capsys.readouterr().err
    assert main(["reduce", str(path), "--modes", "4", "--interface", "root",
                 "-o", str(tmp_path / "x.npz")]) == 1
    assert "craig-bampton only" in capsys.readouterr().err
    assert not (tmp_path / "x.npz").exists()


def test_cli_craig_bampton_invariants(tmp_path, capsys):
    """`reduce --method craig-bampton --interface root --skip-rigid --invariants` on a solid
    writes a floating-frame body equal to the Python API's (the self-equilibrated root-face
    motions are characteristic constraint modes, unit modal mass)."""
    s = solid_box((1.0, 0.1, 0.05), (4, 2, 1), element="hex20")
    path = tmp_path / "s.npz"
    write_fe_model(s.fe, path, node_sets=s.node_sets)
    out = tmp_path / "b.npz"
    assert main(["reduce", str(path), "--method", "craig-bampton", "--interface", "root",
                 "--modes", "5", "--skip-rigid", "--invariants", "-o", str(out)]) == 0
    assert "craig-bampton" in capsys.readouterr().out

    body = load_reduced_body(out)
    ref = reduce_craig_bampton(s.fe, s.node_sets["root"], 5, skip_rigid=True)
    np.testing.assert_allclose(body.K, ref.K, atol=1e-10 * abs(ref.K).max())
    nc = body.settings["constraint_modes"]
    assert nc == 3 * s.node_sets["root"].size - 6
    np.testing.assert_allclose(np.diag(body.M)[:nc], 1.0, rtol=1e-8)


def test_skip_rigid_is_the_rigidly_held_interface():
    """skip_rigid on a solid root face: the basis satisfies T_bᵀ x_b = 0 (the face's rigid
    motion held, its self-equilibrated deformation free), and its eigenvalues are upper bounds
    converging to those of the unreduced model under exactly these six constraints (null-space
    method); --clamped-interface gives the fully clamped face (higher frequencies)."""
    from scipy.linalg import null_space

    from neweul_py.elastic.reductors.interface import rigid_body_fields

    s = solid_box((1.0, 0.1, 0.05), (4, 2, 1), element="hex20")
    fe, root = s.fe, s.node_sets["root"]
    bb = fe.dofs_of_nodes(root)
    T = rigid_body_fields(fe)
    C = np.zeros((6, fe.n_dofs))
    C[:, bb] = T[bb].T
    Z = null_space(C)
    K, M = fe.K.toarray(), fe.M.toarray()
    full = sla.eigh(Z.T @ K @ Z, Z.T @ M @ Z, eigvals_only=True, subset_by_index=[0, 3])
    errs = []
    for modes in (4, 12):
        V, _, _ = craig_bampton_bases(fe, root, modes, skip_rigid=True)
        np.testing.assert_allclose(C @ V, 0.0, atol=1e-12)
        red = np.sort(sla.eigvals(V.T @ K @ V, V.T @ M @ V).real)[:4]
        assert np.all(red >= full * (1 - 1e-8))          # eigensolver round-off
        errs.append(red / full - 1)
    assert np.all(errs[1] < 0.2 * errs[0] + 1e-9) and np.all(errs[1] < 1e-2)
    Vc, _, lam = craig_bampton_bases(fe, root, 4, constraint_modes=False)
    assert Vc.shape[1] == 4 and np.all(np.sort(lam) > full)


def test_cli_clamped_interface(tmp_path):
    """`--clamped-interface` = reduce_craig_bampton(constraint_modes=False)."""
    s = solid_box((1.0, 0.1, 0.05), (4, 2, 1), element="hex8")
    path = tmp_path / "s.npz"
    write_fe_model(s.fe, path, node_sets=s.node_sets)
    out = tmp_path / "b.npz"
    assert main(["reduce", str(path), "--method", "craig-bampton", "--interface", "root",
                 "--modes", "3", "--clamped-interface", "-o", str(out)]) == 0

    body = load_reduced_body(out)
    ref = reduce_craig_bampton(s.fe, s.node_sets["root"], 3, constraint_modes=False)
    assert body.order == 3 and body.settings["clamped_interface"]
    np.testing.assert_allclose(body.K, ref.K, rtol=1e-10)
    assert main(["reduce", str(path), "--modes", "3", "--clamped-interface",
                 "-o", str(out)]) == 1
