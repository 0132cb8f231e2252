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

from ..equations.jacobians import Derivatives
from ..errors import GenerationError
from ..model import (
    ExpressionOutput,
    ForceOutput,
    Frame,
    GeneralizedForce,
    KinematicOutput,
    PointForce,
    RotationalSpringDamper,
    SpringDamper,
    System,
    Torque,
    as_expr,
    input_rate_name,
    symbol,
)
from .cse import Assignment, Block, CseMethod, eliminate, free_symbols, prune
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
    "second_derivative_block",
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


def derivative_block(derivatives: Derivatives, method: CseMethod
                     ) -> tuple[Block, sp.ImmutableMatrix]:
    """The derivatives that :mod:`neweul_py.equations.jacobians` returns, as one CSE'd block
    (their intermediates, then the entries of the matrices side by side, row-major) and the
    joined matrix in the block's symbols."""
    J = derivatives.joined
    block = eliminate(derivatives.intermediates, J.flat(), prefix="_ncg_e", method=method)
    return block, sp.ImmutableMatrix(J.shape[0], J.shape[1], list(block.finals))


def second_derivative_block(derivatives: Derivatives, method: CseMethod
                            ) -> tuple[Block, sp.ImmutableMatrix]:
    """:func:`derivative_block` of directional (second) derivatives, taken through a printed
    first-derivative block: their common subexpressions get names of their own (``_ncg_t``)."""
    J = derivatives.joined
    block = eliminate(derivatives.intermediates, J.flat(), prefix="_ncg_t", method=method)
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
    rows = M.tolist()                    # entries by list index: no sympy indexing per entry
    values: list[sp.Expr] = []
    where: list[list[tuple[int, int]]] = []
    for i in range(n):
        for j in range(i, n):
            if i != j and rows[i][j] == rows[j][i]:
                values.append(rows[i][j])
                where.append([(i, j), (j, i)])
            else:
                values.append(rows[i][j])
                where.append([(i, j)])
                if i != j:
                    values.append(rows[j][i])
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
    rows = J.tolist()
    return {(i, j): v for i, row in enumerate(rows) for j, v in enumerate(row) if v != 0}


def _coordinate_units(system: System) -> list[str]:
    """``rad`` for coordinates used only as rotation angles, ``m`` only in translations."""
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
    return cu


def _expression_unit(expr: sp.Expr, known: dict[sp.Symbol, str]) -> str:
    """The unit of ``c·s`` or a sum of such terms of one unit (``zw − zr``), ``""`` else."""
    terms = sp.Add.make_args(as_expr(expr))
    found = set()
    for term in terms:
        factors = [f for f in sp.Mul.make_args(term) if not f.is_Number]
        if len(factors) != 1 or factors[0] not in known:
            return ""
        found.add(known[factors[0]])
    return found.pop() if len(found) == 1 else ""


def units(system: System) -> tuple[list[str], list[str]]:
    """Best-effort SI units of coordinates (rad for rotation angles, m for translations) and
    of outputs (kinematic outputs ``m``, ``m/s``; forces reported by force elements ``N``,
    torques ``N m``; an expression that is a coordinate, a velocity or an input, times a
    number, or a sum of such terms of one unit); ``""`` where unknown."""
    cu = _coordinate_units(system)
    known: dict[sp.Symbol, str] = {}
    for c, unit in zip(system.coordinates, cu, strict=True):
        if unit:
            known[c.symbol], known[c.velocity_symbol] = unit, f"{unit}/s"
    for name, unit in input_units(system).items():
        if unit:
            known[symbol(name)] = unit
    forces = {el.name: el for el in system.forces}
    ou = []
    for o in system.outputs:
        if isinstance(o, KinematicOutput):
            ou.append("m" if o.quantity == "position" else "m/s")
        elif isinstance(o, ForceOutput):
            ou.append(_force_unit(o, forces.get(o.force)))
        elif isinstance(o, ExpressionOutput):
            ou.append(_expression_unit(o.expr, known))
        else:
            ou.append("")
    return cu, ou


def _force_unit(output: ForceOutput, element: object) -> str:
    if output.component in ("fx", "fy", "fz"):
        return "N"
    if output.component in ("mx", "my", "mz"):
        return "N m"
    if isinstance(element, SpringDamper):
        return "N"
    if isinstance(element, RotationalSpringDamper):
        return "N m"
    return ""


def input_units(system: System) -> dict[str, str]:
    """Best-effort SI unit of each input and of its rates ``d_<u>``, ``dd_<u>`` (``/s``,
    ``/s²``), by where the input enters: alone in frame translations ``m``, rotation angles
    ``rad``; as a component of force vectors or a generalized force on a translation ``N``; of
    torque vectors or a generalized force on an angle ``N m``. ``""`` where it enters
    elsewhere (in expressions, force laws) or in more than one kind of place."""
    seen: dict[sp.Symbol, set[str]] = {}

    def mark(expr: sp.Expr, unit: str) -> None:
        expr = as_expr(expr)
        for s in expr.free_symbols:
            seen.setdefault(s, set()).add(unit if expr == s else "?")

    coordinate_units = dict(zip((c.name for c in system.coordinates),
                                _coordinate_units(system), strict=True))
    for frame in system.frames:
        for _axis, angle in frame.rotation:
            mark(angle, "rad")
        for e in frame.translation:
            mark(e, "m")
    for el in system.forces:
        if isinstance(el, PointForce | Torque):
            for e in el.vector:
                mark(e, "N" if isinstance(el, PointForce) else "N m")
        elif isinstance(el, GeneralizedForce):
            mark(el.value, {"m": "N", "rad": "N m"}.get(
                coordinate_units.get(el.coordinate, ""), "?"))
        else:
            for e in vars(el).values():
                if isinstance(e, sp.Basic):
                    mark(e, "?")
    out: dict[str, str] = {}
    orders = system.input_rate_orders
    for i in system.inputs:
        found = seen.get(i.symbol, set())
        unit = next(iter(found)) if len(found) == 1 and "?" not in found else ""
        out[i.name] = unit
        for k in range(1, orders[i.name] + 1):
            out[input_rate_name(i.name, k)] = f"{unit}/s{'²' if k == 2 else ''}" if unit else ""
    return out


def input_rates(system: System) -> dict[str, list[str]]:
    """Input → the entries of ``u`` that are its time derivatives (``d_<u>``, ``dd_<u>``),
    for the inputs that have them (kinematic excitation; docs/generated-module-protocol.md)."""
    orders = system.input_rate_orders
    return {
        i.name: [input_rate_name(i.name, k) for k in range(1, orders[i.name] + 1)]
        for i in system.inputs
        if orders[i.name]
    }


