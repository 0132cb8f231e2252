"""The C functions of a CSE'd program (:class:`.cse.Block`) for the compiled backend.

:func:`c_body` prints the statements of a block (locals, then the finals into an output
array; long linear combinations as rows of :class:`.c_printer.DotRows`) and
:func:`c_function` wraps them as a C function; :class:`SymbolGroups` names the symbols of the
equations as elements of the C arguments ``y``, ``yd``, ``p``, ``u``, ``a``. Used for the
programs of rigid models (:mod:`.c_module`) and of the symbolic part of models with elastic
bodies (:mod:`.c_splice`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import sympy as sp

from ..errors import GenerationError
from ..model import time
from .c_printer import CPrinter, DotRows
from .cse import Block, free_symbols

__all__ = ["BIG_FUNCTION", "MIN_RUN", "MMTD_ARGS", "X_ARGS", "X_PROLOGUE", "YYD_ARGS",
           "Y_ARGS", "SymbolGroups", "big", "c_body", "c_function", "uses", "x_prologue"]

_IN = "    "


class SymbolGroups:
    """The symbol groups of the equations and their C names (array elements, ``t``)."""

    def __init__(self, equations: Any) -> None:
        self.y = tuple(equations.coordinates)
        self.yd = tuple(equations.velocities)
        self.p = tuple(equations.parameters)
        self.u = tuple(equations.inputs)
        self.a = tuple(sp.Symbol(f"_ncg_a{i}", real=True) for i in range(len(self.y)))
        self.names: dict[sp.Symbol, str] = {time: "t"}
        for group, arr in ((self.y, "y"), (self.yd, "yd"), (self.p, "p"), (self.u, "u"),
                           (self.a, "a")):
            for i, s in enumerate(group):
                self.names[s] = f"{arr}[{i}]"


def uses(block: Block, group: Sequence[sp.Symbol]) -> bool:
    gs = set(group)
    return any(free_symbols(e) & gs for _, e in block.assignments) or any(
        free_symbols(e) & gs for e in block.finals
    )


def c_body(g: SymbolGroups, block: Block, target: str, what: str,
          dots: DotRows | None = None, optional: frozenset[int] = frozenset(),
          zeroed: bool = False) -> list[str]:
    """Statements computing ``block``: locals ``w<k>`` (those the finals read, directly or
    through other locals), then ``target[i] = final_i``
    (zeros by ``memset``; repeated finals — symmetric mass entries — computed once); long
    linear combinations of ``y``, ``yd``, ``a`` as rows of ``dots``, one product per array
    at the top (:meth:`.c_printer.DotRows.batch`). The finals ``optional`` are written only
    ``if (full)`` (a flag of the function: the constant block that the block elimination of
    ``rhs`` never reads, :mod:`.c_solve`). ``zeroed``: the zero finals are zero on entry (a
    static buffer that only this function writes, zero from the load on), so no ``memset``."""
    names = dict(g.names)
    assignments, finals = block.assignments, block.finals
    for k, (s, _) in enumerate(assignments):
        names[s] = f"w{k}"
    pr = CPrinter(names, dots, scaled_locals(g, assignments) if dots else None)
    lines: list[str] = []
    if g.u and uses(block, g.u):
        lines.append("NW_DEFAULT_INPUTS;")
    try:
        printed = []                          # (local, its line, the locals it reads)
        for k, (s, e) in enumerate(assignments):
            pr.used = set()
            printed.append((s, f"const double w{k} = {pr.doprint_expr(e)};", pr.used))
        pr.used = set()
        finals_at = len(lines)
        if not zeroed and any(f == 0 for f in finals):
            lines.append(f"memset({target}, 0, {len(finals)} * sizeof(double));")
        constant = constant_runs(finals)
        for i, run in constant.items():
            cond = "if (full) " if optional.issuperset(range(i, i + len(run))) else ""
            lines.append(f"{cond}{{ static const double c[{len(run)}] = "
                         f"{{{', '.join(pr.doprint_expr(v) for v in run)}}};")
            lines.append(f"  memcpy({target} + {i}, c, sizeof c); }}")
        skip = {i + k for i, run in constant.items() for k in range(len(run))}
        first: dict[sp.Basic, int] = {}
        for i, f in enumerate(finals):
            if f == 0 or i in skip:
                continue
            if i in optional:                 # (never the source of a copy)
                lines.append(f"if (full) {target}[{i}] = {pr.doprint_expr(f)};")
                continue
            if not f.is_Atom and f in first:
                lines.append(f"{target}[{i}] = {target}[{first[f]}];")
                continue
            first.setdefault(f, i)
            lines.append(f"{target}[{i}] = {pr.doprint_expr(f)};")
    except GenerationError as exc:
        raise GenerationError(f"{what}: {exc}") from None
    # only the locals something reads: a shared term c·q_k that every row reads as the
    # number c times q_k (DotRows) would be an unused variable of the C text
    needed = pr.used
    for s, _line, reads in reversed(printed):
        if s in needed:
            needed |= reads
    lines[finals_at:finals_at] = [line for s, line, _reads in printed if s in needed]
    return dots.batch(lines) if dots is not None else lines


#: Shortest run of consecutive numeric finals copied from a table (constant ``Mee`` rows).
MIN_RUN = 8


def constant_runs(finals: Sequence[sp.Basic]) -> dict[int, list[sp.Basic]]:
    """Start → values of the runs of at least :data:`MIN_RUN` consecutive nonzero numbers."""
    runs: dict[int, list[sp.Basic]] = {}
    start = None
    for i, f in enumerate([*finals, sp.S.Zero]):
        if f.is_Number and f != 0:
            start = i if start is None else start
            continue
        if start is not None and i - start >= MIN_RUN:
            runs[start] = list(finals[start:i])
        start = None
    return runs


def scaled_locals(g: SymbolGroups, assignments: Sequence[tuple[sp.Symbol, sp.Expr]]
                       ) -> dict[sp.Symbol, tuple[sp.Number, sp.Symbol]]:
    """Locals ``w = c·v`` with ``v`` a parameter (hoisted constant factors, codegen/cse.py)
    or an element of ``y``, ``ẏ``, ``a`` (the CSE's shared terms ``w_i = c_i q_i``): within
    a sum ``Σ c_i w ẏ_i`` or ``Σ_i w_i`` the printer reads them as ``c·v``, so that the sum
    is one linear combination of ``ẏ`` or ``q`` again (:class:`.c_printer.DotRows`; the
    shared terms' sums as rows were slower than adding the products while each row was its
    own dot product, 1.19 → 1.48 µs, and are faster since the rows of a function are one
    product). Substituting the locals into the expressions instead took seconds for long
    rigid chains."""
    params = set(g.p) | set(g.y) | set(g.yd) | set(g.a)
    return {s: e.args for s, e in assignments
            if e.is_Mul and len(e.args) == 2 and e.args[0].is_Number and e.args[1] in params}


#: Derivative functions with more locals than this are compiled without optimization
#: (``optimize("O0")``): gcc's optimizing passes grow faster than linearly with the size of a
#: function (chain N = 10: 5.8 s → 1.7 s of compile time; the Jacobian 10 → 16 µs, still
#: 30× faster than the NumPy module's).
BIG_FUNCTION = 1000


def c_function(signature: str, body: Sequence[str], quick: bool = False,
              static: bool = False) -> list[str]:
    attr = "__attribute__((optimize(\"O0\"))) " if quick else ""
    attr += "static " if static else ""
    return [f"{attr}int {signature}", "{", *(_IN + b for b in body), _IN + "return 0;", "}",
            ""]


def big(block: Block) -> bool:
    return len(block.assignments) > BIG_FUNCTION


Y_ARGS = "double t, const double *y, const double *p, const double *u, double *out"
YYD_ARGS = ("double t, const double *y, const double *yd, const double *p, const double *u, "
             "double *out")
X_ARGS = "double t, const double *x, const double *p, const double *u, double *out"
X_PROLOGUE = ["const double *y = x;", "const double *yd = x + NW_N;"]


def x_prologue(g: SymbolGroups, block: Block) -> list[str]:
    """The lines of :data:`X_PROLOGUE` that ``block`` reads (no unused variables)."""
    return [line for line, group in zip(X_PROLOGUE, (g.y, g.yd), strict=True)
            if uses(block, group)]
MMTD_ARGS = ("double t, const double *y, const double *p, const double *a, const double *u, "
              "double *out")
