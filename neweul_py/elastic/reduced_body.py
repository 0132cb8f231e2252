"""The reduced elastic body: two-sided (Petrov–Galerkin) reduced data and its file format.

The format is documented in ``docs/reduced-body-format.md``: one uncompressed ``.npz`` (read
with ``allow_pickle=False``) holding the arrays and, as the ``uint8`` array ``meta``, the
UTF-8 JSON metadata. One file, written atomically, so a reader never sees a partial body.
"""

from __future__ import annotations

import dataclasses
import json
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import DataError
from ._io import json_from_uint8, json_to_uint8, load_npz, save_npz_atomic
from .fe_model import DOF_KINDS, loss_reference
from .static_state import StaticDeflection, static_from_arrays

__all__ = [
    "REDUCED_BODY_FORMAT",
    "REDUCED_BODY_VERSION",
    "ReducedBody",
    "load_reduced_body",
    "save_reduced_body",
]

REDUCED_BODY_FORMAT = "neweul-reduced-body"
REDUCED_BODY_VERSION = 1
INVARIANT_PREFIX = "invariants/"
REDUCED_ARRAYS = ("M", "D", "K", "B", "C", "nodes", "kept_dofs", "dof_node", "dof_kind", "V_kept",
           "W_kept")
#: Invariants that are the body's own projected matrices (``Me = Wᵀ M V`` …): a file stores them
#: once, as the matrix (metadata ``invariants_shared``).
SHARED_INVARIANTS = {"Me.m0": "M", "Ke.m0": "K", "De.m0": "D", "Le.m0": "G"}
REDUCED_OPTIONAL = ("V", "W", "eigenvalues", "full_dof_kind", "G")


def json_normal(obj: Any, item: str) -> Any:
    try:
        return json.loads(json.dumps(obj, allow_nan=False))
    except (TypeError, ValueError) as exc:
        raise DataError(f"must be JSON-serializable ({exc})", None, item) from None


@dataclass(frozen=True, eq=False)
class ReducedBody:
    """Reduced second-order model ``M q̈ + D q̇ + K q = B u``, ``y = C q`` of an elastic body.

    Obtained by Petrov–Galerkin projection (``docs/equations.md`` §2–3):
    ``M = Wᵀ M_FE V``, ``D = Wᵀ D_FE V``, ``K = Wᵀ K_FE V``, ``B = Wᵀ B_FE``, ``C = C_FE V``;
    full displacements are ``x ≈ V q``. One-sided data is ``W = V``.

    Parameters
    ----------
    M, D, K
        (r, r) reduced matrices (``D`` is zero for an undamped model); not symmetric in
        general.
    B, C
        (r, n_in) reduced input and (n_out, r) reduced output matrices.
    input_names, output_names
        Names of the columns of ``B`` and the rows of ``C``.
    nodes
        (nk, 4) ``id, x, y, z`` of the kept nodes (interface and output nodes).
    kept_dofs
        (nkd,) indices, in the full FE model, of all DOFs of the kept nodes.
    dof_node, dof_kind
        (nkd,) node id and kind (``ux … rz, p``) of each kept DOF.
    V_kept, W_kept
        (nkd, r) rows of the right basis (displacement shapes: Φ, Ψ of the node frames for
        ``u``/``r`` kinds) and of the left basis (modal loads ``Wᵀ f`` of nodal forces) at the
        kept DOFs.
    V, W
        Optional (n, r) full bases (needed for parametric interpolation, §4).
    full_dof_kind
        Optional (n,) kind (``ux … rz, p``) of every row of the full bases, i.e. of every
        FE DOF; the reductors set it whenever they store ``V``/``W``. Parametric
        interpolation uses it to scale the rows per DOF kind (§4, ``row_scaling``).
    method
        ``"modal"`` or ``"krylov"`` (or another reductor's name).
    settings
        The reductor's settings (JSON-serializable; normalized through JSON on construction
        so that the value after a file round trip is identical).
    eigenvalues
        Optional retained eigenvalues ``λ = ω²`` of the undamped pencil (modal reduction).
    source
        JSON metadata of the FE model (name, file, kind, n_dofs, density).
    invariants
        Optional slot for the floating-frame invariants (§2) as a flat name → array dict
        (``"Ct"``, ``"Cr"``, ``"Me"``, ``"Oe1"``, …: naming is up to the invariants module).
        Stored as ``invariants/<name>`` arrays; any dtype except object; round-trips exactly.
    parameters
        Optional parameter values (name → float) at which this body is a sample of a
        parametric family (§4).
    G
        Optional (r, r) reduced hysteretic damping ``Wᵀ G_FE V`` of the frequency-domain
        stiffness ``K + iG`` (loss factors, ``docs/equations.md`` §1.1); ``D`` holds its
        time-domain equivalent ``G/ω_ref`` when the FE model's ``D`` did.
    loss_reference_frequency
        The reference frequency ``f_ref`` [Hz] of ``G`` (required with it).
    static
        Optional static state the body is linearized about
        (:class:`~neweul_py.elastic.static_state.StaticDeflection`: static reduced
        coordinates, node displacements and interface forces, output values; arrays
        ``static/*``).

    Raises
    ------
    DataError
        Inconsistent shapes, NaN/Inf in the matrices, names not matching ``B``/``C``.
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
    method: str = "modal"
    settings: Mapping[str, Any] = field(default_factory=dict)
    eigenvalues: np.ndarray | None = None
    source: Mapping[str, Any] = field(default_factory=dict)
    invariants: Mapping[str, np.ndarray] | None = None
    parameters: Mapping[str, float] | None = None
    full_dof_kind: np.ndarray | None = None
    static: StaticDeflection | None = None
    format_version: int = REDUCED_BODY_VERSION
    G: np.ndarray | None = None
    loss_reference_frequency: float | None = None

    def __post_init__(self) -> None:
        try:
            self._validate()
        except (TypeError, ValueError, OverflowError, AttributeError) as exc:
            # arrays of the wrong dtype or shape (strings for numbers, ragged lists …)
            raise DataError(f"malformed reduced-body data ({type(exc).__name__}: {exc})"
                            ) from None

    def _validate(self) -> None:
        set_ = object.__setattr__
        r = np.asarray(self.M).shape[0] if np.ndim(self.M) == 2 else -1
        for key in ("M", "D", "K"):
            a = np.asarray(self[key], dtype=np.float64)
            if a.shape != (r, r):
                raise DataError(f"must be {r}×{r}, got {a.shape}", None, key)
            set_(self, key, a)
        set_(self, "B", np.asarray(self.B, dtype=np.float64).reshape(r, -1))
        set_(self, "C", np.asarray(self.C, dtype=np.float64).reshape(-1, r))
        set_(self, "input_names", tuple(str(s) for s in self.input_names))
        set_(self, "output_names", tuple(str(s) for s in self.output_names))
        if len(self.input_names) != self.B.shape[1]:
            raise DataError(f"{len(self.input_names)} input names for {self.B.shape[1]} "
                            "columns", None, "B")
        if len(self.output_names) != self.C.shape[0]:
            raise DataError(f"{len(self.output_names)} output names for {self.C.shape[0]} "
                            "rows", None, "C")
        set_(self, "nodes", np.asarray(self.nodes, dtype=np.float64).reshape(-1, 4))
        set_(self, "kept_dofs", np.asarray(self.kept_dofs, dtype=np.int64).ravel())
        nk = self.kept_dofs.size
        set_(self, "dof_node", np.asarray(self.dof_node, dtype=np.int64).ravel())
        set_(self, "dof_kind", np.asarray(self.dof_kind).astype(str).ravel())
        if self.dof_node.size != nk or self.dof_kind.size != nk:
            raise DataError("dof_node/dof_kind must match kept_dofs", None, "kept_dofs")
        for key in ("V_kept", "W_kept"):
            a = np.asarray(self[key], dtype=np.float64)
            if a.shape != (nk, r):
                raise DataError(f"must be {nk}×{r}, got {a.shape}", None, key)
            set_(self, key, a)
        for key in ("V", "W"):
            if self[key] is not None:
                a = np.asarray(self[key], dtype=np.float64)
                if a.ndim != 2 or a.shape[1] != r:
                    raise DataError(f"must have {r} columns, got {a.shape}", None, key)
                set_(self, key, a)
        if self.eigenvalues is not None:
            set_(self, "eigenvalues", np.asarray(self.eigenvalues).ravel())
        if self.full_dof_kind is not None:
            kinds = np.asarray(self.full_dof_kind)
            if kinds.ndim != 1 or kinds.dtype.kind not in "US":
                raise DataError(f"must be a 1-D array of DOF kinds, got {kinds.dtype} "
                                f"{kinds.shape}", None, "full_dof_kind")
            kinds = kinds.astype("U2")
            unknown = sorted(set(np.unique(kinds).tolist()) - set(DOF_KINDS))
            if unknown:
                raise DataError(f"unknown DOF kinds {unknown} (allowed: "
                                f"{', '.join(DOF_KINDS)})", None, "full_dof_kind")
            for key in ("V", "W"):
                if self[key] is not None and self[key].shape[0] != kinds.size:
                    raise DataError(f"{kinds.size} DOF kinds for the {self[key].shape[0]} "
                                    f"rows of {key}", None, "full_dof_kind")
            kept = self.kept_dofs
            if np.any((kept < 0) | (kept >= kinds.size)) or not np.array_equal(
                    kinds[kept], self.dof_kind):
                raise DataError("the kinds of the kept DOFs differ from dof_kind", None,
                                "full_dof_kind")
            set_(self, "full_dof_kind", kinds)
        self._validate_loss(r)
        for key in ("M", "D", "K", "B", "C", "V_kept", "W_kept"):
            if not np.all(np.isfinite(self[key])):
                raise DataError("has NaN/Inf entries", None, key)
        set_(self, "settings", json_normal(dict(self.settings), "settings"))
        set_(self, "source", json_normal(dict(self.source), "source"))
        if self.parameters is not None:
            params = {str(k): float(v) for k, v in dict(self.parameters).items()}
            if not all(np.isfinite(v) for v in params.values()):
                raise DataError("parameter values must be finite numbers", None, "parameters")
            set_(self, "parameters", params)
        if self.invariants is not None:
            inv = {}
            for k, v in self.invariants.items():
                a = np.asarray(v)
                if a.dtype == object:
                    raise DataError("object arrays cannot be stored", None,
                                    f"invariants.{k}")
                inv[str(k)] = a
            set_(self, "invariants", inv)
        if self.static is not None:
            if not isinstance(self.static, StaticDeflection):
                raise DataError(f"must be a StaticDeflection, got {type(self.static).__name__}",
                                None, "static")
            self.static.check(r, self.nodes.shape[0], len(self.output_names))

    def _validate_loss(self, r: int) -> None:
        """``G`` (r × r, finite) and its reference frequency (:func:`~.fe_model.loss_reference`)."""
        f = loss_reference(self.G, self.loss_reference_frequency, self.D, None)
        if self.G is None:
            return
        g = np.asarray(self.G, dtype=np.float64)
        if g.shape != (r, r):
            raise DataError(f"must be {r}×{r}, got {g.shape}", None, "G")
        if not np.all(np.isfinite(g)):
            raise DataError("has NaN/Inf entries", None, "G")
        object.__setattr__(self, "G", g)
        object.__setattr__(self, "loss_reference_frequency", f)

    def __getitem__(self, key: str) -> Any:
        return getattr(self, key)

    # ------------------------------------------------------------------ properties
    @property
    def order(self) -> int:
        """Reduced order ``r``."""
        return self.M.shape[0]

    @property
    def two_sided(self) -> bool:
        """``False`` for Galerkin data (``W_kept`` equal to ``V_kept``)."""
        return bool(self.settings.get("two_sided", True))

    def with_(self, **changes: Any) -> ReducedBody:
        """A validated copy with some fields changed."""
        return dataclasses.replace(self, **changes)

    # ------------------------------------------------------------------ file I/O


def save_reduced_body(body: ReducedBody, path: str | os.PathLike) -> None:
    """Write ``body`` as a versioned ``.npz`` with embedded JSON metadata, atomically."""
    arrays = {key: body[key] for key in REDUCED_ARRAYS}
    arrays["dof_kind"] = body.dof_kind.astype("U2")
    for key in REDUCED_OPTIONAL:
        if body[key] is not None:
            arrays[key] = body[key]
    names = list(body.invariants or {})
    shared = {}
    for name in names:
        own = SHARED_INVARIANTS.get(name)
        if own is not None and body[own] is not None and np.array_equal(body.invariants[name],
                                                                        body[own]):
            shared[name] = own      # the projected matrix itself: stored once
            continue
        arrays[INVARIANT_PREFIX + name] = body.invariants[name]
    if body.static is not None:
        arrays.update(body.static.to_arrays())
    meta = {
        "format": REDUCED_BODY_FORMAT,
        "version": body.format_version,
        "method": body.method,
        "settings": body.settings,
        "input_names": list(body.input_names),
        "output_names": list(body.output_names),
        "source": body.source,
        "parameters": body.parameters,
        "invariants": names if body.invariants is not None else None,
        "invariants_shared": shared,
        **({"loss_reference_frequency": body.loss_reference_frequency}
           if body.G is not None else {}),
    }
    arrays["meta"] = json_to_uint8(meta)
    save_npz_atomic(path, arrays)


#: Documented types of the metadata fields (docs/reduced-body-format.md): key → (check, what).
META_FIELDS: dict[str, tuple[Any, str]] = {
    "method": (lambda v: isinstance(v, str), "a string"),
    "settings": (lambda v: v is None or isinstance(v, dict), "an object"),
    "source": (lambda v: v is None or isinstance(v, dict), "an object"),
    "input_names": (lambda v: isinstance(v, list) and all(isinstance(s, str) for s in v),
                    "a list of strings"),
    "output_names": (lambda v: isinstance(v, list) and all(isinstance(s, str) for s in v),
                     "a list of strings"),
    "invariants": (lambda v: v is None or (isinstance(v, list)
                                           and all(isinstance(s, str) for s in v)),
                   "null or a list of strings"),
    "loss_reference_frequency": (lambda v: isinstance(v, int | float)
                                 and not isinstance(v, bool), "a number (Hz)"),
    "parameters": (lambda v: v is None or (isinstance(v, dict) and all(
        isinstance(x, int | float) and not isinstance(x, bool) for x in v.values())),
                   "null or an object of numbers"),
}


def check_metadata(meta: Mapping[str, Any], file: str | None = None) -> None:
    """Check the metadata of a reduced-body file field by field against the documented
    types (:data:`META_FIELDS`), so that a wrong type is one :class:`DataError` naming the
    field, never a ``TypeError`` deep inside the reader."""
    for key, (ok, what) in META_FIELDS.items():
        if key in meta and not ok(meta[key]):
            raise DataError(f"must be {what}, got {type(meta[key]).__name__} "
                            f"{str(meta[key])[:60]!r}", file, f"meta.{key}")
    settings = meta.get("settings") or {}
    if "two_sided" in settings and not isinstance(settings["two_sided"], bool):
        raise DataError("must be true or false", file, "meta.settings.two_sided")


def load_reduced_body(path: str | os.PathLike) -> ReducedBody:
    """Read a reduced body; a :class:`DataError` naming the file and array on any problem."""
    file = str(path)
    data = load_npz(path)
    if "meta" not in data:
        raise DataError("missing the \"meta\" array (not a reduced-body file?)", file, "meta")
    meta = json_from_uint8(data["meta"], file)
    if not isinstance(meta, dict) or meta.get("format") != REDUCED_BODY_FORMAT:
        raise DataError(f"\"format\" must be {REDUCED_BODY_FORMAT!r}", file, "meta")
    if meta.get("version") != REDUCED_BODY_VERSION:
        raise DataError(f"unsupported version {meta.get('version')!r} (this reader: "
                        f"{REDUCED_BODY_VERSION})", file, "meta")
    missing = [k for k in REDUCED_ARRAYS if k not in data]
    if missing:
        raise DataError(f"missing arrays {missing}", file, missing[0])
    check_metadata(meta, file)
    names = meta.get("invariants")
    invariants = None
    if names is not None:
        shared = meta.get("invariants_shared") or {}
        if not isinstance(shared, dict) or any(
                SHARED_INVARIANTS.get(k) != v or v not in data for k, v in shared.items()):
            raise DataError("invariants_shared must map Me.m0/Ke.m0/De.m0/Le.m0 to M/K/D/G",
                            file, "meta")
        absent = [n for n in names if INVARIANT_PREFIX + n not in data and n not in shared]
        if absent:
            raise DataError(f"missing invariant arrays {absent}", file, "invariants")
        invariants = {n: data[shared[n]] if n in shared else data[INVARIANT_PREFIX + n]
                      for n in names}
    try:
        return ReducedBody(
            **{key: data[key] for key in REDUCED_ARRAYS},
            **{key: data.get(key) for key in REDUCED_OPTIONAL},
            input_names=tuple(meta.get("input_names", ())),
            output_names=tuple(meta.get("output_names", ())),
            method=str(meta.get("method", "")),
            settings=meta.get("settings") or {},
            source=meta.get("source") or {},
            parameters=meta.get("parameters"),
            invariants=invariants,
            static=static_from_arrays(data, file),
            format_version=int(meta["version"]),
            loss_reference_frequency=meta.get("loss_reference_frequency"),
        )
    except DataError as exc:
        raise DataError(exc.message, file, exc.item) from None
