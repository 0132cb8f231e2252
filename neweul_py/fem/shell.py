"""A rotation-free flat-facet shell element for the tympanic membrane (vectorized over elements).

Formulation (translational DOFs ``ux, uy, uz`` per node only):

* **Membrane**: constant-strain triangle, total Lagrangian, St. Venant–Kirchhoff in plane stress.
  With the shape-function gradients ``G`` (3 nodes × 2) in a local orthonormal frame of the
  reference facet, ``F = Σ_a x_a ⊗ G_a`` (3×2), ``E = ½ (Fᵀ F − I)``, membrane forces
  ``N = t 𝔻 E`` (plane-stress SVK), internal forces ``f_a = A F N G_a`` and the consistent tangent
  ``K = A Bᵀ t𝔻 B + A (G_a · N G_b) I₃`` (material + initial-stress/stress-stiffening part), e.g.
  Bonet & Wood, *Nonlinear Continuum Mechanics for FE Analysis*, 2nd ed., ch. 8 and 9.
* **Bending**: the linear rotation-free *Basic Shell Triangle* (BST) of Oñate & Zárate (2000),
  IJNME 47:557–603: the curvature of a triangle is ``κ = (1/A) ∮ sym(ν ⊗ ∇w) ds`` with the
  gradient on each side taken as the mean of the gradients of the two facets sharing it (the
  patch of the triangle and its three neighbours); ``w`` is the displacement normal to the
  reference facet. On a side without neighbour (the clamped rim) the gradient is zero
  (clamped edge). The bending energy is ``½ A κᵀ D𝔻 κ`` with ``D = E t³ / (12 (1 − ν²))``.
  It is linear in the displacements and evaluated on the reference configuration — i.e. the
  Föppl–von Kármán split "nonlinear membrane + linear bending", adequate for the moderate
  rotations of the TM under ±4 kPa, where the membrane part dominates.
* **Pressure**: a uniform pressure ``Δp`` on the surface is the follower load
  ``f = Δp ∂V/∂x``, ``V = Σ x₀·(x₁ × x₂)/6`` (the volume swept by the surface, exact for flat
  facets; with a fixed rim the gradient at free nodes equals ``Σ A n / 3``), with the symmetric
  load stiffness ``−Δp ∂²V/∂x²``.
* **Mass**: consistent ``ρ t ∫ Nᵀ N dA`` of the facets.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse as sps

from ..errors import ModelError
from .assembly import assemble_matrix, assemble_vector, node_dofs

__all__ = [
    "ShellMaterial",
    "ShellStructure",
    "plane_stress",
    "swept_volume",
]


@dataclass(frozen=True)
class ShellMaterial:
    """Young's modulus ``E`` [Pa], Poisson ratio ``nu``, thickness ``t`` [m], density ``rho``."""

    E: float
    nu: float
    t: float
    rho: float

    def __post_init__(self) -> None:
        for name in ("E", "t", "rho"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ModelError(f"must be positive and finite, got {v!r}", f"material.{name}")
        if not (-1.0 < self.nu < 0.5):
            raise ModelError(f"Poisson ratio must be in (-1, 0.5), got {self.nu!r}", "material.nu")

    @property
    def bending_stiffness(self) -> float:
        """Plate bending stiffness ``D = E t³ / (12 (1 − ν²))``."""
        return self.E * self.t**3 / (12.0 * (1.0 - self.nu**2))


def plane_stress(E: float, nu: float) -> np.ndarray:
    """The plane-stress elasticity matrix (Voigt ``[11, 22, 2·12]``)."""
    return E / (1 - nu**2) * np.array([[1, nu, 0], [nu, 1, 0], [0, 0, (1 - nu) / 2]])


def _skew(v: np.ndarray) -> np.ndarray:
    """(…, 3) → (…, 3, 3) cross-product matrices ``[v]×``."""
    s = np.zeros((*v.shape[:-1], 3, 3))
    s[..., 0, 1], s[..., 0, 2] = -v[..., 2], v[..., 1]
    s[..., 1, 0], s[..., 1, 2] = v[..., 2], -v[..., 0]
    s[..., 2, 0], s[..., 2, 1] = -v[..., 1], v[..., 0]
    return s


def swept_volume(x: np.ndarray, triangles: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """``V = Σ x₀·(x₁×x₂)/6`` of a triangulated surface, its gradient and element Hessians.

    Returns
    -------
    V, grad, hess
        The volume, the (n, 3) gradient and the (nt, 9, 9) element Hessians (node-major DOFs).
    """
    xe = x[triangles]
    x0, x1, x2 = xe[:, 0], xe[:, 1], xe[:, 2]
    vol = float(np.einsum("ij,ij->", x0, np.cross(x1, x2)) / 6.0)
    ge = np.stack([np.cross(x1, x2), np.cross(x2, x0), np.cross(x0, x1)], axis=1) / 6.0
    grad = np.zeros_like(x)
    for i in range(3):
        grad[:, i] = np.bincount(triangles.ravel(), ge[..., i].ravel(), minlength=x.shape[0])
    h = np.zeros((triangles.shape[0], 3, 3, 3, 3))
    for a in range(3):
        b, c = (a + 1) % 3, (a + 2) % 3
        h[:, a, :, b, :] = -_skew(xe[:, c]) / 6.0
        h[:, a, :, c, :] = _skew(xe[:, b]) / 6.0
    return vol, grad, h.reshape(-1, 9, 9)


def _local_frame(xe: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Orthonormal facet frames ``e1, e2, n`` and areas of (nt, 3, 3) triangle coordinates."""
    a = xe[:, 1] - xe[:, 0]
    b = xe[:, 2] - xe[:, 0]
    nv = np.cross(a, b)
    two_area = np.linalg.norm(nv, axis=1)
    n = nv / two_area[:, None]
    e1 = a / np.linalg.norm(a, axis=1)[:, None]
    e2 = np.cross(n, e1)
    return e1, e2, n, 0.5 * two_area


def _gradients(xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Shape-function gradients (…, 3, 2) and signed areas of 2-D triangles ``xi`` (…, 3, 2)."""
    x, y = xi[..., 0], xi[..., 1]
    two_a = (x[..., 1] - x[..., 0]) * (y[..., 2] - y[..., 0]) - (x[..., 2] - x[..., 0]) * (
        y[..., 1] - y[..., 0]
    )
    g = np.empty(xi.shape)
    for a in range(3):
        b, c = (a + 1) % 3, (a + 2) % 3
        g[..., a, 0] = (y[..., b] - y[..., c]) / two_a
        g[..., a, 1] = (x[..., c] - x[..., b]) / two_a
    return g, 0.5 * two_a


def _edge_neighbours(triangles: np.ndarray) -> np.ndarray:
    """(nt, 3) index of the triangle across the side opposite each vertex (−1: none)."""
    nt = triangles.shape[0]
    sides = np.stack(
        [triangles[:, [1, 2]], triangles[:, [2, 0]], triangles[:, [0, 1]]], axis=1
    ).reshape(-1, 2)
    key = np.sort(sides, axis=1)
    _, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    if np.any(counts > 2):
        raise ModelError("surface mesh is not a manifold (a side shared by > 2 facets)", "mesh")
    owner = np.repeat(np.arange(nt), 3)
    order = np.argsort(inv, kind="stable")
    inv_sorted = inv[order]
    nbr = np.full(3 * nt, -1)
    pair = np.flatnonzero(inv_sorted[1:] == inv_sorted[:-1])
    i, j = order[pair], order[pair + 1]
    nbr[i], nbr[j] = owner[j], owner[i]
    return nbr.reshape(nt, 3)


@dataclass(frozen=True, eq=False)
class ShellStructure:
    """Reference data of the facet shell: call its methods with nodal displacements ``u`` (n, 3).

    Parameters
    ----------
    points
        (n, 3) reference coordinates.
    triangles
        (nt, 3) node indices.
    material
        The shell material.

    Notes
    -----
    Build with :meth:`create`; all element quantities are computed at once (vectorized).
    """

    points: np.ndarray
    triangles: np.ndarray
    material: ShellMaterial
    grads: np.ndarray  # (nt, 3, 2) reference shape-function gradients
    areas: np.ndarray  # (nt,)
    normals: np.ndarray  # (nt, 3) reference facet normals
    bending: sps.csr_matrix  # (3n, 3n) linear BST bending stiffness

    @classmethod
    def create(
        cls, points: np.ndarray, triangles: np.ndarray, material: ShellMaterial
    ) -> ShellStructure:
        """Precompute the reference geometry and the bending stiffness."""
        points = np.asarray(points, dtype=float)
        triangles = np.asarray(triangles, dtype=np.int64)
        xe = points[triangles]
        e1, e2, n, area = _local_frame(xe)
        if np.any(area <= 0) or not np.all(np.isfinite(area)):
            raise ModelError("surface mesh has degenerate triangles", "mesh")
        rel = xe - xe[:, :1]
        xi = np.stack([np.einsum("eai,ei->ea", rel, e1), np.einsum("eai,ei->ea", rel, e2)], -1)
        g, _ = _gradients(xi)
        kb = _bst_bending(points, triangles, e1, e2, n, xi, area, material)
        return cls(points, triangles, material, g, area, n, kb)

    @property
    def n_dof(self) -> int:
        """Number of displacement DOFs (3 per node, node-major)."""
        return 3 * self.points.shape[0]

    def _dofs(self) -> np.ndarray:
        return node_dofs(self.triangles, 3)

    @cached_property
    def reference_volume(self) -> float:
        """The swept volume of the reference surface (:func:`swept_volume`), computed once."""
        return swept_volume(self.points, self.triangles)[0]

    def membrane(
        self, u: np.ndarray, tangent: bool = True, incremental_modulus: float | None = None
    ) -> tuple[float, np.ndarray, sps.csr_matrix | None]:
        """Membrane energy, internal forces (3n,) and consistent tangent (TL St. Venant–Kirchhoff).

        Parameters
        ----------
        u
            (n, 3) or (3n,) nodal displacements from the reference configuration.
        tangent
            Also return the tangent (material + stress-stiffening).
        incremental_modulus
            Young's modulus of the tangent's material part ``∫ Bᵀ 𝔻 B dA`` (default the
            material's ``E``); the stress stiffening keeps the stress of ``u`` under ``E``.
            Small motions about a state reached with another modulus (a viscoelastic tissue
            loaded slowly and vibrated fast: docs/equations-middle-ear.md §3).
        """
        m = self.material
        x = self.points + np.reshape(u, (-1, 3))
        xe = x[self.triangles]
        g, a = self.grads, self.areas
        # batched matrix products (einsum over several operands loops element by element)
        f = np.swapaxes(xe, 1, 2) @ g  # (nt, 3, 2) deformation gradient F = Σ_a x_a ⊗ ∇N_a
        c = np.swapaxes(f, 1, 2) @ f   # C = FᵀF
        ev = np.stack([0.5 * (c[:, 0, 0] - 1), 0.5 * (c[:, 1, 1] - 1), c[:, 0, 1]], axis=1)
        dm = m.t * plane_stress(m.E, m.nu)
        nv = ev @ dm  # membrane forces (Voigt) — dm symmetric
        energy = float(0.5 * np.einsum("e,ei,ei->", a, ev, nv))
        nmat = np.stack([nv[:, [0, 2]], nv[:, [2, 1]]], axis=1)  # (nt, 2, 2), symmetric
        gn = g @ (a[:, None, None] * nmat)  # (nt, 3 nodes, 2): A ∇N_a · N
        fe = (gn @ np.swapaxes(f, 1, 2)).reshape(-1, 9)  # A F N ∇N_a per node a
        dofs = self._dofs()
        fint = assemble_vector(fe, dofs, self.n_dof)
        if not tangent:
            return energy, fint, None
        # B (nt, 3 voigt, 3 nodes, 3 comps)
        b = np.empty((len(a), 3, 3, 3))
        b[:, 0] = g[:, :, None, 0] * f[:, None, :, 0]
        b[:, 1] = g[:, :, None, 1] * f[:, None, :, 1]
        b[:, 2] = g[:, :, None, 1] * f[:, None, :, 0] + g[:, :, None, 0] * f[:, None, :, 1]
        b = b.reshape(-1, 3, 9)
        if incremental_modulus is not None:
            dm = dm * (incremental_modulus / m.E)
        km = np.swapaxes(b, 1, 2) @ ((a[:, None, None] * dm) @ b)  # A Bᵀ 𝔻 B
        gg = gn @ np.swapaxes(g, 1, 2)  # A ∇N_a · N ∇N_b
        kg = (gg[:, :, None, :, None] * np.eye(3)[None, None, :, None, :]).reshape(-1, 9, 9)
        return energy, fint, assemble_matrix(km + kg, dofs, self.n_dof)

    def bending_energy(self, u: np.ndarray) -> float:
        """``½ uᵀ K_b u`` of the linear BST bending."""
        uf = np.ravel(u)
        return float(0.5 * uf @ (self.bending @ uf))

    def mass(self) -> sps.csr_matrix:
        """Consistent mass ``ρ t ∫ NᵀN dA`` (3n × 3n)."""
        m = self.material
        me = m.rho * m.t * self.areas[:, None, None] / 12.0 * (np.ones((3, 3)) + np.eye(3))
        ke = np.einsum("eab,ij->eaibj", me, np.eye(3)).reshape(-1, 9, 9)
        return assemble_matrix(ke, self._dofs(), self.n_dof)

    def pressure(self, u: np.ndarray, dp: float) -> tuple[float, np.ndarray, sps.csr_matrix]:
        """Swept volume change, follower load ``Δp ∂V/∂x``, load stiffness ``−Δp ∂²V/∂x²``.

        The pressure ``Δp`` acts on the face opposite to the facet normals (it pushes along ``+n``).
        """
        x = self.points + np.reshape(u, (-1, 3))
        v, grad, h = swept_volume(x, self.triangles)
        kp = assemble_matrix(-dp * h, self._dofs(), self.n_dof)
        return v - self.reference_volume, dp * grad.ravel(), kp


def _bst_bending(
    points: np.ndarray,
    triangles: np.ndarray,
    e1: np.ndarray,
    e2: np.ndarray,
    n: np.ndarray,
    xi: np.ndarray,
    area: np.ndarray,
    material: ShellMaterial,
) -> sps.csr_matrix:
    """Linear rotation-free bending stiffness ``K_b = Bκᵀ (A D𝔻) Bκ`` of the 6-node patches.

    The curvature of a facet is the Hessian of the quadratic ``w(ξ)`` through the facet's three
    nodes and the three nodes opposite its sides (Phaal & Calladine 1992, IJNME 35:955–977;
    the quadratic-patch version of Oñate & Zárate's BST). A side without neighbour is a clamped
    rim: the opposite node is mirrored across it with the same ``w`` (zero normal slope).
    ``w`` is the displacement along the reference facet normal, coordinates are projected
    into the facet plane.
    """
    nt = triangles.shape[0]
    nbr = _edge_neighbours(triangles)
    has = nbr >= 0
    # the node of the neighbour facet opposite the shared side
    nb = np.where(has, nbr, 0)
    nb_tri = triangles[nb]  # (nt, 3 sides, 3)
    a_side = triangles[:, [1, 2, 0]]
    b_side = triangles[:, [2, 0, 1]]
    opp = np.where((nb_tri != a_side[..., None]) & (nb_tri != b_side[..., None]), nb_tri, -1).max(
        axis=2
    )
    rel = points[np.where(has, opp, 0)] - points[triangles[:, 0]][:, None, :]
    xo = np.stack([np.einsum("esi,ei->es", rel, e1), np.einsum("esi,ei->es", rel, e2)], -1)
    # mirror the own vertex across the side where there is no neighbour
    pa, pb = xi[:, [1, 2, 0]], xi[:, [2, 0, 1]]
    t = pb - pa
    t = t / np.linalg.norm(t, axis=-1, keepdims=True)
    d = xi - pa
    foot = pa + np.einsum("esk,esk->es", d, t)[..., None] * t
    ghost = 2.0 * foot - xi
    xo = np.where(has[..., None], xo, ghost)
    pts = np.concatenate([xi, xo], axis=1)  # (nt, 6, 2)
    centre = xi.mean(axis=1, keepdims=True)
    h = np.sqrt(area)[:, None]
    q = (pts - centre) / h[..., None]
    x, y = q[..., 0], q[..., 1]
    vand = np.stack([np.ones_like(x), x, y, x * x, x * y, y * y], axis=-1)  # (nt, 6, 6)
    if np.any(np.abs(np.linalg.det(vand)) < 1e-8):
        raise ModelError("degenerate bending patch (6 patch nodes on a conic)", "mesh")
    coef = np.linalg.inv(vand)[:, 3:, :] / (h[..., None] ** 2)  # rows: c_xx, c_xy, c_yy
    kappa = np.stack([2 * coef[:, 0], 2 * coef[:, 2], 2 * coef[:, 1]], axis=1)  # (nt, 3, 6)
    # patch node indices: ghosts act on the mirrored own vertex
    patch = np.concatenate([triangles, np.where(has, opp, triangles)], axis=1)  # (nt, 6)
    rows = np.broadcast_to(
        3 * np.arange(nt)[:, None, None, None] + np.arange(3)[None, :, None, None], (nt, 3, 6, 3)
    )
    cols = np.broadcast_to(
        3 * patch[:, None, :, None] + np.arange(3)[None, None, None, :], (nt, 3, 6, 3)
    )
    vals = kappa[..., None] * n[:, None, None, :]
    ndof = 3 * points.shape[0]
    bk = sps.csr_matrix((vals.ravel(), (rows.ravel(), cols.ravel())), shape=(3 * nt, ndof))
    db = plane_stress(material.E * material.t**3 / 12.0, material.nu)  # = D [[1, ν, 0], …]
    wmat = sps.kron(sps.diags(area), sps.csr_matrix(db), format="csr")
    return (bk.T @ wmat @ bk).tocsr()
