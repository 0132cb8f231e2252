"""A small Python API that builds a validated :class:`~neweul_py.model.System`.

The description loader uses it, and scripts can use it directly::

    b = SystemBuilder("pendulum")
    b.parameter("m", 1.0)
    b.parameter("l", 0.5)
    b.parameter("g", 9.81)
    b.coordinate("phi", initial=0.1)
    b.gravity([0, 0, "-g"])
    b.frame("arm", rotation=[["y", "phi"]])
    b.body("bob", frame="arm", mass="m", center_of_mass=[0, 0, "-l"])
    system = b.build()

Every value may be a number, an expression string of the description language or a sympy
expression. Strings are parsed in :meth:`SystemBuilder.build`, when every name is known, so
items may be declared in any order. Each value is parsed with the names allowed in its place:

============================================  ==========================================
place                                         allowed names
============================================  ==========================================
masses, centers of mass, inertias, gravity    parameters
input defaults                                parameters, ``t``
frame translations/rotations, points          parameters, coordinates, inputs, ``t``
force vectors, force laws, expression outputs all of the above and velocities ``d_<coord>``
============================================  ==========================================

Every error is a :class:`~neweul_py.errors.ModelError` carrying the key path of the
description file layout (``bodies.malleus.inertia[1][2]``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import sympy as sp

from ..errors import ModelError
from ..model import (
    AXES,
    ELONGATION,
    ELONGATION_RATE,
    FORCE_COMPONENTS,
    INERTIAL,
    Bushing,
    CoincidenceConstraint,
    Constraint,
    Coordinate,
    ElasticBody,
    ExpressionConstraint,
    ExpressionOutput,
    ForceElement,
    ForceOutput,
    Frame,
    GeneralizedForce,
    Input,
    KinematicOutput,
    Output,
    Parameter,
    PointForce,
    RigidBody,
    RotationalSpringDamper,
    SpringDamper,
    System,
    Torque,
    check_name,
    input_rate_name,
    symbol,
    table_characteristic,
    time,
    velocity_name,
)
from .expressions import ExpressionError, as_expression, parse_expression

__all__ = ["SCOPES", "SystemBuilder"]

#: The scopes of expressions: which kinds of names each may use.
SCOPES: Mapping[str, tuple[str, ...]] = {
    "constant": ("parameter",),
    "excitation": ("parameter", "time"),
    "kinematic": ("parameter", "coordinate", "input", "time"),
    "dynamic": ("parameter", "coordinate", "input", "time", "velocity", "input_rate"),
}

_KIND_WORDS = {
    "parameter": "a parameter",
    "coordinate": "a coordinate",
    "velocity": "a velocity",
    "input": "an input",
    "input_rate": "a time derivative of an input",
    "time": "the time",
    "frame": "a frame",
    "body": "a body",
    "elastic_body": "an elastic body",
    "force": "a force element",
    "output": "an output",
}


# ----------------------------------------------------------------------------- values
def _is_sequence(value: object) -> bool:
    return isinstance(value, Sequence) and not isinstance(value, str | bytes)


def _type_name(value: object) -> str:
    return f"{type(value).__name__} {value!r}"


def constant_number(value: object, key_path: str, what: str = "value") -> float:
    """A finite number from an ``int``, ``float`` or a constant expression string (``"2*pi"``).

    YAML reads ``1e-3`` (without a dot) as a string, so numeric strings must be accepted.

    Raises
    ------
    ModelError
        For anything else (``bool``, NaN, inf, names, lists…), naming ``what`` and the value.
    """
    if isinstance(value, bool):
        raise ModelError(f"{what} must be a number, got {_type_name(value)}", key_path)
    if isinstance(value, int | float):
        if not math.isfinite(value):
            raise ModelError(f"{what} must be a finite number, got {value!r}", key_path)
        return float(value)
    if isinstance(value, sp.Basic) and value.is_number:
        try:
            result = float(value)
        except (TypeError, ValueError):
            raise ModelError(f"{what} must be a real number, got {value}", key_path) from None
    elif isinstance(value, str):
        try:
            expr = parse_expression(value, {})
        except ExpressionError as exc:
            raise ModelError(
                f"{what} must be a number (or a constant expression such as 2*pi), got "
                f"{value!r} ({exc.reason})",
                key_path,
            ) from None
        result = float(expr)
    else:
        raise ModelError(f"{what} must be a number, got {_type_name(value)}", key_path)
    if not math.isfinite(result):
        raise ModelError(f"{what} must be a finite number, got {value!r}", key_path)
    return result


def _check_vector(value: object, key_path: str, length: int = 3) -> None:
    """Check the shape of a vector given as a sequence or a sympy matrix."""
    if isinstance(value, sp.MatrixBase):
        if value.shape not in ((length, 1), (1, length)):
            raise ModelError(
                f"expected a vector of {length} expressions, got a matrix of shape {value.shape}",
                key_path,
            )
        return
    if not _is_sequence(value):
        raise ModelError(
            f"expected a list of {length} expressions, got {_type_name(value)}", key_path
        )
    if len(value) != length:
        raise ModelError(
            f"expected a list of {length} expressions, got {len(value)}", key_path
        )


def _check_inertia(value: object, key_path: str) -> None:
    if isinstance(value, Mapping):
        unknown = sorted(str(k) for k in value if k != "diag")
        if unknown:
            raise ModelError(
                f"unknown key {unknown[0]!r}; inertia is a 3×3 list of lists or "
                "{diag: [Ixx, Iyy, Izz]}",
                f"{key_path}.{unknown[0]}",
            )
        if "diag" not in value:
            raise ModelError("missing key 'diag'", key_path)
        _check_vector(value["diag"], f"{key_path}.diag")
        return
    if isinstance(value, sp.MatrixBase):
        if value.shape != (3, 3):
            raise ModelError(f"expected a 3×3 matrix, got shape {value.shape}", key_path)
        return
    if not _is_sequence(value) or len(value) != 3:
        raise ModelError(
            "expected a 3×3 list of lists or {diag: [Ixx, Iyy, Izz]}, got "
            + (f"{len(value)} rows" if _is_sequence(value) else _type_name(value)),
            key_path,
        )
    for i, row in enumerate(value):
        _check_vector(row, f"{key_path}[{i}]")


def _check_frame_name(value: object, key_path: str) -> str:
    if not isinstance(value, str):
        raise ModelError(f"expected a frame name, got {_type_name(value)}", key_path)
    return value


def _check_matrix33(value: object, key_path: str) -> None:
    """A bushing matrix: one value, ``{diag: [a, b, c]}`` or a 3×3 list of lists."""
    if isinstance(value, int | float | str | sp.Expr) and not isinstance(value, bool):
        return
    _check_inertia(value, key_path)


# ----------------------------------------------------------------------------- names
@dataclass(frozen=True)
class _Names:
    """All names of the model, and the parsing of values in a scope."""

    symbols: Mapping[str, sp.Symbol]  # every name that stands for a symbol
    kinds: Mapping[str, str]  # every name of the model → its kind
    #: Expression strings parsed so far, ``(text, scope) → expression`` (a description
    #: repeats the same few: ``m``, ``-l``, ``m*l**2/12`` … once per body); failures are not
    #: kept (their error names the key path).
    parsed: dict[tuple[str, str], sp.Expr] = dataclasses.field(
        default_factory=dict, compare=False, repr=False)

    def namespace(self, scope: str) -> dict[str, sp.Symbol]:
        kinds = SCOPES[scope]
        return {n: s for n, s in self.symbols.items() if self.kinds[n] in kinds}

    def expr(self, value: object, scope: str, key_path: str) -> sp.Expr:
        if isinstance(value, str):
            hit = self.parsed.get((value, scope))
            if hit is None:
                hit = self.parsed[value, scope] = self._parse(value, scope, key_path)
            return hit
        return self._parse(value, scope, key_path)

    def _parse(self, value: object, scope: str, key_path: str) -> sp.Expr:
        namespace = self.namespace(scope)
        if isinstance(value, sp.Basic) and not isinstance(value, sp.MatrixBase):
            # Symbols created by a user with other assumptions stand for the model's symbols.
            swap = {
                s: namespace[s.name]
                for s in value.free_symbols
                if isinstance(s, sp.Symbol) and s.name in namespace and s != namespace[s.name]
            }
            return value.xreplace(swap) if swap else value
        unavailable = {n: _KIND_WORDS[k] for n, k in self.kinds.items() if n not in namespace}
        return as_expression(value, namespace, key_path=key_path, unavailable=unavailable)

    def vector(self, value: object, scope: str, key_path: str) -> sp.ImmutableMatrix:
        if isinstance(value, sp.MatrixBase):
            value = list(value)
        return sp.ImmutableMatrix(
            [self.expr(v, scope, f"{key_path}[{i}]") for i, v in enumerate(value)]
        )

    def inertia(self, value: object, key_path: str) -> sp.ImmutableMatrix:
        if isinstance(value, Mapping):
            diag = list(self.vector(value["diag"], "constant", f"{key_path}.diag"))
            k = len(diag)  # = sp.diag(*diag), without the general block-diagonal builder
            return sp.ImmutableMatrix(k, k, [diag[i] if i == j else sp.S.Zero
                                             for i in range(k) for j in range(k)])
        if isinstance(value, sp.MatrixBase):
            value = value.tolist()
        return sp.ImmutableMatrix(
            [
                [self.expr(v, "constant", f"{key_path}[{i}][{j}]") for j, v in enumerate(row)]
                for i, row in enumerate(value)
            ]
        )


_Make = Callable[[_Names], Any]


def _enabled(n: _Names, enabled: object, path: str) -> sp.Expr:
    """The on/off factor of a force element (parameters only; default 1)."""
    if enabled is None:
        return sp.Integer(1)
    return n.expr(enabled, "constant", f"{path}.enabled")


def _loss_factor(n: _Names, value: object, path: str) -> sp.Expr:
    """The loss factor η of an element with a stiffness (parameters only; default 0). A
    number must be finite and ≥ 0 here; an expression is checked at the parameter defaults
    when the system is built."""
    if value is None or (isinstance(value, int | float) and not isinstance(value, bool)
                         and value == 0):
        return sp.Integer(0)
    key = f"{path}.loss_factor"
    if isinstance(value, float | int) and not isinstance(value, bool) and not (
            math.isfinite(value) and value >= 0):
        raise ModelError(f"a loss factor is a finite number ≥ 0, got {value!r}", key)
    return n.expr(value, "constant", key)


def _points(n: _Names, points: object, path: str) -> tuple[sp.ImmutableMatrix, sp.ImmutableMatrix]:
    if points is None:
        return sp.ImmutableMatrix.zeros(3, 1), sp.ImmutableMatrix.zeros(3, 1)
    pa, pb = (n.vector(p, "kinematic", f"{path}.points[{i}]")
              for i, p in enumerate(points))  # type: ignore[arg-type]
    return pa, pb


def _matrix33(n: _Names, value: object, key_path: str) -> sp.ImmutableMatrix:
    if isinstance(value, Mapping):
        diag = n.vector(value["diag"], "dynamic", f"{key_path}.diag")
        return sp.ImmutableMatrix(sp.diag(*diag))
    if isinstance(value, int | float | str | sp.Expr):
        return sp.ImmutableMatrix(sp.eye(3) * n.expr(value, "dynamic", key_path))
    if isinstance(value, sp.MatrixBase):
        value = value.tolist()
    return sp.ImmutableMatrix(
        [
            [n.expr(v, "dynamic", f"{key_path}[{i}][{j}]") for j, v in enumerate(row)]
            for i, row in enumerate(value)  # type: ignore[arg-type]
        ]
    )


_TABLE_KEYS = ("table", "interpolation")


def _characteristic(
    n: _Names, value: object, variable: sp.Symbol, key_path: str
) -> tuple[sp.Expr, sp.Expr | None]:
    """A stiffness or damping: ``(coefficient, None)`` for an expression (which may use the
    local names ``s`` and ``sd``), ``(0, curve)`` for a table ``{table:, interpolation:}``."""
    if isinstance(value, Mapping):
        unknown = [str(k) for k in value if k not in _TABLE_KEYS]
        if unknown:
            raise ModelError(
                f"unknown key {unknown[0]!r}; a characteristic table has the keys "
                f"{', '.join(_TABLE_KEYS)}",
                f"{key_path}.{unknown[0]}",
            )
        if "table" not in value:
            raise ModelError("a characteristic table needs the key 'table'", key_path)
        rows = value["table"]
        if not _is_sequence(rows):
            raise ModelError(f"expected a list of [value, force] pairs, got {_type_name(rows)}",
                             f"{key_path}.table")
        numbers = []
        for i, row in enumerate(rows):
            if not _is_sequence(row) or len(row) != 2:
                raise ModelError(f"expected a pair [value, force], got {row!r}",
                                 f"{key_path}.table[{i}]")
            numbers.append([constant_number(v, f"{key_path}.table[{i}][{j}]")
                            for j, v in enumerate(row)])
        curve = table_characteristic(
            numbers, value.get("interpolation", "linear"), variable, f"{key_path}.table"
        )
        return sp.Integer(0), curve
    if isinstance(value, sp.Basic) and not isinstance(value, sp.MatrixBase):
        return value, None
    namespace = {**n.namespace("dynamic"), "s": ELONGATION, "sd": ELONGATION_RATE}
    unavailable = {k: _KIND_WORDS[v] for k, v in n.kinds.items() if k not in namespace}
    return as_expression(value, namespace, key_path=key_path, unavailable=unavailable), None


# ----------------------------------------------------------------------------- builder
class SystemBuilder:
    """Collect the items of a multibody system and build a validated :class:`System`.

    Parameters
    ----------
    name
        Model name (a valid identifier; also the name of the generated module).
    description
        Free text.

    Notes
    -----
    Shapes, types and names are checked when an item is added; expression strings are parsed
    and the whole model is validated in :meth:`build`. All errors are
    :class:`~neweul_py.errors.ModelError` with a key path such as ``bodies.arm.inertia[1][2]``.
    """

    def __init__(self, name: str, description: str = "") -> None:
        if not isinstance(description, str):
            raise ModelError(f"expected text, got {_type_name(description)}", "description")
        self._name = name
        self._description = description
        self._kinds: dict[str, str] = {}
        self._parameters: list[Parameter] = []
        self._coordinates: list[Coordinate] = []
        self._inputs: list[_Make] = []
        self._frames: list[_Make] = []
        self._bodies: list[_Make] = []
        self._forces: list[_Make] = []
        self._outputs: list[_Make] = []
        self._constraints: list[_Make] = []
        self._constraint_names: set[str] = set()
        self._gravity: _Make | None = None
        self._loss_reference: float | None = None
        self._elastic: list[Callable[[_Names], ElasticBody]] = []

    # -------------------------------------------------------------- helpers
    def _declare(self, group: str, kind: str, name: object) -> str:
        path = f"{group}.{name}"
        why = check_name(name)
        if why is not None:
            raise ModelError(why, path)
        assert isinstance(name, str)
        if name in self._kinds:
            raise ModelError(f"name {name!r} is already used by {_KIND_WORDS[self._kinds[name]]}",
                             path)
        self._kinds[name] = kind
        return path

    # -------------------------------------------------------------- symbols
    def parameter(self, name: str, default: float | str) -> sp.Symbol:
        """Add a parameter with a numeric default; return its symbol.

        ``default`` is a number or a constant expression string (``"2*pi"``, ``"1e-3"``).
        """
        path = self._declare("parameters", "parameter", name)
        self._parameters.append(Parameter(name, constant_number(default, path, "default")))
        return symbol(name)

    def coordinate(
        self, name: str, initial: float | str = 0.0, velocity: float | str = 0.0
    ) -> sp.Symbol:
        """Add a generalized coordinate with initial value and velocity; return its symbol.

        Its velocity is the symbol ``d_<name>`` (see :meth:`velocity`).
        """
        path = self._declare("coordinates", "coordinate", name)
        self._kinds[velocity_name(name)] = "velocity"
        self._coordinates.append(
            Coordinate(
                name,
                constant_number(initial, f"{path}.initial", "initial value"),
                constant_number(velocity, f"{path}.velocity", "initial velocity"),
            )
        )
        return symbol(name)

    @staticmethod
    def velocity(coordinate: str) -> sp.Symbol:
        """The velocity symbol ``d_<coordinate>``."""
        return symbol(velocity_name(coordinate))

    def input(self, name: str, default: object = "0") -> sp.Symbol:
        """Add an input with its default excitation (an expression of ``t`` and parameters)."""
        path = self._declare("inputs", "input", name)
        for k in (1, 2):
            rate = input_rate_name(name, k)
            if rate in self._kinds:
                raise ModelError(
                    f"the input's time derivative {rate!r} is already used by "
                    f"{_KIND_WORDS[self._kinds[rate]]}",
                    path,
                )
            self._kinds[rate] = "input_rate"
        self._inputs.append(lambda n: Input(name, n.expr(default, "excitation", path)))
        return symbol(name)

    # -------------------------------------------------------------- geometry
    def loss_reference_frequency(self, value: object) -> None:
        """Set the model's ``loss_reference_frequency`` [Hz] (a positive number; default
        1000): the frequency at which the time-domain equivalent of the loss factors is exact
        (docs/equations.md §1.1)."""
        key = "loss_reference_frequency"
        f = constant_number(value, key)
        if not (math.isfinite(f) and f > 0):
            raise ModelError(f"must be a positive frequency in Hz, got {value!r}", key)
        self._loss_reference = float(f)

    def gravity(self, vector: object) -> None:
        """Set the gravitational acceleration (ISYS components, parameters allowed)."""
        _check_vector(vector, "gravity")
        self._gravity = lambda n: n.vector(vector, "constant", "gravity")

    def frame(
        self,
        name: str,
        parent: str = INERTIAL,
        translation: object = None,
        rotation: object = None,
    ) -> None:
        """Add a frame.

        Parameters
        ----------
        name
            Frame name.
        parent
            Parent frame (``"ISYS"`` or another frame, declared before or after).
        translation
            Origin in parent components, 3 expressions (default zero).
        rotation
            List of ``[axis, angle]`` pairs, axis ``x``, ``y`` or ``z``, applied one after
            another about the current axes: ``[["x", a], ["y", b]]`` is ``R_x(a)·R_y(b)``
            (child components → parent components).
        """
        path = self._declare("frames", "frame", name)
        _check_frame_name(parent, f"{path}.parent")
        if translation is not None:
            _check_vector(translation, f"{path}.translation")
        rotation = [] if rotation is None else rotation
        if not _is_sequence(rotation):
            raise ModelError(
                f"expected a list of [axis, angle] pairs, got {_type_name(rotation)}",
                f"{path}.rotation",
            )
        for i, pair in enumerate(rotation):
            item = f"{path}.rotation[{i}]"
            if not _is_sequence(pair) or len(pair) != 2:
                hint = (
                    "; a single rotation is written [[axis, angle]]"
                    if isinstance(pair, str) and pair in AXES
                    else ""
                )
                raise ModelError(f"expected a pair [axis, angle], got {pair!r}{hint}", item)
            if pair[0] not in AXES:
                raise ModelError(f"axis must be one of x, y, z, not {pair[0]!r}", f"{item}[0]")

        def make(n: _Names) -> Frame:
            return Frame(
                name,
                parent,
                n.vector(translation, "kinematic", f"{path}.translation")
                if translation is not None
                else sp.ImmutableMatrix.zeros(3, 1),
                tuple(
                    (axis, n.expr(angle, "kinematic", f"{path}.rotation[{i}][1]"))
                    for i, (axis, angle) in enumerate(rotation)
                ),
            )

        self._frames.append(make)

    def elastic_body(
        self,
        body: ElasticBody,
        initial: Sequence[object] | None = None,
        velocity: Sequence[object] | None = None,
        schedule: object = None,
    ) -> None:
        """Add an elastic body (equations.md §2): its coordinates ``NAME_q1 …``, the dependent
        coordinates of its node frames (``NAME_label_ux`` …, eliminated in the generated
        module) and the node frames ``NAME.label`` (:meth:`ElasticBody.node_frames`).

        Parameters
        ----------
        body
            The elastic body.
        initial, velocity
            Initial values and velocities of the elastic coordinates, one number per mode
            (``None``: zeros).
        schedule
            The scheduling variable of a parametric body: an expression of parameters,
            inputs, ``t`` and the coordinates of the symbolic part (key path
            ``elastic_bodies.NAME.schedule``).

        Raises
        ------
        ModelError
            A list whose length is not the number of modes, or a value that is not a number
            (key path ``elastic_bodies.NAME.initial`` / ``.velocity``).
        """
        path = self._declare("elastic_bodies", "elastic_body", body.name)
        values = {}
        for key, given in (("initial", initial), ("velocity", velocity)):
            if given is None:
                given = [0.0] * body.nq
            if isinstance(given, str | bytes) or not isinstance(given, Sequence):
                raise ModelError(f"expected a list of {body.nq} numbers (one per mode), got "
                                 f"{_type_name(given)}", f"{path}.{key}")
            if len(given) != body.nq:
                raise ModelError(f"expected {body.nq} values (one per mode), got {len(given)}",
                                 f"{path}.{key}")
            values[key] = [constant_number(v, f"{path}.{key}.{k + 1}", f"{key} value")
                           for k, v in enumerate(given)]
        for k, c in enumerate(body.coordinate_names):
            self.coordinate(c, values["initial"][k], values["velocity"][k])
        for c in body.all_node_coordinate_names:
            self.coordinate(c)
        for frame in body.node_frames():
            if frame.name in self._kinds:
                raise ModelError(f"name {frame.name!r} is already used by "
                                 f"{_KIND_WORDS[self._kinds[frame.name]]}", path)
            self._kinds[frame.name] = "frame"
            self._frames.append(lambda n, frame=frame: frame)
        if schedule is None:
            self._elastic.append(lambda n, body=body: body)
        else:
            self._elastic.append(lambda n, body=body: dataclasses.replace(
                body, schedule=n.expr(schedule, "kinematic", f"{path}.schedule")))

    def body(
        self,
        name: str,
        frame: str,
        mass: object,
        center_of_mass: object = None,
        inertia: object = None,
    ) -> None:
        """Add a rigid body fixed to ``frame``.

        ``mass``, ``center_of_mass`` (frame components) and ``inertia`` (about the center of
        mass, frame components; a 3×3 list of lists or ``{"diag": [Ixx, Iyy, Izz]}``) may use
        parameters only.
        """
        path = self._declare("bodies", "body", name)
        _check_frame_name(frame, f"{path}.frame")
        if center_of_mass is not None:
            _check_vector(center_of_mass, f"{path}.center_of_mass")
        if inertia is not None:
            _check_inertia(inertia, f"{path}.inertia")

        def make(n: _Names) -> RigidBody:
            com = (
                n.vector(center_of_mass, "constant", f"{path}.center_of_mass")
                if center_of_mass is not None
                else sp.ImmutableMatrix.zeros(3, 1)
            )
            theta = (
                n.inertia(inertia, f"{path}.inertia")
                if inertia is not None
                else sp.ImmutableMatrix.zeros(3, 3)
            )
            return RigidBody(name, frame, n.expr(mass, "constant", f"{path}.mass"), com, theta)

        self._bodies.append(make)

    # -------------------------------------------------------------- forces
    def force(
        self,
        name: str,
        frame: str,
        vector: object,
        point: object = None,
        in_: str = INERTIAL,
        *,
        enabled: object = None,
        report: bool = False,
    ) -> None:
        """Add a force ``vector`` (components of frame ``in_``) at ``point`` of ``frame``.

        ``enabled`` (all force elements): a parameter (or expression of parameters) that
        multiplies the element's action, 1 = on, 0 = off. ``report`` (all force elements): add
        outputs of what the element exerts (:meth:`force_output`), here ``<name>_fx`` … ``_fz``.
        """
        path = self._declare("forces", "force", name)
        self._report(name, report, path, "PointForce")
        _check_frame_name(frame, f"{path}.frame")
        _check_frame_name(in_, f"{path}.in")
        _check_vector(vector, f"{path}.vector")
        if point is not None:
            _check_vector(point, f"{path}.point")

        def make(n: _Names) -> PointForce:
            p = (
                n.vector(point, "kinematic", f"{path}.point")
                if point is not None
                else sp.ImmutableMatrix.zeros(3, 1)
            )
            return PointForce(name, frame, n.vector(vector, "dynamic", f"{path}.vector"), p, in_,
                              enabled=_enabled(n, enabled, path))

        self._forces.append(make)

    def torque(
        self,
        name: str,
        frame: str,
        vector: object,
        in_: str = INERTIAL,
        *,
        enabled: object = None,
        report: bool = False,
    ) -> None:
        """Add a torque ``vector`` (components of frame ``in_``) acting on ``frame``
        (``enabled``, ``report``: see :meth:`force`; reports ``<name>_mx`` … ``_mz``)."""
        path = self._declare("forces", "force", name)
        self._report(name, report, path, "Torque")
        _check_frame_name(frame, f"{path}.frame")
        _check_frame_name(in_, f"{path}.in")
        _check_vector(vector, f"{path}.vector")
        self._forces.append(
            lambda n: Torque(name, frame, n.vector(vector, "dynamic", f"{path}.vector"), in_,
                             enabled=_enabled(n, enabled, path))
        )

    def generalized_force(
        self,
        name: str,
        coordinate: str,
        value: object,
        *,
        enabled: object = None,
        report: bool = False,
    ) -> None:
        """Add a generalized force ``value`` acting directly on ``coordinate`` (``enabled``,
        ``report``: see :meth:`force`; reports ``<name>_force``)."""
        path = self._declare("forces", "force", name)
        self._report(name, report, path, "GeneralizedForce")
        if not isinstance(coordinate, str):
            raise ModelError(
                f"expected a coordinate name, got {_type_name(coordinate)}", f"{path}.coordinate"
            )
        self._forces.append(
            lambda n: GeneralizedForce(name, coordinate,
                                       n.expr(value, "dynamic", f"{path}.value"),
                                       enabled=_enabled(n, enabled, path))
        )

    def spring_damper(
        self,
        name: str,
        between: Sequence[str],
        points: Sequence[object] | None = None,
        *,
        stiffness: object,
        damping: object = 0,
        length: object = 0,
        loss_factor: object = 0,
        enabled: object = None,
        report: bool = False,
    ) -> None:
        """Add a point-to-point spring–damper.

        ``between = [frameA, frameB]``, ``points = [pA, pB]`` (each in its frame's components,
        default origins); tensile force ``stiffness·s + damping·sd`` with the elongation
        ``s = distance − length`` and its rate ``sd``. ``stiffness`` and ``damping`` may be
        expressions of ``s`` and ``sd`` (nonlinear coefficients; inside them these two names
        mean the elongation and its rate), or tables ``{"table": [[s0, F0], …],
        "interpolation": "linear" | "spline"}`` giving the spring force over ``s`` (the damper
        force over ``sd``) directly (:func:`~neweul_py.model.table_characteristic`).
        ``enabled``, ``report``: see :meth:`force` (reports ``<name>_force``, the tensile force).
        ``loss_factor`` (parameters only, ≥ 0): hysteretic damping on the spring's tangent
        stiffness (docs/equations.md §1.1).
        """
        path = self._declare("forces", "force", name)
        self._report(name, report, path, "SpringDamper")
        if not _is_sequence(between) or len(between) != 2:
            raise ModelError(
                f"expected two frame names [frameA, frameB], got {between!r}", f"{path}.between"
            )
        for i, f in enumerate(between):
            _check_frame_name(f, f"{path}.between[{i}]")
        if points is not None:
            if not _is_sequence(points) or len(points) != 2:
                raise ModelError(
                    f"expected two points [pointA, pointB], got {points!r}", f"{path}.points"
                )
            for i, p in enumerate(points):
                _check_vector(p, f"{path}.points[{i}]")

        def make(n: _Names) -> SpringDamper:
            pa, pb = (
                (n.vector(p, "kinematic", f"{path}.points[{i}]") for i, p in enumerate(points))
                if points is not None
                else (sp.ImmutableMatrix.zeros(3, 1), sp.ImmutableMatrix.zeros(3, 1))
            )
            k, k_curve = _characteristic(n, stiffness, ELONGATION, f"{path}.stiffness")
            d, d_curve = _characteristic(n, damping, ELONGATION_RATE, f"{path}.damping")
            return SpringDamper(
                name,
                between[0],
                between[1],
                stiffness=k,
                damping=d,
                length=n.expr(length, "dynamic", f"{path}.length"),
                point_a=pa,
                point_b=pb,
                spring_force=k_curve,
                damper_force=d_curve,
                enabled=_enabled(n, enabled, path),
                loss_factor=_loss_factor(n, loss_factor, path),
            )

        self._forces.append(make)

    def rotational_spring_damper(
        self,
        name: str,
        *,
        coordinate: str | None = None,
        between: Sequence[str] | None = None,
        axis: str = "z",
        stiffness: object = 0,
        damping: object = 0,
        angle: object = 0,
        loss_factor: object = 0,
        enabled: object = None,
        report: bool = False,
    ) -> None:
        """Add a rotational spring–damper on a ``coordinate`` or ``between`` two frames about
        ``axis`` (x, y, z of the first frame).

        The elongation ``s`` is the coordinate (or the relative rotation angle about the axis)
        minus ``angle``; ``stiffness``/``damping`` as in :meth:`spring_damper`. Reports
        ``<name>_force`` (the restoring torque ``F(s, sd)``).
        """
        path = self._declare("forces", "force", name)
        self._report(name, report, path, "RotationalSpringDamper")
        if (coordinate is None) == (between is None):
            raise ModelError(
                "a rotational spring–damper needs exactly one of 'coordinate' or 'between'", path
            )
        if coordinate is not None and not isinstance(coordinate, str):
            raise ModelError(
                f"expected a coordinate name, got {_type_name(coordinate)}", f"{path}.coordinate"
            )
        frames = self._two_frames(between, f"{path}.between") if between is not None else None
        if axis not in AXES:
            raise ModelError(f"axis must be one of x, y, z, not {axis!r}", f"{path}.axis")

        def make(n: _Names) -> RotationalSpringDamper:
            k, k_curve = _characteristic(n, stiffness, ELONGATION, f"{path}.stiffness")
            d, d_curve = _characteristic(n, damping, ELONGATION_RATE, f"{path}.damping")
            return RotationalSpringDamper(
                name,
                stiffness=k,
                damping=d,
                angle=n.expr(angle, "dynamic", f"{path}.angle"),
                coordinate=coordinate,
                frame_a=frames[0] if frames else None,
                frame_b=frames[1] if frames else None,
                axis=axis,  # type: ignore[arg-type]
                spring_force=k_curve,
                damper_force=d_curve,
                enabled=_enabled(n, enabled, path),
                loss_factor=_loss_factor(n, loss_factor, path),
            )

        self._forces.append(make)

    def bushing(
        self,
        name: str,
        between: Sequence[str],
        points: Sequence[object] | None = None,
        *,
        stiffness: object = 0,
        damping: object = 0,
        rotational_stiffness: object = 0,
        rotational_damping: object = 0,
        loss_factor: object = 0,
        enabled: object = None,
        report: bool = False,
    ) -> None:
        """Add a linear 6-DOF bushing between ``points`` (offsets, default origins) of two
        frames (:class:`~neweul_py.model.Bushing`).

        Each of the four matrices (first frame's components) is a 3×3 list of lists,
        ``{"diag": [a, b, c]}`` or one value (isotropic, ``value·I``). Reports ``<name>_fx``
        … ``_fz``, ``_mx`` … ``_mz`` (force and torque on the second frame). ``loss_factor``
        (parameters only, ≥ 0): hysteretic damping on both stiffness matrices
        (docs/equations.md §1.1).
        """
        path = self._declare("forces", "force", name)
        self._report(name, report, path, "Bushing")
        frames = self._two_frames(between, f"{path}.between")
        self._check_points(points, path)
        specs = {
            "stiffness": stiffness,
            "damping": damping,
            "rotational_stiffness": rotational_stiffness,
            "rotational_damping": rotational_damping,
        }
        for key, value in specs.items():
            _check_matrix33(value, f"{path}.{key}")

        def make(n: _Names) -> Bushing:
            pa, pb = _points(n, points, path)
            mats = {k: _matrix33(n, v, f"{path}.{k}") for k, v in specs.items()}
            return Bushing(
                name, frames[0], frames[1], **mats, point_a=pa, point_b=pb,
                enabled=_enabled(n, enabled, path),
                loss_factor=_loss_factor(n, loss_factor, path),
            )

        self._forces.append(make)

    def _two_frames(self, between: object, key_path: str) -> tuple[str, str]:
        if not _is_sequence(between) or len(between) != 2:  # type: ignore[arg-type]
            raise ModelError(f"expected two frame names [frameA, frameB], got {between!r}",
                             key_path)
        a, b = between  # type: ignore[misc]
        return _check_frame_name(a, f"{key_path}[0]"), _check_frame_name(b, f"{key_path}[1]")

    @staticmethod
    def _check_points(points: object, path: str) -> None:
        if points is not None:
            if not _is_sequence(points) or len(points) != 2:  # type: ignore[arg-type]
                raise ModelError(
                    f"expected two points [pointA, pointB], got {points!r}", f"{path}.points"
                )
            for i, p in enumerate(points):  # type: ignore[arg-type]
                _check_vector(p, f"{path}.points[{i}]")

    def _report(self, force: str, report: object, path: str, kind: str) -> None:
        """Declare the outputs a force element of type ``kind`` reports when ``report`` is
        true: ``<force>_force`` for scalar elements, ``<force>_<component>`` otherwise."""
        if report is None or report is False:
            return
        if report is not True:
            raise ModelError(f"report must be true or false, got {_type_name(report)}",
                             f"{path}.report")
        for component in FORCE_COMPONENTS[kind]:
            out = f"{force}_{component}"
            if out in self._kinds:
                raise ModelError(
                    f"cannot report output {out!r}: the name is already used by "
                    f"{_KIND_WORDS[self._kinds[out]]}",
                    f"{path}.report",
                )
            self.force_output(out, force, component)

    # -------------------------------------------------------------- outputs
    def force_output(self, name: str, force: str, component: str = "force") -> None:
        """Add an output reporting what force element ``force`` exerts: ``component``
        ``force`` (scalar elements) or ``fx fy fz mx my mz`` (vector elements), see
        :class:`~neweul_py.model.ForceOutput`."""
        self._declare("outputs", "output", name)
        if not isinstance(force, str):
            raise ModelError(f"expected a force element name, got {_type_name(force)}",
                             f"outputs.{name}.force")
        self._outputs.append(lambda n: ForceOutput(name, force, component))

    # -------------------------------------------------------------- constraints
    def constraint(self, name: str, expr: object) -> None:
        """Add a holonomic constraint ``expr(y, t, u, p) = 0``. A string ``"a = b"`` means
        ``a − b = 0``."""
        path = f"constraints.{name}"
        self._declare_constraint(name, path)

        def make(n: _Names) -> ExpressionConstraint:
            if isinstance(expr, str) and expr.count("=") == 1:
                lhs, rhs = expr.split("=")
                value = n.expr(lhs, "kinematic", path) - n.expr(rhs, "kinematic", path)
            else:
                value = n.expr(expr, "kinematic", path)
            return ExpressionConstraint(name, value)

        self._constraints.append(make)

    def coincide(
        self,
        name: str,
        frames: Sequence[str],
        points: Sequence[object] | None = None,
        components: Sequence[str] = ("x", "y", "z"),
        in_: str = INERTIAL,
    ) -> None:
        """Add the constraints that ``points[1]`` of ``frames[1]`` coincides with
        ``points[0]`` of ``frames[0]`` in ``components`` of frame ``in_``; they are named
        ``<name>_<component>``."""
        path = f"constraints.{name}"
        self._declare_constraint(name, path)
        fa, fb = self._two_frames(frames, f"{path}.coincide")
        self._check_points(points, path)
        _check_frame_name(in_, f"{path}.in")
        if not _is_sequence(components):
            raise ModelError(f"expected a list of components (x, y, z), got "
                             f"{_type_name(components)}", f"{path}.components")
        for i, c in enumerate(components):
            if c not in AXES:
                raise ModelError(f"component must be one of x, y, z, not {c!r}",
                                 f"{path}.components[{i}]")

        def make(n: _Names) -> CoincidenceConstraint:
            pa, pb = _points(n, points, path)
            return CoincidenceConstraint(name, fa, fb, pa, pb, tuple(components), in_)

        self._constraints.append(make)

    def _declare_constraint(self, name: object, path: str) -> None:
        why = check_name(name)
        if why is not None:
            raise ModelError(why, path)
        if name in self._constraint_names:
            raise ModelError(f"constraint {name!r} is defined twice", path)
        self._constraint_names.add(name)  # type: ignore[arg-type]

    # -------------------------------------------------------------- outputs
    def output(self, name: str, expr: object) -> None:
        """Add an output: an expression of coordinates, velocities, inputs, parameters, t."""
        path = self._declare("outputs", "output", name)
        self._outputs.append(lambda n: ExpressionOutput(name, n.expr(expr, "dynamic", path)))

    def kinematic_output(
        self,
        name: str,
        quantity: str,
        frame: str,
        point: object = None,
        in_: str = INERTIAL,
        component: str = "x",
    ) -> None:
        """Add an output: one ``component`` (x, y, z in frame ``in_``) of the absolute
        ``quantity`` (``"position"`` or ``"velocity"``) of ``point`` of ``frame``."""
        path = self._declare("outputs", "output", name)
        if quantity not in ("position", "velocity"):
            raise ModelError(
                f"quantity must be 'position' or 'velocity', not {quantity!r}", path
            )
        _check_frame_name(frame, f"{path}.{quantity}")
        _check_frame_name(in_, f"{path}.in")
        if component not in AXES:
            raise ModelError(
                f"component must be one of x, y, z, not {component!r}", f"{path}.component"
            )
        if point is not None:
            _check_vector(point, f"{path}.point")

        def make(n: _Names) -> KinematicOutput:
            p = (
                n.vector(point, "kinematic", f"{path}.point")
                if point is not None
                else sp.ImmutableMatrix.zeros(3, 1)
            )
            return KinematicOutput(name, quantity, frame, component, p, in_)  # type: ignore[arg-type]

        self._outputs.append(make)

    # -------------------------------------------------------------- build
    def _names(self) -> _Names:
        symbols = {n: symbol(n) for n, k in self._kinds.items() if k in _SYMBOL_KINDS}
        symbols["t"] = time
        return _Names(symbols, {**self._kinds, "t": "time"})

    def build(self) -> System:
        """Parse every expression with the names of its scope and return the validated system.

        Raises
        ------
        ModelError
            The first error found, with its key path.
        """
        n = self._names()
        # Parse in the order of the description file, so the first error is the first one.
        gravity = self._gravity(n) if self._gravity else sp.ImmutableMatrix.zeros(3, 1)
        inputs: tuple[Input, ...] = tuple(make(n) for make in self._inputs)
        frames: tuple[Frame, ...] = tuple(make(n) for make in self._frames)
        bodies: tuple[RigidBody, ...] = tuple(make(n) for make in self._bodies)
        forces: tuple[ForceElement, ...] = tuple(make(n) for make in self._forces)
        outputs: tuple[Output, ...] = tuple(make(n) for make in self._outputs)
        constraints: tuple[Constraint, ...] = tuple(make(n) for make in self._constraints)
        return System(
            name=self._name,
            coordinates=tuple(self._coordinates),
            parameters=tuple(self._parameters),
            inputs=inputs,
            frames=frames,
            bodies=bodies,
            forces=forces,
            outputs=outputs,
            gravity=gravity,
            description=self._description,
            constraints=constraints,
            elastic_bodies=tuple(make(n) for make in self._elastic),
            **({} if self._loss_reference is None
               else {"loss_reference_frequency": self._loss_reference}),
        )


_SYMBOL_KINDS = frozenset({"parameter", "coordinate", "velocity", "input", "input_rate"})
