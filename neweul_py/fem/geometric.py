"""Stress stiffness of the facet shell (membrane) of :mod:`neweul_py.fem.shell`, and its FE model.

For a displacement ``u`` of the reference configuration the linear membrane strain of a facet
is ``ε = sym(F₀ᵀ H)`` with ``F₀ = Σ_a x_a ⊗ G_a`` (the facet's in-plane frame) and
``H = Σ_a u_a ⊗ G_a``, the membrane forces ``N = t 𝔻 ε`` (plane-stress St. Venant–Kirchhoff,
Voigt ``[11, 22, 2·12]``), and the geometric (initial-stress) stiffness is the stress part of
the membrane tangent of :meth:`~neweul_py.fem.shell.ShellStructure.membrane`,

    K_G(u) = Σ_e A_e (G_a · N G_b) I₃

(Bonet & Wood, *Nonlinear Continuum Mechanics for FE Analysis*, 2nd ed., §9.4). Bending
(linear BST) contributes no stress stiffness in this Föppl–von Kármán split.
:func:`shell_model` is the linear FE model of the shell at its reference configuration
(membrane tangent at ``u = 0`` plus bending, consistent mass), ready for
:func:`~neweul_py.elastic.reductors.invariants.stress_stiffening` with
:func:`shell_geometric_stiffness`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.sparse as sps

from ..elastic.bodies.invariants import LOAD_CASES
from ..elastic.fe_model import FEModel
from ..elastic.reductors.invariants import stress_stiffening
from .assembly import assemble_matrix, node_dofs
from .shell import ShellStructure, plane_stress

__all__ = ["shell_geometric_stiffness", "shell_model", "shell_stiffening"]


def shell_geometric_stiffness(shell: ShellStructure, u: np.ndarray) -> sps.csr_matrix:
    """``K_G`` (3n×3n, node-major ``ux, uy, uz``) of the linear membrane stress of ``u``."""
    m = shell.material
    tri, g, a = shell.triangles, shell.grads, shell.areas
    f0 = np.einsum("eai,eaJ->eiJ", shell.points[tri], g)             # (nt, 3, 2)
    H = np.einsum("eai,eaJ->eiJ", np.reshape(u, (-1, 3))[tri], g)
    e = np.einsum("eiI,eiJ->eIJ", f0, H)
    ev = np.stack([e[:, 0, 0], e[:, 1, 1], e[:, 0, 1] + e[:, 1, 0]], axis=1)
    nv = ev @ (m.t * plane_stress(m.E, m.nu))
    nmat = np.stack([nv[:, [0, 2]], nv[:, [2, 1]]], axis=1)          # (nt, 2, 2)
    gg = np.einsum("e,eaI,eIJ,ebJ->eab", a, g, nmat, g)
    kg = np.einsum("eab,ij->eaibj", gg, np.eye(3)).reshape(-1, 9, 9)
    return assemble_matrix(kg, node_dofs(tri, 3), shell.n_dof)


def shell_model(shell: ShellStructure, *, first_id: int = 1, name: str = "shell") -> FEModel:
    """The linear FE model of the shell at its reference configuration (module docstring)."""
    _, _, km = shell.membrane(np.zeros(shell.n_dof))
    K = (km + shell.bending).tocsr()
    M = shell.mass()
    nn = shell.points.shape[0]
    ids = int(first_id) + np.arange(nn)
    return FEModel(M=0.5 * (M + M.T), K=0.5 * (K + K.T), D=None,
                   nodes=np.column_stack([ids, shell.points]), dof_node=np.repeat(ids, 3),
                   dof_kind=np.tile(np.array(["ux", "uy", "uz"]), nn), name=name,
                   symmetric={"M": True, "K": True})


def shell_stiffening(shell: ShellStructure, fe: FEModel, support: Sequence[int],
                     cases: Sequence[str] = LOAD_CASES) -> dict[str, sps.csr_matrix]:
    """``K_G,c`` of the unit inertia load cases of the shell model ``fe`` (from
    :func:`shell_model`) held at the DOFs ``support``
    (:func:`~neweul_py.elastic.reductors.invariants.stress_stiffening`)."""
    return stress_stiffening(fe, lambda u: shell_geometric_stiffness(shell, u), support, cases)
