"""The Python builder API: values in all accepted forms, scopes of names, key paths of errors.
Reference: the model objects of ``neweul_py.model`` built by hand."""

from __future__ import annotations

import pytest
import sympy as sp

from neweul_py.description import SystemBuilder
from neweul_py.errors import ModelError
from neweul_py.model import (
    ExpressionOutput,
    GeneralizedForce,
    KinematicOutput,
    PointForce,
    SpringDamper,
    Torque,
    symbol,
    time,
)

m, l, g, phi, d_phi, u = (symbol(n) for n in ("m", "l", "g", "phi", "d_phi", "u"))


def pendulum() -> SystemBuilder:
    b = SystemBuilder("pendulum", "a test")
    b.parameter("m", 1.0)
    b.parameter("l", "0.5")
    b.parameter("g", 9.81)
    b.coordinate("phi", initial=0.1, velocity="-0.2")
    b.gravity([0, 0, "-g"])
    b.frame("arm", rotation=[["y", "phi"]])
    b.body("bob", frame="arm", mass="m", center_of_mass=[0, 0, "-l"],
           inertia={"diag": [0, 0, 0]})
    return b


def test_builds_the_expected_model() -> None:
    b = pendulum()
    b.input("u", "sin(2*pi*t)")
    b.generalized_force("drive", "phi", "u - 0.1*d_phi")
    b.force("push", "arm", ["u", 0, 0], point=[0, 0, "-l"])
    b.torque("twist", "arm", [0, "-d_phi", 0], in_="arm")
    b.spring_damper("spring", ["ISYS", "arm"], [[0, 0, 0], [0, 0, "-l"]], stiffness=10,
                    damping="0.5", length="l")
    b.output("energy", "m*l**2*d_phi**2/2")
    b.kinematic_output("tip", "velocity", "arm", point=[0, 0, "-l"], component="z")
    s = b.build()

    assert s.name == "pendulum" and s.description == "a test"
    assert [(p.name, p.default) for p in s.parameters] == [("m", 1.0), ("l", 0.5), ("g", 9.81)]
    assert (s.coordinates[0].initial, s.coordinates[0].velocity) == (0.1, -0.2)
    assert s.gravity == sp.ImmutableMatrix([0, 0, -g])
    assert s.inputs[0].default == sp.sin(2 * sp.pi * time)
    assert s.frames[0].rotation == (("y", phi),)
    body = s.bodies[0]
    assert body.mass == m and body.center_of_mass == sp.ImmutableMatrix([0, 0, -l])
    assert body.inertia == sp.zeros(3, 3)
    drive, push, twist, spring = s.forces
    assert isinstance(drive, GeneralizedForce) and drive.value == u - d_phi / 10
    assert isinstance(push, PointForce) and push.vector == sp.ImmutableMatrix([u, 0, 0])
    assert push.in_frame == "ISYS" and push.point == sp.ImmutableMatrix([0, 0, -l])
    assert isinstance(twist, Torque) and twist.in_frame == "arm"
    assert isinstance(spring, SpringDamper)
    assert (spring.stiffness, spring.damping, spring.length) == (10, sp.Rational(1, 2), l)
    assert spring.point_b == sp.ImmutableMatrix([0, 0, -l])
    energy, tip = s.outputs
    assert isinstance(energy, ExpressionOutput) and energy.expr == m * l**2 * d_phi**2 / 2
    assert isinstance(tip, KinematicOutput)
    assert (tip.quantity, tip.frame, tip.component) == ("velocity", "arm", "z")


def test_sympy_values_and_returned_symbols() -> None:
    """Symbols returned by the builder, and plain sympy symbols of the same name, are the
    model's (real) symbols."""
    b = SystemBuilder("s")
    mass = b.parameter("m", 2)
    q = b.coordinate("q")
    b.frame("f", translation=[q, 0, 0])
    b.body("b", "f", mass=sp.Symbol("m") * 2, inertia=sp.eye(3) * mass)
    b.generalized_force("k", "q", -3 * q - b.velocity("q"))
    s = b.build()
    assert s.bodies[0].mass == 2 * m
    assert s.bodies[0].mass.free_symbols == {mass}
    assert s.forces[0].value == -3 * symbol("q") - symbol("d_q")


def test_frames_may_be_declared_before_their_parents() -> None:
    b = SystemBuilder("s")
    b.frame("child", parent="parent", translation=[0, 0, 1])
    b.frame("parent")
    s = b.build()
    assert [f.name for f in s.frames_topological] == ["parent", "child"]


def test_names_may_be_used_before_they_are_declared() -> None:
    b = SystemBuilder("s")
    b.frame("f", rotation=[["z", "q"]])
    b.coordinate("q")
    assert b.build().frames[0].rotation == (("z", symbol("q")),)


@pytest.mark.parametrize(
    ("add", "path", "message"),
    [
        (lambda b: b.body("x", "arm", "m*phi"), "bodies.x.mass", "'phi' is a coordinate"),
        (lambda b: b.body("x", "arm", "m", inertia=[[1, 0, 0], [0, 1, 0], [0, "u", 1]]),
         "bodies.x.inertia[2][1]", "unknown name 'u'"),
        (lambda b: b.body("x", "arm", "m", inertia={"diag": [1, 1, "d_phi"]}),
         "bodies.x.inertia.diag[2]", "'d_phi' is a velocity"),
        (lambda b: b.frame("f", translation=[0, "d_phi", 0]), "frames.f.translation[1]",
         "'d_phi' is a velocity"),
        (lambda b: b.input("v", "phi"), "inputs.v", "'phi' is a coordinate"),
        (lambda b: b.gravity([0, 0, "-g*t"]), "gravity[2]", "'t' is the time"),
        (lambda b: b.output("o", "bob"), "outputs.o", "'bob' is a body"),
        (lambda b: b.body("x", "arm", "m", inertia=[[1, 0.1, 0], [0, 1, 0], [0, 0, 1]]),
         "bodies.x.inertia[0][1]", "symmetric"),
        (lambda b: b.body("x", "arm", "-m"), "bodies.x.mass", "negative"),
        (lambda b: b.body("x", "nowhere", "m"), "bodies.x.frame", "unknown frame 'nowhere'"),
    ],
)
def test_build_errors_carry_key_paths(add, path: str, message: str) -> None:
    b = pendulum()
    add(b)
    with pytest.raises(ModelError) as info:
        b.build()
    assert info.value.key_path == path
    assert message in str(info.value)


@pytest.mark.parametrize(
    ("add", "path", "message"),
    [
        (lambda b: b.parameter("k", "abc"), "parameters.k", "must be a number"),
        (lambda b: b.parameter("k", True), "parameters.k", "must be a number"),
        (lambda b: b.parameter("k", float("inf")), "parameters.k", "finite"),
        (lambda b: b.parameter("k", [1]), "parameters.k", "must be a number"),
        (lambda b: b.parameter("sin", 1), "parameters.sin", "reserved"),
        (lambda b: b.parameter("m", 1), "parameters.m", "already used by a parameter"),
        (lambda b: b.coordinate("d_x"), "coordinates.d_x", "reserved for velocities"),
        (lambda b: b.coordinate("q", velocity="fast"), "coordinates.q.velocity", "number"),
        (lambda b: b.frame("f", translation=[0, 0]), "frames.f.translation", "3 expressions"),
        (lambda b: b.frame("f", rotation=["x", "phi"]), "frames.f.rotation[0]",
         "[[axis, angle]]"),
        (lambda b: b.frame("f", rotation=[["w", "phi"]]), "frames.f.rotation[0][0]",
         "x, y, z"),
        (lambda b: b.body("x", "arm", "m", inertia=[[1, 0, 0], [0, 1, 0]]), "bodies.x.inertia",
         "3×3"),
        (lambda b: b.body("x", "arm", "m", inertia={"dia": [1, 1, 1]}), "bodies.x.inertia.dia",
         "unknown key"),
        (lambda b: b.force("x", "arm", [1, 2, 3, 4]), "forces.x.vector", "3 expressions"),
        (lambda b: b.spring_damper("x", ["arm"], stiffness=1), "forces.x.between",
         "two frame names"),
        (lambda b: b.kinematic_output("x", "speed", "arm"), "outputs.x", "'position' or"),
        (lambda b: b.kinematic_output("x", "position", "arm", component="w"),
         "outputs.x.component", "x, y, z"),
    ],
)
def test_immediate_errors_carry_key_paths(add, path: str, message: str) -> None:
    with pytest.raises(ModelError) as info:
        add(pendulum())
    assert info.value.key_path == path
    assert message in str(info.value)
