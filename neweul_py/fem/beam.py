"""Straight Euler–Bernoulli and Timoshenko beam FE models, 2-D and 3-D (vectorized assembly).

The beam lies on the line ``(x0 + s, y0, z0)``, ``0 ≤ s ≤ L``, along the node positions ``s``
(uniform by default). DOFs per node: ``ux, uy, uz, rx, ry, rz`` (3-D) or ``ux, uy, rz``
(2-D, bending in the x-y plane). Each element is

* a bar (axial ``u``, linear; consistent mass ``ρAh/6 [2 1; 1 2]``) and, in 3-D, a torsion
  rod (``G Jt``, polar mass inertia ``ρ(Iy + Iz)``);
* per bending plane (x-y: ``uy, rz`` with ``θz = v'``; x-z: ``uz, ry`` with ``θy = −w'``)
  the two-node *interdependent-interpolation* element of Friedman & Kosmatka (Computers &
  Structures 47 (1993) 473–481): cubic ``w`` and quadratic ``θ`` that solve the homogeneous
  Timoshenko equations exactly, with ``Φ = 12 EI / (κ G A h²)``. All element matrices are
  integrated from these shape functions (4-point Gauss, exact):
  stiffness ``EI ∫ θ'ᵀθ' + κGA ∫ (w' − θ)ᵀ(w' − θ)`` (the classical
  ``EI/((1+Φ)h³) [12, 6h, −12, 6h; …, (4+Φ)h², …, (2−Φ)h²; …]``), mass
  ``ρA ∫ NwᵀNw + ρI ∫ NθᵀNθ`` and geometric stiffness of an axial force ``N``:
  ``N ∫ Nw'ᵀ Nw'``. ``Φ = 0`` is the Euler–Bernoulli element (cubic Hermite, ``θ = w'``):
  ``EI/h³ [12 6h −12 6h; …]``, ``ρAh/420 [156 22h 54 −13h; …]``, rotary inertia
  ``ρI/(30h) [36 3h −36 3h; …]`` and ``N/(30h) [36 3h −36 3h; …]`` (Przemieniecki,
  *Theory of Matrix Structural Analysis*, 1968).

Euler–Bernoulli beams have no rotary inertia unless ``rotary=True``; Timoshenko beams have it
(``rotary`` defaults to ``True`` there). ``lumped=True`` gives a diagonal mass matrix (half the
element mass to each node; with ``rotary`` half the section rotary inertia to the rotational
DOFs, else none: particles).

Stress stiffening (Wallrapp 1994): :meth:`BeamModel.geometric_stiffness` is ``K_G`` of the
element axial forces ``N_e = EA (u₂ − u₁)/h`` of a displacement ``u``, the function that
:func:`neweul_py.elastic.reductors.invariants.stress_stiffening` needs; :meth:`BeamModel.stiffening`
runs that procedure with the root clamped.
"""

from __future__ import annotations

import numbers
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sps

from ..elastic.bodies.invariants import LOAD_CASES
from ..elastic.fe_model import FEModel
from ..elastic.reductors.invariants import inertia_responses, stress_stiffening
from ..errors import ModelError
from .assembly import assemble_matrix

__all__ = ["BEAM_THEORIES", "BeamModel", "BeamSection", "beam_model", "beam_plane_matrices"]

#: Beam theories of :func:`beam_model`.
BEAM_THEORIES = ("euler-bernoulli", "timoshenko")
_KINDS_3D = ("ux", "uy", "uz", "rx", "ry", "rz")
_KINDS_2D = ("ux", "uy", "rz")
_GAUSS_XI, _GAUSS_W = np.polynomial.legendre.leggauss(4)
_GAUSS_XI, _GAUSS_W = (_GAUSS_XI + 1.0) / 2.0, _GAUSS_W / 2.0


@dataclass(frozen=True)
class BeamSection:
    """Material and cross-section of a uniform beam (SI units or any consistent set).

    Parameters
    ----------
    E, G
        Young's and shear modulus.
    rho
        Density.
    A
        Cross-section area.
    Iy, Iz
        Second moments of area about y (bending in x-z) and z (bending in x-y).
    Jt
        Torsion constant (default ``Iy + Iz``, a circular-like section).
    shear_factor
        Timoshenko shear correction factor ``κ`` (5/6: rectangle).
    """

    E: float = 1.0
    G: float = 0.4
    rho: float = 1.0
    A: float = 1.0
    Iy: float = 1.0e-4
    Iz: float = 1.0e-4
    Jt: float | None = None
    shear_factor: float = 5.0 / 6.0

    def __post_init__(self) -> None:
        for name in ("E", "G", "rho", "A", "Iy", "Iz", "shear_factor"):
            v = getattr(self, name)
            real = isinstance(v, numbers.Real) and not isinstance(v, bool)
            if not (real and np.isfinite(v) and v > 0):
                raise ModelError(f"must be a positive number, got {v!r}", f"section.{name}")
        if self.Jt is not None and not (np.isfinite(self.Jt) and self.Jt > 0):
            raise ModelError(f"must be a positive number, got {self.Jt!r}", "section.Jt")

    @property
    def torsion_constant(self) -> float:
        """``Jt`` (default ``Iy + Iz``)."""
        return self.Iy + self.Iz if self.Jt is None else float(self.Jt)

    @classmethod
    def rectangle(cls, width: float, height: float, *, E: float, nu: float = 0.3,
                  rho: float = 1.0) -> BeamSection:
        """A solid ``width`` (y) × ``height`` (z) rectangle: ``A = bh``, ``Iy = bh³/12``,
        ``Iz = hb³/12``, Saint-Venant ``Jt ≈ β b h³`` (Roark: ``β = ⅓ − 0.21 (h/b)(1 −
        (h/b)⁴/12)`` with ``h ≤ b``), ``G = E/(2(1+ν))``, ``κ = 10(1+ν)/(12+11ν)`` (Cowper)."""
        b, h = max(width, height), min(width, height)
        beta = 1.0 / 3.0 - 0.21 * (h / b) * (1.0 - (h / b) ** 4 / 12.0)
        return cls(E=E, G=E / (2 * (1 + nu)), rho=rho, A=width * height,
                   Iy=width * height**3 / 12, Iz=height * width**3 / 12, Jt=beta * b * h**3,
                   shear_factor=10 * (1 + nu) / (12 + 11 * nu))


def _plane_shapes(h: np.ndarray, phi: np.ndarray) -> tuple[np.ndarray, ...]:
    """Interdependent shape functions at the Gauss points, DOFs ``w1 θ1 w2 θ2``.

    Returns ``Nw, Nw', Nθ, Nθ'`` each (ne, ng, 4) (derivatives with respect to ``x``).
    Friedman & Kosmatka (1993), Eqs. (14)–(15); ``Φ = 0``: cubic Hermite, ``θ = w'``.
    """
    x = _GAUSS_XI[None, :]
    hh, p = h[:, None], phi[:, None]
    c = 1.0 / (1.0 + p)
    one = np.ones_like(x * hh)
    nw = np.stack([c * (2 * x**3 - 3 * x**2 - p * x + 1 + p),
                   c * hh * (x**3 - (2 + p / 2) * x**2 + (1 + p / 2) * x),
                   -c * (2 * x**3 - 3 * x**2 - p * x),
                   c * hh * (x**3 - (1 - p / 2) * x**2 - (p / 2) * x)], axis=-1)
    dnw = np.stack([c * (6 * x**2 - 6 * x - p),
                    c * hh * (3 * x**2 - (4 + p) * x + (1 + p / 2)),
                    -c * (6 * x**2 - 6 * x - p),
                    c * hh * (3 * x**2 - (2 - p) * x - p / 2)], axis=-1) / hh[..., None]
    nt = np.stack([6 * c / hh * (x**2 - x), c * (3 * x**2 - (4 + p) * x + 1 + p),
                   -6 * c / hh * (x**2 - x), c * (3 * x**2 - (2 - p) * x)], axis=-1)
    dnt = np.stack([6 * c / hh * (2 * x - 1) * one, c * (6 * x - (4 + p)) * one,
                    -6 * c / hh * (2 * x - 1) * one, c * (6 * x - (2 - p)) * one],
                   axis=-1) / hh[..., None]
    return nw, dnw, nt, dnt


def beam_plane_matrices(h: np.ndarray, EI: float, kGA: float | None, rhoA: float,
                        rhoI: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Element matrices of one bending plane, DOFs ``w1 θ1 w2 θ2`` with ``θ = w'``.

    Parameters
    ----------
    h
        (ne,) element lengths.
    EI, kGA
        Bending and shear stiffness; ``kGA=None`` is Euler–Bernoulli (``Φ = 0``).
    rhoA, rhoI
        Mass per length and rotary inertia per length (0: none).

    Returns
    -------
    K, M, G
        (ne, 4, 4) stiffness, mass and unit-axial-force geometric stiffness (module
        docstring; Friedman & Kosmatka 1993).
    """
    h = np.asarray(h, dtype=np.float64)
    phi = np.zeros_like(h) if kGA is None else 12.0 * EI / (kGA * h**2)
    nw, dnw, nt, _ = _plane_shapes(h, phi)
    wh = _GAUSS_W[None, :] * h[:, None]

    def integral(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return np.einsum("eg,egi,egj->eij", wh, a, b)

    # closed form of EI ∫ θ'ᵀθ' + κGA ∫ γᵀγ (exact, and free of quadrature round-off so that
    # rigid-body motions stay exact null vectors)
    L, P = h[:, None, None], phi[:, None, None]
    one = np.ones_like(L)
    K = EI * (np.concatenate([
        np.concatenate([12 * one, 6 * L, -12 * one, 6 * L], axis=2),
        np.concatenate([6 * L, (4 + P) * L**2, -6 * L, (2 - P) * L**2], axis=2),
        np.concatenate([-12 * one, -6 * L, 12 * one, -6 * L], axis=2),
        np.concatenate([6 * L, (2 - P) * L**2, -6 * L, (4 + P) * L**2], axis=2)],
        axis=1) / L**3) / (1 + P)
    M = rhoA * integral(nw, nw)
    if rhoI:
        M = M + rhoI * integral(nt, nt)
    G = integral(dnw, dnw)
    return K, M, G


@dataclass(frozen=True, eq=False)
class BeamModel:
    """A beam FE model and the element data its stress stiffness needs.

    Attributes
    ----------
    fe
        The :class:`~neweul_py.elastic.fe_model.FEModel` (node ids ``first_id …``).
    positions
        (nn,) node positions ``s`` along the axis.
    section
        The :class:`BeamSection`.
    theory
        One of :data:`BEAM_THEORIES`.
    planar
        2-D (``ux, uy, rz``) or 3-D (6 DOFs per node).
    node_sets
        ``"root"`` (first node), ``"tip"`` (last node), ``"all"``.
    unit_geometric
        (ne, 2k, 2k) element geometric stiffness of a unit axial force (local DOFs).
    lengths
        (ne,) element lengths.
    """

    fe: FEModel
    positions: np.ndarray
    section: BeamSection
    theory: str
    planar: bool
    node_sets: Mapping[str, np.ndarray] = field(default_factory=dict)
    unit_geometric: np.ndarray | None = None
    lengths: np.ndarray | None = None

    @property
    def dofs_per_node(self) -> int:
        return 3 if self.planar else 6

    @property
    def n_elements(self) -> int:
        return self.positions.size - 1

    def dof(self, node: int, kind: str) -> int:
        """Index of DOF ``kind`` (``"ux"`` …) of node number ``node`` (0-based)."""
        kinds = _KINDS_2D if self.planar else _KINDS_3D
        return self.dofs_per_node * node + kinds.index(kind)

    def node_dofs(self, node: int) -> np.ndarray:
        """All DOF indices of node number ``node`` (0-based; −1: the tip)."""
        node = node % self.positions.size
        return self.dofs_per_node * node + np.arange(self.dofs_per_node)

    @property
    def element_lengths(self) -> np.ndarray:
        """(ne,) element lengths ``h``."""
        return self.lengths

    def axial_forces(self, u: np.ndarray) -> np.ndarray:
        """(ne,) element axial forces ``N_e = EA (u₂ − u₁)/h`` of a displacement ``u``."""
        ux = np.asarray(u, dtype=np.float64)[0::self.dofs_per_node]
        return self.section.E * self.section.A * np.diff(ux) / self.element_lengths

    def geometric_stiffness_of_forces(self, N: np.ndarray) -> sps.csr_matrix:
        """``K_G = Σ_e N_e ∫ Nw'ᵀ Nw'`` (both bending planes in 3-D) of axial forces ``N``."""
        N = np.asarray(N, dtype=np.float64).reshape(-1)
        if N.shape != (self.n_elements,):
            raise ModelError(f"{N.size} axial forces for {self.n_elements} elements",
                             "axial_forces")
        return assemble_matrix(N[:, None, None] * self.unit_geometric, _element_dofs(self),
                               self.fe.n_dofs)

    def geometric_stiffness(self, u: np.ndarray) -> sps.csr_matrix:
        """``K_G`` of the axial forces of the displacement ``u`` (see the module docstring)."""
        return self.geometric_stiffness_of_forces(self.axial_forces(u))

    def stiffening(self, support: Sequence[int] | None = None,
                   cases: Sequence[str] = LOAD_CASES) -> dict[str, sps.csr_matrix]:
        """``K_G,c`` of the 12 unit inertia load cases with the root (or ``support``) fixed.

        Calls :func:`neweul_py.elastic.reductors.invariants.stress_stiffening` with
        :meth:`geometric_stiffness`; the result goes to ``compute_invariants(…,
        geometric_stiffness=…)`` or into an FE file (``write_fe_model(…, stiffening=…)``).
        """
        fixed = self.node_dofs(0) if support is None else np.asarray(support)
        return stress_stiffening(self.fe, self.geometric_stiffness, fixed, cases)

    def stiffening_responses(self, support: Sequence[int] | None = None,
                             cases: Sequence[str] = LOAD_CASES) -> dict[str, np.ndarray]:
        """The static responses ``u_c`` of the same load cases and support as
        :meth:`stiffening` (:func:`neweul_py.elastic.reductors.invariants.inertia_responses`): the
        span of the body's second-order field (``docs/equations.md`` §2.3)."""
        fixed = self.node_dofs(0) if support is None else np.asarray(support)
        return inertia_responses(self.fe, fixed, cases)


def _element_dofs(b: BeamModel) -> np.ndarray:
    k = b.dofs_per_node
    return k * np.arange(b.n_elements)[:, None] + np.arange(2 * k)[None, :]


def beam_model(
    length: float = 1.0,
    n_elements: int = 20,
    section: BeamSection | None = None,
    *,
    theory: str = "euler-bernoulli",
    planar: bool = False,
    positions: Sequence[float] | None = None,
    origin: Sequence[float] = (0.0, 0.0, 0.0),
    rotary: bool | None = None,
    lumped: bool = False,
    first_id: int = 1,
    name: str = "beam",
) -> BeamModel:
    """A straight beam along x (module docstring), unsupported (free-free).

    Parameters
    ----------
    length, n_elements
        Length and number of equal elements (ignored when ``positions`` is given).
    section
        Material and cross-section (default :class:`BeamSection` ``()``).
    theory
        ``"euler-bernoulli"`` or ``"timoshenko"`` (shear deformation + rotary inertia).
    planar
        2-D beam in the x-y plane (``ux, uy, rz``) instead of 3-D.
    positions
        Increasing node positions ``s`` along the axis (a graded mesh).
    origin
        Position of the node at ``s = 0``.
    rotary
        Rotary inertia of the sections (default: ``True`` for Timoshenko, ``False`` for
        Euler–Bernoulli).
    lumped
        Diagonal (lumped) mass matrix.
    first_id
        Id of the first node; ids increase by one along the beam.
    name
        Name of the FE model.

    Returns
    -------
    BeamModel
        ``.fe`` is the FE model, ``.node_sets`` ``root``/``tip``/``all``.

    Raises
    ------
    ModelError
        Unknown theory, non-increasing positions, fewer than one element.

    References
    ----------
    Przemieniecki (1968); Friedman & Kosmatka, Computers & Structures 47 (1993) 473–481.

    Examples
    --------
    >>> b = beam_model(2.0, 10, BeamSection(E=70e9, G=26e9, rho=2700, A=1e-4, Iy=1e-9,
    ...                                     Iz=1e-9), theory="timoshenko")
    >>> b.fe.n_dofs
    66
    """
    if theory not in BEAM_THEORIES:
        raise ModelError(f"unknown beam theory {theory!r} (one of {', '.join(BEAM_THEORIES)})",
                         "theory")
    sec = BeamSection() if section is None else section
    if positions is None:
        if not (isinstance(n_elements, int | np.integer) and n_elements >= 1):
            raise ModelError(f"needs at least one element, got {n_elements!r}", "n_elements")
        if not (np.isfinite(length) and length > 0):
            raise ModelError(f"must be positive, got {length!r}", "length")
        s = np.linspace(0.0, float(length), int(n_elements) + 1)
    else:
        s = np.asarray(positions, dtype=np.float64)
        if s.ndim != 1 or s.size < 2 or not np.all(np.diff(s) > 0):
            raise ModelError("node positions must increase (at least two nodes)", "positions")
    # uniform meshes get exactly equal elements (np.diff of linspace is not)
    h = np.diff(s) if positions is not None else np.full(s.size - 1, s[-1] / (s.size - 1))
    ne, nn = h.size, s.size
    timo = theory == "timoshenko"
    rot = timo if rotary is None else bool(rotary)
    k = 3 if planar else 6
    kGA = sec.shear_factor * sec.G * sec.A if timo else None
    Kz, Mz, Gz = beam_plane_matrices(h, sec.E * sec.Iz, kGA, sec.rho * sec.A,
                                     sec.rho * sec.Iz if rot else 0.0)
    ke = np.zeros((ne, 2 * k, 2 * k))
    me = np.zeros_like(ke)
    ge = np.zeros_like(ke)
    bar_k = np.array([[1.0, -1.0], [-1.0, 1.0]])[None] / h[:, None, None]
    bar_m = np.array([[2.0, 1.0], [1.0, 2.0]])[None] * h[:, None, None] / 6
    ax = np.ix_(range(ne), [0, k], [0, k])
    ke[ax] = sec.E * sec.A * bar_k
    me[ax] = sec.rho * sec.A * bar_m
    xy = [1, 2, 4, 5] if planar else [1, 5, 7, 11]
    sel = np.ix_(range(ne), xy, xy)
    ke[sel], me[sel], ge[sel] = Kz, Mz, Gz
    if not planar:
        Jt = sec.torsion_constant
        tor = np.ix_(range(ne), [3, 9], [3, 9])
        ke[tor] = sec.G * Jt * bar_k
        me[tor] = sec.rho * (sec.Iy + sec.Iz) * bar_m
        Ky, My, Gy = beam_plane_matrices(h, sec.E * sec.Iy, kGA, sec.rho * sec.A,
                                         sec.rho * sec.Iy if rot else 0.0)
        flip = np.diag([1.0, -1.0, 1.0, -1.0])        # θy = −w'
        xz = np.ix_(range(ne), [2, 4, 8, 10], [2, 4, 8, 10])
        ke[xz], me[xz], ge[xz] = flip @ Ky @ flip, flip @ My @ flip, flip @ Gy @ flip
    if lumped:
        me = np.zeros_like(ke)
        half = sec.rho * sec.A * h / 2
        if planar:
            diag = [half, half, sec.rho * sec.Iz * h / 2 if rot else 0 * h]
        else:
            r = [sec.rho * (sec.Iy + sec.Iz) * h / 2, sec.rho * sec.Iy * h / 2,
                 sec.rho * sec.Iz * h / 2] if rot else [0 * h] * 3
            diag = [half, half, half, *r]
        d = np.stack(diag + diag, axis=1)
        me[:, np.arange(2 * k), np.arange(2 * k)] = d
    dofs = k * np.arange(ne)[:, None] + np.arange(2 * k)[None, :]
    n = k * nn
    K = assemble_matrix(ke, dofs, n)
    M = assemble_matrix(me, dofs, n)
    ids = int(first_id) + np.arange(nn)
    o = np.asarray(origin, dtype=np.float64)
    nodes = np.column_stack([ids, s + o[0], np.full(nn, o[1]), np.full(nn, o[2])])
    kinds = np.tile(np.array(_KINDS_2D if planar else _KINDS_3D), nn)
    fe = FEModel(M=M, K=K, D=None, nodes=nodes, dof_node=np.repeat(ids, k), dof_kind=kinds,
                 name=name, symmetric={"M": True, "K": True})
    sets = {"root": ids[:1], "tip": ids[-1:], "all": ids}
    return BeamModel(fe, s, sec, theory, planar, sets, ge, h)
