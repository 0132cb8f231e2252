"""The CSE'd programs of the dynamics and the outputs, computed once per equations.

The NumPy writer (:func:`.writer.module_parts`) and the C backend (:func:`.writer.program_blocks`)
print the same programs: one CSE over ``M``, ``q − k`` and the factored mass matrix, the
forward-mode Jacobians ``∂(q − k)/∂(y, ẏ, u)`` and ``∂(M a)/∂y`` through it, and the outputs
with their Jacobians. Generating both backends in one process asked for them twice (≈ 0.13 s of
the 0.5 s of code generation at N = 10); here they are computed once and kept for the last few
equations objects, looked up by identity (the equations are immutable, and an entry holds its
equations, so an identity cannot be reused while the entry lives). The results depend only on
the arguments, so a hit returns exactly what a fresh computation would.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import sympy as sp

from ..equations.jacobians import (
    Direction,
    Program,
    directional,
    force_jacobians,
    force_parameter_jacobian,
    input_parameter_jacobian,
    mass_matrix_parameter_derivative,
    mass_matrix_times_derivative,
    output_jacobians,
    output_parameter_jacobian,
)
from ..model import as_expr
from .blocks import derivative_block, mass_entries, second_derivative_block
from .cse import Assignment, Block, CseMethod, eliminate, hoist_constant_factors

__all__ = ["DirectionalPrograms", "DynamicsPrograms", "OutputPrograms", "ParameterPrograms",
           "directional_programs", "dynamics_programs", "loss_program", "mass_factor_values",
           "mass_vector_symbols", "output_programs", "parameter_programs", "rhs_parts_program"]

#: Recently computed programs: (equations, key, value), newest last.
_RECENT: list[tuple[Any, tuple[Any, ...], Any]] = []
_RECENT_SIZE = 4


def _remembered(eq: Any, key: tuple[Any, ...], compute: Callable[[], Any]) -> Any:
    for e, k, value in _RECENT:
        if e is eq and k == key:
            return value
    value = compute()
    _RECENT.append((eq, key, value))
    del _RECENT[:-_RECENT_SIZE]
    return value


def mass_factor_values(eq: Any) -> list[sp.Expr]:
    """The weights, then the rows (row by row) of ``eq.mass_factors``; empty without them."""
    factors = getattr(eq, "mass_factors", None) if len(eq.coordinates) else None
    if not factors:
        return []
    return [*(as_expr(w) for w, _ in factors), *(as_expr(g) for _, row in factors for g in row)]


@dataclass(frozen=True)
class DynamicsPrograms:
    """The dynamics of one equations object.

    Attributes
    ----------
    program
        One CSE'd block; its finals are M's unique entries, then ``q − k``, then the factored
        mass matrix's weights and rows (:func:`mass_factor_values`; none in closed form).
    m_where
        The positions of each unique entry of M (:func:`.blocks.mass_entries`).
    m_full
        M in the program's symbols (n × n).
    force_jacobians
        ``(block, J)``: ``∂(q − k)/∂(y, ẏ, u)`` through the program.
    mass_derivative
        ``(block, J)``: ``∂(M a)/∂y`` in the symbols ``Symbol(f"_ncg_a{i}", real=True)``.
    """

    program: Block
    m_where: list[list[tuple[int, int]]]
    m_full: sp.Matrix
    force_jacobians: tuple[Block, sp.ImmutableMatrix]
    mass_derivative: tuple[Block, sp.ImmutableMatrix]

    @property
    def nm(self) -> int:
        """The number of unique entries of M."""
        return len(self.m_where)

    def parts(self, n: int) -> tuple[tuple[sp.Expr, ...], tuple[sp.Expr, ...],
                                     tuple[sp.Expr, ...]]:
        """The finals split into M's unique entries, ``q − k`` and the factored form."""
        f = self.program.finals
        return f[:self.nm], f[self.nm:self.nm + n], f[self.nm + n:]


def dynamics_programs(eq: Any, inter: Sequence[Assignment], method: CseMethod,
                      d_method: CseMethod) -> DynamicsPrograms:
    """The :class:`DynamicsPrograms` of ``eq`` (``inter``: its intermediates as expressions)."""
    def compute() -> DynamicsPrograms:
        n = len(eq.coordinates)
        M = sp.ImmutableMatrix(eq.mass_matrix) if n else sp.ImmutableMatrix.zeros(0, 0)
        fvec = sp.ImmutableMatrix(eq.force_vector) if n else sp.ImmutableMatrix.zeros(0, 1)
        m_values, m_where = mass_entries(M)
        program = eliminate(*hoist_constant_factors(
            inter, [*m_values, *fvec.flat(), *mass_factor_values(eq)], tuple(eq.parameters)),
            prefix="_ncg_c", method=method)
        nm = len(m_values)
        rows = [[sp.S.Zero] * n for _ in range(n)]
        for value, places in zip(program.finals[:nm], m_where, strict=True):
            for i, j in places:
                rows[i][j] = value
        m_full = sp.Matrix(n, n, [v for row in rows for v in row])
        f_red = program.finals[nm:nm + n]
        fj = derivative_block(force_jacobians(eq, Program(program.assignments, f_red)),
                              d_method)
        a_syms = tuple(sp.Symbol(f"_ncg_a{i}", real=True) for i in range(n))
        mj = derivative_block(mass_matrix_times_derivative(
            eq, a_syms, Program(program.assignments, tuple(m_full.flat()))), d_method)
        return DynamicsPrograms(program, m_where, m_full, fj, mj)

    return _remembered(eq, ("dynamics", method, d_method), compute)


@dataclass(frozen=True)
class OutputPrograms:
    """The outputs' CSE'd block and ``(block, J)`` of ``∂out/∂(y, ẏ, u)``."""

    program: Block
    jacobians: tuple[Block, sp.ImmutableMatrix]


def output_programs(eq: Any, inter: Sequence[Assignment], outs: sp.ImmutableMatrix,
                    method: CseMethod, d_method: CseMethod) -> OutputPrograms:
    """The :class:`OutputPrograms` of ``eq`` for the outputs ``outs``."""
    def compute() -> OutputPrograms:
        prog = eliminate(inter, list(outs), prefix="_ncg_o", method=method)
        return OutputPrograms(prog, derivative_block(
            output_jacobians(eq, Program(prog.assignments, prog.finals)), d_method))

    return _remembered(eq, ("outputs", method, d_method, tuple(outs)), compute)


def rhs_parts_program(eq: Any, inter: Sequence[Assignment], outs: sp.ImmutableMatrix,
                      method: CseMethod) -> tuple[Block, list[list[tuple[int, int]]] | None]:
    """One CSE'd block of the outputs ``outs``, ``q − k`` and the mass matrix: its finals are
    ``outs``, then ``q − k``, then the factored form's weights and rows
    (:func:`mass_factor_values`) or, in closed form, M's unique entries; returned with the
    positions of those entries (:func:`.blocks.mass_entries`; ``None`` in the factored form).
    The splice of elastic bodies needs all three at one state in every ``rhs`` call
    (their frame kinematics are hidden outputs, :mod:`~neweul_py.codegen.elastic`): one program
    computes the subexpressions they share (rotations, Jacobian rows, velocities) once."""
    def compute() -> tuple[Block, list[list[tuple[int, int]]] | None]:
        n = len(eq.coordinates)
        fvec = sp.ImmutableMatrix(eq.force_vector) if n else sp.ImmutableMatrix.zeros(0, 1)
        factors = mass_factor_values(eq)
        where = None
        if factors:
            mass = factors
        else:
            M = sp.ImmutableMatrix(eq.mass_matrix) if n else sp.ImmutableMatrix.zeros(0, 0)
            mass, where = mass_entries(M)
        program = eliminate(*hoist_constant_factors(
            inter, [*outs, *fvec, *mass], tuple(eq.parameters), prefix="_ncg_xk"),
            prefix="_ncg_x", method=method)
        return program, where

    return _remembered(eq, ("rhs_parts", method, tuple(outs)), compute)


def loss_program(eq: Any, inter: Sequence[Assignment], method: CseMethod) -> Block | None:
    """The CSE'd program of the hysteretic matrix ``G`` (``Equations.loss_matrix``, n·n
    row-major, zeros included; equations.md §1.1), ``None`` when the model has none."""
    G = getattr(eq, "loss_matrix", None)
    if G is None:
        return None

    def compute() -> Block:
        entries = G.flat() if isinstance(G, sp.MatrixBase) else list(G)
        return eliminate(inter, [as_expr(e) for e in entries], prefix="_ncg_l", method=method)

    return _remembered(eq, ("loss", method), compute)


def mass_vector_symbols(n: int) -> tuple[sp.Symbol, ...]:
    """The symbols ``a`` of ``∂(M a)/∂y`` and ``∂(M a)/∂p`` (the generated functions'
    argument): ``Symbol(f"_ncg_a{i}", real=True)``, i < n."""
    return tuple(sp.Symbol(f"_ncg_a{i}", real=True) for i in range(n))


@dataclass(frozen=True)
class ParameterPrograms:
    """The parameter Jacobians of one equations object (docs/sensitivity.md), each
    ``(block, J)`` through the programs of :func:`dynamics_programs` and
    :func:`output_programs`: ``inputs`` ``∂u₀/∂p`` (nu × np), ``force`` ``∂(q−k)/∂p``
    (n × np), ``mass`` ``∂(M a)/∂p`` (n × np, in :func:`mass_vector_symbols`) and
    ``outputs`` ``∂out/∂p`` (ny × np)."""

    inputs: tuple[Block, sp.ImmutableMatrix]
    force: tuple[Block, sp.ImmutableMatrix]
    mass: tuple[Block, sp.ImmutableMatrix]
    outputs: tuple[Block, sp.ImmutableMatrix]


def parameter_programs(eq: Any, inter: Sequence[Assignment], outs: sp.ImmutableMatrix,
                       method: CseMethod, d_method: CseMethod) -> ParameterPrograms:
    """The :class:`ParameterPrograms` of ``eq`` for the outputs ``outs``."""
    def compute() -> ParameterPrograms:
        n = len(eq.coordinates)
        dp = dynamics_programs(eq, inter, method, d_method)
        op = output_programs(eq, inter, outs, method, d_method)
        f_red = dp.parts(n)[1]
        return ParameterPrograms(
            derivative_block(input_parameter_jacobian(eq), method),
            derivative_block(force_parameter_jacobian(
                eq, Program(dp.program.assignments, f_red)), d_method),
            derivative_block(mass_matrix_parameter_derivative(
                eq, mass_vector_symbols(n),
                Program(dp.program.assignments, tuple(dp.m_full.flat()))),
                d_method),
            derivative_block(output_parameter_jacobian(
                eq, Program(op.program.assignments, op.program.finals)), d_method))

    return _remembered(eq, ("parameters", method, d_method, tuple(outs)), compute)


@dataclass(frozen=True)
class DirectionalPrograms:
    """Directional derivatives along :attr:`direction` ``(δy, δẏ, δp, δu)``, each
    ``(block, J)``: of the force Jacobians ``[∂/∂y, ∂/∂ẏ, ∂/∂u](q−k)`` (n × (2n + nu)), of
    ``M`` (n × n), of ``∂(M a)/∂y`` (n × n), of the output Jacobians (ny × (2n + nu)) and of
    the hysteretic matrix ``G`` (n × n, ``None`` without loss factors)."""

    direction: Direction
    force_jacobians: tuple[Block, sp.ImmutableMatrix]
    mass_matrix: tuple[Block, sp.ImmutableMatrix]
    mass_matrix_times_derivative: tuple[Block, sp.ImmutableMatrix]
    output_jacobians: tuple[Block, sp.ImmutableMatrix]
    loss_matrix: tuple[Block, sp.ImmutableMatrix] | None


def directional_programs(eq: Any, inter: Sequence[Assignment], outs: sp.ImmutableMatrix,
                         method: CseMethod, d_method: CseMethod) -> DirectionalPrograms:
    """The :class:`DirectionalPrograms` of ``eq``: directional derivatives
    (:func:`~neweul_py.equations.jacobians.directional`) through the printed (CSE'd) first
    derivatives."""
    def compute() -> DirectionalPrograms:
        n, nu = len(eq.coordinates), len(eq.inputs)
        d = Direction.of(eq)
        dp = dynamics_programs(eq, inter, method, d_method)
        op = output_programs(eq, inter, outs, method, d_method)

        def along(block: Block, shape: tuple[int, int]) -> tuple[Block, sp.ImmutableMatrix]:
            return second_derivative_block(
                directional(eq, d, Program(block.assignments, tuple(block.finals)), shape),
                d_method)

        loss = loss_program(eq, inter, method)
        return DirectionalPrograms(
            d,
            along(dp.force_jacobians[0], (n, 2 * n + nu)),
            along(Block(dp.program.assignments, tuple(dp.m_full.flat())), (n, n)),
            along(dp.mass_derivative[0], (n, n)),
            along(op.jacobians[0], (outs.shape[0], 2 * n + nu)),
            None if loss is None else along(loss, (n, n)))

    return _remembered(eq, ("directional", method, d_method, tuple(outs)), compute)
