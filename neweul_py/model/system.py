"""The :class:`System`: a validated, immutable multibody model."""

from __future__ import annotations

import hashlib
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, fields, is_dataclass
from functools import cached_property

import sympy as sp

from ..errors import ModelError
from .constraints import CoincidenceConstraint, Constraint, ExpressionConstraint
from .display import system_html, system_markdown
from .elastic import ElasticBody, is_node_frame_name
from .elements import (
    Coordinate,
    ExpressionOutput,
    ForceOutput,
    Frame,
    Input,
    KinematicOutput,
    Output,
    Parameter,
    RigidBody,
)
from .forces import (
    ELONGATION,
    ELONGATION_RATE,
    ForceElement,
)
from .symbols import INERTIAL, check_name, input_rate_name, symbol, time, velocity_name

__all__ = ["DEFAULT_LOSS_REFERENCE_FREQUENCY", "System"]

#: The default ``loss_reference_frequency`` [Hz].
DEFAULT_LOSS_REFERENCE_FREQUENCY = 1000.0


@dataclass(frozen=True)
class System:
    """A multibody system: what it is, validated on construction, never mutated.

    Derived results (kinematics, equations, generated code) are computed by free functions
    that take a ``System`` and return new objects (Pinocchio's Model/Data split).

    Parameters
    ----------
    name
        Model name; also the name of the generated module (a valid identifier).
    coordinates, parameters, inputs, frames, bodies, forces, outputs
        The model items, in the order the generated code uses.
    gravity
        Gravitational acceleration in ISYS components.
    description
        Free text.
    constraints
        Holonomic constraints ``g(y, t) = 0`` closing kinematic loops.
    elastic_bodies
        Elastic bodies (:class:`~neweul_py.model.elastic.ElasticBody`); their
        coordinates, the dependent coordinates of their node frames and the node frames
        (``NAME.label``) are in ``coordinates`` and ``frames``.
    loss_reference_frequency
        ``f_ref`` [Hz] of the loss factors (equations.md §1.1): the time domain replaces the
        hysteretic damping ``iG`` by its viscous equivalent ``G/ω_ref``, exact at
        ``ω_ref = 2π f_ref``; one per model (a body whose data hold another is an error).

    Raises
    ------
    ModelError
        With the key path of the first inconsistency found (unknown names, frame cycles,
        expressions using undefined symbols, negative masses, non-positive inertia…).
    """

    name: str
    coordinates: tuple[Coordinate, ...] = ()
    parameters: tuple[Parameter, ...] = ()
    inputs: tuple[Input, ...] = ()
    frames: tuple[Frame, ...] = ()
    bodies: tuple[RigidBody, ...] = ()
    forces: tuple[ForceElement, ...] = ()
    outputs: tuple[Output, ...] = ()
    gravity: sp.ImmutableMatrix = field(default_factory=lambda: sp.ImmutableMatrix.zeros(3, 1))
    description: str = ""
    constraints: tuple[Constraint, ...] = ()
    elastic_bodies: tuple[ElasticBody, ...] = ()
    loss_reference_frequency: float = DEFAULT_LOSS_REFERENCE_FREQUENCY

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, list):
                object.__setattr__(self, f.name, tuple(value))
        _validate(self)

    # ------------------------------------------------------------------ lookups
    @cached_property
    def frame_map(self) -> Mapping[str, Frame]:
        """Frames by name (without ISYS)."""
        return {f.name: f for f in self.frames}

    def frame_chain(self, name: str) -> tuple[Frame, ...]:
        """The frames from the first child of ISYS down to ``name`` (empty for ISYS)."""
        chain: list[Frame] = []
        while name != INERTIAL:
            frame = self.frame_map[name]
            chain.append(frame)
            name = frame.parent
        return tuple(reversed(chain))

    @cached_property
    def frames_topological(self) -> tuple[Frame, ...]:
        """Frames ordered so that every parent comes before its children (stable)."""
        done: dict[str, Frame] = {}
        for frame in self.frames:
            for f in self.frame_chain(frame.name):
                done.setdefault(f.name, f)
        return tuple(done.values())

    @property
    def coordinate_symbols(self) -> tuple[sp.Symbol, ...]:
        return tuple(c.symbol for c in self.coordinates)

    @property
    def velocity_symbols(self) -> tuple[sp.Symbol, ...]:
        return tuple(c.velocity_symbol for c in self.coordinates)

    @property
    def parameter_symbols(self) -> tuple[sp.Symbol, ...]:
        return tuple(p.symbol for p in self.parameters)

    @cached_property
    def input_rate_orders(self) -> Mapping[str, int]:
        """For each input, how many of its time derivatives the model needs (0, 1 or 2).

        An input that appears in kinematics (frame motion, points, constraints) needs two
        (velocities and accelerations of the excited frames); otherwise the highest of
        ``d_<input>`` (1) and ``dd_<input>`` (2) used in force laws and outputs.
        """
        return _input_rate_orders(self)

    @property
    def input_names(self) -> tuple[str, ...]:
        """Names of the entries of the input vector ``u``: the inputs in order, then the
        derivatives the model needs, ``d_<input>``, ``dd_<input>`` (see
        :attr:`input_rate_orders`)."""
        rates = [
            input_rate_name(u.name, k)
            for u in self.inputs
            for k in range(1, self.input_rate_orders[u.name] + 1)
        ]
        return (*(u.name for u in self.inputs), *rates)

    @property
    def input_symbols(self) -> tuple[sp.Symbol, ...]:
        """Symbols of the input vector ``u`` (ordered as :attr:`input_names`)."""
        return tuple(symbol(n) for n in self.input_names)

    @property
    def input_defaults(self) -> tuple[sp.Expr, ...]:
        """Default excitation of every entry of ``u``: the inputs' defaults and their time
        derivatives (ordered as :attr:`input_names`)."""
        base = {u.name: u.default for u in self.inputs}
        out = [base[u.name] for u in self.inputs]
        for u in self.inputs:
            expr = u.default
            for _ in range(self.input_rate_orders[u.name]):
                expr = sp.diff(expr, time)
                out.append(expr)
        return tuple(out)

    @property
    def constraint_names(self) -> tuple[str, ...]:
        """Names of the scalar constraints, in order (``CONSTRAINTS``)."""
        return tuple(n for c in self.constraints for n in c.names)

    @property
    def parameter_defaults(self) -> dict[sp.Symbol, float]:
        return {p.symbol: p.default for p in self.parameters}

    def _repr_html_(self) -> str:
        """The model at a glance in notebooks (:mod:`~neweul_py.model.display`)."""
        return system_html(self)

    def _repr_markdown_(self) -> str:
        return system_markdown(self)

    @cached_property
    def parameter_ranges(self) -> dict[str, tuple[float | None, float | None]]:
        """``name → (minimum, maximum)`` (inclusive, ``None``: unbounded) of the parameters
        with an admissible range: their own, and at least 0 for a parameter that is by itself
        what a force element refuses to be negative at the defaults (a spring's rest length,
        :meth:`~neweul_py.model.forces.ForceElement.nonnegative`): a new value must obey the
        same rule."""
        ranges = {p.name: (p.minimum, p.maximum) for p in self.parameters
                  if p.minimum is not None or p.maximum is not None}
        names = {p.symbol: p.name for p in self.parameters}
        for fe in self.forces:
            for expr in fe.nonnegative():
                name = names.get(expr)
                if name is not None:
                    lo, hi = ranges.get(name, (None, None))
                    ranges[name] = (0.0 if lo is None else max(lo, 0.0), hi)
        return ranges

    def fingerprint(self) -> str:
        """A SHA-256 of a canonical text of the whole model: equal models, equal fingerprints.

        Used to cache derived results by content.
        """
        return hashlib.sha256(repr(_canonical(self)).encode()).hexdigest()


# ---------------------------------------------------------------------- validation
def _canonical(system: System) -> tuple:
    return tuple((f.name, _canonical_value(getattr(system, f.name))) for f in fields(system))


def _canonical_value(value: object) -> object:
    """A canonical, printable form of a model object: dataclasses field by field, sympy
    expressions as their text with the arguments in sympy's own canonical order
    (``order="none"``; ``str`` sorts the terms of a sum first, which took 30 s for a sum of
    20 000 parameters), elastic bodies by their data's digest (``ElasticBody.__repr__``)."""
    if isinstance(value, sp.Basic):
        return sp.sstr(value, order="none")
    if isinstance(value, tuple | list):
        return tuple(_canonical_value(v) for v in value)
    if isinstance(value, Mapping):
        return tuple(sorted((repr(k), _canonical_value(v)) for k, v in value.items()))
    if isinstance(value, ElasticBody) or not is_dataclass(value) or isinstance(value, type):
        return repr(value)
    return (type(value).__name__,
            tuple((f.name, _canonical_value(getattr(value, f.name))) for f in fields(value)))


@dataclass(frozen=True)
class _Names:
    """The names of a system by what may use them (docs/description-format.md, Expressions)."""

    scopes: Mapping[str, Mapping[str, sp.Symbol]]  # constant, excitation, kinematic, dynamic
    frames: frozenset[str]
    coordinates: frozenset[str]
    defaults: Mapping[sp.Symbol, float]

    def need_frame(self, name: str, path: str) -> None:
        if name not in self.frames:
            raise ModelError(
                f"unknown frame {name!r}; frames are: {', '.join(sorted(self.frames))}", path
            )

    def need_coordinate(self, name: str, path: str) -> None:
        if name not in self.coordinates:
            raise ModelError(
                f"unknown coordinate {name!r}; coordinates are: "
                f"{', '.join(sorted(self.coordinates)) or '(none)'}",
                path,
            )

    def at_defaults(self, expr: sp.Basic) -> object:
        """:func:`_numeric` at the parameter defaults."""
        return _numeric(expr, self.defaults)


def _validate(s: System) -> None:
    if check_name(s.name) is not None:
        raise ModelError(f"model name: {check_name(s.name)}", "name")
    seen = _unique_names(s)
    for fe in s.forces:
        if not isinstance(fe, ForceElement):
            raise ModelError(f"not a force element: {fe!r}", f"forces.{fe.name}")
    _validate_numbers(s)
    names = _names(s, seen)
    _check_symbols(s.gravity, names.scopes["constant"], "gravity")
    for u in s.inputs:
        _check_symbols(u.default, names.scopes["excitation"], f"inputs.{u.name}")
    _validate_losses(s, names.scopes["constant"])
    _validate_elastic(s, set(names.frames), seen)
    _validate_frames(s, names.scopes["kinematic"])
    for b in s.bodies:
        _validate_body(b, names)
    for fe in s.forces:
        _validate_force(fe, names)
    for out in s.outputs:
        _validate_output(s, out, names)
    _validate_constraints(s, names)


def _unique_names(s: System) -> dict[str, str]:
    """Every item's name valid and used once; returns name → group."""
    seen: dict[str, str] = {}
    groups = (
        ("parameters", s.parameters),
        ("coordinates", s.coordinates),
        ("inputs", s.inputs),
        ("frames", s.frames),
        ("bodies", s.bodies),
        ("forces", s.forces),
        ("outputs", s.outputs),
        ("constraints", s.constraints),
    )
    for group, items in groups:
        for item in items:
            path = f"{group}.{item.name}"
            node = group == "frames" and is_node_frame_name(item.name)
            why = None if node else check_name(item.name)
            if why is not None:
                raise ModelError(why, path)
            if item.name in seen:
                raise ModelError(f"name {item.name!r} is already used in {seen[item.name]}", path)
            seen[item.name] = group
    return seen


def _finite(v: object) -> bool:
    return not isinstance(v, bool) and isinstance(v, int | float) and math.isfinite(v)


def _validate_numbers(s: System) -> None:
    """Parameter defaults and initial values are finite numbers."""
    for p in s.parameters:
        if not _finite(p.default):
            raise ModelError(
                f"default must be a finite number, got {p.default!r}", f"parameters.{p.name}"
            )
    for c in s.coordinates:
        for attr in ("initial", "velocity"):
            v = getattr(c, attr)
            if not _finite(v):
                raise ModelError(
                    f"{attr} value must be a finite number, got {v!r}", f"coordinates.{c.name}"
                )


def _names(s: System, seen: Mapping[str, str]) -> _Names:
    """The names of each scope; the names of input rates are reserved."""
    par = {p.name: p.symbol for p in s.parameters}
    crd = {c.name: c.symbol for c in s.coordinates}
    vel = {velocity_name(c.name): c.velocity_symbol for c in s.coordinates}
    inp = {u.name: u.symbol for u in s.inputs}
    tt = {"t": time}
    rates = {
        input_rate_name(u.name, k): symbol(input_rate_name(u.name, k))
        for u in s.inputs
        for k in (1, 2)
    }
    for name in rates:
        if name in seen:
            raise ModelError(
                f"name {name!r} is reserved for a time derivative of the input "
                f"{name.split('_', 1)[1]!r}",
                f"{seen[name]}.{name}",
            )
    kinematic = {**par, **crd, **inp, **tt}
    scopes = {
        "constant": par,
        "excitation": {**par, **tt},
        "kinematic": kinematic,
        "dynamic": {**kinematic, **vel, **rates},
    }
    return _Names(scopes, frozenset({INERTIAL, *s.frame_map}), frozenset(crd),
                  {p.symbol: p.default for p in s.parameters})


def _validate_body(b: RigidBody, names: _Names) -> None:
    path = f"bodies.{b.name}"
    constant = names.scopes["constant"]
    names.need_frame(b.frame, f"{path}.frame")
    _check_symbols(b.mass, constant, f"{path}.mass")
    _check_symbols(b.center_of_mass, constant, f"{path}.center_of_mass")
    _check_symbols(b.inertia, constant, f"{path}.inertia")
    mass = names.at_defaults(b.mass)
    if mass is not None and mass < 0:  # type: ignore[operator]
        raise ModelError(f"mass must not be negative (it is {mass:g})", f"{path}.mass")
    inertia = names.at_defaults(b.inertia)
    if inertia is not None:
        _check_inertia(inertia, f"{path}.inertia")  # type: ignore[arg-type]


#: The local names of a characteristic's expressions (docs/description-format.md).
_LOCAL = {"s": ELONGATION, "sd": ELONGATION_RATE}


def _validate_force(fe: ForceElement, names: _Names) -> None:
    """A force element by its schema (:attr:`ForceElement.keys`): the frames and coordinates
    it names exist, its expressions use the names of their scopes (a characteristic's
    coefficients also ``s`` and ``sd``, its table curve only its own variable); loss factors
    are checked by :func:`_validate_losses`."""
    keys = type(fe).schema()
    for key in keys:
        for where, name in fe.entries(key):
            if name is None:
                continue
            if key.kind in ("frame", "frames"):
                names.need_frame(name, where)  # type: ignore[arg-type]
            elif key.kind == "coordinate":
                names.need_coordinate(name, where)  # type: ignore[arg-type]
    for key in keys:
        if key.scope is None or key.kind == "loss_factor":
            continue
        allowed = names.scopes[key.scope]
        if key.kind == "characteristic":
            (where, coefficient), (_, curve) = fe.entries(key)
            _check_symbols(coefficient, {**allowed, **_LOCAL}, where)
            if curve is not None:
                _check_symbols(curve, {key.variable: _LOCAL[key.variable]}, where)
            continue
        for where, value in fe.entries(key):
            _check_symbols(value, allowed, where)
    fe.check(names.at_defaults)


def _validate_output(s: System, out: Output, names: _Names) -> None:
    path = f"outputs.{out.name}"
    if isinstance(out, ExpressionOutput):
        _check_symbols(out.expr, names.scopes["dynamic"], path)
    elif isinstance(out, KinematicOutput):
        names.need_frame(out.frame, f"{path}.{out.quantity}")
        names.need_frame(out.in_frame, f"{path}.in")
        _check_symbols(out.point, names.scopes["kinematic"], f"{path}.point")
    elif isinstance(out, ForceOutput):
        _check_force_output(s, out, path)
    else:
        raise ModelError(f"not an output: {out!r}", path)


def _validate_constraints(s: System, names: _Names) -> None:
    kinematic = names.scopes["kinematic"]
    used: dict[str, str] = {}
    for con in s.constraints:
        path = f"constraints.{con.name}"
        if isinstance(con, ExpressionConstraint):
            _check_symbols(con.expr, kinematic, path)
        elif isinstance(con, CoincidenceConstraint):
            names.need_frame(con.frame_a, f"{path}.coincide[0]")
            names.need_frame(con.frame_b, f"{path}.coincide[1]")
            names.need_frame(con.in_frame, f"{path}.in")
            _check_symbols(con.point_a, kinematic, f"{path}.points[0]")
            _check_symbols(con.point_b, kinematic, f"{path}.points[1]")
        else:
            raise ModelError(f"not a constraint: {con!r}", path)
        for n in con.names:
            if n in used:
                raise ModelError(f"constraint name {n!r} is already used by {used[n]}", path)
            used[n] = path


def _check_force_output(s: System, out: ForceOutput, path: str) -> None:
    forces = {f.name: f for f in s.forces}
    if out.force not in forces:
        raise ModelError(
            f"unknown force element {out.force!r}; force elements are: "
            f"{', '.join(sorted(forces)) or '(none)'}",
            f"{path}.force",
        )
    kind = type(forces[out.force])
    valid = kind.components
    if out.component not in valid:
        raise ModelError(
            f"a {kind.__name__} element reports the component(s) {', '.join(valid) or '(none)'}, "
            f"not {out.component!r}",
            f"{path}.component",
        )


def _input_rate_orders(s: System) -> dict[str, int]:
    """See :attr:`System.input_rate_orders`."""
    inputs = {u.symbol: u.name for u in s.inputs}
    orders = dict.fromkeys(inputs.values(), 0)
    if not inputs:
        return orders
    kinematic: list[sp.Basic] = []
    for f in s.frames:
        kinematic.append(f.translation)
        kinematic.extend(a for _, a in f.rotation)
    for fe in s.forces:
        kinematic.extend(v for _, v, key in fe.expressions() if key.scope == "kinematic")
    for item in (*s.outputs, *s.constraints):
        for attr in ("point", "point_a", "point_b", "expr"):
            value = getattr(item, attr, None)
            if isinstance(value, sp.Basic) and (attr != "expr" or isinstance(item, Constraint)):
                kinematic.append(value)
    for expr in kinematic:
        for sym in expr.free_symbols & set(inputs):
            orders[inputs[sym]] = 2
    rate_symbols = {
        symbol(input_rate_name(name, k)): (name, k) for name in inputs.values() for k in (1, 2)
    }
    for expr in iter_expressions(s):
        for sym in expr.free_symbols & set(rate_symbols):
            name, k = rate_symbols[sym]
            orders[name] = max(orders[name], k)
    return orders


def _exact(x: float) -> str:
    """``x`` with as many digits as it takes to tell it from any other float (``:g`` when
    that is exact, else the shortest round-trip form: ``1000.0000000000001``)."""
    short = format(x, "g")
    return short if float(short) == x else repr(float(x))


def _validate_losses(s: System, constant: Mapping[str, sp.Symbol]) -> None:
    """``loss_reference_frequency`` a positive finite number; every ``loss_factor`` uses
    parameters only and is finite and ≥ 0 at the parameter defaults; every elastic body with
    a hysteretic matrix has the model's reference frequency (equations.md §1.1)."""
    f = s.loss_reference_frequency
    if (isinstance(f, bool) or not isinstance(f, int | float) or not math.isfinite(f)
            or f <= 0):
        raise ModelError(f"the loss reference frequency must be a positive number of Hz, got "
                         f"{f!r}", "loss_reference_frequency")
    object.__setattr__(s, "loss_reference_frequency", float(f))
    defaults = {p.symbol: p.default for p in s.parameters}
    for fe in s.forces:
        for where, eta in (e for k in type(fe).keys if k.kind == "loss_factor"
                           for e in fe.entries(k)):
            if eta == 0:
                continue
            _check_symbols(eta, constant, where)
            value = _numeric(eta, defaults)  # type: ignore[arg-type]
            if value is None or not math.isfinite(value) or value < 0:  # type: ignore[arg-type]
                got = eta if value is None else value
                raise ModelError(f"a loss factor is a finite number ≥ 0, got {got} at the "
                                 "parameter defaults", where)
    if not s.elastic_bodies:
        return
    from ..ffrf.schema import loss_reference_frequency  # NumPy: elastic models only

    for e in s.elastic_bodies:
        for i, data in enumerate(e.samples or (e.data,)):
            own = loss_reference_frequency(data)
            if own is not None and own != s.loss_reference_frequency:
                where = f" (sample {i + 1})" if e.samples else ""
                raise ModelError(
                    f"the body's data{where} hold loss factors for f_ref = {_exact(own)} Hz, "
                    f"the model's loss_reference_frequency is "
                    f"{_exact(s.loss_reference_frequency)} Hz "
                    "(set loss_reference_frequency to the body's)", f"elastic_bodies.{e.name}")


def _validate_elastic(s: System, frames: set[str], seen: Mapping[str, str]) -> None:
    """Elastic bodies: reference frame known, coordinates and node frames present."""
    coords = {c.name for c in s.coordinates}
    for e in s.elastic_bodies:
        path = f"elastic_bodies.{e.name}"
        if not isinstance(e, ElasticBody):
            raise ModelError(f"expected an ElasticBody, got {type(e).__name__}", path)
        if e.name in seen:
            raise ModelError(f"name {e.name!r} is already used in {seen[e.name]}", path)
        if e.frame not in frames:
            usable = sorted(f for f in frames if not _hangs_on(s, f, f"{e.name}."))
            raise ModelError(
                f"unknown frame {e.frame!r}; frames are: {', '.join(usable)}",
                f"{path}.frame",
            )
        for c in (*e.coordinate_names, *e.all_node_coordinate_names):
            if c not in coords:
                raise ModelError(f"the elastic coordinate {c!r} is not a coordinate", path)
        for label, _node in e.nodes:
            if e.node_frame_name(label) not in frames:
                raise ModelError(f"the node frame {e.node_frame_name(label)!r} is missing",
                                 f"{path}.nodes.{label}")
        if _hangs_on(s, e.frame, f"{e.name}."):
            raise ModelError("the reference frame cannot hang on the body's own nodes",
                             f"{path}.frame")
    _validate_schedules(s)


def _validate_schedules(s: System) -> None:
    """A schedule may use parameters, inputs, ``t`` and the coordinates of the symbolic part,
    but no elastic or node coordinate (they follow from the schedule itself)."""
    elastic = {symbol(c): e.name for e in s.elastic_bodies
               for c in (*e.coordinate_names, *e.all_node_coordinate_names)}
    for e in s.elastic_bodies:
        if e.schedule is None:
            continue
        used = sorted(str(c) for c in e.schedule.free_symbols if c in elastic)
        if used:
            raise ModelError(f"a schedule cannot use elastic or node coordinates "
                             f"({', '.join(used)}): they depend on the schedule",
                             f"elastic_bodies.{e.name}.schedule")


def _hangs_on(s: System, frame: str, prefix: str) -> bool:
    """Whether ``frame`` or one of its ancestors is named ``prefix…`` (a node frame of the
    elastic body ``prefix[:-1]``): such frames cannot carry that body."""
    parent = {f.name: f.parent for f in s.frames}
    name, hops = frame, 0
    while name != INERTIAL and name in parent and hops <= len(parent):
        if name.startswith(prefix):
            return True
        name, hops = parent[name], hops + 1
    return False


def _validate_frames(s: System, allowed: Mapping[str, sp.Symbol]) -> None:
    names = {f.name for f in s.frames}
    for f in s.frames:
        path = f"frames.{f.name}"
        if f.parent != INERTIAL and f.parent not in names:
            raise ModelError(
                f"unknown parent frame {f.parent!r}; frames are: "
                f"{', '.join(sorted(names | {INERTIAL}))}",
                f"{path}.parent",
            )
        _check_symbols(f.translation, allowed, f"{path}.translation")
        for i, (_axis, angle) in enumerate(f.rotation):
            _check_symbols(angle, allowed, f"{path}.rotation[{i}][1]")
    parent = {f.name: f.parent for f in s.frames}
    for f in s.frames:
        seen = [f.name]
        name = f.parent
        while name != INERTIAL:
            if name in seen:
                cycle = " -> ".join([*seen[seen.index(name):], name])
                raise ModelError(f"frame cycle: {cycle}", f"frames.{f.name}.parent")
            seen.append(name)
            name = parent[name]


def _check_symbols(expr: object, allowed: Mapping[str, sp.Symbol], path: str) -> None:
    if not isinstance(expr, sp.Basic):
        raise ModelError(f"expected a sympy expression, got {type(expr).__name__}", path)
    allowed_symbols = set(allowed.values())
    for sym in sorted(expr.free_symbols, key=str):
        if sym not in allowed_symbols:
            raise ModelError(
                f"unknown name {str(sym)!r} here; allowed names are: "
                f"{', '.join(sorted(allowed)) or '(none)'}",
                path,
            )


def _numeric(expr: sp.Basic, defaults: Mapping[sp.Symbol, float]) -> object:
    """Value of a constant expression at the parameter defaults (a float, or rows of floats
    for a matrix), or None if not numeric. The defaults replace the symbols all at once
    (``xreplace``; ``subs`` orders the pairs and rebuilds the expression once per pair, and
    was most of the time of loading a description)."""
    try:   # only the expression's own symbols (a model may have thousands of parameters)
        values = {k: sp.Float(float(defaults[k])) for k in expr.free_symbols if k in defaults}
        value = expr.xreplace(values)
        if isinstance(value, sp.MatrixBase):
            return [[float(v) for v in row] for row in value.tolist()]
        return float(value)
    except (TypeError, ValueError):
        return None


def symmetric_eigenvalues3(a: Sequence[Sequence[float]]) -> tuple[float, float, float]:
    """Eigenvalues of a symmetric 3 × 3 matrix, ascending, by cyclic Jacobi rotations.

    Each rotation ``(p, r)`` with ``θ = (a_rr − a_pp) / (2 a_pr)``,
    ``t = sgn θ / (|θ| + √(θ² + 1))`` zeroes ``a_pr`` (Golub & Van Loan, *Matrix
    Computations*, §8.5): ``a_pp −= t a_pr``, ``a_rr += t a_pr`` and the third row turns by
    ``c = 1/√(t² + 1)``, ``s = t c``. Plain Python: checking an inertia tensor needs no NumPy.
    A diagonal matrix gives its diagonal exactly; otherwise the rotations stop when the
    off-diagonal part is below the rounding of the diagonal (a few sweeps); the matrix is
    scaled by a power of two first, so no square overflows.
    """
    largest = max(abs(float(v)) for row in a for v in row)
    e = math.frexp(largest)[1]  # a · 2⁻ᵉ is exact and below 1: no square overflows
    m = [[math.ldexp(float(a[i][j]), -e) for j in range(3)] for i in range(3)]
    for _ in range(50):
        off = m[0][1] ** 2 + m[0][2] ** 2 + m[1][2] ** 2
        if off <= 1e-40 * (m[0][0] ** 2 + m[1][1] ** 2 + m[2][2] ** 2) or off == 0.0:
            break
        for p, r in ((0, 1), (0, 2), (1, 2)):
            apr = m[p][r]
            if apr == 0.0:
                continue
            theta = (m[r][r] - m[p][p]) / (2.0 * apr)
            t = math.copysign(1.0, theta) / (abs(theta) + math.hypot(theta, 1.0))
            c = 1.0 / math.hypot(t, 1.0)
            sn = t * c
            k = 3 - p - r  # the third index
            akp, akr = m[k][p], m[k][r]
            m[k][p] = m[p][k] = c * akp - sn * akr
            m[k][r] = m[r][k] = sn * akp + c * akr
            m[p][p] -= t * apr
            m[r][r] += t * apr
            m[p][r] = m[r][p] = 0.0
    d = sorted(math.ldexp(m[i][i], e) for i in range(3))
    return d[0], d[1], d[2]


def _check_inertia(inertia: Sequence[Sequence[float]], path: str) -> None:
    """A physical inertia tensor is symmetric positive semidefinite and its principal
    moments satisfy the triangle inequality (I1 ≤ I2 + I3)."""
    entries = [v for row in inertia for v in row]
    if not all(math.isfinite(v) for v in entries):
        raise ModelError("inertia is not finite", path)
    size = max(abs(v) for v in entries) or 1.0  # scaled: 1e308 entries must not overflow
    scaled = symmetric_eigenvalues3([[0.5 * (inertia[i][j] / size + inertia[j][i] / size)
                                      for j in range(3)] for i in range(3)])
    moments = [size * v for v in scaled]
    largest = max(abs(v) for v in scaled)
    if scaled[0] < -1e-12 * max(largest, 1e-300):
        raise ModelError(
            f"inertia must be positive semidefinite; principal moments are "
            f"{', '.join(f'{m:g}' for m in moments)}",
            path,
        )
    if scaled[2] > scaled[0] + scaled[1] + 1e-9 * largest:
        raise ModelError(
            f"principal moments {', '.join(f'{m:g}' for m in moments)} violate the triangle "
            "inequality I3 ≤ I1 + I2 (no real body has them)",
            path,
        )


def iter_expressions(system: System) -> Iterable[sp.Basic]:
    """All sympy expressions of a system (for tests and fingerprints)."""
    yield system.gravity
    for group in (
        system.frames,
        system.bodies,
        system.forces,
        system.outputs,
        system.inputs,
        system.constraints,
    ):
        for item in group:
            for f in fields(item):
                v = getattr(item, f.name)
                if isinstance(v, sp.Basic):
                    yield v
                elif f.name == "rotation":
                    yield from (a for _, a in v)
