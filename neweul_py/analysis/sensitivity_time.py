"""Forward sensitivities of simulations: the variational equations integrated with the state
(docs/sensitivity.md §5).

For ``ẋ = f(t, x, p)`` (``f`` the module's ``rhs`` with the inputs ``u(t, p)``) the
sensitivities ``S = ∂x/∂p`` (``STATE_SIZE × k``) obey

    Ṡ = ∂f/∂x · S + ∂f/∂p,    S(t₀) = 0,

with the analytic ``∂f/∂x`` (``rhs_jacobian``) and ``∂f/∂p = rhs_parameter_jacobian +
∂rhs/∂u · ∂u₀/∂p`` (the chain through the default excitation; ``∂rhs/∂u = [0; M⁻¹(∂(q−k)/∂u −
∂(M ÿ)/∂u)]``, the last term from ``mass_matrix_directional`` where the module has it). The
state and ``S`` are integrated together by :func:`scipy.integrate.solve_ivp` (the same
tolerances control both); the implicit methods get the block-diagonal part
``diag(∂f/∂x, ∂f/∂x ⊗ I)`` of the augmented Jacobian (enough for their Newton iterations).
The outputs' sensitivities are ``∂out/∂x · S + ∂out/∂p (+ ∂out/∂u · ∂u₀/∂p)``.
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..atomic import atomic_write
from ..errors import NeweulError, SolverError
from . import protocol as proto
from .module import GeneratedModel, ModelLike, as_model
from .results import ResultDisplay, SimulationResult, check_output_path
from .sensitivity import (
    held_inputs,
    input_parameter_jacobian,
    parameter_indices,
    require_parameter_derivatives,
)

__all__ = ["METHODS", "SimulationSensitivity", "simulate_sensitivity"]

#: Integrators of :func:`simulate_sensitivity` (``scipy.integrate.solve_ivp`` names).
METHODS: tuple[str, ...] = ("RK45", "DOP853", "RK23", "Radau", "BDF", "LSODA")
_IMPLICIT = frozenset({"Radau", "BDF", "LSODA"})


@dataclass(frozen=True, repr=False)
class SimulationSensitivity(ResultDisplay):
    """A simulation and the derivatives of its states and outputs with respect to parameters.

    Attributes
    ----------
    result : SimulationResult
        The simulation itself.
    parameters : tuple of str
    values : ndarray (k,)
    dx_dp : ndarray (nt, STATE_SIZE, k)
        ``∂[y, ẏ]/∂p`` at the output times.
    dout_dp : ndarray (nt, ny, k)
        ``∂out/∂p``.
    """

    result: SimulationResult
    parameters: tuple[str, ...]
    values: np.ndarray
    dx_dp: np.ndarray
    dout_dp: np.ndarray

    def columns(self) -> dict[str, np.ndarray]:
        """The simulation's columns (``t``, coordinates, ``d_<coordinate>``, outputs), then
        ``<column>__dlog_<parameter>`` = ``p ∂(column)/∂p`` for every state or output column
        and parameter."""
        cols = self.result.columns()
        names = list(cols)[1:]
        table = np.concatenate([self.dx_dp, self.dout_dp], axis=1) * self.values
        for i, c in enumerate(names):
            for j, nm in enumerate(self.parameters):
                cols[f"{c}__dlog_{nm}"] = table[:, i, j]
        return cols

    def summary(self) -> str:
        r = self.result
        return (f"SimulationSensitivity({r.t.size} times, t = {r.t[0]:g} … {r.t[-1]:g} s; "
                f"parameters {', '.join(self.parameters)})")

    def to_csv(self, path: str | os.PathLike[str]) -> Path:
        """Write :meth:`columns` as CSV (17 significant digits), atomically."""
        cols = self.columns()
        buf = io.StringIO()
        wr = csv.writer(buf, lineterminator="\n")
        wr.writerow(list(cols))
        for row in np.column_stack(list(cols.values())):
            wr.writerow([f"{v:.17g}" for v in row])
        return atomic_write(check_output_path(path, (".csv",), "sensitivities"), buf.getvalue())


def simulate_sensitivity(
    module: ModelLike, t_end: float, wrt: str | Sequence[str] | None = None, *,
    t_start: float = 0.0, p: proto.ParameterLike = None,
    u: Mapping[str, float] | Sequence[float] | np.ndarray | None = None,
    x0: Mapping[str, float] | Sequence[float] | np.ndarray | None = None,
    method: str = "RK45", rtol: float = 1e-8, atol: float = 1e-10, n_out: int = 501,
    t_eval: Sequence[float] | np.ndarray | None = None, max_step: float = np.inf,
) -> SimulationSensitivity:
    """Integrate the state with its forward sensitivities (module docstring).

    Parameters
    ----------
    module
        A generated module (or its path); unconstrained.
    t_end, t_start, n_out, t_eval, max_step, method, rtol, atol
        As :func:`~neweul_py.analysis.simulate.simulate` (``method`` one of :data:`METHODS`;
        the tolerances hold for the state and the sensitivities alike).
    wrt
        Parameter names (default: all).
    p
        Parameters (``None``: defaults; mapping: overrides by name; vector).
    u
        ``None``: the default excitation, whose dependence on the parameters is chained in;
        a mapping holds the named inputs (the others follow the default excitation), a vector
        holds all.
    x0
        Initial state (``None``: ``INITIAL_STATE``; mapping over it, or a vector); it does
        not depend on the parameters.

    Raises
    ------
    NeweulError
        For constrained modules (not covered), unknown names, bad times or methods.
    SolverError
        When the integration fails.
    """
    module = as_model(module)
    if module.has_constraints:
        raise NeweulError("forward sensitivities of simulations are not covered for models "
                          "with constraints (docs/sensitivity.md)")
    require_parameter_derivatives(module)
    if method not in METHODS:
        raise NeweulError(f"unknown method {method!r}; methods are: {', '.join(METHODS)}")
    t_start, t_end = float(t_start), float(t_end)
    if not (np.isfinite(t_start) and np.isfinite(t_end)) or t_end <= t_start:
        raise NeweulError(f"t_end ({t_end:g}) must be a finite time after t_start ({t_start:g})")
    pv = proto.resolve_parameters(module, p)
    idx = parameter_indices(module, wrt)
    names = list(module.COORDINATES)
    n, k = len(names), len(idx)
    nx = 2 * n
    state = [*names, *(f"d_{c}" for c in names)]
    x_init = proto.override_vector(np.asarray(module.INITIAL_STATE, dtype=float)[:nx].copy(),
                                   state, x0, "state")
    held = held_inputs(module, u)
    if t_eval is None:
        if int(n_out) < 2:
            raise NeweulError("n_out must be at least 2")
        times = np.linspace(t_start, t_end, int(n_out))
    else:
        times = np.asarray(t_eval, dtype=float).reshape(-1)
        if (times.size == 0 or times[0] < t_start or times[-1] > t_end
                or np.any(np.diff(times) < 0)):
            raise NeweulError("t_eval must be increasing times within [t_start, t_end]")

    def inputs(t: float) -> np.ndarray:
        return proto.resolve_inputs(module, t, pv, u)

    def parameter_rates(t: float, x: np.ndarray, uu: np.ndarray) -> np.ndarray:
        """``∂f/∂p`` (nx, k): at fixed inputs, plus the chain through the default
        excitation."""
        Jp = np.asarray(module.rhs_parameter_jacobian(t, x, pv, uu), dtype=float)[:, idx]
        U = input_parameter_jacobian(module, t, pv, held)[:, idx]
        if np.any(U):
            Jp = Jp + _rhs_input_derivative(module, t, x, pv, uu, U)
        return Jp

    last = {"t": t_start, "x": x_init}

    def f(t: float, z: np.ndarray) -> np.ndarray:
        x = z[:nx]
        last["t"], last["x"] = t, x
        uu = inputs(t)
        S = z[nx:].reshape(nx, k)
        J = np.asarray(module.rhs_jacobian(t, x, pv, uu), dtype=float)
        return np.concatenate([np.asarray(module.rhs(t, x, pv, uu), dtype=float),
                               (J @ S + parameter_rates(t, x, uu)).ravel()])

    kwargs: dict[str, Any] = {}
    if method in _IMPLICIT:
        from scipy import sparse

        def jac(t: float, z: np.ndarray) -> Any:
            J = np.asarray(module.rhs_jacobian(t, z[:nx], pv, inputs(t)), dtype=float)
            return sparse.block_diag([J, sparse.kron(J, sparse.identity(k))], format="csc")

        kwargs["jac"] = jac
    from scipy.integrate import solve_ivp

    z0 = np.concatenate([x_init, np.zeros(nx * k)])
    try:
        with np.errstate(all="ignore"):
            sol = solve_ivp(f, (t_start, t_end), z0, method=method, t_eval=times, rtol=rtol,
                            atol=atol, max_step=max_step, **kwargs)
    except (ArithmeticError, np.linalg.LinAlgError) as exc:
        raise SolverError(f"the model cannot be evaluated at t = {last['t']:g} "
                          f"({type(exc).__name__}: {exc})", last_iterate=np.array(last["x"]),
                          names=state) from None
    if not sol.success or sol.y.shape[1] != times.size or not np.all(np.isfinite(sol.y)):
        raise SolverError(f"{method} stopped at t = {last['t']:g} of {t_end:g}: {sol.message}",
                          last_iterate=np.array(last["x"]), names=state)
    z = sol.y.T
    x, S = z[:, :nx], z[:, nx:].reshape(times.size, nx, k)
    outs, douts = _outputs(module, times, x, S, pv, idx, inputs, held)
    result = SimulationResult(
        t=times, y=x[:, :n].copy(), yd=x[:, n:].copy(), outputs=outs,
        coordinates=tuple(names), output_names=tuple(module.OUTPUTS),
        coordinate_units=tuple(module.COORDINATE_UNITS),
        output_units=tuple(module.OUTPUT_UNITS),
        model_name=module.MODEL_NAME,
        parameters=dict(zip(module.PARAMETERS, map(float, pv), strict=True)),
        source_hash=module.SOURCE_HASH, method=method, message=str(sol.message),
        nfev=int(sol.nfev))
    return SimulationSensitivity(result, tuple(list(module.PARAMETERS)[i] for i in idx),
                                 pv[idx].copy(), S, douts)


def _rhs_input_derivative(module: GeneratedModel, t: float, x: np.ndarray, p: np.ndarray,
                          u: np.ndarray, U: np.ndarray) -> np.ndarray:
    """``∂rhs/∂u · U`` (nx, k) = ``[0; M⁻¹(∂(q−k)/∂u U − ∂(M ÿ)/∂u U)]``; the last term from
    ``mass_matrix_directional`` where the module has it (modules with elastic bodies do not:
    their mass matrix is taken as independent of the inputs)."""
    n = len(module.COORDINATES)
    y, yd = x[:n], x[n:2 * n]
    M = np.asarray(module.mass_matrix(t, y, p, u), dtype=float)
    fu = np.asarray(module.force_jacobians(t, y, yd, p, u)[2], dtype=float).reshape(n, -1)
    rhs = fu @ U
    directional = module.mass_matrix_directional
    if directional is not None:
        ydd = np.linalg.solve(M, np.asarray(module.force_vector(t, y, yd, p, u), dtype=float))
        zero, zp = np.zeros(n), np.zeros(p.size)
        rhs = rhs - np.column_stack([np.asarray(directional(t, y, p, zero, zp, u, U[:, j]))
                                     @ ydd for j in range(U.shape[1])])
    out = np.zeros((2 * n, U.shape[1]))
    out[n:] = np.linalg.solve(M, rhs)
    return out


def _outputs(module: GeneratedModel, times: np.ndarray, x: np.ndarray, S: np.ndarray, p: np.ndarray,
             idx: Sequence[int], inputs: Any, held: Sequence[int]
             ) -> tuple[np.ndarray, np.ndarray]:
    """The outputs and ``∂out/∂p`` at the output times (the module evaluates one state per
    call)."""
    ny = len(module.OUTPUTS)
    outs = np.empty((times.size, ny))
    douts = np.empty((times.size, ny, len(idx)))
    if not ny:
        return outs, douts
    for i, t in enumerate(times):
        uu = inputs(t)
        outs[i] = module.outputs(t, x[i], p, uu)
        C, D = (np.asarray(a, dtype=float) for a in module.output_jacobians(t, x[i], p, uu))
        Op = np.asarray(module.output_parameter_jacobian(t, x[i], p, uu), dtype=float)[:, idx]
        U = input_parameter_jacobian(module, t, p, held)[:, idx]
        douts[i] = C @ S[i] + Op + (D.reshape(ny, -1) @ U if U.size else 0.0)
    return outs, douts
