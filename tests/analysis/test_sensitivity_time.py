"""Forward sensitivities of simulations (analysis/sensitivity_time.py; docs/sensitivity.md §6).

Reference: central differences of two simulations (DOP853, rtol 1e-12).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from neweul_py.analysis.module import load_generated
from neweul_py.analysis.sensitivity_time import simulate_sensitivity
from neweul_py.analysis.simulate import simulate
from neweul_py.errors import NeweulError

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(("name", "wrt"), [("pendulum", ["l", "g"]),
                                           ("quarter_car", ["ks", "cs", "A", "v"])])
def test_simulation_sensitivity_equals_central_differences(name, wrt) -> None:
    """∂x/∂p and ∂out/∂p of the variational equations equal central differences of two
    simulations (DOP853, rtol 1e-12; relative step 1e-6); the quarter car's A and v enter only
    through the default road excitation (the chain ∂rhs/∂u · ∂u₀/∂p)."""
    mod = load_generated(ROOT / "generated" / f"{name}.py")
    res = simulate_sensitivity(mod, 1.0, wrt, n_out=11, rtol=1e-10, atol=1e-12)
    p = mod.default_parameters()
    for j, nm in enumerate(wrt):
        v = p[list(mod.PARAMETERS).index(nm)]
        h = 1e-6 * abs(v)
        runs = [simulate(mod, 1.0, n_out=11, p={nm: v + s * h}, method="DOP853", rtol=1e-12,
                         atol=1e-14) for s in (1.0, -1.0)]
        dx = (np.hstack([runs[0].y, runs[0].yd]) - np.hstack([runs[1].y, runs[1].yd])) / (2 * h)
        dout = (runs[0].outputs - runs[1].outputs) / (2 * h)
        np.testing.assert_allclose(res.dx_dp[:, :, j], dx, rtol=0,
                                   atol=1e-6 * np.abs(dx).max(), err_msg=nm)
        np.testing.assert_allclose(res.dout_dp[:, :, j], dout, rtol=0,
                                   atol=1e-6 * np.abs(dout).max(), err_msg=nm)




def test_constrained_models_are_one_error() -> None:
    """Models with constraints are not covered (one error naming them)."""
    crank = load_generated(ROOT / "generated" / "slider_crank.py")
    with pytest.raises(NeweulError, match="constraints"):
        simulate_sensitivity(crank, 0.1)
