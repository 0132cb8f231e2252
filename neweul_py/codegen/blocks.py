"""Building blocks of generated functions, shared by every code writer of :mod:`neweul_py.codegen`.

A generated function is a list of source lines: a prologue that unpacks the argument arrays
into Python floats (:func:`prologue`, :func:`inputs_prologue`), the CSE'd assignments
(:func:`assignments`) and the fills of the result arrays (:func:`vector`, :func:`matrix_fill`,
:func:`mass_fill`); :func:`function` wraps them into a ``def``. :class:`Context` holds the
names and symbol groups of one module, so that all of its functions agree on them.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import sympy as sp

from ..errors import GenerationError
from ..model import Frame, KinematicOutput, System, input_rate_name
from .cse import Assignment, Block, CseMethod, eliminate, free_symbols, prune
from .derivatives import jacobian
from .printer import FastPrinter, NamePool

__all__ = [
    "INDENT",
    "Context",
    "assignments",
    "checked",
    "derivative_block",
    "function",
    "input_rates",
    "inputs_prologue",
    "mass_entries",
    "mass_fill",
    "matrix_fill",
    "prologue",
    "sparse",
    "subblock",
    "units",
    "unpack_line",
    "uses",
    "vector",
]

INDENT = "    "


@dataclass
class Context:
    """Names and symbol groups shared by all functions of one module."""

    y: tuple[sp.Symbol, ...]
    yd: tuple[sp.Symbol, ...]
    p: tuple[sp.Symbol, ...]
    u: tuple[sp.Symbol, ...]
    intermediates: tuple[Assignment, ...]
    pool: NamePool
    printer: FastPrinter = field(init=False)

    def __post_init__(self) -> None:
        self.printer = FastPrinter(self.pool.names)

    def name(self, s: sp.Symbol) -> str:
        return self.pool.names[s]

    def pr(self, e: sp.Expr) -> str:
        return self.printer.doprint_expr(e)


def unpack_line(names: Sequence[str], source: str) -> str:
    if len(names) == 1:
        return f"{names[0]}, = {source}"
    return f"{', '.join(names)} = {source}"


def checked(ctx: Context, block: Block, allowed: Sequence[sp.Symbol], what: str) -> Block:
    """Check a function body only uses the symbols the function receives; name its locals."""
    assigned = {s for s, _ in block.assignments}
    free: set[sp.Symbol] = set()
    for _, e in block.assignments:
        free |= free_symbols(e)
    for e in block.finals:
        free |= free_symbols(e)
    bad = sorted((s for s in free - assigned - set(allowed)), key=lambda s: s.name)
    if bad:
        raise GenerationError(
            f"{what} depends on {', '.join(s.name for s in bad)}, which it cannot use"
        )
    for s, _ in block.assignments:
        if s not in ctx.pool.names:
            wanted = s.name[len("_ncg"):] if s.name.startswith("_ncg_") else s.name
            ctx.pool.claim(s, wanted)
    return block


def subblock(program: Block, finals: Sequence[sp.Expr]) -> Block:
    """The part of a CSE'd program that ``finals`` (expressions in its symbols) need."""
    return Block(tuple(prune(program.assignments, finals)), tuple(finals))


def derivative_block(
    program: Sequence[Assignment],
    exprs: Sequence[sp.Expr],
    wrt: Sequence[sp.Symbol],
    method: CseMethod,
    tick: Callable[[float], None] | None = None,
) -> tuple[Block, sp.ImmutableMatrix]:
    """Forward-mode Jacobian of ``exprs`` through ``program``, then CSE over the result
    (``tick``: progress of the derivative, :func:`.derivatives.jacobian`)."""
    d_inter, J = jacobian(exprs, wrt, program, prefix="_ncg_d",
                          tick=None if tick is None else (lambda f: tick(0.6 * f)))
    if tick is not None:
        tick(0.6)
    block = eliminate(d_inter, list(J), prefix="_ncg_e", method=method)
    if tick is not None:
        tick(1.0)
    return block, sp.ImmutableMatrix(J.shape[0], J.shape[1], list(block.finals))


def uses(block: Block, group: Sequence[sp.Symbol]) -> bool:
    gs = set(group)
    return any(free_symbols(e) & gs for _, e in block.assignments) or any(
        free_symbols(e) & gs for e in block.finals
    )


def prologue(
    ctx: Context, block: Block, sources: Sequence[tuple[Sequence[sp.Symbol], str]]
) -> list[str]:
    """Unpack the argument arrays the block uses into Python floats."""
    lines = []
    for group, source in sources:
        if group and uses(block, group):
            lines.append(unpack_line([ctx.name(s) for s in group], source))
    return lines


def inputs_prologue(ctx: Context, block: Block) -> list[str]:
    if not ctx.u or not uses(block, ctx.u):
        return []
    return [
        "if u is None:",
        f"{INDENT}u = default_inputs(t, p)",
        unpack_line([ctx.name(s) for s in ctx.u], "_np.asarray(u, dtype=_np.float64).tolist()"),
    ]


def assignments(ctx: Context, block: Block,
                tick: Callable[[float], None] | None = None) -> list[str]:
    """The printed assignments of ``block`` (``tick``: called with the fraction printed)."""
    if tick is None:
        return [f"{ctx.name(s)} = {ctx.pr(e)}" for s, e in block.assignments]
    lines = []
    count = len(block.assignments)
    every = max(count // 50, 1)
    for k, (s, e) in enumerate(block.assignments):
        if k % every == 0:
            tick(k / count)
        lines.append(f"{ctx.name(s)} = {ctx.pr(e)}")
    return lines


def vector(ctx: Context, target: str, values: Sequence[sp.Expr]) -> list[str]:
    if not values:
        return [f"{target} = _np.zeros(0)"]
    items = ", ".join(ctx.pr(v) for v in values)
    if len(values) == 1:
        items += ","
    return [f"{target} = _np.array(({items}), dtype=_np.float64)"]


def matrix_fill(
    ctx: Context, target: str, shape: tuple[int, int], entries: dict[tuple[int, int], sp.Expr]
) -> list[str]:
    """Fill a preallocated array; ``entries`` maps (i, j) → value (absent means zero)."""
    full = len(entries) == shape[0] * shape[1]
    alloc = "empty" if full else "zeros"
    lines = [f"{target} = _np.{alloc}({shape!r})"]
    for (i, j), v in entries.items():
        lines.append(f"{target}[{i}, {j}] = {ctx.pr(v)}")
    return lines


def mass_entries(M: sp.ImmutableMatrix) -> tuple[list[sp.Expr], list[list[tuple[int, int]]]]:
    """Unique entries of M (symmetric pairs share one) and the positions of each."""
    n = M.shape[0]
    values: list[sp.Expr] = []
    where: list[list[tuple[int, int]]] = []
    for i in range(n):
        for j in range(i, n):
            if i != j and M[i, j] == M[j, i]:
                values.append(M[i, j])
                where.append([(i, j), (j, i)])
            else:
                values.append(M[i, j])
                where.append([(i, j)])
                if i != j:
                    values.append(M[j, i])
                    where.append([(j, i)])
    return values, where


def mass_fill(
    ctx: Context, n: int, reduced: Sequence[sp.Expr], where: Sequence[Sequence[tuple[int, int]]]
) -> list[str]:
    lines = [f"M = _np.empty(({n}, {n}))"]
    for value, places in zip(reduced, where, strict=True):
        targets = " = ".join(f"M[{i}, {j}]" for i, j in places)
        lines.append(f"{targets} = {ctx.pr(value)}")
    return lines


def function(signature: str, doc: str, body: Sequence[str]) -> list[str]:
    out = [f"def {signature}:", f'{INDENT}"""{doc}"""']
    out += [INDENT + line for line in body]
    return [*out, "", ""]


def sparse(J: sp.ImmutableMatrix) -> dict[tuple[int, int], sp.Expr]:
    return {
        (i, j): J[i, j] for i in range(J.shape[0]) for j in range(J.shape[1]) if J[i, j] != 0
    }


def units(system: System) -> tuple[list[str], list[str]]:
    """Best-effort SI units of coordinates (rad for rotation angles, m for translations) and
    of kinematic outputs; ``""`` where unknown."""
    rot: set[sp.Symbol] = set()
    trans: set[sp.Symbol] = set()
    frame: Frame
    for frame in system.frames:
        for _axis, angle in frame.rotation:
            rot |= angle.free_symbols
        trans |= frame.translation.free_symbols
    cu = []
    for c in system.coordinates:
        s = c.symbol
        cu.append("rad" if s in rot and s not in trans else "m" if s in trans and s not in rot
                  else "")
    ou = []
    for o in system.outputs:
        if isinstance(o, KinematicOutput):
            ou.append("m" if o.quantity == "position" else "m/s")
        else:
            ou.append("")
    return cu, ou


def input_rates(system: System) -> dict[str, list[str]]:
    """Input → the entries of ``u`` that are its time derivatives (``d_<u>``, ``dd_<u>``),
    for the inputs that have them (kinematic excitation; docs/generated-module-protocol.md)."""
    orders = system.input_rate_orders
    return {
        i.name: [input_rate_name(i.name, k) for k in range(1, orders[i.name] + 1)]
        for i in system.inputs
        if orders[i.name]
    }


