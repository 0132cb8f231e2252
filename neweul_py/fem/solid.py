"""Linear-elastic solid elements (Hex8, Hex20, Tet10) on box meshes, and their stress stiffness.

Isotropic linear elasticity, ``σ = λ tr(ε) I + 2μ ε``, ``ε = sym ∇u``, with the element
families of scikit-fem on a structured box mesh (``MeshHex``/``MeshTet.init_tensor``):

* ``"hex8"``: trilinear brick (``ElementHex1``; locks in bending: use several elements
  through the thickness or Hex20),
* ``"hex20"``: serendipity quadratic brick (``ElementHexS2``),
* ``"tet10"``: quadratic tetrahedron (``ElementTetP2``), six tets per box cell.

``K = ∫ ε(v) : σ(u) dV`` and the consistent mass ``M = ρ ∫ v·u dV`` are integrated with
the shape functions and Gauss rules of scikit-fem's *scalar* element (rule of the element's
degree), all elements at once: with ``N_a`` the shape functions of an element and ``dV`` the
quadrature weights times ``|det J|``, the element blocks are

    K_{ai,bj} = Σ_q dV (λ ∂_i N_a ∂_j N_b + μ ∂_j N_a ∂_i N_b + μ δ_ij ∇N_a·∇N_b),
    M_{ai,bj} = ρ δ_ij Σ_q dV N_a N_b

(one batched matrix product per element set, then one sparse scatter), the same integrals
scikit-fem's generic assembly of the vector form evaluates pair of local DOFs by pair. Nodes
are the element's DOF locations (vertices, and edge midpoints of the quadratic elements), with
DOFs ``ux, uy, uz``.

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
from functools import cached_property

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


def _shape_functions(basis) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Values (nb, ne, nq), gradients (nb, 3, ne, nq) and weights ``dV`` (ne, nq) of the
    scalar shape functions of a scikit-fem ``CellBasis`` at its quadrature points."""
    values = np.stack([np.asarray(f[0]) for f in basis.basis])
    grads = np.stack([np.asarray(f[0].grad) for f in basis.basis])
    return values, grads, np.asarray(basis.dx)


def _vector_dofs(element_dofs: np.ndarray) -> np.ndarray:
    """(ne, nb, 3) global DOFs ``3k + c`` of the local nodes ``k`` (element_dofs (nb, ne))."""
    return 3 * element_dofs.T[:, :, None] + np.arange(3)


def _scatter(blocks: np.ndarray, dofs: np.ndarray, n: int) -> sps.csr_matrix:
    """Sum element blocks (ne, m, m) into an ``n × n`` CSR matrix, ``dofs`` (ne, m)."""
    m = dofs.shape[1]
    rows = np.broadcast_to(dofs[:, :, None], (dofs.shape[0], m, m))
    cols = np.broadcast_to(dofs[:, None, :], (dofs.shape[0], m, m))
    return sps.csr_matrix(sps.coo_matrix((blocks.ravel(), (rows.ravel(), cols.ravel())),
                                         shape=(n, n)))


def _component_blocks(scalar: np.ndarray) -> np.ndarray:
    """(ne, nb·3, nb·3) blocks ``S_ab δ_ij`` of scalar element matrices ``S`` (ne, nb, nb)."""
    ne, nb, _ = scalar.shape
    out = np.zeros((ne, nb, 3, nb, 3))
    for c in range(3):
        out[:, :, c, :, c] = scalar
    return out.reshape(ne, 3 * nb, 3 * nb)


def _elasticity_blocks(grads: np.ndarray, dx: np.ndarray, lam: float,
                       mu: float) -> np.ndarray:
    """(ne, nb·3, nb·3) element stiffness blocks of linear isotropic elasticity (module
    docstring), local DOF ``3a + i``."""
    nb, _, ne, nq = grads.shape
    g = grads.transpose(2, 0, 1, 3).reshape(ne, 3 * nb, nq)         # [e, (a,i), q]
    A = np.matmul(g * dx[:, None, :], g.transpose(0, 2, 1))          # Σ_q dV ∂_i N_a ∂_j N_b
    A = A.reshape(ne, nb, 3, nb, 3)
    lap = np.einsum("eakbk->eab", A)                                 # ∇N_a·∇N_b
    K = lam * A + mu * A.transpose(0, 1, 4, 3, 2)
    for c in range(3):
        K[:, :, c, :, c] += mu * lap
    return K.reshape(ne, 3 * nb, 3 * nb)


@dataclass(frozen=True, eq=False)
class SolidModel:
    """A solid FE model and the scikit-fem basis its stress stiffness is assembled on.

    Attributes
    ----------
    fe
        The :class:`~neweul_py.elastic.fe_model.FEModel` (node ids ``first_id …``,
        DOFs ``ux, uy, uz`` node-major).
    scalar_basis
        The scikit-fem ``Basis`` of the scalar element on the mesh (its node ``k`` carries
        the DOFs ``3k + c`` of ``fe``); every integral of the model uses its quadrature.
    material
        The :class:`SolidMaterial`.
    element
        One of :data:`SOLID_ELEMENTS`.
    node_sets
        ``"root"`` (face ``x = x0``), ``"tip"`` (face ``x = x0 + Lx``), ``"all"``.
    """

    fe: FEModel
    scalar_basis: object
    material: SolidMaterial
    element: str
    node_sets: Mapping[str, np.ndarray] = field(default_factory=dict)

    @cached_property
    def basis(self):
        """The scikit-fem ``Basis`` of ``ElementVector(element)`` on the same mesh and
        quadrature (DOF ``3k + c`` is component ``c`` of node ``k``, the order of ``fe``),
        built at first use, for forms beyond this module's."""
        from skfem import ElementVector

        return self.scalar_basis.with_element(ElementVector(self.scalar_basis.elem))

    @cached_property
    def _shape(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        values, grads, dx = _shape_functions(self.scalar_basis)
        return values, grads, dx, _vector_dofs(np.asarray(self.scalar_basis.element_dofs))

    def _checked(self, u: np.ndarray) -> np.ndarray:
        u = np.asarray(u, dtype=np.float64)
        if u.shape != (self.fe.n_dofs,):
            raise ModelError(f"displacement has shape {u.shape}, expected "
                             f"({self.fe.n_dofs},)", "u")
        return u

    def stress(self, u: np.ndarray) -> np.ndarray:
        """(3, 3, ne, nqp) linear stress of ``u`` at the quadrature points."""
        _, grads, _, dofs = self._shape
        lam, mu = self.material.lame
        grad_u = np.einsum("eac,aieq->cieq", self._checked(u)[dofs], grads)  # ∂_i u_c
        return _stress(grad_u, lam, mu)

    def geometric_stiffness(self, u: np.ndarray) -> sps.csr_matrix:
        """Initial-stress matrix ``∫ σ_ij ∂_i v_k ∂_j w_k dV`` of the linear stress of ``u``
        (block diagonal in the component ``k``: the scalar matrix
        ``Σ_q dV σ_ij ∂_i N_a ∂_j N_b`` once per component)."""
        _, grads, dx, dofs = self._shape
        sigma = self.stress(u)
        g = grads.transpose(2, 0, 1, 3)                                  # [e, a, i, q]
        sg = np.einsum("ijeq,eajq->eaiq", sigma * dx, g)                 # dV σ_ij ∂_j N_a
        nb, ne, nq = g.shape[1], g.shape[0], g.shape[3]
        scalar = np.matmul(sg.reshape(ne, nb, 3 * nq),
                           g.reshape(ne, nb, 3 * nq).transpose(0, 2, 1))
        return _scatter(_component_blocks(scalar), dofs.reshape(ne, -1), self.fe.n_dofs)

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
    from skfem import Basis

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
    scalar = Basis(mesh_type.init_tensor(*axes), el)
    values, grads, dx = _shape_functions(scalar)
    dofs = _vector_dofs(np.asarray(scalar.element_dofs))
    ne = dofs.shape[0]
    n = 3 * scalar.N
    K = _scatter(_elasticity_blocks(grads, dx, *mat.lame), dofs.reshape(ne, -1), n)
    v = values.transpose(1, 0, 2)                                        # [e, a, q]
    mass = mat.rho * np.matmul(v * dx[:, None, :], v.transpose(0, 2, 1))  # ρ Σ_q dV N_a N_b
    M = _scatter(_component_blocks(mass), dofs.reshape(ne, -1), n)
    K = 0.5 * (K + K.T)
    M = 0.5 * (M + M.T)
    xyz = np.asarray(scalar.doflocs).T
    nn = xyz.shape[0]
    ids = int(first_id) + np.arange(nn)
    nodes = np.column_stack([ids, xyz])
    fe = FEModel(M=M, K=K, D=None, nodes=nodes, dof_node=np.repeat(ids, 3),
                 dof_kind=np.tile(np.array(["ux", "uy", "uz"]), nn), name=name,
                 symmetric={"M": True, "K": True})
    tol = 1e-9 * L.max()
    sets = {"root": ids[np.abs(xyz[:, 0] - o[0]) <= tol],
            "tip": ids[np.abs(xyz[:, 0] - o[0] - L[0]) <= tol], "all": ids}
    return SolidModel(fe, scalar, mat, element, sets)
