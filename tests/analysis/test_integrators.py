"""The compiled integrator loop (analysis/integrators.py, ``simulate(method="c-dopri5")``)
against SciPy's RK45, whose step control it reproduces, and its documented limits."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from compiler import needs_c_compiler
from scipy.integrate import solve_ivp

from neweul_py.analysis.module import load_generated
from neweul_py.analysis.simulate import simulate
from neweul_py.codegen import generate_module
from neweul_py.codegen.c_module import write_c_module
from neweul_py.description import load_description
from neweul_py.equations import newton_euler
from neweul_py.errors import NeweulError

ROOT = Path(__file__).resolve().parents[2]
pytestmark = needs_c_compiler


def _modules(name: str, directory: Path):
    eq = newton_euler(load_description(ROOT / "examples" / f"{name}.yaml"))
    npath = generate_module(eq, "h", directory / f"{name}.py")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        cmod = load_generated(write_c_module(eq, npath))
    assert cmod.BACKEND == "c"
    return load_generated(npath), cmod


def test_c_dopri5_takes_the_steps_of_scipy_rk45(tmp_path):
    """Reference: scipy.integrate.solve_ivp(method='RK45') on the same right-hand side — the
    C loop implements its error control, so the evaluation count is equal and the states
    agree to round-off."""
    _, mc = _modules("double_pendulum", tmp_path)
    p = mc.default_parameters()
    times = np.linspace(0.0, 3.0, 31)
    ref = solve_ivp(lambda t, x: mc.rhs(t, x, p), (0.0, 3.0), mc.INITIAL_STATE, t_eval=times,
                    rtol=1e-8, atol=1e-8)
    res = simulate(mc, 3.0, method="c-dopri5", t_eval=times, rtol=1e-8, atol=1e-8)
    assert res.nfev == ref.nfev
    np.testing.assert_allclose(np.hstack((res.y, res.yd)), ref.y.T, rtol=0, atol=1e-11)


def test_c_dopri5_refuses_what_it_cannot_do(tmp_path):
    """Reference: the documented limits (NumPy modules, constrained models, Python u(t))."""
    mnp, mc = _modules("four_bar", tmp_path)
    with pytest.raises(NeweulError, match="--backend c"):
        simulate(mnp, 1.0, method="c-dopri5")
    with pytest.raises(NeweulError, match="constraints"):
        simulate(mc, 1.0, method="c-dopri5")
    _, mq = _modules("quarter_car", tmp_path)
    with pytest.raises(NeweulError, match="input function"):
        simulate(mq, 1.0, method="c-dopri5", u=lambda t: np.zeros(len(mq.INPUTS)))
