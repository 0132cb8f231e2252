"""Time integration of a generated model.

:func:`simulate` checks the options (:class:`SimulationOptions`), picks the integrator of
``method`` and the model (:func:`integrator`: the strategies of
:mod:`~neweul_py.analysis.integrators`) and lets it run: ``scipy.integrate.solve_ivp`` on the
first-order form ``ẋ = rhs(t, x, p, u(t))`` (the implicit methods Radau, BDF, LSODA with the
module's analytic ``rhs_jacobian``), the compiled loop ``c-dopri5``, fixed generalized-α steps
on the second-order form (:mod:`~neweul_py.analysis.generalized_alpha`: stiff flexible bodies),
or, for models with ``CONSTRAINTS``, the DAE with drift control (:mod:`~neweul_py.analysis.dae`).
"""

from __future__ import annotations

import dataclasses
import numbers
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import NeweulError, SolverError
from .dae import ConstrainedDAE
from .generalized_alpha import MAX_STEPS, GeneralizedAlphaSteps
from .integrators import (
    COMPILED_METHODS,
    SCIPY_METHODS,
    CompiledLoop,
    InputLike,
    Integrator,
    Run,
    SolveIVP,
)
from .module import GeneratedModel, ModelLike, as_model
from .results import SimulationResult

__all__ = ["METHODS", "SimulationOptions", "integrator", "simulate"]

#: The words of a generated module's error for a schedule outside a parametric body's samples
#: (NumPy and compiled modules alike: docs/generated-module-protocol.md).
OUTSIDE_SAMPLES = "outside the sampled range"
#: Integrators offered (``scipy.integrate.solve_ivp`` names; implicit ones use the Jacobian),
#: the fixed-step second-order method, then those running inside compiled modules.
METHODS: tuple[str, ...] = (*SCIPY_METHODS, "generalized-alpha", *COMPILED_METHODS)


@dataclass(frozen=True)
class SimulationOptions:
    """The options of :func:`simulate` (its keyword arguments besides ``method``).

    Attributes
    ----------
    t_start
        Initial time [s] (default 0).
    rtol, atol
        Tolerances of the integrator (of the Newton iterations for generalized-α); defaults
        1e-6, 1e-9. ``atol`` may be one value per state (``STATE_SIZE``: positions and
        velocities have different units) for generalized-α and the SciPy methods of
        unconstrained models.
    n_out
        Number of equally spaced output times (including both ends; default 501), unless
        ``t_eval`` is given.
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
        Largest step of the integrator (default unbounded).
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
    max_steps
        ``method="generalized-alpha"``: the largest number of steps ``ceil(T / h)``, checked
        before the first one (default 10⁹; docs/limits.md).
    """

    t_start: float = 0.0
    rtol: float = 1e-6
    atol: float | Sequence[float] | np.ndarray = 1e-9
    n_out: int = 501
    t_eval: Sequence[float] | np.ndarray | None = None
    p: Mapping[str, float] | Sequence[float] | np.ndarray | None = None
    x0: Mapping[str, float] | Sequence[float] | np.ndarray | None = None
    u: InputLike = None
    max_step: float = np.inf
    independent: Sequence[str] | None = None
    progress: Callable[[float, float], None] | None = None
    h: float | None = None
    rho_inf: float = 0.9
    max_steps: int = MAX_STEPS

    @classmethod
    def of(cls, options: Mapping[str, Any]) -> SimulationOptions:
        """The options from keyword arguments (an unknown one is a ``TypeError`` naming the
        valid ones, as for any function)."""
        valid = [f.name for f in dataclasses.fields(cls)]
        unknown = [k for k in options if k not in valid]
        if unknown:
            raise TypeError(f"simulate() got an unexpected keyword argument {unknown[0]!r}; "
                            f"options are: method, {', '.join(valid)}")
        return cls(**options)


def integrator(method: str, model: GeneratedModel) -> Integrator:
    """The integrator of ``method`` for ``model``: a SciPy method steps the DAE of a model
    with constraints, the first-order ODE otherwise."""
    if method not in METHODS:
        raise NeweulError(f"unknown method {method!r}; methods are: {', '.join(METHODS)}")
    if method in COMPILED_METHODS:
        return CompiledLoop()
    if method == GeneralizedAlphaSteps.method:
        return GeneralizedAlphaSteps()
    return ConstrainedDAE(method) if model.has_constraints else SolveIVP(method)


def simulate(module: ModelLike, t_end: float, *, method: str = "RK45",
             **options: Any) -> SimulationResult:
    """Integrate a generated model from ``t_start`` to ``t_end``.

    Solves ``ẋ = rhs(t, x, p, u(t))`` with ``x = [y, ẏ]`` by the integrator of ``method``
    (module docstring). Modules with ``CONSTRAINTS`` (closed loops) are integrated as a DAE
    (:func:`neweul_py.analysis.dae.simulate_constrained`: constraint forces, drift control; the
    initial state is made consistent first, the multipliers become ``lambda_<name>`` outputs).

    Parameters
    ----------
    module
        A generated model, module, or the path of one.
    t_end
        Final time [s].
    method
        One of :data:`METHODS`: a ``scipy.integrate.solve_ivp`` method (default ``RK45``);
        ``"c-dopri5"``: RK45's method and step control in the C loop of a compiled module;
        ``"generalized-alpha"``: fixed steps ``h`` of the generalized-α method on the
        second-order form (stiff elastic bodies, unconstrained models).
    **options
        ``t_start``, ``rtol``, ``atol``, ``n_out``, ``t_eval``, ``p``, ``x0``, ``u``,
        ``max_step``, ``independent``, ``progress``, ``h``, ``rho_inf``, ``max_steps``: see
        :class:`SimulationOptions`.

    Returns
    -------
    SimulationResult
        Times, coordinates, velocities and outputs at the output times.

    Raises
    ------
    SolverError
        When the integrator fails (with the last state reached), the mass matrix is singular
        (naming the coordinates without inertia), or a parametric body's schedule leaves its
        sampled range during the run.

    Examples
    --------
    >>> res = simulate("generated/pendulum.py", 5.0, method="DOP853")  # doctest: +SKIP
    >>> res.to_csv("pendulum.csv")  # doctest: +SKIP
    """
    model = as_model(module)
    strategy = integrator(method, model)
    run = _run(model, strategy, t_end, SimulationOptions.of(options))
    try:
        return strategy.simulate(model, run)
    except ValueError as exc:       # a schedule that leaves a parametric body's samples
        if OUTSIDE_SAMPLES not in str(exc):
            raise
        raise SolverError(f"the simulation left the model's validity: {exc}") from None


def _run(model: GeneratedModel, strategy: Integrator, t_end: float,
         o: SimulationOptions) -> Run:
    """The checked options: times, tolerances, what the integrator needs, parameters and
    initial state, in this order."""
    t_start, t_end = float(o.t_start), float(t_end)
    if not (np.isfinite(t_start) and np.isfinite(t_end)) or t_end <= t_start:
        raise NeweulError(f"t_end ({t_end:g}) must be a finite time after t_start ({t_start:g})")
    atol = _absolute_tolerance(model, strategy, o.atol)
    if not (isinstance(o.rtol, numbers.Real) and not isinstance(o.rtol, bool) and o.rtol > 0):
        raise NeweulError(f"rtol must be a positive number, got {o.rtol!r}")
    run = Run(method=strategy.method, t_start=t_start, t_end=t_end, p=np.empty(0),
              x0=np.empty(0), u=o.u, rtol=float(o.rtol), atol=atol, n_out=o.n_out,
              t_eval=o.t_eval, max_step=o.max_step, independent=o.independent,
              progress=o.progress, h=o.h, rho_inf=o.rho_inf, max_steps=o.max_steps)
    strategy.check(model, run)  # before the parameters and the state are read
    return dataclasses.replace(run, p=_parameters(model, o.p), x0=_initial_state(model, o.x0))


def _index(names: Sequence[str], name: str, kind: str) -> int:
    try:
        return list(names).index(name)
    except ValueError:
        raise NeweulError(
            f"unknown {kind} {name!r}; {kind}s are: {', '.join(names) or '(none)'}"
        ) from None


def _parameters(model: GeneratedModel, p: Any) -> np.ndarray:
    names = list(model.PARAMETERS)
    values = np.asarray(model.default_parameters(), dtype=float).copy()
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


def _initial_state(model: GeneratedModel, x0: Any) -> np.ndarray:
    x = np.asarray(model.INITIAL_STATE, dtype=float).copy()
    if x0 is None:
        return x
    if isinstance(x0, Mapping):
        for k, v in x0.items():
            x[_index(model.state_names, k, "state")] = float(v)
        return x
    arr = np.asarray(x0, dtype=float).reshape(-1)
    if arr.size != x.size:
        raise NeweulError(f"x0 has {arr.size} entries, the state has {x.size}")
    return arr


def _absolute_tolerance(model: GeneratedModel, strategy: Integrator,
                        atol: Any) -> float | np.ndarray:
    """``atol`` as a positive number, or one positive value per state where the integrator
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
    size = int(model.STATE_SIZE)
    if a.shape != (size,):
        raise NeweulError(f"atol must be a number or one value per state ({size}), "
                          f"got shape {a.shape}")
    if not strategy.per_state_atol or model.has_constraints:
        raise NeweulError(f"atol per state applies to generalized-alpha and the SciPy methods "
                          f"of unconstrained models, not to {strategy.method!r}"
                          + (" with constraints" if model.has_constraints else ""))
    return a
