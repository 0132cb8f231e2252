"""Geometry and meshes of the acousto-structural FE models, generated in code.

Everything here is arrays in, arrays out (no element physics):

* :func:`disk_mesh` – a triangulated disc of ``n_rings`` concentric rings (node ``j = 0`` of every
  ring lies on the positive x axis, so that a radial line of nodes exists for the manubrium);
* :func:`cone_membrane` – the disc lifted to a shallow cone (the tympanic membrane), its apex
  (umbo) optionally off the rim's centre;
* :func:`extrude_tets` – a prism-layer extrusion of a surface triangulation, split into tetrahedra
  conformingly, with a user-supplied morph for each layer (ear canal, tympanic cavity);
* :func:`box_tets` – a structured box of tetrahedra (verification).

The coordinate system of the middle-ear models: ``z`` is the medial direction (from the ear canal
through the TM into the tympanic cavity), the TM rim lies in the plane ``z = 0``, the umbo at
``(0, 0, depth)``, the manubrium along ``+x`` (superior), ``+y`` anterior. The rim is a circle
centred on the umbo, or posterior-superior of it for an off-centre umbo
(:attr:`SurfaceMesh.rim_centre`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import Delaunay

from ..errors import ModelError

__all__ = [
    "SurfaceMesh",
    "TetMesh",
    "box_tets",
    "cone_membrane",
    "disk_mesh",
    "extrude_tets",
    "manubrium_section",
    "tet_volumes",
    "triangle_areas",
]


@dataclass(frozen=True, eq=False)
class SurfaceMesh:
    """A triangulated surface in 3-D.

    Parameters
    ----------
    points
        (n, 3) node coordinates.
    triangles
        (nt, 3) node indices, oriented so that ``(x1 − x0) × (x2 − x0)`` points along ``+z``
        (medially) for the middle-ear meshes.
    boundary
        Indices of the nodes on the outer rim (clamped annulus).
    line
        Indices of a radial line of nodes from the centre outwards (the manubrium), centre first.
    ring
        (n,) ring number of each node (0 = centre).
    rim_centre
        (2,) ``x, y`` of the centre of the circular rim (the origin unless the umbo is off
        centre).
    """

    points: np.ndarray
    triangles: np.ndarray
    boundary: np.ndarray
    line: np.ndarray
    ring: np.ndarray
    rim_centre: np.ndarray = field(default_factory=lambda: np.zeros(2))


@dataclass(frozen=True, eq=False)
class TetMesh:
    """A tetrahedral volume mesh: (n, 3) ``points`` and (nt, 4) positively oriented ``tets``."""

    points: np.ndarray
    tets: np.ndarray


def triangle_areas(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Areas of the triangles (vectorized)."""
    x = points[triangles]
    return 0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1)


def tet_volumes(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Signed volumes of the tetrahedra (positive for a right-handed vertex order)."""
    x = points[tets]
    a, b, c = x[:, 1] - x[:, 0], x[:, 2] - x[:, 0], x[:, 3] - x[:, 0]
    return np.einsum("ij,ij->i", a, np.cross(b, c)) / 6.0


def disk_mesh(radius: float, n_rings: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A Delaunay triangulation of a disc made of concentric rings.

    Ring ``k`` (``k = 1 … n_rings``) carries ``6 k`` equally spaced nodes, the first at angle 0,
    so element sizes are nearly uniform (≈ ``radius / n_rings``).

    Parameters
    ----------
    radius
        Disc radius (> 0).
    n_rings
        Number of rings (≥ 1).

    Returns
    -------
    xy, triangles, ring
        (n, 2) coordinates, (nt, 3) counter-clockwise triangles, (n,) ring number of each node.
    """
    if not (np.isfinite(radius) and radius > 0):
        raise ModelError(f"disc radius must be positive, got {radius!r}", "geometry.radius")
    if n_rings < 1:
        raise ModelError(f"need at least one ring, got {n_rings}", "mesh.n_rings")
    xy = [np.zeros((1, 2))]
    ring = [np.zeros(1, dtype=int)]
    for k in range(1, n_rings + 1):
        phi = 2.0 * np.pi * np.arange(6 * k) / (6 * k)
        r = radius * k / n_rings
        xy.append(np.column_stack([r * np.cos(phi), r * np.sin(phi)]))
        ring.append(np.full(6 * k, k))
    xy_all = np.vstack(xy)
    ring_all = np.concatenate(ring)
    tri = Delaunay(xy_all).simplices.astype(np.int64)
    # orient counter-clockwise
    d = xy_all[tri]
    cross = (d[:, 1, 0] - d[:, 0, 0]) * (d[:, 2, 1] - d[:, 0, 1]) - (d[:, 1, 1] - d[:, 0, 1]) * (
        d[:, 2, 0] - d[:, 0, 0]
    )
    flip = cross < 0
    tri[flip] = tri[flip][:, [0, 2, 1]]
    area = 0.5 * np.abs(cross)
    if np.any(area < 1e-12 * radius**2):
        raise ModelError("disc triangulation produced degenerate triangles", "mesh")
    return xy_all, tri, ring_all


def cone_membrane(
    radius: float,
    depth: float,
    n_rings: int,
    line_length: float = 1.0,
    bulge: float = 0.0,
    umbo_offset: float = 0.0,
) -> SurfaceMesh:
    """The tympanic membrane: a shallow cone over a disc mesh, apex (umbo) at ``(0, 0, depth)``.

    The profile along every ray from the umbo to the rim is
    ``z = depth (1 − ρ) − 4 bulge ρ (1 − ρ)``, ``ρ`` the fraction of the way from the umbo to
    the rim. With ``umbo_offset = e > 0`` the umbo lies ``e·radius`` anterior of the rim's
    centre: the disc point ``p`` (``r = |p|``) is mapped to ``p + (1 − r/radius) u``,
    ``u = (0, e·radius)`` — every ring ``r`` becomes the circle of radius ``r`` about
    ``(1 − r/radius) u``, the rim stays, the centre goes to ``u``, ``ρ = r/radius`` on the
    rays from ``u`` (Jacobian ``I − u p̂ᵀ/radius``, determinant ``1 − u·p̂/radius ≥ 1 − e``, so no
    element folds for ``e < 1``; the area and the volume under the cone are those of the
    centred cone). The radial line of the positive ``x`` axis becomes the straight segment
    from the umbo to the superior rim point ``(radius, 0)``; the mesh is then turned about the
    umbo by ``atan e`` and moved so that the umbo is at the origin and that segment (the
    manubrium) runs along ``+x`` again. ``docs/equations-middle-ear.md`` §1 (geometry).

    Parameters
    ----------
    radius
        Radius of the rim (annulus).
    depth
        Height of the apex (umbo) above the rim plane, positive medially (``depth = 0`` gives a
        flat plate).
    n_rings
        Rings of the disc mesh (refinement).
    line_length
        Fraction of the way from the umbo to the rim covered by the radial line of interface
        nodes (manubrium); rim nodes are never part of it.
    bulge
        Lateral (−z) bulge of the radial generators at mid-way (the curved radial fibres of
        the pars tensa; 0 gives a straight cone).
    umbo_offset
        Anterior offset ``e`` of the umbo from the rim's centre, as a fraction of the radius
        (``0 ≤ e < 0.5``; 0: the centred cone).

    Returns
    -------
    SurfaceMesh
    """
    if not np.isfinite(depth) or depth < 0 or depth >= radius:
        raise ModelError(
            f"cone depth must be in [0, radius) = [0, {radius}), got {depth!r}", "geometry.depth"
        )
    if not (np.isfinite(umbo_offset) and 0.0 <= umbo_offset < 0.5):
        raise ModelError(
            f"umbo offset must be in [0, 0.5) of the radius, got {umbo_offset!r}",
            "geometry.umbo_offset",
        )
    xy, tri, ring = disk_mesh(radius, n_rings)
    r = np.hypot(xy[:, 0], xy[:, 1])
    rho = r / radius
    z = depth * (1.0 - rho) - 4.0 * bulge * rho * (1.0 - rho)
    boundary = np.flatnonzero(ring == n_rings)
    on_axis = (np.abs(xy[:, 1]) < 1e-12 * radius) & (xy[:, 0] >= -1e-12 * radius)
    in_reach = (r <= line_length * radius * (1 + 1e-12)) & (ring < n_rings)
    line = np.flatnonzero(on_axis & in_reach)
    line = line[np.argsort(r[line])]
    xy, centre = _off_centre(xy, rho, radius, umbo_offset)
    return SurfaceMesh(np.column_stack([xy, z]), tri, boundary, line, ring, centre)


def _off_centre(
    xy: np.ndarray, rho: np.ndarray, radius: float, e: float
) -> tuple[np.ndarray, np.ndarray]:
    """The map of :func:`cone_membrane` for an umbo ``e·radius`` anterior of the rim's centre,
    in the umbo's frame (manubrium along ``+x``); returns the points and the rim's centre."""
    u = np.array([0.0, e * radius])
    q = xy + (1.0 - rho)[:, None] * u - u
    c, s = np.cos(np.arctan(e)), np.sin(np.arctan(e))
    turn = np.array([[c, -s], [s, c]])
    return q @ turn.T, turn @ -u


def manubrium_section(mesh: SurfaceMesh) -> tuple[np.ndarray, np.ndarray]:
    """The TM section through the umbo along the manubrium's ray and the inferior one.

    The nodes of the disc's positive and negative ``x`` axes (node ``1 + 3k(k − 1)`` and
    ``1 + 3k²`` of ring ``k`` in :func:`disk_mesh`'s order) — straight rays from the umbo to
    the superior and to the inferior rim point (for an off-centre umbo they meet at
    ``180° − 2 atan e``, not in one line) — ordered from the inferior rim to the superior one.

    Returns
    -------
    nodes, s
        Node indices and their signed in-plane distance from the umbo (``+`` superior).
    """
    k = np.arange(1, int(mesh.ring.max()) + 1)
    nodes = np.concatenate([(1 + 3 * k**2)[::-1], [0], 1 + 3 * k * (k - 1)])
    d = np.hypot(*(mesh.points[nodes, :2] - mesh.points[0, :2]).T)
    s = np.where(np.arange(nodes.size) < k.size, -d, d)
    return nodes, s


def extrude_tets(
    base: np.ndarray,
    triangles: np.ndarray,
    n_layers: int,
    morph: Callable[[np.ndarray, float], np.ndarray],
    grading: float = 1.0,
) -> tuple[TetMesh, np.ndarray, np.ndarray]:
    """Extrude a surface triangulation into layers of prisms, each split into three tetrahedra.

    Layer ``ℓ`` (``ℓ = 0 … n_layers``) has the coordinates ``morph(base, s_ℓ)`` with
    ``s_0 = 0`` (``morph(base, 0)`` must be the base surface itself) and ``s = 1`` at the far
    end; the parameter ``s_ℓ`` grows geometrically with ratio ``grading`` so that the layers
    are thin at the base (the TM) and thicker away from it. The prisms are split by the
    vertex-index rule (diagonal of each quadrilateral face from the smaller index at the lower
    layer to the larger one at the upper layer), which makes the split conforming.

    Returns
    -------
    mesh, base_nodes, far_nodes
        The mesh; indices of the nodes of layer 0 (same order as ``base``) and of the last layer.
    """
    if n_layers < 1:
        raise ModelError(f"need at least one layer, got {n_layers}", "mesh.n_layers")
    nb = base.shape[0]
    if grading == 1.0:
        s = np.linspace(0.0, 1.0, n_layers + 1)
    else:
        w = grading ** np.arange(n_layers)
        s = np.concatenate([[0.0], np.cumsum(w) / w.sum()])
    points = np.vstack([morph(base, float(sl)) for sl in s])
    t = np.sort(triangles, axis=1)
    a, b, c = t[:, 0], t[:, 1], t[:, 2]
    tets = []
    for layer in range(n_layers):
        lo, hi = layer * nb, (layer + 1) * nb
        tets.append(
            np.vstack(
                [
                    np.column_stack([a + lo, b + lo, c + lo, c + hi]),
                    np.column_stack([a + lo, b + lo, b + hi, c + hi]),
                    np.column_stack([a + lo, a + hi, b + hi, c + hi]),
                ]
            )
        )
    tets_all = np.vstack(tets)
    vol = tet_volumes(points, tets_all)
    # a proper extrusion keeps the orientation of every split tetrahedron through all layers,
    # and the orientation of the sorted base triangle relative to the extrusion direction
    sign = np.sign(vol).reshape(n_layers, 3 * t.shape[0])
    x0 = points[t]
    nrm = np.cross(x0[:, 1] - x0[:, 0], x0[:, 2] - x0[:, 0])
    up = points[nb + t[:, 0]] - points[t[:, 0]]
    orient = np.tile(np.sign(np.einsum("ij,ij->i", nrm, up)), 3)
    rel = (sign[0] * orient).reshape(3, -1)  # per split type: one orientation for all prisms
    bad = np.any(sign != sign[0], axis=0) | np.any(rel != rel[:, :1], axis=1).repeat(t.shape[0])
    if (
        not np.all(np.isfinite(points))
        or np.any(bad)
        or np.any(np.abs(vol) <= 1e-14 * np.abs(vol).max())
    ):
        raise ModelError(
            "volume mesh has degenerate or inverted tetrahedra (check the geometry)", "mesh"
        )
    neg = vol < 0
    tets_all[neg] = tets_all[neg][:, [0, 2, 1, 3]]
    return TetMesh(points, tets_all), np.arange(nb), np.arange(n_layers * nb, (n_layers + 1) * nb)


def box_tets(lengths: tuple[float, float, float], divisions: tuple[int, int, int]) -> TetMesh:
    """A structured tetrahedral mesh of the box ``[0, Lx] × [0, Ly] × [0, Lz]``.

    The box is a rectangle (split into triangles) extruded along ``z``, so the split is the same
    conforming one as in :func:`extrude_tets`.
    """
    lx, ly, lz = lengths
    nx, ny, nz = divisions
    gx, gy = np.meshgrid(np.linspace(0, lx, nx + 1), np.linspace(0, ly, ny + 1), indexing="ij")
    base = np.column_stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)])
    idx = np.arange(gx.size).reshape(nx + 1, ny + 1)
    q0, q1 = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel()
    q2, q3 = idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    tri = np.vstack([np.column_stack([q0, q1, q2]), np.column_stack([q0, q2, q3])])

    def morph(p: np.ndarray, s: float) -> np.ndarray:
        return p + np.array([0.0, 0.0, s * lz])

    mesh, _, _ = extrude_tets(base, tri, nz, morph)
    return mesh
