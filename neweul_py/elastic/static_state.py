"""The static state a reduced or parametric body is linearized about (its ``static/*`` arrays).

A working-point body stands for a *nonlinear* structure as a large static deflection plus
linear dynamics about it (``docs/equations-middle-ear.md`` §5)::

    x(σ, t) = X + u_s(σ) + V q(t),
    M q̈ + D q̇ + K q = B u + Wᵀ (f_n − f_s(σ)),

with ``f_n`` the forces the attached parts apply at the body's node frames. The body's
``q = 0`` is the static state; it is in equilibrium there when the node forces equal the
static interface forces ``f_s``. :class:`StaticDeflection` is what the body carries of that
state, per working point:

* ``q`` (r,) — the static reduced coordinates, the projection of the FE static state
  ``x_s`` on the body's basis (:func:`static_deflection`: ``Ḡ``-orthogonal for a Galerkin
  basis with the energy metric, ``(WᵀV)⁻¹Wᵀx_s`` otherwise), and ``residual`` — the relative
  part of ``x_s`` the basis leaves out, ``‖x_s − V q‖/‖x_s‖`` (in the same metric);
* ``node_u`` (n_nodes, 3) — the static displacement of every kept node (the body's node
  frames, in the order of ``nodes``), taken from ``x_s`` itself (exact, not ``V q``); so the
  node positions of the nonlinear state are ``X + u_s`` and, in motion, ``X + u_s + Φ q``;
* ``node_force`` (n_nodes, 3) — the static interface forces ``f_s`` at those nodes [N]
  (forces *on* the body; zero at nodes nothing is attached to);
* ``outputs`` (n_out,) — the static value of each of the body's outputs: the FE output rows
  applied to ``x_s`` (exact for displacement outputs), or the exact nonlinear value where
  the writer knows it (the swept volume of the middle-ear TM).

In a file the group is the arrays ``static/q``, ``static/node_u``, ``static/node_force``,
``static/outputs``, ``static/residual`` (``docs/reduced-body-format.md``); a parametric body
stacks them over its samples (first axis) and :meth:`StaticDeflection.mixed` mixes them with
the body's interpolation weights, like every other stored quantity — except the residual, a
ratio of norms, which is the largest residual of the samples mixed (:func:`residual_bound`).
In common coordinates ``q̃ = T_i q_i`` (:meth:`StaticDeflection.transformed`); the physical
arrays do not change.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sps

from ..errors import DataError, SolverError

__all__ = ["STATIC_KEYS", "STATIC_PREFIX", "StaticDeflection", "node_positions", "node_rows",
           "residual_bound", "rigid_map",
           "static_deflection", "static_from_arrays", "tied_static_equilibrium"]

STATIC_PREFIX = "static/"
#: The arrays of the group, in file order.
STATIC_KEYS = ("q", "node_u", "node_force", "outputs", "residual")


@dataclass(frozen=True, eq=False)
class StaticDeflection:
    """The static state of one working point, or of ``k`` stacked samples (module docstring).

    Parameters
    ----------
    q
        (r,) static reduced coordinates (``(k, r)`` stacked).
    node_u, node_force
        (n_nodes, 3) static displacement [m] and static interface force [N] of every kept
        node, in the order of the body's ``nodes`` (``(k, n_nodes, 3)`` stacked).
    outputs
        (n_out,) static values of the body's outputs, in the order of ``output_names``.
    residual
        Relative residual ``‖x_s − V q‖/‖x_s‖`` of the projection (``(k,)`` stacked).
    """

    q: np.ndarray
    node_u: np.ndarray
    node_force: np.ndarray
    outputs: np.ndarray
    residual: np.ndarray

    def __post_init__(self) -> None:
        for key in STATIC_KEYS:
            a = np.asarray(self[key], dtype=np.float64)
            if not np.all(np.isfinite(a)):
                raise DataError("has NaN/Inf entries", None, f"static.{key}")
            object.__setattr__(self, key, a)

    def __getitem__(self, key: str) -> Any:
        return getattr(self, key)

    @property
    def stacked(self) -> bool:
        """Whether the arrays carry a leading sample axis."""
        return self.q.ndim == 2

    def check(self, r: int, n_nodes: int, n_out: int, k: int | None = None
              ) -> StaticDeflection:
        """``self`` if its shapes fit a body of order ``r`` with ``n_nodes`` kept nodes and
        ``n_out`` outputs (``k`` samples stacked, or a single working point for ``None``);
        otherwise a :class:`DataError` naming the array (``static.q`` …)."""
        lead = () if k is None else (k,)
        want = {"q": (*lead, r), "node_u": (*lead, n_nodes, 3),
                "node_force": (*lead, n_nodes, 3), "outputs": (*lead, n_out),
                "residual": lead}
        for key, shape in want.items():
            if self[key].shape != shape:
                raise DataError(f"must be {shape}, got {self[key].shape}", None,
                                f"static.{key}")
        if np.any(self.residual < 0):
            raise DataError("a relative residual is never negative", None, "static.residual")
        return self

    def mixed(self, w: np.ndarray) -> StaticDeflection:
        """``Σ_i w_i X_i`` of stacked samples (the weights of
        :meth:`~neweul_py.elastic.interpolation.ParametricBody.weights`), the residual
        :func:`residual_bound`; a unit vector returns that sample bit for bit."""
        w = np.asarray(w, dtype=np.float64)
        idx = np.flatnonzero(w)
        if idx.size == 1:
            return StaticDeflection(*(self[key][idx[0]].copy() for key in STATIC_KEYS))
        return StaticDeflection(**{key: np.einsum("i,i...->...", w[idx], self[key][idx])
                                   for key in STATIC_KEYS if key != "residual"},
                                residual=residual_bound(self.residual, w))

    def transformed(self, T: np.ndarray) -> StaticDeflection:
        """The state in common coordinates ``q̃ = T q`` (``T`` = ``T_i`` of the sample)."""
        return dataclasses.replace(self, q=np.asarray(T) @ self.q)

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The file arrays ``static/<key>``."""
        return {STATIC_PREFIX + key: self[key] for key in STATIC_KEYS}

    @staticmethod
    def stack(states: list[StaticDeflection]) -> StaticDeflection:
        """The samples' states stacked on a first axis."""
        return StaticDeflection(*(np.stack([s[key] for s in states]) for key in STATIC_KEYS))


def residual_bound(residuals: np.ndarray, w: np.ndarray) -> np.ndarray:
    """The relative residual of a static state mixed from samples with the weights ``w``.

    A residual ``‖x_s − V q‖/‖x_s‖`` is a ratio of norms, not a quantity linear in the
    state: mixing it with signed weights (cubic cardinal functions are negative between
    some samples) can give a negative "residual". The mixed state's residual is therefore
    the bound ``max_i r_i`` over the samples with a nonzero weight ``w_i`` (the FE state
    between samples is not known, so its own residual cannot be computed).

    Parameters
    ----------
    residuals
        (k,) the samples' residuals, each ≥ 0.
    w
        (k,), (2k,) or (3k,) weights; with Hermite weights all but the first ``k`` (those of
        the slopes and curvatures, whose residual derivatives are zero) do not count.

    Returns
    -------
    numpy.ndarray
        The () residual, ≥ 0 (the sample's own at a unit weight vector).
    """
    r = np.asarray(residuals, dtype=np.float64)
    used = np.flatnonzero(np.asarray(w, dtype=np.float64)[:r.size])
    return np.array(r[used].max() if used.size else r.max())


def static_from_arrays(data: Mapping[str, np.ndarray], file: str | None = None
                       ) -> StaticDeflection | None:
    """The ``static/*`` group of a body file's arrays, ``None`` if it has none; a
    :class:`DataError` naming the file when the group is incomplete."""
    present = [key for key in STATIC_KEYS if STATIC_PREFIX + key in data]
    if not present:
        return None
    missing = [key for key in STATIC_KEYS if key not in present]
    if missing:
        raise DataError(f"the static group lacks {[STATIC_PREFIX + m for m in missing]}",
                        file, STATIC_PREFIX + missing[0])
    try:
        return StaticDeflection(*(data[STATIC_PREFIX + key] for key in STATIC_KEYS))
    except DataError as exc:
        raise DataError(exc.message, file, exc.item) from None


def node_rows(nodes: np.ndarray, dof_node: np.ndarray, dof_kind: np.ndarray) -> np.ndarray:
    """(n_nodes, 3) index into the kept DOFs of ``ux, uy, uz`` of every kept node (−1 where
    the node has no such DOF)."""
    ids = np.asarray(nodes)[:, 0].astype(np.int64)
    out = np.full((ids.size, 3), -1, dtype=np.int64)
    for a, kind in enumerate(("ux", "uy", "uz")):
        sel = np.flatnonzero(np.asarray(dof_kind) == kind)
        pos = {int(n): int(i) for n, i in zip(np.asarray(dof_node)[sel], sel, strict=True)}
        out[:, a] = [pos.get(int(n), -1) for n in ids]
    return out


def static_deflection(body: Any, x: np.ndarray, *, V: np.ndarray | None = None,
                      W: np.ndarray | None = None, output_rows: np.ndarray | None = None,
                      node_force: Mapping[int, np.ndarray] | None = None,
                      outputs: Mapping[str, float] | None = None,
                      metric: sps.spmatrix | None = None) -> StaticDeflection:
    """The static state of a reduced body from the FE static state ``x`` (module docstring).

    Parameters
    ----------
    body
        The :class:`~neweul_py.elastic.reduced_body.ReducedBody` of the working point.
    V, W
        Its full right and left bases (default: the body's stored ``V``, ``W``; ``W = V``
        when neither gives one).
    x
        (n,) the static displacement on the FE model's DOFs (pressures 0 for a u–p model:
        the static pressure is the reference of the acoustic perturbation).
    output_rows
        (n_out, n) the FE output rows (``C_FE``); ``outputs = C_FE x`` (``None``: zeros,
        unless given in ``outputs``).
    node_force
        Node id → (3,) static force on the body at that node [N] (e.g. the FE file's
        ``static_manubrium_force``); nodes not named get zero. A node that is not one of the
        body's kept nodes is a :class:`DataError`.
    outputs
        Output name → exact static value, replacing ``C_FE x`` for that output (e.g. the
        nonlinear swept volume).
    metric
        Ḡ (n × n, symmetric positive definite): ``q = (VᵀḠV)⁻¹VᵀḠx`` and the residual in
        that norm. ``None``: ``q = (WᵀV)⁻¹Wᵀx`` (the oblique projection of two-sided data;
        least squares for ``W = V``) and the Euclidean residual.
    """
    V = body.V if V is None else np.asarray(V)
    W = (body.W if body.W is not None else V) if W is None else np.asarray(W)
    if V is None:
        raise DataError("the static reduced coordinates need the body's full basis V "
                        "(reduce with the bases stored)", None, "V")
    x = np.asarray(x, dtype=np.float64).ravel()
    if x.size != V.shape[0]:
        raise DataError(f"the static state has {x.size} entries for a basis of "
                        f"{V.shape[0]} rows", None, "static.x")
    if metric is not None:
        GV = metric @ V
        q = np.linalg.solve(V.T @ GV, GV.T @ x)
        norm = lambda v: float(np.sqrt(max(v @ (metric @ v), 0.0)))  # noqa: E731
    else:
        q = np.linalg.lstsq(W.T @ V, W.T @ x, rcond=None)[0]
        norm = lambda v: float(np.linalg.norm(v))  # noqa: E731
    nx = norm(x)
    residual = norm(x - V @ q) / nx if nx > 0 else 0.0
    rows = node_rows(body.nodes, body.dof_node, body.dof_kind)
    xk = x[body.kept_dofs]
    node_u = np.where(rows >= 0, xk[np.maximum(rows, 0)], 0.0)
    ids = [int(n) for n in body.nodes[:, 0]]
    force = np.zeros((len(ids), 3))
    for nid, f in (node_force or {}).items():
        if int(nid) not in ids:
            raise DataError(f"static interface force at node {nid}, which is not one of the "
                            f"body's kept nodes {ids}", None, "static.node_force")
        force[ids.index(int(nid))] = np.asarray(f, dtype=np.float64).reshape(3)
    y = (np.zeros(len(body.output_names)) if output_rows is None
         else np.asarray(output_rows @ x, dtype=np.float64).ravel())
    for name, value in (outputs or {}).items():
        if name not in body.output_names:
            raise DataError(f"no output {name!r} (outputs: {', '.join(body.output_names)})",
                            None, "static.outputs")
        y[list(body.output_names).index(name)] = float(value)
    return StaticDeflection(q=q, node_u=node_u, node_force=force, outputs=y,
                            residual=np.array(residual))


def rigid_map(nodes: np.ndarray, node_ids: np.ndarray, origin: np.ndarray) -> np.ndarray:
    """(3m, 6) displacement of the points ``x_i`` of a rigid body at the nodes ``node_ids``
    for its translation and small rotation ``(t, θ)`` about ``origin``:
    ``u_i = t + θ × (x_i − origin)`` (rows ``ux, uy, uz`` of node 1, node 2, …)."""
    xyz = {int(r[0]): np.asarray(r[1:4], dtype=np.float64) for r in np.asarray(nodes)}
    T = np.zeros((3 * len(node_ids), 6))
    for j, nid in enumerate(node_ids):
        r = xyz[int(nid)] - np.asarray(origin, dtype=np.float64)
        T[3 * j:3 * j + 3, :3] = np.eye(3)
        T[3 * j:3 * j + 3, 3:] = -np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]],
                                            [-r[1], r[0], 0.0]])   # θ × r = −r̃ θ
    return T


#: Round-off floor of :func:`tied_static_equilibrium`: a Newton step below this fraction of
#: the translation that has stopped shrinking for this many steps ends the iteration.
FLOOR_RTOL = 1e-3
FLOOR_STALLS = 3


def tied_static_equilibrium(body: Any, node_ids: np.ndarray, k: float,
                            restoring: Any, origin: np.ndarray, *, tol: float = 1e-8,
                            max_iter: int = 50) -> dict[str, np.ndarray]:
    """Static equilibrium of a body carrying its static state, tied to a rigid part.

    The rigid part (translation and small rotation ``y = (t, θ)`` about ``origin``, from the
    reference configuration) is tied to the body's nodes ``node_ids`` by isotropic springs
    ``k`` each, and held by the restoring force ``F_c(y)`` (``restoring(y) → (F_c, K_c)``, a
    force/moment (6,) and its tangent (6, 6)). With the node displacements
    ``x_n = u_s + Φ_n q`` (static node displacements + the body's motion) and the spring
    forces on the body ``f = −k (x_n − T y)`` (:func:`rigid_map`), the equations are

        K q − Φ_Wᵀ (f − f_s) = 0        (the body about its static state, f_s its static
                                         interface forces; equilibrium at q = 0 when f = f_s)
        F_c(y) + Tᵀ f = 0               (the rigid part)

    solved by Newton's method (least-squares steps: the constant-pressure ``λ = 0`` modes of
    closed air volumes leave ``K`` singular, and the static state does not excite them) from
    the body's static state: ``q = 0`` and the rigid part where
    the static interface forces put it, ``T y₀ = u_s + f_s/k`` (least squares; exact when
    ``f_s`` came from such springs). The linear body about a state of large deflection may
    have other, spurious equilibria far from it (its tangent is not that of the
    nonlinear structure there), so the start matters (docs/equations-middle-ear.md §7).

    Converged when the step of the translation ``t`` is below ``tol`` times ``|t|``, or below
    :data:`FLOOR_RTOL` ``|t|`` and no smaller than half the smallest step so far for
    :data:`FLOOR_STALLS` steps in a row (Newton stalls at the round-off floor: the tangent of
    a u–p body is ill-conditioned, cond ≈ 1e14 for the middle ear at refine 1, and the floor
    is absolute — about 1e-10 m there — so at the small displacements next to Δp = 0 it is
    1e-4 of ``|t|``: −60 Pa with the chain's table characteristic).

    Returns
    -------
    dict
        ``q`` (r,), ``y`` (6,), ``node_u`` (m, 3) the node displacements ``x_n``, ``outputs``
        the static outputs ``y_s + C q``, ``iterations``.

    Raises
    ------
    DataError
        The body carries no static state or lacks one of the nodes (a translation a node
        lacks carries no spring).
    SolverError
        No convergence in ``max_iter`` steps.
    """
    st = body.static
    if st is None:
        raise DataError("the body carries no static state", None, "static")
    ids = [int(n) for n in body.nodes[:, 0]]
    missing = [int(n) for n in node_ids if int(n) not in ids]
    if missing:
        raise DataError(f"nodes {missing} are not kept nodes of the body {ids}", None, "nodes")
    sel = [ids.index(int(n)) for n in node_ids]
    rows = node_rows(body.nodes, body.dof_node, body.dof_kind)[sel].ravel()
    has = rows >= 0             # translations a node lacks carry no spring
    phi, phi_w = body.V_kept[rows[has]], body.W_kept[rows[has]]
    us, fs = st.node_u[sel].ravel()[has], st.node_force[sel].ravel()[has]
    T = rigid_map(body.nodes, node_ids, origin)[has]
    r = body.order
    q, y = np.zeros(r), np.linalg.lstsq(T, us + fs / k, rcond=None)[0]
    iterations, best, stalls = 0, np.inf, 0
    while iterations < max_iter:
        iterations += 1
        f = -k * (us + phi @ q - T @ y)
        Fc, Kc = restoring(y)
        res = np.r_[body.K @ q - phi_w.T @ (f - fs), Fc + T.T @ f]
        J = np.block([[body.K + k * phi_w.T @ phi, -k * phi_w.T @ T],
                      [-k * T.T @ phi, np.asarray(Kc) + k * T.T @ T]])
        dz = np.linalg.lstsq(J, -res, rcond=None)[0]   # K of closed air volumes: λ = 0
        q, y = q + dz[:r], y + dz[r:]
        scale = max(np.abs(y[:3]).max(), 1e-30)
        step = np.abs(dz[r:r + 3]).max()
        stalls = stalls + 1 if step >= 0.5 * best else 0
        best = min(best, step)
        if step <= tol * scale or (step <= FLOOR_RTOL * scale and stalls >= FLOOR_STALLS):
            break                   # converged, or the round-off floor reached
    else:
        raise SolverError(f"the tied static problem did not converge in {max_iter} Newton "
                          "steps", residual=float(np.abs(res).max()))
    node_u = np.zeros(3 * len(sel))
    node_u[has] = us + phi @ q
    node_u = node_u.reshape(-1, 3)
    return {"q": q, "y": y, "node_u": node_u, "outputs": st.outputs + body.C @ q,
            "iterations": iterations}


def node_positions(body: Any, q: np.ndarray | None = None) -> np.ndarray:
    """(n_nodes, 3) positions of the body's node frames in the nonlinear state,
    ``X + u_s + Φ q`` (reference + static deflection + the motion about it; ``q = None``: the
    static state itself). A body without a static state gives ``X + Φ q``.

    Examples
    --------
    >>> node_positions(parametric_body.at(-2000.0))[0]      # doctest: +SKIP
    array([ 3.4e-06, 0.0, 1.95e-03])
    """
    X = np.asarray(body.nodes[:, 1:4], dtype=np.float64)
    u = X.copy() if body.static is None else X + body.static.node_u
    if q is not None:
        rows = node_rows(body.nodes, body.dof_node, body.dof_kind)
        phi = np.where(rows[..., None] >= 0, body.V_kept[np.maximum(rows, 0)], 0.0)
        u = u + phi @ np.asarray(q, dtype=np.float64)
    return u
