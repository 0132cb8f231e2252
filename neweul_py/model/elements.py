"""Plain, immutable model objects: what the mechanism *is*, no derivation.

Every object is a frozen dataclass holding sympy expressions (``sympy.ImmutableMatrix`` for
vectors and tensors). Objects check their own local consistency on construction; the checks
that need the whole model (known names, frame tree) are done by :class:`~neweul_py.model.System`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import sympy as sp

from ..errors import ModelError
from .symbols import INERTIAL, symbol, velocity_name

__all__ = [
    "AXES",
    "Coordinate",
    "ExpressionOutput",
    "ForceOutput",
    "Frame",
    "Input",
    "KinematicOutput",
    "Output",
    "Parameter",
    "RigidBody",
    "range_text",
    "vector3",
]

AXES = ("x", "y", "z")
_ZERO = sp.Integer(0)  # immutable: safe as a dataclass default
Axis = Literal["x", "y", "z"]


def vector3(value: object, key_path: str) -> sp.ImmutableMatrix:
    """Return ``value`` as an immutable 3×1 sympy column, or raise :class:`ModelError`."""
    try:
        mat = sp.ImmutableMatrix(value)
    except Exception as exc:
        raise ModelError(f"expected a vector of 3 expressions ({exc})", key_path) from None
    if mat.shape == (1, 3):
        mat = mat.T
    if mat.shape != (3, 1):
        raise ModelError(f"expected a vector of 3 expressions, got shape {mat.shape}", key_path)
    return mat


def _zero3() -> sp.ImmutableMatrix:
    return sp.ImmutableMatrix.zeros(3, 1)


@dataclass(frozen=True)
class Parameter:
    """A named constant with a default value; generated code takes it in the vector ``p``.

    ``minimum`` and ``maximum`` (inclusive, ``None``: unbounded) are the values the model
    admits — a length ``minimum=0`` — that every command checks a new value against
    (``PARAMETER_RANGES`` of the generated module, docs/description-format.md).
    """

    name: str
    default: float
    minimum: float | None = None
    maximum: float | None = None

    def __post_init__(self) -> None:
        path = f"parameters.{self.name}"
        for what in ("minimum", "maximum"):
            v = getattr(self, what)
            if v is not None and (isinstance(v, bool) or not isinstance(v, int | float)
                                  or not math.isfinite(v)):
                raise ModelError(f"the {what} must be a finite number, got {v!r}", path)
        lo, hi = self.minimum, self.maximum
        if lo is not None and hi is not None and lo > hi:
            raise ModelError(f"the minimum {lo:g} is above its maximum {hi:g}", path)
        d = self.default
        if isinstance(d, int | float) and not isinstance(d, bool) and (
                (lo is not None and d < lo) or (hi is not None and d > hi)):
            raise ModelError(f"the default {d:g} is outside its range {range_text(lo, hi)}",
                             path)

    @property
    def symbol(self) -> sp.Symbol:
        return symbol(self.name)


def range_text(lo: float | None, hi: float | None) -> str:
    """``2 … 3``, ``≥ 0``, ``≤ 1`` (inclusive bounds)."""
    if lo is not None and hi is not None:
        return f"{lo:g} … {hi:g}"
    return f"≥ {lo:g}" if lo is not None else f"≤ {hi:g}"


@dataclass(frozen=True)
class Coordinate:
    """A generalized coordinate ``y_i`` with its initial value and initial velocity."""

    name: str
    initial: float = 0.0
    velocity: float = 0.0

    @property
    def symbol(self) -> sp.Symbol:
        """The coordinate itself, ``y_i``."""
        return symbol(self.name)

    @property
    def velocity_symbol(self) -> sp.Symbol:
        """Its time derivative ``ẏ_i``, named ``d_<name>``."""
        return symbol(velocity_name(self.name))


@dataclass(frozen=True)
class Input:
    """An input ``u_i`` with its default excitation, an expression of ``t`` and parameters."""

    name: str
    default: sp.Expr = _ZERO

    @property
    def symbol(self) -> sp.Symbol:
        return symbol(self.name)


@dataclass(frozen=True)
class Frame:
    """A coordinate frame placed relative to its parent.

    The origin is ``translation`` (parent components); the rotation matrix (child components →
    parent components) is ``R_a1(φ1) · R_a2(φ2) · …`` for ``rotation = ((a1, φ1), (a2, φ2), …)``,
    each elementary rotation about the *current* axis.
    """

    name: str
    parent: str = INERTIAL
    translation: sp.ImmutableMatrix = field(default_factory=_zero3)
    rotation: tuple[tuple[Axis, sp.Expr], ...] = ()

    def __post_init__(self) -> None:
        for i, (axis, _angle) in enumerate(self.rotation):
            if axis not in AXES:
                raise ModelError(
                    f"rotation axis must be one of x, y, z, not {axis!r}",
                    f"frames.{self.name}.rotation[{i}][0]",
                )


@dataclass(frozen=True)
class RigidBody:
    """A rigid body fixed to a frame.

    ``center_of_mass`` is given in the frame's components, ``inertia`` is the inertia tensor
    about the center of mass in the frame's components.
    """

    name: str
    frame: str
    mass: sp.Expr
    center_of_mass: sp.ImmutableMatrix = field(default_factory=_zero3)
    inertia: sp.ImmutableMatrix = field(default_factory=lambda: sp.ImmutableMatrix.zeros(3, 3))

    def __post_init__(self) -> None:
        if self.inertia.shape != (3, 3):
            raise ModelError(
                f"inertia must be 3×3, got shape {self.inertia.shape}",
                f"bodies.{self.name}.inertia",
            )
        for i in range(3):
            for j in range(i + 1, 3):
                # entry by entry: equal entries need no algebra (the usual case), and the
                # matrix difference ``(I − Iᵀ).applyfunc(expand)`` was most of loading a chain
                a, b = self.inertia[i, j], self.inertia[j, i]
                if a != b and sp.expand(a - b) != 0:
                    raise ModelError(
                        f"inertia must be symmetric: [{i}][{j}] = {self.inertia[i, j]} but "
                        f"[{j}][{i}] = {self.inertia[j, i]}",
                        f"bodies.{self.name}.inertia[{i}][{j}]",
                    )


class Output:
    """Marker base class of outputs."""

    name: str


@dataclass(frozen=True)
class ExpressionOutput(Output):
    """An output given as an expression of coordinates, velocities, inputs, parameters, t."""

    name: str
    expr: sp.Expr


@dataclass(frozen=True)
class KinematicOutput(Output):
    """The position or velocity of ``point`` of ``frame`` (absolute, relative to ISYS),
    resolved in ``in_frame``, one ``component``."""

    name: str
    quantity: Literal["position", "velocity"]
    frame: str
    component: Axis
    point: sp.ImmutableMatrix = field(default_factory=_zero3)
    in_frame: str = INERTIAL

    def __post_init__(self) -> None:
        if self.quantity not in ("position", "velocity"):
            raise ModelError(
                f"quantity must be 'position' or 'velocity', not {self.quantity!r}",
                f"outputs.{self.name}",
            )
        if self.component not in AXES:
            raise ModelError(
                f"component must be one of x, y, z, not {self.component!r}",
                f"outputs.{self.name}.component",
            )


@dataclass(frozen=True)
class ForceOutput(Output):
    """An output reporting what force element ``force`` exerts (times its ``enabled`` factor).

    ``component``: one of the element's :attr:`~neweul_py.model.ForceElement.components` —
    ``force`` for scalar elements (a spring–damper's tensile force, a rotational
    spring–damper's torque ``F(s, sd)``, a generalized force's value); ``fx fy fz`` /
    ``mx my mz`` for vector elements: a ``force``/``torque`` element's vector in its ``in``
    frame, a bushing's force and torque on its second frame in the first frame's components.
    """

    name: str
    force: str
    component: str = "force"
