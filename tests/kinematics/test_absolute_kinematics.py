"""Absolute kinematics (equations.md §1) against direct differentiation of hand-built
rotation matrices and positions.

Reference: for a spatial tree with coordinate-dependent rotations and translations and
explicitly time-dependent (prescribed) motion, ``S`` and ``r`` are built by hand with
``sympy.rot_axis``-free explicit matrices, then ``J_T = Sᵀ ∂r/∂y``, ``v̄ = Sᵀ ∂r/∂t``,
``ω̃ = Sᵀ Ṡ``, ``J_R = ∂ω/∂ẏ``, ``ā = Sᵀ (r̈ − ∂r/∂y ÿ)``, ``ᾱ = α − J_R ÿ`` by sympy's ``diff``
and compared numerically at random states, for both forms.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from neweul_py.errors import ModelError
from neweul_py.kinematics import absolute_kinematics, elementary_rotation, rotation_product
from neweul_py.model import (
    Coordinate,
    Frame,
    Input,
    Parameter,
    System,
    symbol,
    time,
)

a, b, c, s = (symbol(x) for x in ("a", "b", "c", "s"))
l, h, w = (symbol(x) for x in ("l", "h", "w"))


def _rx(q):
    return sp.Matrix([[1, 0, 0], [0, sp.cos(q), -sp.sin(q)], [0, sp.sin(q), sp.cos(q)]])


def _ry(q):
    return sp.Matrix([[sp.cos(q), 0, sp.sin(q)], [0, 1, 0], [-sp.sin(q), 0, sp.cos(q)]])


def _rz(q):
    return sp.Matrix([[sp.cos(q), -sp.sin(q), 0], [sp.sin(q), sp.cos(q), 0], [0, 0, 1]])


def tree() -> tuple[System, dict[str, tuple[sp.Matrix, sp.Matrix]]]:
    """A small tree: f1 (x–y rotation), f2 on f1 (prismatic s along a rotated axis, prescribed
    z rotation w t + c), f3 on f1 (prescribed translation h sin t, rotation z a)."""
    system = System(
        "tree",
        coordinates=tuple(Coordinate(n) for n in ("a", "b", "c", "s")),
        parameters=(Parameter("l", 0.7), Parameter("h", 0.3), Parameter("w", 1.9)),
        frames=(
            Frame("f2", "f1", sp.ImmutableMatrix([l + s, s * h, 0]), (("z", w * time + c),)),
            Frame("f1", rotation=(("x", a), ("y", b))),
            Frame("f3", "f1", sp.ImmutableMatrix([0, h * sp.sin(time), l]),
                  (("z", a), ("x", sp.pi / 6))),
        ),
    )
    s1 = _rx(a) * _ry(b)
    r1 = sp.zeros(3, 1)
    s2 = s1 * _rz(w * time + c)
    r2 = r1 + s1 * sp.Matrix([l + s, s * h, 0])
    s3 = s1 * _rz(a) * _rx(sp.pi / 6)
    r3 = r1 + s1 * sp.Matrix([0, h * sp.sin(time), l])
    return system, {"f1": (s1, r1), "f2": (s2, r2), "f3": (s3, r3)}


def _reference(system: System, s_mat: sp.Matrix, r: sp.Matrix) -> dict[str, sp.Matrix]:
    """Body-fixed kinematics of one frame by direct differentiation."""
    y = sp.Matrix(system.coordinate_symbols)
    yd = sp.Matrix(system.velocity_symbols)
    ydd = sp.Matrix([symbol(f"dd_{c.name}") for c in system.coordinates])

    def ddt(expr: sp.Matrix) -> sp.Matrix:
        out = expr.diff(time)
        for q, qd, qdd in zip(y, yd, ydd, strict=True):
            out += expr.diff(q) * qd + expr.diff(qd) * qdd
        return out

    v = ddt(r)
    acc = ddt(v)
    w_tilde = s_mat.T * ddt(s_mat)
    omega = sp.Matrix([w_tilde[2, 1], w_tilde[0, 2], w_tilde[1, 0]])
    alpha = ddt(omega)
    zero_dd = {d: 0 for d in ydd}
    return {
        "S": s_mat,
        "r": r,
        "JT": s_mat.T * r.jacobian(y),
        "vbar": s_mat.T * r.diff(time),
        "JR": omega.jacobian(yd),
        "wbar": omega.subs(dict.fromkeys(yd, 0)),
        "omega": omega,
        "abar": s_mat.T * acc.subs(zero_dd),
        "alphabar": alpha.subs(zero_dd),
    }


def _ours(kin, name: str) -> dict[str, sp.Matrix]:
    fk = kin.frames[name]
    col = sp.Matrix
    return {
        "S": sp.Matrix(kin.rotation_matrix(name)),
        "r": col(kin.origin(name)),
        "JT": sp.Matrix.hstack(*(col(v) for v in fk.JT)),
        "vbar": col(fk.vbar),
        "JR": sp.Matrix.hstack(*(col(v) for v in fk.JR)),
        "wbar": col(fk.wbar),
        "omega": col(fk.omega),
        "abar": col(fk.abar),
        "alphabar": col(fk.alphabar),
    }


@pytest.mark.parametrize("form", ["closed", "recursive"])
def test_frame_kinematics_match_direct_differentiation(form: str) -> None:
    system, hand = tree()
    kin = absolute_kinematics(system, form)
    args = [*system.coordinate_symbols, *system.velocity_symbols,
            *system.parameter_symbols, time]
    rng = np.random.default_rng(3)
    for name, (s_mat, r) in hand.items():
        ref = _reference(system, s_mat, r)
        ours = _ours(kin, name)
        keys = list(ref)
        f_ref = sp.lambdify(args, [ref[k] for k in keys])
        f_ours = sp.lambdify(args, [ours[k] for k in keys],
                             cse=lambda e: (list(kin.workspace.assignments), e))
        for _ in range(20):
            x = rng.uniform(-2, 2, len(args))
            for key, u, v in zip(keys, f_ours(*x), f_ref(*x), strict=True):
                np.testing.assert_allclose(
                    np.asarray(u, float), np.asarray(v, float), rtol=1e-12, atol=1e-12,
                    err_msg=f"{name}.{key}",
                )


def test_point_position_and_velocity_in_other_frames() -> None:
    """A point of f2 resolved in f3: position and velocity from the hand-built S and r."""
    system, hand = tree()
    kin = absolute_kinematics(system, "recursive")
    p = (h, -l, sp.Rational(1, 3))
    s2, r2 = hand["f2"]
    s3, _ = hand["f3"]
    rp = r2 + s2 * sp.Matrix(p)
    y, yd = sp.Matrix(system.coordinate_symbols), sp.Matrix(system.velocity_symbols)
    vp = rp.jacobian(y) * yd + rp.diff(time)
    ref = [s3.T * rp, s3.T * vp]
    ours = [sp.Matrix(kin.point_position("f2", p, "f3")),
            sp.Matrix(kin.express(kin.velocity(kin.point("f2", p)), "f2", "f3"))]
    args = [*system.coordinate_symbols, *system.velocity_symbols,
            *system.parameter_symbols, time]
    f_ref = sp.lambdify(args, ref)
    f_ours = sp.lambdify(args, ours, cse=lambda e: (list(kin.workspace.assignments), e))
    rng = np.random.default_rng(5)
    for _ in range(20):
        x = rng.uniform(-2, 2, len(args))
        for u, v in zip(f_ours(*x), f_ref(*x), strict=True):
            np.testing.assert_allclose(np.asarray(u, float), np.asarray(v, float), rtol=1e-12,
                                       atol=1e-12)


def test_elementary_rotation_convention() -> None:
    """``R_z(φ)`` maps child components to parent components: the child x axis is
    ``(cos φ, sin φ, 0)`` in the parent; the product applies about the current axes."""
    phi = sp.Symbol("phi")
    rz = sp.Matrix(elementary_rotation("z", phi))
    assert list(rz[:, 0]) == [sp.cos(phi), sp.sin(phi), 0]
    for axis in "xyz":
        r = sp.Matrix(elementary_rotation(axis, phi))
        assert sp.simplify(r.T * r - sp.eye(3)) == sp.zeros(3, 3)
        assert sp.simplify(r.det()) == 1
    prod = sp.Matrix(rotation_product((("x", a), ("y", b))))
    assert (prod - _rx(a) * _ry(b)).expand() == sp.zeros(3, 3)


def test_inputs_in_frame_kinematics_excite_by_the_chain_rule() -> None:
    """Kinematic excitation: a frame translated by an input ``u(t)`` moves with
    ``v̄ = u̇`` and ``ā = ü`` (inputs ``d_u``, ``dd_u``), by hand."""
    u, du, ddu = symbol("u"), symbol("d_u"), symbol("dd_u")
    system = System(
        "excited",
        coordinates=(Coordinate("a"),),
        inputs=(Input("u", sp.sin(time)),),
        frames=(Frame("f", translation=sp.ImmutableMatrix([u, 0, 0]), rotation=(("z", a),)),),
    )
    assert system.input_names == ("u", "d_u", "dd_u")
    assert system.input_defaults[1:] == (sp.cos(time), -sp.sin(time))
    fk = absolute_kinematics(system).frames["f"]
    assert sp.simplify(sp.Matrix(fk.vbar) - sp.Matrix([du * sp.cos(a), -du * sp.sin(a), 0])) \
        == sp.zeros(3, 1)
    assert sp.simplify(sp.Matrix(fk.abar) - sp.Matrix([ddu * sp.cos(a), -ddu * sp.sin(a), 0])) \
        == sp.zeros(3, 1)


def test_input_derivatives_in_kinematics_are_rejected_naming_the_key() -> None:
    du = symbol("d_u")
    with pytest.raises(ModelError, match=r"frames\.f\.translation"):
        System(
            "bad",
            coordinates=(Coordinate("a"),),
            inputs=(Input("u", sp.sin(time)),),
            frames=(Frame("f", translation=sp.ImmutableMatrix([du, 0, 0])),),
        )
    system = System(
        "bad2",
        coordinates=(Coordinate("a"),),
        inputs=(Input("u"),),
        frames=(Frame("f", rotation=(("z", a),)),),
    )
    kin = absolute_kinematics(system)
    with pytest.raises(ModelError, match=r"forces\.push\.point"):
        kin.point("f", (du, 0, 0), "forces.push.point")
