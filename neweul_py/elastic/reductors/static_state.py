"""The static state of a reduced body from the FE static state.

The working-point body is described in ``docs/equations-middle-ear.md`` §5.

:func:`static_deflection` projects the FE static state ``x_s`` on the body's basis and keeps
the exact node displacements, interface forces and outputs of that state
(:class:`~neweul_py.elastic.bodies.static.StaticDeflection`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import scipy.sparse as sps

from ...errors import DataError
from ..bodies.static import StaticDeflection, node_rows

__all__ = [
    "metric_gram",
    "static_deflection",
]


def metric_gram(metric: sps.spmatrix, V: np.ndarray) -> np.ndarray:
    """``VᵀḠV``: the Gram matrix of the basis in the metric, the product of
    :func:`static_deflection` that does not depend on the state (r × r; ``ḠV``, as large as
    ``V``, is not kept)."""
    return V.T @ np.asarray(metric @ V)


def static_deflection(body: Any, x: np.ndarray, *, V: np.ndarray | None = None,
                      W: np.ndarray | None = None, output_rows: np.ndarray | None = None,
                      node_force: Mapping[int, np.ndarray] | None = None,
                      outputs: Mapping[str, float] | None = None,
                      metric: sps.spmatrix | None = None,
                      gram: np.ndarray | None = None) -> StaticDeflection:
    """The static state of a reduced body from the FE static state ``x`` (module docstring).

    Parameters
    ----------
    body
        The :class:`~neweul_py.elastic.bodies.reduced.ReducedBody` of the working point.
    V, W
        Its full right and left bases (default: the body's stored ``V``, ``W``; ``W = V``
        when neither gives one).
    x
        (n,) the static displacement on the FE model's DOFs (pressures 0 for a u–p model:
        the static pressure is the reference of the acoustic perturbation).
    output_rows
        (n_out, n) the FE output rows (``C_FE``); ``outputs = C_FE x`` (``None``: zeros,
        unless given in ``outputs``).
    node_force
        Node id → (3,) static force on the body at that node [N] (e.g. the FE file's
        ``static_manubrium_force``); nodes not named get zero. A node that is not one of the
        body's kept nodes is a :class:`DataError`.
    outputs
        Output name → exact static value, replacing ``C_FE x`` for that output (e.g. the
        nonlinear swept volume).
    metric
        Ḡ (n × n, symmetric positive definite): ``q = (VᵀḠV)⁻¹VᵀḠx`` and the residual in
        that norm. ``None``: ``q = (WᵀV)⁻¹Wᵀx`` (the oblique projection of two-sided data;
        least squares for ``W = V``) and the Euclidean residual.
    gram
        ``VᵀḠV`` of this metric and ``V`` (:func:`metric_gram`), for a caller that projects
        many states on one basis: computed here when ``None``.
    """
    V = body.V if V is None else np.asarray(V)
    W = (body.W if body.W is not None else V) if W is None else np.asarray(W)
    if V is None:
        raise DataError("the static reduced coordinates need the body's full basis V "
                        "(reduce with the bases stored)", None, "V")
    x = np.asarray(x, dtype=np.float64).ravel()
    if x.size != V.shape[0]:
        raise DataError(f"the static state has {x.size} entries for a basis of "
                        f"{V.shape[0]} rows", None, "static.x")
    if metric is not None:
        VGV = metric_gram(metric, V) if gram is None else gram
        q = np.linalg.solve(VGV, V.T @ np.asarray(metric @ x))
        norm = lambda v: float(np.sqrt(max(v @ (metric @ v), 0.0)))  # noqa: E731
    else:
        q = np.linalg.lstsq(W.T @ V, W.T @ x, rcond=None)[0]
        norm = lambda v: float(np.linalg.norm(v))  # noqa: E731
    nx = norm(x)
    residual = norm(x - V @ q) / nx if nx > 0 else 0.0
    rows = node_rows(body.nodes, body.dof_node, body.dof_kind)
    xk = x[body.kept_dofs]
    node_u = np.where(rows >= 0, xk[np.maximum(rows, 0)], 0.0)
    ids = [int(n) for n in body.nodes[:, 0]]
    force = np.zeros((len(ids), 3))
    for nid, f in (node_force or {}).items():
        if int(nid) not in ids:
            raise DataError(f"static interface force at node {nid}, which is not one of the "
                            f"body's kept nodes {ids}", None, "static.node_force")
        force[ids.index(int(nid))] = np.asarray(f, dtype=np.float64).reshape(3)
    y = (np.zeros(len(body.output_names)) if output_rows is None
         else np.asarray(output_rows @ x, dtype=np.float64).ravel())
    for name, value in (outputs or {}).items():
        if name not in body.output_names:
            raise DataError(f"no output {name!r} (outputs: {', '.join(body.output_names)})",
                            None, "static.outputs")
        y[list(body.output_names).index(name)] = float(value)
    return StaticDeflection(q=q, node_u=node_u, node_force=force, outputs=y,
                            residual=np.array(residual))
