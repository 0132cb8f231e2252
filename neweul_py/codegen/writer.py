"""The module writer: :class:`~neweul_py.equations.Equations` → a standalone NumPy module.

The module implements the generated-module protocol (``docs/generated-module-protocol.md``).
Every function is straight-line code produced by :func:`.cse.eliminate`; scalars are Python
floats (``_math`` functions), arrays are assembled once with NumPy. Jacobians come from symbolic
derivatives (:func:`.derivatives.jacobian`), never from finite differences.

Writing is atomic: the text is rendered completely first (so an invalid model raises before
anything touches the disk), written to a temporary file in the target directory, flushed,
``fsync``-ed and moved over the target with :func:`os.replace`. The text depends only on the
equations and the source hash — no timestamps, no hash-ordered iteration — so regeneration is
byte-identical.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import sympy as sp

from ..atomic import atomic_write
from ..errors import GenerationError
from ..model import Frame, KinematicOutput, System, as_expr, input_rate_name, time
from .constraints import constraint_constant, constraint_functions
from .cse import Assignment, Block, CseMethod, eliminate, free_symbols, prune
from .derivatives import jacobian
from .printer import FastPrinter, NamePool

__all__ = ["PROTOCOL_VERSION", "generate_module", "program_blocks", "render_module"]

#: Version of the generated-module protocol written here.
PROTOCOL_VERSION = 1

_INDENT = "    "


@dataclass
class _Ctx:
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


def _unpack(names: Sequence[str], source: str) -> str:
    if len(names) == 1:
        return f"{names[0]}, = {source}"
    return f"{', '.join(names)} = {source}"


def _checked(ctx: _Ctx, block: Block, allowed: Sequence[sp.Symbol], what: str) -> Block:
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


def _subblock(program: Block, finals: Sequence[sp.Expr]) -> Block:
    """The part of a CSE'd program that ``finals`` (expressions in its symbols) need."""
    return Block(tuple(prune(program.assignments, finals)), tuple(finals))


def _derivative_block(
    program: Sequence[Assignment],
    exprs: Sequence[sp.Expr],
    wrt: Sequence[sp.Symbol],
    method: CseMethod,
) -> tuple[Block, sp.ImmutableMatrix]:
    """Forward-mode Jacobian of ``exprs`` through ``program``, then CSE over the result."""
    d_inter, J = jacobian(exprs, wrt, program, prefix="_ncg_d")
    block = eliminate(d_inter, list(J), prefix="_ncg_e", method=method)
    return block, sp.ImmutableMatrix(J.shape[0], J.shape[1], list(block.finals))


def _uses(block: Block, group: Sequence[sp.Symbol]) -> bool:
    gs = set(group)
    return any(free_symbols(e) & gs for _, e in block.assignments) or any(
        free_symbols(e) & gs for e in block.finals
    )


def _prologue(
    ctx: _Ctx, block: Block, sources: Sequence[tuple[Sequence[sp.Symbol], str]]
) -> list[str]:
    """Unpack the argument arrays the block uses into Python floats."""
    lines = []
    for group, source in sources:
        if group and _uses(block, group):
            lines.append(_unpack([ctx.name(s) for s in group], source))
    return lines


def _inputs_prologue(ctx: _Ctx, block: Block) -> list[str]:
    if not ctx.u or not _uses(block, ctx.u):
        return []
    return [
        "if u is None:",
        f"{_INDENT}u = default_inputs(t, p)",
        _unpack([ctx.name(s) for s in ctx.u], "_np.asarray(u, dtype=_np.float64).tolist()"),
    ]


def _assignments(ctx: _Ctx, block: Block) -> list[str]:
    return [f"{ctx.name(s)} = {ctx.pr(e)}" for s, e in block.assignments]


def _vector(ctx: _Ctx, target: str, values: Sequence[sp.Expr]) -> list[str]:
    if not values:
        return [f"{target} = _np.zeros(0)"]
    items = ", ".join(ctx.pr(v) for v in values)
    if len(values) == 1:
        items += ","
    return [f"{target} = _np.array(({items}), dtype=_np.float64)"]


def _matrix_fill(
    ctx: _Ctx, target: str, shape: tuple[int, int], entries: dict[tuple[int, int], sp.Expr]
) -> list[str]:
    """Fill a preallocated array; ``entries`` maps (i, j) → value (absent means zero)."""
    full = len(entries) == shape[0] * shape[1]
    alloc = "empty" if full else "zeros"
    lines = [f"{target} = _np.{alloc}({shape!r})"]
    for (i, j), v in entries.items():
        lines.append(f"{target}[{i}, {j}] = {ctx.pr(v)}")
    return lines


def _mass_entries(M: sp.ImmutableMatrix) -> tuple[list[sp.Expr], list[list[tuple[int, int]]]]:
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


def _mass_fill(
    ctx: _Ctx, n: int, reduced: Sequence[sp.Expr], where: Sequence[Sequence[tuple[int, int]]]
) -> list[str]:
    lines = [f"M = _np.empty(({n}, {n}))"]
    for value, places in zip(reduced, where, strict=True):
        targets = " = ".join(f"M[{i}, {j}]" for i, j in places)
        lines.append(f"{targets} = {ctx.pr(value)}")
    return lines


def _function(signature: str, doc: str, body: Sequence[str]) -> list[str]:
    out = [f"def {signature}:", f'{_INDENT}"""{doc}"""']
    out += [_INDENT + line for line in body]
    return [*out, "", ""]


def _sparse(J: sp.ImmutableMatrix) -> dict[tuple[int, int], sp.Expr]:
    return {
        (i, j): J[i, j] for i in range(J.shape[0]) for j in range(J.shape[1]) if J[i, j] != 0
    }


def _units(system: System) -> tuple[list[str], list[str]]:
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


def _input_rates(system: System) -> dict[str, list[str]]:
    """Input → the entries of ``u`` that are its time derivatives (``d_<u>``, ``dd_<u>``),
    for the inputs that have them (kinematic excitation; docs/generated-module-protocol.md)."""
    orders = system.input_rate_orders
    return {
        i.name: [input_rate_name(i.name, k) for k in range(1, orders[i.name] + 1)]
        for i in system.inputs
        if orders[i.name]
    }


def render_module(
    equations: Any, source_hash: str, *, cse: bool = True, _elastic: bool = True
) -> str:
    """The complete source text of the generated module.

    Parameters
    ----------
    equations
        An :class:`~neweul_py.equations.Equations` (coordinates, velocities, parameters,
        inputs, intermediates, mass_matrix, force_vector, outputs, output_names, system).
    source_hash
        SHA-256 (hex) of the description the equations came from; stored as ``SOURCE_HASH``.
    cse
        Eliminate common subexpressions (default). Off only for debugging.

    Raises
    ------
    GenerationError
        When the equations cannot be turned into code (unknown symbols, a mass matrix that
        depends on velocities, unprintable functions …).

    Notes
    -----
    Systems with elastic bodies are rendered by :func:`.elastic.render_elastic_module`
    (equations.md §2), which calls this function for the rigid part (``_elastic=False``).
    """
    if _elastic and getattr(equations.system, "elastic_bodies", ()):
        from .elastic import render_elastic_module

        return render_elastic_module(equations, source_hash, cse=cse)
    eq = equations
    system: System = eq.system
    y, yd, p, u = (tuple(eq.coordinates), tuple(eq.velocities), tuple(eq.parameters),
                   tuple(eq.inputs))
    n, nu = len(y), len(u)
    if n == 0:
        raise GenerationError(f"model {system.name!r} has no coordinates")
    M = sp.ImmutableMatrix(eq.mass_matrix)
    fvec = sp.ImmutableMatrix(eq.force_vector)
    outs = sp.ImmutableMatrix(eq.outputs) if len(eq.outputs) else sp.ImmutableMatrix.zeros(0, 1)
    if M.shape != (n, n) or fvec.shape != (n, 1):
        raise GenerationError(
            f"mass matrix {M.shape} and force vector {fvec.shape} do not fit {n} coordinates"
        )
    names_out = list(eq.output_names)
    if outs.shape[0] != len(names_out):
        raise GenerationError("outputs and output_names differ in length")
    inter = tuple((s, as_expr(e)) for s, e in eq.intermediates)

    pool = NamePool()
    pool.names[time] = "t"
    for s in (*y, *yd, *p, *u):
        pool.claim(s)
    for s, _ in inter:
        pool.claim(s)
    ctx = _Ctx(y, yd, p, u, inter, pool)
    # Closed-form expressions profit from sympy's full CSE; recursive-form ones already reuse
    # intermediates, and tree CSE is several times faster at nearly the same operation count.
    method: CseMethod = "none" if not cse else ("tree" if inter else "full")
    # Forward-mode derivatives of a recursive program are already a program without repeated
    # subtrees worth the (super-linear) search; of closed-form ones tree CSE is cheap and helps.
    d_method: CseMethod = "none" if not cse or inter else "tree"

    a_syms = tuple(sp.Symbol(f"_ncg_a{i}", real=True) for i in range(n))
    for i, s in enumerate(a_syms):
        pool.claim(s, f"_a{i}")

    kin = (*y, *p, *u, time)
    dyn = (*kin, *yd)
    y_src = "_np.asarray(y, dtype=_np.float64).tolist()"
    yd_src = "_np.asarray(yd, dtype=_np.float64).tolist()"
    p_src = "_np.asarray(p, dtype=_np.float64).tolist()"

    funcs: list[str] = []

    # ---- default_parameters / default_inputs
    funcs += _function(
        "default_parameters()",
        "The parameter vector ``p`` of the defaults (ordered as ``PARAMETERS``).",
        ["return _np.array(_P0, dtype=_np.float64)"],
    )
    # the input vector: inputs, then the time derivatives kinematic excitation needs (issue 4)
    u_defaults = [as_expr(e) for e in system.input_defaults]
    b = _checked(ctx, eliminate((), u_defaults, method=method), (*p, time), "the default inputs")
    body = _prologue(ctx, b, [(p, p_src)]) + _assignments(ctx, b) + _vector(ctx, "u", b.finals)
    funcs += _function("default_inputs(t, p)",
                       "The default excitation ``u(t)`` of the description.", [*body, "return u"])

    # ---- one CSE'd program for M and q − k: rhs uses it whole, the other functions prune it
    m_values, m_where = _mass_entries(M)
    nm = len(m_values)
    program = eliminate(inter, [*m_values, *fvec], prefix="_ncg_c", method=method)
    m_red, f_red = program.finals[:nm], program.finals[nm:]
    m_full = sp.zeros(n, n)
    for value, places in zip(m_red, m_where, strict=True):
        for i, j in places:
            m_full[i, j] = value

    # ---- mass_matrix
    b = _checked(ctx, _subblock(program, m_red), kin, "the mass matrix")
    body = (_prologue(ctx, b, [(y, y_src), (p, p_src)]) + _inputs_prologue(ctx, b)
            + _assignments(ctx, b) + _mass_fill(ctx, n, b.finals, m_where))
    funcs += _function("mass_matrix(t, y, p, u=None)",
                       "Mass matrix ``M(y, t)``, shape (n, n).", [*body, "return M"])

    # ---- force_vector
    b = _checked(ctx, _subblock(program, f_red), dyn, "the force vector")
    body = (_prologue(ctx, b, [(y, y_src), (yd, yd_src), (p, p_src)])
            + _inputs_prologue(ctx, b) + _assignments(ctx, b) + _vector(ctx, "f", b.finals))
    funcs += _function("force_vector(t, y, yd, p, u=None)",
                       "Generalized forces ``q − k``, shape (n,).", [*body, "return f"])

    # ---- rhs: M and f in one block, then one linear solve
    b = _checked(ctx, program, dyn, "the right-hand side")
    body = ["x = _np.asarray(x, dtype=_np.float64)"]
    if _uses(b, (*y, *yd)):
        body.append(_unpack([ctx.name(s) for s in (*y, *yd)], "x.tolist()"))
    body += _prologue(ctx, b, [(p, p_src)]) + _inputs_prologue(ctx, b) + _assignments(ctx, b)
    body += _mass_fill(ctx, n, b.finals[:nm], m_where)
    body += _vector(ctx, "f", b.finals[nm:])
    body += [
        f"xd = _np.empty({2 * n})",
        f"xd[:{n}] = x[{n}:{2 * n}]",
        f"xd[{n}:] = _np.linalg.solve(M, f)",
        "return xd",
    ]
    funcs += _function("rhs(t, x, p, u=None)",
                       "First-order form ``[ẏ, M⁻¹(q − k)]`` of the equations of motion.", body)

    # ---- force_jacobians: forward mode through the CSE'd program
    b, Jr = _derivative_block(program.assignments, f_red, (*y, *yd, *u), d_method)
    b = _checked(ctx, b, dyn, "the force Jacobians")
    body = (_prologue(ctx, b, [(y, y_src), (yd, yd_src), (p, p_src)])
            + _inputs_prologue(ctx, b) + _assignments(ctx, b))
    body += _matrix_fill(ctx, "fy", (n, n), _sparse(Jr[:, :n]))
    body += _matrix_fill(ctx, "fyd", (n, n), _sparse(Jr[:, n:2 * n]))
    body += _matrix_fill(ctx, "fu", (n, nu), _sparse(Jr[:, 2 * n:]))
    funcs += _function(
        "force_jacobians(t, y, yd, p, u=None)",
        "``∂(q−k)/∂y``, ``∂(q−k)/∂ẏ`` (n, n) and ``∂(q−k)/∂u`` (n, nu), analytic.",
        [*body, "return fy, fyd, fu"],
    )

    # ---- mass_matrix_times_derivative: ∂(M a)/∂y
    ma = [sp.Add(*(m_full[i, j] * a_syms[j] for j in range(n))) for i in range(n)]
    b, Jr = _derivative_block(program.assignments, ma, y, d_method)
    b = _checked(ctx, b, (*kin, *a_syms), "∂(M a)/∂y")
    body = (_prologue(ctx, b, [(y, y_src), (p, p_src),
                               (a_syms, "_np.asarray(a, dtype=_np.float64).tolist()")])
            + _inputs_prologue(ctx, b) + _assignments(ctx, b)
            + _matrix_fill(ctx, "dMa", (n, n), _sparse(Jr)))
    funcs += _function("mass_matrix_times_derivative(t, y, p, a, u=None)",
                       "``∂(M(y) a)/∂y`` for a fixed vector ``a``, shape (n, n).",
                       [*body, "return dMa"])

    # ---- rhs_jacobian (numeric combination of the analytic pieces)
    funcs += _function(
        "rhs_jacobian(t, x, p, u=None)",
        "``∂ rhs/∂x`` = [[0, I], [M⁻¹(∂f/∂y − ∂(M ÿ)/∂y), M⁻¹ ∂f/∂ẏ]], analytic.",
        [
            "x = _np.asarray(x, dtype=_np.float64)",
            *(["if u is None:", f"{_INDENT}u = default_inputs(t, p)"] if nu else []),
            f"y = x[:{n}]",
            f"yd = x[{n}:{2 * n}]",
            "M = mass_matrix(t, y, p, u)",
            "ydd = _np.linalg.solve(M, force_vector(t, y, yd, p, u))",
            "fy, fyd, _fu = force_jacobians(t, y, yd, p, u)",
            "dMa = mass_matrix_times_derivative(t, y, p, ydd, u)",
            f"J = _np.zeros(({2 * n}, {2 * n}))",
            f"J[:{n}, {n}:] = _np.eye({n})",
            f"J[{n}:, :] = _np.linalg.solve(M, _np.hstack((fy - dMa, fyd)))",
            "return J",
        ],
    )

    # ---- outputs and output_jacobians
    x_unpack = [((*y, *yd), "_np.asarray(x, dtype=_np.float64).tolist()"), (p, p_src)]
    out_prog = eliminate(inter, list(outs), prefix="_ncg_o", method=method)
    b = _checked(ctx, out_prog, dyn, "the outputs")
    body = (_prologue(ctx, b, x_unpack) + _inputs_prologue(ctx, b) + _assignments(ctx, b)
            + _vector(ctx, "out", b.finals))
    funcs += _function("outputs(t, x, p, u=None)", "The outputs, ordered as ``OUTPUTS``.",
                       [*body, "return out"])
    ny = outs.shape[0]
    b, Jr = _derivative_block(out_prog.assignments, out_prog.finals, (*y, *yd, *u),
                              d_method)
    b = _checked(ctx, b, dyn, "the output Jacobians")
    body = (_prologue(ctx, b, x_unpack) + _inputs_prologue(ctx, b) + _assignments(ctx, b)
            + _matrix_fill(ctx, "C", (ny, 2 * n), _sparse(Jr[:, :2 * n]) if ny else {})
            + _matrix_fill(ctx, "D", (ny, nu), _sparse(Jr[:, 2 * n:]) if ny else {}))
    funcs += _function("output_jacobians(t, x, p, u=None)",
                       "``∂out/∂x`` (ny, STATE_SIZE) and ``∂out/∂u`` (ny, nu), analytic.",
                       [*body, "return C, D"])

    # ---- constraints g, G, ∂g/∂t, γ of closed loops (codegen/constraints.py, issue 4)
    ce = getattr(eq, "constraints", None)
    funcs += constraint_functions(ctx, ce, method)

    # ---- header and constants
    cu, ou = _units(system)
    x0 = [float(c.initial) for c in system.coordinates] + [
        float(c.velocity) for c in system.coordinates
    ]
    pdef = {pp.name: float(pp.default) for pp in system.parameters}
    if [str(s) for s in p] != list(pdef):
        raise GenerationError("the equations' parameters differ from the model's")
    consts = [
        f"PROTOCOL_VERSION = {PROTOCOL_VERSION}",
        f"MODEL_NAME = {system.name!r}",
        f"DESCRIPTION = {system.description!r}",
        f"COORDINATES = {[str(s) for s in y]!r}",
        f"COORDINATE_UNITS = {cu!r}",
        f"INITIAL_STATE = {x0!r}",
        "PARAMETERS = {" + "".join(f"\n    {k!r}: {v!r}," for k, v in pdef.items())
        + ("\n}" if pdef else "}"),
        f"INPUTS = {[str(s) for s in u]!r}",
        f"INPUT_RATES = {_input_rates(system)!r}",
        f"OUTPUTS = {names_out!r}",
        f"OUTPUT_UNITS = {ou!r}",
        constraint_constant(tuple(ce.names) if ce is not None else ()),
        f"STATE_SIZE = {2 * n}",
        f"SOURCE_HASH = {source_hash!r}",
        "MASS_MATRIX_SYMMETRIC = " + repr(bool(M == M.T)),
        "",
        f"_P0 = {tuple(pdef.values())!r}",
    ]
    header = [
        f'"""Equations of motion of the model {system.name!r}: generated by neweul-py, do not '
        "edit.",
        "",
        "Implements the generated-module protocol (version "
        f"{PROTOCOL_VERSION}, docs/generated-module-protocol.md).",
        "State ``x = [y, ẏ]``; parameters ``p`` ordered as ``PARAMETERS``; inputs ``u`` ordered",
        "as ``INPUTS`` (``u=None``: the description's default excitation). Needs only NumPy.",
        '"""',
        "",
        "import math as _math",
        "",
        "import numpy as _np",
        "",
        *consts,
        "",
        "",
    ]
    return "\n".join(header + funcs).rstrip("\n") + "\n"


def generate_module(
    equations: Any, source_hash: str, path: str | os.PathLike[str], *, cse: bool = True
) -> Path:
    """Render the module for ``equations`` and write it atomically to ``path``.

    Parameters
    ----------
    equations
        The symbolic equations (:class:`~neweul_py.equations.Equations`).
    source_hash
        SHA-256 of the description; becomes ``SOURCE_HASH``.
    path
        Target file (``generated/<name>.py``). Its directory is created if needed.

    Returns
    -------
    Path
        ``path``. If rendering fails nothing is written and an existing file is untouched.

    Examples
    --------
    >>> generate_module(newton_euler(load_description("examples/pendulum.yaml")),
    ...                 description_hash(b"..."), "generated/pendulum.py")  # doctest: +SKIP
    """
    text = render_module(equations, source_hash, cse=cse)
    return atomic_write(path, text)


def program_blocks(equations: Any, *, cse: bool = True) -> dict[str, Block]:
    """The CSE'd straight-line programs of the protocol functions, for other printers.

    The same calls to :func:`.cse.eliminate` and :func:`.derivatives.jacobian`, in the same
    order and with the same methods, as :func:`render_module` makes (deterministic, so the
    blocks are those the NumPy module prints). Matrices are given row-major with every entry
    (zeros included): ``mass_matrix`` (n·n), ``force_vector`` (n), ``rhs`` (n·n of ``M``,
    then n of ``q − k``), ``force_jacobians`` (n × (2n + nu): ``∂/∂y``, ``∂/∂ẏ``, ``∂/∂u``),
    ``mass_matrix_times_derivative`` (n·n, in the symbols ``Symbol(f"_ncg_a{i}", real=True)``
    of the vector ``a``), ``default_inputs`` (nu), ``outputs`` (ny), ``output_jacobians``
    (ny × (2n + nu)), ``constraints`` (nc), ``constraint_jacobian`` (nc·n),
    ``constraint_time_derivative`` (nc), ``constraint_gamma`` (nc). Rigid models only (elastic
    bodies are spliced in numerically by :mod:`.elastic`).
    """
    eq = equations
    y, yd, u = tuple(eq.coordinates), tuple(eq.velocities), tuple(eq.inputs)
    n = len(y)
    M = sp.ImmutableMatrix(eq.mass_matrix)
    fvec = sp.ImmutableMatrix(eq.force_vector)
    outs = sp.ImmutableMatrix(eq.outputs) if len(eq.outputs) else sp.ImmutableMatrix.zeros(0, 1)
    inter = tuple((s, as_expr(e)) for s, e in eq.intermediates)
    method: CseMethod = "none" if not cse else ("tree" if inter else "full")
    d_method: CseMethod = "none" if not cse or inter else "tree"
    a_syms = tuple(sp.Symbol(f"_ncg_a{i}", real=True) for i in range(n))
    out: dict[str, Block] = {}
    out["default_inputs"] = eliminate((), [as_expr(e) for e in eq.system.input_defaults],
                                      method=method)
    m_values, m_where = _mass_entries(M)
    program = eliminate(inter, [*m_values, *fvec], prefix="_ncg_c", method=method)
    nm = len(m_values)
    m_full = sp.zeros(n, n)
    for value, places in zip(program.finals[:nm], m_where, strict=True):
        for i, j in places:
            m_full[i, j] = value
    f_red = program.finals[nm:]
    out["mass_matrix"] = _subblock(program, list(m_full))
    out["force_vector"] = _subblock(program, f_red)
    out["rhs"] = Block(program.assignments, (*m_full, *f_red))
    b, Jr = _derivative_block(program.assignments, f_red, (*y, *yd, *u), d_method)
    out["force_jacobians"] = Block(b.assignments, tuple(Jr))
    ma = [sp.Add(*(m_full[i, j] * a_syms[j] for j in range(n))) for i in range(n)]
    b, Jr = _derivative_block(program.assignments, ma, y, d_method)
    out["mass_matrix_times_derivative"] = Block(b.assignments, tuple(Jr))
    out_prog = eliminate(inter, list(outs), prefix="_ncg_o", method=method)
    out["outputs"] = out_prog
    b, Jr = _derivative_block(out_prog.assignments, out_prog.finals, (*y, *yd, *u), d_method)
    out["output_jacobians"] = Block(b.assignments, tuple(Jr))
    ce = getattr(eq, "constraints", None)
    if ce is not None and ce.nc:
        for name, exprs, prefix in (("constraints", ce.g, "_ncg_g"),
                                    ("constraint_jacobian", ce.G, "_ncg_G"),
                                    ("constraint_time_derivative", ce.g_t, "_ncg_gt"),
                                    ("constraint_gamma", ce.gamma, "_ncg_h")):
            out[name] = eliminate((), list(exprs), prefix=prefix, method=method)
    else:
        for name in ("constraints", "constraint_jacobian", "constraint_time_derivative",
                     "constraint_gamma"):
            out[name] = Block((), ())
    return out
