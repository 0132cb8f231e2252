"""The fixed-step generalized-α integrator (analysis/generalized_alpha.py) against closed forms.

References: the damped linear oscillator ``x(t) = e^{−ζωt}(x0 cos ω_d t + …)``; the period of
the mathematical pendulum ``T = 4 √(l/g) K(sin²(φ0/2))`` (complete elliptic integral of the
first kind); and the method's design property (Chung & Hulbert 1993): the spectral radius of
one step at ``ω h → ∞`` is ``ρ∞``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.special import ellipk

from neweul_py.analysis.generalized_alpha import coefficients
from neweul_py.analysis.module import load_generated
from neweul_py.analysis.simulate import simulate
from neweul_py.codegen import generate_module
from neweul_py.description import load_description_text
from neweul_py.equations import newton_euler
from neweul_py.errors import NeweulError

GENERATED = Path(__file__).resolve().parents[2] / "generated"

OSCILLATOR = """
name: oscillator
parameters: {m: 2.0, k: 50.0, c: 0.4}
coordinates:
  z: {initial: 1.1, velocity: 0.0}   # x = z − 1: a linear spring and damper
frames:
  mass: {translation: [0, 0, z]}
bodies:
  block: {frame: mass, mass: m}
forces:
  spring: {type: generalized, coordinate: z, value: -k*(z - 1) - c*d_z}
"""


@pytest.fixture(scope="module")
def oscillator(tmp_path_factory):
    def make(k: float, c: float):
        text = OSCILLATOR.replace("k: 50.0", f"k: {k!r}").replace("c: 0.4", f"c: {c!r}")
        path = tmp_path_factory.mktemp("osc") / "oscillator.py"
        return load_generated(generate_module(newton_euler(load_description_text(text)),
                                              "0" * 64, path))
    return make


def _oscillator_exact(t: np.ndarray, m: float, k: float, c: float, x0: float) -> np.ndarray:
    w = np.sqrt(k / m)
    zeta = c / (2 * np.sqrt(k * m))
    wd = w * np.sqrt(1 - zeta**2)
    return np.exp(-zeta * w * t) * x0 * (np.cos(wd * t) + zeta * w / wd * np.sin(wd * t))


@pytest.mark.parametrize("rho_inf", [1.0, 0.9, 0.5, 0.0])
def test_second_order_on_the_damped_oscillator(oscillator, rho_inf) -> None:
    """Global error at t = 2 s falls by 4 when h halves (order 2 for every ρ∞; closed form
    of the damped linear oscillator)."""
    mod = oscillator(50.0, 0.4)
    errors = []
    for h in (0.02, 0.01, 0.005):
        res = simulate(mod, 2.0, method="generalized-alpha", h=h, rho_inf=rho_inf,
                       rtol=1e-12, atol=1e-14, n_out=3)
        exact = _oscillator_exact(res.t, 2.0, 50.0, 0.4, 0.1)
        errors.append(np.max(np.abs(res.y[:, 0] - 1.0 - exact)))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all((orders > 1.85) & (orders < 2.3)), (errors, orders)
    assert errors[-1] < 2e-3 * 0.1


def test_pendulum_period_closed_form() -> None:
    """After one period ``T = 4√(l/g) K(sin²(φ0/2))`` (φ0 = 0.3 rad) the pendulum is back at
    φ0 at rest, to O(h²): error ratio ≈ 4 per halving; outputs between steps are the
    Hermite-interpolated states (the bob's x = −l sin φ)."""
    mod = load_generated(GENERATED / "pendulum.py")
    l_, g, phi0 = 0.5, 9.81, 0.3
    period = 4 * np.sqrt(l_ / g) * ellipk(np.sin(phi0 / 2) ** 2)
    errs = []
    for h in (period / 100, period / 200, period / 400):
        res = simulate(mod, period, method="generalized-alpha", h=h, rho_inf=0.8,
                       rtol=1e-12, atol=1e-14, n_out=7)
        errs.append(abs(res.y[-1, 0] - phi0) + abs(res.yd[-1, 0]) * np.sqrt(l_ / g))
        np.testing.assert_allclose(res.column("x_bob"), -l_ * np.sin(res.y[:, 0]), atol=1e-12)
    ratio = np.array(errs[:-1]) / np.array(errs[1:])
    assert np.all((ratio > 3.5) & (ratio < 4.6)), (errs, ratio)
    # the quarter period: the bob passes the bottom (φ = 0) at T/4
    res = simulate(mod, period / 4, method="generalized-alpha", h=period / 800, n_out=2,
                   rtol=1e-12, atol=1e-14)
    assert abs(res.y[-1, 0]) < 1e-4


@pytest.mark.parametrize("rho_inf", [0.0, 0.5, 0.9])
def test_unresolved_mode_is_damped_by_rho_inf(oscillator, rho_inf) -> None:
    """An undamped mode with ω h = 1e4 decays per step by the spectral radius ρ∞, a double
    root at ω h → ∞ (the method's design property, Chung & Hulbert 1993), so the amplitude
    goes like k ρ∞ᵏ after the first steps' velocity overshoot (Erlicher et al. 2002): the rate
    over steps 20 … 30 is ρ∞ (ρ∞ = 0: annihilated within a few steps). A resolved mode
    (ω h = 0.01, 300 steps) keeps its amplitude to 1e-5."""
    w = np.sqrt(1e8 / 2.0)
    mod = oscillator(1e8, 0.0)
    h = 1e4 / w
    res = simulate(mod, 30 * h, method="generalized-alpha", h=h, rho_inf=rho_inf,
                   rtol=1e-10, atol=1e-12, n_out=31)
    amp = np.abs(res.y[:, 0] - 1.0) + np.abs(res.yd[:, 0]) / w
    if rho_inf == 0.0:
        assert np.all(amp[8:] < 1e-10 * amp[0]), amp
    else:
        rate = (amp[30] / amp[20]) ** 0.1 / 1.5 ** 0.1  # k ρᵏ: (30/20)·ρ¹⁰
        assert abs(rate - rho_inf) < 0.03 * rho_inf, (rate, amp)
    slow = oscillator(1.0, 0.0)
    w = np.sqrt(0.5)
    res = simulate(slow, 300 * 0.01 / w, method="generalized-alpha", h=0.01 / w,
                   rho_inf=rho_inf, rtol=1e-13, atol=1e-16, n_out=2)
    amp = np.hypot(res.y[-1, 0] - 1.0, res.yd[-1, 0] / w)
    assert abs(amp - 0.1) < 1e-5


def test_coefficients_of_chung_hulbert() -> None:
    """α_m, α_f, γ, β of Chung & Hulbert (1993), Eqs. (25), (17), (20): ρ∞ = 1 is the
    trapezoidal rule (α_m = α_f = ½, γ = ½, β = ¼)."""
    c = coefficients(1.0)
    assert (c.alpha_m, c.alpha_f, c.gamma, c.beta) == (0.5, 0.5, 0.5, 0.25)
    c = coefficients(0.0)
    assert (c.alpha_m, c.alpha_f, c.gamma, c.beta) == (-1.0, 0.0, 1.5, 1.0)


def test_bad_arguments_are_clear_errors(oscillator) -> None:
    """No step, a bad ρ∞ or a bad h: one NeweulError naming the argument."""
    mod = oscillator(50.0, 0.4)
    with pytest.raises(NeweulError, match="needs the step h"):
        simulate(mod, 1.0, method="generalized-alpha")
    with pytest.raises(NeweulError, match="rho_inf"):
        simulate(mod, 1.0, method="generalized-alpha", h=0.1, rho_inf=1.5)
    with pytest.raises(NeweulError, match="step h"):
        simulate(mod, 1.0, method="generalized-alpha", h=-0.1)


@pytest.mark.parametrize("h", [1e-300, 1e-320, 5e-324])
def test_step_count_is_capped_before_the_first_step(oscillator, capsys, h) -> None:
    """``--step 1e-300`` hung (10³⁰⁰ steps) and ignored ``--max-steps``; 1e-320 overflowed the
    step count. The count ceil(T / h) is checked against ``max_steps`` (API default 10⁹, the
    CLI's ``--max-steps``, default 10⁶) before anything is integrated. Reference: the
    arithmetic T / h."""
    from neweul_py.analysis.generalized_alpha import MAX_STEPS
    from neweul_py.cli import main

    mod = oscillator(50.0, 0.4)
    with pytest.raises(NeweulError, match=f"more than max_steps = {MAX_STEPS}"):
        simulate(mod, 1.0, method="generalized-alpha", h=h)
    with pytest.raises(NeweulError, match=r"2000 steps .* more than max_steps = 1000"):
        simulate(mod, 2.0, method="generalized-alpha", h=1e-3, max_steps=1000)
    assert simulate(mod, 1.0, method="generalized-alpha", h=1e-3, max_steps=1000).t[-1] == 1.0
    path = str(GENERATED / "pendulum.py")
    for extra, cap in (([], "1000000"), (["--max-steps", "10"], "10")):
        code = main(["simulate", path, "--t-end", "1", "--method", "generalized-alpha",
                     "--step", repr(h), "-q", *extra])
        err = capsys.readouterr().err
        assert code == 1 and err.count("\n") == 1 and f"--max-steps {cap}" in err


def test_cli_step_and_rho_inf(capsys) -> None:
    """``neweul simulate --method generalized-alpha --step H --rho-inf R`` gives the final state
    of the API call with the same arguments (reference: ``simulate``); without ``--step`` it
    is one error line naming the option."""
    from neweul_py.cli import main

    path = GENERATED / "pendulum.py"
    assert main(["simulate", str(path), "--t-end", "0.5", "--method", "generalized-alpha",
                 "--step", "1e-3", "--rho-inf", "0.5", "-q"]) == 0
    out = capsys.readouterr().out
    res = simulate(load_generated(path), 0.5, method="generalized-alpha", h=1e-3, rho_inf=0.5)
    assert f"phi = {res.y[-1, 0]:.6g}" in out
    assert main(["simulate", str(path), "--t-end", "0.5", "--method", "generalized-alpha",
                 "-q"]) == 1
    assert "--step" in capsys.readouterr().err


def test_absolute_tolerance_per_state(oscillator) -> None:
    """``atol`` may be one value per state ``[y, ẏ]``: the same value everywhere gives the
    scalar's trajectory exactly, and a velocity tolerance in velocity units (ω times the
    position's) still meets the closed form of the damped oscillator to the method's error
    (1e-4 at h = 1e-3 s, ω = 5 rad/s)."""
    mod = oscillator(50.0, 0.4)
    kw = {"method": "generalized-alpha", "h": 1e-3, "rho_inf": 0.8, "rtol": 1e-10, "n_out": 11}
    scalar = simulate(mod, 2.0, atol=1e-12, **kw)
    uniform = simulate(mod, 2.0, atol=np.full(mod.STATE_SIZE, 1e-12), **kw)
    np.testing.assert_array_equal(uniform.y, scalar.y)
    units = simulate(mod, 2.0, atol=np.array([1e-12, 5e-12]), **kw)
    exact = 1.0 + _oscillator_exact(units.t, 2.0, 50.0, 0.4, 0.1)
    assert np.abs(units.y[:, 0] - exact).max() < 1e-4


@pytest.mark.parametrize(("atol", "method", "match"), [
    (np.array([1e-9, 1e-9, 1e-9]), "generalized-alpha", r"one value per state \(2\), got shape"),
    (np.array([1e-9, -1.0]), "generalized-alpha", "atol must be a positive number"),
    (np.array([1e-9, np.nan]), "RK45", "atol must be a positive number"),
    (["a", "b"], "RK45", "atol must be a positive number"),
    ("1e-9", "generalized-alpha", "atol must be a positive number"),
    (True, "generalized-alpha", "atol must be a positive number"),
    (1e-9 + 1e-9j, "RK45", "atol must be a positive number"),
    ({"z": 1e-9}, "RK45", "atol must be a positive number"),
])
def test_bad_absolute_tolerance_is_refused(oscillator, atol, method, match) -> None:
    """A per-state ``atol`` of the wrong length, or a value that is not a positive real
    number (text, a flag, complex, a mapping), is one NeweulError naming ``atol``."""
    with pytest.raises(NeweulError, match=match):
        simulate(oscillator(50.0, 0.4), 1.0, method=method, h=1e-3, atol=atol)


STIFF_SOFT = """
name: stiff_soft
parameters: {k1: 1.0, k2: 1.0e8, kc: 1.0}
coordinates:
  z1: {initial: 1.0, velocity: 0.0}
  z2: {initial: 0.0, velocity: 0.0}
frames:
  a: {translation: [0, 0, z1]}
  b: {translation: [z2, 0, 0]}
bodies:
  ma: {frame: a, mass: 1.0}
  mb: {frame: b, mass: 1.0}
forces:
  soft: {type: generalized, coordinate: z1, value: -k1*z1 - kc*(z1 - z2)}
  stiff: {type: generalized, coordinate: z2, value: -k2*(1 + 0.9*sin(2*pi*t))*z2 - kc*(z2 - z1)}
"""


def test_time_varying_stiffness_with_a_reused_iteration_matrix(tmp_path) -> None:
    """A soft oscillator coupled to a stiff spring whose stiffness varies by ±90 % (ω h = 100
    for the stiff one): the iteration matrix is reused over the steps while the stiffness
    moves away from it. Reference: the stiff spring holds ``z2 ≈ kc z1 / k2 ≈ 10⁻⁸ z1``, so
    the soft coordinate is the oscillator ``z1 = cos(√(k1 + kc) t)`` to O(kc/k2) (SciPy's
    Radau at rtol 1e-9 agrees to 1e-4; too slow for a unit test). Generalized-α must stay
    bounded and give ``z1`` to the method's error; accepting the first increment of an old
    matrix without measuring its contraction gave 10⁶⁴ at t = 3 s."""
    mod = load_generated(generate_module(newton_euler(load_description_text(STIFF_SOFT)),
                                         "0" * 64, tmp_path / "stiff_soft.py"))
    ga = simulate(mod, 3.0, method="generalized-alpha", h=1e-2, rho_inf=0.5, rtol=1e-6,
                  atol=1e-8, n_out=31)
    assert np.abs(ga.y[:, 1]).max() < 1e-5
    assert np.abs(ga.y[:, 0] - np.cos(np.sqrt(2.0) * ga.t)).max() < 2e-3


def _compiled(text: str, tmp_path: Path):
    """The NumPy module of ``text`` and its compiled module (C backend, its own loop)."""
    from neweul_py.codegen.c_module import write_c_module

    eq = newton_euler(load_description_text(text))
    npath = generate_module(eq, "0" * 64, tmp_path / "model.py")
    mod = load_generated(write_c_module(eq, npath))
    if mod.BACKEND != "c":
        pytest.skip(f"no compiled backend here: {mod.BACKEND_NOTE}")
    assert mod.generalized_alpha_steps is not None
    return load_generated(npath), mod


def test_compiled_loop_takes_the_python_loops_steps_on_the_oscillator(tmp_path) -> None:
    """The C loop of a compiled module (Newton's method on the residual ``M ÿ − (q − k)``
    with ``S⁻¹``) against the Python loop on the same module (on
    ``ÿ − M⁻¹(q − k)`` with ``S⁻¹ M``): for a constant mass matrix both are the same
    iteration, so the states agree to round-off, with the same number of evaluations; and
    ``simulate`` uses the C loop (its result is the loop's). Reference for both: the closed
    form of the damped oscillator to the method's error."""
    from neweul_py.analysis.generalized_alpha import integrate_generalized_alpha

    _mnp, mod = _compiled(OSCILLATOR, tmp_path)
    p, x0 = mod.default_parameters(), np.asarray(mod.INITIAL_STATE, dtype=float)
    times = np.linspace(0.0, 2.0, 41)
    kw = {"h": 1e-3, "rho_inf": 0.5, "rtol": 1e-8, "atol": 1e-10, "names": ["z", "d_z"]}
    py = integrate_generalized_alpha(mod, (0.0, 2.0), x0, p, lambda t: None, times, **kw)
    c = integrate_generalized_alpha(mod, (0.0, 2.0), x0, p, lambda t: None, times,
                                    loop_inputs=None, **kw)
    np.testing.assert_allclose(c.y, py.y, rtol=0, atol=1e-12)
    assert c.nfev == py.nfev
    exact = 1.0 + _oscillator_exact(times, 2.0, 50.0, 0.4, 0.1)
    assert np.abs(c.y[0] - exact).max() < 1e-5
    res = simulate(mod, 2.0, method="generalized-alpha", h=1e-3, rho_inf=0.5, rtol=1e-8,
                   atol=1e-10, n_out=41)
    np.testing.assert_allclose(res.y[:, 0], c.y[0], rtol=0, atol=1e-14)


def test_compiled_loop_with_time_varying_stiffness(tmp_path) -> None:
    """The stiff spring of ``test_time_varying_stiffness_with_a_reused_iteration_matrix`` in
    the C loop: bounded, ``z1`` the oscillator ``cos(√2 t)`` to the method's error (the same
    reference and bounds). The mass matrix is constant, so the C loop must be the Python
    loop's iteration on the same module, its rebuilds of the matrix included (a rebuilt
    matrix is fresh for the step after the retry too): the same evaluations and the same
    states to round-off."""
    from neweul_py.analysis.generalized_alpha import integrate_generalized_alpha

    _mnp, mod = _compiled(STIFF_SOFT, tmp_path)
    ga = simulate(mod, 3.0, method="generalized-alpha", h=1e-2, rho_inf=0.5, rtol=1e-6,
                  atol=1e-8, n_out=31)
    assert np.abs(ga.y[:, 1]).max() < 1e-5
    assert np.abs(ga.y[:, 0] - np.cos(np.sqrt(2.0) * ga.t)).max() < 2e-3
    p, x0 = mod.default_parameters(), np.asarray(mod.INITIAL_STATE, dtype=float)
    times = np.linspace(0.0, 3.0, 31)
    kw = {"h": 1e-2, "rho_inf": 0.5, "rtol": 1e-6, "atol": 1e-8, "names": list("abcd")}
    py = integrate_generalized_alpha(mod, (0.0, 3.0), x0, p, lambda t: None, times, **kw)
    c = integrate_generalized_alpha(mod, (0.0, 3.0), x0, p, lambda t: None, times,
                                    loop_inputs=None, **kw)
    assert c.njev == py.njev > 5 and c.nfev == py.nfev
    np.testing.assert_allclose(c.y, py.y, rtol=0, atol=1e-12)


def test_compiled_loop_starts_from_a_jacobian_with_nan(tmp_path) -> None:
    """A damper ``c √(z² + ż²)`` from rest: its derivatives are 0/0 at the start, so the
    first iteration matrix holds NaN. The Python loop's increments are then NaN, its
    iterations fail and it rebuilds the matrix at the predictor; the C loop must do the
    same instead of reporting a singular matrix (reference: the Python loop on the same
    module, to round-off)."""
    from neweul_py.analysis.generalized_alpha import integrate_generalized_alpha

    text = OSCILLATOR.replace("z: {initial: 1.1, velocity: 0.0}",
                              "z: {initial: 0.0, velocity: 0.0}").replace(
        "value: -k*(z - 1) - c*d_z", "value: -k*z - c*sqrt(z**2 + d_z**2) + 1")
    _mnp, mod = _compiled(text, tmp_path)
    p, x0 = mod.default_parameters(), np.zeros(2)
    times = np.linspace(0.0, 0.5, 11)
    kw = {"h": 1e-2, "rho_inf": 0.5, "rtol": 1e-8, "atol": 1e-10, "names": ["z", "d_z"]}
    py = integrate_generalized_alpha(mod, (0.0, 0.5), x0, p, lambda t: None, times, **kw)
    c = integrate_generalized_alpha(mod, (0.0, 0.5), x0, p, lambda t: None, times,
                                    loop_inputs=None, **kw)
    assert np.all(np.isfinite(c.y)) and c.y[0, -1] > 0
    np.testing.assert_allclose(c.y, py.y, rtol=0, atol=1e-12)


def test_compiled_loop_refuses_a_force_that_is_not_a_number(tmp_path) -> None:
    """A force ``√(1.2 − z)`` with the mass moving up from ``z = 1.19``: finite where the run
    starts (and so is the iteration matrix), NaN in the compiled module's C once an iterate
    passes ``z = 1.2``. The Python loop's increments are then NaN, its Newton iterations fail
    and the run ends with a SolverError; the C loop must end the same way instead of
    accepting NaN states (the largest of its increments by ``fmax`` would drop a NaN).
    Reference: the Python loop on the same module."""
    from neweul_py.analysis.generalized_alpha import integrate_generalized_alpha
    from neweul_py.errors import SolverError as _SolverError

    text = OSCILLATOR.replace("value: -k*(z - 1) - c*d_z",
                              "value: -k*(z - 1) - c*d_z + sqrt(1.2 - z)").replace(
        "z: {initial: 1.1, velocity: 0.0}", "z: {initial: 1.19, velocity: 1.0}")
    _mnp, mod = _compiled(text, tmp_path)
    p, x0 = mod.default_parameters(), np.asarray(mod.INITIAL_STATE, dtype=float)
    times = np.linspace(0.0, 0.1, 3)
    kw = {"h": 1e-2, "rho_inf": 0.5, "rtol": 1e-6, "atol": 1e-8, "names": ["z", "d_z"]}
    for loop in ({}, {"loop_inputs": None}):
        with pytest.raises(_SolverError, match="does not converge"):
            integrate_generalized_alpha(mod, (0.0, 0.1), x0, p, lambda t: None, times,
                                        **loop, **kw)
