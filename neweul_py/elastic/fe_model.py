"""The FE-model container: sparse ``M``, ``K``, ``D`` with nodes, DOF map, inputs and outputs.

Structure kinds (``kind``):

* ``"structural"`` – displacement/rotation DOFs only;
* ``"acoustic"`` – pressure DOFs only;
* ``"up-coupled"`` – pressure-based u–p form of Eq. (2) of the seed paper
  (``docs/equations.md`` §3),
  ``[Ms 0; ρCᵀ Mf] ẍ + D ẋ + [Ks −C; 0 Kf] x = f`` with fluid density ``density`` (ρ),
  ``x = [u; p]`` (the u and p DOFs may be interleaved; the DOF map tells them apart).

The container validates on construction (shapes, finiteness, DOF map, declared symmetry,
the block structure of Eq. (2)) and never changes afterwards; :meth:`FEModel.with_` makes a
changed copy. Readers and writers live in :mod:`neweul_py.elastic.io.fe_files`.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import numbers
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
import scipy.sparse as sps

from ..errors import DataError

__all__ = ["DOF_KINDS", "FE_KINDS", "SYMMETRY_RTOL", "FEModel", "up_block_deviations"]

#: DOF kinds of the DOF map.
DOF_KINDS = ("ux", "uy", "uz", "rx", "ry", "rz", "p")
#: Structure kinds of an FE model.
FE_KINDS = ("structural", "acoustic", "up-coupled")
#: Relative tolerance of symmetry and block-structure checks (max-abs norm).
SYMMETRY_RTOL = 1e-10


def _max_abs(a: sps.spmatrix) -> float:
    return float(abs(a).max()) if a.nnz else 0.0


def _is_real_number(x: object) -> bool:
    """A real scalar (Python or NumPy int/float), not a bool, string or sequence."""
    return (isinstance(x, numbers.Real) and not isinstance(x, bool | np.bool_)
            and np.ndim(x) == 0)


def loss_reference(G: object, f: object, D: object, source: str | None) -> float | None:
    """The reference frequency of a hysteretic matrix ``G`` (docs/equations.md §1.1), checked:
    ``G`` and ``f`` come together, ``f`` is a positive finite number [Hz], and the time-domain
    damping ``D`` (which contains ``G/ω_ref``, subtracted by the loss form) is there. ``None``
    without ``G``. FE models, reduced and parametric bodies share this rule."""
    if G is None:
        if f is not None:
            raise DataError("a loss reference frequency without a hysteretic matrix G",
                            source, "loss_reference_frequency")
        return None
    if f is None or not _is_real_number(f) or not np.isfinite(f) or f <= 0:
        raise DataError(f"the hysteretic matrix G needs a positive reference frequency in "
                        f"Hz, got {f!r}", source, "loss_reference_frequency")
    if D is None:
        raise DataError("a hysteretic matrix G needs the time-domain damping D, which "
                        "contains its equivalent G/ω_ref", source, "D")
    return float(f)


def asymmetry(a: sps.spmatrix) -> float:
    """``max|A − Aᵀ| / max|A|`` (0 for the zero matrix)."""
    scale = _max_abs(a)
    return _max_abs(a - a.T) / scale if scale > 0 else 0.0


def up_block_deviations(M: sps.spmatrix, K: sps.spmatrix, D: sps.spmatrix | None,
                        is_p: np.ndarray, rho: float) -> dict[str, float]:
    """Relative deviations of ``M``, ``K`` (and ``D``) from the block structure of the u–p
    model, Eq. (2) of docs/equations.md §3: ``M_up = 0``, ``K_pu = 0``,
    ``M_pu = ρCᵀ = −ρK_upᵀ``, no loss coupling, symmetric diagonal blocks.

    Returns
    -------
    dict
        ``"M_up"`` ``max|M_up|/max|M|``, ``"K_pu"`` ``max|K_pu|/max|K|``, ``"D_up"``
        ``max(|D_up|, |D_pu|)/max|D|`` (0 without ``D``), ``"coupling"``
        ``max|M_pu + ρK_upᵀ| / max(max|M_pu|, ρ max|K_up|)``, and for each of ``M``, ``K``,
        ``D`` and block ``uu``, ``pp`` (e.g. ``"K_pp"``) its :func:`asymmetry`.
    """
    u, p = np.flatnonzero(~is_p), np.flatnonzero(is_p)
    mats = {"M": sps.csr_matrix(M), "K": sps.csr_matrix(K)}
    if D is not None:
        mats["D"] = sps.csr_matrix(D)

    def rel(a: sps.spmatrix, whole: sps.spmatrix) -> float:
        scale = _max_abs(whole)
        return _max_abs(a) / scale if scale > 0 else 0.0

    M_, K_ = mats["M"], mats["K"]
    out = {"M_up": rel(M_[u][:, p], M_), "K_pu": rel(K_[p][:, u], K_), "D_up": 0.0}
    if "D" in mats:
        d = mats["D"]
        out["D_up"] = max(rel(d[u][:, p], d), rel(d[p][:, u], d))
    m_pu, k_up = M_[p][:, u], K_[u][:, p]
    ref = max(_max_abs(m_pu), rho * _max_abs(k_up))
    out["coupling"] = _max_abs(m_pu + rho * k_up.T) / ref if ref > 0 else 0.0
    for key, a in mats.items():
        for name, idx in (("uu", u), ("pp", p)):
            out[f"{key}_{name}"] = asymmetry(a[idx][:, idx])
    return out


@dataclass(frozen=True, eq=False)
class FEModel:
    """A linear(ized) second-order FE model ``M ẍ + D ẋ + K x = B u``, ``y = C x``.

    Parameters
    ----------
    M, K
        Sparse n×n mass and stiffness matrices (stored as CSR); may be unsymmetric (u–p
        coupling). Dense arrays are accepted and converted.
    D
        Sparse n×n damping matrix or ``None`` (no damping).
    nodes
        (nn, 4) array of ``id, x, y, z``; ids are integers, unique.
    dof_node
        (n,) node id of each DOF (each must be in ``nodes``).
    dof_kind
        (n,) str array, each one of :data:`DOF_KINDS`; a (node, kind) pair occurs once.
    inputs, outputs
        Name → ((dof_index, weight), …): a load vector ``b`` with ``b[dof] += weight``
        (inputs), an output row ``c`` with ``c[dof] += weight`` (outputs).
    kind
        One of :data:`FE_KINDS`.
    density
        The fluid density ρ of Eq. (2) (``up-coupled`` only, required there); a real
        number (not a string, list or bool).
    name
        A name for messages.
    symmetric
        Declared symmetries, e.g. ``{"M": True, "K": True}`` (values must be bools: the
        string ``"no"`` is an error, not ``True``); a declared-symmetric matrix
        that is not (relative max-abs asymmetry > :data:`SYMMETRY_RTOL`) is an error.
    source
        The file the model was read from (named in error messages), or ``None``.
    G
        Optional sparse n×n hysteretic damping of the frequency-domain stiffness ``K + iG``
        (loss factors, ``docs/equations.md`` §1.1); ``D`` then holds the time-domain
        equivalent ``G/ω_ref`` (plus any viscous damping of its own).
    loss_reference_frequency
        The reference frequency ``f_ref`` [Hz] of ``G`` (``ω_ref = 2π f_ref``; required with
        ``G``, a positive finite number).

    Raises
    ------
    DataError
        Naming ``source`` and the matrix or table at fault
        (``docs/fe-builders-and-interfaces.md``, "Checks of an FE model").

    Examples
    --------
    >>> import numpy as np, scipy.sparse as sps
    >>> fe = FEModel(M=sps.eye(2), K=sps.diags([1.0, 4.0]), D=None,
    ...              nodes=np.array([[1, 0, 0, 0], [2, 1, 0, 0]]),
    ...              dof_node=np.array([1, 2]), dof_kind=np.array(["ux", "ux"]),
    ...              inputs={"f": ((1, 1.0),)}, outputs={"x": ((1, 1.0),)})
    >>> fe.B(["f"]).ravel().tolist(), fe.n_dofs
    ([0.0, 1.0], 2)
    """

    M: sps.csr_matrix
    K: sps.csr_matrix
    D: sps.csr_matrix | None
    nodes: np.ndarray
    dof_node: np.ndarray
    dof_kind: np.ndarray
    inputs: Mapping[str, tuple[tuple[int, float], ...]] = field(default_factory=dict)
    outputs: Mapping[str, tuple[tuple[int, float], ...]] = field(default_factory=dict)
    kind: str = "structural"
    density: float | None = None
    name: str = "fe-model"
    symmetric: Mapping[str, bool] = field(default_factory=dict)
    source: str | None = None
    G: sps.csr_matrix | None = None
    loss_reference_frequency: float | None = None

    # ------------------------------------------------------------------ validation
    def __post_init__(self) -> None:
        set_ = object.__setattr__
        src = self.source
        for key, a in _checked_matrices(self, src).items():
            set_(self, key, a)
        n = self.M.shape[0]
        set_(self, "nodes", _checked_nodes(self.nodes, src))
        dof_node, dof_kind = _checked_dof_map(self.dof_node, self.dof_kind, self.nodes, n, src)
        set_(self, "dof_node", dof_node)
        set_(self, "dof_kind", dof_kind)
        for label in ("inputs", "outputs"):
            set_(self, label, _checked_dof_table(getattr(self, label), label, n, src))
        self._check_kind()
        set_(self, "symmetric", _checked_symmetry(self, src))
        self._check_loss()

    def _check_kind(self) -> None:
        """The model kind against its DOF kinds; an ``up-coupled`` model's density and block
        structure (:meth:`_check_up_blocks`)."""
        src = self.source
        if self.kind not in FE_KINDS:
            raise DataError(f"unknown kind {self.kind!r} (allowed: {', '.join(FE_KINDS)})",
                            src, "kind")
        is_p = self.dof_kind == "p"
        if self.kind == "structural" and is_p.any():
            raise DataError("a structural model has pressure DOFs", src, "dofs")
        if self.kind == "acoustic" and not is_p.all():
            raise DataError("an acoustic model has only pressure DOFs", src, "dofs")
        if self.density is not None and not _is_real_number(self.density):
            raise DataError(f"must be a number, got {self.density!r} "
                            f"({type(self.density).__name__})", src, "density")
        if self.kind == "up-coupled":
            if self.density is None or not np.isfinite(self.density) or self.density <= 0:
                raise DataError(f"an up-coupled model needs a positive fluid density, got "
                                f"{self.density!r}", src, "density")
            if is_p.all() or not is_p.any():
                raise DataError("an up-coupled model needs both displacement and pressure "
                                "DOFs", src, "dofs")
            object.__setattr__(self, "density", float(self.density))
            self._check_up_blocks(is_p)

    def _check_loss(self) -> None:
        """``G`` and ``loss_reference_frequency``: :func:`loss_reference`."""
        object.__setattr__(self, "loss_reference_frequency", loss_reference(
            self.G, self.loss_reference_frequency, self.D, self.source))

    def _check_up_blocks(self, is_p: np.ndarray) -> None:
        """Block structure of Eq. (2): ``M_up = 0``, ``K_pu = 0``, ``M_pu = −ρ K_upᵀ``,
        symmetric blocks (:func:`up_block_deviations`)."""
        src, rho = self.source, self.density
        dev = up_block_deviations(self.M, self.K, None, is_p, rho)
        if dev["M_up"] > SYMMETRY_RTOL:
            raise DataError("up-coupled: the u–p block of M (rows u, columns p) must be zero "
                            "(Eq. (2))", src, "M")
        if dev["K_pu"] > SYMMETRY_RTOL:
            raise DataError("up-coupled: the p–u block of K (rows p, columns u) must be zero "
                            "(Eq. (2))", src, "K")
        if dev["coupling"] > 1e-8:
            raise DataError("up-coupled: M_pu must equal ρ·Cᵀ = −ρ·K_upᵀ (Eq. (2)) with the "
                            f"declared density ρ = {rho}", src, "M")
        for key, block, part in (("M", "uu", "structure"), ("K", "uu", "structure"),
                                 ("M", "pp", "fluid"), ("K", "pp", "fluid")):
            value = dev[f"{key}_{block}"]
            if value > SYMMETRY_RTOL:
                raise DataError(f"up-coupled: the {part} block must be symmetric (Eq. (2)), "
                                f"asymmetry {value:.3g}", src, key)

    # ------------------------------------------------------------------ derived data
    @property
    def n_dofs(self) -> int:
        """Number of DOFs ``n``."""
        return self.M.shape[0]

    @cached_property
    def pressure_dofs(self) -> np.ndarray:
        """Boolean mask of the pressure DOFs."""
        return self.dof_kind == "p"

    @cached_property
    def fingerprint(self) -> str:
        """SHA-256 (hex) of what a reduction depends on: ``M``, ``K``, ``D``, nodes, DOF map,
        inputs, outputs, kind and density — not the name, file or symmetry flags.

        Matrices enter in canonical CSR form (explicit zeros dropped, indices sorted), so the
        same model read from a manifest or an ``.npz`` has the same fingerprint. A reduced
        body records it in ``source["fingerprint"]``;
        :func:`~neweul_py.elastic.quality.measures.check_source` compares.
        """
        h = hashlib.sha256(b"neweul-fe-fingerprint-1")

        def add(tag: str, a: np.ndarray) -> None:
            a = np.ascontiguousarray(a)
            h.update(f"{tag}:{a.dtype.str}:{a.shape}".encode())
            h.update(a.tobytes())

        keys = ("M", "K", "D") + (("G",) if self.G is not None else ())
        for key in keys:    # G only when present: fingerprints of lossless models unchanged
            a = getattr(self, key)
            if a is None:
                h.update(f"{key}:none".encode())
                continue
            a = a.copy()
            a.eliminate_zeros()
            a.sort_indices()
            add(f"{key}.indptr", a.indptr.astype(np.int64))
            add(f"{key}.indices", a.indices.astype(np.int64))
            add(f"{key}.data", a.data)
        if self.G is not None:
            h.update(f"f_ref:{self.loss_reference_frequency!r}".encode())
        add("nodes", self.nodes)
        add("dof_node", self.dof_node)
        add("dof_kind", self.dof_kind.astype("U2"))
        io = {"inputs": {k: [list(p) for p in v] for k, v in self.inputs.items()},
              "outputs": {k: [list(p) for p in v] for k, v in self.outputs.items()},
              "kind": self.kind, "density": self.density}
        h.update(json.dumps(io, sort_keys=True).encode())
        return h.hexdigest()

    @property
    def input_names(self) -> tuple[str, ...]:
        return tuple(self.inputs)

    @property
    def output_names(self) -> tuple[str, ...]:
        return tuple(self.outputs)

    def _table(self, label: str, names: Sequence[str] | str | None) -> np.ndarray:
        table = getattr(self, label)
        if names is None:
            names = list(table)
        elif isinstance(names, str):
            names = [names]
        out = np.zeros((self.n_dofs, len(names)))
        for j, name in enumerate(names):
            if name not in table:
                raise DataError(f"unknown {label[:-1]} {name!r} (known: "
                                f"{', '.join(table) or 'none'})", self.source, label)
            pairs = np.asarray(table[name]).reshape(-1, 2)
            np.add.at(out[:, j], pairs[:, 0].astype(np.int64), pairs[:, 1])
        return out

    def B(self, names: Sequence[str] | str | None = None) -> np.ndarray:
        """Dense n×k input matrix of the named inputs (all, in order, by default)."""
        return self._table("inputs", names)

    def C(self, names: Sequence[str] | str | None = None) -> np.ndarray:
        """Dense k×n output matrix of the named outputs (all, in order, by default)."""
        return self._table("outputs", names).T

    def dofs_of_nodes(self, node_ids: Sequence[int] | np.ndarray) -> np.ndarray:
        """Indices of all DOFs of the given nodes, in DOF order."""
        ids = np.asarray(node_ids, dtype=np.int64)
        missing = np.setdiff1d(ids, self.nodes[:, 0].astype(np.int64))
        if missing.size:
            raise DataError(f"unknown node ids {missing[:5].tolist()}", self.source, "nodes")
        return np.flatnonzero(np.isin(self.dof_node, ids))

    def io_nodes(self) -> np.ndarray:
        """Sorted ids of the nodes carrying an input or output DOF."""
        idx = [i for table in (self.inputs, self.outputs) for pairs in table.values()
               for i, _ in pairs]
        return np.unique(self.dof_node[np.asarray(idx, dtype=np.int64)])

    def with_(self, **changes) -> FEModel:
        """A validated copy with some fields changed (pyMOR's ``with_``)."""
        return dataclasses.replace(self, **changes)


_KIND_SORTER = np.argsort(np.array(DOF_KINDS))


def _checked_matrices(fe: FEModel, src: str | None) -> dict[str, sps.csr_matrix]:
    """``M``, ``K`` and the optional ``D``, ``G`` as real, finite, square float64 CSR
    matrices of one size."""
    mats = {}
    for key in ("M", "K", "D", "G"):
        a = getattr(fe, key)
        if a is None:
            if key not in ("D", "G"):
                raise DataError("matrix is missing", src, key)
            continue
        try:
            a = sps.csr_matrix(a)
        except (TypeError, ValueError) as exc:
            raise DataError(f"not a matrix ({exc})", src, key) from None
        if a.dtype.kind not in "fiu":
            raise DataError(f"matrix must be real, got dtype {a.dtype}", src, key)
        a = a.astype(np.float64)
        a.sum_duplicates()
        if a.ndim != 2 or a.shape[0] != a.shape[1]:
            raise DataError(f"matrix must be square, got shape {a.shape}", src, key)
        if not np.all(np.isfinite(a.data)):
            bad = int(np.count_nonzero(~np.isfinite(a.data)))
            raise DataError(f"matrix has {bad} NaN/Inf entries", src, key)
        mats[key] = a
    n = mats["M"].shape[0]
    for key, a in mats.items():
        if a.shape != (n, n):
            raise DataError(f"shape {a.shape} does not match M's {(n, n)}", src, key)
    return mats


def _checked_nodes(nodes: Any, src: str | None) -> np.ndarray:
    """The node table: (nn, 4) ``id, x, y, z``, finite, unique integer ids."""
    nodes = np.asarray(nodes, dtype=np.float64)
    if nodes.ndim != 2 or nodes.shape[1] != 4:
        raise DataError(f"node table must be (nn, 4) id,x,y,z, got {nodes.shape}", src,
                        "nodes")
    if not np.all(np.isfinite(nodes)):
        raise DataError("node table has NaN/Inf entries", src, "nodes")
    if np.any(nodes[:, 0] != np.round(nodes[:, 0])):
        raise DataError("node ids must be integers", src, "nodes")
    if np.unique(nodes[:, 0]).size != nodes.shape[0]:
        raise DataError("node ids are not unique", src, "nodes")
    return nodes


def _checked_dof_map(dof_node: Any, dof_kind: Any, nodes: np.ndarray, n: int,
                     src: str | None) -> tuple[np.ndarray, np.ndarray]:
    """The DOF map: a node of the table and a kind of :data:`DOF_KINDS` for each of the
    ``n`` DOFs, each (node, kind) pair once."""
    dof_node = np.asarray(dof_node)
    if dof_node.shape != (n,):
        raise DataError(f"DOF map has {dof_node.size} entries but the matrices have {n} "
                        "rows", src, "dofs")
    if dof_node.dtype.kind == "f" and np.any(dof_node != np.round(dof_node)):
        raise DataError("DOF node ids must be integers", src, "dofs")
    dof_node = dof_node.astype(np.int64)
    missing = np.setdiff1d(dof_node, nodes[:, 0].astype(np.int64))
    if missing.size:
        raise DataError(f"DOFs refer to node ids not in the node table: "
                        f"{missing[:5].tolist()}", src, "dofs")
    dof_kind = np.asarray(dof_kind).astype(str)
    if dof_kind.shape != (n,):
        raise DataError(f"DOF kinds have {dof_kind.size} entries, expected {n}", src, "dofs")
    unknown = np.setdiff1d(dof_kind, DOF_KINDS)
    if unknown.size:
        raise DataError(f"unknown DOF kinds {unknown[:5].tolist()} (allowed: "
                        f"{', '.join(DOF_KINDS)})", src, "dofs")
    code = dof_node * len(DOF_KINDS) + np.searchsorted(np.array(DOF_KINDS), dof_kind,
                                                       sorter=_KIND_SORTER)
    if np.unique(code).size != n:
        raise DataError("a (node, kind) pair occurs more than once in the DOF map", src,
                        "dofs")
    return dof_node, dof_kind


def _checked_dof_table(table: Mapping[str, Any], label: str, n: int, src: str | None
                       ) -> dict[str, tuple[tuple[int, float], ...]]:
    """Inputs or outputs: name → ((dof_index, weight), …), at least one finite pair each,
    indices in ``[0, n)``."""
    out = {}
    for name, pairs in dict(table).items():
        try:
            arr = np.asarray(pairs, dtype=np.float64).reshape(-1, 2)
        except (TypeError, ValueError):
            raise DataError("entries must be [dof_index, weight] pairs", src,
                            f"{label}.{name}") from None
        if arr.shape[0] == 0:
            raise DataError("no DOFs", src, f"{label}.{name}")
        if not np.all(np.isfinite(arr)):
            raise DataError("NaN/Inf entries", src, f"{label}.{name}")
        idx = arr[:, 0]
        if np.any(idx != np.round(idx)) or np.any(idx < 0) or np.any(idx >= n):
            raise DataError(f"DOF indices must be integers in [0, {n})", src,
                            f"{label}.{name}")
        out[str(name)] = tuple((int(i), float(w)) for i, w in arr)
    return out


def _checked_symmetry(fe: FEModel, src: str | None) -> dict[str, bool]:
    """The declared symmetries: ``M``, ``K``, ``D`` → a bool, and a declared-symmetric
    matrix within :data:`SYMMETRY_RTOL`."""
    if not isinstance(fe.symmetric, Mapping):
        raise DataError(f"must map matrix names to true/false, got {fe.symmetric!r}", src,
                        "symmetric")
    sym = {}
    for key, declared in dict(fe.symmetric).items():
        if key not in ("M", "K", "D"):
            raise DataError(f"symmetry declared for unknown matrix {key!r}", src, "symmetric")
        if not isinstance(declared, bool | np.bool_):  # "no" would be truthy
            raise DataError(f"must be true or false, got {declared!r}", src,
                            f"symmetric.{key}")
        sym[key] = bool(declared)
    for key, declared in sym.items():
        a = getattr(fe, key)
        if declared and a is not None and asymmetry(a) > SYMMETRY_RTOL:
            raise DataError(f"declared symmetric but max|A−Aᵀ|/max|A| = {asymmetry(a):.3g}",
                            src, key)
    return sym
