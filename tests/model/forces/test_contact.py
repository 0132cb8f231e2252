"""The point–plane contact (``neweul_py/model/forces/contact.py``) against closed forms.

References:
- generalized forces: ``q = −F ∂δ/∂y`` with the penetration ``δ = −n̂·S_Aᵀ (r_PB − r_PA)`` of a
  contact point of a turning body against a turning, tilted plane, written here with sympy's
  rotation matrices and differentiated by sympy, and the Hunt–Crossley law
  ``F = max(δ, 0)^e · max(0, k + λ δ̇)`` (Hunt & Crossley 1975);
- potential: ``k p^(e+1)/(e+1)``, ``p = max(δ, 0)``;
- a point mass thrown at the plane without gravity, linear and undamped (``e = 1``, ``λ = 0``):
  half a harmonic oscillation in contact, ``T = π √(m/k)``, rebound at the impact speed ``v0``,
  largest force ``v0 √(k m)``, so the free flight after it ends where the closed form says.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from neweul_py.api import simulate_description
from neweul_py.description import load_description_text
from neweul_py.equations import newton_euler
from neweul_py.errors import DescriptionError
from neweul_py.model import symbol, time

RNG = np.random.default_rng(20240611)

TILTED = """
name: tilted_contact
parameters: {m: 2, k: 300, e: 1.5, lam: 4, r: 0.1, sw: 1}
coordinates: {alpha: 0, beta: 0, x: 0, y: 0, z: 0}
frames:
  plane: {translation: [0, 0, 0.05], rotation: [[y, alpha]]}
  ball: {translation: [x, y, z], rotation: [[x, beta]]}
bodies:
  b: {frame: ball, mass: m, inertia: {diag: [1, 1, 1]}}
  p: {frame: plane, mass: m, inertia: {diag: [1, 1, 1]}}
forces:
  touch:
    type: plane_contact
    between: [plane, ball]
    points: [[0.1, 0, 0.2], [0, 0.05, -r]]
    normal: [0, 0, 2]
    stiffness: k
    exponent: e
    damping: lam
    enabled: sw
    report: true
"""


def _rx(a):
    return sp.Matrix([[1, 0, 0], [0, sp.cos(a), -sp.sin(a)], [0, sp.sin(a), sp.cos(a)]])


def _ry(a):
    return sp.Matrix([[sp.cos(a), 0, sp.sin(a)], [0, 1, 0], [-sp.sin(a), 0, sp.cos(a)]])


def _reference():
    """``δ(y)``, ``∂δ/∂y`` and ``δ̇(y, ẏ)`` of the description above, by sympy."""
    alpha, beta, x, y, z = (symbol(n) for n in ("alpha", "beta", "x", "y", "z"))
    q = sp.Matrix([alpha, beta, x, y, z])
    qd = sp.Matrix(sp.symbols("v0:5"))
    r_pa = sp.Matrix([0, 0, 0.05]) + _ry(alpha) * sp.Matrix([0.1, 0, 0.2])
    r_pb = sp.Matrix([x, y, z]) + _rx(beta) * sp.Matrix([0, 0.05, -0.1])
    depth = -(_ry(alpha).T * (r_pb - r_pa))[2]
    grad = sp.Matrix([depth]).jacobian(q)
    args = (q, qd)
    return (sp.lambdify(args, depth, "numpy"), sp.lambdify(args, list(grad), "numpy"),
            sp.lambdify(args, (grad * qd)[0], "numpy"))


@pytest.mark.parametrize("form", ["closed", "recursive"])
def test_generalized_forces_are_the_hunt_crossley_law_on_the_penetration(form: str) -> None:
    """``q = −F ∂δ/∂y`` and the reported ``F`` equal the closed form at random states, in
    and out of contact; the normal ``[0, 0, 2]`` is normalized; ``sw = 0`` switches it off."""
    system = load_description_text(TILTED)
    eq = newton_euler(system, form).substituted()
    args = (system.coordinate_symbols, system.velocity_symbols, system.parameter_symbols, time)
    gyro = sp.lambdify(args, list(eq.force_vector.xreplace(  # inertia terms, no contact
        {symbol("sw"): 0})), "numpy")
    total = sp.lambdify(args, list(eq.force_vector), "numpy")
    report = sp.lambdify(args, eq.outputs[0], "numpy")
    depth, grad, rate = _reference()
    P = [p.default for p in system.parameters]
    k, e, lam = 300.0, 1.5, 4.0
    inside = 0
    for _ in range(40):
        yv = np.append(RNG.uniform(-0.3, 0.3, 4), RNG.uniform(0.05, 0.65))  # z about δ = 0
        ydv = RNG.normal(size=5)
        d = depth(yv, ydv)
        force = max(d, 0.0) ** e * max(0.0, k + lam * rate(yv, ydv))
        inside += d > 0
        q = np.array(total(yv, ydv, P, 0.0)) - np.array(gyro(yv, ydv, P, 0.0))
        np.testing.assert_allclose(q, -force * np.array(grad(yv, ydv)), rtol=1e-10,
                                   atol=1e-10)
        assert report(yv, ydv, P, 0.0) == pytest.approx(force, rel=1e-10, abs=1e-12)
    assert 5 < inside < 35  # both in and out of contact


def test_potential_is_the_integral_of_the_spring_part() -> None:
    """The energy's springs entry is ``k p^(e+1)/(e+1)`` at random states."""
    system = load_description_text(TILTED)
    eq = newton_euler(system, "closed")
    potential = sp.lambdify((system.coordinate_symbols, system.parameter_symbols),
                            eq.energy[2], "numpy")
    depth, _, _ = _reference()
    P = [p.default for p in system.parameters]
    for _ in range(20):
        yv = np.append(RNG.uniform(-0.3, 0.3, 4), RNG.uniform(0.05, 0.65))
        p = max(depth(yv, np.zeros(5)), 0.0)
        assert potential(yv, P) == pytest.approx(300.0 * p**2.5 / 2.5, rel=1e-10, abs=1e-14)


BOUNCE = """
name: bounce
parameters: {m: 1, k: 10000, r: 0.1}
coordinates: {z: {initial: 0.15, velocity: -1}}
frames:
  ball: {translation: [0, 0, z]}
bodies:
  b: {frame: ball, mass: m}
forces:
  ground: {type: plane_contact, between: [ISYS, ball], points: [[0, 0, 0], [0, 0, -r]],
           stiffness: k, report: true}
"""


def test_an_undamped_linear_contact_returns_the_impact_speed_after_half_a_period(
        tmp_path) -> None:
    """Generated and simulated: the point touches at ``t = 0.05``, stays ``π √(m/k)`` in
    contact, leaves at ``v0 = 1``; at ``t = 0.2`` it is ``r + v0 (0.15 − π √(m/k))`` high; the
    largest force is ``v0 √(k m) = 100``."""
    path = tmp_path / "bounce.yaml"
    path.write_text(BOUNCE)
    res = simulate_description(path, 0.2, cache=tmp_path / "cache", method="DOP853",
                               rtol=1e-11, atol=1e-12, max_step=1e-3, n_out=2001)
    contact = math.pi * math.sqrt(1 / 10000)
    assert res.yd[-1, 0] == pytest.approx(1.0, rel=1e-6)
    assert res.y[-1, 0] == pytest.approx(0.1 + (0.15 - contact), rel=1e-6)
    force = res.column("ground_force")
    assert force.max() == pytest.approx(100.0, rel=1e-4)
    assert force.min() == 0.0


@pytest.mark.parametrize(("change", "key", "words"), [
    ("exponent: 0.5", "forces.touch.exponent", "at least 1"),
    ("normal: [0, 0, 0]", "forces.touch.normal", "must not be zero"),
    ("stiffness: k*x", "forces.touch.stiffness", "'x' is a coordinate"),
    ("damping: -lam", "forces.touch.damping", "at least 0"),
])
def test_bad_values_are_one_error_naming_the_key(change: str, key: str, words: str) -> None:
    """Each bad value is one DescriptionError naming its key path."""
    name = change.split(":")[0]
    text = "\n".join(line for line in TILTED.splitlines() if not line.startswith(f"    {name}:"))
    text = text.replace("    type: plane_contact", f"    type: plane_contact\n    {change}")
    with pytest.raises(DescriptionError, match=words) as err:
        load_description_text(text)
    assert key in str(err.value)
