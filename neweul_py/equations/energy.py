"""Energies of the rigid part of a model: kinetic, gravity, springs (equations.md §1).

```
T   = Σ_i ½ m_i v_ci·v_ci + ½ ω_iᵀ I_i ω_i          (v_c = J_T,c ẏ + v̄_c, body components)
V_g = −Σ_i m_i g·r_ci                              (r_c: center of mass, ISYS)
V_s = Σ_elements enabled·V                          (each element's potential)
```
``V_s`` sums the potentials the force elements form
(:meth:`~neweul_py.model.ForceElement.potential`): ``½ k s²`` of point-to-point spring–dampers
and of rotational spring–dampers on a coordinate whose spring law is linear with a constant
``stiffness`` (``s = ℓ − length`` or ``s = coordinate − angle``). Tables, coefficients that
depend on ``s`` or ``sd``, rotational spring–dampers between frames, bushings and applied
forces are left out (their potential is not formed), so the sum of the energies is conserved
only when such elements do no work. Elastic bodies add their own terms in the generated module
(:func:`neweul_py.ffrf.splice.ffrf_energy`).
"""

from __future__ import annotations

import sympy as sp

from ..kinematics import Kinematics
from ..model import INERTIAL, System, as_expr
from ..model.algebra import dot, mat_vec
from ..model.canonical import add, mul

__all__ = ["energies"]

_HALF = sp.Rational(1, 2)


def _kinetic_and_gravity(kin: Kinematics, system: System) -> tuple[sp.Expr, sp.Expr]:
    g = tuple(system.gravity)
    kinetic: list[sp.Expr] = []
    gravity: list[sp.Expr] = []
    for body in system.bodies:
        if body.frame == INERTIAL:
            continue
        c = tuple(body.center_of_mass)
        fk = kin.frames[body.frame]
        v = kin.velocity(kin.point(body.frame, c, f"bodies.{body.name}.center_of_mass"))
        w = fk.omega
        inertia = tuple(tuple(body.inertia[i, j] for j in range(3)) for i in range(3))
        m = as_expr(body.mass)
        # ½ (m v·v + ω·Iω) and −m g·r, sympy's nodes by the constructors of model.canonical
        kinetic.append(mul(_HALF, add(mul(m, dot(v, v)), dot(w, mat_vec(inertia, w)))))
        r = kin.point_position(body.frame, c, INERTIAL)
        gravity.append(mul(-m, dot(g, r)))
    return add(*kinetic), add(*gravity)


def _springs(kin: Kinematics, system: System) -> sp.Expr:
    """``Σ enabled·V`` of the force elements that have a potential
    (:meth:`~neweul_py.model.ForceElement.potential`)."""
    terms: list[sp.Expr] = []
    for fe in system.forces:
        potential = fe.potential(kin)
        if potential is not None:
            terms.append(fe.enabled * potential)
    return sp.Add(*terms)


def energies(kin: Kinematics, system: System) -> sp.ImmutableMatrix:
    """``[T, V_g, V_s]`` of the rigid bodies and linear springs (module docstring), as
    expressions of ``y``, ``ẏ``, ``p``, ``u``, ``t`` and the intermediates of ``kin``."""
    kinetic, gravity = _kinetic_and_gravity(kin, system)
    return sp.ImmutableMatrix([kinetic, gravity, _springs(kin, system)])

