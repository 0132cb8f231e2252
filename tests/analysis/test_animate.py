"""Animations of simulated models (analysis/animate.py, analysis/scene.py, simulate --animate)."""

from __future__ import annotations

import shutil
import types
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from neweul_py.analysis import animate, load_generated, simulate
from neweul_py.analysis.animate import animation_frames, check_animation_path
from neweul_py.analysis.scene import (
    build_scene,
    equivalent_dimensions,
)
from neweul_py.cli import main
from neweul_py.errors import NeweulError

ROOT = Path(__file__).resolve().parents[2]
GENERATED = ROOT / "generated"


def _rotation(seed: int) -> np.ndarray:
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


@pytest.mark.parametrize("shape, factor", [("box", 12.0), ("ellipsoid", 20.0)])
def test_equivalent_body_has_the_given_inertia(shape: str, factor: float) -> None:
    """Reference: the inertia of a homogeneous box, m (b² + c²)/12 about its axes, and of an
    ellipsoid with diameters a, b, c, m (b² + c²)/20 (Gross et al., Table 3.2), turned by a
    random rotation; the recovered dimensions and axes reproduce the tensor."""
    m, dims = 2.5, np.array([0.3, 0.1, 0.05])
    sq = dims**2
    principal = m / factor * np.array([sq[1] + sq[2], sq[0] + sq[2], sq[0] + sq[1]])
    Q = _rotation(4)
    inertia = Q @ np.diag(principal) @ Q.T
    got, axes = equivalent_dimensions(m, inertia, shape)
    np.testing.assert_allclose(np.sort(got), np.sort(dims), rtol=1e-12)
    g2 = got**2
    rebuilt = axes @ np.diag(m / factor * np.array([g2[1] + g2[2], g2[0] + g2[2],
                                                     g2[0] + g2[1]])) @ axes.T
    np.testing.assert_allclose(rebuilt, inertia, atol=1e-14)
    np.testing.assert_array_equal(equivalent_dimensions(1.0, np.zeros((3, 3)))[0], 0.0)


def test_pictures_follow_fps_and_the_cap() -> None:
    """Reference: the documented rule min(frames, len(t), 1 + round(span·fps))."""
    t = np.linspace(0.0, 2.0, 201)
    assert animation_frames(t, 10.0, 150).size == 21
    assert animation_frames(t, 1000.0, 150).size == 150
    assert animation_frames(t[:5], 1000.0, 150).size == 5
    idx = animation_frames(t, 10.0, 150)
    assert idx[0] == 0 and idx[-1] == 200 and np.all(np.diff(idx) == 10)
    with pytest.raises(NeweulError, match="fps"):
        animation_frames(t, 0.0, 10)


def test_gif_has_one_picture_per_sample_and_the_bob_moves(tmp_path: Path) -> None:
    """Reference: the GIF read back with PIL (frame count, picture size dpi·size) and the
    scene's bob at the pendulum's closed-form position l (−sin φ, 0, −cos φ)."""
    mod = load_generated(GENERATED / "pendulum.py")
    res = simulate(mod, 2.0, n_out=201)
    path = animate(res, mod, tmp_path / "out" / "pendulum.gif", fps=10, dpi=40, size=4)
    with Image.open(path) as im:
        assert im.n_frames == 21 and im.size == (160, 160)
    capped = animate(res, mod, tmp_path / "capped.gif", fps=50, frames=7, dpi=30, size=3)
    with Image.open(capped) as im:
        assert im.n_frames == 7
    idx = animation_frames(res.t, 10, 150)
    scene = build_scene(mod, res, idx)
    phi, length = res.y[idx, 0], mod.PARAMETERS["l"]
    np.testing.assert_allclose(scene.centers[:, 0],
                               length * np.stack([-np.sin(phi), 0 * phi, -np.cos(phi)], 1),
                               atol=1e-14)
    assert scene.meshes == (None,)  # a point mass is drawn as a dot


def test_rigid_bodies_become_meshes_about_their_centers() -> None:
    """Reference: the chain's rods (inertia m l²/12, m r²/2): their box faces average to the
    center of mass of each rod (a box is symmetric about it) at every picture."""
    mod = load_generated(GENERATED / "chain3_spatial.py")
    res = simulate(mod, 0.5, n_out=11)
    for shape in ("box", "ellipsoid"):
        scene = build_scene(mod, res, np.arange(11), shape=shape)
        for k, mesh in enumerate(scene.meshes):
            assert mesh is not None
            np.testing.assert_allclose(mesh.mean(axis=(1, 2)), scene.centers[:, k], atol=1e-12)


def test_bad_paths_and_modules_are_one_clear_error(tmp_path: Path, monkeypatch) -> None:
    """Reference: the documented errors (suffix, ffmpeg missing → suggest .gif, a module
    without frame_poses → regenerate, a result of another model)."""
    with pytest.raises(NeweulError, match=r"\.avi.*use \.gif or \.mp4"):
        check_animation_path(tmp_path / "x.avi")
    from matplotlib import animation

    monkeypatch.setattr(animation.FFMpegWriter, "isAvailable", classmethod(lambda cls: False))
    with pytest.raises(NeweulError, match=r"ffmpeg.*\.gif instead"):
        check_animation_path(tmp_path / "x.mp4")
    mod = load_generated(GENERATED / "pendulum.py")
    res = simulate(mod, 0.2, n_out=5)
    old = types.SimpleNamespace(**{k: v for k, v in vars(mod).items()
                                   if k not in ("frame_poses", "FRAMES")})
    with pytest.raises(NeweulError, match="regenerate"):
        animate(res, old, tmp_path / "a.gif")
    with pytest.raises(NeweulError, match="its own model"):
        animate(res, GENERATED / "double_pendulum.py", tmp_path / "b.gif")
    assert not list(tmp_path.glob("*.gif"))


def test_cli_animate_writes_the_gif_quietly(tmp_path: Path, capsys) -> None:
    """Reference: the GIF read back (1 + 1 s · 5 fps = 6 pictures) and an empty stderr
    (capsys is not a terminal); a wrong suffix fails before the simulation."""
    out = tmp_path / "p.gif"
    assert main(["simulate", str(GENERATED / "pendulum.py"), "--t-end", "1", "--animate",
                 str(out), "--fps", "5", "--body-shape", "ellipsoid"]) == 0
    captured = capsys.readouterr()
    assert captured.err == "" and f"animation: {out}" in captured.out
    with Image.open(out) as im:
        assert im.n_frames == 6
    assert main(["simulate", str(GENERATED / "pendulum.py"), "--t-end", "1", "--animate",
                 str(tmp_path / "p.webm")]) == 1
    assert "use .gif or .mp4" in capsys.readouterr().err


def test_cli_body_shapes_are_the_scene_shapes() -> None:
    """Reference: analysis.scene.SHAPES (the CLI keeps its own copy to start fast)."""
    from neweul_py.analysis.scene import SHAPES
    from neweul_py.commands.simulate import BODY_SHAPES

    assert BODY_SHAPES == SHAPES


ELASTIC = """
name: hub_beam
coordinates: {a: {initial: 0.3, velocity: 2.0}}
frames:
  hub: {rotation: [[z, a]]}
elastic_bodies:
  beam: {frame: hub, data: beam.SID_FEM, nodes: {tip: 1793}, modes: 2, inertia: sid}
"""


def test_elastic_body_is_its_node_cloud(tmp_path: Path) -> None:
    """Reference: the module's node_positions at the sampled states (the cloud of the SID
    file's nodes) and the picture count of the GIF."""
    from neweul_py.api import generate

    shutil.copy(ROOT / "tests" / "data" / "beam.SID_FEM", tmp_path / "beam.SID_FEM")
    (tmp_path / "m.yaml").write_text(ELASTIC)
    mod = load_generated(generate(tmp_path / "m.yaml", tmp_path / "gen"))
    res = simulate(mod, 0.2, n_out=9)
    scene = build_scene(mod, res, np.arange(9))
    ((name, cloud),) = scene.clouds
    assert name == "beam" and cloud.shape == (9, mod.BODIES[0]["nodes"], 3)
    p = mod.default_parameters()
    for k in (0, 8):
        x = np.concatenate([res.y[k], res.yd[k]])
        np.testing.assert_allclose(cloud[k], mod.node_positions(res.t[k], x, p)[0])
    with Image.open(animate(res, mod, tmp_path / "beam.gif", fps=20, dpi=30, size=3)) as im:
        assert im.n_frames == 5


def test_speed_slows_the_animation_down(tmp_path: Path) -> None:
    """Reference: the rule 1 + round(span·fps/speed) pictures — a 50 ms run at 20 pictures per
    second and 0.01× speed lasts 5 s, 101 pictures (13 at real time with the old fps cap of
    240); the GIF written by the CLI has the count of the rule, and its title says so."""
    t = np.linspace(0.0, 0.05, 501)
    assert animation_frames(t, 20.0, 1000, speed=0.01).size == 101
    assert animation_frames(t, 240.0, 1000).size == 13
    assert animation_frames(t, 20.0, 1000, speed=0.5).size == 3
    with pytest.raises(NeweulError, match="speed"):
        animation_frames(t, 20.0, 10, speed=0.0)
    out = tmp_path / "slow.gif"
    assert main(["simulate", str(GENERATED / "pendulum.py"), "--t-end", "0.05", "--n-out",
                 "201", "--animate", str(out), "--fps", "10", "--speed", "0.05", "-q"]) == 0
    with Image.open(out) as im:
        assert im.n_frames == 11                # 1 + round(0.05 s · 10/s / 0.05)
    for bad in (["--speed", "-1"], ["--scale", "big"], ["--scale", "0"]):
        with pytest.raises(SystemExit) as info:
            main(["simulate", str(GENERATED / "pendulum.py"), "--t-end", "0.05", "--animate",
                  str(out), *bad])
        assert info.value.code == 2


def _hub_beam(tmp_path: Path):
    from neweul_py.api import generate

    shutil.copy(ROOT / "tests" / "data" / "beam.SID_FEM", tmp_path / "beam.SID_FEM")
    (tmp_path / "m.yaml").write_text(ELASTIC.replace(
        "inertia: sid}", "inertia: sid, initial: [0.002, -0.001]}"))
    mod = load_generated(generate(tmp_path / "m.yaml", tmp_path / "gen"))
    return mod, simulate(mod, 0.05, n_out=11)


def test_deformation_scale_magnifies_the_displacement(tmp_path: Path) -> None:
    """Reference: the module's node_positions at the simulated state and with the elastic
    coordinates set to zero (the undeformed body in the same rigid motion): the cloud drawn
    is r(0) + s (r(q) − r(0)); ``auto`` makes the largest drawn displacement a tenth of the
    undeformed cloud's extent; the colours are the true |r(q) − r(0)|."""
    mod, res = _hub_beam(tmp_path)
    p = mod.default_parameters()
    idx = np.arange(res.t.size)
    rest, true = [], []
    for k in idx:
        x = np.concatenate([res.y[k], res.yd[k]])
        true.append(mod.node_positions(res.t[k], x, p)[0])
        x[[mod.COORDINATES.index("beam_q1"), mod.COORDINATES.index("beam_q2")]] = 0.0
        rest.append(mod.node_positions(res.t[k], x, p)[0])
    rest, true = np.array(rest), np.array(true)
    moved = np.linalg.norm(true - rest, axis=-1)
    assert moved.max() > 0
    seven = build_scene(mod, res, idx, scale=7.0)
    np.testing.assert_allclose(seven.clouds[0][1], rest + 7.0 * (true - rest), atol=1e-14)
    np.testing.assert_allclose(seven.displacements[0], moved, atol=1e-15)
    auto = build_scene(mod, res, idx, scale="auto")
    extent = np.ptp(rest[0], axis=0).max()
    drawn = np.linalg.norm(auto.clouds[0][1] - rest, axis=-1)
    np.testing.assert_allclose(drawn.max(), 0.1 * extent, rtol=1e-12)
    assert auto.deformation_scale == pytest.approx(0.1 * extent / moved.max())
    np.testing.assert_allclose(build_scene(mod, res, idx).clouds[0][1], true, atol=1e-15)
    for bad in (0.0, -2.0, "big"):
        with pytest.raises(NeweulError, match="deformation scale"):
            build_scene(mod, res, idx, scale=bad)


def test_nodes_are_coloured_by_displacement_with_a_labelled_bar(tmp_path: Path) -> None:
    """Artist-level: the node scatter's colour values are the true displacements of each
    picture, the colour bar says what and in which unit, the title gives the deformation
    scale and the speed, and every text stays inside the picture."""
    from neweul_py.analysis.animate import draw_scene, scene_title
    from neweul_py.analysis.plot import new_figure

    mod, res = _hub_beam(tmp_path)
    scene = build_scene(mod, res, np.arange(res.t.size), scale="auto")
    fig = new_figure(figsize=(5, 5), dpi=80, layout="constrained")
    ax, update = draw_scene(fig, scene, scene_title("hub_beam", scene, 0.01))
    [cloud] = ax.collections[-1:]
    np.testing.assert_allclose(cloud.get_array(), scene.displacements[0][0])
    update(5)
    np.testing.assert_allclose(cloud.get_array(), scene.displacements[0][5])
    bar = fig.axes[-1]
    assert bar.get_ylabel() == "elastic displacement |d| [m]"
    title = ax.get_title()
    assert title.startswith("hub_beam\ndeformation ×") and "0.01× speed (slow motion)" in title
    assert [ax.get_xlabel(), ax.get_ylabel(), ax.get_zlabel()] == ["x [m]", "y [m]", "z [m]"]
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    for text in (ax.title, bar.yaxis.label):
        box = text.get_window_extent(renderer)
        assert box.x0 >= 0 and box.x1 <= fig.bbox.width and box.y1 <= fig.bbox.height
