"""Mass matrix of a branched tree (equations.md §1) against the kinetic energy.

Reference: ``M = ∂²T/∂ẏ²`` with ``T = ½ Σ (m v_cᵀ v_c + ω_Kᵀ I ω_K)`` built by hand from
explicit rotation matrices and positions (``v = ṙ``, ``ω̃ = Sᵀ Ṡ``). The tree branches twice,
one coordinate drives two frames (a gear-like coupling), one frame is prismatic and one has
a prescribed time-dependent rotation, so that the recursive form's backward recursion over
the tree (``M = Σ Jᵀ Θ J`` evaluated children → parents) sees every case.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
import sympy as sp

from neweul_py.equations import newton_euler
from neweul_py.model import Coordinate, Frame, Parameter, RigidBody, System, symbol, time

a, b, c, s = (symbol(x) for x in ("a", "b", "c", "s"))
l, h, w, k = (symbol(x) for x in ("l", "h", "w", "k"))


def _rx(q):
    return sp.Matrix([[1, 0, 0], [0, sp.cos(q), -sp.sin(q)], [0, sp.sin(q), sp.cos(q)]])


def _ry(q):
    return sp.Matrix([[sp.cos(q), 0, sp.sin(q)], [0, 1, 0], [-sp.sin(q), 0, sp.cos(q)]])


def _rz(q):
    return sp.Matrix([[sp.cos(q), -sp.sin(q), 0], [sp.sin(q), sp.cos(q), 0], [0, 0, 1]])


def _body(name, frame, mass, com, inertia):
    return RigidBody(name, frame, mass, sp.ImmutableMatrix(com), sp.ImmutableMatrix(inertia))


@functools.cache
def tree():
    ms = [symbol(f"m{i}") for i in range(5)]
    inertia = [sp.Matrix([[0.03 + 0.01 * i, 0.002, 0], [0.002, 0.04, 0.001],
                          [0, 0.001, 0.05]]) for i in range(5)]
    frames = (
        Frame("root", rotation=(("z", a), ("x", b))),
        Frame("left", "root", sp.ImmutableMatrix([l, 0, 0]), (("y", c),)),
        Frame("right", "root", sp.ImmutableMatrix([0, l, h]), (("z", k * a), ("x", w * time))),
        Frame("slider", "left", sp.ImmutableMatrix([s, h, 0])),
        Frame("tip", "right", sp.ImmutableMatrix([0, 0, l]), (("y", s),)),
    )
    coms = [(h, 0, 0), (l / 2, 0, h), (0, h, 0), (0, 0, 0), (h, h, 0)]
    names = ["root", "left", "right", "slider", "tip"]
    system = System(
        "tree",
        coordinates=tuple(Coordinate(n) for n in ("a", "b", "c", "s")),
        parameters=(*(Parameter(f"m{i}", 1.0 + 0.2 * i) for i in range(5)),
                    Parameter("l", 0.8), Parameter("h", 0.2), Parameter("w", 1.3),
                    Parameter("k", 0.5)),
        frames=frames,
        bodies=tuple(_body(f"body_{n}", n, ms[i], coms[i], inertia[i])
                     for i, n in enumerate(names)),
    )
    s_root = _rz(a) * _rx(b)
    s_left = s_root * _ry(c)
    s_right = s_root * _rz(k * a) * _rx(w * time)
    s_tip = s_right * _ry(s)
    r_root = sp.zeros(3, 1)
    r_left = s_root * sp.Matrix([l, 0, 0])
    r_right = s_root * sp.Matrix([0, l, h])
    r_slider = r_left + s_left * sp.Matrix([s, h, 0])
    r_tip = r_right + s_right * sp.Matrix([0, 0, l])
    hand = {"root": (s_root, r_root), "left": (s_left, r_left), "right": (s_right, r_right),
            "slider": (s_left, r_slider), "tip": (s_tip, r_tip)}
    y = sp.Matrix(system.coordinate_symbols)
    yd = sp.Matrix(system.velocity_symbols)

    def ddt(m):
        out = m.diff(time)
        for q, qd in zip(y, yd, strict=True):
            out += m.diff(q) * qd
        return out

    energy = 0
    for i, n in enumerate(names):
        s_mat, r = hand[n]
        v = ddt(r + s_mat * sp.Matrix(coms[i]))
        wt = s_mat.T * ddt(s_mat)
        om = sp.Matrix([wt[2, 1], wt[0, 2], wt[1, 0]])
        energy += (ms[i] * (v.T * v)[0] + (om.T * inertia[i] * om)[0]) / 2
    mass = sp.hessian(energy, list(yd))
    return system, mass


@pytest.mark.parametrize("form", [
    # 6 s of CPU; the closed form is checked against Kane's method by default
    # (tests/equations/test_newton_euler_kane.py)
    pytest.param("closed", marks=pytest.mark.slow), "recursive"])
def test_tree_mass_matrix_equals_kinetic_energy_hessian(form: str) -> None:
    system, mass = tree()
    eq = newton_euler(system, form=form)
    # (all intermediates are evaluated, some need ẏ: pass it, M does not depend on it)
    args = [list(system.coordinate_symbols), list(system.parameter_symbols), time,
            list(system.velocity_symbols)]
    ours = sp.lambdify(args, eq.mass_matrix, cse=lambda e: (list(eq.intermediates), e))
    ref = sp.lambdify(args, mass)
    rng = np.random.default_rng(4)
    for _ in range(20):
        y = rng.uniform(-np.pi, np.pi, 4)
        p = np.array([x.default for x in system.parameters]) * rng.uniform(0.8, 1.2, 9)
        t = rng.uniform(0, 5)
        m_ours = np.asarray(ours(list(y), list(p), t, list(rng.normal(size=4))), float)
        m_ref = np.asarray(ref(list(y), list(p), t, [0.0] * 4), float)
        np.testing.assert_allclose(m_ours, m_ref, rtol=1e-11, atol=1e-12)
        assert np.all(np.linalg.eigvalsh(m_ours) > 0)
