"""Simulation of constrained systems (closed kinematic loops), equations.md §1.

The index-3 DAE ``M ÿ + k = q + G_Rᵀ λ``, ``g(y, t) = 0`` is integrated in its index-1 form: at
every right-hand-side call the augmented linear system

    [ M  −G_Rᵀ ] [ ÿ ]   [ q − k                               ]
    [ G    0   ] [ λ ] = [ −γ − 2α ġ − β² g ],   ġ = G ẏ + ∂g/∂t

is solved for the accelerations and the multipliers (``α``, ``β``: Baumgarte stabilization,
off by default). ``G_R`` is the Jacobian of the reactions (the module's
``constraint_reaction_jacobian``): it differs from ``G = ∂g/∂y`` only for constraints on node
frames of two-sided elastic bodies, whose reactions enter the elastic rows through the left
basis (equations.md §2); modules without it have ``G_R = G``.

**Drift control**: the integrator is restarted at every output time, and before
each restart the state is projected back onto the position manifold ``g(y) = 0`` and the velocity
manifold ``ġ = 0`` (Gauss–Newton steps of least change in the kinetic metric ``M``, or, with
``independent`` coordinates, by moving only the dependent ones — coordinate partitioning). The
constraint violation therefore never accumulates beyond what one output interval produces; the
largest correction made is reported (:attr:`ConstrainedSimulation.max_drift`).

Consistent initial conditions (:func:`consistent_initial_state`) are found by Newton's method on
``g(y) = 0`` holding the independent coordinates, and by solving ``G ẏ = −∂g/∂t`` for the dependent
velocities. By default the dependent coordinates are the last linearly independent columns of
``G`` (scanning ``COORDINATES`` from the end), so the coordinates listed first keep the positions
and velocities the description gives them. The constraint forces ``λ`` are returned with the
results (columns ``lambda_<name>``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import NeweulError, SolverError
from . import protocol as proto
from .integrators import Run
from .module import GeneratedModel, ModelLike, as_model
from .results import SimulationResult

__all__ = [
    "ConstrainedDAE",
    "ConstrainedSimulation",
    "consistent_initial_state",
    "default_partition",
    "simulate_constrained",
]


@dataclass(frozen=True, repr=False)
class ConstrainedSimulation:
    """Result of :func:`simulate_constrained`.

    Attributes
    ----------
    result : SimulationResult
        Time, coordinates, velocities and outputs; the multipliers are appended to the outputs
        as ``lambda_<constraint>`` columns, so ``result.save("x.csv")`` writes them too.
    lambdas : ndarray (nt, nc)
        Constraint multipliers (the generalized constraint forces are ``G_Rᵀ λ``; for a
        ``coincide`` constraint the force that frame A exerts on frame B, in the components
        of the constraint's frame).
    constraints : tuple of str
    position_residual, velocity_residual : ndarray (nt,)
        ``max |g|`` and ``max |ġ|`` at the output times (after projection).
    drift : ndarray (nt,)
        ``max |g|`` reached at each output time *before* projection (the drift of one interval).
    """

    result: SimulationResult
    lambdas: np.ndarray
    constraints: tuple[str, ...]
    position_residual: np.ndarray
    velocity_residual: np.ndarray
    drift: np.ndarray

    def __repr__(self) -> str:
        return (f"ConstrainedSimulation({self.result.summary()}; {len(self.constraints)} "
                f"constraints, max drift {self.max_drift:.3g})")

    def to_dataframe(self) -> Any:
        """The results table (with the ``lambda_<constraint>`` columns) as a DataFrame."""
        return self.result.to_dataframe()

    @property
    def t(self) -> np.ndarray:
        """Output times."""
        return self.result.t

    @property
    def y(self) -> np.ndarray:
        """Coordinates (nt, n)."""
        return self.result.y

    @property
    def yd(self) -> np.ndarray:
        """Velocities (nt, n)."""
        return self.result.yd

    @property
    def max_drift(self) -> float:
        """Largest constraint violation reached before a projection."""
        return float(self.drift.max(initial=0.0))

    def save(self, path: str | Path) -> Path:
        """Write the results (with the ``lambda_<constraint>`` columns) as ``.csv`` or ``.npz``."""
        return self.result.save(path)


class _Constraints:
    """Constraint evaluation for one model, parameter vector and (optional) partition."""

    def __init__(self, module: GeneratedModel, p: np.ndarray) -> None:
        self.module = module
        self.p = p
        self.names = list(module.CONSTRAINTS)
        self.nc = len(self.names)
        self.n = module.n
        self.separate_reactions = module.separate_reactions
        self.rheonomic = bool(self.nc) and self._probe_rheonomic()

    def _probe_rheonomic(self) -> bool:
        y = np.asarray(self.module.INITIAL_STATE, dtype=float)[: self.n]
        for t in (0.0, 0.37, 1.91):
            if np.any(proto.constraint_time_derivative(self.module, t, y, self.p)):
                return True
        return False

    def g(self, t: float, y: np.ndarray) -> np.ndarray:
        return np.asarray(self.module.constraints(t, y, self.p), dtype=float)

    def jac(self, t: float, y: np.ndarray) -> np.ndarray:
        return np.asarray(self.module.constraint_jacobian(t, y, self.p), dtype=float).reshape(
            self.nc, self.n
        )

    def reaction(self, t: float, y: np.ndarray, gj: np.ndarray | None = None) -> np.ndarray:
        """``G_R`` of the reactions ``G_Rᵀ λ`` (``G`` — ``gj`` when given — for modules
        without ``constraint_reaction_jacobian``)."""
        if not self.separate_reactions:
            return self.jac(t, y) if gj is None else gj
        return proto.constraint_reaction_jacobian(self.module, t, y, self.p)

    def g_t(self, t: float, y: np.ndarray) -> np.ndarray:
        if not self.rheonomic:
            return np.zeros(self.nc)
        return proto.constraint_time_derivative(self.module, t, y, self.p)


def _metric(module: GeneratedModel, t: float, y: np.ndarray, p: np.ndarray) -> np.ndarray | None:
    """``M⁻¹`` when ``M`` is well conditioned (kinetic metric of the projection), else None."""
    m = np.asarray(module.mass_matrix(t, y, p), dtype=float)
    if np.linalg.cond(m) > 1e12:
        return None
    return np.linalg.inv(m)


def _project_position(
    con: _Constraints,
    t: float,
    y: np.ndarray,
    dep: np.ndarray | None,
    winv: np.ndarray | None,
    tol: float,
    maxiter: int = 30,
) -> np.ndarray:
    """Newton on ``g(y) = 0`` moving only ``dep`` (or all, least change in M); raises when the
    constraints cannot be met."""
    y, g = proto.project_onto_constraints(
        lambda yv: con.g(t, yv), lambda yv: con.jac(t, yv), y, tol,
        moved=dep, winv=None if dep is not None else winv, maxiter=maxiter,
    )
    if np.abs(g).max(initial=0.0) <= tol:
        return y
    worst = [con.names[i] for i in np.flatnonzero(np.abs(g) > tol)]
    raise SolverError(
        "constraints cannot be satisfied (inconsistent at this state): residual "
        + ", ".join(f"{nm}={v:.3g}" for nm, v in zip(con.names, g, strict=True) if nm in worst),
        last_iterate=y,
        residual=float(np.abs(g).max()),
        names=list(con.module.COORDINATES),
    )


def _project_velocity(
    con: _Constraints,
    t: float,
    y: np.ndarray,
    yd: np.ndarray,
    dep: np.ndarray | None,
    winv: np.ndarray | None,
) -> np.ndarray:
    """Velocities satisfying ``G ẏ + ∂g/∂t = 0`` (least change, or solving for ``dep``)."""
    gj = con.jac(t, y)
    res = gj @ yd + con.g_t(t, y)
    yd = yd.copy()
    if dep is not None:
        yd[dep] -= np.linalg.lstsq(gj[:, dep], res, rcond=None)[0]
    else:
        w = winv if winv is not None else np.eye(con.n)
        yd -= w @ gj.T @ np.linalg.solve(gj @ w @ gj.T, res)
    return yd


def _check_rank(con: _Constraints, t: float, y: np.ndarray, where: str = "initial state") -> None:
    redundant = proto.redundant_constraints(con.jac(t, y), con.names)
    if redundant:
        raise NeweulError(f"redundant constraints at the {where}: " + "; ".join(redundant))


def _check_regular(module: GeneratedModel, con: _Constraints, t: float, y: np.ndarray,
                   p: np.ndarray, where: str, dep: np.ndarray | None = None) -> None:
    """Name the cause of a singular augmented matrix: redundant constraints, or coordinates
    without inertia in the motions the constraints allow.

    With reactions of their own (``G_R ≠ G``: node frames of two-sided elastic bodies, whose
    left and right bases may be scaled very differently) the motions and the test directions
    are the partition bases of ``G`` and ``G_R`` (``dep``, else the default partition), which
    do not mix the scales of the coordinates as orthonormal null spaces would."""
    names = list(module.COORDINATES)
    m = np.asarray(module.mass_matrix(t, y, p), dtype=float)
    if not con.nc:
        proto.check_mass_matrix(m, names)
        return
    _check_rank(con, t, y, where)
    gj = con.jac(t, y)
    gr = con.reaction(t, y, gj)
    if gr is not gj and not np.array_equal(gr, gj):
        if proto.redundant_constraints(gr, con.names):
            raise NeweulError(f"redundant constraint reactions at the {where}: "
                              + "; ".join(proto.redundant_constraints(gr, con.names)))
        dep = default_partition(gj) if dep is None else dep
        if dep is not None:
            indep = np.array([j for j in range(con.n) if j not in set(dep.tolist())], dtype=int)
            basis = proto.partition_basis(gj, indep, dep)
            left = proto.reaction_free_basis(gr, gj, indep, dep, basis)
            proto.check_mass_matrix(m, names, basis, left)
            return
    basis, _ = proto.null_space(gj)
    left = basis if gr is gj else proto.null_space(gr)[0]
    proto.check_mass_matrix(m, names, basis, left)


def consistent_initial_state(
    module: ModelLike,
    y0: Mapping[str, float] | Sequence[float] | np.ndarray | None = None,
    yd0: Mapping[str, float] | Sequence[float] | np.ndarray | None = None,
    p: proto.ParameterLike = None,
    t: float = 0.0,
    *,
    independent: Sequence[str] | None = None,
    tol: float = 1e-13,
) -> tuple[np.ndarray, np.ndarray]:
    """Coordinates and velocities on the constraint manifold near ``(y0, ẏ0)``.

    Parameters
    ----------
    module
        A generated model (or module, or its path) with ``CONSTRAINTS``.
    y0, yd0
        Guesses: vectors, or mappings name → value over the module's ``INITIAL_STATE``.
    p
        Parameters.
    t
        Time.
    independent
        Coordinates whose values (and velocities) are kept exactly; Newton on ``g(y) = 0`` moves
        the others (coordinate partitioning). ``None``: the same, with the dependent coordinates
        chosen as the *last* columns of ``G`` that are linearly independent (scanning
        ``COORDINATES`` from the end, :func:`default_partition`), so the first coordinates keep
        their given positions and velocities; only when no well-conditioned partition exists or
        Newton fails with it, all coordinates move, by the least change in the kinetic metric
        ``M``.
    tol
        Tolerance on ``max |g|`` (scaled by ``1 + max |y|``).

    Returns
    -------
    y, yd : ndarray
        ``g(y, t) = 0`` and ``G ẏ = −∂g/∂t``.

    Raises
    ------
    NeweulError
        Redundant constraints at the start (named, with the constraints they depend on).
    SolverError
        Constraints that cannot be satisfied (inconsistent), with their residuals.
    """
    module = as_model(module)
    names = list(module.COORDINATES)
    n = len(names)
    pv = proto.resolve_parameters(module, p)
    x_init = np.asarray(module.INITIAL_STATE, dtype=float)
    y = proto.override_vector(x_init[:n].copy(), names, y0, "coordinate").copy()
    yd = proto.override_vector(x_init[n : 2 * n].copy(), names, yd0, "coordinate").copy()
    con = _Constraints(module, pv)
    if con.nc == 0:
        return y, yd
    _check_rank(con, t, y)
    ptol = tol * (1 + np.abs(y).max())
    winv = _metric(module, t, y, pv)
    if independent is not None:
        _, dep = proto.partition(con.jac(t, y), names, independent)
        y_new = _project_position(con, t, y, dep, winv, ptol)
    else:
        dep = default_partition(con.jac(t, y))
        y_new = None
        if dep is not None:
            try:
                y_new = _project_position(con, t, y, dep, winv, ptol)
                if default_partition(con.jac(t, y_new)) is None:
                    y_new = None  # the partition degenerates on the way: use the metric
            except SolverError:
                y_new = None
        if y_new is None:  # fall back to the least change in the kinetic metric
            dep = None
            y_new = _project_position(con, t, y, None, winv, ptol)
    y = y_new
    _check_rank(con, t, y)
    yd = _project_velocity(con, t, y, yd, dep, winv)
    return y, yd


def default_partition(g_jac: np.ndarray, max_cond: float = 1e8) -> np.ndarray | None:
    """Dependent coordinates of the default partition, or None without a well-conditioned one.

    The columns of ``G`` are scanned from the *last* coordinate to the first; a column is taken
    when it raises the rank of the columns taken so far (greedy rank test,
    :func:`~neweul_py.analysis.protocol.partition`), until there are as many as constraints.
    The choice is accepted when the block ``G[:, dep]`` is well conditioned
    (``cond ≤ max_cond``); the coordinates not taken keep their values.
    """
    nc, n = g_jac.shape
    if nc == 0:
        return np.zeros(0, dtype=int)
    try:
        _, dep = proto.partition(g_jac, [str(i) for i in range(n)], None)
    except NeweulError:
        return None
    if np.linalg.cond(g_jac[:, dep]) > max_cond:
        return None
    return dep


def simulate_constrained(
    module: ModelLike,
    t_end: float,
    *,
    t_start: float = 0.0,
    n_out: int = 1001,
    t_eval: Sequence[float] | np.ndarray | None = None,
    y0: Sequence[float] | np.ndarray | None = None,
    yd0: Sequence[float] | np.ndarray | None = None,
    p: proto.ParameterLike = None,
    u: Callable[[float], Any] | Mapping[str, float] | Sequence[float] | None = None,
    independent: Sequence[str] | None = None,
    method: str = "DOP853",
    rtol: float = 1e-10,
    atol: float = 1e-12,
    baumgarte: tuple[float, float] = (0.0, 0.0),
    projection_tol: float = 1e-13,
    progress: Callable[[float, float], None] | None = None,
) -> ConstrainedSimulation:
    """Simulate a module with holonomic constraints (DAE with drift control; see module docstring).

    Parameters
    ----------
    module
        A generated module (or its path); without constraints this is a plain ODE simulation.
    t_end, t_start
        Time span.
    n_out, t_eval
        Output times: ``t_eval``, or ``n_out`` equidistant points. Projection happens there.
    y0, yd0
        Initial guesses (default ``INITIAL_STATE``), made consistent first
        (:func:`consistent_initial_state`).
    p
        Parameters.
    u
        Inputs: ``None`` (the default excitation), a constant vector or mapping, or ``u(t)``.
    independent
        Coordinates held exactly when making the initial state consistent and moved freely by the
        projections (the dependent ones absorb the corrections). ``None``: the initial state
        keeps the coordinates of the default partition (the first ones in ``COORDINATES`` order
        that the constraints leave free, see :func:`consistent_initial_state`); the projections
        during the integration are of least change in the kinetic metric.
    method, rtol, atol
        Passed to :func:`scipy.integrate.solve_ivp`.
    baumgarte
        ``(α, β)`` of the stabilization term ``2α ġ + β² g`` (1/s); zero by default since the
        projections control the drift.
    projection_tol
        Tolerance on ``max |g|`` of the position projection (scaled by ``1 + max |y|``).
    progress
        Called as ``progress(done, total)`` with the simulated time reached and the time span
        after each output interval (a :class:`neweul_py.progress.Tracker` draws a bar).

    Returns
    -------
    ConstrainedSimulation
        Time, coordinates, velocities, outputs, multipliers ``λ`` and constraint residuals.
    """
    module = as_model(module)
    if not module.first_order_state:
        raise NeweulError("simulate_constrained: states beyond [y, ẏ] are not supported yet")
    pv = proto.resolve_parameters(module, p)
    times = (
        np.asarray(t_eval, dtype=float)
        if t_eval is not None
        else np.linspace(t_start, t_end, max(2, int(n_out)))
    )
    if times.size < 2 or np.any(np.diff(times) <= 0):
        raise NeweulError("output times must be increasing (at least two)")
    y, yd = consistent_initial_state(
        module, y0, yd0, pv, float(times[0]), independent=independent, tol=projection_tol
    )
    dae = _IndexOne(module, pv, proto.input_function(module, pv, u), baumgarte)
    if independent is not None and dae.con.nc:
        _, dae.dependent = proto.partition(dae.con.jac(times[0], y), dae.names, independent)
    _check_regular(module, dae.con, float(times[0]), y, pv, "initial state", dae.dependent)
    trajectory = _Trajectory.empty(dae, times.size)
    trajectory.record(dae, 0, times[0], y, yd)
    x = np.concatenate([y, yd])
    first_step = None
    from scipy.integrate import solve_ivp  # imported when a loop is integrated

    for k in range(1, times.size):
        t0, t1 = float(times[k - 1]), float(times[k])
        h0 = None if first_step is None else min(first_step, t1 - t0)
        sol = solve_ivp(dae.rhs, (t0, t1), x, method=method, rtol=rtol, atol=atol,
                        first_step=h0)
        if not sol.success:
            raise SolverError(
                f"simulate_constrained: integration failed at t = {sol.t[-1]:.6g}: {sol.message}",
                last_iterate=sol.y[:, -1], residual=None, names=dae.state_names,
            )
        if sol.t.size >= 2:
            first_step = float(sol.t[-1] - sol.t[-2])
        y, yd = dae.project(t1, sol.y[:dae.n, -1], sol.y[dae.n:, -1], projection_tol,
                            trajectory.drift, k)
        x = np.concatenate([y, yd])
        trajectory.record(dae, k, t1, y, yd)
        if progress is not None:
            progress(float(t1 - times[0]), float(times[-1] - times[0]))
    return trajectory.simulation(dae, times, method)


class _IndexOne:
    """The index-1 form of a constrained model at fixed parameters and inputs: accelerations
    and multipliers from the augmented system (module docstring), the right-hand side that
    ``solve_ivp`` steps, the projections at the output times and the diagnosis of a singular
    system. ``dependent``: the coordinates the projections move (``None``: all, in the kinetic
    metric)."""

    def __init__(self, module: GeneratedModel, pv: np.ndarray, ufun: Callable[[float], Any],
                 baumgarte: tuple[float, float]) -> None:
        self.module, self.pv, self.ufun = module, pv, ufun
        self.names = list(module.COORDINATES)
        self.n = len(self.names)
        self.state_names = [*self.names, *(f"d_{c}" for c in self.names)]
        self.con = _Constraints(module, pv)
        self.alpha, self.beta = baumgarte
        self.dependent: np.ndarray | None = None
        self.nfev = 0

    def accelerations(self, t: float, yv: np.ndarray,
                      ydv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``ÿ`` and ``λ`` of the augmented system at ``(t, y, ẏ)``."""
        module, pv, con = self.module, self.pv, self.con
        uv = self.ufun(t)
        m = np.asarray(module.mass_matrix(t, yv, pv), dtype=float)
        force = np.asarray(module.force_vector(t, yv, ydv, pv, uv), dtype=float)
        if not con.nc:
            return np.linalg.solve(m, force), np.zeros(0)
        gj = con.jac(t, yv)
        c = -np.asarray(module.constraint_gamma(t, yv, ydv, pv), dtype=float)
        if self.alpha or self.beta:
            c = (c - 2 * self.alpha * (gj @ ydv + con.g_t(t, yv))
                 - self.beta**2 * con.g(t, yv))
        return proto.augmented_solve(m, gj, force, c, con.reaction(t, yv, gj))

    def singular(self, t: float, x: np.ndarray) -> SolverError:
        """What is singular at ``(t, x)``: the diagnosis of :func:`_check_regular` (massless
        motions, redundant constraints) or, failing one, the augmented matrix itself."""
        try:
            _check_regular(self.module, self.con, t, x[:self.n], self.pv,
                           f"state at t = {t:.6g}", self.dependent)
            why = "the augmented matrix [M −G_Rᵀ; G 0] is singular"
        except NeweulError as exc:
            why = str(exc)
        return SolverError(f"the constrained system is singular at t = {t:.6g}: {why}",
                           last_iterate=x.copy(), names=self.state_names)

    def rhs(self, t: float, x: np.ndarray) -> np.ndarray:
        """``[ẏ; ÿ]`` for ``solve_ivp``."""
        self.nfev += 1
        try:
            ydd, _ = self.accelerations(t, x[:self.n], x[self.n:])
        except np.linalg.LinAlgError:
            raise self.singular(t, x) from None
        return np.concatenate([x[self.n:], ydd])

    def project(self, t: float, y: np.ndarray, yd: np.ndarray, tol: float,
                drift: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        """The state projected onto ``g = 0`` and ``ġ = 0`` (module docstring); the position
        violation before it goes to ``drift[k]``."""
        con = self.con
        if not con.nc:
            return y, yd
        drift[k] = np.abs(con.g(t, y)).max()
        try:
            winv = _metric(self.module, t, y, self.pv)
            y = _project_position(con, t, y, self.dependent, winv, tol * (1 + np.abs(y).max()))
            yd = _project_velocity(con, t, y, yd, self.dependent, winv)
        except np.linalg.LinAlgError:
            raise self.singular(t, np.concatenate([y, yd])) from None
        return y, yd


@dataclass(frozen=True)
class _Trajectory:
    """The states, multipliers, outputs and constraint residuals at the output times."""

    y: np.ndarray
    yd: np.ndarray
    lambdas: np.ndarray
    outputs: np.ndarray
    position_residual: np.ndarray
    velocity_residual: np.ndarray
    drift: np.ndarray

    @classmethod
    def empty(cls, dae: _IndexOne, nt: int) -> _Trajectory:
        """Room for ``nt`` output times."""
        n = dae.n
        return cls(np.empty((nt, n)), np.empty((nt, n)), np.empty((nt, dae.con.nc)),
                   np.empty((nt, len(dae.module.OUTPUTS))), np.zeros(nt), np.zeros(nt),
                   np.zeros(nt))

    def record(self, dae: _IndexOne, k: int, t: float, yv: np.ndarray,
               ydv: np.ndarray) -> None:
        """Row ``k``: the state at ``t`` with its multipliers, outputs and residuals."""
        module, con = dae.module, dae.con
        self.y[k], self.yd[k] = yv, ydv
        try:
            _, self.lambdas[k] = dae.accelerations(t, yv, ydv)
        except np.linalg.LinAlgError:
            raise dae.singular(t, np.concatenate([yv, ydv])) from None
        if module.OUTPUTS:
            self.outputs[k] = module.outputs(t, np.concatenate([yv, ydv]), dae.pv, dae.ufun(t))
        if con.nc:
            self.position_residual[k] = np.abs(con.g(t, yv)).max()
            self.velocity_residual[k] = np.abs(con.jac(t, yv) @ ydv + con.g_t(t, yv)).max()

    def simulation(self, dae: _IndexOne, times: np.ndarray,
                   method: str) -> ConstrainedSimulation:
        """The :class:`ConstrainedSimulation` of the recorded rows."""
        module, con = dae.module, dae.con
        result = SimulationResult(
            t=times,
            y=self.y,
            yd=self.yd,
            outputs=np.hstack([self.outputs, self.lambdas]),
            coordinates=tuple(dae.names),
            output_names=(*module.OUTPUTS, *(f"lambda_{c}" for c in con.names)),
            coordinate_units=tuple(module.COORDINATE_UNITS),
            output_units=((*module.OUTPUT_UNITS, *([""] * con.nc))  # none given: none here
                          if module.OUTPUT_UNITS or not module.OUTPUTS else ()),
            model_name=module.MODEL_NAME,
            parameters=dict(zip(module.PARAMETERS, map(float, dae.pv), strict=True)),
            source_hash=module.SOURCE_HASH,
            method=method,
            message="constrained: projection at output times",
            nfev=dae.nfev,
        )
        return ConstrainedSimulation(
            result=result,
            lambdas=self.lambdas,
            constraints=tuple(con.names),
            position_residual=self.position_residual,
            velocity_residual=self.velocity_residual,
            drift=self.drift,
        )


class ConstrainedDAE:
    """Models with ``CONSTRAINTS`` in :func:`~neweul_py.analysis.simulate`: the index-1 DAE
    with drift control (:func:`simulate_constrained`), stepped by the SciPy ``method``; the
    multipliers become ``lambda_<name>`` outputs."""

    per_state_atol = False

    def __init__(self, method: str) -> None:
        self.method = method

    def check(self, model: GeneratedModel, run: Run) -> None:
        """Every SciPy method steps the DAE."""

    def simulate(self, model: GeneratedModel, run: Run) -> SimulationResult:
        n = model.n
        return simulate_constrained(
            model, run.t_end, t_start=run.t_start, n_out=run.n_out, t_eval=run.t_eval,
            y0=run.x0[:n], yd0=run.x0[n:2 * n], p=run.p, u=run.u,  # type: ignore[arg-type]
            method=self.method, rtol=run.rtol, atol=run.atol,  # type: ignore[arg-type]
            independent=run.independent, progress=run.progress,
        ).result
