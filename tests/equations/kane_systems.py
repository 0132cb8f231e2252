"""Reference systems built twice: as neweul-py models and, by hand, with
``sympy.physics.mechanics`` (ReferenceFrame, Point, RigidBody, Particle, KanesMethod).

Kane's generalized speeds are chosen ``u = q̇`` so that Kane's ``mass_matrix`` and ``forcing``
equal our ``M`` and ``q − k`` exactly (both are Jourdain projections with the same partial
velocities), not only up to a regular transformation.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import sympy as sp
import sympy.physics.mechanics as me

from neweul_py.equations import Equations
from neweul_py.model import (
    Coordinate,
    Frame,
    Parameter,
    RigidBody,
    SpringDamper,
    System,
    symbol,
    time,
)

T = me.dynamicsymbols._t


@dataclass
class Reference:
    """A model and its Kane counterpart in our symbols."""

    system: System
    mass_matrix: sp.Matrix  # Kane, in our symbols
    forcing: sp.Matrix


def _kane(
    name: str,
    n: int,
    build: Callable[[list, list, me.ReferenceFrame, me.Point], tuple[list, list]],
) -> tuple[sp.Matrix, sp.Matrix]:
    """Run KanesMethod with q̇ = u and translate to our symbols (coordinate names q0…)."""
    q = me.dynamicsymbols(f"{name}_q0:{n}")
    u = me.dynamicsymbols(f"{name}_u0:{n}")
    frame_n = me.ReferenceFrame("N")
    origin = me.Point("O")
    origin.set_vel(frame_n, 0)
    bodies, loads = build(q, u, frame_n, origin)
    kd = [qi.diff(T) - ui for qi, ui in zip(q, u, strict=True)]
    kane = me.KanesMethod(frame_n, q_ind=q, u_ind=u, kd_eqs=kd)
    kane.kanes_equations(bodies, loads)
    return kane.mass_matrix, kane.forcing, q, u  # type: ignore[return-value]


def _to_ours(exprs: sp.Matrix, q: list, u: list, names: list[str]) -> sp.Matrix:
    ud = [ui.diff(T) for ui in u]
    qd = [qi.diff(T) for qi in q]
    rep = {}
    rep.update({a: 0 for a in ud})
    rep.update({a: symbol(f"d_{nm}") for a, nm in zip(qd, names, strict=True)})
    rep.update({a: symbol(f"d_{nm}") for a, nm in zip(u, names, strict=True)})
    rep.update({a: symbol(nm) for a, nm in zip(q, names, strict=True)})
    rep[T] = time
    return exprs.xreplace(rep)  # exact node replacement: fast, derivatives matched first


def _orient(parent: me.ReferenceFrame, rotation: list[tuple[str, sp.Expr]], name: str):
    """Successive rotations about the current axes (child → parent: R_a1 R_a2 …)."""
    frame = parent
    for k, (axis, angle) in enumerate(rotation):
        child = me.ReferenceFrame(f"{name}{k}")
        child.orient_axis(frame, getattr(frame, axis), angle)
        frame = child
    return frame


def _vec(frame: me.ReferenceFrame, comps) -> me.Vector:
    return comps[0] * frame.x + comps[1] * frame.y + comps[2] * frame.z


# ------------------------------------------------------------------ double pendulum
def double_pendulum(kane: bool = True) -> Reference:
    """Planar double pendulum of two rods with inertia, rotating about z, gravity −y."""
    m1, m2, l1, c1, c2, i1, i2, g = (
        symbol(s) for s in ("m1", "m2", "l1", "c1", "c2", "i1", "i2", "g")
    )
    a, b = symbol("a"), symbol("b")
    params = (
        Parameter("m1", 1.3), Parameter("m2", 0.7), Parameter("l1", 1.1), Parameter("c1", 0.5),
        Parameter("c2", 0.4), Parameter("i1", 0.1), Parameter("i2", 0.05), Parameter("g", 9.81),
    )
    system = System(
        "double_pendulum",
        coordinates=(Coordinate("a"), Coordinate("b")),
        parameters=params,
        frames=(
            Frame("link1", rotation=(("z", a),)),
            Frame("link2", "link1", sp.ImmutableMatrix([l1, 0, 0]), (("z", b),)),
        ),
        bodies=(
            RigidBody("rod1", "link1", m1, sp.ImmutableMatrix([c1, 0, 0]),
                      sp.ImmutableMatrix(sp.diag(0, i1, i1))),
            RigidBody("rod2", "link2", m2, sp.ImmutableMatrix([c2, 0, 0]),
                      sp.ImmutableMatrix(sp.diag(0, i2, i2))),
        ),
        gravity=sp.ImmutableMatrix([0, -g, 0]),
    )

    def build(q, u, n, o):
        f1 = _orient(n, [("z", q[0])], "A")
        f2 = _orient(f1, [("z", q[1])], "B")
        p2 = o.locatenew("P2", l1 * f1.x)
        g1 = o.locatenew("G1", c1 * f1.x)
        g2 = p2.locatenew("G2", c2 * f2.x)
        for p in (g1, g2):
            p.set_vel(n, p.pos_from(o).dt(n))
        b1 = me.RigidBody("b1", g1, f1, m1, (me.inertia(f1, 0, i1, i1), g1))
        b2 = me.RigidBody("b2", g2, f2, m2, (me.inertia(f2, 0, i2, i2), g2))
        loads = [(g1, -m1 * g * n.y), (g2, -m2 * g * n.y)]
        return [b1, b2], loads

    if not kane:
        return Reference(system, None, None)  # type: ignore[arg-type]
    mm, fo, q, u = _kane("dp", 2, build)
    names = ["a", "b"]
    return Reference(system, _to_ours(mm, q, u, names), _to_ours(fo, q, u, names))


# ------------------------------------------------------------------ heavy symmetric top
def heavy_top() -> Reference:
    """Heavy symmetric top on a fixed point, Cardan angles x-y-z, gravity −z."""
    m, h, ia, ic, g = (symbol(s) for s in ("m", "h", "ia", "ic", "g"))
    al, be, ga = symbol("al"), symbol("be"), symbol("ga")
    system = System(
        "top",
        coordinates=(Coordinate("al"), Coordinate("be"), Coordinate("ga")),
        parameters=(Parameter("m", 2.0), Parameter("h", 0.3), Parameter("ia", 0.04),
                    Parameter("ic", 0.03), Parameter("g", 9.81)),
        frames=(Frame("top", rotation=(("x", al), ("y", be), ("z", ga))),),
        bodies=(RigidBody("body", "top", m, sp.ImmutableMatrix([0, 0, h]),
                          sp.ImmutableMatrix(sp.diag(ia, ia, ic))),),
        gravity=sp.ImmutableMatrix([0, 0, -g]),
    )

    def build(q, u, n, o):
        f = _orient(n, [("x", q[0]), ("y", q[1]), ("z", q[2])], "T")
        c = o.locatenew("C", h * f.z)
        c.set_vel(n, c.pos_from(o).dt(n))
        body = me.RigidBody("b", c, f, m, (me.inertia(f, ia, ia, ic), c))
        return [body], [(c, -m * g * n.z)]

    mm, fo, q, u = _kane("top", 3, build)
    names = ["al", "be", "ga"]
    return Reference(system, _to_ours(mm, q, u, names), _to_ours(fo, q, u, names))


# ------------------------------------------------------------------ cart, spring, pendulum
def cart_pendulum() -> Reference:
    """Cart on x with a spring–damper to a wall point, and a pendulum (point mass + rod
    inertia) hinged on the cart, gravity −y."""
    mc, mp, l, ip, k, c, l0, w, g = (
        symbol(s) for s in ("mc", "mp", "l", "ip", "k", "c", "l0", "w", "g")
    )
    x, ph = symbol("x"), symbol("ph")
    system = System(
        "cart_pendulum",
        coordinates=(Coordinate("x"), Coordinate("ph")),
        parameters=(Parameter("mc", 3.0), Parameter("mp", 0.8), Parameter("l", 0.6),
                    Parameter("ip", 0.02), Parameter("k", 40.0), Parameter("c", 1.5),
                    Parameter("l0", 0.9), Parameter("w", 1.2), Parameter("g", 9.81)),
        frames=(
            Frame("cart", translation=sp.ImmutableMatrix([x, 0, 0])),
            Frame("arm", "cart", rotation=(("z", ph),)),
        ),
        bodies=(
            RigidBody("cart_body", "cart", mc),
            RigidBody("bob", "arm", mp, sp.ImmutableMatrix([0, -l, 0]),
                      sp.ImmutableMatrix(sp.diag(ip, 0, ip))),
        ),
        forces=(
            SpringDamper("spring", "ISYS", "cart", k, c, l0,
                         point_a=sp.ImmutableMatrix([-w, 0, 0])),
        ),
        gravity=sp.ImmutableMatrix([0, -g, 0]),
    )

    def build(q, u, n, o):
        cart = o.locatenew("Cart", q[0] * n.x)
        cart.set_vel(n, u[0] * n.x)
        arm = _orient(n, [("z", q[1])], "P")
        bob = cart.locatenew("Bob", -l * arm.y)
        bob.set_vel(n, bob.pos_from(o).dt(n))
        b1 = me.Particle("cartp", cart, mc)
        b2 = me.RigidBody("bobb", bob, arm, mp, (me.inertia(arm, ip, 0, ip), bob))
        stretch = q[0] + w  # distance from the wall point (positive in the tests)
        spring = -(k * (stretch - l0) + c * u[0]) * n.x
        return [b1, b2], [(cart, spring), (cart, -mc * g * n.y), (bob, -mp * g * n.y)]

    mm, fo, q, u = _kane("cp", 2, build)
    names = ["x", "ph"]
    return Reference(system, _to_ours(mm, q, u, names), _to_ours(fo, q, u, names))


# ------------------------------------------------------------------ 3-link spatial chain
def spatial_chain(links: int = 3, kane: bool = True) -> Reference:
    """Spatial chain, each joint two rotations (z then y), links along x, general (non-
    diagonal) inertia and CoM off the link axis, gravity along an oblique direction."""
    names: list[str] = []
    params = [Parameter("g", 9.81)]
    frames: list[Frame] = []
    bodies: list[RigidBody] = []
    data = []
    for i in range(links):
        a, b = f"a{i}", f"b{i}"
        names += [a, b]
        ps = {
            f"m{i}": 1.0 + 0.3 * i, f"l{i}": 0.8 + 0.1 * i, f"cx{i}": 0.4, f"cy{i}": 0.05,
            f"jx{i}": 0.02, f"jy{i}": 0.05 + 0.01 * i, f"jz{i}": 0.06, f"jxy{i}": 0.004,
        }
        params += [Parameter(k, v) for k, v in ps.items()]
        m, l, cx, cy, jx, jy, jz, jxy = (symbol(k) for k in ps)
        inertia = sp.ImmutableMatrix([[jx, jxy, 0], [jxy, jy, 0], [0, 0, jz]])
        parent = "ISYS" if i == 0 else f"f{i - 1}"
        trans = sp.ImmutableMatrix([0, 0, 0] if i == 0 else [symbol(f"l{i - 1}"), 0, 0])
        frames.append(Frame(f"f{i}", parent, trans, (("z", symbol(a)), ("y", symbol(b)))))
        bodies.append(RigidBody(f"body{i}", f"f{i}", m, sp.ImmutableMatrix([cx, cy, 0]), inertia))
        data.append((m, l, cx, cy, jx, jy, jz, jxy))
    g = symbol("g")
    gdir = (sp.Rational(1, 3), -sp.Rational(2, 3), -sp.Rational(2, 3))
    system = System(
        f"chain{links}", coordinates=tuple(Coordinate(nm) for nm in names),
        parameters=tuple(params), frames=tuple(frames), bodies=tuple(bodies),
        gravity=sp.ImmutableMatrix([g * d for d in gdir]),
    )

    def build(q, u, n, o):
        parent_frame, joint = n, o
        kb, loads = [], []
        for i, (m, l, cx, cy, jx, jy, jz, jxy) in enumerate(data):
            f = _orient(parent_frame, [("z", q[2 * i]), ("y", q[2 * i + 1])], f"F{i}_")
            com = joint.locatenew(f"G{i}", cx * f.x + cy * f.y)
            com.v2pt_theory(joint, n, f)
            inert = me.inertia(f, jx, jy, jz, jxy, 0, 0)
            kb.append(me.RigidBody(f"B{i}", com, f, m, (inert, com)))
            loads.append((com, m * g * _vec(n, gdir)))
            nxt = joint.locatenew(f"J{i}", l * f.x)
            nxt.v2pt_theory(joint, n, f)
            joint, parent_frame = nxt, f
        return kb, loads

    if not kane:
        return Reference(system, None, None)  # type: ignore[arg-type]
    mm, fo, q, u = _kane("sc", 2 * links, build)
    return Reference(system, _to_ours(mm, q, u, names), _to_ours(fo, q, u, names))


# ------------------------------------------------------------------ prescribed motion
def prescribed_carrier() -> Reference:
    """A carrier with prescribed (explicitly time-dependent) translation A sin(ν t) along x
    and rotation Ω t about z, carrying a pendulum hinged about the carrier's x axis."""
    m, l, ix, amp, nu, om, g = (symbol(s) for s in ("m", "l", "ix", "amp", "nu", "om", "g"))
    ph = symbol("ph")
    system = System(
        "carrier",
        coordinates=(Coordinate("ph"),),
        parameters=(Parameter("m", 0.9), Parameter("l", 0.7), Parameter("ix", 0.03),
                    Parameter("amp", 0.2), Parameter("nu", 3.0), Parameter("om", 1.7),
                    Parameter("g", 9.81)),
        frames=(
            Frame("carrier", translation=sp.ImmutableMatrix([amp * sp.sin(nu * time), 0, 0]),
                  rotation=(("z", om * time),)),
            Frame("arm", "carrier", sp.ImmutableMatrix([0, l / 2, 0]), (("x", ph),)),
        ),
        bodies=(RigidBody("bob", "arm", m, sp.ImmutableMatrix([0, 0, -l]),
                          sp.ImmutableMatrix(sp.diag(ix, ix, 0))),),
        gravity=sp.ImmutableMatrix([0, 0, -g]),
    )

    def build(q, u, n, o):
        car = _orient(n, [("z", om * T)], "C")
        p = o.locatenew("P", amp * sp.sin(nu * T) * n.x + l / 2 * car.y)
        arm = _orient(car, [("x", q[0])], "A")
        bob = p.locatenew("Bob", -l * arm.z)
        bob.set_vel(n, bob.pos_from(o).dt(n))
        body = me.RigidBody("b", bob, arm, m, (me.inertia(arm, ix, ix, 0), bob))
        return [body], [(bob, -m * g * n.z)]

    mm, fo, q, u = _kane("pc", 1, build)
    return Reference(system, _to_ours(mm, q, u, ["ph"]), _to_ours(fo, q, u, ["ph"]))


# ------------------------------------------------------------------ numeric helpers
def numeric_equations(eq: Equations) -> Callable:
    """``f(y, yd, p, t, u) -> (M, q − k, outputs)`` evaluating the intermediates in order."""
    args = [list(eq.coordinates), list(eq.velocities), list(eq.parameters), time, list(eq.inputs)]
    exprs = [eq.mass_matrix, eq.force_vector, eq.outputs]
    fn = sp.lambdify(args, exprs, modules="numpy",
                     cse=lambda e: (list(eq.intermediates), e))

    def call(y, yd, p, t, u=()):
        m, f, o = fn(list(y), list(yd), list(p), t, list(u))
        return np.asarray(m, float), np.asarray(f, float).ravel(), np.asarray(o, float).ravel()

    return call


def numeric_reference(ref: Reference) -> Callable:
    s = ref.system
    args = [list(s.coordinate_symbols), list(s.velocity_symbols), list(s.parameter_symbols), time]
    fn = sp.lambdify(args, [ref.mass_matrix, ref.forcing], modules="numpy")

    def call(y, yd, p, t):
        m, f = fn(list(y), list(yd), list(p), t)
        return np.asarray(m, float), np.asarray(f, float).ravel()

    return call


def random_states(system: System, count: int, seed: int = 0):
    """``count`` random ``(y, ẏ, p, t)``: angles in ±π, speeds in ±3, parameters ×(0.7…1.3)."""
    rng = np.random.default_rng(seed)
    n = len(system.coordinates)
    defaults = np.array([p.default for p in system.parameters], float)
    for _ in range(count):
        yield (
            rng.uniform(-np.pi, np.pi, n),
            rng.uniform(-3, 3, n),
            defaults * rng.uniform(0.7, 1.3, defaults.size),
            rng.uniform(0, 10),
        )


def rel_err(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))
