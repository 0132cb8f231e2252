"""The FE-model container: sparse ``M``, ``D``, ``K`` with nodes, DOF map, inputs and outputs.

Structure kinds (``kind``):

* ``"structural"`` – displacement DOFs only, symmetric ``M``, ``K``;
* ``"acoustic"`` – pressure DOFs only;
* ``"up-coupled"`` – pressure-based u–p form of Eq. (2) of the seed paper,
  ``[Ms 0; ρCᵀ Mf] ü + D u̇ + [Ks −C; 0 Kf] u = f`` with fluid density ``density`` (ρ).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sps

__all__ = ["DOF_KINDS", "FE_KINDS", "FEModel"]

#: DOF kinds of the DOF map.
DOF_KINDS = ("ux", "uy", "uz", "rx", "ry", "rz", "p")
#: Structure kinds of an FE model.
FE_KINDS = ("structural", "acoustic", "up-coupled")


@dataclass(frozen=True, eq=False)
class FEModel:
    """A linear(ized) second-order FE model ``M ẍ + D ẋ + K x = B u``, ``y = C x``.

    Parameters
    ----------
    M, K
        Sparse (CSR) n×n mass and stiffness matrices; may be unsymmetric (u–p coupling).
    D
        Sparse n×n damping matrix or ``None`` (no damping).
    nodes
        (nn, 4) array of ``id, x, y, z``.
    dof_node
        (n,) node id of each DOF.
    dof_kind
        (n,) str array, each one of :data:`DOF_KINDS`.
    inputs, outputs
        Name → ((dof_index, weight), …): a load vector ``b`` with ``b[dof] = weight`` (inputs),
        an output row ``c`` with ``c[dof] = weight`` (outputs).
    kind
        One of :data:`FE_KINDS`.
    density
        The fluid density ρ of Eq. (2) (``up-coupled`` only).
    name
        A name for messages.
    """

    M: sps.csr_matrix
    K: sps.csr_matrix
    D: sps.csr_matrix | None
    nodes: np.ndarray
    dof_node: np.ndarray
    dof_kind: np.ndarray
    inputs: Mapping[str, tuple[tuple[int, float], ...]] = field(default_factory=dict)
    outputs: Mapping[str, tuple[tuple[int, float], ...]] = field(default_factory=dict)
    kind: str = "structural"
    density: float | None = None
    name: str = "fe-model"
    # validation, symmetry declarations, input/output matrices and file I/O: see the
    # readers/writers of this package.
