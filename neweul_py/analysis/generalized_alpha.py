"""Fixed-step generalized-α integration of ``M(y) ÿ = q − k`` (stiff flexible multibody systems).

The generalized-α method of Chung & Hulbert (J. Appl. Mech. 60 (1993) 371–375) in the form of
Arnold & Brüls for nonlinear second-order systems (Multibody Syst. Dyn. 18 (2007) 185–202,
Eqs. (8)–(10)), as Exudyn and most flexible-multibody codes use it: with the step ``h``, an
acceleration-like variable ``a`` and the true accelerations ``ÿ``,

```
y₊ = y + h ẏ + h² (½ − β) a + h² β a₊
ẏ₊ = ẏ + h (1 − γ) a + h γ a₊
(1 − α_m) a₊ + α_m a = (1 − α_f) ÿ₊ + α_f ÿ
M(y₊) ÿ₊ = (q − k)(t₊, y₊, ẏ₊)
```

with ``α_m = (2ρ∞ − 1)/(ρ∞ + 1)``, ``α_f = ρ∞/(ρ∞ + 1)``, ``γ = ½ + α_f − α_m``,
``β = ¼ (γ + ½)²``: second order, unconditionally stable for linear problems, and the
spectral radius ``ρ∞ ∈ [0, 1]`` at infinite frequency damps the unresolved stiff modes
(ρ∞ = 1: none, the trapezoidal rule; ρ∞ = 0: asymptotic annihilation) while the resolved
ones keep their amplitude to O(h²).

The unknown of a step is ``ÿ₊``; ``y₊`` and ``ẏ₊`` are affine in it
(``y₊ = ŷ + h² β′ ÿ₊``, ``ẏ₊ = v̂ + h γ′ ÿ₊``, ``β′ = β (1 − α_f)/(1 − α_m)``,
``γ′ = γ (1 − α_f)/(1 − α_m)``). Newton's method on the residual
``r(ÿ₊) = M(y₊) ÿ₊ − (q − k)`` uses the iteration matrix
``S = M + h γ′ C_t + h² β′ K_t`` with ``C_t = −∂(q−k)/∂ẏ``,
``K_t = −∂(q−k)/∂y + ∂(M ÿ)/∂y`` (the module's analytic ``force_jacobians`` and
``mass_matrix_times_derivative``). *Modified* Newton: the iteration matrix is built once and
reused over the iterations and the steps; it is rebuilt only when an iteration contracts too
slowly or fails to converge within a few iterations. The residual is taken in the
acceleration form ``r̃ = ÿ₊ − rhs(y₊, ẏ₊)`` (``= M⁻¹ r``), so that one iteration costs one
``rhs`` call (one evaluation of the frame kinematics for M and q − k together) and one
matrix–vector product with the stored ``S⁻¹ M``. The iterations stop by the estimate of
Hairer & Wanner (*Solving ODEs II*, §IV.8, Eq. (8.10)): with the contraction
``θ = ‖Δ_k‖/‖Δ_(k−1)‖`` the remaining error is about ``θ/(1 − θ) ‖Δ_k‖`` (the last step's θ
serves for the first iteration only right after the matrix was rebuilt; with an older matrix
the step's own contraction is measured first), measured on the position and velocity updates
``h² β′ Δ`` and ``h γ′ Δ`` against ``atol + rtol |·|``. Output times between steps are
interpolated by cubic Hermite polynomials (``y`` from ``y, ẏ``; ``ẏ`` from ``ẏ, ÿ``), so the
user sees the same result arrays as from the SciPy methods.

A compiled module with its own loop (``generalized_alpha_steps``,
:data:`~neweul_py.codegen.c_templates.C_GALPHA`) takes the steps in C when the inputs are
constant or the default (:func:`_compiled_steps` drives it: it builds ``S`` and its inverse
at the start and whenever the loop asks, and raises the errors): the same predictor,
stopping rule and outputs, with Newton's method on the residual ``r = M ÿ₊ − (q − k)`` and
the kept ``S⁻¹`` (``Δ = S⁻¹ r``, Arnold & Brüls, Eq. (14)), as the Python loop keeps
``S⁻¹ M``: no solve with ``M`` per iteration. With a
constant ``M`` that is the iteration above; when ``M`` changes the two stop at different
iterates within the tolerance (docs/analysis.md).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from ..errors import NeweulError, SolverError
from .integrators import FirstOrder, Run, Solution
from .module import GeneratedModel

__all__ = ["GeneralizedAlpha", "GeneralizedAlphaSteps", "coefficients",
           "integrate_generalized_alpha"]

#: Newton iterations per step before the iteration matrix is rebuilt (and then the step fails).
MAX_ITERATIONS = 8
#: Contraction above which the iteration matrix is rebuilt.
SLOW_CONTRACTION = 0.5
#: An increment below this multiple of the round-off of ``ÿ₊`` counts as converged (with
#: ``ω h ≫ 1`` the positions ``ŷ + h² β′ ÿ₊`` lose digits to cancellation, so tight
#: tolerances cannot be met by the increments).
ROUND_OFF = 64 * np.finfo(float).eps
#: A weighted increment below this ends the iterations (far inside the tolerance).
SMALL_INCREMENT = 1e-3


class GeneralizedAlpha:
    """The coefficients ``α_m, α_f, γ, β`` of the method for ``ρ∞`` (Chung & Hulbert 1993,
    Eqs. (25), (17), (20)) and the factors ``h² β′``, ``h γ′`` of ``ÿ₊`` in ``y₊``, ``ẏ₊``."""

    def __init__(self, rho_inf: float, h: float = 1.0) -> None:
        if not 0.0 <= rho_inf <= 1.0:
            raise NeweulError(f"rho_inf must lie in [0, 1], got {rho_inf:g}")
        self.rho_inf, self.h = float(rho_inf), float(h)
        self.alpha_m = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0)
        self.alpha_f = rho_inf / (rho_inf + 1.0)
        self.gamma = 0.5 + self.alpha_f - self.alpha_m
        self.beta = 0.25 * (self.gamma + 0.5) ** 2
        ratio = (1 - self.alpha_f) / (1 - self.alpha_m)
        self.c_y = h * h * self.beta * ratio
        self.c_v = h * self.gamma * ratio
        # ŷ = y + h ẏ + h²[(½ − β) a + β k], v̂ = ẏ + h[(1 − γ) a + γ k] with the known part
        # k = (α_f ÿ − α_m a)/(1 − α_m) of a₊, as coefficients of a and ÿ
        am, af = self.alpha_m, self.alpha_f
        b, g = self.beta, self.gamma
        self._ya, self._yy = h * h * (0.5 - b - b * am / (1 - am)), h * h * b * af / (1 - am)
        self._va, self._vy = h * (1 - g - g * am / (1 - am)), h * g * af / (1 - am)

    def predict(self, y: np.ndarray, v: np.ndarray, a: np.ndarray, ydd: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
        """``(ŷ, v̂)``: ``y₊ = ŷ + c_y ÿ₊`` and ``ẏ₊ = v̂ + c_v ÿ₊`` (module docstring)."""
        return (y + self.h * v + self._ya * a + self._yy * ydd,
                v + self._va * a + self._vy * ydd)

    def next_a(self, a: np.ndarray, ydd: np.ndarray, ydd_new: np.ndarray) -> np.ndarray:
        """``a₊`` from ``(1 − α_m) a₊ + α_m a = (1 − α_f) ÿ₊ + α_f ÿ``."""
        return ((1 - self.alpha_f) * ydd_new + self.alpha_f * ydd - self.alpha_m * a) / (
            1 - self.alpha_m)


def coefficients(rho_inf: float, h: float = 1.0) -> GeneralizedAlpha:
    """The method's coefficients for the spectral radius ``rho_inf`` (and the step ``h``)."""
    return GeneralizedAlpha(rho_inf, h)


def _hermite(t0: float, t1: float, p0: np.ndarray, d0: np.ndarray, p1: np.ndarray,
             d1: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Cubic Hermite interpolation of values ``p`` with derivatives ``d`` at times ``t``."""
    h = t1 - t0
    s = ((t - t0) / h)[:, None]
    h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
    h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
    return h00 * p0 + h10 * h * d0 + h01 * p1 + h11 * h * d1


class _Problem:
    """The module with fixed ``p`` and inputs: accelerations and the Newton matrix."""

    def __init__(self, module: GeneratedModel, p: np.ndarray, uf: Callable[[float], Any],
                 n: int) -> None:
        self.module, self.p, self.uf, self.n = module, p, uf, n
        self.nfev = 0
        self.njev = 0

    def acceleration(self, t: float, x: np.ndarray) -> np.ndarray:
        """``ÿ = M⁻¹ (q − k)`` at the state ``x = [y, ẏ]`` (one ``rhs`` call)."""
        self.nfev += 1
        return np.asarray(self.module.rhs(t, x, self.p, self.uf(t)), dtype=float)[self.n:]

    def newton_matrix(self, t: float, y: np.ndarray, yd: np.ndarray, ydd: np.ndarray,
                      c: GeneralizedAlpha) -> np.ndarray:
        """``S⁻¹ M`` with ``S = M + c_v C_t + c_y K_t`` at ``(t, y, ẏ, ÿ)``: the inverse of
        ``∂r̃/∂ÿ₊`` for the acceleration-form residual."""
        S, mass = self.iteration_matrix(t, y, yd, ydd, c)
        return np.linalg.solve(S, mass)

    def iteration_matrix(self, t: float, y: np.ndarray, yd: np.ndarray, ydd: np.ndarray,
                         c: GeneralizedAlpha) -> tuple[np.ndarray, np.ndarray]:
        """``(S, M)``: ``S = M + c_v C_t + c_y K_t`` and ``M`` at ``(t, y, ẏ, ÿ)`` (module
        docstring; one Jacobian evaluation)."""
        self.njev += 1
        u, m = self.uf(t), self.module
        fy, fyd, _fu = m.force_jacobians(t, y, yd, self.p, u)
        dma = m.mass_matrix_times_derivative(t, y, self.p, ydd, u)
        mass = np.asarray(m.mass_matrix(t, y, self.p, u), dtype=float)
        S = mass - c.c_v * np.asarray(fyd) + c.c_y * (np.asarray(dma) - np.asarray(fy))
        return S, mass


def _newton(prob: _Problem, cz: np.ndarray, tn: float, y_hat: np.ndarray,
            v_hat: np.ndarray, x: np.ndarray, G: np.ndarray, scale: np.ndarray,
            theta: float, fresh: bool) -> tuple[np.ndarray | None, float]:
    """Modified Newton on ``r̃(ÿ₊) = ÿ₊ − rhs(ŷ + c_y ÿ₊, v̂ + c_v ÿ₊)`` from ``x``.

    The error estimate ``θ/(1 − θ) ‖Δ‖`` may stop the iterations after the first increment
    only with a ``fresh`` matrix (``θ`` is then the last step's); with an older one the
    contraction of *this* step must have been measured: under a stiffness that changes with
    time the old matrix can make the iteration diverge in a stiff component while the first
    increment is small, and accepting it step after step let the solution grow without bound
    (``tests/analysis/test_generalized_alpha.py``, a stiff spring whose stiffness varies by
    ±90 %: 10⁶⁹ after 3 s; the middle-ear EMBS under a Δp ramp).

    Returns ``(ÿ₊, θ)``, or ``(None, θ)`` when it does not converge (or contracts slower than
    :data:`SLOW_CONTRACTION` with an old matrix, ``fresh`` false)."""
    previous = np.inf
    z_hat = np.concatenate((y_hat, v_hat))
    for k in range(MAX_ITERATIONS):
        dx = G @ (x - prob.acceleration(tn, z_hat + cz * np.concatenate((x, x))))
        x = x - dx
        err = float((np.abs(dx) * scale).max())
        if not math.isfinite(err):
            return None, theta
        if k:
            theta = err / previous
            if theta >= 1.0 or (theta > SLOW_CONTRACTION and not fresh):
                return None, theta
        if ((k or fresh) and theta < 1.0 and theta / (1.0 - theta) * err <= 1.0) \
                or err <= SMALL_INCREMENT or np.abs(dx).max() <= ROUND_OFF * np.abs(x).max():
            return x, theta
        previous = err
    return None, theta


#: Default cap of the number of steps of one run (docs/limits.md).
MAX_STEPS = 10**9


def step_count(span: float, h: float, max_steps: int = MAX_STEPS) -> int:
    """The number of equal steps of at most ``h`` over ``span``: ``ceil(span / h)``.

    Raises
    ------
    NeweulError
        ``h`` is not a positive number, or the count exceeds ``max_steps`` (checked before
        any step: ``h = 1e-300`` would take 10³⁰⁰ of them).
    """
    if not (isinstance(h, int | float) and np.isfinite(h) and h > 0):
        raise NeweulError(f"the step h must be a positive number, got {h!r}")
    ratio = span / h * (1 - 1e-12)
    if not ratio <= max_steps:            # also inf, when span / h overflows
        raise NeweulError(
            f"generalized-alpha with the step h = {h:g} takes {ratio:.4g} steps for "
            f"{span:g} s, more than max_steps = {max_steps} (docs/limits.md): use a larger "
            "step")
    return max(1, math.ceil(ratio))


def _inverse(S: np.ndarray) -> np.ndarray:
    """``S⁻¹`` for the C loop (LAPACK; ``LinAlgError`` when ``S`` is singular, as the Python
    loop's solve with ``S``); a matrix that is not finite is passed as it is, so that the C
    loop fails its iterations as the Python loop does with NaN increments."""
    S = np.asarray(S, dtype=float)
    return np.linalg.inv(S) if np.isfinite(S).all() else S


def _compiled_steps(module: GeneratedModel, t_span: tuple[float, float], steps: int,
                    c: GeneralizedAlpha, x0: np.ndarray, p: np.ndarray, u: Any,
                    times: np.ndarray, rtol: float, atol: np.ndarray, names: list[str],
                    progress: Callable[[float, float], None] | None) -> Solution:
    """The steps of :func:`integrate_generalized_alpha` in the module's C loop
    (``generalized_alpha_steps``, :data:`~neweul_py.codegen.c_templates.C_GALPHA`): the
    same predictor, stopping rule, rebuild protocol and outputs, Newton's method on the
    residual ``M ÿ₊ − (q − k)`` with ``S⁻¹`` kept in C; this driver builds ``S`` and its
    inverse (at the start and whenever the loop asks), reports progress and raises the
    errors."""
    t0, t1 = t_span
    n = x0.size // 2
    prob = _Problem(module, p, lambda _t: u, n)
    ydd = prob.acceleration(t0, x0)
    state = np.concatenate((x0, ydd, ydd))
    out = np.full((times.size, 2 * n), np.nan)
    k = int(np.searchsorted(times, t0, side="right"))
    out[:k] = x0
    Si = _inverse(prob.iteration_matrix(t0, x0[:n], x0[n:], ydd, c)[0])
    flags = np.array([0.5, 1.0, 0.0])
    coef = np.array([c.h, c.c_y, c.c_v, c._ya, c._yy, c._va, c._vy, c.alpha_m, c.alpha_f,
                     MAX_ITERATIONS, SLOW_CONTRACTION, ROUND_OFF, SMALL_INCREMENT])
    counters = np.array([k, prob.nfev, 0], dtype=np.int64)
    work = np.zeros(n * n + 3 * n + 1)      # this run's S⁻¹ (and the failing point)
    report = max(1, steps // 200)
    i = 0
    while i < steps:
        last = min(steps, (i // report + 1) * report)
        status = module.generalized_alpha_steps(t0, t1, i, last, steps, coef, p, u, Si, rtol,
                                                atol, state, flags, work, times, out,
                                                counters)
        Si, i = None, int(counters[2])
        tn = t0 + (i + 1) * c.h if i + 1 < steps else t1
        y, v, ydd_i, a = state.reshape(4, n)
        if status == 1:                  # rebuild the matrix at the predictor, retry
            y_hat, v_hat = c.predict(y, v, a, ydd_i)
            Si = _inverse(prob.iteration_matrix(tn, y_hat + c.c_y * ydd_i,
                                               v_hat + c.c_v * ydd_i, ydd_i, c)[0])
            flags[:] = (0.5, 1.0, 1.0)
            continue
        if status == 2:
            raise SolverError(
                f"generalized-alpha: Newton's method does not converge at t = {tn:g} "
                f"(h = {c.h:g}); use a smaller step", last_iterate=state[:2 * n].copy(),
                names=names)
        if status:                       # the model's own error where it failed
            prob.acceleration(tn, work[n * n + n:n * n + 3 * n].copy())
            raise SolverError(f"generalized-alpha: the model failed at t = {tn:g} "
                              f"(code {status - 4})", last_iterate=state[:2 * n].copy(),
                              names=names)
        if progress is not None:
            progress(min(i * c.h, t1 - t0), t1 - t0)
    return Solution(times, out.T, True,
                    "The solver successfully reached the end of the integration interval.",
                    int(counters[1]), prob.njev)


def integrate_generalized_alpha(
    module: GeneratedModel,
    t_span: tuple[float, float],
    x0: np.ndarray,
    p: np.ndarray,
    uf: Callable[[float], Any],
    times: np.ndarray,
    *,
    h: float,
    rho_inf: float,
    rtol: float,
    atol: float | np.ndarray,
    names: list[str],
    progress: Callable[[float, float], None] | None = None,
    max_steps: int = MAX_STEPS,
    loop_inputs: Any = ...,
) -> Solution:
    """Integrate the module from ``x0`` over ``t_span`` with generalized-α steps of (at most)
    ``h``; in the module's C loop when it has one (``generalized_alpha_steps``) and the
    inputs are constant (``loop_inputs``: ``None`` for the default excitation or the input
    vector; ``...``, the default: not constant).

    Parameters
    ----------
    module
        A generated model (``rhs``, ``mass_matrix``, ``force_jacobians``,
        ``mass_matrix_times_derivative``).
    t_span
        ``(t_start, t_end)``; the span is divided into ``ceil(span / h)`` equal steps.
    x0
        Initial state ``[y, ẏ]``.
    p, uf
        Parameters and the input function ``u(t)`` (``None`` results: default excitation).
    times
        Output times (increasing, within ``t_span``).
    h
        Step size.
    rho_inf
        Spectral radius at infinite frequency, in ``[0, 1]``.
    rtol, atol
        Tolerances of the Newton iterations on the position and velocity updates; ``atol`` a
        number or one per state ``[y, ẏ]`` (velocities have their own unit: a tone of
        angular frequency ω moves them ω times more than the positions).
    names
        State names for error messages.
    progress
        ``progress(done, total)`` hook, called about 200 times.
    max_steps
        Largest number of steps (:func:`step_count`).
    loop_inputs
        ``u`` of every step when constant (above).

    Returns
    -------
    Solution
        The states at ``times`` (``y`` of shape (2n, len(times))) and the number of
        ``rhs`` evaluations as ``nfev``.

    Raises
    ------
    SolverError
        When Newton's method does not converge in a step even with a fresh iteration matrix
        (with the last state reached).
    """
    t0, t1 = t_span
    steps = step_count(t1 - t0, h, max_steps)
    h = (t1 - t0) / steps
    c = coefficients(rho_inf, h)
    n = x0.size // 2
    atol_y, atol_v = np.broadcast_to(np.asarray(atol, dtype=float), (2 * n,)).reshape(2, n)
    if loop_inputs is not ... and module.generalized_alpha_steps is not None:
        return _compiled_steps(module, (t0, t1), steps, c, np.asarray(x0, dtype=float), p,
                               loop_inputs, times, rtol, np.concatenate((atol_y, atol_v)),
                               names, progress)
    cz = np.repeat((c.c_y, c.c_v), n)  # [y₊, ẏ₊] = [ŷ, v̂] + cz · [ÿ₊, ÿ₊]
    prob = _Problem(module, p, uf, n)
    y, v = x0[:n].astype(float), x0[n:].astype(float)
    ydd = prob.acceleration(t0, np.concatenate((y, v)))
    a = ydd.copy()
    out = np.empty((times.size, 2 * n))
    k = int(np.searchsorted(times, t0, side="right"))
    out[:k] = x0
    G = prob.newton_matrix(t0, y, v, ydd, c)
    fresh, theta = True, 0.5
    report = max(1, steps // 200)
    for i in range(steps):
        t, tn = t0 + i * h, (t0 + (i + 1) * h if i + 1 < steps else t1)
        y_hat, v_hat = c.predict(y, v, a, ydd)
        scale = np.maximum(c.c_y / (atol_y + rtol * np.abs(y)),
                           c.c_v / (atol_v + rtol * np.abs(v)))
        x_new, theta = _newton(prob, cz, tn, y_hat, v_hat, ydd, G, scale, theta, fresh)
        fresh = False
        if x_new is None:  # rebuild the matrix at the predictor and try once more
            G = prob.newton_matrix(tn, y_hat + c.c_y * ydd, v_hat + c.c_v * ydd, ydd, c)
            fresh, theta = True, 0.5
            x_new, theta = _newton(prob, cz, tn, y_hat, v_hat, ydd, G, scale, theta, True)
            if x_new is None:
                raise SolverError(
                    f"generalized-alpha: Newton's method does not converge at t = {tn:g} "
                    f"(h = {h:g}); use a smaller step", last_iterate=np.concatenate((y, v)),
                    names=names)
        a = c.next_a(a, ydd, x_new)
        y_new, v_new = y_hat + c.c_y * x_new, v_hat + c.c_v * x_new
        j = int(np.searchsorted(times, tn, side="right")) if i + 1 < steps else times.size
        if j > k:
            out[k:j, :n] = _hermite(t, tn, y, v, y_new, v_new, times[k:j])
            out[k:j, n:] = _hermite(t, tn, v, ydd, v_new, x_new, times[k:j])
            k = j
        y, v, ydd = y_new, v_new, x_new
        if progress is not None and i % report == 0:
            progress(tn - t0, t1 - t0)
    return Solution(times, out.T, True,
                    "The solver successfully reached the end of the integration interval.",
                    prob.nfev, prob.njev)


class GeneralizedAlphaSteps(FirstOrder):
    """``method="generalized-alpha"`` of :func:`~neweul_py.analysis.simulate`: fixed steps
    ``h`` of :func:`integrate_generalized_alpha` (unconstrained models)."""

    method = "generalized-alpha"

    def check(self, model: GeneratedModel, run: Run) -> None:
        if run.h is None:
            raise NeweulError("method 'generalized-alpha' needs the step h "
                              "(neweul simulate --step)")
        if model.has_constraints:
            raise NeweulError("method 'generalized-alpha' integrates unconstrained models; "
                              "models with constraints use the DAE integrators (RK45, …)")
        step_count(run.t_end - run.t_start, run.h, run.max_steps)   # before the first step

    def solve(self, model: GeneratedModel, run: Run, uf: Callable[[float], Any],
              times: np.ndarray, last: Any) -> Solution:
        return integrate_generalized_alpha(
            model, (run.t_start, run.t_end), run.x0, run.p, uf, times,
            h=float(run.h),  # type: ignore[arg-type]
            rho_inf=run.rho_inf, rtol=run.rtol, atol=run.atol, names=model.state_names,
            progress=run.progress, max_steps=run.max_steps,
            loop_inputs=... if callable(run.u) else (None if run.u is None
                                                     else uf(run.t_start)))
