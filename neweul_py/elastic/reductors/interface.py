"""Node sets and averaged interface node frames (RBE3-like) of elastic bodies.

An *averaged* node frame follows the weighted mean motion of a set of nodes (a hinge face, a
bone attachment) instead of one node. With weights ``w_i``, node translations ``u_i`` and
positions ``r_i = x_i − x_c`` relative to the weighted centroid ``x_c = Σ w_i x_i / Σ w_i``,
the weighted least-squares rigid fit ``min Σ w_i |u_i − (u + θ × r_i)|²`` gives

    u = Σ w_i u_i / Σ w_i,      θ = S⁻¹ Σ w_i r̃_i u_i,   S = Σ w_i r̃_iᵀ r̃_i

(``r̃`` the cross-product matrix, ``r̃ᵀ = −r̃``; Σ w_i r_i = 0 decouples ``u`` and ``θ``). This
is the kinematics of an RBE3 element (MSC Nastran *Quick Reference Guide*, RBE3; the
"interpolation constraint" of Abaqus' distributing coupling). It is linear in the nodal
displacements, ``[u; θ] = A x`` with a 6×n averaging operator ``A``
(:func:`averaging_operator`), so the frame's mode shapes are ``[Φ; Ψ] = A V``. The loads of
the frame are distributed by ``Aᵀ`` (virtual work), so their modal loads are
``(A W)ᵀ [f; l]``: the load side of two-sided bodies, consistent with ``W``.

:func:`averaged_node_frame` builds the :class:`~neweul_py.elastic.bodies.invariants.NodeFrame` of a
new (virtual) node id at ``x_c``; :func:`add_interface_frames` adds such frames to the
invariants of a reduced body, where they are used like any node frame.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

import numpy as np
import scipy.sparse as sps

from ...errors import DataError
from ..bodies.invariants import Invariants, NodeFrame, body_invariants, skew
from ..bodies.taylor import Taylor
from ..fe_model import FEModel

__all__ = [
    "add_interface_frames",
    "averaged_node_frame",
    "averaging_operator",
    "parse_node_set",
    "rigid_body_fields",
]

_TRANS = ("ux", "uy", "uz")
_ROT = ("rx", "ry", "rz")


def _rows_of(table: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """Row of each id in the (unique) id column ``table`` (ids must be present)."""
    order = np.argsort(table)
    return order[np.searchsorted(table[order], ids)]


def _dof_of(fe: FEModel, ids: np.ndarray, kind: str) -> np.ndarray:
    """DOF index of ``kind`` at each node of ``ids`` (−1: the node has no such DOF)."""
    sel = np.flatnonzero(fe.dof_kind == kind)
    if sel.size == 0:
        return np.full(ids.size, -1)
    nodes = fe.dof_node[sel]
    order = np.argsort(nodes)
    pos = np.clip(np.searchsorted(nodes[order], ids), 0, sel.size - 1)
    return np.where(nodes[order][pos] == ids, sel[order][pos], -1)


def parse_node_set(spec: str, fe: FEModel, named: Mapping[str, np.ndarray] | None = None,
                   item: str = "interface") -> np.ndarray:
    """Node ids of a node-set specification: comma-separated ids, ranges and set names.

    ``"1,2,5"``, ``"10:20"`` (the ids of the node table in ``[10, 20]``), ``"root"`` (a set
    named in the FE file, :func:`~neweul_py.elastic.io.fe_files.read_node_sets`), or a mix
    (``"root,40:45"``).

    Returns
    -------
    numpy.ndarray
        Sorted unique node ids.

    Raises
    ------
    DataError
        Naming ``fe.source`` and ``item``: an unknown set name, ids not in the node table, an
        empty set.
    """
    named = named or {}
    ids = fe.nodes[:, 0].astype(np.int64)
    out: list[np.ndarray] = []
    for token in (t.strip() for t in str(spec).split(",")):
        if not token:
            continue
        lo, sep, hi = token.partition(":")
        try:
            if sep:
                a, b = int(lo), int(hi)
                out.append(ids[(ids >= a) & (ids <= b)])
                continue
            out.append(np.array([int(token)]))
            continue
        except ValueError:
            pass
        if token not in named:
            known = ", ".join(sorted(named)) or "none"
            raise DataError(f"no node set {token!r} (sets in the file: {known})", fe.source,
                            item)
        out.append(np.asarray(named[token], dtype=np.int64))
    nodes = np.unique(np.concatenate(out)) if out else np.zeros(0, dtype=np.int64)
    if nodes.size == 0:
        raise DataError(f"node set {spec!r} is empty", fe.source, item)
    missing = np.setdiff1d(nodes, ids)
    if missing.size:
        raise DataError(f"node set {spec!r} names node ids not in the model: "
                        f"{missing[:5].tolist()}", fe.source, item)
    return nodes


def rigid_body_fields(fe: FEModel) -> np.ndarray:
    """(n, 6) rigid-body fields: translations ``e_a`` and small rotations ``e_b × x`` about
    the origin (rotational DOFs get ``e_b``); zero rows for pressure DOFs."""
    x = fe.nodes[_rows_of(fe.nodes[:, 0].astype(np.int64), fe.dof_node), 1:4]   # (n, 3)
    T = np.zeros((fe.n_dofs, 6))
    for a, (t, r) in enumerate(zip(_TRANS, _ROT, strict=True)):
        is_t, is_r = fe.dof_kind == t, fe.dof_kind == r
        T[is_t, a] = 1.0
        T[is_r, 3 + a] = 1.0
        # (e_b × x)_a = ε_abk x_k for b = 0, 1, 2
        T[is_t, 3:] = np.cross(np.eye(3), x[is_t][:, None, :])[:, :, a]
    return T


def averaging_operator(fe: FEModel, node_ids: Sequence[int],
                       weights: Sequence[float] | None = None,
                       item: str = "interface") -> tuple[sps.csr_matrix, np.ndarray]:
    """The 6×n RBE3 averaging operator ``A`` (``[u; θ] = A x``) and the centroid ``x_c``.

    Parameters
    ----------
    fe
        The FE model (only the translational DOFs of the set enter).
    node_ids
        The node set.
    weights
        Positive weight per node (default 1).
    item
        Named in errors.

    Notes
    -----
    Rotations that the node positions do not determine (the directions of the null space of
    ``S``: the axis of collinear nodes, all of them for one node) are taken as the weighted
    mean of the nodal rotation DOFs, ``θ_n = P_n Σ w_i θ_i / Σ w_i`` — exact for rigid motion
    (beam nodes, a single node).

    Raises
    ------
    DataError
        Unknown ids, non-positive weights, nodes without translational DOFs, or nodes whose
        positions do not determine a rotation and that have no rotation DOFs (collinear in
        3-D: ``S`` singular).
    """
    ids = np.asarray(node_ids, dtype=np.int64)
    table = fe.nodes[:, 0].astype(np.int64)
    if ids.size == 0:
        raise DataError("node set is empty", fe.source, item)
    missing = np.setdiff1d(ids, table)
    if missing.size:
        raise DataError(f"unknown node ids {missing[:5].tolist()}", fe.source, item)
    w = np.ones(ids.size) if weights is None else np.asarray(weights, dtype=np.float64)
    if w.shape != ids.shape or not np.all(np.isfinite(w) & (w > 0)):
        raise DataError("weights must be positive, one per node", fe.source, item)
    x = fe.nodes[_rows_of(table, ids), 1:4]
    wn = w / w.sum()
    xc = wn @ x
    r = x - xc
    S = np.einsum("i,iab->ab", wn, skew(r).transpose(0, 2, 1) @ skew(r))
    dofs = {k: _dof_of(fe, ids, k) for k in _TRANS + _ROT}
    if not any((dofs[k] >= 0).any() for k in _TRANS):
        raise DataError("the nodes of the set have no translational DOFs", fe.source, item)
    has_rot = any((dofs[k] >= 0).any() for k in _ROT)
    s, Q = np.linalg.eigh(S)
    rng = s > 1e-10 * max(s.max(), np.finfo(float).tiny)
    all_trans = all((dofs[k] >= 0).any() for k in _TRANS)
    if not rng.all() and not has_rot and all_trans:
        raise DataError(f"the {ids.size} nodes of the set are collinear (or one node): their "
                        "mean rotation is undetermined; use a node frame or more nodes",
                        fe.source, item)
    Sinv = (Q[:, rng] / s[rng]) @ Q[:, rng].T
    Pn = Q[:, ~rng] @ Q[:, ~rng].T          # rotations the positions do not determine
    R = np.einsum("ab,i,ibc->iac", Sinv, wn, skew(r))               # θ = Σ R_i u_i + …
    rows, cols, vals = [], [], []

    def add(row: int, kind: str, coef: np.ndarray) -> None:
        has = dofs[kind] >= 0
        rows.append(np.full(has.sum(), row))
        cols.append(dofs[kind][has])
        vals.append(coef[has])

    for c, kind in enumerate(_TRANS):
        add(c, kind, wn)
        for a in range(3):
            add(3 + a, kind, R[:, a, c])
    if has_rot and not rng.all():            # … + P_n Σ w_i θ_i (mean nodal rotation)
        for c, kind in enumerate(_ROT):
            for a in range(3):
                add(3 + a, kind, wn * Pn[a, c])
    A = sps.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                       shape=(6, fe.n_dofs))
    return A, xc


def averaged_node_frame(fe: FEModel, V: np.ndarray, W: np.ndarray | None, frame_id: int,
                        node_ids: Sequence[int], weights: Sequence[float] | None = None,
                        orientation: np.ndarray | None = None) -> NodeFrame:
    """The :class:`~neweul_py.elastic.bodies.invariants.NodeFrame` of the weighted mean motion of a
    node set (module docstring), for a new node id ``frame_id`` at the weighted centroid.

    ``Φ = A_u V``, ``Ψ = A_θ V`` (right basis), load side ``A W`` for two-sided data
    (``W`` given), ``origin(q) = x_c + Φ q``, ``AP(q) = AP⁰ + Σ_k ψ̃_k AP⁰ q_k`` as for node
    frames of single nodes (:func:`~neweul_py.elastic.reductors.invariants.compute_invariants`).
    """
    A, xc = averaging_operator(fe, node_ids, weights, f"interface_frames.{frame_id}")
    V = np.asarray(V, dtype=np.float64)
    if V.ndim != 2 or V.shape[0] != fe.n_dofs:
        raise DataError(f"V has shape {V.shape}, expected ({fe.n_dofs}, nq)", fe.source, "V")
    nq = V.shape[1]
    av = A @ V
    phi, psi = av[:3], av[3:]
    AP0 = np.eye(3) if orientation is None else np.asarray(orientation, dtype=np.float64)
    AP1 = np.einsum("kab,bc->akc", skew(psi.T), AP0)
    phw = psw = None
    if W is not None:
        aw = A @ np.asarray(W, dtype=np.float64)
        phw, psw = aw[:3], aw[3:]
    return NodeFrame(int(frame_id), Taylor.from_arrays(xc[:, None], phi[:, :, None]),
                     Taylor.from_arrays(phi, nq=nq), Taylor.from_arrays(psi, nq=nq),
                     Taylor.from_arrays(AP0, AP1), phw, psw)


def add_interface_frames(body, fe: FEModel, frames: Mapping[int, Sequence[int]],
                         weights: Mapping[int, Sequence[float]] | None = None):
    """The reduced body with averaged node frames added to its invariants.

    Parameters
    ----------
    body
        A :class:`~neweul_py.elastic.bodies.reduced.ReducedBody` with invariants and full bases.
    fe
        The FE model it was reduced from.
    frames
        New node id → node set.
    weights
        Optional new node id → weights.

    Raises
    ------
    DataError
        The body has no invariants or bases, or a new id is already a node (FE node or
        node frame).
    """
    inv: Invariants | None = body_invariants(body)
    if inv is None or body.V is None:
        raise DataError("averaged interface frames need the invariants and the full bases "
                        "(reduce with --invariants / store_bases=True)", fe.source,
                        "interface_frames")
    taken = set(fe.nodes[:, 0].astype(np.int64).tolist()) | {n.id for n in inv.nodes}
    new = []
    for fid, nodes in frames.items():
        if int(fid) in taken:
            raise DataError(f"id {fid} is already a node of the model; pick a new id",
                            fe.source, f"interface_frames.{fid}")
        taken.add(int(fid))
        new.append(averaged_node_frame(fe, body.V, body.W if body.two_sided else None,
                                       int(fid), nodes, (weights or {}).get(fid)))
    inv = dataclasses.replace(inv, nodes=inv.nodes + tuple(new))
    return body.with_(invariants=inv.to_flat())
