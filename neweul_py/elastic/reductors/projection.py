"""Petrov–Galerkin projection, shared by every reductor (pyMOR style: one ``project``).

With right basis ``V`` (``x ≈ V q``) and left basis ``W`` (test functions), a second-order
model ``M ẍ + D ẋ + K x = B u``, ``y = C x`` becomes
``Wᵀ M V q̈ + Wᵀ D V q̇ + Wᵀ K V q = Wᵀ B u``, ``y = C V q`` (``docs/equations.md`` §2–3,
"two-sided data"); one-sided (Galerkin) data is ``W = V``. The projection acts on each matrix
separately, so the second-order structure is kept.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
import scipy.sparse as sps

from ...errors import SolverError
from ..bodies.reduced import ReducedBody
from ..fe_model import FEModel

__all__ = ["biorthonormalize", "build_reduced_body", "orthonormal_append", "project"]

#: Optional callback receiving short progress messages of long steps (the CLI prints them).
Progress = Callable[[str], None] | None


def project(
    V: np.ndarray,
    W: np.ndarray,
    matrices: Mapping[str, sps.spmatrix | np.ndarray | None],
    B: np.ndarray | None = None,
    C: np.ndarray | None = None,
    base: tuple[Mapping[str, sps.spmatrix | None], Mapping[str, np.ndarray | None]] | None
    = None,
) -> dict[str, np.ndarray | None]:
    """Project system matrices: ``X_r = Wᵀ X V`` for each, ``B_r = Wᵀ B``, ``C_r = C V``.

    Parameters
    ----------
    V, W
        (n, r) right and left bases (``W = V`` for Galerkin projection).
    matrices
        Name → n×n sparse or dense matrix (``None`` stays ``None``).
    B, C
        Optional (n, k) input and (l, n) output matrices.
    base
        ``(matrices₀, projected₀)``: the sparse matrices of another model of the same mesh
        and their projections on the same ``(V, W)``. A sparse ``X`` is then projected as
        ``Wᵀ X₀ V + Wᵀ (X − X₀) V`` with the difference restricted to its nonzero rows and
        columns: the working points of a parametric body differ in a few rows (the
        prestressed membrane), and the blocks that do not vary come out equal to the base's.

    Returns
    -------
    dict
        The reduced matrices under the same names, plus ``"B"`` and ``"C"`` when given.
        Sparse matrices are only multiplied with the dense bases, never densified.

    References
    ----------
    ``docs/equations.md`` §3 (two-sided modal truncation); pyMOR's
    ``project(op, range_basis, source_basis)``.

    Examples
    --------
    >>> import numpy as np
    >>> V = np.eye(3)[:, :2]
    >>> project(V, V, {"K": np.diag([1.0, 2.0, 3.0])})["K"].tolist()
    [[1.0, 0.0], [0.0, 2.0]]
    """
    out: dict[str, np.ndarray | None] = {}
    for name, x in matrices.items():
        x0, p0 = (None, None) if base is None else (base[0].get(name), base[1].get(name))
        if x is None:
            out[name] = None
        elif sps.issparse(x) and sps.issparse(x0) and p0 is not None and x0.shape == x.shape:
            out[name] = np.asarray(p0) + _difference_projection(V, W, sps.csr_matrix(x - x0))
        else:
            out[name] = np.asarray(W.T @ np.asarray(x @ V))
    if B is not None:
        out["B"] = np.asarray(W.T @ B)
    if C is not None:
        out["C"] = np.asarray(C @ V)
    return out


def _difference_projection(V: np.ndarray, W: np.ndarray, dx: sps.csr_matrix) -> np.ndarray:
    """``Wᵀ ΔX V`` on the nonzero rows and columns of the sparse ``ΔX`` only."""
    dx.eliminate_zeros()
    nz_rows, nz_cols = dx.nonzero()
    rows, cols = np.unique(nz_rows), np.unique(nz_cols)
    if rows.size == 0:
        return np.zeros((W.shape[1], V.shape[1]))
    block = dx[rows][:, cols]
    return W[rows].T @ np.asarray(block @ V[cols])


def biorthonormalize(
    V: np.ndarray, W: np.ndarray, M: sps.spmatrix, cond_max: float = 1e12
) -> tuple[np.ndarray, np.ndarray]:
    """Scale bases so that ``Wᵀ M V = I``: unit columns of ``V``, then ``W ← W (Wᵀ M V)⁻ᵀ``.

    Raises
    ------
    SolverError
        ``Wᵀ M V`` is singular or worse conditioned than ``cond_max`` (the left and right
        subspaces are (nearly) M-orthogonal: no Petrov–Galerkin model exists for them).
    """
    V = V / np.linalg.norm(V, axis=0)
    W = W / np.linalg.norm(W, axis=0)
    G = W.T @ (M @ V)
    cond = np.linalg.cond(G) if G.size else 1.0
    if not np.isfinite(cond) or cond > cond_max:
        raise SolverError(f"Wᵀ M V is singular (condition number {cond:.3g}): left and right "
                          "bases do not pair up", residual=cond)
    W = np.linalg.solve(G, W.T).T
    return V, W


def orthonormal_append(
    Q: np.ndarray, X: np.ndarray, rtol: float = 1e-10, max_cols: int | None = None
) -> np.ndarray:
    """Append the columns of ``X`` to the orthonormal ``Q`` in order (Gram–Schmidt, twice).

    Columns whose remainder after orthogonalization is below ``rtol`` times their norm are
    dropped (deflation); the order of the kept columns is the order of ``X``, so truncating
    the result keeps the earliest (e.g. lowest-moment) directions.
    """
    cols = [Q[:, j] for j in range(Q.shape[1])]
    basis = Q
    for j in range(X.shape[1]):
        if max_cols is not None and len(cols) >= max_cols:
            break
        x = X[:, j].copy()
        nx = np.linalg.norm(x)
        if nx == 0:
            continue
        for _ in range(2):
            if basis.shape[1]:
                x -= basis @ (basis.T @ x)
        nr = np.linalg.norm(x)
        if nr <= rtol * nx:
            continue
        cols.append(x / nr)
        basis = np.column_stack(cols)
    return basis if cols else np.zeros((X.shape[0], 0))


def build_reduced_body(
    fe: FEModel,
    V: np.ndarray,
    W: np.ndarray,
    method: str,
    settings: Mapping,
    keep_nodes: Sequence[int] | np.ndarray | None = None,
    store_bases: bool = False,
    eigenvalues: np.ndarray | None = None,
    base: tuple[FEModel, ReducedBody] | None = None,
) -> ReducedBody:
    """Project ``fe`` with ``(V, W)`` and wrap the result as a :class:`ReducedBody`.

    ``M``, ``D``, ``K`` and the hysteretic damping ``G`` of ``K + iG`` (when the FE model has
    one, ``docs/equations.md`` §1.1) are projected alike, ``X_r = Wᵀ X V``; the body keeps
    ``G``'s reference frequency, and ``D`` stays the FE model's own (for the middle-ear files
    already ``G/ω_ref``: nothing is added, so nothing is counted twice).

    ``keep_nodes`` (node ids) selects the rows of ``V`` that are stored (all DOFs of those
    nodes); by default the nodes carrying an input or output DOF. ``settings`` gains
    ``two_sided`` — whether ``W`` differs from ``V`` — unless the caller states it.
    ``base``: another FE model of the same mesh and its body projected on the same
    ``(V, W)``; only the matrices' differences to it are projected (:func:`project`).
    """
    names = ("M", "D", "K", "G")
    prior = None
    if base is not None:
        fe0, body0 = base
        prior = ({k: getattr(fe0, k) for k in names},
                 {"M": body0.M, "K": body0.K, "G": body0.G,
                  "D": body0.D if fe0.D is not None else None})
    red = project(V, W, {k: getattr(fe, k) for k in names}, B=fe.B(), C=fe.C(), base=prior)
    nodes = fe.io_nodes() if keep_nodes is None else np.unique(np.asarray(keep_nodes,
                                                                          dtype=np.int64))
    dofs = fe.dofs_of_nodes(nodes)
    node_rows = fe.nodes[np.isin(fe.nodes[:, 0].astype(np.int64), nodes)]
    D = red["D"] if red["D"] is not None else np.zeros_like(red["M"])
    return ReducedBody(
        M=red["M"], D=D, K=red["K"], B=red["B"], C=red["C"],
        input_names=fe.input_names, output_names=fe.output_names,
        nodes=node_rows, kept_dofs=dofs, dof_node=fe.dof_node[dofs],
        dof_kind=fe.dof_kind[dofs], V_kept=V[dofs], W_kept=W[dofs],
        V=V if store_bases else None, W=W if store_bases else None,
        full_dof_kind=fe.dof_kind if store_bases else None,
        method=method,
        settings={"two_sided": not (W is V or np.array_equal(W, V)), **dict(settings)},
        eigenvalues=eigenvalues, G=red["G"],
        loss_reference_frequency=fe.loss_reference_frequency,
        source={"name": fe.name, "file": fe.source, "kind": fe.kind, "n_dofs": fe.n_dofs,
                "density": fe.density, "fingerprint": fe.fingerprint},
    )

