"""Applied loads: a force at a point, a torque on a frame, a generalized force on a coordinate."""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from ..symbols import INERTIAL
from .base import ForceElement, Key
from .loads import KinematicsView, Loads

__all__ = ["GeneralizedForce", "PointForce", "Torque"]

_ONE = sp.Integer(1)


def _zero3() -> sp.ImmutableMatrix:
    return sp.ImmutableMatrix.zeros(3, 1)


@dataclass(frozen=True)
class PointForce(ForceElement):
    """A force ``vector`` (components of frame ``in_frame``) acting at ``point`` of ``frame``:
    ``q += J_Pᵀ f`` with ``f`` and ``J_P`` in the components of ``frame`` (equations.md §1).
    Reports the vector (``fx fy fz``, ``in_frame`` components)."""

    type_name = "force"
    keys = (
        Key("frame", "frame", required=True),
        Key("point", "vector", scope="kinematic"),
        Key("vector", "vector", scope="dynamic", required=True),
        Key("in", "frame", ("in_frame",)),
    )
    components = ("fx", "fy", "fz")

    name: str
    frame: str
    vector: sp.ImmutableMatrix
    point: sp.ImmutableMatrix = field(default_factory=_zero3)
    in_frame: str = INERTIAL
    enabled: sp.Expr = _ONE

    def loads(self, kin: KinematicsView, omega_ref: sp.Expr | float) -> Loads:
        out = Loads.empty(kin.n)
        f_k = kin.express(tuple(self.vector), self.in_frame, self.frame)
        out.force_at(kin.point(self.frame, tuple(self.point), f"{self.path}.point"), f_k)
        out.reported = dict(zip(self.components, tuple(self.vector), strict=True))
        return out


@dataclass(frozen=True)
class Torque(ForceElement):
    """A torque ``vector`` (components of frame ``in_frame``) acting on ``frame``:
    ``q += J_Rᵀ l`` (``frame`` components). Reports the vector (``mx my mz``)."""

    type_name = "torque"
    keys = (
        Key("frame", "frame", required=True),
        Key("vector", "vector", scope="dynamic", required=True),
        Key("in", "frame", ("in_frame",)),
    )
    components = ("mx", "my", "mz")

    name: str
    frame: str
    vector: sp.ImmutableMatrix
    in_frame: str = INERTIAL
    enabled: sp.Expr = _ONE

    def loads(self, kin: KinematicsView, omega_ref: sp.Expr | float) -> Loads:
        out = Loads.empty(kin.n)
        out.torque_on(kin.frames[self.frame],
                      kin.express(tuple(self.vector), self.in_frame, self.frame))
        out.reported = dict(zip(self.components, tuple(self.vector), strict=True))
        return out


@dataclass(frozen=True)
class GeneralizedForce(ForceElement):
    """A generalized force ``value`` acting directly on ``coordinate`` (adds to ``q``).
    Reports its value (``force``)."""

    type_name = "generalized"
    keys = (
        Key("coordinate", "coordinate", required=True),
        Key("value", "expression", scope="dynamic", required=True),
    )
    components = ("force",)

    name: str
    coordinate: str
    value: sp.Expr
    enabled: sp.Expr = _ONE

    def loads(self, kin: KinematicsView, omega_ref: sp.Expr | float) -> Loads:
        out = Loads.empty(kin.n)
        out.generalized[kin.coordinate_index(self.coordinate)].append(self.value)
        out.reported = {"force": self.value}
        return out
