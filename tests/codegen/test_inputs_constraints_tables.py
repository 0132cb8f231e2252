"""Generated code for inputs, loops and tables: input vectors with the rates kinematic excitation
needs, ∂/∂u of forces and outputs, constraint functions with inputs, table characteristics.

References: finite differences of the generated functions themselves (``force_vector`` in
``u``, ``constraints`` in ``y`` and ``t``), the derivative of the default excitation by hand, and
the constraint ``g = x − u sin φ`` differentiated by hand.
"""

from __future__ import annotations

import ast

import numpy as np

from neweul_py.analysis.module import load_generated
from neweul_py.codegen import generate_module
from neweul_py.description import load_description_text
from neweul_py.equations import newton_euler

RNG = np.random.default_rng(11)

MODEL = """
name: excited
parameters: {m: 2, k: 50, c: 0.4, a: 0.3, w: 3, sw: 1}
coordinates: {x: 0.1, phi: 0.2}
inputs: {u: a*sin(w*t), F: 0}
frames:
  base: {translation: [u, 0, 0]}
  cart: {parent: base, translation: [x, 0, 0], rotation: [[z, phi]]}
bodies:
  body: {frame: cart, mass: m, center_of_mass: [0.1, 0, 0], inertia: {diag: [0.01, 0.01, 0.02]}}
forces:
  spring: {type: spring_damper, between: [base, cart], points: [[-1, 0, 0], [0, 0, 0]],
           length: 1, stiffness: {table: [[-1, -60], [0, 0], [1, 40]], interpolation: spline},
           damping: c, enabled: sw, report: true}
  twist: {type: rotational_spring_damper, coordinate: phi, stiffness: k, damping: c}
  push: {type: generalized, coordinate: x, value: F}
constraints:
  ride: phi = u*x
outputs:
  abs_x: {position: cart, component: x}
  abs_vx: {velocity: cart, component: x}
"""


def _module(tmp_path):
    system = load_description_text(MODEL)
    path = generate_module(newton_euler(system), "test", tmp_path / "excited.py")
    return load_generated(path)


def test_input_vector_carries_the_rates_of_kinematic_excitation(tmp_path) -> None:
    mod = _module(tmp_path)
    assert mod.INPUTS == ["u", "F", "d_u", "dd_u"]
    assert mod.INPUT_RATES == {"u": ["d_u", "dd_u"]}
    assert mod.CONSTRAINTS == ["ride"]
    assert "spring_force" in mod.OUTPUTS
    p = mod.default_parameters()
    t = 0.7
    np.testing.assert_allclose(mod.default_inputs(t, p),
                               [0.3 * np.sin(3 * t), 0, 0.9 * np.cos(3 * t),
                                -2.7 * np.sin(3 * t)], rtol=1e-14)
    x = np.array([0.1, 0.2, 0.3, -0.4])
    np.testing.assert_array_equal(mod.rhs(t, x, p), mod.rhs(t, x, p, mod.default_inputs(t, p)))
    # the absolute velocity of the cart includes the excitation rate d_u
    u = np.array([0.05, 0.0, 0.7, 0.0])
    np.testing.assert_allclose(mod.outputs(t, x, p, u)[mod.OUTPUTS.index("abs_vx")],
                               0.7 + 0.3, rtol=1e-14)
    np.testing.assert_allclose(mod.outputs(t, x, p, u)[mod.OUTPUTS.index("abs_x")],
                               0.05 + 0.1, rtol=1e-14)


def test_force_and_output_jacobians_in_u_match_finite_differences(tmp_path) -> None:
    mod = _module(tmp_path)
    p = mod.default_parameters()
    for _ in range(10):
        y, yd, u = RNG.normal(size=2) * 0.5, RNG.normal(size=2), RNG.normal(size=4) * 0.3
        fy, fyd, fu = mod.force_jacobians(0.3, y, yd, p, u)
        x = np.concatenate([y, yd])
        c, d = mod.output_jacobians(0.3, x, p, u)
        h = 1e-6
        for j in range(4):
            e = np.eye(4)[j] * h
            fd = (mod.force_vector(0.3, y, yd, p, u + e) - mod.force_vector(0.3, y, yd, p, u - e))
            np.testing.assert_allclose(fu[:, j], fd / (2 * h), rtol=1e-6, atol=1e-6)
            fd = mod.outputs(0.3, x, p, u + e) - mod.outputs(0.3, x, p, u - e)
            np.testing.assert_allclose(d[:, j], fd / (2 * h), rtol=1e-6, atol=1e-6)
        for j in range(2):
            e = np.eye(2)[j] * h
            fd = mod.force_vector(0.3, y + e, yd, p, u) - mod.force_vector(0.3, y - e, yd, p, u)
            np.testing.assert_allclose(fy[:, j], fd / (2 * h), rtol=1e-6, atol=1e-6)
            fd = mod.force_vector(0.3, y, yd + e, p, u) - mod.force_vector(0.3, y, yd - e, p, u)
            np.testing.assert_allclose(fyd[:, j], fd / (2 * h), rtol=1e-6, atol=1e-6)
        for j in range(4):
            e = np.eye(4)[j] * h
            fd = mod.outputs(0.3, x + e, p, u) - mod.outputs(0.3, x - e, p, u)
            np.testing.assert_allclose(c[:, j], fd / (2 * h), rtol=1e-6, atol=1e-6)


def test_generated_constraint_functions_with_an_input(tmp_path) -> None:
    """g = φ − u x: G = [−u, 1], ∂g/∂t = −u̇ x, γ = −ü x − 2 u̇ ẋ."""
    mod = _module(tmp_path)
    p = mod.default_parameters()
    for _ in range(10):
        y, yd, u = RNG.normal(size=2), RNG.normal(size=2), RNG.normal(size=4)
        np.testing.assert_allclose(mod.constraints(0.0, y, p, u), [y[1] - u[0] * y[0]])
        np.testing.assert_allclose(mod.constraint_jacobian(0.0, y, p, u), [[-u[0], 1.0]])
        np.testing.assert_allclose(mod.constraint_time_derivative(0.0, y, p, u),
                                   [-u[2] * y[0]])
        np.testing.assert_allclose(mod.constraint_gamma(0.0, y, yd, p, u),
                                   [-u[3] * y[0] - 2 * u[2] * yd[0]], rtol=1e-13, atol=1e-14)
    # default excitation when u is omitted (the protocol's (t, y, p) call)
    t, y = 0.4, np.array([0.3, 0.1])
    np.testing.assert_allclose(mod.constraints(t, y, p), [0.1 - 0.3 * np.sin(1.2) * 0.3])


def test_generated_module_imports_only_numpy_and_math(tmp_path) -> None:
    """Table characteristics are emitted as plain comparisons: no scipy interpolation, no
    sympy (the only optional import is SciPy's LAPACK wrapper of the solve, at the first
    solve and guarded by ``try``; codegen/packing.py)."""
    system = load_description_text(MODEL)
    path = generate_module(newton_euler(system), "test", tmp_path / "excited.py")
    tree = ast.parse(path.read_text())
    imported = {alias.name for node in ast.walk(tree) if isinstance(node, ast.Import)
                for alias in node.names}
    imported |= {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)}
    assert imported <= {"numpy", "math", "struct", "scipy.linalg.lapack"}
    guarded = {node.module for t in ast.walk(tree) if isinstance(t, ast.Try)
               for node in ast.walk(t) if isinstance(node, ast.ImportFrom)}
    assert guarded == {"scipy.linalg.lapack"}
    top = {n.module if isinstance(n, ast.ImportFrom) else n.names[0].name
           for n in tree.body if isinstance(n, ast.Import | ast.ImportFrom)}
    assert top <= {"numpy", "math", "struct"}  # SciPy only at the first solve


def test_long_tables_generate_linearly_and_evaluate_like_numpy_interp(tmp_path) -> None:
    """A 200-point linear characteristic: the generated force is numpy.interp of the table
    (inside) and its Jacobian the segment slope; the module stays small (one comparison chain
    per use, not one per derivative symbol)."""
    xs = np.linspace(-0.2, 0.2, 200)
    fs = 1e3 * xs + 4e5 * xs**3
    rows = ", ".join(f"[{float(a)!r}, {float(b)!r}]" for a, b in zip(xs, fs, strict=True))
    system = load_description_text(f"""
name: long_table
coordinates: {{x: 0.5}}
frames:
  b: {{translation: [x, 0, 0]}}
bodies:
  m: {{frame: b, mass: 1}}
forces:
  tab: {{type: spring_damper, between: [ISYS, b], length: 0.4,
         stiffness: {{table: [{rows}], interpolation: linear}}}}
""")
    path = generate_module(newton_euler(system), "test", tmp_path / "long_table.py")
    assert path.stat().st_size < 150_000
    mod = load_generated(path)
    p = mod.default_parameters()
    for s in RNG.uniform(-0.19, 0.19, 50):
        np.testing.assert_allclose(mod.force_vector(0.0, [0.4 + s], [0.0], p),
                                   [-np.interp(s, xs, fs)], rtol=1e-12, atol=1e-9)
        k = np.searchsorted(xs, s) - 1
        slope = (fs[k + 1] - fs[k]) / (xs[k + 1] - xs[k])
        np.testing.assert_allclose(mod.force_jacobians(0.0, [0.4 + s], [0.0], p)[0],
                                   [[-slope]], rtol=1e-10)
