"""Parameter sensitivities of equilibria and linear models (docs/sensitivity.md §2–3).

Everything here works on a generated module through its analytic parameter derivatives
(docs/generated-module-protocol.md, "Parameter derivatives"):

- **equilibrium** ``F(y, p) = (q − k)(y, 0, p, u₀(p)) = 0``: by the implicit function theorem
  ``dy₀/dp = −F_y⁻¹ F_p`` with ``F_p = ∂(q−k)/∂p + ∂(q−k)/∂u · ∂u₀/∂p`` (§1 of the page);
- **linear model** ``(M0, P, Q, B, C, D, G)``: total derivatives along
  ``(δy = dy₀/dp_j, δp = e_j, δu = ∂u₀/∂p_j)`` from the module's directional functions,
  ``dQ = −d(∂f/∂y) + d(∂(M a)/∂y)|_{a=ÿ₀} + ∂(M dÿ₀)/∂y`` (§2);
- the sensitivities of **modes** and **frequency responses** built on these are in
  :mod:`.sensitivity_response`.

Modules without the directional functions (elastic bodies) and constrained modules get the
linear model's derivatives as central differences of the analytic linearization (relative step
:data:`RELATIVE_STEP`, the equilibrium solved again at each point); the result says so
(``method``). Forward sensitivities of simulations are in :mod:`.sensitivity_time`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..errors import NeweulError
from . import protocol as proto
from .equilibrium import EquilibriumResult, equilibrium
from .linearize import LinearModel, linearize
from .module import GeneratedModel, ModelLike, as_model
from .results import ResultDisplay

__all__ = [
    "ANALYTIC",
    "DIFFERENCES",
    "RELATIVE_STEP",
    "EquilibriumSensitivity",
    "LinearModelDerivative",
    "equilibrium_sensitivity",
    "held_inputs",
    "input_parameter_jacobian",
    "linear_model_derivatives",
    "parameter_indices",
    "require_parameter_derivatives",
]

#: ``method`` of results from the module's analytic derivatives.
ANALYTIC = "analytic"
#: ``method`` of results whose linear-model derivatives are central differences.
DIFFERENCES = "central differences of the analytic linearization"
#: Relative step of those differences.
RELATIVE_STEP = 1e-6

def parameter_indices(module: ModelLike, wrt: str | Sequence[str] | None,
                      p: np.ndarray | None = None) -> list[int]:
    """Positions in ``PARAMETERS`` of the names ``wrt`` (``None``: every parameter).

    Raises
    ------
    NeweulError
        For a name the model lacks (listing the valid ones), a repeated name, or (with ``p``)
        a parameter whose value is 0 (log sensitivities need a nonzero value).
    """
    names = list(module.PARAMETERS)
    chosen = names if wrt is None else [wrt] if isinstance(wrt, str) else list(wrt)
    if not chosen:
        raise NeweulError("no parameters to differentiate with respect to (--wrt NAME)")
    idx = [proto.name_index(names, nm, "parameter") for nm in chosen]
    if len(set(idx)) < len(idx):
        raise NeweulError(f"a parameter is named twice: {', '.join(chosen)}")
    if p is not None:
        zero = [names[i] for i in idx if p[i] == 0.0]
        if zero:
            raise NeweulError(f"parameter(s) {', '.join(zero)} are 0: sensitivities per ln p "
                              "need nonzero values (set one with -p NAME=VALUE)")
    return idx


def input_parameter_jacobian(model: GeneratedModel, t: float, p: np.ndarray,
                             held: Sequence[int] = ()) -> np.ndarray:
    """``∂u₀/∂p`` (nu, np) of the default excitation, zero in the rows of the inputs
    ``held`` (:func:`held_inputs`)."""
    nu = len(model.INPUTS)
    if not nu:
        return np.zeros((0, p.size))
    U = np.array(model.default_inputs_parameter_jacobian(t, p), dtype=float).reshape(nu, -1)
    U[list(held)] = 0.0
    return U


def held_inputs(model: GeneratedModel, u: Any) -> list[int]:
    """Indices of the inputs that ``u`` (as given to linearize, equilibrium or simulate)
    holds: none for ``None``, the named ones of a mapping, all of a vector."""
    names = list(model.INPUTS)
    if u is None:
        return []
    if isinstance(u, Mapping):
        return [proto.name_index(names, k, "input") for k in u]
    return list(range(len(names)))


def require_parameter_derivatives(model: GeneratedModel) -> None:
    """One error for a module generated before the parameter derivatives existed."""
    if not model.has_parameter_derivatives:
        raise NeweulError(f"{model.MODEL_NAME}: the module has no parameter derivatives "
                          "(rhs_parameter_jacobian …): regenerate it (docs/sensitivity.md)")


# ----------------------------------------------------------------------------- equilibrium
@dataclass(frozen=True, repr=False)
class EquilibriumSensitivity(ResultDisplay):
    """``dy₀/dp`` of a static equilibrium.

    Attributes
    ----------
    equilibrium : EquilibriumResult
    parameters : tuple of str
        The parameters differentiated with respect to (columns).
    values : ndarray (k,)
        Their values.
    dy_dp : ndarray (n, k)
        ``dy₀/dp`` (zero rows for coordinates held fixed).
    """

    equilibrium: EquilibriumResult
    parameters: tuple[str, ...]
    values: np.ndarray
    dy_dp: np.ndarray

    def columns(self) -> dict[str, np.ndarray]:
        """``coordinate``, its value and ``dY_dlog_NAME`` (= p ∂y/∂p) per parameter."""
        cols: dict[str, np.ndarray] = {
            "coordinate": np.array(self.equilibrium.coordinates, dtype=str),
            "value": np.asarray(self.equilibrium.y, dtype=float)}
        for j, nm in enumerate(self.parameters):
            cols[f"dvalue_dlog_{nm}"] = self.values[j] * self.dy_dp[:, j]
        return cols

    def summary(self) -> str:
        return (f"EquilibriumSensitivity({len(self.equilibrium.coordinates)} coordinates, "
                f"parameters {', '.join(self.parameters)})")


def equilibrium_sensitivity(module: ModelLike, eq: EquilibriumResult,
                            wrt: str | Sequence[str] | None = None, *,
                            fixed: Sequence[str] = (), u: Any = None) -> EquilibriumSensitivity:
    """``dy₀/dp = −F_y⁻¹ F_p`` at the equilibrium ``eq`` (docs/sensitivity.md §1).

    Parameters
    ----------
    module
        The generated module ``eq`` was found for.
    eq
        The equilibrium (:func:`~neweul_py.analysis.equilibrium.equilibrium`).
    wrt
        Parameter names (default: all).
    fixed
        Coordinates held fixed in the equilibrium search (their rows are zero).
    u
        The inputs given to the equilibrium search (held: their default's dependence on the
        parameters is not chained in), ``None`` for the default excitation.

    Raises
    ------
    NeweulError
        For constrained modules (not covered analytically: see
        :func:`linear_model_derivatives`, which differentiates them numerically) and names the
        model lacks.
    SolverError
        When the stiffness ``F_y`` is singular (the equilibrium is not isolated).
    """
    module = as_model(module)
    require_parameter_derivatives(module)
    if module.has_constraints:
        raise NeweulError("equilibrium sensitivities of constrained models are not covered "
                          "analytically (docs/sensitivity.md)")
    idx = parameter_indices(module, wrt)
    names = list(module.COORDINATES)
    n = len(names)
    free = [i for i in range(n) if names[i] not in set(fixed)]
    for nm in fixed:
        proto.name_index(names, nm, "coordinate")
    y, p, uv, t = eq.y, eq.p, eq.u, eq.t
    zero = np.zeros(n)
    fy, _fyd, fu = (np.asarray(a, dtype=float)
                    for a in module.force_jacobians(t, y, zero, p, uv))
    fp = np.asarray(module.force_parameter_jacobian(t, y, zero, p, uv), dtype=float)
    Fp = fp + fu.reshape(n, -1) @ input_parameter_jacobian(module, t, p,
                                                           held_inputs(module, u))
    dy = np.zeros((n, len(idx)))
    if free:
        K = fy[np.ix_(free, free)]
        if np.linalg.cond(K) > 1e13:
            from ..errors import SolverError

            raise SolverError("equilibrium sensitivity: the stiffness ∂F/∂y is singular at the "
                              "equilibrium (not isolated: hold a coordinate with fixed)",
                              last_iterate=y.copy(), residual=eq.residual, names=names)
        dy[free] = -np.linalg.solve(K, Fp[np.ix_(free, idx)])
    return EquilibriumSensitivity(eq, tuple(list(module.PARAMETERS)[i] for i in idx),
                                  p[idx].copy(), dy)


# ----------------------------------------------------------------------------- linear model
@dataclass(frozen=True)
class LinearModelDerivative:
    """``d/dp_j`` of the matrices of a :class:`~neweul_py.analysis.linearize.LinearModel`
    (total: the operating point moves with the parameter where it is an equilibrium).

    Attributes
    ----------
    parameter : str
    value : float
        The parameter's value.
    M0, P, Q, B, C, D : ndarray
        The derivatives of the matrices of the same names.
    G : ndarray or None
        Of the hysteretic matrix (``None`` when the model has none).
    """

    parameter: str
    value: float
    M0: np.ndarray
    P: np.ndarray
    Q: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    G: np.ndarray | None = None

    def as_linear_model(self, lin: LinearModel) -> LinearModel:
        """``lin`` with these matrices (its names and basis): the linear pieces of
        :meth:`LinearModel.dynamic_stiffness` and :meth:`LinearModel.output_rows` applied to
        the derivatives (the basis rows of coordinates do not change with ``p``)."""
        return replace(lin, M0=self.M0, P=self.P, Q=self.Q, B=self.B, C=self.C, D=self.D,
                       G=self.G, basis=np.zeros_like(lin.basis))


def linear_model_derivatives(
    module: ModelLike, lin: LinearModel, wrt: str | Sequence[str] | None = None, *,
    equilibrium_point: bool = True, fixed: Sequence[str] = (), u: Any = None,
    start: Any = None,
) -> tuple[list[LinearModelDerivative], str]:
    """The derivatives of ``lin``'s matrices with respect to each parameter of ``wrt``
    (docs/sensitivity.md §2).

    Parameters
    ----------
    module
        The generated module ``lin`` linearizes.
    lin
        The linear model (:func:`~neweul_py.analysis.linearize.linearize`).
    wrt
        Parameter names (default: all).
    equilibrium_point
        ``lin`` is about a static equilibrium, which moves with the parameters (``dy₀/dp``,
        :func:`equilibrium_sensitivity`); ``False``: about a fixed state (the initial one).
    fixed, u, start
        As given to the equilibrium search (coordinates held, inputs held, start); ``u`` and
        ``start`` are used again by the central differences.

    Returns
    -------
    derivatives, method
        One :class:`LinearModelDerivative` per parameter and :data:`ANALYTIC` or
        :data:`DIFFERENCES` (modules without the directional functions — elastic bodies — and
        constrained modules).
    """
    module = as_model(module)
    require_parameter_derivatives(module)
    idx = parameter_indices(module, wrt)
    names = list(module.PARAMETERS)
    if not module.has_directional_derivatives or module.has_constraints:
        return [_difference(module, lin, names[i], equilibrium_point, fixed, u, start)
                for i in idx], DIFFERENCES
    n = len(lin.all_coordinates)
    t, y, yd, p, uv = lin.t, lin.y0, lin.yd0, lin.p, lin.u0
    if equilibrium_point:
        eq = EquilibriumResult(y, np.zeros(0), 0.0, 0, lin.all_coordinates, (), p, uv, t)
        dy0 = equilibrium_sensitivity(module, eq, [names[i] for i in idx], fixed=fixed,
                                      u=u).dy_dp
    else:
        dy0 = np.zeros((n, len(idx)))
    U = input_parameter_jacobian(module, t, p, held_inputs(module, u))
    M = np.asarray(module.mass_matrix(t, y, p, uv), dtype=float)
    f = np.asarray(module.force_vector(t, y, yd, p, uv), dtype=float)
    fy, fyd, fu = (np.asarray(a, dtype=float) for a in module.force_jacobians(t, y, yd, p, uv))
    fu = fu.reshape(n, -1)
    fp = np.asarray(module.force_parameter_jacobian(t, y, yd, p, uv), dtype=float)
    ydd = np.linalg.solve(M, f)
    x0 = np.concatenate([y, yd])
    has_loss = lin.G is not None and module.loss_matrix_directional is not None
    out = []
    for col, i in enumerate(idx):
        dy, dyd, du = dy0[:, col], np.zeros(n), U[:, i]
        dp = np.zeros(p.size)
        dp[i] = 1.0
        dM = np.asarray(module.mass_matrix_directional(t, y, p, dy, dp, uv, du), dtype=float)
        dfy, dfyd, dfu = (np.asarray(a, dtype=float) for a in
                          module.force_jacobians_directional(t, y, yd, p, dy, dyd, dp, uv, du))
        df = fy @ dy + fyd @ dyd + fp[:, i] + fu @ du
        dydd = np.linalg.solve(M, df - dM @ ydd)
        dQ = -dfy
        if np.any(ydd):
            dQ = dQ + np.asarray(module.mass_matrix_times_derivative_directional(
                t, y, p, ydd, dy, dp, uv, du), dtype=float)
        if np.any(dydd):
            dQ = dQ + np.asarray(module.mass_matrix_times_derivative(t, y, p, dydd, uv),
                                 dtype=float)
        if lin.C.shape[0]:
            dC, dD = (np.asarray(a, dtype=float) for a in module.output_jacobians_directional(
                t, x0, p, np.concatenate([dy, dyd]), dp, uv, du))
        else:
            dC, dD = np.zeros_like(lin.C), np.zeros_like(lin.D)
        dG = None
        if has_loss:
            dG = np.asarray(module.loss_matrix_directional(
                t, x0, p, np.concatenate([dy, dyd]), dp, uv, du), dtype=float)
        out.append(LinearModelDerivative(names[i], float(p[i]), dM, -dfyd, dQ,
                                         dfu.reshape(lin.B.shape), dC.reshape(lin.C.shape),
                                         dD.reshape(lin.D.shape), dG))
    return out, ANALYTIC


def _difference(module: GeneratedModel, lin: LinearModel, name: str, equilibrium_point: bool,
                fixed: Sequence[str], u: Any, start: Any) -> LinearModelDerivative:
    """Central differences of the analytic linearization in ``name`` (relative step
    :data:`RELATIVE_STEP`), the operating point found again on each side."""
    k = list(module.PARAMETERS).index(name)
    value = float(lin.p[k])
    h = RELATIVE_STEP * (abs(value) or 1.0)
    sides = []
    for sign in (1.0, -1.0):
        p = lin.p.copy()
        p[k] = value + sign * h
        if equilibrium_point:
            eq = equilibrium(module, p=p, u=u, y0=lin.y0 if start is None else start,
                             t=lin.t, fixed=fixed)
            sides.append(linearize(module, eq, p=p, u0=eq.u,
                                   independent=list(lin.coordinates)
                                   if lin.constraints else None))
        else:
            sides.append(linearize(module, lin.y0, lin.yd0, None if u is None else lin.u0,
                                   p, lin.t,
                                   independent=list(lin.coordinates)
                                   if lin.constraints else None))
    a, b = sides

    def d(x: np.ndarray | None, z: np.ndarray | None) -> np.ndarray | None:
        return None if x is None or z is None else (x - z) / (2 * h)

    return LinearModelDerivative(name, value, d(a.M0, b.M0), d(a.P, b.P), d(a.Q, b.Q),
                                 d(a.B, b.B), d(a.C, b.C), d(a.D, b.D), d(a.G, b.G))
