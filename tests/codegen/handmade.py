"""Hand-derived equations (Lagrange's equations with sympy) for testing codegen on its own.

Independent of ``neweul_py.equations``: ``M = ∂²T/∂ẏ²``, ``q − k = ∂T/∂y − (∂²T/∂ẏ∂y) ẏ −
∂V/∂y + Q`` for scleronomic models.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from neweul_py.model import (
    Coordinate,
    ExpressionOutput,
    Frame,
    Input,
    Parameter,
    RigidBody,
    System,
    symbol,
)


@dataclass(frozen=True)
class HandEquations:
    """Same fields as :class:`neweul_py.equations.Equations`."""

    system: System
    coordinates: tuple
    velocities: tuple
    parameters: tuple
    inputs: tuple
    intermediates: tuple
    mass_matrix: sp.ImmutableMatrix
    force_vector: sp.ImmutableMatrix
    outputs: sp.ImmutableMatrix
    output_names: tuple


def lagrange(system: System, T: sp.Expr, V: sp.Expr, Q=None, intermediates=()) -> HandEquations:
    y = system.coordinate_symbols
    yd = system.velocity_symbols
    n = len(y)
    M = sp.Matrix(n, n, lambda i, j: sp.diff(T, yd[i], yd[j]))
    f = sp.Matrix(
        [
            sp.diff(T, y[i]) - sum(sp.diff(T, yd[i], y[j]) * yd[j] for j in range(n))
            - sp.diff(V, y[i])
            for i in range(n)
        ]
    )
    if Q is not None:
        f += sp.Matrix(Q)
    outs = [o.expr for o in system.outputs]
    return HandEquations(
        system=system,
        coordinates=y,
        velocities=yd,
        parameters=system.parameter_symbols,
        inputs=system.input_symbols,
        intermediates=tuple(intermediates),
        mass_matrix=sp.ImmutableMatrix(M),
        force_vector=sp.ImmutableMatrix(f),
        outputs=sp.ImmutableMatrix(outs) if outs else sp.ImmutableMatrix.zeros(0, 1),
        output_names=tuple(o.name for o in system.outputs),
    )


def pendulum(torque_input: bool = True) -> HandEquations:
    """Point mass m on a massless rod l, angle phi from the downward vertical, torque u."""
    m, l, g, phi, dphi = (symbol(s) for s in ("m", "l", "g", "phi", "d_phi"))
    u = symbol("F")
    inputs = (Input("F", sp.Float(0.1) * sp.sin(symbol("t"))),) if torque_input else ()
    system = System(
        name="pendulum",
        parameters=(Parameter("m", 1.0), Parameter("l", 0.5), Parameter("g", 9.81)),
        coordinates=(Coordinate("phi", 0.3, 0.0),),
        inputs=inputs,
        frames=(Frame("rod", rotation=(("y", phi),)),),
        bodies=(RigidBody("bob", "rod", m, sp.ImmutableMatrix([0, 0, -l])),),
        outputs=(ExpressionOutput("height", -l * sp.cos(phi)),
                 ExpressionOutput("speed", l * dphi)),
    )
    T = m * l**2 * dphi**2 / 2
    V = -m * g * l * sp.cos(phi)
    return lagrange(system, T, V, Q=[u] if torque_input else None)


def double_pendulum(with_intermediates: bool = False) -> HandEquations:
    """Planar double pendulum of two point masses (angles absolute from the vertical)."""
    m1, m2, l1, l2, g = (symbol(s) for s in ("m1", "m2", "l1", "l2", "g"))
    a, b, da, db = (symbol(s) for s in ("a", "b", "d_a", "d_b"))
    system = System(
        name="double_pendulum",
        parameters=tuple(Parameter(n, v) for n, v in
                         (("m1", 1.0), ("m2", 0.7), ("l1", 1.0), ("l2", 0.8), ("g", 9.81))),
        coordinates=(Coordinate("a", 1.0, 0.0), Coordinate("b", -0.5, 0.3)),
        frames=(Frame("f1", rotation=(("y", a),)),),
        bodies=(RigidBody("b1", "f1", m1, sp.ImmutableMatrix([0, 0, -l1])),),
        outputs=(ExpressionOutput("x2", l1 * sp.sin(a) + l2 * sp.sin(b)),
                 ExpressionOutput("z2", -l1 * sp.cos(a) - l2 * sp.cos(b))),
    )
    T = ((m1 + m2) * l1**2 * da**2 / 2 + m2 * l2**2 * db**2 / 2
         + m2 * l1 * l2 * da * db * sp.cos(a - b))
    V = -(m1 + m2) * g * l1 * sp.cos(a) - m2 * g * l2 * sp.cos(b)
    eq = lagrange(system, T, V)
    if not with_intermediates:
        return eq
    # Same equations through intermediates c = cos(a − b), s = sin(a − b), w = m2 l1 l2.
    c, s, w = sp.symbols("z_c z_s z_w", real=True)
    inter = ((w, m2 * l1 * l2), (c, sp.cos(a - b)), (s, sp.sin(a - b)))
    back = {sp.cos(a - b): c, sp.sin(a - b): s}
    M = eq.mass_matrix.subs(back).subs(m2 * l1 * l2, w)
    f = eq.force_vector.subs(back)
    return HandEquations(**{**eq.__dict__, "intermediates": inter,
                            "mass_matrix": sp.ImmutableMatrix(M),
                            "force_vector": sp.ImmutableMatrix(f)})
