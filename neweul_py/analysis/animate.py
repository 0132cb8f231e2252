"""Animations of simulated models: matplotlib 3-D, written to GIF (Pillow) or MP4 (ffmpeg).

Each picture shows, at one time of a :class:`~neweul_py.analysis.SimulationResult`:

- every frame of ``FRAMES`` as a triad (x red, y green, z blue) at its origin;
- a grey line from each frame's parent origin to its origin, and from each rigid body's frame
  origin to its center of mass;
- each rigid body as the homogeneous box or ellipsoid of its mass and inertia
  (:mod:`.scene`), point masses as dots;
- each elastic body as the cloud of the nodes of its data, moved by its elastic coordinates,
  its deformation magnified by a deformation scale (``scale``, ``"auto"``: the largest
  displacement a tenth of the body, :func:`.scene.deformation_scale`) and each node coloured
  by its true displacement (colour bar in m).

The poses come from the module's ``frame_poses`` (docs/generated-module-protocol.md). The
result is subsampled to at most ``frames`` pictures shown at ``fps`` pictures per second;
``speed`` simulated seconds pass per second of the animation (1: real time; 0.01: a 50 ms
run lasts 5 s, slow motion), so there are ``1 + span·fps/speed`` pictures unless capped.

Examples
--------
>>> res = simulate("generated/double_pendulum.py", 5.0)              # doctest: +SKIP
>>> animate(res, "generated/double_pendulum.py", "double_pendulum.gif")  # doctest: +SKIP
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..atomic import atomic_write
from ..errors import NeweulError
from ..progress import report
from .module import as_model
from .plot import new_figure
from .results import SimulationResult
from .scene import SHAPES, Scene, build_scene

__all__ = ["ANIMATION_SUFFIXES", "animate", "animation_frames", "check_animation_path",
           "draw_scene", "scene_title"]

#: File types of animations: GIF (Pillow, comes with matplotlib) and MP4 (needs ffmpeg).
ANIMATION_SUFFIXES = (".gif", ".mp4")
_AXIS_COLORS = ("tab:red", "tab:green", "tab:blue")


def check_animation_path(path: str | os.PathLike[str]) -> Path:
    """``path`` if an animation can be written there: a ``.gif``, or an ``.mp4`` when ffmpeg
    is installed. Commands call this before they compute anything.

    Raises
    ------
    NeweulError
        Another suffix, no matplotlib, or ``.mp4`` without ffmpeg (suggesting ``.gif``).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in ANIMATION_SUFFIXES:
        raise NeweulError(f"{path}: cannot write an animation as "
                          f"{suffix or '(no suffix)'}; use .gif or .mp4")
    try:
        from matplotlib import animation
    except ImportError:
        raise NeweulError("animations need matplotlib: pip install 'neweul-py[plot]'") from None
    if suffix == ".mp4" and not animation.FFMpegWriter.isAvailable():
        raise NeweulError(f"{path}: writing .mp4 needs ffmpeg, which is not installed (not on "
                          "PATH); write a .gif instead")
    return path


def animation_frames(t: np.ndarray, fps: float, frames: int, speed: float = 1.0
                     ) -> np.ndarray:
    """Rows of ``t`` to show: ``min(frames, len(t), 1 + round((t_end − t_start)·fps/speed))``
    pictures, equally spaced in the rows (at least one); ``speed`` is simulated seconds per
    second of the animation."""
    t = np.asarray(t, dtype=float)
    if not fps > 0 or frames < 1:
        raise NeweulError(f"fps must be positive and frames at least 1 (got {fps}, {frames})")
    if not (np.isfinite(speed) and speed > 0):
        raise NeweulError(f"speed must be a positive number, got {speed}")
    if t.size == 0:
        raise NeweulError("the result holds no time steps to animate")
    span = float(t[-1] - t[0])
    count = int(min(frames, t.size, 1 + round(span * fps / speed)))
    return np.unique(np.round(np.linspace(0, t.size - 1, max(count, 1))).astype(int))


def scene_title(name: str, scene: Scene, speed: float) -> str:
    """The picture's title: the model on the first line; the deformation scale (elastic
    bodies) and the speed on the second."""
    parts = []
    if scene.clouds and scene.deformation_scale != 1.0:
        parts.append(f"deformation ×{scene.deformation_scale:.3g}")
    if speed != 1.0:
        parts.append(f"{speed:g}× speed" + (" (slow motion)" if speed < 1 else ""))
    return "\n".join(p for p in (name, ", ".join(parts)) if p)


def draw_scene(fig: Any, scene: Scene, title: str) -> tuple[Any, Callable[[int], None]]:
    """Draw the first picture of ``scene`` into ``fig``; returns its 3-D axes and the function
    that moves every artist to picture ``k``."""
    # (Path3DCollection has no public setter of its 3-D offsets: ``_offsets3d`` is what
    # matplotlib's own scatter animations assign)
    from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

    ax = fig.add_subplot(projection="3d")
    half = 0.55 * scene.size
    for setter, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), scene.center, strict=True):
        setter(c - half, c + half)
    ax.set_box_aspect((1, 1, 1))
    from matplotlib.ticker import MaxNLocator

    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):  # few tick labels: text is most of a picture
        axis.set_major_locator(MaxNLocator(4))
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.set_title(title, fontsize="medium")
    triad = 0.08 * scene.size
    where = {name: i for i, name in enumerate(scene.frames)}
    parents = np.array([where.get(p, -1) for p in scene.parents], dtype=int)
    frames_of_bodies = np.array(scene.body_frames, dtype=int)
    none = np.zeros((1, 2, 3))  # a collection needs a segment; a point draws nothing

    def link_segments(k: int) -> np.ndarray:
        r = scene.origins[k]
        r_all = np.vstack([r, np.zeros((1, 3))])
        segments = [np.stack([r_all[parents], r], axis=1), none]
        if scene.bodies:
            segments.append(np.stack([r_all[frames_of_bodies], scene.centers[k]], axis=1))
        return np.concatenate(segments)

    def axis_segments(k: int, a: int) -> np.ndarray:
        r, S = scene.origins[k], scene.rotations[k]
        return np.concatenate([np.stack([r, r + triad * S[:, :, a]], axis=1), none])

    links = Line3DCollection(link_segments(0), colors="0.45", linewidths=1.5)
    ax.add_collection3d(links, autolim=False)
    axes = [Line3DCollection(axis_segments(0, a), colors=c, linewidths=1.2)
            for a, c in enumerate(_AXIS_COLORS)]
    for art in axes:
        ax.add_collection3d(art, autolim=False)
    solids = []
    colors = [f"C{k % 10}" for k in range(len(scene.meshes))]
    for mesh, color in zip(scene.meshes, colors, strict=True):
        if mesh is None:
            solids.append(None)
            continue
        poly = Poly3DCollection(mesh[0], facecolors=color, edgecolors="0.2", linewidths=0.3,
                                alpha=0.6)
        ax.add_collection3d(poly, autolim=False)
        solids.append(poly)
    points = [k for k, m in enumerate(scene.meshes) if m is None]
    (dots,) = ax.plot([], [], [], "o", color="k", markersize=6, linestyle="")
    # nodes coloured by their true displacement, one colour scale for all elastic bodies
    from matplotlib.colors import Normalize

    top = max((float(d.max(initial=0.0)) for d in scene.displacements), default=0.0)
    norm = Normalize(0.0, top if top > 0 else 1.0)
    clouds = [ax.scatter(cloud[0, :, 0], cloud[0, :, 1], cloud[0, :, 2], s=6, c=disp[0],
                         cmap="viridis", norm=norm, depthshade=False, label=name)
              for (name, cloud), disp in zip(scene.clouds, scene.displacements, strict=True)]
    if clouds:
        bar = fig.colorbar(clouds[0], ax=ax, shrink=0.6, pad=0.08)
        bar.set_label("elastic displacement |d| [m]")
    clock = ax.text2D(0.02, 0.95, "", transform=ax.transAxes)

    def update(k: int) -> None:
        links.set_segments(link_segments(k))
        for a, art in enumerate(axes):
            art.set_segments(axis_segments(k, a))
        for poly, mesh in zip(solids, scene.meshes, strict=True):
            if poly is not None:
                poly.set_verts(mesh[k])
        c = scene.centers[k, points] if points else np.zeros((0, 3))
        dots.set_data_3d(c[:, 0], c[:, 1], c[:, 2])
        for art, (_, cloud), disp in zip(clouds, scene.clouds, scene.displacements,
                                         strict=True):
            art._offsets3d = (cloud[k, :, 0], cloud[k, :, 1], cloud[k, :, 2])
            art.set_array(disp[k])
        clock.set_text(f"t = {scene.t[k]:.3f} s")

    return ax, update


def animate(
    result: SimulationResult,
    module: Any,
    path: str | os.PathLike[str],
    *,
    fps: float = 20.0,
    frames: int = 150,
    shape: str = "box",
    speed: float = 1.0,
    scale: float | str = "auto",
    p: Mapping[str, float] | Sequence[float] | np.ndarray | None = None,
    u: Callable[[float], Any] | Mapping[str, float] | Sequence[float] | None = None,
    dpi: int = 80,
    size: float = 5.0,
    progress: Callable[..., Any] | None = None,
) -> Path:
    """Write an animation of ``result`` (a simulation of ``module``) to ``path``.

    Parameters
    ----------
    result
        The simulation (:func:`~neweul_py.analysis.simulate`).
    module
        Its generated module (or the path of one), with ``frame_poses``.
    path
        ``.gif`` (matplotlib's PillowWriter) or ``.mp4`` (FFMpegWriter; needs ffmpeg).
    fps
        Pictures per second of the animation.
    frames
        At most this many pictures (:func:`animation_frames`).
    shape
        Rigid bodies as ``"box"`` or ``"ellipsoid"`` of their mass and inertia.
    speed
        Simulated seconds per second of the animation (below 1: slow motion).
    scale
        Deformation scale of elastic bodies: a factor, or ``"auto"`` (the largest
        displacement a tenth of its body, :func:`~neweul_py.analysis.scene.deformation_scale`;
        1 for rigid models).
    p, u
        Parameters (default: ``result.parameters``) and inputs (as in ``simulate``; they
        matter where frames move with inputs).
    dpi, size
        Resolution and edge of the square picture [in].
    progress
        A hook: a :class:`~neweul_py.progress.Tracker` gets ``(picture, pictures)``.

    Returns
    -------
    Path
        ``path``, written atomically.

    Raises
    ------
    NeweulError
        A wrong suffix, ``.mp4`` without ffmpeg, no matplotlib, a module without
        ``frame_poses`` (regenerate it) or a result of another model.
    """
    path = check_animation_path(path)
    if shape not in SHAPES:
        raise NeweulError(f"unknown body shape {shape!r}; shapes: {', '.join(SHAPES)}")
    mod = as_model(module)
    index = animation_frames(result.t, fps, int(frames), speed)
    scene = build_scene(mod, result, index, p=p, u=u, shape=shape, scale=scale)
    from matplotlib import animation

    fig = new_figure(figsize=(size, size), dpi=dpi, layout="constrained")
    name = result.model_name or mod.MODEL_NAME
    _ax, update = draw_scene(fig, scene, scene_title(name, scene, speed))
    count = scene.t.size
    writer: Any = (animation.PillowWriter(fps=fps) if path.suffix.lower() == ".gif"
                   else animation.FFMpegWriter(fps=fps))
    with tempfile.TemporaryDirectory(prefix=".neweul-animate-") as tmp:
        out = Path(tmp) / f"animation{path.suffix.lower()}"
        try:  # the writer grabs each picture once (FuncAnimation would draw it twice)
            with writer.saving(fig, out, dpi):
                for k in range(count):
                    update(k)
                    writer.grab_frame()
                    report(progress, "", k + 1, count)
        except (OSError, RuntimeError, ValueError) as exc:
            raise NeweulError(f"{path}: cannot write the animation ({exc})") from None
        return atomic_write(path, out.read_bytes())
