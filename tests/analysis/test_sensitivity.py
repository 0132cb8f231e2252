"""Parameter sensitivities of equilibria and linear models (analysis/sensitivity.py;
docs/sensitivity.md §2–3).

References: the preloaded pendulum's closed form ``dφ₀/dT = 1/(k + m g l cos φ₀)`` (module
``preloaded`` of conftest.py), and the linear model's derivatives of the analytic path against
those of central differences of the linearization.
"""

from __future__ import annotations

from dataclasses import fields, replace

import numpy as np
import pytest

from neweul_py.analysis import sensitivity as sens
from neweul_py.analysis.equilibrium import equilibrium
from neweul_py.analysis.linearize import linearize
from neweul_py.errors import NeweulError


def test_equilibrium_sensitivity_equals_the_closed_form(preloaded) -> None:
    """k φ₀ + m g l sin φ₀ = T gives dφ₀/dT = 1/(k + m g l cos φ₀) and
    dφ₀/dk = −φ₀/(k + m g l cos φ₀)."""
    mod = preloaded
    eq = equilibrium(mod)
    res = sens.equilibrium_sensitivity(mod, eq, ["T", "k"])
    m, l, g, k = 1.5, 0.4, 9.81, 3.0
    phi = eq.y[0]
    K = k + m * g * l * np.cos(phi)
    assert res.dy_dp[0, 0] == pytest.approx(1.0 / K, rel=1e-12)
    assert res.dy_dp[0, 1] == pytest.approx(-phi / K, rel=1e-12)


def test_differences_fallback_equals_the_analytic_derivatives(preloaded) -> None:
    """A module without the directional functions (generated without sensitivities, or with
    elastic bodies) gets the linear model's derivatives as central differences; they equal
    the analytic ones."""
    mod = preloaded
    lin = linearize(mod, equilibrium(mod))
    analytic, _ = sens.linear_model_derivatives(mod, lin)
    bare = replace(mod, **{f.name: None for f in fields(mod) if f.name.endswith("_directional")})
    numeric, method = sens.linear_model_derivatives(bare, lin)
    assert method == sens.DIFFERENCES
    for a, b in zip(analytic, numeric, strict=True):
        for key in ("M0", "P", "Q", "B", "C", "D"):
            x, y = getattr(a, key), getattr(b, key)
            np.testing.assert_allclose(y, x, rtol=0, atol=1e-6 * max(1.0, np.abs(x).max()),
                                       err_msg=f"{a.parameter} {key}")


def test_bad_names_and_values_are_one_error(oscillator) -> None:
    """An unknown parameter (listing the valid ones), a repeated one, a zero value and a
    constrained model each give one NeweulError."""
    mod = oscillator
    lin = linearize(mod, equilibrium(mod))
    with pytest.raises(NeweulError, match=r"unknown parameter 'q'.*m, k, c"):
        sens.linear_model_derivatives(mod, lin, ["q"])
    with pytest.raises(NeweulError, match="named twice"):
        sens.parameter_indices(mod, ["k", "k"])
    with pytest.raises(NeweulError, match="are 0"):
        sens.parameter_indices(mod, ["k"], np.array([1.0, 0.0, 1.0]))
