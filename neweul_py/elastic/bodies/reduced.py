"""The reduced elastic body: two-sided (Petrov–Galerkin) reduced data and its file format.

The format is documented in ``docs/reduced-body-format.md``: one uncompressed ``.npz`` (read
with ``allow_pickle=False``) holding the arrays and, as the ``uint8`` array ``meta``, the
UTF-8 JSON metadata. One file, written atomically, so a reader never sees a partial body.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...errors import DataError
from ..fe_model import DOF_KINDS, loss_reference
from .static import StaticDeflection

__all__ = [
    "INVARIANT_PREFIX",
    "REDUCED_BODY_VERSION",
    "SHARED_INVARIANTS",
    "ReducedBody",
    "json_normal",
]


REDUCED_BODY_VERSION = 1
INVARIANT_PREFIX = "invariants/"
#: Invariants that are the body's own projected matrices (``Me = Wᵀ M V`` …): a file stores them
#: once, as the matrix (metadata ``invariants_shared``).
SHARED_INVARIANTS = {"Me.m0": "M", "Ke.m0": "K", "De.m0": "D", "Le.m0": "G"}


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
        (:class:`~neweul_py.elastic.bodies.static.StaticDeflection`: static reduced
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
        for key in ("M", "D", "K", "B", "C", "V_kept", "W_kept", "V", "W", "G", "nodes"):
            if self[key] is not None and np.iscomplexobj(self[key]):   # float64 by the format
                raise DataError("has complex entries; the format holds real float64 arrays",
                                None, key)
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
        if not np.all(np.isfinite(self.nodes)):
            raise DataError("has NaN/Inf entries", None, "nodes")
        ids = self.nodes[:, 0]
        if np.any(ids < 0) or np.any(ids != np.round(ids)):
            raise DataError("node ids (first column) must be non-negative whole numbers",
                            None, "nodes")
        for key in ("kept_dofs", "dof_node"):
            raw = np.asarray(self[key])
            if raw.size and (raw.dtype.kind not in "iubf" or not np.all(np.isfinite(raw))
                             or np.any(raw < 0) or np.any(raw != np.round(raw))):
                raise DataError("must hold non-negative whole numbers", None, key)
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
        for key in ("V", "W"):
            if self[key] is not None and not np.all(np.isfinite(self[key])):
                raise DataError("has NaN/Inf entries", None, key)
        if self.eigenvalues is not None:
            set_(self, "eigenvalues", np.asarray(self.eigenvalues).ravel())
            self._validate_eigenvalues()
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

    def _validate_eigenvalues(self) -> None:
        """``λ = ω²`` of the retained modes: finite, and (real spectra) not negative beyond
        round-off (``λ < −10⁻⁸ max|λ|``: a body that is not stable on its own, or a corrupted
        file; rigid-body modes are ``λ ≈ 0`` of either sign). Complex spectra (two-sided
        reductions of non-symmetric models) may have complex ``λ``."""
        lam = self.eigenvalues
        if lam.dtype.kind not in "fc" and lam.size:
            raise DataError(f"must be numbers, got {lam.dtype}", None, "eigenvalues")
        if not np.all(np.isfinite(lam)):
            raise DataError("has NaN/Inf entries", None, "eigenvalues")
        real = lam.real if np.iscomplexobj(lam) else lam
        if real.size and real.min() < -1e-8 * float(np.abs(lam).max()):
            raise DataError(f"has a negative eigenvalue λ = ω² = {real.min():.6g} (the body "
                            "is not stable on its own)", None, "eigenvalues")

    def _validate_loss(self, r: int) -> None:
        """``G`` (r × r, finite) and its reference frequency
        (:func:`~neweul_py.elastic.fe_model.loss_reference`)."""
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
