"""The fields every elastic body holds, and their one check (``docs/reduced-body-format.md``).

A :class:`~neweul_py.elastic.bodies.reduced.ReducedBody` (one working point) and a
:class:`~neweul_py.elastic.bodies.parametric.ParametricBody` (``k`` samples in common
coordinates) hold the same quantities — the reduced matrices, the names of the inputs and
outputs, the kept nodes and DOFs, the bases, the invariants, the static state, the loss
data — a parametric body with a leading sample axis on what varies over the samples.
:class:`BodyFields` declares them once and :func:`check_body_fields` checks and normalizes
them once, for either: ``k = None`` for a single body, the number of samples otherwise.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Self

import numpy as np

from ...errors import DataError
from ..fe_model import DOF_KINDS, loss_reference
from .static import StaticDeflection

__all__ = ["CARRIED_INVARIANTS", "BodyFields", "check_body_fields", "checked_dof_kinds",
           "real_array"]


#: Floating-point invariants that are one value for all samples (checked when the body is
#: built, their slopes zero): :meth:`ParametricBody.at
#: <neweul_py.elastic.bodies.parametric.ParametricBody.at>` carries them, it does not mix
#: them (weights that sum to one only to round-off would turn 1000 Hz into
#: 1000.0000000000001).
CARRIED_INVARIANTS = ("loss.f_ref",)


@dataclass(frozen=True, eq=False, kw_only=True)
class BodyFields:
    """The fields a reduced and a parametric body share (keyword-only).

    ``r`` = reduced order, ``nk`` = kept DOFs, ``n`` = FE DOFs; the arrays marked *stacked*
    carry a leading axis of the ``k`` samples in a parametric body.

    Parameters
    ----------
    M, D, K
        (r, r) reduced matrices ``Wᵀ M_FE V`` … (``docs/equations.md`` §2–3; ``D`` zero for
        an undamped model; not symmetric in general); stacked.
    B, C
        (r, n_in) reduced input and (n_out, r) reduced output matrices; stacked.
    input_names, output_names
        Names of the columns of ``B`` and the rows of ``C``.
    nodes
        (nk_nodes, 4) ``id, x, y, z`` of the kept nodes (interface and output nodes).
    kept_dofs
        (nk,) indices, in the full FE model, of all DOFs of the kept nodes.
    dof_node, dof_kind
        (nk,) node id and kind (``ux … rz, p``) of each kept DOF.
    V_kept, W_kept
        (nk, r) rows of the right basis (displacement shapes: Φ, Ψ of the node frames for
        ``u``/``r`` kinds) and of the left basis (modal loads ``Wᵀ f`` of nodal forces) at
        the kept DOFs; stacked.
    V, W
        Optional (n, r) full bases (needed for parametric interpolation, §4); stacked.
    full_dof_kind
        Optional (n,) kind (``ux … rz, p``) of every row of the full bases, i.e. of every FE
        DOF; the reductors set it whenever they store ``V``/``W``.
    invariants
        Optional floating-frame invariants (§2) as a flat name → array dict (``"Ct"``,
        ``"Cr"``, ``"Me"``, ``"Oe1"``, … :meth:`Invariants.to_flat
        <neweul_py.elastic.bodies.invariants.Invariants.to_flat>` names), any dtype except
        object; stacked.
    static
        Optional static state the body is linearized about
        (:class:`~neweul_py.elastic.bodies.static.StaticDeflection`; stacked).
    G
        Optional (r, r) reduced hysteretic damping ``Wᵀ G_FE V`` of the frequency-domain
        stiffness ``K + iG`` (loss factors, ``docs/equations.md`` §1.1); ``D`` holds its
        time-domain equivalent ``G/ω_ref`` when the FE model's ``D`` did; stacked.
    loss_reference_frequency
        The reference frequency ``f_ref`` [Hz] of ``G`` (required with it).
    format_version
        The version of the body's format (each body type has its own).
    """

    M: np.ndarray
    D: np.ndarray
    K: np.ndarray
    B: np.ndarray
    C: np.ndarray
    input_names: tuple[str, ...]
    output_names: tuple[str, ...]
    nodes: np.ndarray
    kept_dofs: np.ndarray
    dof_node: np.ndarray
    dof_kind: np.ndarray
    V_kept: np.ndarray
    W_kept: np.ndarray
    V: np.ndarray | None = None
    W: np.ndarray | None = None
    full_dof_kind: np.ndarray | None = None
    invariants: Mapping[str, np.ndarray] | None = None
    static: StaticDeflection | None = None
    G: np.ndarray | None = None
    loss_reference_frequency: float | None = None
    format_version: int = 1

    def __getitem__(self, key: str) -> Any:
        return getattr(self, key)

    def with_(self, **changes: Any) -> Self:
        """A validated copy with some fields changed."""
        return dataclasses.replace(self, **changes)


def real_array(a: Any, key: str, shape: tuple[int, ...] | None = None,
               ndim: int | None = None) -> np.ndarray:
    """``a`` as a finite real float64 array of the given shape (or number of dimensions);
    a :class:`DataError` naming ``key`` otherwise."""
    if np.iscomplexobj(a):      # float64 by the format
        raise DataError("has complex entries; the format holds real float64 arrays", None,
                        key)
    arr = np.asarray(a, dtype=np.float64)
    if ndim is not None and arr.ndim != ndim:
        raise DataError(f"must have {ndim} dimensions, got shape {arr.shape}", None, key)
    if shape is not None and arr.shape != shape:
        raise DataError(f"must be {shape}, got {arr.shape}", None, key)
    if not np.all(np.isfinite(arr)):
        raise DataError("has NaN/Inf entries", None, key)
    return arr


def checked_dof_kinds(kinds: Any, rows: Mapping[str, int]) -> np.ndarray:
    """``full_dof_kind`` as a (n,) ``U2`` array of known DOF kinds, one per row of every FE
    array in ``rows`` (name → number of rows)."""
    kinds = np.asarray(kinds)
    if kinds.ndim != 1 or kinds.dtype.kind not in "US":
        raise DataError(f"must be a 1-D array of DOF kinds, got {kinds.dtype} {kinds.shape}",
                        None, "full_dof_kind")
    kinds = kinds.astype("U2")
    unknown = sorted(set(np.unique(kinds).tolist()) - set(DOF_KINDS))
    if unknown:
        raise DataError(f"unknown DOF kinds {unknown} (allowed: {', '.join(DOF_KINDS)})",
                        None, "full_dof_kind")
    for name, n in rows.items():
        if n != kinds.size:
            raise DataError(f"{kinds.size} DOF kinds for the {n} rows of {name}", None,
                            "full_dof_kind")
    return kinds


def check_body_fields(body: BodyFields, k: int | None) -> int:
    """Check and normalize the :class:`BodyFields` of ``body`` in place (a frozen body under
    construction): ``k = None`` for a single body, the number of samples for stacked arrays.
    ``full_dof_kind`` is left to the body type (:func:`checked_dof_kinds`), which knows the
    rows it describes. Returns the reduced order ``r``; a :class:`DataError` naming the field
    on the first problem."""
    set_ = object.__setattr__
    lead = () if k is None else (k,)
    m = np.asarray(body.M)
    r = m.shape[-1] if m.ndim == len(lead) + 2 else -1
    for key in ("M", "D", "K"):
        set_(body, key, real_array(body[key], key, (*lead, r, r)))
    set_(body, "input_names", tuple(str(s) for s in body.input_names))
    set_(body, "output_names", tuple(str(s) for s in body.output_names))
    n_in, n_out = len(body.input_names), len(body.output_names)
    if k is None:       # a single body's B and C may come flat
        set_(body, "B", np.asarray(body.B).reshape(r, -1))
        set_(body, "C", np.asarray(body.C).reshape(-1, r))
    for key, shape in (("B", (*lead, r, n_in)), ("C", (*lead, n_out, r))):
        a = real_array(body[key], key, ndim=len(shape))
        if a.shape != shape:
            raise DataError(f"must be {shape} ({n_in} inputs, {n_out} outputs by name), got "
                            f"{a.shape}", None, key)
        set_(body, key, a)
    _check_kept(body)
    nk = body.kept_dofs.size
    for key in ("V_kept", "W_kept"):
        set_(body, key, real_array(body[key], key, (*lead, nk, r)))
    for key in ("V", "W"):
        if body[key] is not None:
            a = real_array(body[key], key, ndim=len(lead) + 2)
            if a.shape[-1] != r or a.shape[:-2] != lead:
                raise DataError(f"must be {(*lead, 'n', r)}, got {a.shape}", None, key)
            set_(body, key, a)
    f = loss_reference(body.G, body.loss_reference_frequency, body.D, None)
    if body.G is not None:
        set_(body, "G", real_array(body.G, "G", (*lead, r, r)))
        set_(body, "loss_reference_frequency", f)
    if body.invariants is not None:
        set_(body, "invariants", _checked_invariants(body.invariants, k))
    if body.static is not None:
        if not isinstance(body.static, StaticDeflection):
            raise DataError(f"must be a StaticDeflection, got {type(body.static).__name__}",
                            None, "static")
        body.static.check(r, body.nodes.shape[0], n_out, k)
    return r


def _check_kept(body: BodyFields) -> None:
    """The kept nodes and DOFs: ``nodes`` (·, 4) finite with whole non-negative ids,
    ``kept_dofs`` and ``dof_node`` whole non-negative numbers, one ``dof_kind`` each."""
    set_ = object.__setattr__
    nodes = real_array(body.nodes, "nodes")
    if nodes.ndim != 2 or nodes.shape[1] != 4:
        raise DataError(f"must be (nodes, 4): id, x, y, z per row; got shape {nodes.shape}",
                        None, "nodes")
    ids = nodes[:, 0]
    if np.any(ids < 0) or np.any(ids != np.round(ids)):
        raise DataError("node ids (first column) must be non-negative whole numbers", None,
                        "nodes")
    set_(body, "nodes", nodes)
    for key in ("kept_dofs", "dof_node"):
        raw = np.asarray(body[key])
        if raw.size and (raw.dtype.kind not in "iubf" or not np.all(np.isfinite(raw))
                         or np.any(raw < 0) or np.any(raw != np.round(raw))):
            raise DataError("must hold non-negative whole numbers", None, key)
        set_(body, key, raw.astype(np.int64).ravel())
    set_(body, "dof_kind", np.asarray(body.dof_kind).astype("U2").ravel())
    nk = body.kept_dofs.size
    if body.dof_node.size != nk or body.dof_kind.size != nk:
        raise DataError("dof_node/dof_kind must match kept_dofs", None, "kept_dofs")


def _checked_invariants(inv: Mapping[str, Any], k: int | None) -> dict[str, np.ndarray]:
    """The flat invariants: no object arrays; stacked (``k`` samples) finite where floating
    point, and one value for all samples where not floating point or carried
    (:data:`~neweul_py.elastic.bodies.parametric.CARRIED_INVARIANTS`)."""
    out = {}
    for name, v in inv.items():
        a = np.asarray(v)
        item = f"invariants.{name}"
        if a.dtype == object:
            raise DataError("object arrays cannot be stored", None, item)
        if k is not None:
            if a.ndim < 1 or a.shape[0] != k:
                raise DataError(f"must be stacked over the {k} samples, got shape {a.shape}",
                                None, item)
            if a.dtype.kind == "f" and not np.all(np.isfinite(a)):
                raise DataError("has NaN/Inf entries", None, item)
            if a.dtype.kind != "f" or name in CARRIED_INVARIANTS:
                _check_constant(a, item)
        out[str(name)] = a
    return out



def _check_constant(a: np.ndarray, item: str) -> None:
    """A stacked invariant that must be one value for all samples (not interpolated): a
    :class:`DataError` naming the first sample that differs from sample 1."""
    for i in range(1, a.shape[0]):
        if not np.array_equal(a[0], a[i]):
            got = f" ({a[i].tolist()!r} vs {a[0].tolist()!r})" if a[0].size == 1 else ""
            raise DataError(f"sample {i + 1} differs from sample 1{got}: one value for all "
                            "samples (it is carried, not interpolated)", None, item)
