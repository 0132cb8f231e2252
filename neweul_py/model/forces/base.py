"""The base class of force elements and their schema: the description keys each one reads.

A force element is one frozen dataclass that says, in one place (sympy's ``ActuatorBase`` is
the model):

- its description ``type`` (:attr:`ForceElement.type_name`) and its keys
  (:attr:`ForceElement.keys`, one :class:`Key` each: what the value is, the names its
  expressions may use, the fields it fills, whether it is required). The description layer
  parses a ``forces.NAME`` mapping by this table; :class:`~neweul_py.model.System` checks the
  frames, coordinates and expression names of every element by it;
- what it reports (:attr:`ForceElement.components`, outputs ``{force: NAME, component: …}``);
- its loads, :meth:`ForceElement.loads`: given the kinematics (the protocol
  :class:`~neweul_py.model.forces.loads.KinematicsView`), its terms of the generalized forces
  ``q`` (docs/equations.md §1), the quantities it reports and its entries of the hysteretic
  matrix;
- its potential energy, :meth:`ForceElement.potential`, where it has one.

An absent optional key leaves the dataclass field at its default, so the field defaults are
the description's defaults.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar, Literal

import sympy as sp

if TYPE_CHECKING:
    from .loads import KinematicsView, Loads

__all__ = [
    "ENABLED",
    "LOSS_FACTOR",
    "ForceElement",
    "Key",
    "ValueKind",
]

_ONE = sp.Integer(1)

#: What the value of a key is:
#:
#: * ``frame``: a frame name; ``frames``: two frame names ``[A, B]`` (``between``)
#: * ``coordinate``: a coordinate name; ``axis``: ``x``, ``y`` or ``z``
#: * ``expression``: one expression; ``vector``: three; ``points``: two vectors of three
#: * ``matrix``: a 3×3 matrix: a 3×3 list, ``{diag: [a, b, c]}`` or one value (``value·I``)
#: * ``characteristic``: an expression of ``s`` and ``sd`` or a table
#:   ``{table: [[v, F], …], interpolation: linear|spline}`` (a curve over its ``variable``):
#:   fills the coefficient field and the curve field
#: * ``loss_factor``: a loss factor η ≥ 0 of parameters (docs/equations.md §1.1)
ValueKind = Literal["frame", "frames", "coordinate", "axis", "expression", "vector", "points",
                    "matrix", "characteristic", "loss_factor"]
#: The names an expression may use: ``constant`` parameters; ``kinematic`` also coordinates,
#: inputs and ``t``; ``dynamic`` also velocities and input rates (docs/description-format.md).
Scope = Literal["constant", "kinematic", "dynamic"]


@dataclass(frozen=True)
class Key:
    """One key of a force element's description mapping.

    Parameters
    ----------
    name
        The key (``between``, ``stiffness``).
    kind
        What its value is (:data:`ValueKind`).
    attrs
        The dataclass fields it fills, in order: one, or two for ``frames`` and ``points``
        (``frame_a, frame_b``), and for a ``characteristic`` (coefficient, curve).
        Default: the field named like the key.
    scope
        The names its expressions may use (:data:`Scope`); ``None`` for names.
    required
        Whether the description must give it.
    variable
        The argument of a ``characteristic`` table: ``s`` or ``sd``.
    """

    name: str
    kind: ValueKind
    attrs: tuple[str, ...] = ()
    scope: Scope | None = None
    required: bool = False
    variable: Literal["s", "sd"] | None = None

    def __post_init__(self) -> None:
        if not self.attrs:
            object.__setattr__(self, "attrs", (self.name,))

    def entries(self, element: object) -> list[tuple[str, object]]:
        """``(key path below the element, value)`` of every field the key fills: ``between[0]``,
        ``between[1]`` for pairs; the coefficient and the curve of a characteristic both under
        the key's own name."""
        values = [getattr(element, a) for a in self.attrs]
        if self.kind in ("frames", "points"):
            return [(f"{self.name}[{i}]", v) for i, v in enumerate(values)]
        return [(self.name, v) for v in values]


#: Every element's on/off factor (parameters only; default 1).
ENABLED = Key("enabled", "expression", scope="constant")
#: The loss factor of elements with a stiffness (parameters only; default 0).
LOSS_FACTOR = Key("loss_factor", "loss_factor", scope="constant")


class ForceElement:
    """Base class of all force elements (each subclass is a frozen dataclass).

    Every element has an ``enabled`` factor (an expression of parameters, default 1) that
    multiplies everything it exerts: a parameter set to 0 switches the element off.

    Subclasses set the class attributes :attr:`type_name`, :attr:`keys` and
    :attr:`components` and implement :meth:`loads` (module docstring).
    """

    #: The description ``type`` of the element.
    type_name: ClassVar[str]
    #: Its description keys (without ``type``, ``enabled`` and ``report``), in order.
    keys: ClassVar[tuple[Key, ...]]
    #: The components it reports (:class:`~neweul_py.model.ForceOutput`).
    components: ClassVar[tuple[str, ...]]

    name: str
    enabled: sp.Expr = _ONE

    @property
    def path(self) -> str:
        """Its key path in a description, ``forces.NAME``."""
        return f"forces.{self.name}"

    @classmethod
    def schema(cls) -> tuple[Key, ...]:
        """All keys the element reads: its own, then ``enabled``."""
        return (*cls.keys, ENABLED)

    def expressions(self) -> Iterator[tuple[str, sp.Basic, Key]]:
        """``(key path, expression, key)`` of every expression the element holds (curves
        included), in the order of its keys."""
        for key in self.schema():
            if key.scope is None:
                continue
            for where, value in self.entries(key):
                if isinstance(value, sp.Basic):
                    yield where, value, key

    def entries(self, key: Key) -> list[tuple[str, object]]:
        """:meth:`Key.entries` with the full key paths (``forces.NAME.between[0]``)."""
        return [(f"{self.path}.{where}", v) for where, v in key.entries(self)]

    def check(self, at_defaults: Callable[[sp.Basic], object]) -> None:
        """Checks beyond the schema, given the value of an expression at the parameter
        defaults (a float, or ``None`` when it is not constant); raise
        :class:`~neweul_py.errors.ModelError`. None by default."""

    def nonnegative(self) -> tuple[sp.Expr, ...]:
        """The expressions that :meth:`check` refuses to be negative at the defaults (a rest
        length): a parameter that is one of them by itself admits no negative value either
        (:attr:`~neweul_py.model.System.parameter_ranges`). None by default."""
        return ()

    def loads(self, kin: KinematicsView, omega_ref: sp.Expr | float) -> Loads:
        """What the element exerts, before its ``enabled`` factor
        (:class:`~neweul_py.model.forces.loads.Loads`).

        Parameters
        ----------
        kin
            The kinematics of the model (:class:`~neweul_py.model.forces.loads.KinematicsView`).
        omega_ref
            ``ω_ref = 2π f_ref`` of the loss factors (docs/equations.md §1.1).
        """
        raise NotImplementedError(f"{type(self).__name__} has no loads")

    def potential(self, kin: KinematicsView) -> sp.Expr | None:
        """Its potential energy before the ``enabled`` factor, or ``None`` where it has none
        (that is formed)."""
        return None
