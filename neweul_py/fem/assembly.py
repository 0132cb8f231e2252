"""Assembly of element arrays into sparse global matrices (vectorized, no loop over elements)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sps

__all__ = ["assemble_matrix", "assemble_vector", "node_dofs"]


def node_dofs(nodes: np.ndarray, n_per_node: int) -> np.ndarray:
    """DOF indices ``n_per_node·node + k`` of element nodes: (ne, nen) → (ne, nen·n_per_node)."""
    nodes = np.asarray(nodes)
    d = n_per_node * nodes[..., None] + np.arange(n_per_node)
    return d.reshape(*nodes.shape[:-1], nodes.shape[-1] * n_per_node)


def assemble_matrix(ke: np.ndarray, dofs: np.ndarray, n: int) -> sps.csr_matrix:
    """Sum element matrices ``ke`` (ne, k, k) at ``dofs`` (ne, k) into an n×n CSR matrix."""
    k = dofs.shape[1]
    rows = np.repeat(dofs, k, axis=1).ravel()
    cols = np.tile(dofs, (1, k)).ravel()
    return sps.csr_matrix((ke.ravel(), (rows, cols)), shape=(n, n))


def assemble_vector(fe: np.ndarray, dofs: np.ndarray, n: int) -> np.ndarray:
    """Sum element vectors ``fe`` (ne, k) at ``dofs`` (ne, k) into a length-n vector."""
    return np.bincount(dofs.ravel(), weights=fe.ravel(), minlength=n)
