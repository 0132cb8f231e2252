"""The result of the derivation: :class:`Equations` (``M ÿ = q − k`` plus outputs).

This is the interface between ``equations/`` and ``codegen/``; see equations.md §1 and
docs/generated-module-protocol.md.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import sympy as sp

from ..model import System
from .constraints import ConstraintEquations
from .display import equations_latex, equations_summary
from .poses import FramePoses

__all__ = ["Equations"]


@dataclass(frozen=True, repr=False)
class Equations:
    """Symbolic equations of motion ``M(y, t) ÿ = q(y, ẏ, u, t) − k(y, ẏ, t)`` (equations.md §1).

    The expressions use only ``coordinates``, ``velocities``, ``parameters``, ``inputs``, the
    time symbol ``t`` (:data:`neweul_py.model.time`) and the symbols assigned in
    ``intermediates``.

    Attributes
    ----------
    system
        The model the equations were derived from.
    coordinates
        ``y``, in the order of ``system.coordinates``.
    velocities
        ``ẏ``, the symbols ``d_<name>``, same order.
    parameters
        ``p``, in the order of ``system.parameters`` (the order of the vector ``p``).
    inputs
        ``u``, in the order of ``system.inputs``.
    intermediates
        Ordered assignments ``(symbol, expression)``; each expression may use the symbols
        above and the symbols of *earlier* assignments only. Empty in closed form; in
        recursive form it holds the absolute kinematics and per-body contributions. Code
        must evaluate them in order before ``mass_matrix``, ``force_vector``, ``outputs``.
        Intermediates that depend only on ``y``, ``p``, ``t`` can be told apart from those
        that need ``ẏ`` or ``u`` by :meth:`dependencies`.
    mass_matrix
        ``M`` (n×n, symmetric), may reference intermediates.
    force_vector
        ``q − k`` (n×1), may reference intermediates.
    outputs
        The outputs (ny×1), expression and kinematic outputs of ``system.outputs``, in order.
    output_names
        Their names.
    constraints
        The holonomic constraints ``g``, ``G``, ``∂g/∂t``, ``γ`` (closed form, no
        intermediates; :mod:`~neweul_py.equations.constraints`); ``None`` means none.
    energy
        ``[kinetic, gravity, springs]`` energy of the rigid bodies and force elements (3×1;
        :mod:`~neweul_py.equations.energy`); ``None``: not derived.
    elastic
        The splice of the elastic bodies (:class:`~neweul_py.equations.elastic.ElasticEquations`),
        ``None`` without elastic bodies.
    poses
        The absolute poses of the frames (:class:`~neweul_py.equations.poses.FramePoses`,
        for animations); ``None``: not derived.
    mass_factors
        The same mass matrix as weighted rank-one terms ``M = Σ_r w_r g_r g_rᵀ``, rows
        ``(w_r, g_r)`` (recursive form; ``None`` in closed form): code generators may evaluate
        ``M = Gᵀ diag(w) G`` numerically.
    loss_matrix
        The hysteretic matrix ``G`` (n×n, may reference intermediates) of the force elements'
        loss factors, ``K + iG`` in the frequency domain (equations.md §1.1); ``None``: no
        element has a loss factor. The time-domain equivalent ``G/ω_ref`` is already in
        ``force_vector``; the elastic bodies' ``Le`` is added by the splice.
    """

    system: System
    coordinates: tuple[sp.Symbol, ...]
    velocities: tuple[sp.Symbol, ...]
    parameters: tuple[sp.Symbol, ...]
    inputs: tuple[sp.Symbol, ...]
    intermediates: tuple[tuple[sp.Symbol, sp.Expr], ...]
    mass_matrix: sp.ImmutableMatrix
    force_vector: sp.ImmutableMatrix
    outputs: sp.ImmutableMatrix
    output_names: tuple[str, ...]
    constraints: ConstraintEquations | None = None
    energy: sp.ImmutableMatrix | None = None
    elastic: Any = None
    poses: FramePoses | None = None
    mass_factors: tuple[tuple[sp.Expr, tuple[sp.Expr, ...]], ...] | None = None
    loss_matrix: sp.ImmutableMatrix | None = None

    @property
    def n(self) -> int:
        """Number of generalized coordinates."""
        return len(self.coordinates)

    def __repr__(self) -> str:
        return f"<Equations of {equations_summary(self)}>"

    def _repr_latex_(self) -> str:
        """``M``, ``q − k`` and the intermediates they use, for notebooks
        (:func:`~neweul_py.equations.display.equations_latex`)."""
        return equations_latex(self)

    @property
    def is_closed_form(self) -> bool:
        """True when there are no intermediates (everything fully substituted)."""
        return not self.intermediates

    def dependencies(self) -> dict[sp.Symbol, frozenset[sp.Symbol]]:
        """For each intermediate, the set of *base* symbols (y, ẏ, p, u, t) it depends on,
        transitively through earlier intermediates.

        Codegen can use it to evaluate in ``mass_matrix(t, y, p)`` only the intermediates
        that do not need ``ẏ`` or ``u``.
        """
        deps: dict[sp.Symbol, frozenset[sp.Symbol]] = {}
        for sym, expr in self.intermediates:
            base: set[sp.Symbol] = set()
            for s in expr.free_symbols:
                if s in deps:
                    base |= deps[s]
                else:
                    base.add(s)
            deps[sym] = frozenset(base)
        return deps

    def substituted(self) -> Equations:
        """The same equations with all intermediates substituted (no simplification).

        Expressions can grow large for long chains; meant for tests and small models.
        """
        if not self.intermediates:
            return self
        values: dict[sp.Symbol, sp.Expr] = {}
        for sym, expr in self.intermediates:
            values[sym] = expr.xreplace(values)

        def sub(m: sp.ImmutableMatrix) -> sp.ImmutableMatrix:
            return sp.ImmutableMatrix(m.shape[0], m.shape[1], [e.xreplace(values) for e in m])

        return replace(
            self,
            intermediates=(),
            mass_matrix=sub(self.mass_matrix),
            force_vector=sub(self.force_vector),
            outputs=sub(self.outputs),
            energy=None if self.energy is None else sub(self.energy),
            loss_matrix=None if self.loss_matrix is None else sub(self.loss_matrix),
            poses=None if self.poses is None else self.poses.substituted(values),
            mass_factors=None,
        )
