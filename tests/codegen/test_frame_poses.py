"""The poses of the frames in generated modules: ``frame_poses``, ``body_properties``,
``node_positions`` and the constants ``FRAMES``, ``FRAME_PARENTS``, ``BODIES``
(equations/poses.py, codegen/writer.py, codegen/elastic.py)."""

from __future__ import annotations

import shutil
import warnings
from pathlib import Path

import numpy as np
from compiler import needs_c_compiler

from neweul_py.analysis.module import load_generated
from neweul_py.api import generate
from neweul_py.codegen import generate_module
from neweul_py.description import load_description
from neweul_py.equations import newton_euler

ROOT = Path(__file__).resolve().parents[2]
GENERATED = ROOT / "generated"


def _ry(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def test_pendulum_bob_at_its_closed_form_position() -> None:
    """Reference: the mathematical pendulum's bob at l (−sin φ, 0, −cos φ) (rotation about y
    of the point (0, 0, −l)) and the frame's rotation R_y(φ), for several angles."""
    mod = load_generated(GENERATED / "pendulum.py")
    p = mod.default_parameters()
    length = mod.PARAMETERS["l"]
    assert mod.FRAMES == ["rod"] and mod.FRAME_PARENTS == ["ISYS"]
    assert mod.BODIES == [{"name": "bob", "frame": "rod", "kind": "rigid"}]
    mass, com, inertia = mod.body_properties(p)
    np.testing.assert_array_equal(mass, [mod.PARAMETERS["m"]])
    np.testing.assert_array_equal(com, [[0.0, 0.0, -length]])
    assert inertia.shape == (1, 3, 3) and not inertia.any()
    for phi in (-2.0, 0.0, 0.3, 1.7):
        r, S = mod.frame_poses(0.0, np.array([phi, 0.4]), p)
        assert r.shape == (1, 3) and S.shape == (1, 3, 3)
        np.testing.assert_allclose(S[0], _ry(phi), atol=1e-15)
        np.testing.assert_allclose(r[0] + S[0] @ com[0],
                                   length * np.array([-np.sin(phi), 0.0, -np.cos(phi)]),
                                   atol=1e-15)


def test_planar_chain_frames_at_the_sum_of_the_links() -> None:
    """Reference: the planar chain's joint k at Σ_{i<k} l (−sin θ_i, 0, −cos θ_i) with the
    absolute angles θ_i = q_1 + … + q_i (recursive form, 10 links), rotations R_y(θ_k)."""
    mod = load_generated(GENERATED / "chain10_planar.py")
    p = mod.default_parameters()
    length = mod.PARAMETERS["l"]
    q = np.linspace(0.4, -0.3, 10)
    r, S = mod.frame_poses(0.0, np.concatenate([q, np.zeros(10)]), p)
    theta = np.cumsum(q)
    links = length * np.stack([-np.sin(theta), 0 * theta, -np.cos(theta)], axis=1)
    joints = np.vstack([np.zeros(3), np.cumsum(links, axis=0)[:-1]])
    np.testing.assert_allclose(r, joints, atol=1e-14)
    np.testing.assert_allclose(S, np.stack([_ry(a) for a in theta]), atol=1e-14)
    assert mod.FRAME_PARENTS == ["ISYS", *mod.FRAMES[:-1]]


def test_closed_and_recursive_forms_agree_and_the_tip_is_the_output(tmp_path: Path) -> None:
    """Reference: the two derivations of the spatial chain (closed form: one substituted
    expression per entry; recursive: the workspace's intermediates) and the module's own
    kinematic outputs (the tip, a point of the last link); S stays orthonormal."""
    system = load_description(ROOT / "examples" / "chain3_spatial.yaml")
    mods = [load_generated(generate_module(newton_euler(system, form=f), "h",
                                           tmp_path / f / "chain3_spatial.py"))
            for f in ("closed", "recursive")]
    rng = np.random.default_rng(3)
    p = mods[0].default_parameters()
    for _ in range(5):
        x = rng.uniform(-2.0, 2.0, 12)
        (r1, S1), (r2, S2) = (m.frame_poses(0.0, x, p) for m in mods)
        np.testing.assert_allclose(r1, r2, atol=1e-14)
        np.testing.assert_allclose(S1, S2, atol=1e-14)
        np.testing.assert_allclose(np.einsum("fij,fkj->fik", S1, S1),
                                   np.broadcast_to(np.eye(3), S1.shape), atol=1e-14)
        tip = r1[-1] + S1[-1] @ np.array([0.0, 0.0, -mods[0].PARAMETERS["l"]])
        np.testing.assert_allclose(tip, mods[0].outputs(0.0, x, p), atol=1e-14)


ELASTIC = """
name: hub_beam
parameters: {J: 1.0}
coordinates: {a: {initial: 0.3}}
frames:
  hub: {rotation: [[z, a]]}
bodies:
  hub_mass: {frame: hub, mass: 1, inertia: {diag: [J, J, J]}}
elastic_bodies:
  beam: {frame: hub, data: beam.SID_FEM, nodes: {tip: 1793}, modes: 3, inertia: sid}
outputs:
  tip_x: {position: beam.tip, in: ISYS, component: x}
  tip_y: {position: beam.tip, in: ISYS, component: y}
  tip_z: {position: beam.tip, in: ISYS, component: z}
"""


def test_elastic_node_cloud_moves_with_the_modes(tmp_path: Path) -> None:
    """Reference: the SID file's node positions and mode shapes (x_P + Φ_P q, rotated by the
    hub angle R_z(a)), and the symbolic node frame ``beam.tip`` (the kinematic outputs and
    the pose of the node frame)."""
    from neweul_py.elastic.io.reader import read_elastic_data

    shutil.copy(ROOT / "tests" / "data" / "beam.SID_FEM", tmp_path / "beam.SID_FEM")
    (tmp_path / "m.yaml").write_text(ELASTIC)
    mod = load_generated(generate(tmp_path / "m.yaml", tmp_path / "gen"))
    assert mod.FRAMES == ["hub", "beam.tip"]
    assert mod.BODIES[1] == {"name": "beam", "frame": "hub", "kind": "elastic",
                             "nodes": mod.BODIES[1]["nodes"]}
    x = np.array(mod.INITIAL_STATE)
    q = np.array([0.01, -0.02, 0.005])
    x[1:4] = q
    p = mod.default_parameters()
    (cloud,) = mod.node_positions(0.0, x, p)
    flat = read_elastic_data(tmp_path / "beam.SID_FEM", 3)
    a = x[0]
    Rz = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0, 0, 1.0]])
    expected = (flat["nodes.origin.m0"][:, :, 0] + flat["nodes.phi"] @ q) @ Rz.T
    np.testing.assert_allclose(cloud, expected, atol=1e-14)
    tip = list(flat["nodes.id"]).index(1793)
    np.testing.assert_allclose(cloud[tip], mod.outputs(0.0, x, p), atol=1e-14)
    r, _S = mod.frame_poses(0.0, x, p)
    np.testing.assert_allclose(r[1], cloud[tip], atol=1e-14)


@needs_c_compiler
def test_compiled_module_has_the_poses_of_its_twin(tmp_path: Path) -> None:
    """Reference: the NumPy twin (the compiled wrapper delegates the functions its library
    does not implement: energy and the poses)."""
    from neweul_py.codegen.c_module import write_c_module

    eq = newton_euler(load_description(ROOT / "examples" / "double_pendulum.yaml"))
    npath = generate_module(eq, "h", tmp_path / "double_pendulum.py")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cmod = load_generated(write_c_module(eq, npath))
    twin = load_generated(npath)
    x = np.array([0.3, -0.2, 0.1, 0.0])
    p = twin.default_parameters()
    assert cmod.FRAMES == twin.FRAMES and cmod.BODIES == twin.BODIES
    for got, want in zip(cmod.frame_poses(0.0, x, p), twin.frame_poses(0.0, x, p),
                         strict=True):
        np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(cmod.energy(0.0, x, p), twin.energy(0.0, x, p))
