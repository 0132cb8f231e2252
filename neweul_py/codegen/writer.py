"""The module writer: :class:`~neweul_py.equations.Equations` → the parts of a NumPy module.

A generated module is *composed* of named parts (:class:`ModuleParts`): the docstring, the
imports, the protocol constants and one source block per function. :func:`module_parts`
renders the symbolic equations into such parts (every function straight-line code from
:func:`.cse.eliminate`; scalars are Python floats with ``_math`` functions, arrays are
assembled once with NumPy; Jacobians are the symbolic derivatives that
:mod:`neweul_py.equations.jacobians` takes through the CSE'd program, never finite
differences), and :func:`compose` joins parts into the module text. Writers of richer modules
(elastic bodies, :mod:`~neweul_py.codegen.elastic`) select, rename and add parts — they never
edit rendered text.

The text depends only on the equations and the source hash — no timestamps, no hash-ordered
iteration — so regeneration is byte-identical (docs/generated-module-protocol.md).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import sympy as sp

from ..errors import GenerationError
from ..model import System, as_expr, time
from ..progress import StagedProgress, Steps
from .blocks import (
    INDENT,
    Context,
    assignments,
    checked,
    function,
    input_rates,
    input_units,
    inputs_prologue,
    mass_fill,
    matrix_fill,
    prologue,
    sparse,
    subblock,
    units,
    unpack_line,
    vector,
)
from .constraints import constraint_constant, constraint_functions
from .cse import Block, CseMethod, eliminate
from .packing import (
    IMPORTS,
    factored_definitions,
    factored_mass,
    factored_rhs,
    factored_sizes,
    pack_definition,
    packed_matrix,
    packed_parts,
    packed_rhs,
    solver_definition,
)
from .parameters import parameter_functions
from .printer import NamePool
from .programs import (
    dynamics_programs,
    loss_program,
    mass_factor_values,
    output_programs,
    parameter_programs,
    rhs_parts_program,
)

__all__ = ["ENERGY_TERMS", "PROTOCOL_VERSION", "ModuleParts", "compose", "module_parts",
           "program_blocks"]

#: Version of the generated-module protocol written here.
PROTOCOL_VERSION = 1

#: The entries of ``energy(t, x, p)``, in order.
ENERGY_TERMS = ("kinetic", "gravity", "springs", "strain")

_Y_SRC = "_np.asarray(y, dtype=_np.float64).tolist()"
_YD_SRC = "_np.asarray(yd, dtype=_np.float64).tolist()"
_P_SRC = "_np.asarray(p, dtype=_np.float64).tolist()"


@dataclass(frozen=True)
class ModuleParts:
    """The parts a module text is composed of (:func:`compose`).

    Attributes
    ----------
    docstring
        Lines of the module docstring (without the quotes).
    imports
        Import lines.
    constants
        Protocol constants, name → Python literal text, in order.
    private
        Private module-level definitions (source lines), after the constants.
    functions
        Function name → its source lines (a ``def`` block), in order.
    """

    docstring: tuple[str, ...]
    imports: tuple[str, ...]
    constants: dict[str, str]
    private: tuple[str, ...] = ()
    functions: dict[str, tuple[str, ...]] = field(default_factory=dict)

    def with_(self, **changes: Any) -> ModuleParts:
        """A copy with some parts replaced."""
        return replace(self, **changes)


def compose(parts: ModuleParts) -> str:
    """The module text: docstring, imports, constants, private definitions, functions."""
    lines = ['"""' + parts.docstring[0], *parts.docstring[1:], '"""', ""]
    lines += [*parts.imports, ""]
    lines += [f"{name} = {value}" for name, value in parts.constants.items()]
    lines += ["", *parts.private, "", ""]
    for block in parts.functions.values():
        lines += [*block, "", ""]
    return "\n".join(lines).rstrip("\n") + "\n"


def _function(name: str, args: str, doc: str, body: Sequence[str]) -> tuple[str, ...]:
    return tuple(function(f"{name}({args})", doc, body)[:-2])


def _dynamics(ctx: Context, eq: Any, method: CseMethod, d_method: CseMethod,
              prefix: str, step: Steps) -> dict[str, tuple[str, ...]]:
    """mass_matrix, force_vector, rhs, force_jacobians, mass_matrix_times_derivative and
    rhs_jacobian from one CSE'd program of ``M`` and ``q − k`` (equations.md §1). ``M`` is
    packed in one buffer and ``rhs`` solves in place (:mod:`.packing`)."""
    y, yd, p, u = ctx.y, ctx.yd, ctx.p, ctx.u
    n, nu = len(y), len(u)
    kin = (*y, *p, *u, time)
    dyn = (*kin, *yd)
    out: dict[str, tuple[str, ...]] = {}
    dp = dynamics_programs(eq, ctx.intermediates, method, d_method)
    program, m_where, nm = dp.program, dp.m_where, dp.nm
    m_red, f_red, fac_red = dp.parts(n)
    step()

    b = checked(ctx, subblock(program, fac_red or m_red), kin, "the mass matrix")
    body = (prologue(ctx, b, [(y, _Y_SRC), (p, _P_SRC)]) + inputs_prologue(ctx, b)
            + assignments(ctx, b))
    if fac_red:
        body += factored_mass(ctx, n, b.finals)
    elif n:
        body += [*packed_matrix(ctx, "M", n, b.finals, m_where), "return M"]
    else:
        body += [*mass_fill(ctx, n, b.finals, m_where), "return M"]
    out["mass_matrix"] = _function(f"{prefix}mass_matrix", "t, y, p, u=None",
                                   "Mass matrix ``M(y, t)``, shape (n, n).", body)
    step()

    b = checked(ctx, subblock(program, f_red), dyn, "the force vector")
    body = (prologue(ctx, b, [(y, _Y_SRC), (yd, _YD_SRC), (p, _P_SRC)])
            + inputs_prologue(ctx, b) + assignments(ctx, b, step.part())
            + vector(ctx, "f", b.finals))
    out["force_vector"] = _function(f"{prefix}force_vector", "t, y, yd, p, u=None",
                                    "Generalized forces ``q − k``, shape (n,).",
                                    [*body, "return f"])
    step()

    b = checked(ctx, subblock(program, [*f_red, *fac_red]) if fac_red
                else subblock(program, [*m_red, *f_red]), dyn, "the right-hand side")
    body = ["x = _np.asarray(x, dtype=_np.float64)"]
    if n:
        body.append(unpack_line([ctx.name(s) for s in (*y, *yd)], "x.tolist()"))
    body += prologue(ctx, b, [(p, _P_SRC)]) + inputs_prologue(ctx, b) + assignments(ctx, b)
    yd_names = [ctx.name(s) for s in yd]
    if fac_red:
        body += factored_rhs(ctx, yd_names, b.finals[:n], n, b.finals[n:])
    elif n:
        body += packed_rhs(ctx, yd_names, b.finals[nm:], n, b.finals[:nm], m_where)
    else:
        body += [*vector(ctx, "f", b.finals[nm:]), "return _np.empty(0)"]
    out["rhs"] = _function(f"{prefix}rhs", "t, x, p, u=None",
                           "First-order form ``[ẏ, M⁻¹(q − k)]`` of the equations of motion.",
                           [line for line in body if line])
    step()

    b, Jr = dp.force_jacobians
    b = checked(ctx, b, dyn, "the force Jacobians")
    body = (prologue(ctx, b, [(y, _Y_SRC), (yd, _YD_SRC), (p, _P_SRC)])
            + inputs_prologue(ctx, b) + assignments(ctx, b))
    body += matrix_fill(ctx, "fy", (n, n), sparse(Jr[:, :n]))
    body += matrix_fill(ctx, "fyd", (n, n), sparse(Jr[:, n:2 * n]))
    body += matrix_fill(ctx, "fu", (n, nu), sparse(Jr[:, 2 * n:]))
    out["force_jacobians"] = _function(
        f"{prefix}force_jacobians", "t, y, yd, p, u=None",
        "``∂(q−k)/∂y``, ``∂(q−k)/∂ẏ`` (n, n) and ``∂(q−k)/∂u`` (n, nu), analytic.",
        [*body, "return fy, fyd, fu"])
    step()

    a_syms = tuple(sp.Symbol(f"_ncg_a{i}", real=True) for i in range(n))
    for i, s in enumerate(a_syms):
        ctx.pool.claim(s, f"_a{i}")
    b, Jr = dp.mass_derivative
    b = checked(ctx, b, (*kin, *a_syms), "∂(M a)/∂y")
    body = (prologue(ctx, b, [(y, _Y_SRC), (p, _P_SRC),
                              (a_syms, "_np.asarray(a, dtype=_np.float64).tolist()")])
            + inputs_prologue(ctx, b) + assignments(ctx, b)
            + matrix_fill(ctx, "dMa", (n, n), sparse(Jr)))
    out["mass_matrix_times_derivative"] = _function(
        f"{prefix}mass_matrix_times_derivative", "t, y, p, a, u=None",
        "``∂(M(y) a)/∂y`` for a fixed vector ``a``, shape (n, n).", [*body, "return dMa"])
    step()

    out["rhs_jacobian"] = _function(
        f"{prefix}rhs_jacobian", "t, x, p, u=None",
        "``∂ rhs/∂x`` = [[0, I], [M⁻¹(∂f/∂y − ∂(M ÿ)/∂y), M⁻¹ ∂f/∂ẏ]], analytic.",
        [
            "x = _np.asarray(x, dtype=_np.float64)",
            *(["if u is None:", f"{INDENT}u = default_inputs(t, p)"] if nu else []),
            f"y = x[:{n}]",
            f"yd = x[{n}:{2 * n}]",
            f"M = {prefix}mass_matrix(t, y, p, u)",
            f"ydd = _np.linalg.solve(M, {prefix}force_vector(t, y, yd, p, u))",
            f"fy, fyd, _fu = {prefix}force_jacobians(t, y, yd, p, u)",
            f"dMa = {prefix}mass_matrix_times_derivative(t, y, p, ydd, u)",
            f"J = _np.zeros(({2 * n}, {2 * n}))",
            f"J[:{n}, {n}:] = _np.eye({n})",
            f"J[{n}:, :] = _np.linalg.solve(M, _np.hstack((fy - dMa, fyd)))",
            "return J",
        ])
    return out


def _state_functions(ctx: Context, eq: Any, outs: sp.ImmutableMatrix,
                     energy: sp.ImmutableMatrix, method: CseMethod, d_method: CseMethod,
                     prefix: str, step: Steps) -> dict[str, tuple[str, ...]]:
    """outputs, output_jacobians and energy: functions of the state ``x = [y, ẏ]``."""
    y, yd, p, u = ctx.y, ctx.yd, ctx.p, ctx.u
    n = len(y)
    dyn = (*y, *p, *u, time, *yd)
    x_unpack = [((*y, *yd), "_np.asarray(x, dtype=_np.float64).tolist()"), (p, _P_SRC)]
    out: dict[str, tuple[str, ...]] = {}
    op = output_programs(eq, ctx.intermediates, outs, method, d_method)
    out_prog = op.program
    b = checked(ctx, out_prog, dyn, "the outputs")
    body = (prologue(ctx, b, x_unpack) + inputs_prologue(ctx, b) + assignments(ctx, b)
            + vector(ctx, "out", b.finals))
    out["outputs"] = _function(f"{prefix}outputs", "t, x, p, u=None",
                               "The outputs, ordered as ``OUTPUTS``.", [*body, "return out"])
    step()
    ny = outs.shape[0]
    b, Jr = op.jacobians
    b = checked(ctx, b, dyn, "the output Jacobians")
    body = (prologue(ctx, b, x_unpack) + inputs_prologue(ctx, b)
            + assignments(ctx, b, step.part(0.6, 1.0))
            + matrix_fill(ctx, "C", (ny, 2 * n), sparse(Jr[:, :2 * n]) if ny else {})
            + matrix_fill(ctx, "D", (ny, len(u)), sparse(Jr[:, 2 * n:]) if ny else {}))
    out["output_jacobians"] = _function(
        f"{prefix}output_jacobians", "t, x, p, u=None",
        "``∂out/∂x`` (ny, STATE_SIZE) and ``∂out/∂u`` (ny, nu), analytic.",
        [*body, "return C, D"])
    step()
    e_prog = eliminate(ctx.intermediates, list(energy), prefix="_ncg_w", method=method)
    b = checked(ctx, e_prog, dyn, "the energy")
    body = (prologue(ctx, b, x_unpack) + inputs_prologue(ctx, b) + assignments(ctx, b)
            + vector(ctx, "energy", b.finals))
    out["energy"] = _function(
        f"{prefix}energy", "t, x, p, u=None",
        "``[kinetic, gravity, springs, strain]`` energy (``ENERGY``; strain: elastic bodies).",
        [*body, "return energy"])
    step()
    return out


def _rhs_parts(ctx: Context, eq: Any, outs: sp.ImmutableMatrix, method: CseMethod,
               prefix: str) -> tuple[int, dict[str, tuple[str, ...]]]:
    """``rhs_parts(t, x, p, u=None)``: the outputs ``outs``, ``M`` and ``q − k`` at one state
    from one CSE'd program (:func:`.programs.rhs_parts_program`), and the number of values
    it packs. The splice of elastic bodies calls it once per ``rhs`` instead of
    ``outputs``, ``mass_matrix`` and ``force_vector`` (with ``outs`` the hidden frame
    kinematics, :mod:`~neweul_py.codegen.elastic`)."""
    y, yd, p, u = ctx.y, ctx.yd, ctx.p, ctx.u
    n, ny = len(y), outs.shape[0]
    prog, where = rhs_parts_program(eq, ctx.intermediates, outs, method)
    b = checked(ctx, prog, (*y, *p, *u, time, *yd), "the outputs, mass matrix and forces")
    body = (prologue(ctx, b, [((*y, *yd), "_np.asarray(x, dtype=_np.float64).tolist()"),
                              (p, _P_SRC)])
            + inputs_prologue(ctx, b) + assignments(ctx, b))
    k, closing = packed_parts(ctx, b.finals[:ny], b.finals[ny:ny + n], n, b.finals[ny + n:],
                              where)
    return k, {"rhs_parts": _function(
        f"{prefix}rhs_parts", "t, x, p, u=None",
        "``(out, M, q − k)`` at the state ``x``: the selected outputs, the mass matrix and "
        "the generalized forces, with their common subexpressions computed once.",
        [*body, *closing])}


def _loss_function(ctx: Context, eq: Any, method: CseMethod, prefix: str
                   ) -> dict[str, tuple[str, ...]]:
    """``loss_matrix(t, x, p, u=None)``: the hysteretic matrix ``G`` of the force elements'
    loss factors (equations.md §1.1), or nothing when the model has none."""
    b = loss_program(eq, ctx.intermediates, method)
    if b is None:
        return {}
    y, yd, p, u = ctx.y, ctx.yd, ctx.p, ctx.u
    n = len(y)
    b = checked(ctx, b, (*y, *p, *u, time, *yd), "the loss matrix")
    x_unpack = [((*y, *yd), "_np.asarray(x, dtype=_np.float64).tolist()"), (p, _P_SRC)]
    G = sp.ImmutableMatrix(n, n, list(b.finals)) if n else sp.ImmutableMatrix.zeros(0, 0)
    body = (prologue(ctx, b, x_unpack) + inputs_prologue(ctx, b) + assignments(ctx, b)
            + matrix_fill(ctx, "G", (n, n), sparse(G)))
    return {"loss_matrix": _function(
        f"{prefix}loss_matrix", "t, x, p, u=None",
        "Hysteretic matrix ``G`` of ``K + iG`` (loss factors), shape (n, n).",
        [*body, "return G"])}


def _pose_functions(ctx: Context, eq: Any, method: CseMethod,
                    prefix: str) -> dict[str, tuple[str, ...]]:
    """frame_poses (the poses of :class:`~neweul_py.equations.poses.FramePoses`) and
    body_properties (mass, center of mass and inertia of the rigid bodies, parameters only)."""
    y, p = ctx.y, ctx.p
    n = len(y)
    poses = eq.poses
    nf = len(poses.frames)
    out: dict[str, tuple[str, ...]] = {}
    prog = eliminate(ctx.intermediates, [*poses.positions, *poses.rotations], prefix="_ncg_r",
                     method=method)
    b = checked(ctx, prog, (*y, *p, *ctx.u, time), "the frame poses")
    body = (prologue(ctx, b, [(y, f"_np.asarray(x, dtype=_np.float64)[:{n}].tolist()"),
                              (p, _P_SRC)])
            + inputs_prologue(ctx, b) + assignments(ctx, b) + vector(ctx, "pose", b.finals))
    out["frame_poses"] = _function(
        f"{prefix}frame_poses", "t, x, p, u=None",
        "Origins ``r`` (nF, 3) and rotations ``S`` (nF, 3, 3) of ``FRAMES``, in ISYS.",
        [*body, f"return pose[:{3 * nf}].reshape({nf}, 3), pose[{3 * nf}:].reshape({nf}, 3, 3)"])
    bodies = eq.system.bodies
    nb = len(bodies)
    values = [as_expr(b.mass) for b in bodies]
    values += [as_expr(x) for b in bodies for x in b.center_of_mass]
    values += [as_expr(x) for b in bodies for x in b.inertia]
    b = checked(ctx, eliminate((), values, method=method), p, "the body properties")
    body = (prologue(ctx, b, [(p, _P_SRC)]) + assignments(ctx, b) + vector(ctx, "v", b.finals))
    out["body_properties"] = _function(
        "body_properties", "p",
        "Rigid ``BODIES``: masses (nb,), centers of mass (nb, 3), inertias (nb, 3, 3).",
        [*body, f"return v[:{nb}], v[{nb}:{4 * nb}].reshape({nb}, 3), "
                f"v[{4 * nb}:].reshape({nb}, 3, 3)"])
    return out


def _body_list(system: System) -> str:
    """``BODIES``: one dict per rigid body, then per elastic body (with its node count)."""
    rows = [f"\n    {{'name': {b.name!r}, 'frame': {b.frame!r}, 'kind': 'rigid'}},"
            for b in system.bodies]
    rows += [f"\n    {{'name': {b.name!r}, 'frame': {b.frame!r}, 'kind': 'elastic', "
             f"'nodes': {len(b.data['nodes.id'])}}},"
             for b in system.elastic_bodies]
    return "[" + "".join(rows) + ("\n]" if rows else "]")


def _parameter_ranges(system: System) -> dict[str, str]:
    """``PARAMETER_RANGES`` — ``name: (minimum, maximum)`` of the parameters with an
    admissible range (:attr:`~neweul_py.model.System.parameter_ranges`), in the order of
    ``PARAMETERS`` — or nothing for a model without any (its module stays as it was)."""
    ranges = system.parameter_ranges
    if not ranges:
        return {}
    rows = [f"\n    {p.name!r}: {tuple(ranges[p.name])!r}," for p in system.parameters
            if p.name in ranges]
    return {"PARAMETER_RANGES": "{" + "".join(rows) + "\n}"}


def _constants(eq: Any, source_hash: str, names_out: list[str], symmetric: bool
               ) -> dict[str, str]:
    system: System = eq.system
    y, p, u = eq.coordinates, eq.parameters, eq.inputs
    cu, ou = units(system)
    x0 = [float(c.initial) for c in system.coordinates] + [
        float(c.velocity) for c in system.coordinates]
    pdef = {pp.name: float(pp.default) for pp in system.parameters}
    if [str(s) for s in p] != list(pdef):
        raise GenerationError("the equations' parameters differ from the model's")
    ce = getattr(eq, "constraints", None)
    eq_poses = getattr(eq, "poses", None)
    return {
        "PROTOCOL_VERSION": repr(PROTOCOL_VERSION),
        "MODEL_NAME": repr(system.name),
        "DESCRIPTION": repr(system.description),
        "COORDINATES": repr([str(s) for s in y]),
        "COORDINATE_UNITS": repr(cu),
        "INITIAL_STATE": repr(x0),
        "PARAMETERS": "{" + "".join(f"\n    {k!r}: {v!r}," for k, v in pdef.items())
        + ("\n}" if pdef else "}"),
        **_parameter_ranges(system),
        "INPUTS": repr([str(s) for s in u]),
        "INPUT_RATES": repr(input_rates(system)),
        "INPUT_UNITS": repr([input_units(system).get(str(s), "") for s in u]),
        "OUTPUTS": repr(names_out),
        "OUTPUT_UNITS": repr(ou),
        "CONSTRAINTS": constraint_constant(tuple(ce.names) if ce is not None else ()
                                           ).split(" = ", 1)[1],
        "ENERGY": repr(list(ENERGY_TERMS)),
        "STATE_SIZE": repr(2 * len(y)),
        "SOURCE_HASH": repr(source_hash),
        "MASS_MATRIX_SYMMETRIC": repr(symmetric),
        **({} if getattr(eq, "loss_matrix", None) is None else {
            "LOSS_REFERENCE_FREQUENCY": repr(float(system.loss_reference_frequency))}),
        **({} if eq_poses is None else {
            "FRAMES": repr(list(eq_poses.frames)),
            "FRAME_PARENTS": repr(list(eq_poses.parents)),
            "BODIES": _body_list(system),
        }),
    }


def _header(system: System) -> tuple[str, ...]:
    return (
        f"Equations of motion of the model {system.name!r}: generated by neweul-py, do not edit.",
        "",
        f"Implements the generated-module protocol (version {PROTOCOL_VERSION}, "
        "docs/generated-module-protocol.md).",
        "State ``x = [y, ẏ]``; parameters ``p`` ordered as ``PARAMETERS``; inputs ``u`` ordered",
        "as ``INPUTS`` (``u=None``: the description's default excitation). Needs NumPy; uses",
        "SciPy's LAPACK wrappers for the solve of ``rhs`` when importable.",
    )


def _schedule_functions(ctx: Context, schedules: Sequence[sp.Expr],
                        jacobians: tuple[sp.ImmutableMatrix, sp.ImmutableMatrix] | None,
                        method: CseMethod, prefix: str,
                        parameter_jacobian: sp.ImmutableMatrix | None = None
                        ) -> dict[str, tuple[str, ...]]:
    """``schedule(t, y, p, u)`` (the values ``σ`` of the parametric bodies),
    ``schedule_jacobians(t, y, p, u)`` (``∂σ/∂y``, ``∂σ/∂u``, from ``equations/``) and
    ``schedule_parameter_jacobian(t, y, p, u)`` (``∂σ/∂p``)."""
    y, p, u = ctx.y, ctx.p, ctx.u
    src = [(y, _Y_SRC), (p, _P_SRC)]
    allowed = (*y, *p, *u, time)
    out: dict[str, tuple[str, ...]] = {}
    b = checked(ctx, eliminate((), [as_expr(e) for e in schedules], method=method), allowed,
                "the schedules of the parametric elastic bodies")
    body = (prologue(ctx, b, src) + inputs_prologue(ctx, b) + assignments(ctx, b)
            + vector(ctx, "sigma", b.finals))
    out["schedule"] = _function(f"{prefix}schedule", "t, y, p, u=None",
                                "Scheduling values of the parametric elastic bodies.",
                                [*body, "return sigma"])
    k = len(schedules)
    Jy, Ju = jacobians if jacobians is not None else (sp.zeros(k, len(y)), sp.zeros(k, len(u)))
    entries = [as_expr(e) for e in (*Jy, *Ju)]
    b = checked(ctx, eliminate((), entries, method=method), allowed,
                "the schedule Jacobians of the parametric elastic bodies")
    fy = {(i // len(y), i % len(y)): e for i, e in enumerate(b.finals[:k * len(y)]) if e != 0}
    fu = {(i // len(u), i % len(u)): e for i, e in enumerate(b.finals[k * len(y):]) if e != 0}
    body = (prologue(ctx, b, src) + inputs_prologue(ctx, b) + assignments(ctx, b)
            + matrix_fill(ctx, "Sy", (k, len(y)), fy) + matrix_fill(ctx, "Su", (k, len(u)), fu))
    out["schedule_jacobians"] = _function(
        f"{prefix}schedule_jacobians", "t, y, p, u=None",
        "``∂σ/∂y`` (k, n) and ``∂σ/∂u`` (k, nu) of the schedules, analytic.",
        [*body, "return Sy, Su"])
    Jp = (parameter_jacobian if parameter_jacobian is not None
          else sp.zeros(k, len(p)))
    b = checked(ctx, eliminate((), [as_expr(e) for e in Jp], method=method), allowed,
                "the schedules' parameter Jacobian")
    fp = {(i // len(p), i % len(p)): e for i, e in enumerate(b.finals) if e != 0}
    body = (prologue(ctx, b, src) + inputs_prologue(ctx, b) + assignments(ctx, b)
            + matrix_fill(ctx, "Sp", (k, len(p)), fp))
    out["schedule_parameter_jacobian"] = _function(
        f"{prefix}schedule_parameter_jacobian", "t, y, p, u=None",
        "``∂σ/∂p`` (k, np) of the schedules, analytic.", [*body, "return Sp"])
    return out


def module_parts(equations: Any, source_hash: str, *, cse: bool = True, prefix: str = "",
                 allow_empty: bool = False, schedules: Sequence[sp.Expr] = (),
                 schedule_jacobians: tuple[sp.ImmutableMatrix, sp.ImmutableMatrix] | None = None,
                 rhs_parts: int | None = None, directional: bool = False,
                 schedule_parameter_jacobian: sp.ImmutableMatrix | None = None,
                 progress: StagedProgress = None) -> ModuleParts:
    """The parts of the generated module of (the symbolic part of) ``equations``.

    Parameters
    ----------
    equations
        An :class:`~neweul_py.equations.Equations` (coordinates, velocities, parameters,
        inputs, intermediates, mass_matrix, force_vector, outputs, output_names, energy,
        constraints, system).
    source_hash
        SHA-256 (hex) of the description the equations came from; stored as ``SOURCE_HASH``.
    cse
        Eliminate common subexpressions (default). Off only for debugging.
    prefix
        Prefix of the function names (``"_rigid_"`` when another writer wraps them; the
        parts stay keyed by the protocol names).
    allow_empty
        Accept equations without coordinates (the symbolic part of an elastic-only model).
    schedules, schedule_jacobians, schedule_parameter_jacobian
        Scheduling expressions of parametric elastic bodies (parameters, inputs, ``t``,
        coordinates) and their Jacobians: emitted as ``{prefix}schedule(t, y, p, u)``,
        ``{prefix}schedule_jacobians(t, y, p, u)`` and
        ``{prefix}schedule_parameter_jacobian(t, y, p, u)``.
    rhs_parts
        With an index ``k``: also ``{prefix}rhs_parts(t, x, p, u)``, the outputs from ``k`` on
        with ``M`` and ``q − k`` from one program (:func:`_rhs_parts`; the splice of
        elastic bodies, whose frame kinematics are those outputs).
    directional
        Also the directional (second) derivatives of :mod:`.parameters` (``neweul generate
        --sensitivities``; the splice of elastic bodies does not use them).
    progress
        ``progress("code generation", done, total)`` after each block (CSE, derivatives,
        printing of one function; :mod:`neweul_py.progress`).

    Raises
    ------
    GenerationError
        When the equations cannot be turned into code (unknown symbols, a mass matrix that
        depends on velocities, unprintable functions …).
    """
    eq = equations
    system: System = eq.system
    y, yd, p, u = (tuple(eq.coordinates), tuple(eq.velocities), tuple(eq.parameters),
                   tuple(eq.inputs))
    n = len(y)
    if n == 0 and not allow_empty:
        raise GenerationError(f"model {system.name!r} has no coordinates")
    M = sp.ImmutableMatrix(eq.mass_matrix) if n else sp.ImmutableMatrix.zeros(0, 0)
    fvec = sp.ImmutableMatrix(eq.force_vector) if n else sp.ImmutableMatrix.zeros(0, 1)
    outs = sp.ImmutableMatrix(eq.outputs) if len(eq.outputs) else sp.ImmutableMatrix.zeros(0, 1)
    if M.shape != (n, n) or fvec.shape != (n, 1):
        raise GenerationError(
            f"mass matrix {M.shape} and force vector {fvec.shape} do not fit {n} coordinates")
    names_out = list(eq.output_names)
    if outs.shape[0] != len(names_out):
        raise GenerationError("outputs and output_names differ in length")
    energy = getattr(eq, "energy", None)
    energy = (sp.ImmutableMatrix([0, 0, 0, 0]) if energy is None
              else sp.ImmutableMatrix([*energy, 0]))
    inter = tuple((s, as_expr(e)) for s, e in eq.intermediates)

    pool = NamePool()
    pool.names[time] = "t"
    for s in (*y, *yd, *p, *u):
        pool.claim(s)
    for s, _ in inter:
        pool.claim(s)
    ctx = Context(y, yd, p, u, inter, pool)
    # Closed-form expressions profit from sympy's full CSE; recursive-form ones already reuse
    # intermediates, and tree CSE is several times faster at nearly the same operation count.
    method: CseMethod = "none" if not cse else ("tree" if inter else "full")
    # Forward-mode derivatives of a recursive program are already a program without repeated
    # subtrees worth the (super-linear) search; of closed-form ones tree CSE is cheap and helps.
    d_method: CseMethod = "none" if not cse or inter else "tree"

    has_poses = getattr(eq, "poses", None) is not None
    # default inputs, (schedules), 6 blocks of the dynamics, 3 of the state, constraints, poses,
    # parameter derivatives
    step = Steps(progress, "code generation", 12 + bool(schedules) + has_poses)
    funcs: dict[str, tuple[str, ...]] = {
        "default_parameters": _function(
            "default_parameters", "",
            "The parameter vector ``p`` of the defaults (ordered as ``PARAMETERS``).",
            ["return _np.array(_P0, dtype=_np.float64)"]),
    }
    # the input vector: inputs, then the time derivatives kinematic excitation needs
    u_defaults = [as_expr(e) for e in system.input_defaults]
    b = checked(ctx, eliminate((), u_defaults, method=method), (*p, time), "the default inputs")
    body = prologue(ctx, b, [(p, _P_SRC)]) + assignments(ctx, b) + vector(ctx, "u", b.finals)
    funcs["default_inputs"] = _function("default_inputs", "t, p",
                                        "The default excitation ``u(t)`` of the description.",
                                        [*body, "return u"])
    step()
    if schedules:
        funcs.update(_schedule_functions(ctx, schedules, schedule_jacobians, method, prefix,
                                         schedule_parameter_jacobian))
        step()
    funcs.update(_dynamics(ctx, eq, method, d_method, prefix, step))
    funcs.update(_state_functions(ctx, eq, outs, energy, method, d_method, prefix, step))
    funcs.update(_loss_function(ctx, eq, method, prefix))
    parts_size = 0
    if rhs_parts is not None:
        parts_size, fused = _rhs_parts(ctx, eq, outs[rhs_parts:, :], method, prefix)
        funcs.update(fused)
    # constraints g, G, ∂g/∂t, γ of closed loops (codegen/constraints.py)
    for name, block in constraint_functions(ctx, getattr(eq, "constraints", None), method,
                                            prefix).items():
        funcs[name] = tuple(block)
    step()
    if has_poses:  # poses of the frames (animations)
        funcs.update(_pose_functions(ctx, eq, method, prefix))
        step()
    # derivatives with respect to the parameters (docs/sensitivity.md)
    funcs.update(parameter_functions(ctx, eq, outs, method, d_method, prefix, directional))
    step()
    pdef = tuple(float(pp.default) for pp in system.parameters)
    symmetric = bool(M == M.T)
    factors = mass_factor_values(eq)
    sizes = (factored_sizes(n, factors) if factors
             else (n * n, n * n + 2 * n) if n else ())
    if parts_size and parts_size not in sizes:
        sizes = (*sizes, parts_size)
    helpers = factored_definitions(n, factors) if factors else solver_definition(symmetric)
    return ModuleParts(
        docstring=_header(system),
        imports=IMPORTS,
        constants=_constants(eq, source_hash, names_out, symmetric),
        private=(f"_P0 = {pdef!r}", *(pack_definition(s) for s in sizes), "", "", *helpers),
        functions=funcs,
    )


def program_blocks(equations: Any, *, cse: bool = True,
                   progress: StagedProgress = None) -> dict[str, Block]:
    """The CSE'd straight-line programs of the protocol functions, for other printers.

    The programs of :mod:`.programs`, which :func:`module_parts` prints too (computed once when
    both backends are generated from the same equations object). Matrices are given row-major with
    every entry (zeros included): ``mass_matrix`` (n·n), ``force_vector`` (n), ``rhs`` (n·n of
    ``M``, then n of ``q − k``), ``force_jacobians`` (n × (2n + nu): ``∂/∂y``, ``∂/∂ẏ``, ``∂/∂u``),
    ``mass_matrix_times_derivative`` (n·n, in the symbols ``Symbol(f"_ncg_a{i}", real=True)`` of
    the vector ``a``), ``default_inputs`` (nu), ``outputs`` (ny), ``output_jacobians`` (ny × (2n +
    nu)), ``constraints`` (nc), ``constraint_jacobian`` (nc·n), ``constraint_time_derivative``
    (nc), ``constraint_gamma`` (nc), for models with loss factors, ``loss_matrix`` (n·n,
    equations.md §1.1), and the parameter derivatives ``force_parameter_jacobian`` (n × np),
    ``mass_matrix_parameter_derivative`` (n × np, in the symbols ``a``) and
    ``output_parameter_jacobian`` (ny × np, docs/sensitivity.md). Rigid models only (elastic
    bodies are spliced in numerically by :mod:`~neweul_py.codegen.elastic`). The NumPy module's
    own ``mass_matrix`` and ``rhs`` evaluate ``Equations.mass_factors`` when given
    (:mod:`.packing`); the blocks here keep M's entries. ``progress``: a staged hook,
    ``("C code", done, 7)`` after each block.
    """
    step = Steps(progress, "C code", 7)
    eq = equations
    n = len(eq.coordinates)
    outs = sp.ImmutableMatrix(eq.outputs) if len(eq.outputs) else sp.ImmutableMatrix.zeros(0, 1)
    inter = tuple((s, as_expr(e)) for s, e in eq.intermediates)
    method: CseMethod = "none" if not cse else ("tree" if inter else "full")
    d_method: CseMethod = "none" if not cse or inter else "tree"
    out: dict[str, Block] = {}
    out["default_inputs"] = eliminate((), [as_expr(e) for e in eq.system.input_defaults],
                                      method=method)
    step()
    dp = dynamics_programs(eq, inter, method, d_method)
    program, m_full = dp.program, dp.m_full
    f_red = dp.parts(n)[1]
    out["mass_matrix"] = subblock(program, m_full.flat())
    out["force_vector"] = subblock(program, f_red)
    out["rhs"] = subblock(program, (*m_full.flat(), *f_red))
    step()
    b, Jr = dp.force_jacobians
    out["force_jacobians"] = Block(b.assignments, tuple(Jr))
    step()
    b, Jr = dp.mass_derivative
    out["mass_matrix_times_derivative"] = Block(b.assignments, tuple(Jr))
    step()
    op = output_programs(eq, inter, outs, method, d_method)
    out["outputs"] = op.program
    step()
    b, Jr = op.jacobians
    out["output_jacobians"] = Block(b.assignments, tuple(Jr))
    step()
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
    loss = loss_program(eq, inter, method)
    if loss is not None:
        out["loss_matrix"] = loss
    pp = parameter_programs(eq, inter, outs, method, d_method)
    for name, (b, Jr) in (("force_parameter_jacobian", pp.force),
                          ("mass_matrix_parameter_derivative", pp.mass),
                          ("output_parameter_jacobian", pp.outputs)):
        out[name] = Block(b.assignments, tuple(Jr))
    step()
    return out

