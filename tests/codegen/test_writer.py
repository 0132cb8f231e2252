"""The module writer against direct lambdify of the same symbolic equations.

Reference: ``sympy.lambdify`` of the (substituted) equations and ``sympy.diff`` for the
Jacobians, at random states; ``rhs_jacobian`` also against central differences of ``rhs``.
"""

from __future__ import annotations

from pathlib import Path

import handmade
import numpy as np
import pytest
import sympy as sp

from neweul_py.analysis.module import load_generated
from neweul_py.codegen import generate_module, render_module
from neweul_py.model import time

CASES = {
    "pendulum": lambda: handmade.pendulum(),
    "double": lambda: handmade.double_pendulum(),
    "double_inter": lambda: handmade.double_pendulum(with_intermediates=True),
}


def _substituted(eq):
    values = {}
    for s, e in eq.intermediates:
        values[s] = e.xreplace(values)
    return lambda m: sp.Matrix(m).xreplace(values)


@pytest.fixture(params=sorted(CASES))
def case(request, tmp_path):
    eq = CASES[request.param]()
    path = generate_module(eq, "0" * 64, tmp_path / f"{eq.system.name}.py")
    return eq, load_generated(path)


def test_functions_match_lambdify(case):
    eq, mod = case
    sub = _substituted(eq)
    y, yd, p, u = eq.coordinates, eq.velocities, eq.parameters, eq.inputs
    n, nu = len(y), len(u)
    args = (time, *y, *yd, *p, *u)
    M = sub(eq.mass_matrix)
    f = sub(eq.force_vector)
    out = sub(eq.outputs)
    a = sp.symbols(f"a0:{n}", real=True)
    Ma_y = (M * sp.Matrix(a)).jacobian(y)
    ref = {
        "M": sp.lambdify(args, M),
        "f": sp.lambdify(args, f),
        "fy": sp.lambdify(args, f.jacobian(y)),
        "fyd": sp.lambdify(args, f.jacobian(yd)),
        "fu": sp.lambdify(args, f.jacobian(u)) if nu else None,
        "Ma_y": sp.lambdify((*args, *a), Ma_y),
        "out": sp.lambdify(args, out),
        "C": sp.lambdify(args, out.jacobian([*y, *yd])),
    }
    rng = np.random.default_rng(1)
    for _ in range(20):
        t = rng.uniform(0, 3)
        yv, ydv = rng.uniform(-2, 2, n), rng.uniform(-2, 2, n)
        pv = mod.default_parameters() * rng.uniform(0.5, 1.5, len(p))
        uv = rng.uniform(-1, 1, nu)
        vals = (t, *yv, *ydv, *pv, *uv)
        x = np.concatenate([yv, ydv])
        Mr = np.array(ref["M"](*vals), dtype=float)
        fr = np.array(ref["f"](*vals), dtype=float).ravel()
        np.testing.assert_allclose(mod.mass_matrix(t, yv, pv, uv), Mr, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(mod.force_vector(t, yv, ydv, pv, uv), fr, rtol=1e-12,
                                   atol=1e-12)
        np.testing.assert_allclose(mod.rhs(t, x, pv, uv),
                                   np.concatenate([ydv, np.linalg.solve(Mr, fr)]), rtol=1e-11,
                                   atol=1e-12)
        fy, fyd, fu = mod.force_jacobians(t, yv, ydv, pv, uv)
        np.testing.assert_allclose(fy, ref["fy"](*vals), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(fyd, ref["fyd"](*vals), rtol=1e-12, atol=1e-12)
        assert fu.shape == (n, nu)
        if nu:
            np.testing.assert_allclose(fu, ref["fu"](*vals), rtol=1e-12, atol=1e-12)
        av = rng.normal(size=n)
        np.testing.assert_allclose(mod.mass_matrix_times_derivative(t, yv, pv, av, uv),
                                   ref["Ma_y"](*vals, *av), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(mod.outputs(t, x, pv, uv),
                                   np.array(ref["out"](*vals), dtype=float).ravel(),
                                   rtol=1e-12, atol=1e-12)
        C, D = mod.output_jacobians(t, x, pv, uv)
        np.testing.assert_allclose(C, ref["C"](*vals), rtol=1e-12, atol=1e-12)
        assert D.shape == (len(eq.output_names), nu)
        # rhs_jacobian against central differences of rhs
        J = mod.rhs_jacobian(t, x, pv, uv)
        h = 1e-6
        Jfd = np.column_stack([
            (mod.rhs(t, x + h * e, pv, uv) - mod.rhs(t, x - h * e, pv, uv)) / (2 * h)
            for e in np.eye(2 * n)
        ])
        np.testing.assert_allclose(J, Jfd, rtol=1e-6, atol=1e-6)


def test_protocol_constants(case):
    eq, mod = case
    n = len(eq.coordinates)
    assert mod.PROTOCOL_VERSION == 1
    assert mod.COORDINATES == [str(s) for s in eq.coordinates]
    assert list(mod.PARAMETERS) == [str(s) for s in eq.parameters]
    assert mod.STATE_SIZE == 2 * n == len(mod.INITIAL_STATE)
    assert mod.OUTPUTS == list(eq.output_names)
    assert mod.SOURCE_HASH == "0" * 64
    assert mod.constraints(0.0, np.zeros(n), mod.default_parameters()).shape == (0,)
    assert mod.constraint_jacobian(0.0, np.zeros(n), mod.default_parameters()).shape == (0, n)


def test_default_inputs_used_when_u_is_none(tmp_path):
    eq = handmade.pendulum()
    mod = load_generated(generate_module(eq, "h", tmp_path / "pendulum.py"))
    p = mod.default_parameters()
    x = np.array([0.2, -0.1])
    t = 0.7
    u = mod.default_inputs(t, p)
    np.testing.assert_allclose(u, [0.1 * np.sin(t)])
    np.testing.assert_array_equal(mod.rhs(t, x, p), mod.rhs(t, x, p, u))


def test_names_clashing_with_generated_code_are_renamed():
    """Model names such as ``a``, ``x``, ``p`` or ``abs`` must not shadow the module's own."""
    text = render_module(handmade.double_pendulum(), "h")
    assert "a_, b = " in text
    ns: dict = {}
    exec(compile(text, "<gen>", "exec"), ns)
    assert ns["COORDINATES"] == ["a", "b"]


def test_model_names_never_overwrite_the_generated_locals(tmp_path: Path) -> None:
    """Parameters named like the generated code's own locals and functions (``fy``, ``fyd``,
    ``fu``, ``C``, ``D``, ``G``, ``M``, ``f``, ``J``, ``default_inputs``) give the same
    linearization, FRF and Radau simulation as the same model with plain names (the
    reference)."""
    from neweul_py.analysis import load_generated, simulate
    from neweul_py.analysis.frf import frequency_response
    from neweul_py.analysis.linearize import linearize
    from neweul_py.api import generate

    names = ["fy", "fyd", "fu", "C", "D", "G", "M", "f", "J", "default_inputs"]
    template = """
name: {name}
parameters: {{{p0}: 1.5, {p1}: 0.8, {p2}: 9.81, {p3}: 20.0, {p4}: 0.3, {p5}: 0.1,
             {p6}: 0.7, {p7}: 0.2, {p8}: 0.05, {p9}: 1.0}}
gravity: [0, 0, -{p2}]
coordinates: {{a: {{initial: 0.4}}, z: {{}}}}
inputs: {{F: 0}}
frames:
  slide: {{translation: [0, 0, z]}}
  arm: {{parent: slide, rotation: [[y, a]]}}
bodies:
  cart: {{frame: slide, mass: {p6}}}
  bob: {{frame: arm, mass: {p0}, center_of_mass: [0, 0, -{p1}],
        inertia: {{diag: [{p8}, {p8}, {p8}]}}}}
forces:
  spring: {{type: spring_damper, between: [ISYS, slide], points: [[0, 0, 1], [0, 0, 0]],
           stiffness: {p3}, damping: {p4}, length: {p9}}}
  drive: {{type: generalized, coordinate: a, value: "{p5}*F - {p7}*d_a"}}
outputs:
  tip: {{position: arm, point: [0, 0, -{p1}], component: x}}
"""
    results = []
    for tag, ps in (("clash", names), ("plain", [f"q{i}" for i in range(10)])):
        text = template.format(name=tag, **{f"p{i}": n for i, n in enumerate(ps)})
        (tmp_path / f"{tag}.yaml").write_text(text)
        mod = load_generated(generate(tmp_path / f"{tag}.yaml", tmp_path / "gen"))
        lin = linearize(mod)
        fr = frequency_response(lin, [0.5, 2.0], ["F"], ["tip"])
        res = simulate(mod, 1.0, method="Radau", rtol=1e-9, atol=1e-12, n_out=11)
        results.append((lin.Q, lin.P, lin.B, fr.magnitude, res.y))
    for a, b in zip(*results, strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12)


def test_parameter_ranges_constant(tmp_path):
    """``PARAMETER_RANGES`` (protocol): the admissible ranges of the description, explicit or
    implied by a rest length, as ``name: (minimum, maximum)`` with None unbounded; a model
    without any has no such constant (its module is unchanged). Reference: the text."""
    from neweul_py.description import load_description_text
    from neweul_py.equations import newton_euler

    text = ("name: ranged\nparameters:\n  k: {value: 10, min: 0, max: 1e4}\n  l0: 0.5\n"
            "  m: 1\ncoordinates: {x: 0.6}\nframes: {f: {translation: [x, 0, 0]}}\n"
            "bodies: {b: {frame: f, mass: m}}\nforces:\n  s: {type: spring_damper, "
            "between: [ISYS, f], stiffness: k, length: l0}\n")
    eq = newton_euler(load_description_text(text))
    mod = load_generated(generate_module(eq, "h", tmp_path / "ranged.py"))
    assert mod.PARAMETER_RANGES == {"k": (0.0, 10000.0), "l0": (0.0, None)}
    plain = generate_module(handmade.pendulum(), "h", tmp_path / "p.py")
    assert "PARAMETER_RANGES" not in plain.read_text()
    assert load_generated(plain).PARAMETER_RANGES == {}     # the typed view's default
