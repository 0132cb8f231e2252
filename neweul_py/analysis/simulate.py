"""Time integration of a generated module with :func:`scipy.integrate.solve_ivp`.

Integrates the first-order form ``ẋ = rhs(t, x, p, u(t))`` of the generated module; the implicit
methods (Radau, BDF, LSODA) get the module's analytic ``rhs_jacobian``. ``method=
"generalized-alpha"`` integrates the second-order form with fixed steps ``h`` instead
(:mod:`~neweul_py.analysis.generalized_alpha`: stiff flexible bodies).
"""

from __future__ import annotations

import numbers
import os
from collections.abc import Callable, Mapping, Sequence
from types import ModuleType
from typing import Any

import numpy as np

from ..errors import ModelError, NeweulError, SolverError
from . import protocol as proto
from .generalized_alpha import integrate_generalized_alpha
from .integrators import COMPILED_METHODS, check_compiled, integrate_compiled
from .module import check_protocol, load_generated
from .results import SimulationResult

__all__ = ["METHODS", "simulate"]

#: Integrators offered (``scipy.integrate.solve_ivp`` names; implicit ones use the Jacobian),
#: then those running inside compiled modules (analysis/integrators.py).
METHODS: tuple[str, ...] = ("RK45", "DOP853", "RK23", "Radau", "BDF", "LSODA",
                            "generalized-alpha", *COMPILED_METHODS)
#: The fixed-step second-order method (analysis/generalized_alpha.py).
FIXED_STEP = "generalized-alpha"
_IMPLICIT = frozenset({"Radau", "BDF", "LSODA"})

InputLike = Callable[[float], Any] | Mapping[str, float] | Sequence[float] | np.ndarray | None


def _index(names: Sequence[str], name: str, kind: str) -> int:
    try:
        return list(names).index(name)
    except ValueError:
        raise NeweulError(
            f"unknown {kind} {name!r}; {kind}s are: {', '.join(names) or '(none)'}"
        ) from None


def _parameters(module: ModuleType, p: Any) -> np.ndarray:
    names = list(module.PARAMETERS)
    values = np.asarray(module.default_parameters(), dtype=float).copy()
    if p is None:
        return values
    if isinstance(p, Mapping):
        for k, v in p.items():
            values[_index(names, k, "parameter")] = float(v)
        return values
    arr = np.asarray(p, dtype=float).reshape(-1)
    if arr.size != values.size:
        raise NeweulError(f"p has {arr.size} entries, the model has {values.size} parameters")
    return arr


def _initial_state(module: ModuleType, x0: Any) -> np.ndarray:
    x = np.asarray(module.INITIAL_STATE, dtype=float).copy()
    if x0 is None:
        return x
    if isinstance(x0, Mapping):
        names = [*module.COORDINATES, *(f"d_{c}" for c in module.COORDINATES)]
        for k, v in x0.items():
            i = _index(names, k, "state")
            x[i] = float(v)
        return x
    arr = np.asarray(x0, dtype=float).reshape(-1)
    if arr.size != x.size:
        raise NeweulError(f"x0 has {arr.size} entries, the state has {x.size}")
    return arr


def _input_function(module: ModuleType, p: np.ndarray, u: InputLike) -> Callable[[float], Any]:
    nu = len(module.INPUTS)
    if u is None:
        return lambda t: None  # the module evaluates its default excitation itself
    if callable(u):
        return lambda t: np.asarray(u(t), dtype=float).reshape(nu)
    fixed = np.asarray(module.default_inputs(0.0, p), dtype=float).reshape(-1).copy()
    if isinstance(u, Mapping):
        for k, v in u.items():
            fixed[_index(module.INPUTS, k, "input")] = float(v)
    else:
        arr = np.asarray(u, dtype=float).reshape(-1)
        if arr.size != nu:
            raise NeweulError(f"u has {arr.size} entries, the model has {nu} inputs")
        fixed = arr
    return lambda t: fixed


def _massless(module: ModuleType, t: float, x: np.ndarray, p: np.ndarray) -> str:
    """Which coordinates carry no inertia at ``(t, x)`` ("" when the mass matrix is regular):
    the diagnosis of linearize/modes/frf (null space of ``M``)."""
    n = len(module.COORDINATES)
    try:
        with np.errstate(all="ignore"):
            m = np.asarray(module.mass_matrix(t, np.asarray(x, dtype=float)[:n], p), dtype=float)
        if not np.all(np.isfinite(m)):
            return ""
        proto.check_mass_matrix(m, list(module.COORDINATES))
    except ModelError as exc:
        return str(exc).removeprefix("singular mass matrix: ")
    return ""


def _absolute_tolerance(module: ModuleType, method: str, atol: Any) -> float | np.ndarray:
    """``atol`` as a positive number, or one positive value per state where the method
    takes that (generalized-α, SciPy's ``solve_ivp``; not the compiled loop, not models with
    constraints)."""
    bad = NeweulError(f"atol must be a positive number or one per state, got {atol!r:.60}")
    raw = np.asarray(atol)
    if isinstance(atol, str | bytes) or raw.dtype.kind not in "fiu":  # no text, bool, complex
        raise bad
    a = raw.astype(float)
    if not (a.size and np.all(np.isfinite(a)) and np.all(a > 0)):
        raise bad
    if a.ndim == 0:
        return float(a)
    size = int(module.STATE_SIZE)
    if a.shape != (size,):
        raise NeweulError(f"atol must be a number or one value per state ({size}), "
                          f"got shape {a.shape}")
    if method in COMPILED_METHODS or list(getattr(module, "CONSTRAINTS", []) or []):
        raise NeweulError(f"atol per state applies to generalized-alpha and the SciPy methods "
                          f"of unconstrained models, not to {method!r}"
                          + (" with constraints" if getattr(module, "CONSTRAINTS", None) else ""))
    return a


def simulate(
    module: ModuleType | str | os.PathLike[str],
    t_end: float,
    *,
    t_start: float = 0.0,
    method: str = "RK45",
    rtol: float = 1e-6,
    atol: float | Sequence[float] | np.ndarray = 1e-9,
    n_out: int = 501,
    t_eval: Sequence[float] | np.ndarray | None = None,
    p: Mapping[str, float] | Sequence[float] | np.ndarray | None = None,
    x0: Mapping[str, float] | Sequence[float] | np.ndarray | None = None,
    u: InputLike = None,
    max_step: float = np.inf,
    independent: Sequence[str] | None = None,
    progress: Callable[[float, float], None] | None = None,
    h: float | None = None,
    rho_inf: float = 0.9,
) -> SimulationResult:
    """Integrate a generated model from ``t_start`` to ``t_end``.

    Solves ``ẋ = rhs(t, x, p, u(t))`` with ``x = [y, ẏ]`` by ``scipy.integrate.solve_ivp``;
    for Radau, BDF and LSODA the analytic ``rhs_jacobian`` of the module is used. Modules with
    ``CONSTRAINTS`` (closed loops) are handed to
    :func:`neweul_py.analysis.dae.simulate_constrained` (constraint forces, drift control; the
    initial state is made consistent first, the multipliers become ``lambda_<name>`` outputs).

    Parameters
    ----------
    module
        A generated module or the path of one.
    t_end
        Final time [s].
    t_start
        Initial time [s].
    method
        One of :data:`METHODS`; ``"c-dopri5"``: RK45's method and step control in the C loop
        of a compiled module (:mod:`~neweul_py.analysis.integrators`);
        ``"generalized-alpha"``: fixed steps ``h`` of the generalized-α method on the
        second-order form (:mod:`~neweul_py.analysis.generalized_alpha`; stiff elastic
        bodies, unconstrained models).
    rtol, atol
        Tolerances of the integrator (of the Newton iterations for generalized-α). ``atol``
        may be one value per state (``STATE_SIZE``: positions and velocities have different
        units) for generalized-α and the SciPy methods.
    n_out
        Number of equally spaced output times (including both ends), unless ``t_eval`` is given.
    t_eval
        Explicit output times (within ``[t_start, t_end]``).
    p
        Parameters: ``None`` (defaults), a mapping name → value overriding defaults, or a full
        vector ordered as ``PARAMETERS``.
    x0
        Initial state: ``None`` (``INITIAL_STATE``), a mapping (coordinate or ``d_<coordinate>``
        → value) overriding it, or a full vector.
    u
        Inputs: ``None`` (the description's default excitation), a callable ``u(t)``, or
        constants (mapping name → value over the defaults at t = 0, or a vector).
    max_step
        Largest step of the integrator.
    independent
        Models with constraints only: coordinates whose initial positions and velocities are
        kept exactly when the initial state is made consistent (default: the coordinates the
        constraints leave free, first in ``COORDINATES`` order; see
        :func:`~neweul_py.analysis.dae.consistent_initial_state`).
    progress
        Called as ``progress(done, total)`` with the simulated time reached (``t − t_start``)
        and the span ``t_end − t_start``, at most about 200 times per run plus once at the end;
        a :class:`neweul_py.progress.Tracker` draws a bar with the remaining time on stderr.
    h
        Step size of ``method="generalized-alpha"`` (required there, unused otherwise).
    rho_inf
        Spectral radius at infinite frequency of ``method="generalized-alpha"``, in [0, 1]
        (default 0.9, Exudyn's default: light damping of the unresolved modes).

    Returns
    -------
    SimulationResult
        Times, coordinates, velocities and outputs at the output times.

    Raises
    ------
    SolverError
        When the integrator fails (with the last state reached) or the mass matrix is singular
        (naming the coordinates without inertia).

    Examples
    --------
    >>> res = simulate("generated/pendulum.py", 5.0, method="DOP853")  # doctest: +SKIP
    >>> res.to_csv("pendulum.csv")  # doctest: +SKIP
    """
    if not isinstance(module, ModuleType) and isinstance(module, str | os.PathLike):
        module = load_generated(module)
    else:
        check_protocol(module)
    if method not in METHODS:
        raise NeweulError(f"unknown method {method!r}; methods are: {', '.join(METHODS)}")
    t_start, t_end = float(t_start), float(t_end)
    if not (np.isfinite(t_start) and np.isfinite(t_end)) or t_end <= t_start:
        raise NeweulError(f"t_end ({t_end:g}) must be a finite time after t_start ({t_start:g})")
    atol = _absolute_tolerance(module, method, atol)
    if not (isinstance(rtol, numbers.Real) and not isinstance(rtol, bool) and rtol > 0):
        raise NeweulError(f"rtol must be a positive number, got {rtol!r}")
    check_compiled(module, method, u)
    if method == FIXED_STEP:
        if h is None:
            raise NeweulError("method 'generalized-alpha' needs the step h "
                              "(neweul simulate --step)")
        if list(getattr(module, "CONSTRAINTS", []) or []):
            raise NeweulError("method 'generalized-alpha' integrates unconstrained models; "
                              "models with constraints use the DAE integrators (RK45, …)")
    pv = _parameters(module, p)
    x_init = _initial_state(module, x0)
    if list(getattr(module, "CONSTRAINTS", []) or []):
        # closed loops: index-1 DAE with drift control (analysis/dae.py); max_step unused
        from .dae import simulate_constrained

        n = len(module.COORDINATES)
        return simulate_constrained(
            module, t_end, t_start=t_start, n_out=n_out, t_eval=t_eval, y0=x_init[:n],
            yd0=x_init[n:2 * n], p=pv, u=u, method=method, rtol=rtol, atol=atol,
            independent=independent, progress=progress,
        ).result
    if independent is not None:
        raise NeweulError(
            f"independent coordinates apply to models with constraints; "
            f"{getattr(module, 'MODEL_NAME', 'this model')} has none"
        )
    uf = _input_function(module, pv, u)
    if t_eval is None:
        if int(n_out) < 2:
            raise NeweulError("n_out must be at least 2")
        times = np.linspace(t_start, t_end, int(n_out))
    else:
        times = np.asarray(t_eval, dtype=float).reshape(-1)
        if times.size == 0 or times[0] < t_start or times[-1] > t_end or np.any(np.diff(times) < 0):
            raise NeweulError("t_eval must be increasing times within [t_start, t_end]")

    rhs = module.rhs
    last = {"t": t_start, "x": x_init}
    span = t_end - t_start
    mark = [t_start if progress is not None else np.inf]  # next time to report

    def f(t: float, x: np.ndarray) -> np.ndarray:
        last["t"], last["x"] = t, x
        if t >= mark[0]:  # throttled: ~200 reports per run, none without a hook
            mark[0] = t + span / 200
            progress(min(t, t_end) - t_start, span)
        return rhs(t, x, pv, uf(t))

    kwargs: dict[str, Any] = {}
    if method in _IMPLICIT:
        jac = module.rhs_jacobian
        kwargs["jac"] = lambda t, x: jac(t, x, pv, uf(t))

    n = len(module.COORDINATES)
    state_names = [*module.COORDINATES, *(f"d_{c}" for c in module.COORDINATES)]
    try:
        with np.errstate(all="ignore"):
            if method == FIXED_STEP:
                sol = integrate_generalized_alpha(
                    module, (t_start, t_end), x_init, pv, uf, times, h=float(h),  # type: ignore[arg-type]
                    rho_inf=rho_inf, rtol=rtol, atol=atol, names=state_names,
                    progress=progress)
            elif method in COMPILED_METHODS:
                sol = integrate_compiled(module, (t_start, t_end), x_init, pv,
                                         None if u is None else uf(t_start), times, rtol=rtol,
                                         atol=atol, max_step=max_step, names=state_names)
            else:
                from scipy.integrate import solve_ivp  # ~0.4 s; not for the other methods

                sol = solve_ivp(f, (t_start, t_end), x_init, method=method, t_eval=times,
                                rtol=rtol, atol=atol, max_step=max_step, **kwargs)
    except ArithmeticError as exc:  # the generated module: math.exp(1000), 1/0 of a spring …
        raise SolverError(
            f"the model cannot be evaluated at t = {last['t']:g} ({type(exc).__name__}: {exc})",
            last_iterate=np.array(last["x"]), names=state_names,
        ) from None
    except np.linalg.LinAlgError:
        why = _massless(module, last["t"], last["x"], pv)
        raise SolverError(
            f"singular mass matrix at t = {last['t']:g}" + (f": {why}" if why else ""),
            last_iterate=np.array(last["x"]),
            names=state_names,
        ) from None
    if not sol.success or sol.y.shape[1] != times.size or not np.all(np.isfinite(sol.y)):
        reached = sol.t[-1] if sol.t.size else t_start
        why = _massless(module, last["t"], last["x"], pv)
        if why:
            raise SolverError(f"singular mass matrix at t = {last['t']:g}: {why}",
                              last_iterate=np.array(last["x"]), names=state_names)
        raise SolverError(
            f"{method} stopped at t = {reached:g} of {t_end:g}: {sol.message}",
            last_iterate=np.array(last["x"]),
            names=state_names,
        )
    if progress is not None:
        progress(span, span)
    x = sol.y.T
    ny = len(module.OUTPUTS)
    outs = np.empty((times.size, ny))
    if ny:
        for k, (tk, xk) in enumerate(zip(times, x, strict=True)):
            try:
                outs[k] = module.outputs(tk, xk, pv, uf(tk))
            except ArithmeticError as exc:  # e.g. exp(1000) in an output
                raise SolverError(f"the outputs cannot be evaluated at t = {tk:g} "
                                  f"({type(exc).__name__}: {exc})", last_iterate=xk,
                                  names=state_names) from None
    return SimulationResult(
        t=times,
        y=x[:, :n].copy(),
        yd=x[:, n:2 * n].copy(),
        outputs=outs,
        coordinates=tuple(module.COORDINATES),
        output_names=tuple(module.OUTPUTS),
        coordinate_units=tuple(getattr(module, "COORDINATE_UNITS", ())),
        output_units=tuple(getattr(module, "OUTPUT_UNITS", ())),
        model_name=module.MODEL_NAME,
        parameters=dict(zip(module.PARAMETERS, map(float, pv), strict=True)),
        source_hash=module.SOURCE_HASH,
        method=method,
        message=str(sol.message),
        nfev=int(sol.nfev),
    )
