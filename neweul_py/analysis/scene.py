"""The moving scene of a simulated model: frame poses, body shapes and node clouds over time,
as plain arrays for :mod:`.animate` (docs/generated-module-protocol.md: ``frame_poses``,
``body_properties``, ``node_positions``).

Rigid bodies are drawn as the homogeneous box or ellipsoid with their mass and inertia tensor
about the center of mass. With the principal moments ``λ_1, λ_2, λ_3`` (eigenvalues of ``I``,
eigenvectors the box's axes) a box of edges ``a_i`` has ``λ_1 = m (a_2² + a_3²)/12``, so

    a_i = √(6 (λ_j + λ_k − λ_i) / m),

and an ellipsoid of semi-axes ``c_i`` has ``λ_1 = m (c_2² + c_3²)/5``, so
``c_i = √(5 (λ_j + λ_k − λ_i) / (2 m))`` (Gross et al., *Engineering Mechanics 3*, Table 3.2).
Dimensions below :data:`MIN_SIZE` of the scene (thin rods, point masses) are drawn at that
size, so every body stays visible.

Elastic bodies are their node clouds. Their deformation — the nodes' displacement
``d = r(q) − r(0)`` from where the same rigid motion puts the undeformed body (its elastic
coordinates set to zero) — is usually micrometres on a body of centimetres, so it can be drawn
magnified: ``r(0) + s d`` with a deformation scale ``s`` (:func:`deformation_scale`; ``"auto"``
makes the largest displacement shown :data:`AUTO_DEFORMATION` of the body's size). The true
``|d|`` is kept for colouring the nodes.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import NeweulError
from .module import GeneratedModel, ModelLike, as_model
from .protocol import resolve_inputs, resolve_parameters
from .results import SimulationResult

__all__ = ["AUTO_DEFORMATION", "MIN_SIZE", "SHAPES", "Scene", "box_mesh", "build_scene",
           "deformation_scale", "elastic_coordinates", "ellipsoid_mesh",
           "equivalent_dimensions"]

#: Body shapes: ``box`` or ``ellipsoid`` of equal mass and inertia.
SHAPES = ("box", "ellipsoid")
#: Smallest drawn body dimension (edge or diameter), as a fraction of the scene's size.
MIN_SIZE = 0.04
#: The largest elastic displacement drawn with the scale ``"auto"``, as a fraction of the size
#: of its body's undeformed node cloud.
AUTO_DEFORMATION = 0.1


def deformation_scale(scale: float | str, displacement: float, size: float) -> float:
    """The factor ``s`` of the drawn deformation ``r(0) + s d``.

    Parameters
    ----------
    scale
        A positive number, or ``"auto"``: ``AUTO_DEFORMATION · size / displacement`` where
        the deformation is smaller than that, else 1 (never shrunk).
    displacement
        The largest ``|d|`` over the nodes and times shown.
    size
        The size of the undeformed body (its node cloud's largest extent).

    Raises
    ------
    NeweulError
        Neither ``"auto"`` nor a positive finite number.
    """
    if isinstance(scale, str):
        if scale != "auto":
            raise NeweulError(f"deformation scale must be 'auto' or a positive number, "
                              f"got {scale!r}")
        if not displacement > 0 or not size > 0:
            return 1.0
        return max(1.0, AUTO_DEFORMATION * size / displacement)
    value = float(scale)
    if not (np.isfinite(value) and value > 0):
        raise NeweulError(f"deformation scale must be 'auto' or a positive number, got {scale!r}")
    return value


def elastic_coordinates(module: Any, body: str) -> list[int]:
    """Indices in ``COORDINATES`` of the elastic coordinates of ``body``: ``body_q<k>`` and
    the coordinates of its FE inputs, ``body_q<k>_<input>``
    (docs/generated-module-protocol.md)."""
    pattern = re.compile(rf"{re.escape(body)}_q\d+(_\w+)?")
    return [j for j, c in enumerate(module.COORDINATES) if pattern.fullmatch(c)]


def equivalent_dimensions(mass: float, inertia: np.ndarray, shape: str = "box"
                          ) -> tuple[np.ndarray, np.ndarray]:
    """Edges (box) or diameters (ellipsoid) of the homogeneous body with ``mass`` and
    ``inertia`` (about the center of mass), and its axes (module docstring).

    Returns
    -------
    dims, axes
        (3,) full dimensions along the columns of ``axes`` (3, 3; principal axes, frame
        components). Zeros for a point mass (zero mass or inertia).
    """
    inertia = 0.5 * (np.asarray(inertia, dtype=float) + np.asarray(inertia, dtype=float).T)
    lam, axes = np.linalg.eigh(inertia)
    if not mass > 0 or not np.any(lam > 0):
        return np.zeros(3), np.eye(3)
    other = lam.sum() - 2.0 * lam  # λ_j + λ_k − λ_i
    factor = 6.0 if shape == "box" else 10.0  # (2 c_i)² = 4·5/(2m)(…) = 10/m (…)
    return np.sqrt(np.clip(factor * other / mass, 0.0, None)), axes


def box_mesh(dims: np.ndarray, axes: np.ndarray, center: np.ndarray) -> np.ndarray:
    """The 6 faces (6, 4, 3) of the box with edges ``dims`` along ``axes`` about ``center``."""
    corners = np.array([[i, j, k] for i in (-0.5, 0.5) for j in (-0.5, 0.5)
                        for k in (-0.5, 0.5)])
    faces = np.array([[0, 1, 3, 2], [4, 5, 7, 6], [0, 1, 5, 4], [2, 3, 7, 6], [0, 2, 6, 4],
                      [1, 3, 7, 5]])
    points = center + (corners * dims) @ axes.T
    return points[faces]


def ellipsoid_mesh(dims: np.ndarray, axes: np.ndarray, center: np.ndarray,
                   n: int = 10) -> np.ndarray:
    """Quadrilaterals (n·n, 4, 3) of the ellipsoid with diameters ``dims`` along ``axes``."""
    u = np.linspace(0.0, 2.0 * np.pi, n + 1)
    v = np.linspace(0.0, np.pi, n + 1)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    unit = np.stack([np.cos(uu) * np.sin(vv), np.sin(uu) * np.sin(vv), np.cos(vv)], axis=-1)
    grid = center + (0.5 * unit * dims) @ axes.T  # (n+1, n+1, 3)
    quads = np.stack([grid[:-1, :-1], grid[1:, :-1], grid[1:, 1:], grid[:-1, 1:]], axis=2)
    return quads.reshape(-1, 4, 3)


@dataclass(frozen=True, eq=False)
class Scene:
    """A model's geometry at the animation times (all ISYS components).

    Attributes
    ----------
    t
        (nf,) times.
    frames, parents
        ``FRAMES`` and ``FRAME_PARENTS`` of the module.
    origins, rotations
        (nf, nF, 3) and (nf, nF, 3, 3): ``frame_poses`` at each time.
    bodies
        Names of the rigid bodies, in ``BODIES`` order.
    body_frames
        Index of each rigid body's frame in ``frames`` (−1: ISYS).
    centers
        (nf, nb, 3) the bodies' centers of mass.
    meshes
        Per rigid body its polygons (nf, k, 4, 3), or ``None`` for a point mass.
    clouds
        Per elastic body its names and node positions (nf, nk, 3), the deformation drawn
        ``deformation_scale`` times (module docstring).
    displacements
        Per elastic body the true ``|d|`` of its nodes (nf, nk) [m].
    deformation_scale
        The factor ``s`` the clouds' deformation is drawn with (1: true positions).
    center, size
        Middle and edge of a cube holding everything (the plot's limits).
    """

    t: np.ndarray
    frames: tuple[str, ...]
    parents: tuple[str, ...]
    origins: np.ndarray
    rotations: np.ndarray
    bodies: tuple[str, ...]
    body_frames: tuple[int, ...]
    centers: np.ndarray
    meshes: tuple[np.ndarray | None, ...]
    clouds: tuple[tuple[str, np.ndarray], ...]
    center: np.ndarray
    size: float
    displacements: tuple[np.ndarray, ...] = ()
    deformation_scale: float = 1.0


def _check(module: GeneratedModel, result: SimulationResult) -> None:
    what = module.MODEL_NAME
    if not module.has_poses:
        raise NeweulError(
            f"{what}: the generated module has no frame_poses (it was generated before "
            "animations were supported); regenerate it with `neweul generate`")
    if list(result.coordinates) != list(module.COORDINATES):
        raise NeweulError(
            f"the result's coordinates ({', '.join(result.coordinates)}) are not those of "
            f"{what} ({', '.join(module.COORDINATES)}): animate a result with its own model")


def build_scene(
    module: ModelLike,
    result: SimulationResult,
    index: Sequence[int] | np.ndarray,
    *,
    p: Mapping[str, float] | Sequence[float] | np.ndarray | None = None,
    u: Callable[[float], Any] | Mapping[str, float] | Sequence[float] | None = None,
    shape: str = "box",
    scale: float | str = 1.0,
) -> Scene:
    """The scene of ``result`` (a simulation of ``module``) at the samples ``index``.

    Parameters
    ----------
    module
        The generated model (or module, or its path) with ``frame_poses``.
    result
        Its simulation.
    index
        Rows of ``result.t`` to show.
    p
        Parameters (default: ``result.parameters``, the values simulated with).
    u
        The inputs as in :func:`~neweul_py.analysis.simulate` (frames driven by inputs).
    shape
        ``"box"`` or ``"ellipsoid"`` (:data:`SHAPES`).
    scale
        Deformation scale of the elastic bodies' clouds: a positive factor, or ``"auto"``
        (:func:`deformation_scale`, the largest displacement of any body shown).

    Raises
    ------
    NeweulError
        A module without ``frame_poses`` (regenerate it), a result of another model, an
        unknown shape.
    """
    if shape not in SHAPES:
        raise NeweulError(f"unknown body shape {shape!r}; shapes: {', '.join(SHAPES)}")
    module = as_model(module)
    _check(module, result)
    pv = resolve_parameters(module, result.parameters if p is None else p)
    index = np.asarray(index, dtype=int)
    t = np.asarray(result.t, dtype=float)[index]
    x = np.hstack([result.y, result.yd])[index]
    n_state = int(module.STATE_SIZE)
    if x.shape[1] != n_state:
        raise NeweulError(f"the result holds {x.shape[1]} states, the module {n_state}")
    frames = tuple(module.FRAMES)
    where = {name: i for i, name in enumerate(frames)}
    rigid = [b for b in module.BODIES if b.get("kind") == "rigid"]
    elastic = [b for b in module.BODIES if b.get("kind") == "elastic"]
    has_nodes = elastic and module.has_node_positions
    ufun = u if callable(u) else (lambda _t: u)
    origins, rotations, clouds, rests = [], [], [], []
    rigid_only = np.ones(x.shape[1])      # x with the elastic coordinates set to zero
    for b in elastic if has_nodes else ():
        rigid_only[elastic_coordinates(module, b["name"])] = 0.0
    for ti, xi in zip(t, x, strict=True):
        ui = ufun(ti)
        ui = resolve_inputs(module, ti, pv, None if ui is None else ui)
        r, S = module.frame_poses(ti, xi, pv, ui)
        origins.append(np.asarray(r, dtype=float).reshape(len(frames), 3))
        rotations.append(np.asarray(S, dtype=float).reshape(len(frames), 3, 3))
        if has_nodes:
            clouds.append([np.asarray(c, dtype=float) for c in module.node_positions(ti, xi, pv,
                                                                                    ui)])
            rests.append([np.asarray(c, dtype=float) for c in module.node_positions(
                ti, xi * rigid_only, pv, ui)])
    origins_a = np.array(origins).reshape(t.size, len(frames), 3)
    rotations_a = np.array(rotations).reshape(t.size, len(frames), 3, 3)
    # poses with ISYS appended as the last row, so that index −1 means ISYS
    r_all = np.concatenate([origins_a, np.zeros((t.size, 1, 3))], axis=1)
    s_all = np.concatenate([rotations_a, np.broadcast_to(np.eye(3), (t.size, 1, 3, 3))], axis=1)
    body_frames = tuple(where.get(b["frame"], -1) for b in rigid)
    if rigid:
        mass, com, inertia = (np.asarray(a, dtype=float) for a in module.body_properties(pv))
    else:
        mass, com, inertia = np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3, 3))
    fi = np.array(body_frames, dtype=int)
    centers = (r_all[:, fi] + np.einsum("tbij,bj->tbi", s_all[:, fi], com)
               if rigid else np.zeros((t.size, 0, 3)))
    node_sets: tuple[tuple[str, np.ndarray], ...] = ()
    displacements: tuple[np.ndarray, ...] = ()
    factor = 1.0
    if has_nodes:
        deformed = [np.array([c[k] for c in clouds]) for k in range(len(elastic))]
        rest = [np.array([c[k] for c in rests]) for k in range(len(elastic))]
        moved = [d - r for d, r in zip(deformed, rest, strict=True)]
        displacements = tuple(np.linalg.norm(m, axis=-1) for m in moved)
        largest = max((float(d.max(initial=0.0)) for d in displacements), default=0.0)
        extent = max((float(np.ptp(r[0], axis=0).max(initial=0.0)) if r.size else 0.0
                      for r in rest), default=0.0)
        factor = deformation_scale(scale, largest, extent)
        node_sets = tuple((b["name"], r + factor * m)
                          for b, r, m in zip(elastic, rest, moved, strict=True))
    else:
        deformation_scale(scale, 0.0, 0.0)       # (the argument is checked all the same)
    points = [origins_a.reshape(-1, 3), centers.reshape(-1, 3), np.zeros((1, 3)),
              *(c.reshape(-1, 3) for _, c in node_sets)]
    allp = np.vstack(points)
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    dims = [equivalent_dimensions(m, i, shape) for m, i in zip(mass, inertia, strict=True)]
    reach = max([float(np.max(d)) for d, _ in dims] + [0.0])
    size = max(float(np.max(hi - lo)) + reach, 1e-9)
    if size <= 1e-9:
        size = 1.0
    center = 0.5 * (lo + hi)
    meshes: list[np.ndarray | None] = []
    make = box_mesh if shape == "box" else ellipsoid_mesh
    for k, (d, axes) in enumerate(dims):
        if not np.any(d > 0):
            meshes.append(None)
            continue
        local = make(np.maximum(d, MIN_SIZE * size), axes, com[k])  # frame components
        f = fi[k]
        meshes.append(r_all[:, f, None, None, :]
                      + np.einsum("tij,kvj->tkvi", s_all[:, f], local))
    return Scene(t=t, frames=frames, parents=tuple(module.FRAME_PARENTS),
                 origins=origins_a, rotations=rotations_a,
                 bodies=tuple(b["name"] for b in rigid), body_frames=body_frames,
                 centers=centers, meshes=tuple(meshes), clouds=node_sets, center=center,
                 size=size, displacements=displacements, deformation_scale=factor)
