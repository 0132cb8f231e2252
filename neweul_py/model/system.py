"""The :class:`System`: a validated, immutable multibody model."""

from __future__ import annotations

import hashlib
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, fields
from functools import cached_property

import numpy as np
import sympy as sp

from ..errors import ModelError
from .elements import (
    Coordinate,
    ExpressionOutput,
    ForceElement,
    Frame,
    GeneralizedForce,
    Input,
    KinematicOutput,
    Output,
    Parameter,
    PointForce,
    RigidBody,
    SpringDamper,
    Torque,
)
from .symbols import INERTIAL, check_name, time, velocity_name

__all__ = ["System"]


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

    @property
    def input_symbols(self) -> tuple[sp.Symbol, ...]:
        return tuple(u.symbol for u in self.inputs)

    @property
    def parameter_defaults(self) -> dict[sp.Symbol, float]:
        return {p.symbol: p.default for p in self.parameters}

    def fingerprint(self) -> str:
        """A SHA-256 of a canonical text of the whole model: equal models, equal fingerprints.

        Used to cache derived results by content.
        """
        return hashlib.sha256(sp.srepr(_canonical(self)).encode()).hexdigest()


# ---------------------------------------------------------------------- validation
def _canonical(system: System) -> tuple:
    return tuple(
        (f.name, repr(getattr(system, f.name))) for f in fields(system)
    )


def _validate(s: System) -> None:
    if check_name(s.name) is not None:
        raise ModelError(f"model name: {check_name(s.name)}", "name")
    seen: dict[str, str] = {}
    groups = (
        ("parameters", s.parameters),
        ("coordinates", s.coordinates),
        ("inputs", s.inputs),
        ("frames", s.frames),
        ("bodies", s.bodies),
        ("forces", s.forces),
        ("outputs", s.outputs),
    )
    for group, items in groups:
        for item in items:
            path = f"{group}.{item.name}"
            why = check_name(item.name)
            if why is not None:
                raise ModelError(why, path)
            if item.name in seen:
                raise ModelError(f"name {item.name!r} is already used in {seen[item.name]}", path)
            seen[item.name] = group

    for p in s.parameters:
        if (
            isinstance(p.default, bool)
            or not isinstance(p.default, int | float)
            or not math.isfinite(p.default)
        ):
            raise ModelError(
                f"default must be a finite number, got {p.default!r}", f"parameters.{p.name}"
            )
    for c in s.coordinates:
        for attr in ("initial", "velocity"):
            v = getattr(c, attr)
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise ModelError(
                    f"{attr} value must be a finite number, got {v!r}", f"coordinates.{c.name}"
                )

    par = {p.name: p.symbol for p in s.parameters}
    crd = {c.name: c.symbol for c in s.coordinates}
    vel = {velocity_name(c.name): c.velocity_symbol for c in s.coordinates}
    inp = {u.name: u.symbol for u in s.inputs}
    tt = {"t": time}
    constant = par
    kinematic = {**par, **crd, **inp, **tt}
    dynamic = {**kinematic, **vel}

    _check_symbols(s.gravity, constant, "gravity")
    for u in s.inputs:
        _check_symbols(u.default, {**par, **tt}, f"inputs.{u.name}")

    _validate_frames(s, kinematic)
    frames = {INERTIAL, *s.frame_map}

    def need_frame(name: str, path: str) -> None:
        if name not in frames:
            raise ModelError(
                f"unknown frame {name!r}; frames are: {', '.join(sorted(frames))}", path
            )

    defaults = {p.symbol: p.default for p in s.parameters}
    for b in s.bodies:
        path = f"bodies.{b.name}"
        need_frame(b.frame, f"{path}.frame")
        _check_symbols(b.mass, constant, f"{path}.mass")
        _check_symbols(b.center_of_mass, constant, f"{path}.center_of_mass")
        _check_symbols(b.inertia, constant, f"{path}.inertia")
        mass = _numeric(b.mass, defaults)
        if mass is not None and mass < 0:
            raise ModelError(f"mass must not be negative (it is {mass:g})", f"{path}.mass")
        inertia = _numeric(b.inertia, defaults)
        if inertia is not None:
            _check_inertia(np.asarray(inertia, dtype=float), f"{path}.inertia")

    coordinates = set(crd)
    for fe in s.forces:
        path = f"forces.{fe.name}"
        if isinstance(fe, PointForce):
            need_frame(fe.frame, f"{path}.frame")
            need_frame(fe.in_frame, f"{path}.in")
            _check_symbols(fe.point, kinematic, f"{path}.point")
            _check_symbols(fe.vector, dynamic, f"{path}.vector")
        elif isinstance(fe, Torque):
            need_frame(fe.frame, f"{path}.frame")
            need_frame(fe.in_frame, f"{path}.in")
            _check_symbols(fe.vector, dynamic, f"{path}.vector")
        elif isinstance(fe, GeneralizedForce):
            if fe.coordinate not in coordinates:
                raise ModelError(
                    f"unknown coordinate {fe.coordinate!r}; coordinates are: "
                    f"{', '.join(sorted(coordinates)) or '(none)'}",
                    f"{path}.coordinate",
                )
            _check_symbols(fe.value, dynamic, f"{path}.value")
        elif isinstance(fe, SpringDamper):
            need_frame(fe.frame_a, f"{path}.between[0]")
            need_frame(fe.frame_b, f"{path}.between[1]")
            _check_symbols(fe.point_a, kinematic, f"{path}.points[0]")
            _check_symbols(fe.point_b, kinematic, f"{path}.points[1]")
            for attr in ("stiffness", "damping", "length"):
                _check_symbols(getattr(fe, attr), dynamic, f"{path}.{attr}")
        elif not isinstance(fe, ForceElement):
            raise ModelError(f"not a force element: {fe!r}", path)

    for out in s.outputs:
        path = f"outputs.{out.name}"
        if isinstance(out, ExpressionOutput):
            _check_symbols(out.expr, dynamic, path)
        elif isinstance(out, KinematicOutput):
            need_frame(out.frame, f"{path}.{out.quantity}")
            need_frame(out.in_frame, f"{path}.in")
            _check_symbols(out.point, kinematic, f"{path}.point")
        else:
            raise ModelError(f"not an output: {out!r}", path)


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
    """Value of a constant expression at the parameter defaults, or None if not numeric."""
    try:
        value = expr.subs(defaults)
        if isinstance(value, sp.MatrixBase):
            return np.array(value.evalf(), dtype=float)
        return float(value)
    except (TypeError, ValueError):
        return None


def _check_inertia(inertia: np.ndarray, path: str) -> None:
    """A physical inertia tensor is symmetric positive semidefinite and its principal
    moments satisfy the triangle inequality (I1 ≤ I2 + I3)."""
    if not np.all(np.isfinite(inertia)):
        raise ModelError("inertia is not finite", path)
    moments = np.linalg.eigvalsh(0.5 * (inertia + inertia.T))
    scale = max(float(np.max(np.abs(moments))), 1e-300)
    if moments[0] < -1e-12 * scale:
        raise ModelError(
            f"inertia must be positive semidefinite; principal moments are "
            f"{', '.join(f'{m:g}' for m in moments)}",
            path,
        )
    if moments[2] > moments[0] + moments[1] + 1e-9 * scale:
        raise ModelError(
            f"principal moments {', '.join(f'{m:g}' for m in moments)} violate the triangle "
            "inequality I3 ≤ I1 + I2 (no real body has them)",
            path,
        )


def iter_expressions(system: System) -> Iterable[sp.Basic]:
    """All sympy expressions of a system (for tests and fingerprints)."""
    yield system.gravity
    for group in (system.frames, system.bodies, system.forces, system.outputs, system.inputs):
        for item in group:
            for f in fields(item):
                v = getattr(item, f.name)
                if isinstance(v, sp.Basic):
                    yield v
