"""Linear-elastic solid elements (Hex8, Hex20, Tet10) on box meshes, and their stress stiffness.

Isotropic linear elasticity, ``σ = λ tr(ε) I + 2μ ε``, ``ε = sym ∇u``, with the element
families of scikit-fem on a structured box mesh (``MeshHex``/``MeshTet.init_tensor``):

* ``"hex8"``: trilinear brick (``ElementHex1``; locks in bending: use several elements
  through the thickness or Hex20),
* ``"hex20"``: serendipity quadratic brick (``ElementHexS2``),
* ``"tet10"``: quadratic tetrahedron (``ElementTetP2``), six tets per box cell.

``K = ∫ ε(v) : σ(u) dV`` and the consistent mass ``M = ρ ∫ v·u dV`` are assembled by
scikit-fem (vectorized over all elements; Gauss rules of the element's degree). Nodes are the
element's DOF locations (vertices, and edge midpoints of the quadratic elements), with DOFs
``ux, uy, uz``.

Stress stiffening: :meth:`SolidModel.geometric_stiffness` is the initial-stress matrix

    K_G(u) = ∫ B_NLᵀ σ B_NL dV,   (K_G)_{ak,bk} = ∫ σ_ij ∂_i N_a ∂_j N_b dV,

of the linear stress ``σ(u)`` of a displacement ``u`` (the second variation of
``∫ σ : E_NL dV`` with the Green–Lagrange strain's quadratic part
``E_NL = ½ ∇uᵀ∇u``; Bathe, *Finite Element Procedures*, 1996, §6.2.3; Zienkiewicz & Taylor,
*The Finite Element Method*, vol. 2, ch. 6), the function that
:func:`neweul_py.elastic.reductors.invariants.stress_stiffening` needs.
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

__all__ = ["SOLID_ELEMENTS", "SolidMaterial", "SolidModel", "solid_box"]

#: Element families of :func:`solid_box`.
SOLID_ELEMENTS = ("hex8", "hex20", "tet10")


@dataclass(frozen=True)
class SolidMaterial:
    """Isotropic linear-elastic material: Young's modulus, Poisson ratio, density."""

    E: float = 1.0
    nu: float = 0.3
    rho: float = 1.0

    def __post_init__(self) -> None:
        for name in ("E", "rho"):
            v = getattr(self, name)
            real = isinstance(v, numbers.Real) and not isinstance(v, bool)
            if not (real and np.isfinite(v) and v > 0):
                raise ModelError(f"must be a positive number, got {v!r}", f"material.{name}")
        if not (isinstance(self.nu, numbers.Real) and -1.0 < self.nu < 0.5):
            raise ModelError(f"Poisson ratio must be in (-1, 0.5), got {self.nu!r}",
                             "material.nu")

    @property
    def lame(self) -> tuple[float, float]:
        """Lamé parameters ``λ = Eν/((1+ν)(1−2ν))``, ``μ = E/(2(1+ν))``."""
        E, nu = self.E, self.nu
        return E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))


def _element(kind: str):
    import skfem

    if kind == "hex8":
        return skfem.ElementHex1(), skfem.MeshHex
    if kind == "hex20":
        return skfem.ElementHexS2(), skfem.MeshHex
    if kind == "tet10":
        return skfem.ElementTetP2(), skfem.MeshTet
    raise ModelError(f"unknown solid element {kind!r} (one of {', '.join(SOLID_ELEMENTS)})",
                     "element")


def _stress(grad_u: np.ndarray, lam: float, mu: float) -> np.ndarray:
    """Linear stress ``λ tr(ε) I + 2μ ε`` of displacement gradients (3, 3, …)."""
    eps = 0.5 * (grad_u + np.swapaxes(grad_u, 0, 1))
    tr = np.einsum("ii...->...", eps)
    return lam * np.einsum("ij,...->ij...", np.eye(3), tr) + 2 * mu * eps


@dataclass(frozen=True, eq=False)
class SolidModel:
    """A solid FE model and the scikit-fem basis its stress stiffness is assembled on.

    Attributes
    ----------
    fe
        The :class:`~neweul_py.elastic.fe_model.FEModel` (node ids ``first_id …``,
        DOFs ``ux, uy, uz`` node-major).
    basis
        The scikit-fem ``Basis`` of ``ElementVector(element)`` (DOF ``3k + c`` is component
        ``c`` of node ``k``, the same order as ``fe``).
    material
        The :class:`SolidMaterial`.
    element
        One of :data:`SOLID_ELEMENTS`.
    node_sets
        ``"root"`` (face ``x = x0``), ``"tip"`` (face ``x = x0 + Lx``), ``"all"``.
    """

    fe: FEModel
    basis: object
    material: SolidMaterial
    element: str
    node_sets: Mapping[str, np.ndarray] = field(default_factory=dict)

    def stress(self, u: np.ndarray) -> np.ndarray:
        """(3, 3, ne, nqp) linear stress of ``u`` at the quadrature points."""
        lam, mu = self.material.lame
        return _stress(np.asarray(self.basis.interpolate(np.asarray(u, float)).grad), lam, mu)

    def geometric_stiffness(self, u: np.ndarray) -> sps.csr_matrix:
        """Initial-stress matrix ``∫ σ_ij ∂_i v_k ∂_j w_k dV`` of the linear stress of ``u``."""
        from skfem import BilinearForm, asm

        lam, mu = self.material.lame

        @BilinearForm
        def initial_stress(a, b, w):
            s = _stress(w["u"].grad, lam, mu)
            return np.einsum("ij...,ki...,kj...->...", s, a.grad, b.grad)

        u = np.asarray(u, dtype=np.float64)
        if u.shape != (self.fe.n_dofs,):
            raise ModelError(f"displacement has shape {u.shape}, expected "
                             f"({self.fe.n_dofs},)", "u")
        return sps.csr_matrix(asm(initial_stress, self.basis, u=self.basis.interpolate(u)))

    def stiffening(self, support: Sequence[int] | None = None,
                   cases: Sequence[str] = LOAD_CASES) -> dict[str, sps.csr_matrix]:
        """``K_G,c`` of the 12 unit inertia load cases, the root face (or ``support``) fixed
        (:func:`neweul_py.elastic.reductors.invariants.stress_stiffening`)."""
        fixed = self.fe.dofs_of_nodes(self.node_sets["root"]) if support is None else support
        return stress_stiffening(self.fe, self.geometric_stiffness, fixed, cases)

    def stiffening_responses(self, support: Sequence[int] | None = None,
                             cases: Sequence[str] = LOAD_CASES) -> dict[str, np.ndarray]:
        """The static responses ``u_c`` of the same load cases and support as
        :meth:`stiffening` (:func:`neweul_py.elastic.reductors.invariants.inertia_responses`): the
        span of the body's second-order field (``docs/equations.md`` §2.3)."""
        fixed = self.fe.dofs_of_nodes(self.node_sets["root"]) if support is None else support
        return inertia_responses(self.fe, fixed, cases)


def solid_box(
    lengths: Sequence[float] = (1.0, 0.1, 0.1),
    divisions: Sequence[int] = (10, 1, 1),
    material: SolidMaterial | None = None,
    *,
    element: str = "hex20",
    origin: Sequence[float] = (0.0, 0.0, 0.0),
    first_id: int = 1,
    name: str = "solid",
) -> SolidModel:
    """A free box ``[x0, x0+Lx] × [y0, y0+Ly] × [z0, z0+Lz]`` of solid elements.

    Parameters
    ----------
    lengths
        Edge lengths ``Lx, Ly, Lz`` (a cantilever: x the long axis).
    divisions
        Cells per direction (Tet10: six tetrahedra per cell).
    material
        The :class:`SolidMaterial` (default ``E = 1, ν = 0.3, ρ = 1``).
    element
        ``"hex8"``, ``"hex20"`` or ``"tet10"``.
    origin
        The corner ``(x0, y0, z0)``.
    first_id, name
        Id of the first node, name of the FE model.

    Returns
    -------
    SolidModel

    Raises
    ------
    ModelError
        Unknown element, non-positive lengths or divisions.

    Examples
    --------
    >>> s = solid_box((1.0, 0.1, 0.05), (8, 2, 1), element="hex20")
    >>> s.fe.n_dofs, s.node_sets["root"].size
    (822, 13)
    """
    from skfem import Basis, BilinearForm, ElementVector, asm
    from skfem.helpers import dot

    mat = SolidMaterial() if material is None else material
    el, mesh_type = _element(element)
    L = np.asarray(lengths, dtype=np.float64)
    nd = np.asarray(divisions)
    if L.shape != (3,) or not np.all(np.isfinite(L) & (L > 0)):
        raise ModelError(f"three positive lengths needed, got {lengths!r}", "lengths")
    if nd.shape != (3,) or not np.all(nd == np.round(nd)) or np.any(nd < 1):
        raise ModelError(f"three positive integer divisions needed, got {divisions!r}",
                         "divisions")
    o = np.asarray(origin, dtype=np.float64)
    axes = [o[i] + np.linspace(0.0, L[i], int(nd[i]) + 1) for i in range(3)]
    mesh = mesh_type.init_tensor(*axes)
    basis = Basis(mesh, ElementVector(el))
    lam, mu = mat.lame

    @BilinearForm
    def elasticity(a, b, _):
        return np.einsum("ij...,ij...->...", _stress(a.grad, lam, mu),
                         0.5 * (b.grad + np.swapaxes(b.grad, 0, 1)))

    @BilinearForm
    def mass(a, b, _):
        return mat.rho * dot(a, b)

    K = sps.csr_matrix(asm(elasticity, basis))
    M = sps.csr_matrix(asm(mass, basis))
    K = 0.5 * (K + K.T)
    M = 0.5 * (M + M.T)
    xyz = np.asarray(basis.doflocs)[:, 0::3].T
    nn = xyz.shape[0]
    ids = int(first_id) + np.arange(nn)
    nodes = np.column_stack([ids, xyz])
    fe = FEModel(M=M, K=K, D=None, nodes=nodes, dof_node=np.repeat(ids, 3),
                 dof_kind=np.tile(np.array(["ux", "uy", "uz"]), nn), name=name,
                 symmetric={"M": True, "K": True})
    tol = 1e-9 * L.max()
    sets = {"root": ids[np.abs(xyz[:, 0] - o[0]) <= tol],
            "tip": ids[np.abs(xyz[:, 0] - o[0] - L[0]) <= tol], "all": ids}
    return SolidModel(fe, basis, mat, element, sets)
