"""``M a`` without forming ``M``: a matrix–vector product pushed into a traced matrix.

The generalized-α loop of a compiled module needs the residual ``r = M a − (q − k)`` at every
Newton iteration (:data:`~neweul_py.codegen.c_templates.C_GALPHA`), not ``M`` itself. The
traced mass matrix of :func:`~neweul_py.ffrf.splice.ffrf_add_mass` is a sum of products and
of blocks added to parts of it; :func:`matvec` records ``M a`` by the rules of linear
algebra,

* ``(A B) a = A (B a)``,
* ``(X ± Y) a = X a ± Y a``,
* ``M`` equal to ``B`` but for the block ``B[R, C] ± X`` (or ``X`` where ``B`` is zero):
  ``M a = B a`` with ``(M a)[R] = (B a)[R] ± X a[C]``,

and takes the plain product where none applies. For a body on a fixed frame,
``M = S_Wᵀ M_s S_V + blockdiag(0, M_e)``, this reads ``M_e`` once and ``S_V``, ``S_W`` in
the rows the symbolic part uses, instead of writing the ``n × n`` matrix and reading it
back (as a ``(389, 389)`` middle ear: 1.2 MB each way per evaluation). The operations are
those of the matrix, in another order: the result equals ``M a`` to round-off.
"""

from __future__ import annotations

import numpy as np

from .c_trace import Graph, Node, TArray

__all__ = ["matvec"]


def matvec(m: TArray, a: TArray) -> TArray:
    """``m @ a``, pushed into the operations that form ``m`` (module docstring).

    Parameters
    ----------
    m
        A traced matrix (n, k).
    a
        A traced vector (k,).

    Returns
    -------
    TArray
        The traced product (n,), equal to ``m @ a`` to round-off.

    Raises
    ------
    ValueError
        When the shapes do not multiply.
    """
    if len(m.shape) != 2 or len(a.shape) != 1 or m.shape[1] != a.shape[0]:
        raise ValueError(f"matvec of shapes {m.shape} and {a.shape}")
    return TArray(m.graph, _push(m.graph, m.node, a.node))


def _push(g: Graph, node: Node, x: Node) -> Node:
    """The node of ``node @ x`` (``node`` 2-D, ``x`` 1-D)."""
    if node.op == "zeros":
        return g.zeros(node.shape[:1], node.cplx or x.cplx)
    if node.op == "dot" and all(len(a.shape) == 2 for a in node.args):
        left, right = node.args
        return np.dot(TArray(g, left), TArray(g, _push(g, right, x))).node
    if (node.op == "ew" and node.params in (("add",), ("sub",))
            and node.args[0].shape == node.args[1].shape == node.shape):
        a, b = (TArray(g, _push(g, arg, x)) for arg in node.args)
        return (a + b if node.params == ("add",) else a - b).node
    if node.op == "update":
        pushed = _push_update(g, node, x)
        if pushed is not None:
            return pushed
    return np.dot(TArray(g, node), TArray(g, x)).node


def _push_update(g: Graph, node: Node, x: Node) -> Node | None:
    """``node @ x`` for ``node = B`` with the block ``[R, C]`` set to ``B[R, C] ± X`` or, where
    ``B[R, C]`` is zero, to ``X``; ``None`` for any other assignment."""
    base, value = node.args
    basic, fancy = node.params
    if fancy or len(basic) != 2 or not all(isinstance(b, tuple) for b in basic):
        return None
    # (start, stop, step) of slice.indices: a stop of -1 ends a reversed slice at the start
    rows, cols = (slice(b[0], b[1] if b[1] >= 0 else None, b[2]) for b in basic)
    region = TArray(g, base)[rows, cols].node
    if region.op == "zeros":
        sign, added = 1.0, value
    elif (value.op == "ew" and value.params in (("add",), ("sub",))
          and value.args[0] is region):
        sign, added = (1.0 if value.params == ("add",) else -1.0), value.args[1]
    else:
        return None
    if added.shape != region.shape:
        return None
    y = TArray(g, _push(g, base, x))
    product = TArray(g, _push(g, added, TArray(g, x)[cols].node))
    y[rows] = y[rows] + product if sign > 0 else y[rows] - product
    return y.node
