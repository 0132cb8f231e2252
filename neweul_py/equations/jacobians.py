"""The derivatives of the equations of motion that a generated module evaluates
(docs/equations.md §1, "Linearization"; docs/generated-module-protocol.md).

Every symbolic derivative of the protocol is taken here, by the forward-mode chain rule of
:func:`~neweul_py.equations.derivatives.jacobian` through a *program*: ordered assignments and
the values they lead to. By default the program is the equations' own
(``Equations.intermediates`` and ``M``, ``q − k``, the outputs); code generation passes the
common-subexpression-eliminated program it prints instead (:mod:`neweul_py.codegen.programs`),
so that the derivatives reuse its subexpressions, and prints what comes back. Code generation
derives nothing itself.

===========================================  ==================================================
function                                     matrices
===========================================  ==================================================
:func:`force_jacobians`                      ``∂(q−k)/∂y``, ``∂(q−k)/∂ẏ``, ``∂(q−k)/∂u``
:func:`mass_matrix_times_derivative`         ``∂(M(y) a)/∂y`` for a vector of symbols ``a``
:func:`output_jacobians`                     ``∂out/∂[y, ẏ]``, ``∂out/∂u``
:func:`force_parameter_jacobian`             ``∂(q−k)/∂p``
:func:`mass_matrix_parameter_derivative`     ``∂(M(y) a)/∂p``
:func:`output_parameter_jacobian`            ``∂out/∂p``
:func:`input_parameter_jacobian`             ``∂u₀/∂p`` of the default excitation
:func:`directional`                          ``d/dε`` of any of these (or of ``M``, ``G``)
                                             along a :class:`Direction` ``(δy, δẏ, δp, δu)``
===========================================  ==================================================

The directional derivatives are the second derivatives that the parameter derivatives of the
linearized matrices need (docs/sensitivity.md): ``dQ/dp_j`` is the derivative of ``−∂(q−k)/∂y
+ ∂(M ÿ0)/∂y`` along ``(δy = dy0/dp_j, δp = e_j, …)``; one seeded column each keeps the code
as long as the first derivatives' instead of ``np`` times as long.

Distributional derivatives (``DiracDelta`` from ``sign``, ``Heaviside``, ``Abs′``) are taken
as zero: the Jacobians are the derivatives almost everywhere.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import sympy as sp

from ..model import as_expr
from ..model.canonical import add, mul
from ..model.program import Assignment
from .derivatives import directional_derivative, jacobian

__all__ = [
    "SECOND_PREFIX",
    "Derivatives",
    "Direction",
    "Program",
    "directional",
    "force_jacobians",
    "force_parameter_jacobian",
    "input_parameter_jacobian",
    "mass_matrix_parameter_derivative",
    "mass_matrix_times_derivative",
    "output_jacobians",
    "output_parameter_jacobian",
]

#: Name prefix of the derivative intermediates made here.
PREFIX = "_ncg_d"
#: Name prefix of the intermediates of directional (second) derivatives, which are taken
#: through programs holding first-derivative intermediates.
SECOND_PREFIX = "_ncg_s"


@dataclass(frozen=True)
class Program:
    """Straight-line code: ``assignments`` in order, then the ``values`` it computes.

    Attributes
    ----------
    assignments
        Ordered ``(symbol, expression)`` pairs; each expression may use earlier symbols.
    values
        The expressions to differentiate, in the symbols of ``assignments`` and the base
        symbols (coordinates, velocities, parameters, inputs, ``t``).
    """

    assignments: tuple[Assignment, ...]
    values: tuple[sp.Expr, ...]


@dataclass(frozen=True)
class Derivatives:
    """Symbolic derivative matrices and the intermediates they need.

    Attributes
    ----------
    intermediates
        Ordered assignments to evaluate first: those of the program the derivatives were
        taken through that they need, each followed by its derivative intermediates.
    matrices
        The requested matrices, in the order documented by the producing function.
    """

    intermediates: tuple[Assignment, ...]
    matrices: tuple[sp.ImmutableMatrix, ...]

    @property
    def joined(self) -> sp.ImmutableMatrix:
        """The matrices side by side (they share their rows)."""
        if len(self.matrices) == 1:
            return self.matrices[0]
        return sp.ImmutableMatrix.hstack(*self.matrices)


def _split(inter: Sequence[Assignment], J: sp.ImmutableMatrix,
           widths: Sequence[int]) -> Derivatives:
    """``J`` cut into column blocks of ``widths``."""
    parts, start = [], 0
    for w in widths:
        parts.append(sp.ImmutableMatrix(J[:, start:start + w]) if J.rows else
                     sp.ImmutableMatrix.zeros(0, w))
        start += w
    return Derivatives(tuple(inter), tuple(parts))


def _program(program: Program | None, assignments: Sequence[Assignment],
             values: Sequence[Any]) -> Program:
    if program is not None:
        return program
    return Program(tuple((s, as_expr(e)) for s, e in assignments),
                   tuple(as_expr(e) for e in values))


def _times(m: Sequence[sp.Expr], a: Sequence[sp.Symbol]) -> tuple[sp.Expr, ...]:
    """``M a`` for the n·n entries ``m`` of ``M`` (row-major); the entries that are zero by
    construction are skipped (the mass matrix of an EMBS is mostly zero: its elastic rows
    are handled numerically)."""
    n = len(a)
    zero = sp.S.Zero
    return tuple(add(*(mul(m[i * n + j], a[j]) for j in range(n) if m[i * n + j] is not zero))
                 for i in range(n))


def _through(program: Program, wrt: Sequence[sp.Symbol], widths: Sequence[int]
             ) -> Derivatives:
    inter, J = jacobian(program.values, wrt, program.assignments, prefix=PREFIX)
    return _split(inter, J, widths)


def force_jacobians(equations: Any, program: Program | None = None) -> Derivatives:
    """``∂(q−k)/∂y`` (n×n), ``∂(q−k)/∂ẏ`` (n×n), ``∂(q−k)/∂u`` (n×nu), in this order.

    Linearization (equations.md §1): ``P = −∂(q−k)/∂ẏ``, ``Q = −∂(q−k)/∂y (+ ∂(M ÿ0)/∂y)``,
    ``B = ∂(q−k)/∂u``.

    Parameters
    ----------
    equations
        An :class:`~neweul_py.equations.Equations` (its symbol groups; its intermediates and
        force vector unless ``program`` is given).
    program
        The force vector ``q − k`` as the values of another program (e.g. CSE'd).
    """
    y, yd, u = (tuple(equations.coordinates), tuple(equations.velocities),
                tuple(equations.inputs))
    program = _program(program, equations.intermediates, list(equations.force_vector))
    return _through(program, (*y, *yd, *u), (len(y), len(yd), len(u)))


def mass_matrix_times_derivative(equations: Any, a: Sequence[sp.Symbol],
                                 program: Program | None = None) -> Derivatives:
    """``∂(M(y) a)/∂y`` (n×n) for a vector of symbols ``a`` (the ``∂M/∂y · ÿ0`` term of
    equations.md §1).

    Parameters
    ----------
    equations
        An :class:`~neweul_py.equations.Equations`.
    a
        n symbols that appear nowhere else.
    program
        The entries of ``M`` (n·n, row-major) as the values of another program.
    """
    n = len(equations.coordinates)
    if len(a) != n:
        raise ValueError(f"a must have {n} entries, got {len(a)}")
    program = _program(program, equations.intermediates, equations.mass_matrix.flat())
    ma = _times(program.values, a)
    return _through(Program(program.assignments, ma), tuple(equations.coordinates), (n,))


def output_jacobians(equations: Any, program: Program | None = None) -> Derivatives:
    """``∂out/∂x`` (ny × 2n, ``x = [y, ẏ]``) and ``∂out/∂u`` (ny × nu), in this order.

    Parameters
    ----------
    equations
        An :class:`~neweul_py.equations.Equations`.
    program
        The outputs as the values of another program.
    """
    y, yd, u = (tuple(equations.coordinates), tuple(equations.velocities),
                tuple(equations.inputs))
    program = _program(program, equations.intermediates, list(equations.outputs))
    return _through(program, (*y, *yd, *u), (len(y) + len(yd), len(u)))


def force_parameter_jacobian(equations: Any, program: Program | None = None) -> Derivatives:
    """``∂(q−k)/∂p`` (n × np) at fixed ``y``, ``ẏ``, ``u`` (``program``: as in
    :func:`force_jacobians`)."""
    p = tuple(equations.parameters)
    program = _program(program, equations.intermediates, list(equations.force_vector))
    return _through(program, p, (len(p),))


def mass_matrix_parameter_derivative(equations: Any, a: Sequence[sp.Symbol],
                                     program: Program | None = None) -> Derivatives:
    """``∂(M(y) a)/∂p`` (n × np) for a vector of symbols ``a`` (``program``: as in
    :func:`mass_matrix_times_derivative`)."""
    n, p = len(equations.coordinates), tuple(equations.parameters)
    if len(a) != n:
        raise ValueError(f"a must have {n} entries, got {len(a)}")
    program = _program(program, equations.intermediates, equations.mass_matrix.flat())
    ma = _times(program.values, a)
    return _through(Program(program.assignments, ma), p, (len(p),))


def output_parameter_jacobian(equations: Any, program: Program | None = None) -> Derivatives:
    """``∂out/∂p`` (ny × np) at fixed state and inputs (``program``: as in
    :func:`output_jacobians`)."""
    p = tuple(equations.parameters)
    program = _program(program, equations.intermediates, list(equations.outputs))
    return _through(program, p, (len(p),))


def input_parameter_jacobian(equations: Any) -> Derivatives:
    """``∂u₀/∂p`` (nu × np) of the default excitation ``u₀(t, p)`` (``System.input_defaults``:
    the inputs and the time derivatives that kinematic excitation adds)."""
    p = tuple(equations.parameters)
    values = tuple(as_expr(e) for e in equations.system.input_defaults)
    return _through(Program((), values), p, (len(p),))


@dataclass(frozen=True)
class Direction:
    """The rates ``(δy, δẏ, δp, δu)`` of a directional derivative, as symbols.

    Attributes
    ----------
    dy, dyd, dp, du
        One symbol per coordinate, velocity, parameter and input (``_ncg_dy0`` …): the
        arguments of the generated directional functions.
    """

    dy: tuple[sp.Symbol, ...]
    dyd: tuple[sp.Symbol, ...]
    dp: tuple[sp.Symbol, ...]
    du: tuple[sp.Symbol, ...]

    @classmethod
    def of(cls, equations: Any) -> Direction:
        """The direction symbols of ``equations``' symbol groups."""
        def group(name: str, size: int) -> tuple[sp.Symbol, ...]:
            return tuple(sp.Symbol(f"_ncg_{name}{i}", real=True) for i in range(size))

        return cls(group("dy", len(equations.coordinates)),
                   group("dyd", len(equations.velocities)),
                   group("dp", len(equations.parameters)), group("du", len(equations.inputs)))

    def rates(self, equations: Any) -> Mapping[sp.Symbol, sp.Symbol]:
        """Base symbol → its rate."""
        pairs = [(equations.coordinates, self.dy), (equations.velocities, self.dyd),
                 (equations.parameters, self.dp), (equations.inputs, self.du)]
        return {s: d for group, rates in pairs for s, d in zip(group, rates, strict=True)}


def directional(equations: Any, direction: Direction, program: Program,
                shape: tuple[int, int] | None = None) -> Derivatives:
    """``d/dε`` of the values of ``program`` along ``direction`` (equations.md §1 with the
    parameter derivatives of docs/sensitivity.md): the second derivatives of the linearized
    matrices when ``program`` holds a first derivative (:func:`force_jacobians`,
    :func:`mass_matrix_times_derivative`, :func:`output_jacobians` as
    :attr:`Derivatives.intermediates` and :attr:`Derivatives.joined`), or ``dM`` when it holds
    ``M``.

    Parameters
    ----------
    equations
        An :class:`~neweul_py.equations.Equations` (its symbol groups).
    direction
        The rates, :meth:`Direction.of`.
    program
        The values to differentiate and their assignments (whose names must not begin with
        :data:`SECOND_PREFIX`).
    shape
        The shape of the one matrix returned (default: a column).

    Returns
    -------
    Derivatives
        One matrix: the directional derivative of the values, reshaped row-major.
    """
    inter, d = directional_derivative(program.values, direction.rates(equations),
                                      program.assignments, prefix=SECOND_PREFIX)
    rows, cols = shape or (len(program.values), 1)
    return Derivatives(tuple(inter), (sp.ImmutableMatrix(rows, cols, list(d)),))
