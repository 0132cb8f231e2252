"""Force elements and outputs (equations.md §1, "Force elements contribute through the
Jacobians of their points of action") against hand-derived results.

References: for a planar double pendulum the positions of points are written by hand,
``J_P = ∂r_P/∂y`` by sympy's ``diff``; a point force adds ``J_Pᵀ f``; a torque about z adds
its value to every angle it turns; a spring–damper adds ``−F ∂s/∂y`` with
``F = k (s − L) + d ṡ``; a particle on a spring to the origin has ``q = −F e``. Each is checked
in closed and recursive form at random states.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
import sympy as sp
from kane_systems import double_pendulum as _double_pendulum
from kane_systems import numeric_equations, rel_err

from neweul_py.equations import newton_euler
from neweul_py.model import (
    Coordinate,
    ExpressionOutput,
    Frame,
    GeneralizedForce,
    Input,
    KinematicOutput,
    Parameter,
    PointForce,
    RigidBody,
    SpringDamper,
    System,
    Torque,
    symbol,
    time,
)

FORMS = ["closed", "recursive"]
double_pendulum = functools.cache(_double_pendulum)


def _rz(q):
    return sp.Matrix([[sp.cos(q), -sp.sin(q), 0], [sp.sin(q), sp.cos(q), 0], [0, 0, 1]])


def _with(system: System, **changes) -> System:
    fields = {f: getattr(system, f) for f in system.__dataclass_fields__}
    fields.update(changes)
    return System(**fields)


def _compile(exprs, system):
    args = [list(system.coordinate_symbols), list(system.velocity_symbols),
            list(system.parameter_symbols), time, list(system.input_symbols)]
    fn = sp.lambdify(args, exprs)

    def call(y, yd, p, t, u=()):
        return np.asarray(fn(list(y), list(yd), list(p), t, list(u)), float).ravel()

    return call


@pytest.mark.parametrize("form", FORMS)
def test_particle_on_spring_damper(form: str) -> None:
    """Particle at (x, y) with a spring–damper to ISYS's origin: M = m I, q = −F (x, y)/s."""
    m, k, d, length = (symbol(n) for n in ("m", "k", "d", "L"))
    x, y = symbol("x"), symbol("y")
    system = System(
        "particle",
        coordinates=(Coordinate("x"), Coordinate("y")),
        parameters=(Parameter("m", 0.5), Parameter("k", 20.0), Parameter("d", 0.7),
                    Parameter("L", 0.4)),
        frames=(Frame("pos", translation=sp.ImmutableMatrix([x, y, 0])),),
        bodies=(RigidBody("mass", "pos", m),),
        forces=(SpringDamper("spring", "ISYS", "pos", k, d, length),),
    )
    eq = newton_euler(system, form=form)
    f = numeric_equations(eq)
    rng = np.random.default_rng(1)
    for _ in range(20):
        q, qd = rng.uniform(-2, 2, 2), rng.uniform(-2, 2, 2)
        pv = np.array([0.5, 20.0, 0.7, 0.4]) * rng.uniform(0.5, 1.5, 4)
        mm, fv, _ = f(q, qd, pv, 0.0)
        s = np.hypot(*q)
        sdot = q @ qd / s
        force = pv[1] * (s - pv[3]) + pv[2] * sdot
        np.testing.assert_allclose(mm, pv[0] * np.eye(2), rtol=1e-13)
        np.testing.assert_allclose(fv, -force * q / s, rtol=1e-12)


def _pendulum_forces(kane: bool = True) -> tuple[System, sp.Matrix, sp.Matrix]:
    """The double pendulum plus a point force (ISYS comps) and a force in link1 comps at a
    point of link2, a torque about ISYS z on link2, a spring–damper between points of both
    links, a generalized force with an input. Returns the system and the hand-derived
    generalized force to add to the plain pendulum's q − k."""
    base = (double_pendulum() if kane else _double_pendulum(kane=False)).system
    a, b = symbol("a"), symbol("b")
    l1 = symbol("l1")
    fx, fy, px, py, tq, k, dd, ln, sa, sb = (
        symbol(n) for n in ("fx", "fy", "px", "py", "tq", "k", "dd", "ln", "sa", "sb")
    )
    u = symbol("u")
    extra = tuple(
        Parameter(n, v) for n, v in (("fx", 1.2), ("fy", -0.4), ("px", 0.3), ("py", 0.2),
                                     ("tq", 0.8), ("k", 30.0), ("dd", 0.9), ("ln", 0.5),
                                     ("sa", 0.6), ("sb", 0.35))
    )
    point = sp.ImmutableMatrix([px, py, 0])
    system = _with(
        base,
        parameters=base.parameters + extra,
        inputs=(Input("u", sp.sin(time)),),
        forces=(
            PointForce("push", "link2", sp.ImmutableMatrix([fx, fy, 0]), point),
            PointForce("push_local", "link2", sp.ImmutableMatrix([fy * u, 0, 0]), point,
                       in_frame="link1"),
            Torque("motor", "link2", sp.ImmutableMatrix([0, 0, tq])),
            SpringDamper("spring", "link1", "link2", k, dd, ln,
                         point_a=sp.ImmutableMatrix([sa, 0, 0]),
                         point_b=sp.ImmutableMatrix([sb, 0, 0])),
            GeneralizedForce("drive", "a", u * tq),
        ),
        outputs=(
            ExpressionOutput("energy_like", a**2 + symbol("d_b") * u),
            KinematicOutput("tip_x", "position", "link2", "x", point),
            KinematicOutput("tip_vy_local", "velocity", "link2", "y", point, in_frame="link1"),
        ),
    )
    ys = sp.Matrix([a, b])
    yds = sp.Matrix(system.velocity_symbols)
    r_p = _rz(a) * sp.Matrix([l1, 0, 0]) + _rz(a) * _rz(b) * sp.Matrix(point)
    jp = r_p.jacobian(ys)
    q = jp.T * sp.Matrix([fx, fy, 0]) + jp.T * (_rz(a) * sp.Matrix([fy * u, 0, 0]))
    q += sp.Matrix([tq, tq])  # ω of link2 is (ȧ + ḃ) e_z
    r_a = _rz(a) * sp.Matrix([sa, 0, 0])
    r_b = _rz(a) * sp.Matrix([l1, 0, 0]) + _rz(a) * _rz(b) * sp.Matrix([sb, 0, 0])
    dist = sp.sqrt(((r_b - r_a).T * (r_b - r_a))[0])
    ds = sp.Matrix([dist]).jacobian(ys)
    force = k * (dist - ln) + dd * (ds * yds)[0]
    q += -force * ds.T
    q += sp.Matrix([u * tq, 0])
    outputs = sp.Matrix([a**2 + symbol("d_b") * u, r_p[0],
                         (_rz(a).T * (jp * yds))[1]])
    return system, q, outputs


@pytest.mark.parametrize("form", FORMS)
def test_point_force_torque_spring_generalized_and_outputs(form: str) -> None:
    ref = double_pendulum()
    system, q_hand, out_hand = _pendulum_forces()
    plain = numeric_equations(newton_euler(ref.system, form=form))
    full = numeric_equations(newton_euler(system, form=form))
    q_fn, out_fn = _compile(q_hand, system), _compile(out_hand, system)
    rng = np.random.default_rng(11)
    n_base = len(ref.system.parameters)
    for _ in range(20):
        y, yd = rng.uniform(-np.pi, np.pi, 2), rng.uniform(-3, 3, 2)
        p = np.array([x.default for x in system.parameters]) * rng.uniform(0.8, 1.2,
                                                                            len(system.parameters))
        t, u = rng.uniform(0, 5), rng.uniform(-1, 1, 1)
        m0, f0, _ = plain(y, yd, p[:n_base], t)
        m1, f1, o1 = full(y, yd, p, t, u)
        assert rel_err(m1, m0) == 0.0
        assert rel_err(f1 - f0, q_fn(y, yd, p, t, u)) <= 1e-10
        assert rel_err(o1, out_fn(y, yd, p, t, u)) <= 1e-10
