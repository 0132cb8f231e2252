"""Integrators of :func:`~neweul_py.analysis.simulate`: one strategy per method family.

An :class:`Integrator` checks that it can integrate a model with the options given
(:meth:`Integrator.check`) and turns a prepared :class:`Run` into a
:class:`~neweul_py.analysis.results.SimulationResult` (:meth:`Integrator.simulate`). The
families:

- :class:`SolveIVP` — ``scipy.integrate.solve_ivp`` on the first-order form
  ``ẋ = rhs(t, x, p, u(t))``; the implicit methods (Radau, BDF, LSODA) get the module's
  analytic ``rhs_jacobian``;
- :class:`CompiledLoop` — ``c-dopri5``, the integration inside a compiled module (below);
- :class:`~neweul_py.analysis.generalized_alpha.GeneralizedAlphaSteps` — fixed steps of the
  generalized-α method on the second-order form (stiff elastic bodies);
- :class:`~neweul_py.analysis.dae.ConstrainedDAE` — models with ``CONSTRAINTS``: the index-1
  DAE with drift control, stepped by a SciPy method.

The first three share :class:`FirstOrder` (output times, inputs, outputs, and the errors of a
model that cannot be evaluated); :func:`~neweul_py.analysis.simulate` picks one by ``method``.

**The compiled loop.** ``method="c-dopri5"`` hands the whole integration to the module's
``integrate_dopri5`` (modules of the C backend, ``neweul generate --backend c``): the
Dormand–Prince 5(4) pair with the error control, initial step and dense output of
``scipy.integrate.RK45`` (Dormand & Prince, J. Comput. Appl. Math. 6 (1980) 19–26; Hairer,
Nørsett & Wanner, *Solving ODEs I*, §II.4–5), written in C next to the right-hand side. It
takes the same steps as ``solve_ivp(method="RK45")`` on the same module, so results agree to
round-off, at a fraction of the cost when the right-hand side is cheap: planar chain N = 10,
10 s, rtol = atol = 1e-8, 13 496 rhs calls either way: 0.012 s CPU against 0.096 s for SciPy's
RK45 on the same compiled rhs (SciPy's Python work per call, ≈ 6 µs, dwarfs the 1.7 µs rhs),
0.046 s for DOP853 and 0.026 s for LSODA (benchmarks/bench_compiled.py). Chosen by that
measurement for long explicit runs; the SciPy methods stay the default and use the compiled
rhs unchanged wherever the C loop does not apply (constraints, ``u(t)`` given as a Python
function, implicit methods).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, Protocol

import numpy as np

from ..errors import ModelError, NeweulError, SolverError
from . import protocol as proto
from .module import GeneratedModel
from .results import SimulationResult

__all__ = [
    "COMPILED_METHODS",
    "SCIPY_METHODS",
    "CompiledLoop",
    "FirstOrder",
    "Integrator",
    "Run",
    "Solution",
    "SolveIVP",
]

#: ``scipy.integrate.solve_ivp`` methods; the implicit ones use the analytic Jacobian.
SCIPY_METHODS: tuple[str, ...] = ("RK45", "DOP853", "RK23", "Radau", "BDF", "LSODA")
_IMPLICIT = frozenset({"Radau", "BDF", "LSODA"})
#: Integrators run by the compiled module itself.
COMPILED_METHODS: tuple[str, ...] = ("c-dopri5",)

InputLike = Callable[[float], Any] | Mapping[str, float] | Sequence[float] | np.ndarray | None


@dataclass(frozen=True)
class Run:
    """One integration with its options checked (:func:`~neweul_py.analysis.simulate`)."""

    method: str
    t_start: float
    t_end: float
    p: np.ndarray
    x0: np.ndarray
    u: InputLike
    rtol: float
    atol: float | np.ndarray
    n_out: int
    t_eval: Sequence[float] | np.ndarray | None
    max_step: float
    independent: Sequence[str] | None
    progress: Callable[[float, float], None] | None
    h: float | None
    rho_inf: float
    max_steps: int = 10**9


@dataclass
class Solution:
    """The states an integrator reached: ``y`` (states × times) at the times ``t``, as
    ``solve_ivp``'s result has them."""

    t: np.ndarray
    y: np.ndarray
    success: bool
    message: str
    nfev: int
    njev: int = 0


class Integrator(Protocol):
    """A method family of :func:`~neweul_py.analysis.simulate`."""

    #: The method's name (``RK45``, ``c-dopri5`` …).
    method: str
    #: Whether ``atol`` may be one value per state.
    per_state_atol: bool

    def check(self, model: GeneratedModel, run: Run) -> None:
        """Raise :class:`~neweul_py.errors.NeweulError` unless the method can integrate
        ``model`` with these options."""
        ...

    def simulate(self, model: GeneratedModel, run: Run) -> SimulationResult:
        """Integrate and return the result at the output times."""
        ...


@dataclass
class _Last:
    """The last state a right-hand side was evaluated at (for error messages)."""

    t: float
    x: np.ndarray


def _input_function(model: GeneratedModel, p: np.ndarray, u: InputLike) -> Callable[[float], Any]:
    nu = len(model.INPUTS)
    if u is None:
        return lambda t: None  # the module evaluates its default excitation itself
    if callable(u):
        return lambda t: np.asarray(u(t), dtype=float).reshape(nu)
    fixed = np.asarray(model.default_inputs(0.0, p), dtype=float).reshape(-1).copy()
    if isinstance(u, Mapping):
        for k, v in u.items():
            fixed[_index(model.INPUTS, k, "input")] = float(v)
    else:
        arr = np.asarray(u, dtype=float).reshape(-1)
        if arr.size != nu:
            raise NeweulError(f"u has {arr.size} entries, the model has {nu} inputs")
        fixed = arr
    return lambda t: fixed


def _index(names: Sequence[str], name: str, kind: str) -> int:
    try:
        return list(names).index(name)
    except ValueError:
        raise NeweulError(
            f"unknown {kind} {name!r}; {kind}s are: {', '.join(names) or '(none)'}"
        ) from None


def _output_times(run: Run) -> np.ndarray:
    if run.t_eval is None:
        if int(run.n_out) < 2:
            raise NeweulError("n_out must be at least 2")
        return np.linspace(run.t_start, run.t_end, int(run.n_out))
    times = np.asarray(run.t_eval, dtype=float).reshape(-1)
    if (times.size == 0 or times[0] < run.t_start or times[-1] > run.t_end
            or np.any(np.diff(times) < 0)):
        raise NeweulError("t_eval must be increasing times within [t_start, t_end]")
    return times


def _massless(model: GeneratedModel, t: float, x: np.ndarray, p: np.ndarray) -> str:
    """Which coordinates carry no inertia at ``(t, x)`` ("" when the mass matrix is regular):
    the diagnosis of linearize/modes/frf (null space of ``M``)."""
    try:
        with np.errstate(all="ignore"):
            m = np.asarray(model.mass_matrix(t, np.asarray(x, dtype=float)[:model.n], p),
                           dtype=float)
        if not np.all(np.isfinite(m)):
            return ""
        proto.check_mass_matrix(m, list(model.COORDINATES))
    except ModelError as exc:
        return str(exc).removeprefix("singular mass matrix: ")
    return ""


class FirstOrder:
    """The integrators of unconstrained models: the output times, the inputs, the errors of
    a model that cannot be evaluated or has no inertia, and the outputs at the output times
    are the same for all; :meth:`solve` is each method's own."""

    method: str = ""
    per_state_atol: ClassVar[bool] = True

    def check(self, model: GeneratedModel, run: Run) -> None:
        """Nothing beyond :func:`~neweul_py.analysis.simulate`'s own checks."""

    def solve(self, model: GeneratedModel, run: Run, uf: Callable[[float], Any],
              times: np.ndarray, last: _Last) -> Solution:
        """Integrate over ``[t_start, t_end]``; the states at ``times``."""
        raise NotImplementedError

    def simulate(self, model: GeneratedModel, run: Run) -> SimulationResult:
        if run.independent is not None:
            raise NeweulError(
                f"independent coordinates apply to models with constraints; "
                f"{model.MODEL_NAME} has none"
            )
        uf = _input_function(model, run.p, run.u)
        times = _output_times(run)
        names = model.state_names
        last = _Last(run.t_start, run.x0)
        try:
            with np.errstate(all="ignore"):
                sol = self.solve(model, run, uf, times, last)
        except ArithmeticError as exc:  # the generated module: math.exp(1000), 1/0 of a spring …
            raise SolverError(
                f"the model cannot be evaluated at t = {last.t:g} ({type(exc).__name__}: {exc})",
                last_iterate=np.array(last.x), names=names,
            ) from None
        except np.linalg.LinAlgError:
            why = _massless(model, last.t, last.x, run.p)
            raise SolverError(
                f"singular mass matrix at t = {last.t:g}" + (f": {why}" if why else ""),
                last_iterate=np.array(last.x), names=names,
            ) from None
        if not sol.success or sol.y.shape[1] != times.size or not np.all(np.isfinite(sol.y)):
            reached = sol.t[-1] if sol.t.size else run.t_start
            why = _massless(model, last.t, last.x, run.p)
            if why:
                raise SolverError(f"singular mass matrix at t = {last.t:g}: {why}",
                                  last_iterate=np.array(last.x), names=names)
            raise SolverError(
                f"{self.method} stopped at t = {reached:g} of {run.t_end:g}: {sol.message}",
                last_iterate=np.array(last.x), names=names,
            )
        span = run.t_end - run.t_start
        if run.progress is not None:
            run.progress(span, span)
        return _result(model, run, uf, times, sol)


def _result(model: GeneratedModel, run: Run, uf: Callable[[float], Any], times: np.ndarray,
            sol: Solution) -> SimulationResult:
    """The result with the outputs evaluated at the output times."""
    x = sol.y.T
    n, ny = model.n, len(model.OUTPUTS)
    outs = np.empty((times.size, ny))
    if ny:
        for k, (tk, xk) in enumerate(zip(times, x, strict=True)):
            try:
                outs[k] = model.outputs(tk, xk, run.p, uf(tk))
            except ArithmeticError as exc:  # e.g. exp(1000) in an output
                raise SolverError(f"the outputs cannot be evaluated at t = {tk:g} "
                                  f"({type(exc).__name__}: {exc})", last_iterate=xk,
                                  names=model.state_names) from None
    return SimulationResult(
        t=times,
        y=x[:, :n].copy(),
        yd=x[:, n:2 * n].copy(),
        outputs=outs,
        coordinates=tuple(model.COORDINATES),
        output_names=tuple(model.OUTPUTS),
        coordinate_units=tuple(model.COORDINATE_UNITS),
        output_units=tuple(model.OUTPUT_UNITS),
        model_name=model.MODEL_NAME,
        parameters=dict(zip(model.PARAMETERS, map(float, run.p), strict=True)),
        source_hash=model.SOURCE_HASH,
        method=run.method,
        message=str(sol.message),
        nfev=int(sol.nfev),
    )


class SolveIVP(FirstOrder):
    """``scipy.integrate.solve_ivp`` with ``method`` (:data:`SCIPY_METHODS`); the implicit
    methods get ``rhs_jacobian``."""

    def __init__(self, method: str) -> None:
        self.method = method

    def solve(self, model: GeneratedModel, run: Run, uf: Callable[[float], Any],
              times: np.ndarray, last: _Last) -> Solution:
        from scipy.integrate import solve_ivp  # ~0.4 s; not for the other methods

        rhs, pv, progress = model.rhs, run.p, run.progress
        span = run.t_end - run.t_start
        mark = [run.t_start if progress is not None else np.inf]  # next time to report

        def f(t: float, x: np.ndarray) -> np.ndarray:
            last.t, last.x = t, x
            if t >= mark[0]:  # throttled: ~200 reports per run, none without a hook
                mark[0] = t + span / 200
                progress(min(t, run.t_end) - run.t_start, span)  # type: ignore[misc]
            return rhs(t, x, pv, uf(t))

        kwargs: dict[str, Any] = {}
        if self.method in _IMPLICIT:
            jac = model.rhs_jacobian
            kwargs["jac"] = lambda t, x: jac(t, x, pv, uf(t))
        sol = solve_ivp(f, (run.t_start, run.t_end), run.x0, method=self.method, t_eval=times,
                        rtol=run.rtol, atol=run.atol, max_step=run.max_step, **kwargs)
        return Solution(sol.t, sol.y, bool(sol.success), str(sol.message), int(sol.nfev))


class CompiledLoop(FirstOrder):
    """``c-dopri5``: the module's own ``integrate_dopri5`` (module docstring)."""

    method = "c-dopri5"
    per_state_atol = False

    def check(self, model: GeneratedModel, run: Run) -> None:
        if not model.compiled:
            why = model.BACKEND_NOTE if model.BACKEND else ""
            raise NeweulError(
                f"method {self.method!r} runs inside a compiled module; generate the model with "
                "--backend c (backend=\"c\")" + (f" — this one fell back to NumPy: {why}"
                                                  if why else "")
            )
        if model.has_constraints:
            raise NeweulError(
                f"method {self.method!r} integrates unconstrained models; models with "
                "constraints use the DAE integrators (RK45, …), which call the compiled rhs as "
                "well"
            )
        if callable(run.u):
            raise NeweulError(
                f"method {self.method!r} cannot call a Python input function u(t) from C; give "
                "constant inputs, the default excitation (u=None) or use RK45"
            )

    def solve(self, model: GeneratedModel, run: Run, uf: Callable[[float], Any],
              times: np.ndarray, last: _Last) -> Solution:
        """Raises :class:`SolverError` on a singular mass matrix (with the time reached)."""
        assert model.integrate_dopri5 is not None
        u = None if run.u is None else uf(run.t_start)
        x_eval, nfev, status, reached = model.integrate_dopri5(
            run.t_start, run.t_end, run.x0, run.p, times, u=u, rtol=run.rtol, atol=run.atol,
            max_step=run.max_step)
        done = int(np.searchsorted(times, reached, side="right")) if status else times.size
        state = x_eval[done - 1] if done else np.asarray(run.x0, dtype=float)
        if status == 2:
            raise SolverError(f"singular mass matrix near t = {reached:g}", last_iterate=state,
                              names=model.state_names)
        messages = {0: "The solver successfully reached the end of the integration interval.",
                    1: "Required step size is less than spacing between numbers.",
                    3: "The state became non-finite."}
        return Solution(times[:done], x_eval[:done].T, status == 0, messages[status], nfev)
