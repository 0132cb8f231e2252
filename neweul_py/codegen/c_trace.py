"""Tracing the floating-frame kernel's array operations, for the compiled backend.

The compiled backend prints the body equations from the very functions the NumPy module runs
(:mod:`neweul_py.ffrf`): they are called once, at generation, on :class:`TArray` values
instead of arrays. A :class:`TArray` records every operation the kernel performs — products
(``numpy.dot``, ``@``), sums, slices, reshapes, concatenations, fancy indexing, assignments
to parts of an array — as a node of a :class:`Graph`, with its shape and whether it is complex;
nothing is computed. :mod:`.c_kernel` prints the graph as C loops. So the C code holds the
kernel's operations in the kernel's order, and no second implementation of the body
equations exists.

What the kernel does with its values decides what is supported: the NumPy functions it calls
(``dot``, ``concatenate``, ``hstack``, ``vstack``, ``zeros_like``, ``result_type``,
``iscomplexobj``) are dispatched through ``__array_function__``, arithmetic with arrays and
Python numbers through the operators and ``__array_ufunc__``; anything else raises
:class:`TraceError` at generation, never silently. A value can only be *read* by operations,
so control flow that depends on array values (``if numpy.any(x)``) is refused too: such
decisions belong to the data's structure and are taken by the caller before tracing.

Nodes are hash-consed: the same operation on the same nodes is one node, so what two traced
functions share (the mixed samples of a parametric body) is computed once.
"""

from __future__ import annotations

import numbers
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..errors import GenerationError

__all__ = ["Graph", "Node", "TArray", "TraceError"]


class TraceError(GenerationError):
    """The kernel did something the tracer cannot record."""


class Node:
    """One array value of a traced program (immutable).

    Attributes
    ----------
    op
        ``"leaf"``, ``"const"``, ``"zeros"``, ``"view"``, ``"ew"`` (elementwise), ``"dot"``,
        ``"concat"``, ``"pack"``, ``"gather"``, ``"update"`` or ``"mix"`` (a parametric
        body's samples mixed from their compact form,
        :class:`~.c_splice_trace.MixedColumns`).
    args
        The nodes it is computed from.
    shape
        Its shape.
    cplx
        Whether its values are complex.
    params
        The operation's parameters (hashable): a leaf's ``(name, level)``; a view's
        ``(offset, strides)`` into its storage; an elementwise operation's name and scalar;
        a concatenation's axis; an index specification.
    """

    __slots__ = ("args", "cplx", "id", "op", "params", "shape")

    def __init__(self, op: str, args: tuple[Node, ...], shape: tuple[int, ...], cplx: bool,
                 params: Any, ident: int) -> None:
        self.op, self.args, self.shape, self.cplx, self.params = op, args, shape, cplx, params
        self.id = ident

    @property
    def size(self) -> int:
        return int(np.prod(self.shape, dtype=np.int64))

    def __repr__(self) -> str:
        return f"Node#{self.id}({self.op}, {self.shape}{', complex' if self.cplx else ''})"


def _contiguous(shape: Sequence[int]) -> tuple[int, ...]:
    strides, step = [], 1
    for s in reversed(shape):
        strides.append(step)
        step *= max(int(s), 1)
    return tuple(reversed(strides))


class Graph:
    """The nodes of traced programs (hash-consed) and the leaves by name."""

    def __init__(self) -> None:
        self.nodes: list[Node] = []
        self._known: dict[tuple, Node] = {}
        self.leaves: dict[str, Node] = {}

    def node(self, op: str, args: tuple[Node, ...], shape: tuple[int, ...], cplx: bool,
             params: Any = ()) -> Node:
        """The node of ``op`` on ``args`` (an existing equal one when there is one)."""
        shape = tuple(int(s) for s in shape)
        key = (op, tuple(a.id for a in args), shape, cplx, params)
        found = self._known.get(key)
        if found is not None:
            return found
        n = Node(op, args, shape, cplx, params, len(self.nodes))
        self.nodes.append(n)
        self._known[key] = n
        return n

    def leaf(self, name: str, shape: Sequence[int], level: int, cplx: bool = False) -> TArray:
        """An input of the traced program: ``level`` 0 (data, bound once), 1 (changes with
        the schedule) or 2 (an argument of every call)."""
        if name in self.leaves:
            raise TraceError(f"leaf {name!r} defined twice")
        n = self.node("leaf", (), tuple(shape), cplx, (name, level))
        self.leaves[name] = n
        return TArray(self, n)

    def const(self, values: Any) -> Node:
        """A constant array of the kernel (zeros, unit matrices, the structural maps of
        :func:`~neweul_py.ffrf.body.ffrf_rigid_map`): all-zero ones become ``zeros``."""
        a = np.asarray(values)
        if a.dtype.kind not in "biufc":
            raise TraceError(f"cannot trace a constant of dtype {a.dtype}")
        if not np.any(a):
            return self.node("zeros", (), a.shape, a.dtype.kind == "c")
        if a.dtype.kind == "c":
            if np.any(a.imag):
                raise TraceError("complex constants enter only as scalar factors")
            a = a.real                        # a unit matrix of a complex step's dtype
        a = np.array(a, dtype=np.float64, order="C")        # (0-d arrays stay 0-d)
        return self.node("const", (), a.shape, False, (a.tobytes(),))

    def zeros(self, shape: Sequence[int], cplx: bool = False) -> Node:
        return self.node("zeros", (), tuple(shape), cplx)

    def storage_view(self, node: Node) -> tuple[Node, int, tuple[int, ...]]:
        """``(storage, offset, strides)`` of ``node``: a view's, or the node itself with
        contiguous strides."""
        if node.op == "view":
            offset, strides = node.params
            return node.args[0], offset, strides
        return node, 0, _contiguous(node.shape)

    def view(self, base: Node, offset: int, strides: tuple[int, ...], shape: tuple[int, ...]
             ) -> Node:
        """A view of ``base``'s storage (the storage itself for the identity)."""
        storage, _o, _s = self.storage_view(base)
        if offset == 0 and tuple(shape) == storage.shape and tuple(strides) == _contiguous(
                storage.shape):
            return storage
        if storage.op == "zeros":
            return self.zeros(shape, storage.cplx)
        return self.node("view", (storage,), shape, storage.cplx,
                         (int(offset), tuple(int(s) for s in strides)))


def _is_scalar(x: Any) -> bool:
    return (isinstance(x, numbers.Number) and not isinstance(x, bool)) or (
        isinstance(x, np.generic) and x.dtype.kind in "fic")


def _broadcast_shape(*shapes: tuple[int, ...]) -> tuple[int, ...]:
    try:
        return tuple(np.broadcast_shapes(*shapes))
    except ValueError:
        raise TraceError(f"shapes {shapes} do not broadcast") from None


class TArray:
    """A traced array: a handle on a :class:`Node` of a :class:`Graph`. An assignment to a
    part of it replaces its node, as NumPy's changes the array; a view taken before keeps the
    old values (NumPy's would see the change), which the kernel never relies on: it reads
    its views at once (the equality tests of the compiled backend would see otherwise)."""

    __array_priority__ = 1000

    def __init__(self, graph: Graph, node: Node) -> None:
        self.graph = graph
        self.node = node

    # ------------------------------------------------------------------ attributes
    @property
    def shape(self) -> tuple[int, ...]:
        return self.node.shape

    @property
    def ndim(self) -> int:
        return len(self.node.shape)

    @property
    def size(self) -> int:
        return self.node.size

    @property
    def dtype(self) -> np.dtype:
        return np.dtype(np.complex128 if self.node.cplx else np.float64)

    @property
    def T(self) -> TArray:
        return self.transpose()

    def __len__(self) -> int:
        if not self.shape:
            raise TypeError("len() of a 0-d traced array")
        return self.shape[0]

    def __iter__(self):
        raise TraceError("iterating over a traced array (use the kernel's array operations)")

    def __bool__(self) -> bool:
        raise TraceError("the kernel's control flow depends on a traced value")

    def __repr__(self) -> str:
        return f"TArray({self.node!r})"

    # ------------------------------------------------------------------ helpers
    def _wrap(self, node: Node) -> TArray:
        return TArray(self.graph, node)

    def _node_of(self, x: Any) -> Node:
        if isinstance(x, TArray):
            if x.graph is not self.graph:
                raise TraceError("values of two traces mixed")
            return x.node
        if isinstance(x, np.ndarray) and x.dtype == object:
            return self._pack(x)
        if _is_scalar(x) or isinstance(x, np.ndarray | list | tuple):
            return self.graph.const(np.asarray(x))
        raise TraceError(f"cannot trace a value of type {type(x).__name__}")

    def _pack(self, objects: np.ndarray) -> Node:
        """An object array of traced scalars (and numbers) as one vector node."""
        if objects.ndim != 1:
            raise TraceError("only 1-D arrays of traced scalars are supported")
        nodes = []
        for item in objects:
            n = self._node_of(item)
            if n.shape != ():
                raise TraceError("an array of traced arrays that are not scalars")
            nodes.append(n)
        cplx = any(n.cplx for n in nodes)
        return self.graph.node("pack", tuple(nodes), (len(nodes),), cplx)

    # ------------------------------------------------------------------ views
    def reshape(self, *shape: Any) -> TArray:
        if len(shape) == 1 and isinstance(shape[0], tuple | list):
            shape = tuple(shape[0])
        shape = tuple(int(s) for s in shape)
        if -1 in shape:
            known = int(np.prod([s for s in shape if s != -1]))
            shape = tuple(self.size // max(known, 1) if s == -1 else s for s in shape)
        if int(np.prod(shape, dtype=np.int64)) != self.size:
            raise TraceError(f"cannot reshape {self.shape} to {shape}")
        storage, offset, strides = self.graph.storage_view(self.node)
        if strides != _contiguous(self.shape):
            # not contiguous: copy it first (an elementwise identity)
            storage = self.graph.node("ew", (self.node,), self.shape, self.node.cplx,
                                      ("copy",))
            offset = 0
        return self._wrap(self.graph.view(storage, offset, _contiguous(shape), shape))

    def ravel(self) -> TArray:
        return self.reshape(self.size)

    def transpose(self, *axes: int) -> TArray:
        axes = tuple(axes) if axes else tuple(reversed(range(self.ndim)))
        storage, offset, strides = self.graph.storage_view(self.node)
        return self._wrap(self.graph.view(storage, offset, tuple(strides[a] for a in axes),
                                          tuple(self.shape[a] for a in axes)))

    def astype(self, dtype: Any, copy: bool = True) -> TArray:
        dt = np.dtype(dtype)
        if dt.kind == "c" and not self.node.cplx:
            return self._wrap(self.graph.node("ew", (self.node,), self.shape, True, ("cast",)))
        if dt.kind == "f" and self.node.cplx:
            raise TraceError("a complex traced value cast to real")
        return self._wrap(self.node)

    def copy(self) -> TArray:
        return self._wrap(self.node)

    def tolist(self) -> list:
        if self.ndim != 1:
            raise TraceError("tolist() of a traced array that is not 1-D")
        return [self[i] for i in range(self.shape[0])]

    def _index(self, key: Any) -> tuple[list, list[tuple]]:
        """Normalize ``key``: the basic part as per-axis ``(start, stop, step)`` or ``int``
        (and ``None`` for new axes), and fancy indices ``[(axis, int tuple)]`` applied to the
        result of the basic part (one integer array on one axis, or two from
        ``numpy.ix_``)."""
        if not isinstance(key, tuple):
            key = (key,)
        if any(k is Ellipsis for k in key):
            i = key.index(Ellipsis)
            fill = self.ndim - (len(key) - 1 - sum(k is None for k in key))
            key = key[:i] + (slice(None),) * fill + key[i + 1:]
        basic, fancy, axis = [], [], 0
        for k in key:
            if k is None:
                basic.append(None)
                continue
            if axis >= self.ndim:
                raise TraceError(f"too many indices for shape {self.shape}")
            n = self.shape[axis]
            if isinstance(k, slice):
                basic.append(k.indices(n))
            elif isinstance(k, numbers.Integral):
                i = int(k) + (n if k < 0 else 0)
                if not 0 <= i < n:
                    raise TraceError(f"index {k} out of range for axis of {n}")
                basic.append(i)
            elif isinstance(k, np.ndarray | list) and np.asarray(k).dtype.kind in "iu":
                idx = np.asarray(k)
                out_axis = sum(1 for b in basic if not isinstance(b, int))
                flat = tuple(int(v) + (n if v < 0 else 0) for v in idx.ravel())
                if any(not 0 <= v < n for v in flat):
                    raise TraceError("fancy index out of range")
                fancy.append((out_axis, flat, idx.shape))
                basic.append((0, n, 1))
            else:
                raise TraceError(f"cannot trace the index {k!r}")
            axis += 1
        basic += [(0, self.shape[a], 1) for a in range(axis, self.ndim)]
        if len(fancy) == 2:                   # numpy.ix_: (r, 1) and (1, c)
            (a0, f0, s0), (a1, f1, s1) = fancy
            if not (len(s0) == 2 and len(s1) == 2 and s0[1] == 1 and s1[0] == 1):
                raise TraceError("two fancy indices must come from numpy.ix_")
            fancy = [(a0, f0, None), (a1, f1, None)]
        elif len(fancy) == 1:
            a, f, s = fancy[0]
            if len(s) != 1:
                raise TraceError("fancy indices of more than one dimension")
            fancy = [(a, f, None)]
        elif len(fancy) > 2:
            raise TraceError("more than two fancy indices")
        return basic, [(a, f) for a, f, _s in fancy]

    def _basic_view(self, basic: list) -> Node:
        storage, offset, strides = self.graph.storage_view(self.node)
        shape, new_strides, axis = [], [], 0
        for b in basic:
            if b is None:
                shape.append(1)
                new_strides.append(0)
                continue
            if isinstance(b, int):
                offset += b * strides[axis]
            else:
                start, stop, step = b
                count = len(range(start, stop, step))
                offset += start * strides[axis]
                shape.append(count)
                new_strides.append(step * strides[axis])
            axis += 1
        return self.graph.view(storage, offset, tuple(new_strides), tuple(shape))

    def __getitem__(self, key: Any) -> TArray:
        basic, fancy = self._index(key)
        node = self._basic_view(basic)
        if fancy:
            shape = list(node.shape)
            for a, f in fancy:
                shape[a] = len(f)
            node = self.graph.node("gather", (node,), tuple(shape), node.cplx, tuple(fancy))
        return self._wrap(node)

    def __setitem__(self, key: Any, value: Any) -> None:
        basic, fancy = self._index(key)
        region = self._basic_view(basic)
        shape = list(region.shape)
        for a, f in fancy:
            shape[a] = len(f)
        v = self._node_of(value)
        if _broadcast_shape(v.shape, tuple(shape)) != tuple(shape):
            raise TraceError(f"cannot assign shape {v.shape} to a region of {tuple(shape)}")
        if v.cplx and not self.node.cplx:
            raise TraceError("a complex value assigned into a real traced array")
        spec = (tuple(basic), tuple(fancy))
        self.node = self.graph.node("update", (self.node, v), self.shape, self.node.cplx,
                                    spec)

    # ------------------------------------------------------------------ arithmetic
    def _ew(self, name: str, a: Any, b: Any) -> TArray:
        na, nb = self._node_of(a), self._node_of(b)
        shape = _broadcast_shape(na.shape, nb.shape)
        if name in ("add", "sub") and nb.op == "zeros" and shape == na.shape:
            return self._wrap(na)
        if name == "add" and na.op == "zeros" and shape == nb.shape:
            return self._wrap(nb)
        if name == "mul" and (na.op == "zeros" or nb.op == "zeros"):
            return self._wrap(self.graph.zeros(shape, na.cplx or nb.cplx))
        return self._wrap(self.graph.node("ew", (na, nb), shape, na.cplx or nb.cplx, (name,)))

    def _scale(self, factor: Any) -> TArray:
        f = complex(factor)
        if f == 1:
            return self
        if f == 0:
            return self._wrap(self.graph.zeros(self.shape, self.node.cplx))
        cplx = self.node.cplx or f.imag != 0
        value = f if f.imag != 0 else f.real
        return self._wrap(self.graph.node("ew", (self.node,), self.shape, cplx,
                                          ("scale", value)))

    def __add__(self, o: Any) -> TArray:
        return self._ew("add", self, o)

    def __radd__(self, o: Any) -> TArray:
        return self._ew("add", o, self)

    def __sub__(self, o: Any) -> TArray:
        return self._ew("sub", self, o)

    def __rsub__(self, o: Any) -> TArray:
        return self._ew("sub", o, self)

    def __mul__(self, o: Any) -> TArray:
        if _is_scalar(o) or (isinstance(o, np.ndarray) and o.ndim == 0):
            return self._scale(complex(np.asarray(o)))
        return self._ew("mul", self, o)

    def __rmul__(self, o: Any) -> TArray:
        return self.__mul__(o)

    def __truediv__(self, o: Any) -> TArray:
        if _is_scalar(o):
            return self._scale(1.0 / complex(o))
        raise TraceError("division by a traced array")

    def __neg__(self) -> TArray:
        return self._scale(-1.0)

    def __matmul__(self, o: Any) -> TArray:
        return _dot(self, o)

    def __rmatmul__(self, o: Any) -> TArray:
        return _dot(o, self)

    __iadd__ = __add__
    __isub__ = __sub__

    def __array_ufunc__(self, ufunc: Any, method: str, *inputs: Any, **kwargs: Any) -> Any:
        if method != "__call__" or kwargs:
            raise TraceError(f"cannot trace numpy.{ufunc.__name__}.{method}")
        name = ufunc.__name__
        if name == "add":
            return _first(inputs)._ew("add", *inputs)
        if name == "subtract":
            return _first(inputs)._ew("sub", *inputs)
        if name == "multiply":
            a, b = inputs
            if not isinstance(a, TArray):
                a, b = b, a
            return a * b
        if name == "negative":
            return -inputs[0]
        if name == "true_divide" and isinstance(inputs[0], TArray):
            return inputs[0] / inputs[1]
        if name == "matmul":
            return _dot(*inputs)
        raise TraceError(f"cannot trace numpy.{name}")

    def __array_function__(self, func: Any, types: Any, args: Any, kwargs: Any) -> Any:
        handler = _FUNCTIONS.get(func.__name__)
        if handler is None:
            raise TraceError(f"cannot trace numpy.{func.__name__}")
        return handler(*args, **kwargs)


def _first(values: Sequence[Any]) -> TArray:
    for v in values:
        if isinstance(v, TArray):
            return v
        if isinstance(v, np.ndarray) and v.dtype == object:
            for item in v.ravel():
                if isinstance(item, TArray):
                    return item
    raise TraceError("no traced value among the arguments")


def _dot(a: Any, b: Any) -> TArray:
    """``numpy.dot``: the last axis of ``a`` with the second to last of ``b`` (its only one
    when it is 1-D); scalars scale."""
    t = _first((a, b))
    na, nb = t._node_of(a), t._node_of(b)
    if na.shape == () or nb.shape == ():
        raise TraceError("numpy.dot with a 0-d traced array")
    k = na.shape[-1]
    kb = nb.shape[0] if len(nb.shape) == 1 else nb.shape[-2]
    if k != kb:
        raise TraceError(f"numpy.dot of shapes {na.shape} and {nb.shape}")
    shape = na.shape[:-1] + (nb.shape[:-2] + nb.shape[-1:] if len(nb.shape) > 1 else ())
    cplx = na.cplx or nb.cplx
    if na.op == "zeros" or nb.op == "zeros" or k == 0:
        return t._wrap(t.graph.zeros(shape, cplx))
    return t._wrap(t.graph.node("dot", (na, nb), shape, cplx))


def _concatenate(arrays: Sequence[Any], axis: int = 0, **kwargs: Any) -> TArray:
    if kwargs:
        raise TraceError(f"numpy.concatenate with {sorted(kwargs)}")
    t = _first(arrays)
    nodes = [t._node_of(a) for a in arrays]
    ndim = len(nodes[0].shape)
    if any(len(n.shape) != ndim for n in nodes) or ndim == 0:
        raise TraceError("numpy.concatenate of arrays of different dimensions")
    axis = axis % ndim
    shape = list(nodes[0].shape)
    shape[axis] = sum(n.shape[axis] for n in nodes)
    for n in nodes:
        if any(n.shape[i] != shape[i] for i in range(ndim) if i != axis):
            raise TraceError("numpy.concatenate of arrays of other shapes")
    nodes = [n for n in nodes if n.shape[axis]]
    if len(nodes) == 1:
        return t._wrap(nodes[0])
    return t._wrap(t.graph.node("concat", tuple(nodes), tuple(shape),
                                any(n.cplx for n in nodes), (axis,)))


def _hstack(arrays: Sequence[Any], **kwargs: Any) -> TArray:
    t = _first(arrays)
    nodes = [t._node_of(a) for a in arrays]
    return _concatenate(arrays, axis=0 if len(nodes[0].shape) == 1 else 1, **kwargs)


def _vstack(arrays: Sequence[Any], **kwargs: Any) -> TArray:
    t = _first(arrays)
    nodes = [t._node_of(a) for a in arrays]
    if any(len(n.shape) != 2 for n in nodes):
        raise TraceError("numpy.vstack of arrays that are not 2-D")
    return _concatenate(arrays, axis=0, **kwargs)


def _zeros_like(a: TArray, dtype: Any = None, **kwargs: Any) -> TArray:
    cplx = a.node.cplx if dtype is None else np.dtype(dtype).kind == "c"
    return a._wrap(a.graph.zeros(a.shape, cplx))


def _result_type(*args: Any) -> np.dtype:
    kinds = []
    for a in args:
        if isinstance(a, TArray):
            kinds.append(a.dtype)
        else:
            kinds.append(np.result_type(a))
    return np.result_type(*kinds)


def _iscomplexobj(a: Any) -> bool:
    return bool(a.node.cplx) if isinstance(a, TArray) else bool(np.iscomplexobj(a))


_FUNCTIONS = {
    "dot": _dot,
    "matmul": _dot,
    "concatenate": _concatenate,
    "hstack": _hstack,
    "vstack": _vstack,
    "zeros_like": _zeros_like,
    "result_type": _result_type,
    "iscomplexobj": _iscomplexobj,
}
