"""Integrators that run inside a compiled module: no Python call per step.

``method="c-dopri5"`` of :func:`neweul_py.analysis.simulate` hands the whole integration to
the module's ``integrate_dopri5`` (modules of the C backend, ``neweul generate --backend c``):
the Dormand–Prince 5(4) pair with the error control, initial step and dense output of
``scipy.integrate.RK45`` (Dormand & Prince, J. Comput. Appl. Math. 6 (1980) 19–26; Hairer,
Nørsett & Wanner, *Solving ODEs I*, §II.4–5), written in C next to the right-hand side. It
takes the same steps as ``solve_ivp(method="RK45")`` on the same module, so results agree to
round-off, at a fraction of the cost when the right-hand side is cheap: planar chain N = 10,
10 s, rtol = atol = 1e-8, 13 496 rhs calls either way: 0.012 s CPU against 0.096 s for SciPy's
RK45 on the same compiled rhs (SciPy's Python work per call, ≈ 6 µs, dwarfs the 1.7 µs rhs),
0.046 s for DOP853 and 0.026 s for LSODA (benchmarks/bench_compiled.py, benchmarks/README.md).
Chosen by that measurement for long explicit runs; the SciPy methods stay the default and use
the compiled rhs unchanged wherever the C loop does not apply (constraints, ``u(t)`` given as
a Python function, implicit methods).
Output times, outputs and the result are handled by :func:`~neweul_py.analysis.simulate`
exactly as for the SciPy methods.
"""

from __future__ import annotations

from types import ModuleType
from typing import Any

import numpy as np

from ..errors import NeweulError, SolverError

__all__ = ["COMPILED_METHODS", "CompiledSolution", "check_compiled", "integrate_compiled"]

#: Integrators run by the compiled module itself.
COMPILED_METHODS: tuple[str, ...] = ("c-dopri5",)


class CompiledSolution:
    """The fields of ``solve_ivp``'s result that :func:`simulate` reads."""

    def __init__(self, t: np.ndarray, y: np.ndarray, success: bool, message: str,
                 nfev: int) -> None:
        self.t, self.y, self.success, self.message, self.nfev = t, y, success, message, nfev


def check_compiled(module: ModuleType, method: str, u: Any) -> None:
    """Raise :class:`NeweulError` unless ``module`` can integrate itself with ``method``."""
    if method not in COMPILED_METHODS:
        return
    if not callable(getattr(module, "integrate_dopri5", None)):
        why = getattr(module, "BACKEND_NOTE", "") if getattr(module, "BACKEND", "") else ""
        raise NeweulError(
            f"method {method!r} runs inside a compiled module; generate the model with "
            "--backend c (backend=\"c\")" + (f" — this one fell back to NumPy: {why}"
                                              if why else "")
        )
    if list(getattr(module, "CONSTRAINTS", []) or []):
        raise NeweulError(
            f"method {method!r} integrates unconstrained models; models with constraints use "
            "the DAE integrators (RK45, …), which call the compiled rhs as well"
        )
    if callable(u):
        raise NeweulError(
            f"method {method!r} cannot call a Python input function u(t) from C; give constant "
            "inputs, the default excitation (u=None) or use RK45"
        )


def integrate_compiled(
    module: ModuleType,
    t_span: tuple[float, float],
    x0: np.ndarray,
    p: np.ndarray,
    u: np.ndarray | None,
    times: np.ndarray,
    *,
    rtol: float,
    atol: float,
    max_step: float,
    names: list[str],
) -> CompiledSolution:
    """Integrate ``ẋ = rhs(t, x, p, u)`` over ``t_span`` in the module's C loop.

    Parameters
    ----------
    u
        ``None`` (the module's default excitation, evaluated in C) or constant inputs.
    times
        Output times (increasing, within ``t_span``).
    names
        State names for the error message.

    Raises
    ------
    SolverError
        On a singular mass matrix (with the time reached).
    """
    x_eval, nfev, status, reached = module.integrate_dopri5(
        t_span[0], t_span[1], x0, p, times, u=u, rtol=rtol, atol=atol, max_step=max_step)
    done = int(np.searchsorted(times, reached, side="right")) if status else times.size
    last = x_eval[done - 1] if done else np.asarray(x0, dtype=float)
    if status == 2:
        raise SolverError(f"singular mass matrix near t = {reached:g}", last_iterate=last,
                          names=names)
    messages = {0: "The solver successfully reached the end of the integration interval.",
                1: "Required step size is less than spacing between numbers.",
                3: "The state became non-finite."}
    return CompiledSolution(times[:done], x_eval[:done].T, status == 0, messages[status], nfev)
