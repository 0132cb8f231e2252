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
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...errors import DataError

__all__ = [
    "STATIC_KEYS",
    "STATIC_PREFIX",
    "StaticDeflection",
    "node_positions",
    "node_rows",
    "residual_bound",
]


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
        :meth:`~neweul_py.elastic.bodies.parametric.ParametricBody.weights`), the residual
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
