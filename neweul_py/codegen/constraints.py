"""Generated constraint functions of closed kinematic loops (equations.md §1):
``constraints`` (``g``), ``constraint_jacobian`` (``G = ∂g/∂y``),
``constraint_time_derivative`` (``∂g/∂t``) and ``constraint_gamma`` (``γ`` with
``G ÿ + γ = 0``), from the symbolic :class:`~neweul_py.equations.constraints.ConstraintEquations`,
common subexpressions eliminated like the rest of the module.

All four take ``u=None`` as a last argument like the other functions of the protocol (the
default excitation when omitted); the protocol's ``(t, y, p)`` calls work unchanged.

The reactions of rigid models are ``Gᵀ λ``, so these modules define no
``constraint_reaction_jacobian`` (readers use ``G``); modules with elastic bodies add it
(``G_s S_W``, :mod:`neweul_py.codegen.elastic`): a constraint on a node frame of a two-sided
body loads its elastic rows through the left basis.
"""

from __future__ import annotations

from typing import Any

import sympy as sp

from ..model import time
from .blocks import (
    assignments,
    checked,
    function,
    inputs_prologue,
    matrix_fill,
    prologue,
    sparse,
    vector,
)
from .cse import eliminate

__all__ = ["constraint_constant", "constraint_functions"]


def constraint_constant(names: tuple[str, ...]) -> str:
    """The ``CONSTRAINTS`` line of the module."""
    return f"CONSTRAINTS = {list(names)!r}"


def constraint_functions(ctx: Any, ce: Any, method: str, prefix: str = ""
                         ) -> dict[str, list[str]]:
    """Source lines of the four constraint functions, by protocol name.

    Parameters
    ----------
    ctx
        The writer's context (names, printer, symbol groups).
    ce
        :class:`~neweul_py.equations.constraints.ConstraintEquations`, or ``None`` (no
        constraints: empty arrays).
    method
        The CSE method of the module (``"full"``, ``"tree"``, ``"none"``).
    prefix
        Prefix of the function names (see :func:`.writer.module_parts`).
    """
    y, yd, p, u = ctx.y, ctx.yd, ctx.p, ctx.u
    n = len(y)
    nc = 0 if ce is None else ce.nc
    if nc == 0:
        return {
            "constraints": function(f"{prefix}constraints(t, y, p, u=None)",
                                    "Holonomic constraints ``g(y, t)`` (none).",
                                    ["return _np.zeros(0)"])[:-2],
            "constraint_jacobian": function(f"{prefix}constraint_jacobian(t, y, p, u=None)",
                                            "``G = ∂g/∂y`` (none).",
                                            [f"return _np.zeros((0, {n}))"])[:-2],
            "constraint_time_derivative": function(
                f"{prefix}constraint_time_derivative(t, y, p, u=None)", "``∂g/∂t`` (none).",
                ["return _np.zeros(0)"])[:-2],
            "constraint_gamma": function(f"{prefix}constraint_gamma(t, y, yd, p, u=None)",
                                         "``γ`` with ``G ÿ + γ = 0`` (none).",
                                         ["return _np.zeros(0)"])[:-2],
        }

    kin = (*y, *p, *u, time)
    dyn = (*kin, *yd)
    y_src = "_np.asarray(y, dtype=_np.float64).tolist()"
    yd_src = "_np.asarray(yd, dtype=_np.float64).tolist()"
    p_src = "_np.asarray(p, dtype=_np.float64).tolist()"
    out: dict[str, list[str]] = {}

    def positional(finals: list[sp.Expr], what: str, cse_prefix: str):
        b = checked(ctx, eliminate((), finals, prefix=cse_prefix, method=method), kin, what)
        head = prologue(ctx, b, [(y, y_src), (p, p_src)]) + inputs_prologue(ctx, b)
        return b, head + assignments(ctx, b)

    b, body = positional(list(ce.g), "the constraints", "_ncg_g")
    out["constraints"] = function(f"{prefix}constraints(t, y, p, u=None)",
                       "Holonomic constraints ``g(y, t)``, ordered as ``CONSTRAINTS``.",
                       [*body, *vector(ctx, "g", b.finals), "return g"])[:-2]

    b, body = positional(list(ce.G), "the constraint Jacobian", "_ncg_G")
    J = sp.ImmutableMatrix(nc, n, list(b.finals))
    out["constraint_jacobian"] = function(f"{prefix}constraint_jacobian(t, y, p, u=None)",
                       "``G = ∂g/∂y``, shape (nc, n), analytic.",
                       [*body, *matrix_fill(ctx, "G", (nc, n), sparse(J)), "return G"])[:-2]

    b, body = positional(list(ce.g_t), "∂g/∂t", "_ncg_gt")
    out["constraint_time_derivative"] = function(
        f"{prefix}constraint_time_derivative(t, y, p, u=None)",
                       "``∂g/∂t`` (explicit time dependence, through inputs), shape (nc,).",
                       [*body, *vector(ctx, "gt", b.finals), "return gt"])[:-2]

    b = checked(ctx, eliminate((), list(ce.gamma), prefix="_ncg_h", method=method), dyn,
                 "the constraint γ")
    body = (prologue(ctx, b, [(y, y_src), (yd, yd_src), (p, p_src)])
            + inputs_prologue(ctx, b) + assignments(ctx, b))
    out["constraint_gamma"] = function(
        f"{prefix}constraint_gamma(t, y, yd, p, u=None)",
        "``γ = ∂(G ẏ + ∂g/∂t)/∂y · ẏ + ∂(G ẏ + ∂g/∂t)/∂t`` with ``G ÿ + γ = 0``, shape (nc,).",
        [*body, *vector(ctx, "gamma", b.finals), "return gamma"],
    )[:-2]
    return out
