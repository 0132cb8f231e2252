"""Printing traced kernel programs (:mod:`.c_trace`) as C99 loops.

A :class:`.c_trace.Graph` holds the operations the floating-frame kernel performed on traced
values. :class:`KernelPrinter` turns chosen outputs of it into C functions:

* **Levels.** Every node has the level of its highest input: 0 for the arrays of the data
  file (bound once, :func:`bind_lines`), 1 for what changes with the schedule (the weights
  of parametric bodies: the mixed samples, ``S_V(σ)``, ``S_W(σ)`` — computed by a *schedule
  function* when the weights change, :meth:`KernelPrinter.schedule_function`), 2 for the
  arguments of every call. A function computes only its level-2 nodes; what depends on the
  data alone is computed at binding, what depends on the weights once per weights.
* **Storage.** Views (slices, transposes, reshapes, new axes, broadcasts) are affine maps
  ``offset + Σ iₖ·strideₖ`` into the storage of the node they view — a leaf (an argument or
  a bound array), or a computed node's own contiguous buffer (``static`` arrays, sized at
  generation); no view is copied. An assignment into a part of an array writes into the
  array's buffer when nothing else reads the array afterwards, else into a copy.
* **Operations.** Elementwise operations with NumPy's broadcasting; ``numpy.dot`` of
  matrices and vectors through the fixed helpers of :data:`.c_kernel_text.C_DOT` (eight
  partial sums, the zero entries of a vector of weights skipped: mixing a parametric body's
  samples reads only the rows of the samples next to ``σ``), other products as loops;
  concatenations, fancy indexing (index tables are structure and printed), assignments; the
  compact mixing of a parametric body's samples (op ``"mix"``,
  :data:`.c_kernel_text.C_MIX`: its index tables are data, bound and read through
  ``nw_D[k]``, not printed; a mix by the real weights of a body in
  :attr:`KernelPrinter.polynomial_weights` reads the rows of their polynomial on the
  schedule's interval, :data:`.c_splice_text.POLY_C`). Complex values
  (``double complex`` of C99) are what the complex-step derivatives of the kernel need.

Structural constants of the kernel (the maps of ``ffrf_rigid_map``, zeros, unit matrices)
are printed; the arrays of the data file never are — they are read through ``nw_D[k]``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..errors import GenerationError
from .c_trace import Graph, Node, TArray

__all__ = ["KernelPrinter"]

#: The printed functions are loops over arrays: compiled with gcc's -O3 (vectorized; the
#: libraries build with -O1, and other compilers ignore the attribute).
_O3 = '__attribute__((optimize("O3"))) '


def _double(v: float) -> str:
    r = repr(float(v))
    return r if r not in ("inf", "-inf", "nan") else {"inf": "INFINITY", "-inf": "(-INFINITY)",
                                                       "nan": "NAN"}[r]


def _scalar(v: complex | float) -> str:
    if isinstance(v, complex):
        return f"({_double(v.real)} + {_double(v.imag)} * I)"
    return f"({_double(v)})"


def _contiguous(shape: Sequence[int]) -> tuple[int, ...]:
    strides, step = [], 1
    for s in reversed(shape):
        strides.append(step)
        step *= max(int(s), 1)
    return tuple(reversed(strides))


def _loops(shape: Sequence[int], body: list[str], indent: str = "    ") -> list[str]:
    """``for`` loops over ``shape`` (indices ``i0, i1 …``) around ``body``."""
    lines, pad = [], indent
    for a, n in enumerate(shape):
        lines.append(f"{pad}for (long i{a} = 0; i{a} < {int(n)}; ++i{a})")
        pad += "    "
    if not shape:
        return [indent + b for b in body]
    if len(body) == 1:
        return [*lines, pad + body[0]]
    return [*lines, pad[:-4] + "{", *(pad + b for b in body), pad[:-4] + "}"]


def _affine(offset: int, strides: Sequence[int], idx: Sequence[str]) -> str:
    terms = [str(offset)] if offset else []
    for s, i in zip(strides, idx, strict=True):
        if s == 1:
            terms.append(i)
        elif s:
            terms.append(f"{i} * {s}")
    return " + ".join(terms) if terms else "0"


class KernelPrinter:
    """C functions of the outputs of a traced :class:`~.c_trace.Graph` (module docstring).

    Parameters
    ----------
    graph
        The traced programs.
    data
        The data leaves' names in the order of the bound pointer table ``nw_D``.
    prefix
        Prefix of the static buffers' names (one printer per C file).
    """

    def __init__(self, graph: Graph, data: Sequence[str], prefix: str = "nw_k") -> None:
        self.graph = graph
        self.data = {name: i for i, name in enumerate(data)}
        self.prefix = prefix
        self.level: dict[int, int] = {}
        for n in graph.nodes:                 # ids are a topological order
            if n.op == "leaf":
                self.level[n.id] = n.params[1]
            else:
                self.level[n.id] = max((self.level[a.id] for a in n.args), default=0)
        self.static: list[str] = []           # buffers of levels 0 and 1
        self._global: dict[int, str] = {}     # node id → its buffer (levels 0, 1)
        self._consts: dict[int, str] = {}
        self.bound: list[str] = []            # level-0 computations (after binding)
        self._done_low: set[int] = set()
        self.params: dict[int, str] = {}      # leaves of level 1, 2 → C pointer names
        # the weights leaves whose real mixes read the polynomial rows of nw_poly: leaf id →
        # (parametric body k, degree + 1); and the rows made: (k, data name) → (buffer, nv)
        self.polynomial_weights: dict[int, tuple[int, int]] = {}
        self.polynomials: dict[tuple[int, str], tuple[str, int]] = {}
        # matrices whose products x @ B call a helper along the rows' nonzero spans: storage
        # id → (offset, row length, the C function), e.g. S_W and nw_wmap (c_splice)
        self.row_spans: dict[int, tuple[int, int, str]] = {}

    # ------------------------------------------------------------------ names
    def _ctype(self, node: Node) -> str:
        return "double complex" if node.cplx else "double"

    def _storage_name(self, node: Node, local: dict[int, str]) -> str:
        if node.op == "leaf":
            name, level = node.params
            if level == 0:
                if name not in self.data:
                    raise GenerationError(f"the data array {name!r} is not bound")
                return f"nw_D[{self.data[name]}]"
            if node.id not in self.params:
                raise GenerationError(f"the input {name!r} is not an argument")
            return self.params[node.id]
        if node.op == "const":
            return self._const(node)
        if node.id in local:
            return local[node.id]
        if node.id in self._global:
            return self._global[node.id]
        raise GenerationError(f"{node!r} is read before it is computed")

    def _const(self, node: Node) -> str:
        if node.id not in self._consts:
            name = f"{self.prefix}c{node.id}"
            values = np.frombuffer(node.params[0], dtype=np.float64)
            self.static.append(f"static const double {name}[{max(values.size, 1)}] = "
                               f"{{{', '.join(_double(v) for v in values) or '0.0'}}};")
            self._consts[node.id] = name
        return self._consts[node.id]

    def access(self, node: Node, idx: Sequence[str], local: dict[int, str]) -> str:
        """The C expression of the element ``idx`` of ``node`` (broadcast dimensions of
        size 1 read index 0)."""
        idx = [("0" if d == 1 else i) for d, i in zip(node.shape, idx, strict=True)]
        storage, offset, strides = self.graph.storage_view(node)
        if storage.op == "zeros":
            return "0.0"
        return f"{self._storage_name(storage, local)}[{_affine(offset, strides, idx)}]"

    # ------------------------------------------------------------------ functions
    def needed(self, outputs: Sequence[Node]) -> list[Node]:
        """The nodes ``outputs`` depend on, in topological order."""
        seen: set[int] = set()
        stack = list(outputs)
        while stack:
            n = stack.pop()
            if n.id in seen:
                continue
            seen.add(n.id)
            stack.extend(n.args)
        return [n for n in self.graph.nodes if n.id in seen]

    def _materialized(self, n: Node) -> bool:
        return n.op not in ("leaf", "view", "zeros", "const")

    def _emit_low(self, nodes: Sequence[Node], level: int, target: list[str]) -> None:
        """Buffers and code of the nodes of ``level`` (0: at binding, 1: per weights)."""
        for n in nodes:
            if (self.level[n.id] != level or not self._materialized(n)
                    or n.id in self._done_low):
                continue
            name = f"{self.prefix}g{n.id}"
            self.static.append(f"static {self._ctype(n)} {name}[{max(n.size, 1)}];")
            self._global[n.id] = name
            target += self._compute(n, name, {}, set())
            self._done_low.add(n.id)

    def function(self, signature: str, params: Sequence[tuple[str, TArray]],
                 outputs: Sequence[tuple[str, TArray]], direct: bool = False) -> list[str]:
        """A ``static void`` C function ``signature`` computing ``outputs`` (into the pointer
        named first in each pair) from the level-2 leaves ``params`` (pointer names); its
        level-0 and level-1 nodes must have been emitted (:meth:`bind_lines`,
        :meth:`schedule_function`).

        An assignment to a part of an array whose base nothing reads afterwards writes into
        the base's buffer, and one that adds to that part (``x[e] += v``) adds in place.
        ``direct``: the outputs' pointers never alias the arguments, and an output computed
        in a buffer of its own is computed in the output's memory instead of copied there."""
        for name, t in params:
            self.params[t.node.id] = name
        outs = [t.node for _n, t in outputs]
        nodes = self.needed(outs)
        self._emit_low(nodes, 0, self.bound)
        if any(self.level[n.id] == 1 and self._materialized(n) and n.id not in self._done_low
               for n in nodes):
            raise GenerationError(f"{signature}: schedule-level values not computed")
        calls = [n for n in nodes if self.level[n.id] == 2 and self._materialized(n)]
        last: dict[int, int] = {}             # storage id → the last node reading it
        readers: dict[int, int] = {}          # node id → how many nodes read it
        for n in calls:
            for a in n.args:
                st = self.graph.storage_view(a)[0]
                last[st.id] = max(last.get(st.id, -1), n.id)
                readers[a.id] = readers.get(a.id, 0) + 1
        for n in outs:
            last[self.graph.storage_view(n)[0].id] = len(self.graph.nodes)
            readers[n.id] = readers.get(n.id, 0) + 2
        ids = {n.id for n in calls}
        alias: dict[int, int] = {}            # update → the node whose buffer it writes
        fused: dict[int, tuple[str, Node, int]] = {}   # update → (+= or -=, added, its node)
        for n in calls:
            if n.op != "update":
                continue
            base, value = n.args
            # the update is the last reader of its base (the values it assigns were read
            # into their own buffer first): it writes into the base's buffer
            if (base.id in ids and last.get(base.id) == n.id
                    and self.graph.storage_view(value)[0].id != base.id):
                alias[n.id] = base.id
                add = self._in_place(n, value, readers)
                if add is not None:
                    fused[n.id] = add
        skipped = {fused[u][2] for u in fused}
        blocks = self._gemm_blocks(calls, alias, fused, readers)     # dot → its added block
        added_by_gemm = {u.id for u in blocks.values()}
        root: dict[int, int] = {}
        for n in calls:
            root[n.id] = root[alias[n.id]] if n.id in alias else n.id
        fname = signature.split("(")[0].split()[-1]
        names: dict[int, str] = {}
        if direct:                            # outputs computed where they are wanted
            for target, t in outputs:
                r = root.get(t.node.id)
                if r is not None and r not in names and t.node.id in ids:
                    names[r] = target
        local: dict[int, str] = {}
        body: list[str] = []
        for n in calls:
            if n.id in skipped:
                continue
            r = root[n.id]
            if r not in names:
                names[r] = f"{fname}_t{r}"
                self.static.append(f"static {self._ctype(n)} {names[r]}[{max(n.size, 1)}];")
            local[n.id] = names[r]
            if n.id in added_by_gemm:
                continue
            if n.id in blocks:
                body += self._gemm_add(n, blocks[n.id], fused, names[r], local)
            elif n.id in fused:
                sign, added, _v = fused[n.id]
                body += self._add_region(n, names[r], sign, added, local)
            else:
                body += self._compute(n, names[r], local,
                                      {n.args[0].id} if n.id in alias else set())
        for (target, _t), n in zip(outputs, outs, strict=True):
            if local.get(n.id) == target:
                continue
            idx = [f"i{a}" for a in range(len(n.shape))]
            body += _loops(n.shape, [f"{target}[{_affine(0, _contiguous(n.shape), idx)}] = "
                                     f"{self.access(n, idx, local)};"])
        return [f"{_O3}static void {signature}", "{", *body, "}", ""]

    def _region(self, n: Node) -> tuple[int, tuple[int, ...], tuple[int, ...]] | None:
        """``(offset, strides, shape)`` of the part of its (contiguous) base an update
        assigns, or ``None`` with fancy indices."""
        basic, fancy = n.params
        if fancy:
            return None
        strides = _contiguous(n.shape)
        offset, out_strides, shape, axis = 0, [], [], 0
        for b in basic:
            if b is None:
                return None
            if isinstance(b, int):
                offset += b * strides[axis]
            else:
                start, stop, step = b
                offset += start * strides[axis]
                out_strides.append(step * strides[axis])
                shape.append(len(range(start, stop, step)))
            axis += 1
        return offset, tuple(out_strides), tuple(shape)

    def _in_place(self, n: Node, value: Node, readers: dict[int, int]
                  ) -> tuple[str, Node, int] | None:
        """``x[part] += v`` (or ``-=``): the assigned values are the base's part plus or minus
        ``v`` and read by nothing else — ``("+", v, id)``, else ``None``."""
        if value.op != "ew" or value.params[0] not in ("add", "sub") or readers.get(
                value.id, 0) != 1 or value.cplx != n.cplx:
            return None
        region = self._region(n)
        part, added = value.args
        if region is None or part.shape != value.shape:
            return None
        storage, offset, strides = self.graph.storage_view(part)
        if storage.id != n.args[0].id or (offset, strides, part.shape) != region:
            return None
        return ("+" if value.params[0] == "add" else "-"), added, value.id

    def _gemm_blocks(self, calls: Sequence[Node], alias: dict[int, int],
                     fused: dict[int, tuple[str, Node, int]], readers: dict[int, int]
                     ) -> dict[int, Node]:
        """Products ``C = A B`` (printed as ``nw_gemm``) to which one update then adds a block
        ``C[r0:r0+nr, c0:c0+nc] ±= X`` and that nothing else reads: the dot's id → the
        update's, printed as one ``nw_gemm_add`` (the mass matrix of a body on a fixed frame:
        the symbolic part's product and the body's block, without zeroing the block's rows
        first). ``X`` must be computed before the product: bound, per weights, or earlier."""
        nodes = {n.id: n for n in calls}
        pairs: dict[int, Node] = {}
        for u, (_sign, added, _v) in fused.items():
            b = nodes.get(alias[u])
            region = self._region(nodes[u])
            if b is None or b.op != "dot" or readers.get(b.id, 0) != 1 or region is None:
                continue
            x, y = b.args
            sx = self.graph.storage_view(added)
            if (b.cplx or x.cplx or y.cplx or added.cplx or len(x.shape) != 2
                    or len(y.shape) != 2 or len(region[2]) != 2
                    or region[1] != (b.shape[1], 1) or added.shape != region[2]
                    or len(sx[2]) != 2 or sx[0].op == "zeros"
                    or "zeros" in (self.graph.storage_view(x)[0].op,
                                   self.graph.storage_view(y)[0].op)
                    or (self.level[sx[0].id] == 2 and sx[0].id >= b.id)):
                continue
            pairs[b.id] = nodes[u]
        return pairs

    def _gemm_add(self, n: Node, u: Node, fused: dict[int, tuple[str, Node, int]], out: str,
                  local: dict[int, str]) -> list[str]:
        """``nw_gemm_add`` of :meth:`_gemm_blocks`' pair ``n`` (the dot), ``u`` (its
        update)."""
        sign, added, _v = fused[u.id]
        a, b = n.args
        ptr = []
        for v in (a, b, added):
            st, off, strides = self.graph.storage_view(v)
            name = self._storage_name(st, local)
            ptr.append((f"{name} + {off}" if off else name, strides))
        (pa, ta), (pb, tb), (px, tx) = ptr
        offset, _strides, (nr, nc) = self._region(u)
        r0, c0 = divmod(offset, n.shape[1])
        return [f"    nw_gemm_add({a.shape[0]}, {b.shape[1]}, {a.shape[1]}, {pa}, {ta[0]}, "
                f"{ta[1]}, {pb}, {tb[0]}, {tb[1]}, {out}, {r0}, {nr}, {c0}, {nc}, {px}, "
                f"{tx[0]}, {tx[1]}, {'1.0' if sign == '+' else '-1.0'});"]

    def _add_region(self, n: Node, out: str, sign: str, added: Node, local: dict[int, str]
                    ) -> list[str]:
        offset, strides, shape = self._region(n)
        idx = [f"i{a}" for a in range(len(shape))]
        return _loops(shape, [f"{out}[{_affine(offset, strides, idx)}] {sign}= "
                              f"{self._operand(added, shape, idx, local)};"])

    def schedule_function(self, signature: str, params: Sequence[tuple[str, TArray]],
                          outputs: Sequence[TArray]) -> list[str]:
        """A ``static void`` C function computing the level-1 nodes ``outputs`` depend on
        into static buffers (called by the module when the weights change); ``params``: the
        level-1 leaves (pointer names)."""
        for name, t in params:
            self.params[t.node.id] = name
        nodes = self.needed([t.node for t in outputs])
        self._emit_low(nodes, 0, self.bound)
        body: list[str] = []
        self._emit_low(nodes, 1, body)
        return [f"{_O3}static void {signature}", "{", *body, "}", ""]

    def pointer(self, t: TArray) -> str:
        """A C pointer expression to the values of ``t`` when they are contiguous in a
        buffer of level 0 or 1 or a bound array (``S_V(σ)`` for the glue code)."""
        storage, offset, strides = self.graph.storage_view(t.node)
        if strides != _contiguous(t.shape):
            raise GenerationError(f"{t.node!r} is not contiguous")
        if storage.op == "leaf" and storage.params[1] == 0:
            base = f"nw_D[{self.data[storage.params[0]]}]"
        elif storage.id in self._global:
            base = self._global[storage.id]
        else:
            raise GenerationError(f"{t.node!r} has no buffer of level 0 or 1")
        return f"({base} + {offset})" if offset else base

    def bind_lines(self) -> list[str]:
        """The level-0 computations (after the data pointers are bound)."""
        return list(self.bound)

    # ------------------------------------------------------------------ computations
    def _compute(self, n: Node, out: str, local: dict[int, str], aliased: set[int]
                 ) -> list[str]:
        idx = [f"i{a}" for a in range(len(n.shape))]
        lin = _affine(0, _contiguous(n.shape), idx)
        if n.op == "ew":
            return self._ew(n, out, idx, lin, local)
        if n.op == "dot":
            return self._dot(n, out, local)
        if n.op == "mix":
            return self._mix(n, out, local)
        if n.op == "pack":
            return [f"    {out}[{i}] = {self.access(a, [], local)};"
                    for i, a in enumerate(n.args)]
        if n.op == "concat":
            return self._concat(n, out, local)
        if n.op == "gather":
            return self._gather(n, out, idx, lin, local)
        if n.op == "update":
            return self._update(n, out, local, aliased)
        raise GenerationError(f"cannot print {n!r}")

    def _operand(self, a: Node, shape: Sequence[int], idx: Sequence[str],
                 local: dict[int, str]) -> str:
        """Element ``idx`` of ``a`` broadcast to ``shape``."""
        k = len(shape) - len(a.shape)
        return self.access(a, idx[k:], local) if a.shape else self.access(a, [], local)

    def _ew(self, n: Node, out: str, idx: list[str], lin: str, local: dict[int, str]
            ) -> list[str]:
        name = n.params[0]
        ops = [self._operand(a, n.shape, idx, local) for a in n.args]
        if name in ("copy", "cast"):
            expr = ops[0]
        elif name == "scale":
            expr = f"{_scalar(n.params[1])} * {ops[0]}"
        else:
            sym = {"add": "+", "sub": "-", "mul": "*"}[name]
            expr = f"{ops[0]} {sym} {ops[1]}"
        return _loops(n.shape, [f"{out}[{lin}] = {expr};"])

    def _concat(self, n: Node, out: str, local: dict[int, str]) -> list[str]:
        axis = n.params[0]
        strides = _contiguous(n.shape)
        lines, start = [], 0
        for a in n.args:
            idx = [f"i{k}" for k in range(len(a.shape))]
            target = [f"({i} + {start})" if k == axis else i for k, i in enumerate(idx)]
            lines += _loops(a.shape, [f"{out}[{_affine(0, strides, target)}] = "
                                      f"{self.access(a, idx, local)};"])
            start += a.shape[axis]
        return lines

    def _table(self, values: Sequence[int]) -> str:
        name = f"{self.prefix}i{len(self.static)}"
        self.static.append(f"static const long {name}[{max(len(values), 1)}] = "
                           f"{{{', '.join(str(int(v)) for v in values) or '0'}}};")
        return name

    def _gather(self, n: Node, out: str, idx: list[str], lin: str, local: dict[int, str]
                ) -> list[str]:
        src = n.args[0]
        mapped = list(idx)
        for axis, values in n.params:
            mapped[axis] = f"{self._table(values)}[{idx[axis]}]"
        return _loops(n.shape, [f"{out}[{lin}] = {self.access(src, mapped, local)};"])

    def _update(self, n: Node, out: str, local: dict[int, str], aliased: set[int]
                ) -> list[str]:
        base, value = n.args
        lines = []
        if base.id not in aliased:
            bs = self.graph.storage_view(base)[0]
            if bs.op == "zeros":
                lines.append(f"    memset({out}, 0, {max(n.size, 1)} * sizeof *{out});")
            else:
                idx = [f"i{a}" for a in range(len(n.shape))]
                lines += _loops(n.shape, [f"{out}[{_affine(0, _contiguous(n.shape), idx)}] = "
                                          f"{self.access(base, idx, local)};"])
        basic, fancy = n.params
        strides = _contiguous(n.shape)
        # the region: per axis of the array, the index expression of the region's axis r
        region_shape, target, r = [], [], 0
        fancy_at = dict(fancy)
        for b in basic:
            if b is None:
                region_shape.append(1)
                r += 1
                continue
            if isinstance(b, int):
                target.append(str(b))
                continue
            start, stop, step = b
            count = len(range(start, stop, step))
            i = f"i{r}"
            if r in fancy_at:
                count = len(fancy_at[r])
                expr = f"{self._table([start + step * v for v in fancy_at[r]])}[{i}]"
            else:
                expr = f"({start} + {step} * {i})" if (start or step != 1) else i
            region_shape.append(count)
            target.append(expr)
            r += 1
        ridx = [f"i{a}" for a in range(len(region_shape))]
        terms = [f"({t}) * {s}" if s != 1 else f"({t})" for t, s in zip(target, strides,
                                                                        strict=True)]
        address = " + ".join(terms) if terms else "0"
        lines += _loops(region_shape, [f"{out}[{address}] = "
                                       f"{self._operand(value, region_shape, ridx, local)};"])
        return lines

    def _mix(self, n: Node, out: str, local: dict[int, str]) -> list[str]:
        """A parametric body's entries ``i0 …`` mixed from its compact form
        (:data:`.c_kernel_text.C_MIX`): ``(x·r) base`` as
        :func:`~neweul_py.ffrf.parametric.ffrf_mix` (set again only when ``x·r`` or the
        binding changed), then the varying and the mirrored entries."""
        x, rows, base, V, index, mirror = n.args
        i0, lo, hi, mlo, mhi = n.params
        ctype = self._ctype(n)
        self.static += [f"static {ctype} {out}_s = NAN;", f"static long {out}_bound = -1;",
                        f"static int {out}_pl[{max(2 * (hi - lo), 1)}];",
                        f"static nw_mixplan {out}_plan = {{-1, 0, {out}_pl}};"]
        ptr = {}
        for name, a in (("x", x), ("rows", rows), ("base", base), ("V", V),
                        ("index", index), ("mirror", mirror)):
            st, off, _s = self.graph.storage_view(a)
            ptr[name] = (f"{self._storage_name(st, local)} + {off}" if off
                         else self._storage_name(st, local))
        call = "nw_mixz" if n.cplx else "nw_mix"
        rows_x, weights = x.shape[0], ptr["x"]
        poly = self._polynomial_rows(x, V)
        if poly is not None:
            rows_x, weights, ptr["V"] = poly
        return ["    {",
                f"        {ctype} s = 0.0;",
                f"        for (int r = 0; r < {x.shape[0]}; ++r) s += ({ptr['x']})[r] * "
                f"({ptr['rows']})[r];",
                f"        if (s != {out}_s || {out}_bound != nw_binds) {{",
                f"            for (long i = 0; i < {n.size}; ++i) "
                f"{out}[i] = s * ({ptr['base']})[{i0} + i];",
                f"            {out}_s = s;", f"            {out}_bound = nw_binds;",
                "        }", "    }",
                f"    {call}({rows_x}, {weights}, {ptr['V']}, {V.shape[1]}, {lo}, {hi}, "
                f"{ptr['index']}, {ptr['mirror']}, {mirror.size // 2}, {mlo}, {mhi}, {i0}, "
                f"{out}, &{out}_plan, nw_binds);"]

    def _polynomial_rows(self, x: Node, V: Node) -> tuple[int, str, str] | None:
        """``(nd, pw, P)`` when the mix by the real weights ``x`` of ``V`` reads the rows
        ``P = C_j V`` of ``nw_poly`` (:data:`.c_splice_text.POLY_C`) instead: ``x`` one of
        :attr:`polynomial_weights` of lower degree than its length, ``V`` a whole data
        array. The buffers are declared here and listed in :attr:`polynomials`."""
        known = self.polynomial_weights.get(x.id) if x.op == "leaf" else None
        if known is None or V.op != "leaf" or V.params[1] != 0 or len(V.shape) != 2:
            return None
        k, nd = known
        if not nd < x.shape[0] == V.shape[0]:
            return None
        name = V.params[0]
        if (k, name) not in self.polynomials:
            buf = f"nw_P{k}_{self.data[name]}"
            if not any(kk == k for kk, _n in self.polynomials):
                self.static.append(f"static double nw_pw{k}[{nd}];")
            self.static += [f"static double {buf}[{nd * V.shape[1] + 1}];",
                            f"static long {buf}_at = -1;"]
            self.polynomials[k, name] = (buf, int(V.shape[1]))
        return nd, f"nw_pw{k}", self.polynomials[k, name][0]

    def _dot(self, n: Node, out: str, local: dict[int, str]) -> list[str]:
        a, b = n.args
        real = not (a.cplx or b.cplx)
        sa, oa, ta = self.graph.storage_view(a)
        sb, ob, tb = self.graph.storage_view(b)
        pa = f"{self._storage_name(sa, local)} + {oa}" if oa else self._storage_name(sa, local)
        pb = f"{self._storage_name(sb, local)} + {ob}" if ob else self._storage_name(sb, local)
        if real and sa.op != "zeros" and sb.op != "zeros":
            if len(a.shape) == 2 and len(b.shape) == 1:
                if ta[0] == 1 and ta[1] != 1:     # Aᵀ x of a row-major A: its rows, scaled
                    spans = self.row_spans.get(sa.id)
                    if spans and spans[:2] == (oa, a.shape[0]) and ta[1] == a.shape[0]:
                        return [f"    {spans[2]}({a.shape[1]}, {pb}, {tb[0]}, {out});"]
                    return [f"    nw_vecmat({a.shape[1]}, {a.shape[0]}, {pb}, {tb[0]}, {pa}, "
                            f"{ta[1]}, 1, {out});"]
                return [f"    nw_gemv({a.shape[0]}, {a.shape[1]}, {pa}, {ta[0]}, {ta[1]}, "
                        f"{pb}, {tb[0]}, {out});"]
            if len(a.shape) == 1 and len(b.shape) == 2:
                spans = self.row_spans.get(sb.id)
                if spans and spans[:2] == (ob, b.shape[1]) and tb == (b.shape[1], 1):
                    return [f"    {spans[2]}({b.shape[0]}, {pa}, {ta[0]}, {out});"]
                return [f"    nw_vecmat({b.shape[0]}, {b.shape[1]}, {pa}, {ta[0]}, {pb}, "
                        f"{tb[0]}, {tb[1]}, {out});"]
            if len(a.shape) == 2 and len(b.shape) == 2:
                return [f"    nw_gemm({a.shape[0]}, {b.shape[1]}, {a.shape[1]}, {pa}, "
                        f"{ta[0]}, {ta[1]}, {pb}, {tb[0]}, {tb[1]}, {out});"]
        # general: out[a…, b…] = Σ_k A[a…, k] B[b_head…, k, b_last]
        ka = len(a.shape) - 1
        ia = [f"i{x}" for x in range(ka)]
        nbo = len(n.shape) - ka
        ib = [f"i{ka + x}" for x in range(nbo)]
        ak = [*ia, "k"]
        bk = ["k"] if len(b.shape) == 1 else [*ib[:-1], "k", ib[-1]]
        zero = "0.0" if real else "0.0 + 0.0 * I"
        lin = _affine(0, _contiguous(n.shape), [*ia, *ib])
        body = [f"{self._ctype(n)} s = {zero};",
                f"for (long k = 0; k < {a.shape[-1]}; ++k) s += "
                f"{self.access(a, ak, local)} * {self.access(b, bk, local)};",
                f"{out}[{lin}] = s;"]
        return _loops(n.shape, body)
