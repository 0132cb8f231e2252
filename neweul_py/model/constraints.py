"""Holonomic constraints ``g(y, t) = 0`` that close kinematic loops (equations.md §1)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import sympy as sp

from ..errors import ModelError
from .elements import AXES
from .symbols import INERTIAL

__all__ = ["CoincidenceConstraint", "Constraint", "ExpressionConstraint"]

Axis = Literal["x", "y", "z"]


def _zero3() -> sp.ImmutableMatrix:
    return sp.ImmutableMatrix.zeros(3, 1)


class Constraint:
    """Marker base class of holonomic constraints."""

    name: str

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the scalar constraints this item stands for (in ``CONSTRAINTS``)."""
        return (self.name,)


@dataclass(frozen=True)
class ExpressionConstraint(Constraint):
    """``expr(y, t, u, p) = 0``."""

    name: str
    expr: sp.Expr


@dataclass(frozen=True)
class CoincidenceConstraint(Constraint):
    """``point_b`` of ``frame_b`` coincides with ``point_a`` of ``frame_a`` in the listed
    ``components`` of frame ``in_frame``: ``(r_B − r_A)·e_c = 0``, one scalar constraint per
    component, named ``<name>_<component>``."""

    name: str
    frame_a: str
    frame_b: str
    point_a: sp.ImmutableMatrix = field(default_factory=_zero3)
    point_b: sp.ImmutableMatrix = field(default_factory=_zero3)
    components: tuple[Axis, ...] = ("x", "y", "z")
    in_frame: str = INERTIAL

    def __post_init__(self) -> None:
        path = f"constraints.{self.name}.components"
        if not self.components:
            raise ModelError("at least one component is needed", path)
        for i, c in enumerate(self.components):
            if c not in AXES:
                raise ModelError(f"component must be one of x, y, z, not {c!r}", f"{path}[{i}]")
        if len(set(self.components)) != len(self.components):
            raise ModelError("components repeat", path)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(f"{self.name}_{c}" for c in self.components)
