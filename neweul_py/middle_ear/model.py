"""Meshes and constant matrices of the middle-ear FE model (TM, ear canal, tympanic cavity,
antrum and mastoid).

Geometry (``z`` medial; see :mod:`neweul_py.fem.mesh`): the TM is a shallow cone of rim radius
``a = sqrt(area/π)`` and depth ``h`` with the umbo (apex) at ``z = h``, clamped at the rim
(annulus) ``z = 0``; the manubrium is the radial line of TM nodes from the umbo towards the
superior rim (``+x``). The ear canal is the air between the entrance plane ``z = −L`` (diameter
``d``) and the lateral face of the TM (a truncated cone widening from ``d`` to the TM diameter);
the tympanic cavity is the air between the medial face of the TM and the plane ``z = L_c``
inside the cylinder of radius ``a``, with ``L_c`` chosen so that its volume is ``V_c``. Both air
meshes are extrusions of the TM triangulation, so pressure and displacement nodes coincide on the
TM (conforming coupling). The antrum and mastoid are a lumped compliance behind the aditus, a
lumped inertance opening on the medial cavity wall (:func:`build_middle_ear`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sps

from ..errors import ModelError
from ..fem.acoustic import acoustic_matrices, surface_load
from ..fem.mesh import SurfaceMesh, TetMesh, cone_membrane, extrude_tets, tet_volumes
from ..fem.shell import ShellMaterial, ShellStructure
from .chain import chain_tangent_matrix, condensed_support, malleus_map
from .parameters import MiddleEarParameters

__all__ = ["MiddleEar", "build_middle_ear", "flaccida_patches", "support_stiffness"]


@dataclass(frozen=True, eq=False)
class MiddleEar:
    """Meshes and the configuration-independent parts of the middle-ear FE model.

    Built by :func:`build_middle_ear`; use :func:`solve_static` and
    :func:`working_point_model` with it.
    """

    params: MiddleEarParameters
    refine: int
    tm: SurfaceMesh
    shell: ShellStructure
    canal: TetMesh
    cavity: TetMesh
    canal_tm_nodes: np.ndarray  # canal node of each TM node
    cavity_tm_nodes: np.ndarray  # cavity node of each TM node
    canal_entrance: np.ndarray  # (nt, 3) canal node triangles of the entrance plane
    free_dofs: np.ndarray  # TM displacement DOFs (3·node + k) that are not clamped
    support: sps.csr_matrix  # (3n, 3n) ossicular support at the manubrium, tangent at rest
    Mf: sps.csr_matrix  # block-diagonal canal ⊕ cavity ⊕ mastoid (1 DOF if present)
    Kf: sps.csr_matrix  # acoustic Laplacian + the aditus inertance
    probe_weights: np.ndarray  # (4,) barycentric weights
    probe_nodes: np.ndarray  # (4,) canal nodes
    umbo: int
    info: dict = field(default_factory=dict)
    Kf_aditus: sps.csr_matrix | None = None  # the aditus part of Kf (its own loss factor)
    malleus_T: np.ndarray | None = None  # (3m, 6) rigid malleus → manubrium nodes
    flaccida: np.ndarray | None = None  # (n_p,) pars flaccida's patch weights, if present

    @property
    def n_flaccida(self) -> int:
        """1 if the pars flaccida's displacement DOF is present, else 0."""
        return 0 if self.flaccida is None else 1

    @property
    def n_mastoid(self) -> int:
        """1 if the antrum/mastoid pressure DOF is present, else 0."""
        return 1 if self.params.mastoid_volume > 0 else 0

    @property
    def manubrium_dofs(self) -> np.ndarray:
        """TM displacement DOFs ``3·node + k`` of the manubrium nodes (order of ``tm.line``)."""
        return (3 * self.tm.line[:, None] + np.arange(3)).ravel()

    @property
    def n_u(self) -> int:
        """Number of (free) displacement DOFs."""
        return int(self.free_dofs.size)

    @property
    def n_p(self) -> int:
        """Number of pressure DOFs (canal + cavity + mastoid)."""
        return int(self.Mf.shape[0])

    def dof_counts(self) -> dict[str, int]:
        """DOF counts by part."""
        nc = self.canal.points.shape[0]
        return {
            "tm_displacement": self.n_u,
            "canal_pressure": nc,
            "cavity_pressure": self.cavity.points.shape[0],
            "mastoid_pressure": self.n_mastoid,
            "total": self.n_u + self.n_p,
        }




def _layers(length: float, first: float, grading: float = 1.12) -> int:
    """Number of geometrically graded layers starting with thickness ``first``."""
    return max(2, math.ceil(math.log(1.0 + length * (grading - 1.0) / first) / math.log(grading)))


def build_middle_ear(
    params: MiddleEarParameters | None = None, refine: int = 2, verbose: bool = False
) -> MiddleEar:
    """Meshes and constant matrices of the middle-ear model.

    Parameters
    ----------
    params
        Physical data (defaults: :class:`MiddleEarParameters`).
    refine
        Refinement level ``L ≥ 0``: the TM has ``4·2^L`` rings of elements (mesh size
        ``a/(4·2^L)``); the air layers start with that thickness at the TM and grow by 12 % a
        layer. ``L = 2`` (default) gives ≈ 3·10⁴ DOFs, ``L = 0`` a coarse test model.
    verbose
        Print the DOF counts.

    Returns
    -------
    MiddleEar

    Raises
    ------
    ModelError
        Non-physical parameters or a failed mesh generation.

    Examples
    --------
    >>> me = build_middle_ear(refine=0)
    >>> me.dof_counts()["total"]
    1332
    """
    p = params or MiddleEarParameters()
    if not isinstance(refine, int) or refine < 0 or refine > 5:
        raise ModelError(f"refinement level must be an integer in 0…5, got {refine!r}", "refine")
    a, h = p.tm_radius, p.tm_depth
    rings = 4 * 2**refine
    tm = cone_membrane(a, h, rings, p.manubrium_reach, p.tm_bulge, p.umbo_offset)
    if tm.line.size < 2:
        raise ModelError("mesh too coarse for a manubrium of ≥ 2 nodes", "refine")
    material = ShellMaterial(p.tm_E_static, p.tm_nu, p.tm_thickness, p.tm_rho)
    shell = ShellStructure.create(tm.points, tm.triangles, material)
    size = a / rings
    x0 = tm.points
    scale_end = 0.5 * p.canal_diameter / a
    centre = tm.rim_centre  # the canal's axis passes through the rim's centre

    def canal_morph(pts: np.ndarray, s: float) -> np.ndarray:
        f = 1.0 + s * (scale_end - 1.0)
        xy = centre + (pts[:, :2] - centre) * f
        return np.column_stack([xy, (1 - s) * pts[:, 2] - s * p.canal_length])

    lc = p.cavity_length

    def cavity_morph(pts: np.ndarray, s: float) -> np.ndarray:
        return np.column_stack([pts[:, 0], pts[:, 1], (1 - s) * pts[:, 2] + s * lc])

    n_canal = _layers(p.canal_length, size)
    n_cav = _layers(lc - 0.5 * h, size)
    canal, canal_tm, canal_far = extrude_tets(x0, tm.triangles, n_canal, canal_morph, 1.12)
    cavity, cav_tm, cav_far = extrude_tets(x0, tm.triangles, n_cav, cavity_morph, 1.12)
    vol = tet_volumes(cavity.points, cavity.tets).sum()
    if abs(vol - p.cavity_volume) > 0.05 * p.cavity_volume:
        raise ModelError(
            f"cavity mesh volume {vol:.4g} m³ differs from the requested {p.cavity_volume:.4g}",
            "mesh",
        )
    mf_c, kf_c = acoustic_matrices(canal, p.c_air)
    mf_t, kf_t = acoustic_matrices(cavity, p.c_air)
    mf, kf, kf_aditus = _air_matrices(p, mf_c, kf_c, mf_t, kf_t, cavity, cav_far[tm.triangles])

    clamped = np.zeros(shell.n_dof, dtype=bool)
    clamped[(3 * tm.boundary[:, None] + np.arange(3)).ravel()] = True
    free = np.flatnonzero(~clamped)
    umbo = int(tm.line[0])
    t_mal = malleus_map(x0, tm.line, x0[umbo])
    ks = condensed_support(t_mal, p.k_tm_manubrium, chain_tangent_matrix(
        np.zeros(6), p.k_chain, a, p.chain_limit_medial, p.chain_limit_lateral)[1])
    md = (3 * tm.line[:, None] + np.arange(3)).ravel()
    rows, cols = np.meshgrid(md, md, indexing="ij")
    support = sps.csr_matrix((ks.ravel(), (rows.ravel(), cols.ravel())), shape=(shell.n_dof,) * 2)

    probe = np.array([centre[0], centre[1], -p.probe_distance])
    weights, nodes4 = _barycentric(canal, probe)
    me = MiddleEar(
        p,
        refine,
        tm,
        shell,
        canal,
        cavity,
        canal_tm,
        cav_tm,
        canal_far[tm.triangles],
        free,
        support,
        mf,
        kf,
        weights,
        nodes4,
        umbo,
        Kf_aditus=kf_aditus,
        malleus_T=t_mal,
        flaccida=(flaccida_patches(tm, canal, cavity, canal_tm, cav_tm, p, mf.shape[0])
                  if p.pf_compliance > 0 else None),
        info={
            "canal_layers": n_canal,
            "cavity_layers": n_cav,
            "tm_rings": rings,
            "canal_volume_m3": float(tet_volumes(canal.points, canal.tets).sum()),
            "cavity_volume_m3": float(vol),
            "mastoid_volume_m3": p.mastoid_volume,
        },
    )
    if verbose:
        counts = me.dof_counts()
        print(
            "middle ear FE model (refine {}): {} TM displacement + {} canal + {} cavity "
            "pressure DOFs = {} DOFs".format(
                refine,
                counts["tm_displacement"],
                counts["canal_pressure"],
                counts["cavity_pressure"],
                counts["total"],
            )
        )
    return me


def flaccida_patches(tm: SurfaceMesh, canal: TetMesh, cavity: TetMesh, canal_tm: np.ndarray,
                     cavity_tm: np.ndarray, p: MiddleEarParameters, n_p: int) -> np.ndarray:
    """The weights ``g`` (n_p,) of the pars flaccida's load ``A gᵀp = A (p̄_canal − p̄_cavity)``.

    The pars flaccida closes the ring above the superior end of the manubrium
    (:mod:`neweul_py.middle_ear.flaccida`); the model's air has no wall there, so it is loaded by
    the mean pressures over the faces of the canal and of the cavity on the TM triangles whose
    centroids lie within ``max(r, 1.5 h)`` of the superior rim point, the rim node next to the
    manubrium's superior end (``r = √(A/π)`` the pars
    flaccida's radius, ``h = a/(m + 1)`` with ``m`` manubrium nodes, about the TM's ring
    width, so that a coarse mesh still has a patch):
    ``g = b_canal / S_canal − b_cavity / S_cavity`` with ``b = ∫ N dΓ`` over each patch.
    """
    a = p.tm_radius
    rim = tm.points[tm.boundary]
    top = rim[np.argmin(np.linalg.norm(rim - tm.points[tm.line[-1]], axis=1))]
    centroids = tm.points[tm.triangles].mean(axis=1)
    near = np.linalg.norm(centroids - top, axis=1) <= max(math.sqrt(p.pf_area / math.pi),
                                                           1.5 * a / (tm.line.size + 1))
    tri = tm.triangles[near]
    b_c = surface_load(canal.points, canal_tm[tri])
    b_t = surface_load(cavity.points, cavity_tm[tri])
    g = np.zeros(n_p)
    nc, nt = b_c.size, b_t.size
    g[:nc] = b_c / b_c.sum()
    g[nc : nc + nt] = -b_t / b_t.sum()
    return g


def _barycentric(mesh: TetMesh, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Barycentric weights and nodes of the tetrahedron containing ``point``."""
    x = mesh.points[mesh.tets]
    t = np.stack([x[:, 1] - x[:, 0], x[:, 2] - x[:, 0], x[:, 3] - x[:, 0]], axis=2)
    lam = np.linalg.solve(t, (point - x[:, 0])[..., None])[..., 0]
    bary = np.column_stack([1.0 - lam.sum(axis=1), lam])
    inside = np.flatnonzero(bary.min(axis=1) >= -1e-9)
    if inside.size == 0:
        raise ModelError(f"probe point {point.tolist()} lies outside the canal mesh", "probe")
    e = inside[0]
    return bary[e], mesh.tets[e]




def _air_matrices(p, mf_c, kf_c, mf_t, kf_t, cavity: TetMesh, far_triangles: np.ndarray):
    """``Mf``, ``Kf`` of canal ⊕ cavity ⊕ antrum/mastoid, and the aditus part of ``Kf``.

    The antrum and mastoid air cells are a lumped compliance ``C_m = V_m/(ρc²)`` with the
    uniform pressure ``p_m`` (one extra pressure DOF), joined to the cavity by the aditus, a
    lumped inertance ``M_a = ρ l/A`` opening on the medial cavity wall ``Γ_a`` (area ``S``,
    ``b = ∫_Γa N dΓ``). With the volume flow ``Q`` into the aditus, ``M_a Q̇ = p̄ − p_m``
    (``p̄ = bᵀp/S``) and ``Q = C_m ṗ_m``; the cavity's boundary term ``ρ ∫ N a_n dΓ`` becomes
    ``(ρ/M_a) (b/S)(p̄ − p_m)``, so in the pressure form both are symmetric::

        Mf[p_m, p_m] = V_m / c²,   Kf += (A/l) g gᵀ,   g = [b/S on the cavity; −1 on p_m].

    (``docs/equations-middle-ear.md`` §4; a Helmholtz resonator, tested against its closed
    form in ``tests/middle_ear/test_model.py``.)
    """
    if p.mastoid_volume <= 0:
        mf = sps.block_diag([mf_c, mf_t], format="csr")
        kf = sps.block_diag([kf_c, kf_t], format="csr")
        return mf, kf, sps.csr_matrix(kf.shape)
    nc, nt = mf_c.shape[0], mf_t.shape[0]
    b = surface_load(cavity.points, far_triangles)
    g = np.zeros(nc + nt + 1)
    g[nc : nc + nt] = b / b.sum()
    g[-1] = -1.0
    nz = np.flatnonzero(g)
    rows, cols = np.meshgrid(nz, nz, indexing="ij")
    n = g.size
    kf_ad = sps.csr_matrix(
        ((p.aditus_area / p.aditus_length) * np.outer(g[nz], g[nz]).ravel(),
         (rows.ravel(), cols.ravel())), shape=(n, n))
    mm = sps.csr_matrix([[p.mastoid_volume / p.c_air**2]])
    mf = sps.block_diag([mf_c, mf_t, mm], format="csr")
    kf = sps.block_diag([kf_c, kf_t, sps.csr_matrix((1, 1))], format="csr") + kf_ad
    return mf, kf.tocsr(), kf_ad


def support_stiffness(
    points: np.ndarray,
    manubrium: np.ndarray,
    umbo_point: np.ndarray,
    k_attach: float,
    k_chain: float,
    lever: float,
) -> np.ndarray:
    """The *linear* support of the manubrium (the chain tangent at rest), dense 3m×3m.

    ``condensed_support(malleus_map(…), k_attach, diag(k₀ I₃, k₀ a² I₃))`` of
    :mod:`neweul_py.middle_ear.chain`; kept for callers of the former linear model.
    """
    kc = np.diag([k_chain] * 3 + [k_chain * lever**2] * 3)
    return condensed_support(malleus_map(points, manubrium, umbo_point), k_attach, kc)
