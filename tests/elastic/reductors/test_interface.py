"""Averaged interface node frames (RBE3-like) and node sets (neweul_py.elastic.reductors.interface).

Independent references: a rigid-body motion field is reproduced exactly by the weighted
least-squares rigid fit (any weights; beam nodes, which are collinear, through their rotation
DOFs); Timoshenko beam theory for the tip face of a Hex20 cantilever under a tip shear load
(rotation ``PL²/(2EI)``, deflection ``PL³/(3EI) + PL/(κGA)``); virtual work (the load side
is ``A W``).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse.linalg as spla

from neweul_py.cli import main
from neweul_py.elastic import write_fe_model
from neweul_py.elastic.bodies.invariants import body_invariants
from neweul_py.elastic.io.body_files import load_reduced_body
from neweul_py.elastic.reductors.craig_bampton import reduce_craig_bampton
from neweul_py.elastic.reductors.interface import (
    add_interface_frames,
    averaged_node_frame,
    averaging_operator,
    parse_node_set,
    rigid_body_fields,
)
from neweul_py.elastic.reductors.invariants import attach_invariants
from neweul_py.errors import DataError
from neweul_py.fem.beam import beam_model
from neweul_py.fem.solid import SolidMaterial, solid_box


@pytest.mark.parametrize("which", ["solid-tip", "beam-all", "beam-tip", "beam-2d"])
def test_rigid_motion_reproduced(which):
    """For V = rigid fields × random coefficients, Ψ = the rotation and Φ = the translation
    of the weighted centroid, exactly."""
    if which == "solid-tip":
        m, ids = solid_box((1, 0.1, 0.05), (4, 2, 1), origin=(0.2, -0.05, 0.1)), "tip"
    else:
        m = beam_model(1.0, 5, origin=(0.1, 0.2, 0.3), planar=which == "beam-2d")
        ids = "tip" if which == "beam-tip" else "all"
    rng = np.random.default_rng(1)
    c = rng.normal(size=(6, 3))
    if which == "beam-2d":
        c[[2, 3, 4]] = 0.0                       # in-plane motions only
    V = rigid_body_fields(m.fe) @ c
    nodes = m.node_sets[ids]
    nf = averaged_node_frame(m.fe, V, None, 999, nodes, rng.uniform(0.5, 2, nodes.size))
    xc = nf.origin.m0[:, 0]
    np.testing.assert_allclose(nf.psi.m0, c[3:], atol=1e-13)
    np.testing.assert_allclose(nf.phi.m0, c[:3] + np.cross(c[3:].T, xc).T, atol=1e-13)


def test_cantilever_tip_face_against_beam_theory():
    """Hex20 cantilever with a tip shear load: the averaged tip-face frame rotates by
    PL²/(2EI) and moves by PL³/(3EI) + PL/(κGA) within 3 % (clamped root face)."""
    size, mat = (1.0, 0.1, 0.05), SolidMaterial(E=1e4, nu=0.3)
    s = solid_box(size, (10, 2, 1), mat, element="hex20")
    fe = s.fe
    free = np.setdiff1d(np.arange(fe.n_dofs), fe.dofs_of_nodes(s.node_sets["root"]))
    tip = fe.dofs_of_nodes(s.node_sets["tip"])
    tz = tip[fe.dof_kind[tip] == "uz"]
    P = 1e-3
    f = np.zeros(fe.n_dofs)
    f[tz] = P / tz.size
    u = np.zeros(fe.n_dofs)
    u[free] = spla.spsolve(fe.K.tocsc()[free][:, free], f[free])
    A, xc = averaging_operator(fe, s.node_sets["tip"])
    avg = A @ u
    I, G = size[1] * size[2] ** 3 / 12, mat.E / (2 * (1 + mat.nu))
    L = size[0]
    assert xc[0] == pytest.approx(L)
    assert avg[2] == pytest.approx(P * L**3 / (3 * mat.E * I)
                                   + P * L / (5 / 6 * G * size[1] * size[2]), rel=0.03)
    assert -avg[4] == pytest.approx(P * L**2 / (2 * mat.E * I), rel=0.03)   # θy = −w'
    assert abs(avg[3]) < 1e-10 * abs(avg[4]) and abs(avg[5]) < 1e-10 * abs(avg[4])


def test_body_frames_two_sided_and_cli(tmp_path, capsys):
    """add_interface_frames: the new frame's load side is A W (virtual work), its motion
    A V; the CLI option adds the same frame; a taken id or an empty set is an error."""
    s = solid_box((1.0, 0.1, 0.05), (4, 2, 1), element="hex20")
    body = reduce_craig_bampton(s.fe, s.node_sets["root"], 4, skip_rigid=True,
                                store_bases=True)
    W = body.W + 1e-3 * np.random.default_rng(0).normal(size=body.W.shape)
    body = attach_invariants(body.with_(W=W), s.fe)
    got = body_invariants(add_interface_frames(body, s.fe, {1000: s.node_sets["tip"]}))
    nf = got.node(1000)
    A, _ = averaging_operator(s.fe, s.node_sets["tip"])
    np.testing.assert_allclose(np.vstack([nf.phi.m0, nf.psi.m0]), A @ body.V, atol=1e-12)
    np.testing.assert_allclose(np.vstack([nf.load_phi, nf.load_psi]), A @ W, atol=1e-12)
    with pytest.raises(DataError, match="already a node"):
        add_interface_frames(body, s.fe, {1: [2, 3, 4]})
    with pytest.raises(DataError, match="empty"):
        parse_node_set("7000:7001", s.fe)
    path = tmp_path / "s.npz"
    write_fe_model(s.fe, path, node_sets=s.node_sets)
    out = tmp_path / "b.npz"
    assert main(["reduce", str(path), "--method", "craig-bampton", "--interface", "root",
                 "--modes", "4", "--skip-rigid", "--interface-frame", "1000=tip",
                 "-o", str(out)]) == 0
    inv = body_invariants(load_reduced_body(out))
    assert 1000 in [n.id for n in inv.nodes]
    assert main(["reduce", str(path), "--method", "craig-bampton", "--interface", "root",
                 "--modes", "4", "--skip-rigid", "--interface-frame", "5=tip",
                 "-o", str(out)]) == 1
    assert "interface_frames.5" in capsys.readouterr().err


def test_averaged_frame_in_a_description(tmp_path):
    """End to end: a point mass on the averaged frame of the beam's tip node alone gives the
    same generated mass matrix and forces as the mass on the tip node's own frame (the
    averaged frame of one beam node is that node's frame)."""
    from neweul_py.analysis import load_generated
    from neweul_py.api import generate
    from neweul_py.elastic import save_reduced_body

    b = beam_model(0.5, 6)
    body = reduce_craig_bampton(b.fe, b.node_sets["root"], 3, skip_rigid=True,
                                store_bases=True)
    body = add_interface_frames(attach_invariants(body, b.fe, nodes=[7]), b.fe, {100: [7]})
    save_reduced_body(body.with_(V=None, W=None, full_dof_kind=None), tmp_path / "b.npz")
    text = """
name: {name}
parameters: {{g: 9.81}}
gravity: [0, -g, 0]
coordinates: {{a: {{}}}}
frames:
  hub: {{rotation: [[z, a]]}}
elastic_bodies:
  beam: {{frame: hub, data: b.npz, nodes: {{tip: {node}}}}}
bodies:
  m: {{frame: beam.tip, mass: 0.3}}
"""
    mods = []
    for name, node in (("own", 7), ("avg", 100)):
        (tmp_path / f"{name}.yaml").write_text(text.format(name=name, node=node))
        mods.append(load_generated(generate(tmp_path / f"{name}.yaml", tmp_path / "gen")))
    own, avg = mods
    assert list(own.COORDINATES) == list(avg.COORDINATES)
    p = own.default_parameters()
    rng = np.random.default_rng(2)
    n = len(own.COORDINATES)
    y, yd = 0.1 * rng.normal(size=n), rng.normal(size=n)
    np.testing.assert_allclose(avg.mass_matrix(0.0, y, p), own.mass_matrix(0.0, y, p),
                               rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(avg.force_vector(0.0, y, yd, p),
                               own.force_vector(0.0, y, yd, p), rtol=1e-12, atol=1e-13)


def test_node_sets_in_manifest_and_npz(tmp_path):
    """Named node sets round-trip through both FE file forms and resolve in NODESET specs
    (names, ids, ranges mixed); a set naming unknown ids is refused before writing."""
    from neweul_py.elastic.io.fe_files import read_node_sets

    b = beam_model(1.0, 6)
    for name in ("b.json", "b.npz"):
        path = tmp_path / name
        write_fe_model(b.fe, path, node_sets={"ends": [1, 7], "mid": [4]})
        sets = read_node_sets(path)
        assert sets["ends"].tolist() == [1, 7]
        assert parse_node_set("ends,mid,2:3", b.fe, sets).tolist() == [1, 2, 3, 4, 7]
    with pytest.raises(DataError, match=r"node_sets\.bad"):
        write_fe_model(b.fe, tmp_path / "c.npz", node_sets={"bad": [1, 99]})
    assert not (tmp_path / "c.npz").exists()
