"""Generated functions of the parameter derivatives (docs/sensitivity.md,
docs/generated-module-protocol.md): printed from the blocks of
:func:`.programs.parameter_programs` and :func:`.programs.directional_programs`, whose
derivatives :mod:`neweul_py.equations.jacobians` takes.

First derivatives (at fixed inputs ``u``; ``u=None`` holds the default excitation's values):
``default_inputs_parameter_jacobian`` ``∂u₀/∂p``, ``force_parameter_jacobian`` ``∂(q−k)/∂p``,
``mass_matrix_parameter_derivative`` ``∂(M a)/∂p``, ``rhs_parameter_jacobian``
``∂rhs/∂p = [0; M⁻¹(∂(q−k)/∂p − ∂(M ÿ)/∂p)]`` and ``output_parameter_jacobian`` ``∂out/∂p``.

Directional derivatives along ``(δy, δẏ, δp, δu)`` (the second derivatives that the parameter
derivatives of the linearized matrices need; in modules generated with sensitivities,
:func:`.module.render_module`): ``force_jacobians_directional``,
``mass_matrix_directional``, ``mass_matrix_times_derivative_directional``,
``output_jacobians_directional`` and, with loss factors, ``loss_matrix_directional``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import sympy as sp

from ..model import time
from .blocks import (
    INDENT,
    Context,
    assignments,
    checked,
    function,
    inputs_prologue,
    matrix_fill,
    prologue,
    sparse,
)
from .cse import CseMethod
from .programs import (
    directional_programs,
    mass_vector_symbols,
    parameter_programs,
)

__all__ = ["DIRECTIONAL_FUNCTIONS", "PARAMETER_FUNCTIONS", "parameter_functions"]

#: The first-derivative functions, in module order.
PARAMETER_FUNCTIONS = ("default_inputs_parameter_jacobian", "force_parameter_jacobian",
                       "mass_matrix_parameter_derivative", "rhs_parameter_jacobian",
                       "output_parameter_jacobian")
#: The directional functions, in module order (``loss_matrix_directional`` only with loss
#: factors).
DIRECTIONAL_FUNCTIONS = ("force_jacobians_directional", "mass_matrix_directional",
                         "mass_matrix_times_derivative_directional",
                         "output_jacobians_directional", "loss_matrix_directional")


def _array(name: str) -> str:
    return f"_np.asarray({name}, dtype=_np.float64).tolist()"


def _def(name: str, args: str, doc: str, body: Sequence[str]) -> tuple[str, ...]:
    return tuple(function(f"{name}({args})", doc, body)[:-2])


def _fill(ctx: Context, J: sp.ImmutableMatrix, splits: Sequence[tuple[str, int, int]]
          ) -> list[str]:
    """``matrix_fill`` of the column blocks ``(name, start, width)`` of ``J``."""
    lines: list[str] = []
    for name, start, width in splits:
        part = (sp.ImmutableMatrix(J[:, start:start + width]) if J.rows
                else sp.ImmutableMatrix.zeros(0, width))
        lines += matrix_fill(ctx, name, (J.rows, width), sparse(part) if J.rows else {})
    return lines


def parameter_functions(ctx: Context, eq: Any, outs: sp.ImmutableMatrix, method: CseMethod,
                        d_method: CseMethod, prefix: str = "", directional: bool = False
                        ) -> dict[str, tuple[str, ...]]:
    """Source lines of the parameter-derivative functions, by protocol name.

    Parameters
    ----------
    ctx
        The writer's context (names, printer, symbol groups).
    eq
        The equations (see :func:`.writer.module_parts`).
    outs
        The outputs (the module's, and for elastic bodies the hidden frame kinematics).
    method, d_method
        The CSE methods of the module and of its derivatives.
    prefix
        Prefix of the function names (``"_rigid_"`` inside modules with elastic bodies).
    directional
        Also the directional (second) derivatives (modules generated with sensitivities).
    """
    y, yd, p, u = ctx.y, ctx.yd, ctx.p, ctx.u
    n, nu, npar = len(y), len(u), len(p)
    kin = (*y, *p, *u, time)
    dyn = (*kin, *yd)
    a = mass_vector_symbols(n)
    for i, s in enumerate(a):
        ctx.pool.claim(s, f"_a{i}")
    pp = parameter_programs(eq, ctx.intermediates, outs, method, d_method)
    out: dict[str, tuple[str, ...]] = {}

    b, J = pp.inputs
    b = checked(ctx, b, (*p, time), "∂u₀/∂p")
    body = (prologue(ctx, b, [(p, _array("p"))]) + assignments(ctx, b)
            + _fill(ctx, J, [("Up", 0, npar)]))
    out["default_inputs_parameter_jacobian"] = _def(
        "default_inputs_parameter_jacobian", "t, p",
        "``∂u₀/∂p`` (nu, np) of the default excitation, analytic.", [*body, "return Up"])

    b, J = pp.force
    b = checked(ctx, b, dyn, "∂(q−k)/∂p")
    body = (prologue(ctx, b, [(y, _array("y")), (yd, _array("yd")), (p, _array("p"))])
            + inputs_prologue(ctx, b) + assignments(ctx, b) + _fill(ctx, J, [("fp", 0, npar)]))
    out["force_parameter_jacobian"] = _def(
        f"{prefix}force_parameter_jacobian", "t, y, yd, p, u=None",
        "``∂(q−k)/∂p`` (n, np) at fixed ``u``, analytic.", [*body, "return fp"])

    b, J = pp.mass
    b = checked(ctx, b, (*kin, *a), "∂(M a)/∂p")
    body = (prologue(ctx, b, [(y, _array("y")), (p, _array("p")), (a, _array("a"))])
            + inputs_prologue(ctx, b) + assignments(ctx, b) + _fill(ctx, J, [("dMa", 0, npar)]))
    out["mass_matrix_parameter_derivative"] = _def(
        f"{prefix}mass_matrix_parameter_derivative", "t, y, p, a, u=None",
        "``∂(M(y) a)/∂p`` (n, np) for a fixed vector ``a``, analytic.", [*body, "return dMa"])

    out["rhs_parameter_jacobian"] = _def(
        f"{prefix}rhs_parameter_jacobian", "t, x, p, u=None",
        "``∂ rhs/∂p = [0; M⁻¹(∂(q−k)/∂p − ∂(M ÿ)/∂p)]`` (STATE_SIZE, np) at fixed ``u``, "
        "analytic.",
        [
            "x = _np.asarray(x, dtype=_np.float64)",
            *(["if u is None:", f"{INDENT}u = default_inputs(t, p)"] if nu else []),
            f"J = _np.zeros(({2 * n}, {npar}))",
            *([] if not (n and npar) else [
                f"y = x[:{n}]",
                f"yd = x[{n}:{2 * n}]",
                f"M = {prefix}mass_matrix(t, y, p, u)",
                f"ydd = _np.linalg.solve(M, {prefix}force_vector(t, y, yd, p, u))",
                f"fp = {prefix}force_parameter_jacobian(t, y, yd, p, u)",
                f"dMa = {prefix}mass_matrix_parameter_derivative(t, y, p, ydd, u)",
                f"J[{n}:, :] = _np.linalg.solve(M, fp - dMa)"]),
            "return J",
        ])

    b, J = pp.outputs
    b = checked(ctx, b, dyn, "∂out/∂p")
    body = (prologue(ctx, b, [((*y, *yd), _array("x")), (p, _array("p"))])
            + inputs_prologue(ctx, b) + assignments(ctx, b)
            + _fill(ctx, J, [("Op", 0, npar)]))
    out["output_parameter_jacobian"] = _def(
        f"{prefix}output_parameter_jacobian", "t, x, p, u=None",
        "``∂out/∂p`` (ny, np) at fixed state and ``u``, analytic.", [*body, "return Op"])
    if directional:
        out.update(_directional_functions(ctx, eq, outs, method, d_method, prefix))
    return out


def _directional_functions(ctx: Context, eq: Any, outs: sp.ImmutableMatrix, method: CseMethod,
                           d_method: CseMethod, prefix: str) -> dict[str, tuple[str, ...]]:
    """The directional functions (:data:`DIRECTIONAL_FUNCTIONS`)."""
    y, yd, p, u = ctx.y, ctx.yd, ctx.p, ctx.u
    n, nu = len(y), len(u)
    dirs = directional_programs(eq, ctx.intermediates, outs, method, d_method)
    d = dirs.direction
    for name, group in (("dy", d.dy), ("dyd", d.dyd), ("dp", d.dp), ("du", d.du)):
        for i, s in enumerate(group):
            ctx.pool.claim(s, f"_{name}{i}")
    a = mass_vector_symbols(n)
    base = (*y, *yd, *p, *u, time, *d.dy, *d.dyd, *d.dp, *d.du, *a)
    du_src = (f"(_np.zeros({nu}) if du is None else _np.asarray(du, dtype=_np.float64))"
              ".tolist()")
    state = [((*y, *yd), _array("x")), (p, _array("p")), ((*d.dy, *d.dyd), _array("dx")),
             (d.dp, _array("dp")), (d.du, du_src)]
    out: dict[str, tuple[str, ...]] = {}

    def body(block: Any, sources: list, what: str) -> list[str]:
        b = checked(ctx, block, base, what)
        return prologue(ctx, b, sources) + inputs_prologue(ctx, b) + assignments(ctx, b)

    b, J = dirs.force_jacobians
    lines = body(b, [(y, _array("y")), (yd, _array("yd")), (p, _array("p")),
                     (d.dy, _array("dy")), (d.dyd, _array("dyd")), (d.dp, _array("dp")),
                     (d.du, du_src)], "the directional force Jacobians")
    lines += _fill(ctx, J, [("dfy", 0, n), ("dfyd", n, n), ("dfu", 2 * n, nu)])
    out["force_jacobians_directional"] = _def(
        f"{prefix}force_jacobians_directional", "t, y, yd, p, dy, dyd, dp, u=None, du=None",
        "Derivatives of ``force_jacobians`` along ``(δy, δẏ, δp, δu)`` (``du=None``: 0), "
        "analytic.", [*lines, "return dfy, dfyd, dfu"])

    b, J = dirs.mass_matrix
    lines = body(b, [(y, _array("y")), (p, _array("p")), (d.dy, _array("dy")),
                     (d.dp, _array("dp")), (d.du, du_src)], "the directional mass matrix")
    out["mass_matrix_directional"] = _def(
        f"{prefix}mass_matrix_directional", "t, y, p, dy, dp, u=None, du=None",
        "Derivative of ``M`` along ``(δy, δp, δu)`` (n, n), analytic.",
        [*lines, *_fill(ctx, J, [("dM", 0, n)]), "return dM"])

    b, J = dirs.mass_matrix_times_derivative
    lines = body(b, [(y, _array("y")), (p, _array("p")), (a, _array("a")),
                     (d.dy, _array("dy")), (d.dp, _array("dp")), (d.du, du_src)],
                 "the directional ∂(M a)/∂y")
    out["mass_matrix_times_derivative_directional"] = _def(
        f"{prefix}mass_matrix_times_derivative_directional",
        "t, y, p, a, dy, dp, u=None, du=None",
        "Derivative of ``∂(M(y) a)/∂y`` (fixed ``a``) along ``(δy, δp, δu)`` (n, n), analytic.",
        [*lines, *_fill(ctx, J, [("ddMa", 0, n)]), "return ddMa"])

    b, J = dirs.output_jacobians
    lines = body(b, state, "the directional output Jacobians")
    lines += _fill(ctx, J, [("dC", 0, 2 * n), ("dD", 2 * n, nu)])
    out["output_jacobians_directional"] = _def(
        f"{prefix}output_jacobians_directional", "t, x, p, dx, dp, u=None, du=None",
        "Derivatives of ``output_jacobians`` along ``(δx, δp, δu)``, analytic.",
        [*lines, "return dC, dD"])

    if dirs.loss_matrix is not None:
        b, J = dirs.loss_matrix
        lines = body(b, state, "the directional loss matrix")
        out["loss_matrix_directional"] = _def(
            f"{prefix}loss_matrix_directional", "t, x, p, dx, dp, u=None, du=None",
            "Derivative of ``loss_matrix`` along ``(δx, δp, δu)`` (n, n), analytic.",
            [*lines, *_fill(ctx, J, [("dG", 0, n)]), "return dG"])
    return out
