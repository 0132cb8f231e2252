"""The acousto-structural FE model of the tympanic membrane (TM), ear canal and tympanic cavity.

Geometry (``z`` medial; see :mod:`neweul_py.fem.mesh`): the TM is a shallow cone of rim radius
``a = sqrt(area/π)`` and depth ``h`` with the umbo (apex) at ``z = h``, clamped at the rim
(annulus) ``z = 0``; the manubrium is the radial line of TM nodes from the umbo towards the
superior rim (``+x``). The ear canal is the air between the entrance plane ``z = −L`` (diameter
``d``) and the lateral face of the TM (a truncated cone widening from ``d`` to the TM diameter);
the tympanic cavity is the air between the medial face of the TM and the plane ``z = L_c``
inside the cylinder of radius ``a``, with ``L_c`` chosen so that its volume is ``V_c``. Both air
meshes are extrusions of the TM triangulation, so pressure and displacement nodes coincide on the
TM (conforming coupling).

Static load: the static pressure difference ``Δp = p_canal − p_cavity`` (positive pushes the TM
medially, as a negative middle-ear pressure does) is a follower load; the static state is found
by Newton's method with load stepping (:func:`neweul_py.fem.nonlinear.load_path`) with the
ossicular chain supporting the manubrium (:func:`support_stiffness`).

Dynamic model at a working point (Eq. (2) of the seed paper, ``equations.md`` §3)::

    [Ms 0; ρCᵀ Mf] [ü; p̈] + [Ds 0; 0 Df] [u̇; ṗ] + [Ks −C; 0 Kf] [u; p] = [f; p_ex]

with ``Ks`` the consistent tangent at the working point (membrane material + stress stiffening,
bending, pressure load stiffness), ``C`` on both TM faces with the normals out of each air
volume evaluated on the deformed TM, and losses as equivalent viscous damping
``Ds = η_TM/ω_ref · Ks``, ``Df = η_air/ω_ref · Kf`` (exact loss factor at ``ω_ref``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, fields

import numpy as np
import scipy.sparse as sps
import scipy.sparse.linalg as spla

from ..elastic.fe_model import FEModel
from ..elastic.projection import Progress
from ..errors import ModelError, SolverError
from ..progress import report
from .acoustic import acoustic_matrices, surface_load
from .coupling import assemble_up, coupling_matrix
from .mesh import SurfaceMesh, TetMesh, cone_membrane, extrude_tets, tet_volumes
from .nonlinear import NewtonOptions, StaticState, load_path
from .shell import ShellMaterial, ShellStructure

__all__ = [
    "MAX_DISPLACEMENT_FRACTION",
    "MAX_VOLUME_FRACTION",
    "THIN_SHELL_RATIO",
    "MiddleEar",
    "MiddleEarParameters",
    "SweepResult",
    "ValidityBound",
    "build_middle_ear",
    "lowest_tangent_eigenvalue",
    "parse_pressures",
    "pressure_sweep",
    "solve_static",
    "static_summary",
    "static_validity",
    "support_stiffness",
    "working_point_model",
]


#: Thin-shell bound of the TM: ``thickness ≤ radius / THIN_SHELL_RATIO``.
THIN_SHELL_RATIO = 20.0
#: Validity of a static state (:func:`static_validity`): ``|ΔV|`` at most this fraction of the
#: volume of each air space (the air meshes stay in the reference geometry).
MAX_VOLUME_FRACTION = 0.05
#: Validity of a static state: the largest TM displacement at most this fraction of the TM's
#: reference depth (``max z − min z`` of the profile; the cone inverts at about 1).
MAX_DISPLACEMENT_FRACTION = 0.5


@dataclass(frozen=True)
class MiddleEarParameters:
    """Physical and geometric data (SI units); sources in ``examples/middle_ear/README.md``.

    Parameters
    ----------
    tm_area
        Physical TM area [m²] (Hudde & Engel 1998): 60 mm².
    tm_depth
        Cone depth of the TM [m] (Koike 2002; Gan 2004: 1.5–2 mm).
    tm_bulge
        Lateral bulge of the radial generators at mid-radius [m] (curved radial fibres,
        Funnell & Laszlo 1978): profile ``z = h (1 − ρ) − 4 δ ρ (1 − ρ)``.
    tm_thickness
        TM thickness [m] (Kuypers et al. 2006): 0.08 mm. At most ``radius / 20`` (thin-shell
        limit :data:`THIN_SHELL_RATIO`: the facet shell has Kirchhoff bending without
        transverse shear; for a clamped circular plate the Mindlin shear term adds
        ``8 / (3 κ (1 − ν)) · (t/a)²`` ≈ ``4.6 (t/a)²`` to the centre deflection ``p a⁴/(64 D)``
        — Wang, Reddy & Lee, *Shear Deformable Beams and Plates*, 2000 — i.e. ≈ 1 % at
        ``t = a/20``; the TM has ``a/t ≈ 55``).
    tm_E, tm_nu, tm_rho
        Pars tensa Young's modulus, Poisson ratio, density (Wada & Kobayashi; De Greef 2014).
    tm_loss
        TM loss factor η (De Greef et al. 2014: 0.01–0.13).
    manubrium_reach
        Fraction of the TM radius covered by the manubrium nodes, from the umbo.
    k_tm_manubrium
        Total TM–manubrium attachment stiffness [N/m] (LVATB1, Lobato et al.: 36 933 N/m).
    k_chain
        Static stiffness of the ossicular chain at the umbo [N/m]: the malleus ligaments
        (893) in parallel with the incus path — incudomalleolar joint (11 410) in series with
        the incus ligament (129) plus the incudostapedial joint (12 581) in series with the
        annular ligament (764) — of LVATB1: ≈ 1.68·10³ N/m.
    canal_length, canal_diameter
        Ear canal [m] (Rosowski 1993): 25 mm, 7.5 mm.
    cavity_volume
        Tympanic cavity volume [m³] (Hudde & Engel 1998): 0.5 cm³; more than
        :attr:`min_cavity_volume`.
    rho_air, c_air
        Air density [kg/m³] and speed of sound [m/s].
    air_loss
        Small acoustic loss factor of the air.
    probe_distance
        Probe microphone on the axis this far lateral of the TM rim plane [m].
    f_ref
        Frequency [Hz] at which the viscous damping matches the loss factors.
    """

    tm_area: float = 60e-6
    tm_depth: float = 2.0e-3
    tm_bulge: float = 0.5e-3
    tm_thickness: float = 80e-6
    tm_E: float = 32e6
    tm_nu: float = 0.3
    tm_rho: float = 1200.0
    tm_loss: float = 0.1
    manubrium_reach: float = 0.8
    k_tm_manubrium: float = 36933.0
    k_chain: float = 1683.0
    canal_length: float = 25e-3
    canal_diameter: float = 7.5e-3
    cavity_volume: float = 0.5e-6
    rho_air: float = 1.2
    c_air: float = 343.0
    air_loss: float = 0.01
    probe_distance: float = 3e-3
    f_ref: float = 1000.0

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if not (isinstance(v, int | float) and math.isfinite(v)):
                raise ModelError(f"must be a finite number, got {v!r}", f"middle_ear.{f.name}")
        positive = (
            "tm_area tm_thickness tm_E tm_rho k_tm_manubrium k_chain canal_length "
            "canal_diameter cavity_volume rho_air c_air probe_distance f_ref"
        ).split()
        for name in positive:
            if getattr(self, name) <= 0:
                raise ModelError(
                    f"must be positive, got {getattr(self, name)!r}", f"middle_ear.{name}"
                )
        for name in ("tm_loss", "air_loss"):
            if not 0 <= getattr(self, name) < 1:
                raise ModelError("loss factor must be in [0, 1)", f"middle_ear.{name}")
        if not 0 < self.manubrium_reach < 1:
            raise ModelError("must be in (0, 1)", "middle_ear.manubrium_reach")
        a = self.tm_radius
        if self.tm_thickness > a / THIN_SHELL_RATIO:
            raise ModelError(
                f"TM thickness {self.tm_thickness:.4g} m exceeds the thin-shell limit radius/"
                f"{THIN_SHELL_RATIO:g} = {a / THIN_SHELL_RATIO:.4g} m (the shell element has no "
                "transverse shear; beyond the limit that error exceeds ≈ 1 %)",
                "middle_ear.tm_thickness",
            )
        if not 0 <= self.tm_depth < a:
            raise ModelError(
                f"TM depth must be in [0, radius = {a:.4g} m), got {self.tm_depth}",
                "middle_ear.tm_depth",
            )
        if abs(self.tm_bulge) >= 0.25 * a:
            raise ModelError(
                f"TM bulge must be smaller than a quarter of the radius ({0.25 * a:.4g} m)",
                "middle_ear.tm_bulge",
            )
        v_min = self.min_cavity_volume
        if self.cavity_volume <= v_min:
            raise ModelError(
                f"cavity volume {self.cavity_volume:.6g} m³ too small to hold the TM cone "
                f"(needs > {v_min:.6g} m³: the cavity length must exceed 1.05 × the TM height "
                f"{self.tm_height:.4g} m)",
                "middle_ear.cavity_volume",
            )
        if self.probe_distance >= self.canal_length:
            raise ModelError("probe must lie inside the canal", "middle_ear.probe_distance")

    @property
    def tm_radius(self) -> float:
        """Rim radius ``a = sqrt(area / π)``."""
        return math.sqrt(self.tm_area / math.pi)

    @property
    def tm_height(self) -> float:
        """Highest point ``max z`` of the TM profile ``z = h (1 − ρ) − 4 δ ρ (1 − ρ)``.

        ``h`` (the umbo) unless the generators bulge medially by more than ``h/4``
        (``δ < −h/4``): then the vertex of the parabola, ``h − (h + 4δ)² / (16 δ)``.
        """
        h, d = self.tm_depth, self.tm_bulge
        if d < -0.25 * h:
            return h - (h + 4.0 * d) ** 2 / (16.0 * d)
        return h

    @property
    def _profile_volume(self) -> float:
        """Signed volume between the rim plane ``z = 0`` and the TM: ``π a² (h − 2δ) / 3``."""
        return math.pi * self.tm_radius**2 * (self.tm_depth - 2.0 * self.tm_bulge) / 3.0

    @property
    def cavity_length(self) -> float:
        """Axial length ``L_c`` of the cavity cylinder so that its air volume is ``V_c``:
        ``π a² L_c − π a² (h − 2δ)/3 = V_c``."""
        return (self.cavity_volume + self._profile_volume) / (math.pi * self.tm_radius**2)

    @property
    def min_cavity_volume(self) -> float:
        """Smallest admissible cavity volume: the cavity must reach beyond the TM with a gap,
        ``L_c > 1.05 max z``, i.e. ``V_c > π a² (1.05 max z − (h − 2δ)/3)`` (for the default
        shape ``max z = h``: ``π a² (1.05 h − (h − 2δ)/3)`` ≈ 1.06·10⁻⁷ m³)."""
        a = self.tm_radius
        return math.pi * a**2 * 1.05 * self.tm_height - self._profile_volume


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
    support: sps.csr_matrix  # (3n, 3n) ossicular support at the manubrium
    Mf: sps.csr_matrix  # block-diagonal canal ⊕ cavity
    Kf: sps.csr_matrix
    probe_weights: np.ndarray  # (4,) barycentric weights
    probe_nodes: np.ndarray  # (4,) canal nodes
    umbo: int
    info: dict = field(default_factory=dict)

    @property
    def n_u(self) -> int:
        """Number of (free) displacement DOFs."""
        return int(self.free_dofs.size)

    @property
    def n_p(self) -> int:
        """Number of pressure DOFs (canal + cavity)."""
        return int(self.Mf.shape[0])

    def dof_counts(self) -> dict[str, int]:
        """DOF counts by part."""
        nc = self.canal.points.shape[0]
        return {
            "tm_displacement": self.n_u,
            "canal_pressure": nc,
            "cavity_pressure": self.cavity.points.shape[0],
            "total": self.n_u + self.n_p,
        }


def _layers(length: float, first: float, grading: float = 1.12) -> int:
    """Number of geometrically graded layers starting with thickness ``first``."""
    return max(2, math.ceil(math.log(1.0 + length * (grading - 1.0) / first) / math.log(grading)))


def support_stiffness(
    points: np.ndarray,
    manubrium: np.ndarray,
    umbo_point: np.ndarray,
    k_attach: float,
    k_chain: float,
    lever: float,
) -> np.ndarray:
    """Static support of the manubrium nodes by the ossicular chain (condensed, dense 3m×3m).

    Model: a rigid malleus (translation ``q_t`` and small rotation ``θ`` about the umbo) is
    held by the chain with translational stiffness ``k_chain`` and rotational stiffness
    ``k_chain · lever²`` in every direction, and attached to the ``m`` manubrium nodes by
    isotropic springs of total stiffness ``k_attach``. Eliminating ``q = (q_t, θ)``::

        K_sup = k I − k² T (k TᵀT + K_chain)⁻¹ Tᵀ,   u_i = q_t + θ × (x_i − x_umbo),

    with ``k = k_attach / m``. Rigid motions of the manubrium see the chain stiffness, relative
    deformations along the manubrium the (stiff) attachment springs.
    """
    m = manubrium.size
    rel = points[manubrium] - umbo_point
    t = np.zeros((3 * m, 6))
    for i in range(3):
        t[i::3, i] = 1.0
    skew = np.zeros((m, 3, 3))  # θ × r = −[r]× θ
    skew[:, 0, 1], skew[:, 0, 2] = rel[:, 2], -rel[:, 1]
    skew[:, 1, 0], skew[:, 1, 2] = -rel[:, 2], rel[:, 0]
    skew[:, 2, 0], skew[:, 2, 1] = rel[:, 1], -rel[:, 0]
    t[:, 3:] = skew.reshape(3 * m, 3)
    k = k_attach / m
    kc = np.diag([k_chain] * 3 + [k_chain * lever**2] * 3)
    return k * np.eye(3 * m) - k**2 * t @ np.linalg.solve(k * t.T @ t + kc, t.T)


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
    1331
    """
    p = params or MiddleEarParameters()
    if not isinstance(refine, int) or refine < 0 or refine > 5:
        raise ModelError(f"refinement level must be an integer in 0…5, got {refine!r}", "refine")
    a, h = p.tm_radius, p.tm_depth
    rings = 4 * 2**refine
    tm = cone_membrane(a, h, rings, p.manubrium_reach, p.tm_bulge)
    if tm.line.size < 2:
        raise ModelError("mesh too coarse for a manubrium of ≥ 2 nodes", "refine")
    material = ShellMaterial(p.tm_E, p.tm_nu, p.tm_thickness, p.tm_rho)
    shell = ShellStructure.create(tm.points, tm.triangles, material)
    size = a / rings
    x0 = tm.points
    scale_end = 0.5 * p.canal_diameter / a

    def canal_morph(pts: np.ndarray, s: float) -> np.ndarray:
        f = 1.0 + s * (scale_end - 1.0)
        return np.column_stack(
            [pts[:, 0] * f, pts[:, 1] * f, (1 - s) * pts[:, 2] - s * p.canal_length]
        )

    lc = p.cavity_length

    def cavity_morph(pts: np.ndarray, s: float) -> np.ndarray:
        return np.column_stack([pts[:, 0], pts[:, 1], (1 - s) * pts[:, 2] + s * lc])

    n_canal = _layers(p.canal_length, size)
    n_cav = _layers(lc - 0.5 * h, size)
    canal, canal_tm, canal_far = extrude_tets(x0, tm.triangles, n_canal, canal_morph, 1.12)
    cavity, cav_tm, _ = extrude_tets(x0, tm.triangles, n_cav, cavity_morph, 1.12)
    vol = tet_volumes(cavity.points, cavity.tets).sum()
    if abs(vol - p.cavity_volume) > 0.05 * p.cavity_volume:
        raise ModelError(
            f"cavity mesh volume {vol:.4g} m³ differs from the requested {p.cavity_volume:.4g}",
            "mesh",
        )
    mf_c, kf_c = acoustic_matrices(canal, p.c_air)
    mf_t, kf_t = acoustic_matrices(cavity, p.c_air)
    mf = sps.block_diag([mf_c, mf_t], format="csr")
    kf = sps.block_diag([kf_c, kf_t], format="csr")

    clamped = np.zeros(shell.n_dof, dtype=bool)
    clamped[(3 * tm.boundary[:, None] + np.arange(3)).ravel()] = True
    free = np.flatnonzero(~clamped)
    umbo = int(tm.line[0])
    ks = support_stiffness(x0, tm.line, x0[umbo], p.k_tm_manubrium, p.k_chain, a)
    md = (3 * tm.line[:, None] + np.arange(3)).ravel()
    rows, cols = np.meshgrid(md, md, indexing="ij")
    support = sps.csr_matrix((ks.ravel(), (rows.ravel(), cols.ravel())), shape=(shell.n_dof,) * 2)

    probe = np.array([0.0, 0.0, -p.probe_distance])
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
        info={
            "canal_layers": n_canal,
            "cavity_layers": n_cav,
            "tm_rings": rings,
            "canal_volume_m3": float(tet_volumes(canal.points, canal.tets).sum()),
            "cavity_volume_m3": float(vol),
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


# ------------------------------------------------------------------------ static solution
def _residual(me: MiddleEar):
    shell, fi = me.shell, me.free_dofs
    kb_sup = (shell.bending + me.support).tocsr()

    def residual(uf: np.ndarray, dp: float):
        u = np.zeros(shell.n_dof)
        u[fi] = uf
        _, fint, km = shell.membrane(u)
        _, fp, kp = shell.pressure(u, dp)
        r = fint + kb_sup @ u - fp
        k = (km + kb_sup + kp).tocsr()
        scale = max(abs(dp), 1.0) * me.params.tm_area / math.sqrt(me.tm.points.shape[0])
        return r[fi], k[fi][:, fi], scale

    return residual


@dataclass(frozen=True)
class ValidityBound:
    """One validity bound of a static state, ``value ≤ limit`` (SI units).

    ``text`` describes a violation; its ``{value}`` and ``{limit}`` are printed multiplied by
    ``scale`` (to mm, µm, mm³).
    """

    name: str
    value: float
    limit: float
    text: str
    scale: float = 1.0

    @property
    def ok(self) -> bool:
        """The bound holds."""
        return self.value <= self.limit

    def describe(self) -> str:
        """The violation in words, with the value and the limit."""
        return self.text.format(value=self.value * self.scale, limit=self.limit * self.scale)


def static_validity(me: MiddleEar, state: StaticState) -> tuple[ValidityBound, ...]:
    """The physical-validity bounds of a static TM state (all must hold, ``bound.ok``).

    The working-point models keep the air meshes in the reference geometry and take ``C`` on
    the deformed TM; that is consistent only while the TM moves little compared with the air
    spaces. Checked (``x = X + u`` the deformed TM nodes, ``ΔV`` the swept volume):

    * **walls**: every TM node stays inside the tympanic cavity (``z ≤ L_c``, ``r ≤ a``) and the
      ear canal (``z ≥ −L``, inside the canal's conical wall) — penetration depth ≤ 0;
    * **no inversion of the cone**: ``max |u| ≤`` :data:`MAX_DISPLACEMENT_FRACTION` ``· H``,
      ``H = max z − min z`` of the reference TM (the cone inverts when its apex has moved by
      about ``H``; not checked for a flat TM);
    * **small volume change**: ``|ΔV| ≤`` :data:`MAX_VOLUME_FRACTION` ``·`` (mesh volume) of
      the canal and of the cavity (linear acoustics on the reference mesh; the compression of
      the cavity air by ``ΔV`` is itself a static pressure change of ``ρc²ΔV/V_c``, 7 kPa at
      5 % — the order of the static pressures modelled).

    At ±4 kPa (default model) ``|ΔV| ≈ 8 mm³`` (1.7 % of the cavity) and ``max |u| ≈ 0.26 mm``
    (0.13 of ``H = 2 mm``).

    Returns
    -------
    tuple of ValidityBound
        Walls of the cavity and of the canal, cone inversion, volume vs. canal and cavity.
    """
    p = me.params
    a, length, lc = p.tm_radius, p.canal_length, p.cavity_length
    u = _full(me, state)
    x = me.shell.points + u
    r, z = np.hypot(x[:, 0], x[:, 1]), x[:, 2]
    tol = 1e-9 * a
    # canal wall: the extruded rim, r = a + (d/2 − a)·(−z/L) for −L ≤ z ≤ 0
    r_canal = a + (0.5 * p.canal_diameter - a) * np.clip(-z / length, 0.0, 1.0)
    above, below = z >= 0.0, z < 0.0
    cav = np.concatenate([[z.max() - lc], (r - a)[above]]).max()
    can = np.concatenate([[-length - z.min()], (r - r_canal)[below]]).max()
    depth = float(np.ptp(me.shell.points[:, 2]))
    umax = float(np.linalg.norm(u, axis=1).max())
    dv = abs(me.shell.pressure(u.ravel(), 0.0)[0])
    frac = f"{100 * MAX_VOLUME_FRACTION:g} %"
    return (
        ValidityBound(
            "cavity wall",
            cav,
            tol,
            "the TM penetrates the tympanic cavity wall by {value:.3g} mm",
            1e3,
        ),
        ValidityBound(
            "canal wall", can, tol, "the TM penetrates the ear-canal wall by {value:.3g} mm", 1e3
        ),
        ValidityBound(
            "cone inversion",
            umax,
            MAX_DISPLACEMENT_FRACTION * depth if depth > 0 else math.inf,
            "cone inversion: the largest TM displacement {value:.1f} µm exceeds "
            f"{MAX_DISPLACEMENT_FRACTION:g} × the cone depth " + "({limit:.1f} µm)",
            1e6,
        ),
        ValidityBound(
            "canal volume",
            dv,
            MAX_VOLUME_FRACTION * me.info["canal_volume_m3"],
            f"|ΔV| = {{value:.3f}} mm³ exceeds {frac} of the ear-canal volume ({{limit:.3f}} mm³)",
            1e9,
        ),
        ValidityBound(
            "cavity volume",
            dv,
            MAX_VOLUME_FRACTION * me.info["cavity_volume_m3"],
            f"|ΔV| = {{value:.3f}} mm³ exceeds {frac} of the tympanic cavity volume "
            "({limit:.3f} mm³)",
            1e9,
        ),
    )


def solve_static(
    me: MiddleEar,
    pressures: Sequence[float],
    options: NewtonOptions | None = None,
    check_stability: bool = True,
    check_validity: bool = True,
    progress: Progress = None,
) -> list[StaticState]:
    """Static equilibria of the TM at the static pressure differences ``Δp`` [Pa].

    The positive and the negative branch are each followed from the unloaded state with Newton's
    method and adaptive load steps (:func:`~neweul_py.fem.nonlinear.load_path`). With
    ``check_validity`` every converged load step is checked against the physical-validity
    bounds of :func:`static_validity` (so that an absurd load stops at the first invalid step).
    With ``check_stability`` every returned state is checked to have a positive definite tangent
    (:func:`lowest_tangent_eigenvalue`), so that a passed bifurcation is not returned as a
    working point.

    Parameters
    ----------
    progress
        Called with a short message after every converged load step.

    Returns
    -------
    list of StaticState
        In the order of ``pressures``; ``u`` are the free TM displacement DOFs.

    Raises
    ------
    SolverError
        A pressure could not be reached (the message names the last converged load step), a
        load step violates a validity bound (the message names the load step, the bound with its
        value and the last valid load step; ``last_iterate`` is that state), or a reached state
        is unstable.

    Examples
    --------
    >>> me = build_middle_ear(refine=0)
    >>> [s.load for s in solve_static(me, [-1000.0, 0.0, 1000.0])]
    [-1000.0, 0.0, 1000.0]
    """
    dps = np.asarray(pressures, dtype=float)
    if dps.ndim != 1 or dps.size == 0 or not np.all(np.isfinite(dps)):
        raise ModelError("pressures must be a non-empty list of finite numbers", "pressures")
    res = _residual(me)
    out: list[StaticState | None] = [None] * dps.size
    for branch in (np.flatnonzero(dps >= 0), np.flatnonzero(dps < 0)):
        if branch.size == 0:
            continue
        goal = float(dps[branch][np.argmax(np.abs(dps[branch]))])
        last_valid = [StaticState(0.0, np.zeros(me.n_u), 0, 0.0)]

        def on_step(state: StaticState, goal: float = goal, last_valid=last_valid) -> None:
            if check_validity:
                bad = [b for b in static_validity(me, state) if not b.ok]
                if bad:
                    raise SolverError(
                        f"the static state at the load step Δp = {state.load:+g} Pa (of "
                        f"{goal:+g} Pa) is outside the model's validity ("
                        + "; ".join(b.describe() for b in bad)
                        + f"); last valid load step Δp = {last_valid[0].load:+g} Pa",
                        last_iterate=last_valid[0],
                        residual=last_valid[0].residual,
                    )
            last_valid[0] = state
            if progress is not None:
                dv = me.shell.pressure(_full(me, state).ravel(), 0.0)[0]
                progress(
                    f"Δp = {state.load:+9.1f} Pa (of {goal:+g}): {state.iterations} Newton "
                    f"iterations, ΔV = {dv * 1e9:+.4g} mm³"
                )

        try:
            states = load_path(res, me.n_u, dps[branch], options, on_step)
        except SolverError as exc:
            raise SolverError(
                f"TM static solution: {exc.message}", exc.last_iterate, exc.residual
            ) from None
        for i, s in zip(branch, states, strict=True):
            if check_stability:
                lam = lowest_tangent_eigenvalue(me, s)
                if lam < 0:
                    raise SolverError(
                        f"TM static solution at Δp = {s.load:g} Pa is unstable (the tangent "
                        f"with support has the eigenvalue ω² = {lam:.4g} 1/s² < 0: the load "
                        "path passed a bifurcation)",
                        last_iterate=s,
                        residual=s.residual,
                    )
            out[i] = s
    return [s for s in out if s is not None]


def lowest_tangent_eigenvalue(me: MiddleEar, state: StaticState) -> float:
    """The eigenvalue ``ω²`` nearest 0 of the TM tangent (with support) and the TM mass.

    Negative: the static state is unstable. Found by shift-invert Lanczos about 0.
    """
    res = _residual(me)
    _, k, _ = res(state.u, state.load)
    k = 0.5 * (k + k.T)
    ms = me.shell.mass()[me.free_dofs][:, me.free_dofs]
    lam = spla.eigsh(k.tocsc(), M=ms.tocsc(), k=1, sigma=0.0, which="LM")[0]
    return float(lam[0])


def _full(me: MiddleEar, state: StaticState) -> np.ndarray:
    u = np.zeros(me.shell.n_dof)
    u[me.free_dofs] = state.u
    return u.reshape(-1, 3)


def static_summary(me: MiddleEar, state: StaticState) -> dict[str, float]:
    """Volume displacement [m³] (positive medially), umbo displacement [m], support force [N]
    and the lowest in-vacuo TM frequency with support at the working point [Hz] (negative if
    the state were unstable)."""
    u = _full(me, state)
    dv, _, _ = me.shell.pressure(u, 0.0)
    lam = lowest_tangent_eigenvalue(me, state)
    f_sup = (me.support @ u.ravel()).reshape(-1, 3).sum(axis=0)
    return {
        "dp_Pa": state.load,
        "volume_displacement_m3": dv,
        "umbo_ux_m": u[me.umbo, 0],
        "umbo_uy_m": u[me.umbo, 1],
        "umbo_uz_m": u[me.umbo, 2],
        "support_force_z_N": f_sup[2],
        "tm_f1_support_Hz": math.copysign(math.sqrt(abs(lam)), lam) / (2 * math.pi),
        "newton_iterations_last_step": state.iterations,
    }


# ------------------------------------------------------------------------ linearized model
def working_point_model(
    me: MiddleEar, state: StaticState, include_support: bool = False
) -> FEModel:
    """The ``up-coupled`` FE model (Eq. (2)) linearized at a static working point.

    Parameters
    ----------
    me
        The middle-ear model.
    state
        A converged static state from :func:`solve_static`.
    include_support
        Keep the ossicular support springs in ``Ks``; by default they are left out because
        the malleus of the multibody model attaches to the manubrium nodes (the static support
        forces are in :func:`static_summary`).

    Returns
    -------
    FEModel
        DOFs ``[u (free TM nodes, ux uy uz); p canal; p cavity]``. Inputs:
        ``canal_volume_acceleration`` (a piston source at the canal entrance, per m³/s² of
        volume acceleration: ``p_ex = ρ/S ∫ N dΓ · Q̇``) and ``manubrium.<node>.u{x,y,z}``
        (forces on the interface nodes). Outputs: ``probe_pressure`` [Pa],
        ``umbo_u{x,y,z}`` [m], ``tm_volume_displacement`` [m³] (linearized) and
        ``manubrium.<node>.u{x,y,z}`` [m].
    """
    p = me.params
    shell, fi = me.shell, me.free_dofs
    u = _full(me, state)
    _, _, km = shell.membrane(u)
    _, _, kp = shell.pressure(u, state.load)
    _, grad_v, _ = shell.pressure(u, 1.0)  # ∂V/∂u: the linearized volume displacement
    ks = km + shell.bending + kp
    if include_support:
        ks = ks + me.support
    ks = ks.tocsr()[fi][:, fi]
    ks = 0.5 * (ks + ks.T)  # remove round-off asymmetry
    ms = shell.mass()[fi][:, fi]
    x = shell.points + u
    n_tm = shell.points.shape[0]
    nc = me.canal.points.shape[0]
    n_p = me.n_p
    all_nodes = np.arange(n_tm)
    c_canal = coupling_matrix(x, me.tm.triangles, all_nodes, me.canal_tm_nodes, n_tm, n_p, +1.0)
    c_cav = coupling_matrix(x, me.tm.triangles, all_nodes, nc + me.cavity_tm_nodes, n_tm, n_p, -1.0)
    c = (c_canal + c_cav).tocsr()[fi]
    w = 2 * np.pi * p.f_ref
    m, d, k = assemble_up(
        ms, ks, me.Mf, me.Kf, c, p.rho_air, ds=(p.tm_loss / w) * ks, df=(p.air_loss / w) * me.Kf
    )

    # DOF map and node table
    nu = fi.size
    ids_tm = np.arange(1, n_tm + 1)
    ids_canal = n_tm + 1 + np.arange(nc)
    ids_cav = n_tm + nc + 1 + np.arange(me.cavity.points.shape[0])
    nodes = np.vstack(
        [
            np.column_stack([ids_tm, shell.points]),
            np.column_stack([ids_canal, me.canal.points]),
            np.column_stack([ids_cav, me.cavity.points]),
        ]
    )
    kinds = np.array(["ux", "uy", "uz"])
    dof_node = np.concatenate([ids_tm[fi // 3], ids_canal, ids_cav])
    dof_kind = np.concatenate([kinds[fi % 3], np.full(n_p, "p")])

    pos = -np.ones(shell.n_dof, dtype=int)
    pos[fi] = np.arange(nu)
    inputs: dict[str, tuple[tuple[int, float], ...]] = {}
    outputs: dict[str, tuple[tuple[int, float], ...]] = {}
    load = surface_load(me.canal.points, me.canal_entrance)
    area = load.sum()
    nz = np.flatnonzero(load)
    inputs["canal_volume_acceleration"] = tuple(
        (int(nu + i), float(p.rho_air / area * load[i])) for i in nz
    )
    outputs["probe_pressure"] = tuple(
        (int(nu + n), float(wt)) for n, wt in zip(me.probe_nodes, me.probe_weights, strict=True)
    )
    for j, kname in enumerate(kinds):
        outputs[f"umbo_{kname}"] = ((int(pos[3 * me.umbo + j]), 1.0),)
    gv = grad_v.ravel()
    outputs["tm_volume_displacement"] = tuple(
        (int(pos[i]), float(gv[i])) for i in fi if gv[i] != 0.0
    )
    for node in me.tm.line:
        for j, kname in enumerate(kinds):
            name = f"manubrium.{int(ids_tm[node])}.{kname}"
            inputs[name] = ((int(pos[3 * node + j]), 1.0),)
            outputs[name] = ((int(pos[3 * node + j]), 1.0),)
    return FEModel(
        M=m,
        K=k,
        D=d,
        nodes=nodes,
        dof_node=dof_node,
        dof_kind=dof_kind,
        inputs=inputs,
        outputs=outputs,
        kind="up-coupled",
        density=p.rho_air,
        name=f"middle-ear-dp{state.load:+.0f}Pa",
    )


# ------------------------------------------------------------------------ pressure sweep
@dataclass(frozen=True, eq=False)
class SweepResult:
    """The result of :func:`pressure_sweep`: the model, the static states, the table and the
    linearized FE models (one per working point, in the order of ``pressures``)."""

    middle_ear: MiddleEar
    states: tuple[StaticState, ...]
    static: tuple[dict[str, float], ...]
    models: tuple[FEModel, ...]
    out_dir: str | None = None


def parse_pressures(text: str) -> list[float]:
    """``"start:stop:count"`` (inclusive, like ``numpy.linspace``) or a comma list, in Pa."""
    try:
        if ":" in text:
            parts = text.split(":")
            if len(parts) != 3:
                raise ValueError
            start, stop, count = float(parts[0]), float(parts[1]), int(parts[2])
            if count < 1:
                raise ValueError
            return [float(v) for v in np.linspace(start, stop, count)]
        return [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise ModelError(
            f"pressures must be 'start:stop:count' or a comma list of numbers, got {text!r}",
            "pressures",
        ) from None


def pressure_sweep(
    pressures: Sequence[float],
    params: MiddleEarParameters | None = None,
    refine: int = 2,
    out_dir: str | None = None,
    plots: bool = False,
    include_support: bool = False,
    options: NewtonOptions | None = None,
    verbose: bool = False,
    progress: Progress = None,
) -> SweepResult:
    """Static solutions and linearized ``up-coupled`` FE models over static pressures ``Δp``.

    Parameters
    ----------
    pressures
        Static pressure differences ``Δp = p_canal − p_cavity`` [Pa].
    params, refine
        See :func:`build_middle_ear`.
    out_dir
        If given, write (atomically, see :mod:`neweul_py.fem.output`) ``model_dp±NNNNN.npz``
        per working point, ``static.csv``, ``static_displacements.npz`` (TM node displacements
        per working point) and ``sweep.json`` (and PNGs with ``plots``).
    plots
        Also draw the mesh, the static deflection at the extreme pressures and the first TM
        modes at ``Δp = 0`` (needs matplotlib).
    include_support
        Keep the ossicular support in the exported ``Ks`` (see :func:`working_point_model`).
    options
        Newton options.
    verbose
        Print the DOF counts and the static results (stdout).
    progress
        Called with a short message per converged load step and per working point (the CLI
        prints them on stderr).

    Returns
    -------
    SweepResult

    Raises
    ------
    ModelError
        Bad parameters or pressures; SolverError: a pressure beyond Newton convergence or
        beyond the physical validity of the model (:func:`static_validity`, checked after every
        load step). In either case nothing is written.

    Examples
    --------
    >>> res = pressure_sweep([-4000.0, 0.0, 4000.0], refine=0)
    >>> [m.kind for m in res.models]
    ['up-coupled', 'up-coupled', 'up-coupled']
    >>> res.static[2]["volume_displacement_m3"] > 0  # Δp > 0 pushes the TM medially
    True
    """
    dps = [float(v) for v in pressures]
    if not dps or not all(math.isfinite(v) for v in dps):
        raise ModelError("need at least one finite pressure", "pressures")
    if len(set(dps)) != len(dps):
        raise ModelError("pressures must be distinct", "pressures")
    if plots:
        from .plots import require_matplotlib

        require_matplotlib()
    if out_dir is not None:
        from .output import check_output_dir

        check_output_dir(out_dir)  # fail before the work, checked again when writing
    me = build_middle_ear(params, refine, verbose=verbose)
    states = solve_static(me, dps, options, progress=progress)
    table = tuple(static_summary(me, s) for s in states)
    if verbose:
        for row in table:
            print(
                "  Δp = {:+8.1f} Pa: ΔV = {:+.4g} mm³, umbo u_z = {:+.4g} µm".format(
                    row["dp_Pa"], row["volume_displacement_m3"] * 1e9, row["umbo_uz_m"] * 1e6
                )
            )
    models = []
    for i, s in enumerate(states):
        report(progress, f"working point {i + 1}/{len(states)}: FE model at Δp = {s.load:+g} Pa",
               i + 1, len(states))
        models.append(working_point_model(me, s, include_support))
    if out_dir is not None:
        if progress is not None:
            progress(f"writing {out_dir}")
        _write_sweep(me, states, table, models, out_dir, plots, include_support)
    models = tuple(models)
    return SweepResult(me, tuple(states), table, models, out_dir)


def _write_sweep(me, states, table, models, out_dir, plots, include_support) -> None:
    from dataclasses import asdict

    from .output import write_directory_atomically, write_model, write_static_csv

    def fill(tmp):
        files = []
        for s, fe in zip(states, models, strict=True):
            name = f"model_dp{s.load:+06.0f}.npz"
            write_model(fe, tmp / name)
            files.append({"dp_Pa": s.load, "file": name, "n_dofs": fe.n_dofs})
        write_static_csv(list(table), tmp / "static.csv")
        disp = np.stack([_full(me, s) for s in states])
        np.savez(
            tmp / "static_displacements.npz",
            dp_Pa=np.array([s.load for s in states]),
            node_id=np.arange(1, me.tm.points.shape[0] + 1),
            reference=me.tm.points,
            u=disp,
        )
        pictures = []
        if plots:
            from .plots import plot_mesh, plot_static, plot_tm_modes

            pictures.append(plot_mesh(me, tmp / "mesh.png").name)
            loads = [s.load for s in states]
            ext = sorted({int(np.argmin(loads)), int(np.argmax(loads))})
            pictures.append(plot_static(me, [states[i] for i in ext], tmp / "static.png").name)
            zero = int(np.argmin(np.abs(loads)))
            pictures.append(plot_tm_modes(me, states[zero], tmp / "tm_modes.png").name)
        return {
            "format": "neweul-fem-sweep",
            "version": 1,
            "description": "TM + ear canal + tympanic cavity, linearized at static pressures "
            "dp = p_canal - p_cavity (Eq. (2) of the seed paper, u-p form)",
            "refine": me.refine,
            "parameters": asdict(me.params),
            "dof_counts": me.dof_counts(),
            "support_in_K": include_support,
            "interface_nodes": {
                "manubrium": [int(n) + 1 for n in me.tm.line],
                "umbo": int(me.umbo) + 1,
            },
            "working_points": files,
            "static_results": "static.csv",
            "static_displacements": "static_displacements.npz (dp_Pa, node_id, reference, "
            "u[point, node, xyz]) of the TM nodes [m]",
            "pictures": pictures,
        }

    write_directory_atomically(out_dir, fill)
