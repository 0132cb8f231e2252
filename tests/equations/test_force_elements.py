"""Force elements (bushings, rotational spring–dampers, tables) against hand-derived forces
and potentials.

References (all written here, independently of the elements' loads in ``model/forces/``):
- bushing, translation: generalized forces ``−∂V/∂y − (∂Δr/∂y)ᵀ D Δṙ`` with the potential
  ``V = ½ Δrᵀ K Δr`` of the relative displacement ``Δr = S_Aᵀ (r_PB − r_PA)`` differentiated by
  sympy, ``Δṙ = (∂Δr/∂y) ẏ``;
- bushing, rotation about a common axis: ``V = k (1 − cos(β − α))``, damping ``−d (β̇ − α̇)``;
- rotational spring–damper: ``∓(k s + d ṡ)`` with ``s`` the relative angle;
- spring_damper tables: the analytic piecewise-linear function (``numpy.interp`` inside,
  straight continuation outside) and SciPy's natural ``CubicSpline``.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from scipy.interpolate import CubicSpline

from neweul_py.cli import main
from neweul_py.description import load_description_text
from neweul_py.equations import newton_euler
from neweul_py.errors import ModelError
from neweul_py.model import symbol, time

RNG = np.random.default_rng(20261122)


def numeric(system, form: str = "closed"):
    """``(q − k)(y, ẏ, p, u, t)`` and the outputs as NumPy functions (lambdify; tests only)."""
    eq = newton_euler(system, form).substituted()
    args = (system.coordinate_symbols, system.velocity_symbols, system.parameter_symbols,
            system.input_symbols, time)
    f = sp.lambdify(args, list(eq.force_vector), "numpy")
    o = sp.lambdify(args, list(eq.outputs), "numpy")
    return (lambda y, yd, p, u=(), t=0.0: np.array(f(y, yd, p, u, t), dtype=float),
            lambda y, yd, p, u=(), t=0.0: np.array(o(y, yd, p, u, t), dtype=float))


def defaults(system) -> np.ndarray:
    return np.array([p.default for p in system.parameters])


BUSHING = """
name: bushing_test
parameters: {k11: 300, k12: 40, k13: -25, k22: 500, k23: 30, k33: 800,
             d11: 3, d12: 0.5, d22: 4, d33: 6, sw: 1}
coordinates: {alpha: 0, x: 0, y: 0, z: 0, beta: 0}
frames:
  a: {rotation: [[z, alpha]]}
  b: {translation: [x, y, z], rotation: [[x, beta]]}
forces:
  bush:
    type: bushing
    between: [a, b]
    points: [[0.1, 0, 0.05], [0, 0.2, 0]]
    stiffness: [[k11, k12, k13], [k12, k22, k23], [k13, k23, k33]]
    damping: [[d11, d12, 0], [d12, d22, 0], [0, 0, d33]]
    enabled: sw
    report: true
"""


def _rz(a):
    return sp.Matrix([[sp.cos(a), -sp.sin(a), 0], [sp.sin(a), sp.cos(a), 0], [0, 0, 1]])


def _rx(a):
    return sp.Matrix([[1, 0, 0], [0, sp.cos(a), -sp.sin(a)], [0, sp.sin(a), sp.cos(a)]])


@pytest.mark.parametrize("form", ["closed", "recursive"])
def test_bushing_translation_is_the_gradient_of_its_potential(form: str) -> None:
    """Bushing with full K, D between a rotating and a floating frame vs −∂V/∂y and
    −(∂Δr/∂y)ᵀ D Δṙ derived independently; its reported force is −(K Δr + D Δṙ)."""
    system = load_description_text(BUSHING)
    f, out = numeric(system, form)
    alpha, x, y, z, beta = (symbol(n) for n in ("alpha", "x", "y", "z", "beta"))
    q = sp.Matrix([alpha, x, y, z, beta])
    pa, pb = sp.Matrix([0.1, 0, 0.05]), sp.Matrix([0, 0.2, 0])
    dr = _rz(alpha).T * (sp.Matrix([x, y, z]) + _rx(beta) * pb - _rz(alpha) * pa)
    P = defaults(system)
    K = sp.Matrix([[P[0], P[1], P[2]], [P[1], P[3], P[4]], [P[2], P[4], P[5]]])
    D = sp.Matrix([[P[6], P[7], 0], [P[7], P[8], 0], [0, 0, P[9]]])
    V = (dr.T * K * dr)[0] / 2
    Jdr = dr.jacobian(q)
    qd = sp.Matrix(sp.symbols("v0:5"))
    ref = -sp.Matrix([V]).jacobian(q).T - Jdr.T * D * (Jdr * qd)
    ref_f = sp.lambdify((q, qd), list(ref), "numpy")
    force = sp.lambdify((q, qd), list(-(K * dr + D * Jdr * qd)), "numpy")
    for _ in range(20):
        yv, ydv = RNG.normal(size=5), RNG.normal(size=5)
        np.testing.assert_allclose(f(yv, ydv, P), ref_f(yv, ydv), rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(out(yv, ydv, P)[:3], force(yv, ydv), rtol=1e-10, atol=1e-10)
    P_off = P.copy()
    P_off[-1] = 0.0  # enabled: sw = 0 switches it off, and its report
    yv, ydv = RNG.normal(size=5), RNG.normal(size=5)
    assert np.all(f(yv, ydv, P_off) == 0) and np.all(out(yv, ydv, P_off) == 0)


def test_bushing_rotation_about_a_common_axis_has_the_cosine_potential() -> None:
    """Two frames turned about z by α, β: θ_z = sin(β − α), so the torque on B is
    −kr sin(β − α) − dr (β̇ − α̇) = −∂V/∂β with V = kr (1 − cos(β − α)); reaction on A."""
    system = load_description_text("""
name: bushing_rot
parameters: {kr: 7, dr: 0.3}
coordinates: {alpha: 0, beta: 0}
frames:
  a: {rotation: [[z, alpha]]}
  b: {rotation: [[z, beta]]}
forces:
  bush: {type: bushing, between: [a, b], rotational_stiffness: {diag: [1, 2, kr]},
         rotational_damping: dr, report: true}
""")
    f, out = numeric(system)
    P = defaults(system)
    for _ in range(20):
        (a, b), (ad, bd) = RNG.uniform(-1.5, 1.5, 2), RNG.normal(size=2)
        torque = -7 * np.sin(b - a) - 0.3 * (bd - ad)
        np.testing.assert_allclose(f([a, b], [ad, bd], P), [-torque, torque], rtol=1e-12,
                                   atol=1e-12)
        np.testing.assert_allclose(out([a, b], [ad, bd], P)[3:], [0, 0, torque], atol=1e-12)


ROTATIONAL = """
name: rot_test
parameters: {k: 5, c: 0.2, phi0: 0.3, k3: 40}
coordinates: {alpha: 0, beta: 0, phi: 0}
frames:
  a: {rotation: [[x, alpha]]}
  b: {rotation: [[x, beta]]}
forces:
  between: {type: rotational_spring_damper, between: [a, b], axis: x, stiffness: k,
            damping: c, angle: phi0, report: true}
  on_phi: {type: rotational_spring_damper, coordinate: phi, stiffness: "k + k3*s**2",
           damping: "c*(1 + sd**2)", report: true}
"""


@pytest.mark.parametrize("form", ["closed", "recursive"])
def test_rotational_spring_damper_between_frames_and_on_a_coordinate(form: str) -> None:
    """Between frames: s = β − α − φ0 about the common x axis, torque F = k s + c ṡ on B
    (−F) and A (+F). On a coordinate with nonlinear coefficients (expressions of s, sd):
    Q = −(k + k3 s²) s − c (1 + ṡ²) ṡ."""
    system = load_description_text(ROTATIONAL)
    f, out = numeric(system, form)
    P = defaults(system)
    for _ in range(20):
        y = RNG.uniform(-1.2, 1.2, 3)
        yd = RNG.normal(size=3)
        s, sd = y[1] - y[0] - 0.3, yd[1] - yd[0]
        F = 5 * s + 0.2 * sd
        G = (5 + 40 * y[2] ** 2) * y[2] + 0.2 * (1 + yd[2] ** 2) * yd[2]
        np.testing.assert_allclose(f(y, yd, P), [F, -F, -G], rtol=1e-11, atol=1e-12)
        np.testing.assert_allclose(out(y, yd, P), [F, G], rtol=1e-11, atol=1e-12)


TABLE = [[-0.1, -50.0], [0.0, 0.0], [0.05, 10.0], [0.2, 100.0], [0.3, 90.0]]


def _spring_table(interpolation: str) -> str:
    rows = ", ".join(f"[{a}, {b}]" for a, b in TABLE)
    return f"""
name: table_{interpolation}
parameters: {{c: 0.5}}
coordinates: {{x: 0}}
frames:
  b: {{translation: [x, 0, 0]}}
forces:
  sd: {{type: spring_damper, between: [ISYS, b], points: [[-1, 0, 0], [0, 0, 0]], length: 1,
        stiffness: {{table: [{rows}], interpolation: {interpolation}}}, damping: c,
        report: true}}
"""


def test_linear_table_characteristic_is_the_analytic_piecewise_function() -> None:
    """s = x (distance x + 1, free length 1); the tensile force F(s) + c ṡ pulls b back:
    Q = −F. F is numpy.interp inside the table and the end segments continued outside."""
    system = load_description_text(_spring_table("linear"))
    f, out = numeric(system)
    xs, fs = np.array(TABLE).T

    def analytic(s: float) -> float:
        if s < xs[0]:
            return fs[0] + (fs[1] - fs[0]) / (xs[1] - xs[0]) * (s - xs[0])
        if s > xs[-1]:
            return fs[-1] + (fs[-1] - fs[-2]) / (xs[-1] - xs[-2]) * (s - xs[-1])
        return float(np.interp(s, xs, fs))

    for s in [*np.linspace(-0.3, 0.5, 81), *xs]:
        for sd in (0.0, 0.7):
            expected = analytic(s) + 0.5 * sd
            np.testing.assert_allclose(f([s], [sd], [0.5]), [-expected], rtol=1e-12, atol=1e-12)
            np.testing.assert_allclose(out([s], [sd], [0.5]), [expected], rtol=1e-12,
                                       atol=1e-12)


def test_spline_table_characteristic_is_the_natural_cubic_spline() -> None:
    """Inside the table: SciPy's natural CubicSpline; outside: its end tangents."""
    system = load_description_text(_spring_table("spline"))
    f, _ = numeric(system)
    xs, fs = np.array(TABLE).T
    spline = CubicSpline(xs, fs, bc_type="natural")
    for s in np.linspace(-0.3, 0.5, 161):
        if s < xs[0]:
            expected = fs[0] + spline(xs[0], 1) * (s - xs[0])
        elif s > xs[-1]:
            expected = fs[-1] + spline(xs[-1], 1) * (s - xs[-1])
        else:
            expected = spline(s)
        np.testing.assert_allclose(f([s], [0.0], [0.5]), [-expected], rtol=1e-10, atol=1e-10)


def test_input_rates_join_the_input_vector_only_when_used() -> None:
    """``d_u`` in a force law makes ``d_u`` an input-vector entry (default: d/dt of u's
    default); an input in kinematics adds ``d_u`` and ``dd_u``."""
    system = load_description_text("""
name: rates
parameters: {c: 2}
coordinates: {x: 0}
inputs: {u: sin(3*t), w: 0}
frames:
  b: {translation: [x, 0, 0]}
  moving: {translation: [0, w, 0]}
bodies:
  m: {frame: b, mass: 1}
forces:
  damper: {type: generalized, coordinate: x, value: c*(d_u - d_x)}
""")
    assert system.input_names == ("u", "w", "d_u", "d_w", "dd_w")
    assert system.input_defaults[2] == 3 * sp.cos(3 * time)
    f, _ = numeric(system)
    np.testing.assert_allclose(f([0.1], [0.5], [2.0], [0, 0, 1.5, 0, 0]), [2.0 * (1.5 - 0.5)])


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ("{force: nothere}", "unknown force element 'nothere'; force elements are: bush"),
        ("{force: bush, component: force}",
         "reports the component(s) fx, fy, fz, mx, my, mz, not 'force'"),
    ],
)
def test_bad_force_outputs_list_the_valid_names(change: str, message: str) -> None:
    with pytest.raises(ModelError, match=message.replace("(", r"\(").replace(")", r"\)")):
        load_description_text(BUSHING.replace("report: true", "report: false")
                              + f"outputs:\n  bad: {change}\n")


def test_table_errors_name_the_key() -> None:
    text = _spring_table("linear").replace("[0.05, 10.0]", "[-0.05, 10.0]")
    with pytest.raises(ModelError, match=r"stiffness\.table\[2\].*increase strictly"):
        load_description_text(text)
    text = _spring_table("cubic")
    with pytest.raises(ModelError, match="interpolation must be 'linear' or 'spline'"):
        load_description_text(text)


def test_kinematic_excitation_is_the_same_in_closed_and_recursive_form() -> None:
    """Quarter-car on a road input (road frame moved by zr; tire damper sees d_zr): both forms
    give the hand-written forces −kt (zw − zr − lt) − ct (żw − ż_r) − mw g, suspension …"""
    import pathlib

    from neweul_py.description import load_description

    root = pathlib.Path(__file__).resolve().parents[2]
    system = load_description(root / "examples" / "quarter_car.yaml")
    P = defaults(system)
    pv = dict(zip([p.name for p in system.parameters], P, strict=True))
    for form in ("closed", "recursive"):
        f, _ = numeric(system, form)
        for _ in range(5):
            zw, zb = 0.28 + 0.01 * RNG.normal(), 0.6 + 0.01 * RNG.normal()
            vw, vb = RNG.normal(size=2)
            zr, dzr, ddzr = 0.01 * RNG.normal(), RNG.normal(), RNG.normal()
            tire = pv["kt"] * (zw - zr - pv["lt"]) + pv["ct"] * (vw - dzr)
            susp = pv["ks"] * (zb - zw - pv["ls"]) + pv["cs"] * (vb - vw)
            ref = [-tire + susp - pv["mw"] * pv["g"], -susp - pv["mb"] * pv["g"]]
            np.testing.assert_allclose(f([zw, zb], [vw, vb], P, [zr, dzr, ddzr]), ref,
                                       rtol=1e-12)


def test_enabled_and_report_for_forces_torques_and_generalized_forces() -> None:
    """The issue-2 elements get the same switch and reports: a point force's vector (its `in`
    frame), a torque's vector, a generalized force's value, all times `enabled`."""
    system = load_description_text("""
name: switches
parameters: {F: 2, L: 3, Q: 5, sw: 1}
coordinates: {x: 0, phi: 0}
frames:
  b: {translation: [x, 0, 0], rotation: [[z, phi]]}
forces:
  push: {type: force, frame: b, point: [1, 0, 0], vector: [F, 0, 0], in: ISYS, enabled: sw,
         report: true}
  turn: {type: torque, frame: b, vector: [0, 0, L], in: b, enabled: sw, report: true}
  gen: {type: generalized, coordinate: x, value: Q, enabled: 2*sw, report: true}
""")
    f, out = numeric(system)
    assert [o.name for o in system.outputs] == ["push_fx", "push_fy", "push_fz", "turn_mx",
                                                "turn_my", "turn_mz", "gen_force"]
    y, yd = [0.2, 0.4], [0.0, 0.0]
    # push at (1, 0, 0) of b: Q_x = F, Q_phi = (R e_x × F e_x)_z = −F sin(phi)
    np.testing.assert_allclose(f(y, yd, [2, 3, 5, 1]), [2 + 10, -2 * np.sin(0.4) + 3])
    np.testing.assert_allclose(out(y, yd, [2, 3, 5, 1]), [2, 0, 0, 0, 0, 3, 10])
    assert np.all(f(y, yd, [2, 3, 5, 0]) == 0) and np.all(out(y, yd, [2, 3, 5, 0]) == 0)


def test_rotation_driven_by_an_input_uses_its_rates() -> None:
    """A base turned by the input angle u about z, an arm with inertia J on it (angle phi
    relative): M = J, q − k = −J ü − k phi (ω = u̇ + φ̇, α = ü + φ̈)."""
    system = load_description_text("""
name: driven_rotation
parameters: {J: 0.3, k: 4}
coordinates: {phi: 0}
inputs: {u: 0}
frames:
  base: {rotation: [[z, u]]}
  arm: {parent: base, rotation: [[z, phi]]}
bodies:
  disc: {frame: arm, mass: 1, inertia: {diag: [0.2, 0.2, J]}}
forces:
  spring: {type: rotational_spring_damper, coordinate: phi, stiffness: k}
""")
    assert system.input_names == ("u", "d_u", "dd_u")
    f, _ = numeric(system)
    np.testing.assert_allclose(f([0.2], [0.5], [0.3, 4], [0.1, 0.7, 1.3]),
                               [-0.3 * 1.3 - 4 * 0.2], rtol=1e-13)


# ---------------------------------------------------------------- zero-length springs
# The rule of docs/description-format.md. Reference: the force of a linear
# spring of rest length 0, ``F e = k d``, is defined at ``d = 0`` (closed form: the generated
# force is ``−k x``); with a rest length or damping the direction ``e = d/|d|`` is undefined
# where the points meet.

BASE = """name: zl
parameters: {m: 1.0, k: 100.0, c: 1.0, L: 0.1}
coordinates:
  x: {initial: 0.0, velocity: 0.0}
frames:
  cart: {parent: ISYS, translation: [x, 0, 0]}
bodies:
  b: {frame: cart, mass: m}
forces:
  s: {type: spring_damper, between: [BETWEEN], stiffness: k, LAW}
"""


def _write(tmp_path, between: str, law: str):
    path = tmp_path / "zl.yaml"
    path.write_text(BASE.replace("BETWEEN", between).replace("LAW", law))
    return str(path)


@pytest.fixture
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("NEWEUL_CACHE", str(tmp_path / "cache"))


@pytest.mark.usefixtures("_cache")
@pytest.mark.parametrize("law", ["damping: c", "length: L", "damping: c, length: L"])
def test_points_that_always_coincide_are_refused_at_load(tmp_path, capsys, law):
    desc = _write(tmp_path, "cart, cart", law)
    for command in (["generate", desc, "-o", str(tmp_path / "g")], ["equilibrium", desc]):
        assert main(command) == 1
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "forces.s.points" in err and "coincide" in err
        assert "zl.yaml" in err


@pytest.mark.parametrize("command", [["simulate", "--t-end", "1"], ["equilibrium"],
                                     ["linearize", "--at", "initial"], ["modes"]])
@pytest.mark.usefixtures("_cache")
def test_points_that_meet_at_the_start_give_one_error(tmp_path, capsys, command):
    """Points that coincide at the initial state with a rest length: the division by zero
    (ZeroDivisionError in the generated module) becomes one error line."""
    desc = _write(tmp_path, "ISYS, cart", "damping: c, length: L")
    assert main([command[0], desc, *command[1:]]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "ZeroDivisionError" in err and "Traceback" not in err


@pytest.mark.usefixtures("_cache")
def test_linear_zero_length_spring_is_regular_at_zero(tmp_path):
    """No rest length, no damping: F e = k d, finite at d = 0 (the rule of the docs)."""
    from neweul_py.api import load_description_module

    module = load_description_module(_write(tmp_path, "ISYS, cart", "length: 0"))
    p = module.default_parameters()
    for x in (0.0, 0.2):
        f = module.force_vector(0.0, np.array([x]), np.array([0.0]), p)
        assert np.allclose(f, [-100.0 * x])


# ---------------------------------------------------------------- potentials
PROGRESSIVE = """
name: progressive
parameters: {m: 1, k: 100, s1: 0.1, c: 0.5, l0: 0.2, k2: 30}
coordinates: {x: 0.3, phi: 0.1}
frames:
  cart: {translation: [x, 0, 0]}
  arm: {parent: cart, rotation: [[z, phi]]}
bodies:
  b: {frame: arm, mass: m, inertia: {diag: [1, 1, 1]}}
forces:
  progressive: {type: spring_damper, between: [ISYS, cart], stiffness: k*(1 + (s/s1)**2),
                damping: c*abs(sd), length: l0}
  linear: {type: spring_damper, between: [ISYS, cart], stiffness: k2, length: l0}
  hinge: {type: rotational_spring_damper, coordinate: phi, stiffness: k2*(1 + s**2)}
"""


def test_springs_with_coefficients_of_s_have_no_potential_and_generate() -> None:
    """Only the spring with a constant stiffness forms a potential: the energy's springs
    entry is ``½ k2 (|x| − l0)²`` (closed form), free of the local symbols ``s``, ``sd``; the
    generated module renders (a potential ``½ k(s) s²`` carried ``s`` into the code)."""
    from neweul_py.codegen import render_module

    system = load_description_text(PROGRESSIVE)
    eq = newton_euler(system)
    springs = eq.energy[2]
    x, phi = symbol("x"), symbol("phi")
    assert springs.free_symbols <= {x, phi, *system.parameter_symbols}
    value = springs.subs({x: 0.35, phi: 0.4, **system.parameter_defaults})
    assert float(value) == pytest.approx(0.5 * 30 * (0.35 - 0.2) ** 2, rel=1e-14)
    assert "def energy(" in render_module(eq, "0" * 64)
