"""The parameter derivatives of generated modules (codegen/parameters.py, docs/sensitivity.md).

Reference: central differences of the module's own functions in the parameters (and, for the
directional functions, along a random direction ``(δy, δẏ, δp, δu)``), with steps relative to
each parameter; the analytic derivatives must agree to the differences' truncation and
round-off error (relative 1e-5 of the largest entry; steps 1e-3 of each parameter, the
forces of the middle-ear chain cancel to 1e-4 of their terms).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from neweul_py.analysis.module import load_generated
from neweul_py.api import generate

ROOT = Path(__file__).resolve().parents[2]
#: Shipped modules: a pendulum, inputs with rates and default excitation, a closed loop,
#: loss factors and a characteristic, a spatial chain in recursive form, a gyroscope.
MODULES = ("pendulum", "quarter_car", "slider_crank", "middle_ear_chain", "chain3_spatial",
           "heavy_top")


def _difference(f, v0: np.ndarray, h: float = 1e-3) -> np.ndarray:
    """Central differences of ``f`` in each entry of ``v0`` (step ``h·|v0_j|``), stacked
    along the last axis."""
    cols = []
    for j in range(v0.size):
        step = h * (abs(v0[j]) or 1.0)
        e = np.zeros_like(v0)
        e[j] = step
        cols.append((np.asarray(f(v0 + e)) - np.asarray(f(v0 - e))) / (2 * step))
    return np.stack(cols, axis=-1)


def _along(f, h: float = 1e-4) -> np.ndarray:
    return (np.asarray(f(h)) - np.asarray(f(-h))) / (2 * h)


def _close(got, want, what: str, rtol: float = 1e-5) -> None:
    got, want = np.asarray(got, dtype=float), np.asarray(want, dtype=float)
    assert got.shape == want.shape, what
    scale = np.abs(want).max(initial=0.0)
    assert np.abs(got - want).max(initial=0.0) <= rtol * max(scale, 1e-12), what


def _point(mod, seed: int = 3):
    rng = np.random.default_rng(seed)
    n, nu = len(mod.COORDINATES), len(mod.INPUTS)
    p = mod.default_parameters() * (1 + 0.05 * rng.random(len(mod.PARAMETERS)))
    x = np.asarray(mod.INITIAL_STATE, dtype=float) + 0.05 * rng.standard_normal(2 * n)
    u = mod.default_inputs(0.2, p) + 0.1 * rng.standard_normal(nu)
    return rng, 0.2, x, p, u


@pytest.mark.parametrize("name", MODULES)
def test_first_parameter_derivatives_equal_central_differences(name: str) -> None:
    """``∂u₀/∂p``, ``∂(q−k)/∂p``, ``∂(M a)/∂p``, ``∂rhs/∂p``, ``∂out/∂p`` at fixed ``u``."""
    mod = load_generated(ROOT / "generated" / f"{name}.py")
    rng, t, x, p, u = _point(mod)
    n = len(mod.COORDINATES)
    y, yd, a = x[:n], x[n:], rng.standard_normal(n)
    _close(mod.default_inputs_parameter_jacobian(t, p),
           _difference(lambda q: mod.default_inputs(t, q), p), f"{name}: ∂u0/∂p")
    _close(mod.force_parameter_jacobian(t, y, yd, p, u),
           _difference(lambda q: mod.force_vector(t, y, yd, q, u), p), f"{name}: ∂f/∂p")
    _close(mod.mass_matrix_parameter_derivative(t, y, p, a, u),
           _difference(lambda q: mod.mass_matrix(t, y, q, u) @ a, p), f"{name}: ∂(Ma)/∂p")
    _close(mod.rhs_parameter_jacobian(t, x, p, u),
           _difference(lambda q: mod.rhs(t, x, q, u), p), f"{name}: ∂rhs/∂p")
    _close(mod.output_parameter_jacobian(t, x, p, u),
           _difference(lambda q: mod.outputs(t, x, q, u), p), f"{name}: ∂out/∂p")


@pytest.fixture(scope="module")
def with_sensitivities(tmp_path_factory):
    """The examples generated with the directional derivatives (``sensitivities=True``)."""
    tmp = tmp_path_factory.mktemp("sens")
    return {name: load_generated(generate(ROOT / "examples" / f"{name}.yaml", tmp,
                                          sensitivities=True)) for name in MODULES}


def test_sensitivities_only_append_the_directional_functions(with_sensitivities) -> None:
    """The module generated with sensitivities is the shipped one followed by the directional
    functions (reference: the shipped text, byte for byte)."""
    for name, mod in with_sensitivities.items():
        shipped = (ROOT / "generated" / f"{name}.py").read_text()
        text = Path(mod.path).read_text()
        head = shipped.rstrip("\n") + "\n\n\ndef force_jacobians_directional("
        assert text.startswith(head), name
        assert mod.has_directional_derivatives
        assert not load_generated(ROOT / "generated" / f"{name}.py").has_directional_derivatives


@pytest.mark.parametrize("name", MODULES)
def test_directional_derivatives_equal_central_differences(with_sensitivities,
                                                           name: str) -> None:
    """The derivatives of ``force_jacobians``, ``M``, ``∂(M a)/∂y``, ``output_jacobians``
    (and ``loss_matrix``) along a random ``(δy, δẏ, δp, δu)``."""
    mod = with_sensitivities[name]
    rng, t, x, p, u = _point(mod, 5)
    n, nu = len(mod.COORDINATES), len(mod.INPUTS)
    y, yd, a = x[:n], x[n:], rng.standard_normal(n)
    dy, dyd = rng.standard_normal(n), rng.standard_normal(n)
    dp, du = 0.1 * p * rng.standard_normal(p.size), rng.standard_normal(nu)
    dx = np.concatenate([dy, dyd])
    got = mod.force_jacobians_directional(t, y, yd, p, dy, dyd, dp, u, du)
    for k, part in enumerate(("∂f/∂y", "∂f/∂ẏ", "∂f/∂u")):
        _close(got[k], _along(lambda h, k=k: mod.force_jacobians(
            t, y + h * dy, yd + h * dyd, p + h * dp, u + h * du)[k]), f"{name}: d {part}")
    _close(mod.mass_matrix_directional(t, y, p, dy, dp, u, du),
           _along(lambda h: mod.mass_matrix(t, y + h * dy, p + h * dp, u + h * du)),
           f"{name}: dM")
    _close(mod.mass_matrix_times_derivative_directional(t, y, p, a, dy, dp, u, du),
           _along(lambda h: mod.mass_matrix_times_derivative(t, y + h * dy, p + h * dp, a,
                                                            u + h * du)), f"{name}: d ∂(Ma)/∂y")
    got = mod.output_jacobians_directional(t, x, p, dx, dp, u, du)
    for k, part in enumerate(("C", "D")):
        _close(got[k], _along(lambda h, k=k: mod.output_jacobians(
            t, x + h * dx, p + h * dp, u + h * du)[k]), f"{name}: d{part}")
    if mod.loss_matrix is not None:
        _close(mod.loss_matrix_directional(t, x, p, dx, dp, u, du),
               _along(lambda h: mod.loss_matrix(t, x + h * dx, p + h * dp, u + h * du)),
               f"{name}: dG")


def test_directional_rates_default_to_zero_inputs(with_sensitivities) -> None:
    """``du=None`` is the direction without input rates (reference: ``du = 0``)."""
    mod = with_sensitivities["quarter_car"]
    rng, t, x, p, u = _point(mod)
    n = len(mod.COORDINATES)
    dy, dyd, dp = rng.standard_normal(n), rng.standard_normal(n), 0.1 * p
    none = mod.force_jacobians_directional(t, x[:n], x[n:], p, dy, dyd, dp, u)
    zero = mod.force_jacobians_directional(t, x[:n], x[n:], p, dy, dyd, dp, u,
                                           np.zeros(len(mod.INPUTS)))
    for a, b in zip(none, zero, strict=True):
        np.testing.assert_array_equal(a, b)
