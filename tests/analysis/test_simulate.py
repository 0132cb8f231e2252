"""Simulation of the shipped generated modules (``generated/``) against physics.

References: conservation of energy ``T + V`` with ``T = ½ ẏᵀ M ẏ`` and ``V = Σ m g z`` (from the
models' center-of-mass outputs) for the conservative double pendulum and heavy top; the
analytic small-oscillation frequency ``ω = √(g/l)`` of the mathematical pendulum.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from _analysis_helpers import load_fixture

from neweul_py.analysis.module import load_generated
from neweul_py.analysis.simulate import simulate
from neweul_py.errors import NeweulError

GENERATED = Path(__file__).resolve().parents[2] / "generated"


def _module(name: str):
    return load_generated(GENERATED / f"{name}.py")


def _energy(mod, res, masses: dict[str, str]) -> np.ndarray:
    """T + V along a result; ``masses`` maps a height output to its mass parameter."""
    p = np.array(list(res.parameters.values()))
    g = res.parameters["g"]
    e = np.empty(res.t.size)
    for k in range(res.t.size):
        y, yd = res.y[k], res.yd[k]
        kinetic = 0.5 * yd @ mod.mass_matrix(res.t[k], y, p) @ yd
        potential = sum(res.parameters[m] * g * res.column(z)[k] for z, m in masses.items())
        e[k] = kinetic + potential
    return e


@pytest.mark.parametrize(
    ("name", "masses"),
    [
        ("double_pendulum", {"z_rod1": "m1", "z_rod2": "m2"}),
        ("heavy_top", {"z_cm": "m"}),
    ],
)
def test_energy_is_conserved(name, masses):
    """Conservative models keep T + V to 1e-8 relative over 10 s (DOP853, tol 1e-12)."""
    mod = _module(name)
    res = simulate(mod, 10.0, method="DOP853", rtol=1e-12, atol=1e-12, n_out=201)
    e = _energy(mod, res, masses)
    assert np.max(np.abs(e - e[0])) / abs(e[0]) < 1e-8
    assert np.ptp(res.y[:, 0]) > 0.1  # it really moved


def test_pendulum_small_oscillation_frequency_from_jacobian():
    """Eigenvalues of rhs_jacobian at the rest position are ±i√(g/l)."""
    mod = _module("pendulum")
    p = mod.default_parameters()
    prm = dict(zip(mod.PARAMETERS, p, strict=True))
    lam = np.linalg.eigvals(mod.rhs_jacobian(0.0, np.zeros(2), p))
    omega = np.sqrt(prm["g"] / prm["l"])
    np.testing.assert_allclose(np.sort(lam.imag), [-omega, omega], rtol=1e-12)
    np.testing.assert_allclose(lam.real, 0.0, atol=1e-12)


def test_pendulum_small_oscillation_period_from_simulation():
    """Zero crossings of a 1e-4 rad swing are half a period 2π/√(g/l) apart (amplitude
    correction ~ a²/16 ≈ 1e-9)."""
    mod = _module("pendulum")
    res = simulate(mod, 10.0, x0={"phi": 1e-4, "d_phi": 0.0}, method="DOP853", rtol=1e-12,
                   atol=1e-16, n_out=20001)
    phi, t = res.y[:, 0], res.t
    i = np.nonzero(np.sign(phi[:-1]) != np.sign(phi[1:]))[0]
    crossings = t[i] - phi[i] * (t[i + 1] - t[i]) / (phi[i + 1] - phi[i])
    period = 2 * np.mean(np.diff(crossings))
    omega = np.sqrt(res.parameters["g"] / res.parameters["l"])
    assert period == pytest.approx(2 * np.pi / omega, rel=1e-6)


def test_parameters_by_name_change_the_frequency():
    mod = _module("pendulum")
    p = mod.default_parameters().copy()
    p[list(mod.PARAMETERS).index("l")] = 2.0
    lam = np.linalg.eigvals(mod.rhs_jacobian(0.0, np.zeros(2), p))
    res_a = simulate(mod, 1.0, p={"l": 2.0}, n_out=3)
    res_b = simulate(mod, 1.0, p=p, n_out=3)
    np.testing.assert_allclose(res_a.y, res_b.y)
    assert res_a.parameters["l"] == 2.0
    assert np.max(lam.imag) == pytest.approx(np.sqrt(9.81 / 2.0))


@pytest.mark.parametrize("method", ["Radau", "BDF", "LSODA"])
def test_implicit_methods_agree_with_dop853(method):
    """The implicit methods (with the analytic Jacobian) reproduce the explicit reference."""
    mod = _module("cart_pendulum")
    ref = simulate(mod, 2.0, method="DOP853", rtol=1e-11, atol=1e-11, n_out=21)
    res = simulate(mod, 2.0, method=method, rtol=1e-9, atol=1e-10, n_out=21)
    np.testing.assert_allclose(res.y, ref.y, atol=1e-5)
    np.testing.assert_allclose(res.outputs, ref.outputs, atol=1e-4)


def test_inputs_override_the_default_excitation():
    mod = _module("cart_pendulum")
    free = simulate(mod, 1.0, u={"F": 0.0}, n_out=5)
    driven = simulate(mod, 1.0, n_out=5)
    by_callable = simulate(mod, 1.0, u=lambda t: [2.0 * np.sin(4.0 * t)], n_out=5)
    assert not np.allclose(free.y, driven.y)
    np.testing.assert_allclose(by_callable.y, driven.y, rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"t_end": -1.0}, "t_end"),
        ({"t_end": 1.0, "method": "Euler"}, "unknown method 'Euler'; methods are: RK45"),
        ({"t_end": 1.0, "p": {"length": 1.0}}, "unknown parameter 'length'; parameters are: m"),
        ({"t_end": 1.0, "x0": {"psi": 1.0}}, "unknown state 'psi'; states are: phi, d_phi"),
        ({"t_end": 1.0, "x0": [1.0]}, "x0 has 1 entries"),
        ({"t_end": 1.0, "p": [1.0]}, "p has 1 entries"),
    ],
)
def test_bad_arguments_are_one_clear_error(kwargs, message):
    with pytest.raises(NeweulError, match=message.replace("(", r"\(")):
        simulate(_module("pendulum"), **kwargs)


def test_singular_mass_matrix_is_a_solver_error(tmp_path):
    from neweul_py.errors import SolverError

    mod = _module("pendulum")
    with pytest.raises(SolverError, match="singular mass matrix"):
        simulate(mod, 1.0, p={"m": 0.0})


def test_constrained_modules_go_through_the_dae_solver():
    """A closed loop (slider-crank) is simulated with its constraint forces: the result equals
    simulate_constrained's and the loop stays closed."""
    from neweul_py.analysis.dae import simulate_constrained

    mod = _module("slider_crank")
    assert mod.CONSTRAINTS
    res = simulate(mod, 0.5, n_out=11, method="DOP853", rtol=1e-10, atol=1e-12)
    ref = simulate_constrained(mod, 0.5, n_out=11, method="DOP853", rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(res.y, ref.result.y, rtol=1e-12, atol=1e-14)
    p = mod.default_parameters()
    assert max(np.max(np.abs(mod.constraints(t, y, p))) for t, y in zip(res.t, res.y,
                                                                         strict=True)) < 1e-8


def test_simulation_needs_no_sympy(tmp_path):
    """analysis/ works on generated modules alone: simulate and write results with sympy made
    unimportable."""
    import subprocess
    import sys
    import textwrap

    code = textwrap.dedent(f"""
        import sys
        sys.modules["sympy"] = None
        from neweul_py.analysis import simulate
        res = simulate({str(GENERATED / "cart_pendulum.py")!r}, 0.5, method="Radau")
        res.to_csv({str(tmp_path / "out.csv")!r})
        assert not any(m.startswith(("neweul_py.equations", "neweul_py.codegen",
                                     "neweul_py.description", "neweul_py.kinematics"))
                       for m in sys.modules)
        print("ok")
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "ok"


def test_massless_coordinate_is_named():
    """M = diag(m1, m2) of the two-mass oscillator (fixtures/two_mass.py): with m2 = 0 the
    coordinate x2 carries no inertia, and the error says so (as linearize/modes/frf do)."""
    from neweul_py.errors import SolverError

    with pytest.raises(SolverError, match=r"singular mass matrix at t = 0: no inertia in the "
                                          r"motion of coordinate\(s\) x2$"):
        simulate(load_fixture("two_mass"), 1.0, p={"m2": 0.0})


def test_independent_needs_constraints():
    with pytest.raises(NeweulError, match="independent coordinates apply to models with "
                                          "constraints; pendulum has none"):
        simulate(_module("pendulum"), 1.0, independent=["phi"])


@pytest.mark.parametrize(("name", "method", "kind"), [
    ("pendulum", "RK45", "SolveIVP"),
    ("pendulum", "Radau", "SolveIVP"),
    ("pendulum", "generalized-alpha", "GeneralizedAlphaSteps"),
    ("pendulum", "c-dopri5", "CompiledLoop"),
    ("slider_crank", "DOP853", "ConstrainedDAE"),
])
def test_the_method_and_the_model_pick_the_integrator(name, method, kind):
    """The table of docs/analysis.md: a SciPy method steps the DAE of a model with
    constraints, the ODE otherwise; the other methods have their own integrator."""
    from neweul_py.analysis.simulate import integrator

    strategy = integrator(method, _module(name))
    assert type(strategy).__name__ == kind and strategy.method == method


def test_an_unknown_option_is_a_type_error_naming_it():
    """Like any Python function: the misspelt keyword and the valid ones are named."""
    with pytest.raises(TypeError, match=r"'rtoll'.*rtol"):
        simulate(_module("pendulum"), 1.0, rtoll=1e-8)
