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

=============================================  ==========================================
place                                          allowed names
=============================================  ==========================================
masses, centers of mass, inertias, gravity     parameters
input defaults                                 parameters, ``t``
frame translations/rotations, points           parameters, coordinates, inputs, ``t``
force vectors, force laws, expression outputs  all of the above and velocities ``d_<coord>``
=============================================  ==========================================

Every error is a :class:`~neweul_py.errors.ModelError` carrying the key path of the
description file layout (``bodies.malleus.inertia[1][2]``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import sympy as sp

from ..errors import ModelError
from ..model import (
    AXES,
    INERTIAL,
    CoincidenceConstraint,
    Constraint,
    Coordinate,
    ElasticBody,
    ExpressionConstraint,
    ExpressionOutput,
    ForceElement,
    ForceOutput,
    Frame,
    Input,
    KinematicOutput,
    Output,
    Parameter,
    RigidBody,
    System,
    check_name,
    input_rate_name,
    symbol,
    time,
    velocity_name,
)
from .force_keys import check_value, force_schema, force_type, given_values, parse_value
from .values import (
    KIND_WORDS,
    Names,
    check_frame_name,
    check_inertia,
    check_points,
    check_vector,
    constant_number,
    is_sequence,
    parse_points,
    two_frames,
    type_name,
)

__all__ = ["SystemBuilder"]


_Make = Callable[[Names], Any]


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
            raise ModelError(f"expected text, got {type_name(description)}", "description")
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
        self._elastic: list[Callable[[Names], ElasticBody]] = []

    # -------------------------------------------------------------- helpers
    def _declare(self, group: str, kind: str, name: object) -> str:
        path = f"{group}.{name}"
        why = check_name(name)
        if why is not None:
            raise ModelError(why, path)
        assert isinstance(name, str)
        if name in self._kinds:
            raise ModelError(f"name {name!r} is already used by {KIND_WORDS[self._kinds[name]]}",
                             path)
        self._kinds[name] = kind
        return path

    # -------------------------------------------------------------- symbols
    def parameter(self, name: str, default: float | str, minimum: float | str | None = None,
                  maximum: float | str | None = None) -> sp.Symbol:
        """Add a parameter with a numeric default (and optionally the inclusive range of the
        values the model admits: a length ``minimum=0``); return its symbol.

        ``default``, ``minimum`` and ``maximum`` are numbers or constant expression strings
        (``"2*pi"``, ``"1e-3"``).
        """
        path = self._declare("parameters", "parameter", name)
        bounds = [None if v is None else constant_number(v, f"{path}.{key}", key)
                  for v, key in ((minimum, "min"), (maximum, "max"))]
        self._parameters.append(Parameter(name, constant_number(default, path, "default"),
                                          *bounds))
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
                    f"{KIND_WORDS[self._kinds[rate]]}",
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
        check_vector(vector, "gravity")
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
        check_frame_name(parent, f"{path}.parent")
        if translation is not None:
            check_vector(translation, f"{path}.translation")
        rotation = [] if rotation is None else rotation
        if not is_sequence(rotation):
            raise ModelError(
                f"expected a list of [axis, angle] pairs, got {type_name(rotation)}",
                f"{path}.rotation",
            )
        for i, pair in enumerate(rotation):
            item = f"{path}.rotation[{i}]"
            if not is_sequence(pair) or len(pair) != 2:
                hint = (
                    "; a single rotation is written [[axis, angle]]"
                    if isinstance(pair, str) and pair in AXES
                    else ""
                )
                raise ModelError(f"expected a pair [axis, angle], got {pair!r}{hint}", item)
            if pair[0] not in AXES:
                raise ModelError(f"axis must be one of x, y, z, not {pair[0]!r}", f"{item}[0]")

        def make(n: Names) -> Frame:
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
                                 f"{type_name(given)}", f"{path}.{key}")
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
                                 f"{KIND_WORDS[self._kinds[frame.name]]}", path)
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
        check_frame_name(frame, f"{path}.frame")
        if center_of_mass is not None:
            check_vector(center_of_mass, f"{path}.center_of_mass")
        if inertia is not None:
            check_inertia(inertia, f"{path}.inertia")

        def make(n: Names) -> RigidBody:
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
    def force_element(self, name: str, spec: Mapping[str, Any]) -> None:
        """Add a force element from its description mapping ``{type: TYPE, key: value, …}``
        (docs/description-format.md): the element class of ``TYPE`` lists its keys
        (:attr:`~neweul_py.model.ForceElement.keys`). Every element also has ``enabled`` (a
        parameter factor, 1 on, 0 off) and ``report`` (add outputs of what it exerts,
        :meth:`force_output`).

        Shapes, frame and coordinate names are checked here; expression strings are parsed in
        :meth:`build`.
        """
        item = f"forces.{name}"
        element = force_type(spec, item)
        spec = force_schema(element).check(spec, item, f"a {element.type_name!r} force element")
        path = self._declare("forces", "force", name)
        self._report(name, spec.get("report", False), path, element)
        given = given_values(element, spec)
        for key, value in given.items():
            check_value(key, value, f"{path}.{key.name}")

        def make(n: Names) -> ForceElement:
            fields: dict[str, object] = {}
            for key, value in given.items():
                fields.update(parse_value(n, key, value, f"{path}.{key.name}"))
            return element(name=name, **fields)  # type: ignore[call-arg]

        self._forces.append(make)

    def force(self, name: str, frame: str, vector: object, point: object = None,
              in_: str = INERTIAL, *, enabled: object = None, report: bool = False) -> None:
        """Add a force ``vector`` (components of frame ``in_``) at ``point`` of ``frame``
        (:class:`~neweul_py.model.PointForce`; reports ``<name>_fx`` … ``_fz``).

        ``enabled`` (all force elements): a parameter (or expression of parameters) that
        multiplies the element's action, 1 = on, 0 = off. ``report`` (all force elements): add
        outputs of what the element exerts (:meth:`force_output`).
        """
        self.force_element(name, _spec("force", frame=frame, vector=vector, point=point,
                                       enabled=enabled, report=report, **{"in": in_}))

    def torque(self, name: str, frame: str, vector: object, in_: str = INERTIAL, *,
               enabled: object = None, report: bool = False) -> None:
        """Add a torque ``vector`` (components of frame ``in_``) acting on ``frame``
        (:class:`~neweul_py.model.Torque`; reports ``<name>_mx`` … ``_mz``)."""
        self.force_element(name, _spec("torque", frame=frame, vector=vector, enabled=enabled,
                                       report=report, **{"in": in_}))

    def generalized_force(self, name: str, coordinate: str, value: object, *,
                          enabled: object = None, report: bool = False) -> None:
        """Add a generalized force ``value`` acting directly on ``coordinate``
        (:class:`~neweul_py.model.GeneralizedForce`; reports ``<name>_force``)."""
        self.force_element(name, _spec("generalized", coordinate=coordinate, value=value,
                                       enabled=enabled, report=report))

    def spring_damper(self, name: str, between: Sequence[str],
                      points: Sequence[object] | None = None, *, stiffness: object,
                      damping: object = 0, length: object = 0, loss_factor: object = 0,
                      enabled: object = None, report: bool = False) -> None:
        """Add a point-to-point spring–damper (:class:`~neweul_py.model.SpringDamper`).

        ``between = [frameA, frameB]``, ``points = [pA, pB]`` (each in its frame's components,
        default origins); tensile force ``stiffness·s + damping·sd`` with the elongation
        ``s = distance − length`` and its rate ``sd``. ``stiffness`` and ``damping`` may be
        expressions of ``s`` and ``sd`` (nonlinear coefficients; inside them these two names
        mean the elongation and its rate), or tables ``{"table": [[s0, F0], …],
        "interpolation": "linear" | "spline"}`` giving the spring force over ``s`` (the damper
        force over ``sd``) directly (:func:`~neweul_py.model.table_characteristic`).
        Reports ``<name>_force``, the tensile force. ``loss_factor`` (parameters only, ≥ 0):
        hysteretic damping on the spring's tangent stiffness (docs/equations.md §1.1).
        """
        self.force_element(name, _spec(
            "spring_damper", between=between, points=points, stiffness=stiffness,
            damping=damping, length=length, loss_factor=loss_factor, enabled=enabled,
            report=report))

    def rotational_spring_damper(
        self, name: str, *, coordinate: str | None = None, between: Sequence[str] | None = None,
        axis: str = "z", stiffness: object = 0, damping: object = 0, angle: object = 0,
        loss_factor: object = 0, enabled: object = None, report: bool = False,
    ) -> None:
        """Add a rotational spring–damper on a ``coordinate`` or ``between`` two frames about
        ``axis`` (x, y, z of the first frame; :class:`~neweul_py.model.RotationalSpringDamper`).

        The elongation ``s`` is the coordinate (or the relative rotation angle about the axis)
        minus ``angle``; ``stiffness``/``damping`` as in :meth:`spring_damper`. Reports
        ``<name>_force`` (the restoring torque ``F(s, sd)``).
        """
        self.force_element(name, _spec(
            "rotational_spring_damper", coordinate=coordinate, between=between, axis=axis,
            stiffness=stiffness, damping=damping, angle=angle, loss_factor=loss_factor,
            enabled=enabled, report=report))

    def bushing(
        self, name: str, between: Sequence[str], points: Sequence[object] | None = None, *,
        stiffness: object = 0, damping: object = 0, rotational_stiffness: object = 0,
        rotational_damping: object = 0, loss_factor: object = 0, enabled: object = None,
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
        self.force_element(name, _spec(
            "bushing", between=between, points=points, stiffness=stiffness, damping=damping,
            rotational_stiffness=rotational_stiffness, rotational_damping=rotational_damping,
            loss_factor=loss_factor, enabled=enabled, report=report))

    def _report(self, force: str, report: object, path: str,
                element: type[ForceElement]) -> None:
        """Declare the outputs a force element reports when ``report`` is true:
        ``<force>_<component>`` for each of its components (``<force>_force`` for scalar
        elements)."""
        if report is None or report is False:
            return
        if report is not True:
            raise ModelError(f"report must be true or false, got {type_name(report)}",
                             f"{path}.report")
        for component in element.components:
            out = f"{force}_{component}"
            if out in self._kinds:
                raise ModelError(
                    f"cannot report output {out!r}: the name is already used by "
                    f"{KIND_WORDS[self._kinds[out]]}",
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
            raise ModelError(f"expected a force element name, got {type_name(force)}",
                             f"outputs.{name}.force")
        self._outputs.append(lambda n: ForceOutput(name, force, component))

    # -------------------------------------------------------------- constraints
    def constraint(self, name: str, expr: object) -> None:
        """Add a holonomic constraint ``expr(y, t, u, p) = 0``. A string ``"a = b"`` means
        ``a − b = 0``."""
        path = f"constraints.{name}"
        self._declare_constraint(name, path)

        def make(n: Names) -> ExpressionConstraint:
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
        fa, fb = two_frames(frames, f"{path}.coincide")
        check_points(points, f"{path}.points")
        check_frame_name(in_, f"{path}.in")
        if not is_sequence(components):
            raise ModelError(f"expected a list of components (x, y, z), got "
                             f"{type_name(components)}", f"{path}.components")
        for i, c in enumerate(components):
            if c not in AXES:
                raise ModelError(f"component must be one of x, y, z, not {c!r}",
                                 f"{path}.components[{i}]")

        def make(n: Names) -> CoincidenceConstraint:
            pa, pb = parse_points(n, points, f"{path}.points")
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
        check_frame_name(frame, f"{path}.{quantity}")
        check_frame_name(in_, f"{path}.in")
        if component not in AXES:
            raise ModelError(
                f"component must be one of x, y, z, not {component!r}", f"{path}.component"
            )
        if point is not None:
            check_vector(point, f"{path}.point")

        def make(n: Names) -> KinematicOutput:
            p = (
                n.vector(point, "kinematic", f"{path}.point")
                if point is not None
                else sp.ImmutableMatrix.zeros(3, 1)
            )
            return KinematicOutput(name, quantity, frame, component, p, in_)  # type: ignore[arg-type]

        self._outputs.append(make)

    # -------------------------------------------------------------- build
    def _names(self) -> Names:
        symbols = {n: symbol(n) for n, k in self._kinds.items() if k in _SYMBOL_KINDS}
        symbols["t"] = time
        return Names(symbols, {**self._kinds, "t": "time"})

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


def _spec(type_: str, **values: object) -> dict[str, object]:
    """A force element's description mapping from keyword arguments (``None``: not given)."""
    return {"type": type_, **{k: v for k, v in values.items() if v is not None}}
