"""The reduced elastic body: two-sided (Petrov–Galerkin) reduced data.

Its file (``docs/reduced-body-format.md``: one uncompressed ``.npz`` holding the arrays and,
as the ``uint8`` array ``meta``, the UTF-8 JSON metadata, written atomically) is read and
written by :mod:`neweul_py.elastic.io.body_files`.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...errors import DataError
from .fields import BodyFields, check_body_fields, checked_dof_kinds

__all__ = [
    "INVARIANT_PREFIX",
    "REDUCED_BODY_VERSION",
    "SHARED_INVARIANTS",
    "ReducedBody",
    "json_normal",
    "validate_reduced",
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


@dataclass(frozen=True, eq=False, kw_only=True)
class ReducedBody(BodyFields):
    """Reduced second-order model ``M q̈ + D q̇ + K q = B u``, ``y = C q`` of an elastic body.

    Obtained by Petrov–Galerkin projection (``docs/equations.md`` §2–3):
    ``M = Wᵀ M_FE V``, ``D = Wᵀ D_FE V``, ``K = Wᵀ K_FE V``, ``B = Wᵀ B_FE``, ``C = C_FE V``;
    full displacements are ``x ≈ V q``. One-sided data is ``W = V``. Plain immutable data:
    the fields of :class:`~neweul_py.elastic.bodies.fields.BodyFields` (matrices, names,
    kept nodes and DOFs, bases, invariants, static state, loss data), unstacked, and those
    below, checked on construction by :func:`validate_reduced` (keyword arguments only).

    Parameters
    ----------
    method
        ``"modal"`` or ``"krylov"`` (or another reductor's name).
    settings
        The reductor's settings (JSON-serializable; normalized through JSON on construction
        so that the value after a file round trip is identical).
    eigenvalues
        Optional retained eigenvalues ``λ = ω²`` of the undamped pencil (modal reduction).
    source
        JSON metadata of the FE model (name, file, kind, n_dofs, density).
    parameters
        Optional parameter values (name → float) at which this body is a sample of a
        parametric family (§4).
    **fields
        The :class:`~neweul_py.elastic.bodies.fields.BodyFields`; ``full_dof_kind``
        (with ``V``/``W``) is what parametric interpolation scales the rows by (§4,
        ``row_scaling``).

    Raises
    ------
    DataError
        Data that contradict the format (``docs/reduced-body-format.md``, "Checks of a
        body").
    """

    method: str = "modal"
    settings: Mapping[str, Any] = field(default_factory=dict)
    eigenvalues: np.ndarray | None = None
    source: Mapping[str, Any] = field(default_factory=dict)
    parameters: Mapping[str, float] | None = None
    format_version: int = REDUCED_BODY_VERSION

    def __post_init__(self) -> None:
        validate_reduced(self)

    # ------------------------------------------------------------------ properties
    @property
    def order(self) -> int:
        """Reduced order ``r``."""
        return self.M.shape[0]

    @property
    def two_sided(self) -> bool:
        """``False`` for Galerkin data (``W_kept`` equal to ``V_kept``)."""
        return bool(self.settings.get("two_sided", True))


def validate_reduced(body: ReducedBody) -> None:
    """Check and normalize a reduced body under construction: the shared fields
    (:func:`~neweul_py.elastic.bodies.fields.check_body_fields`), the eigenvalues, the DOF
    kinds of the full bases, and the JSON metadata. Malformed arrays (strings for numbers,
    ragged lists …) are one :class:`DataError` too."""
    set_ = object.__setattr__
    try:
        check_body_fields(body, None)
        if body.eigenvalues is not None:
            set_(body, "eigenvalues", _checked_eigenvalues(body.eigenvalues))
        if body.full_dof_kind is not None:
            kinds = checked_dof_kinds(body.full_dof_kind, {
                key: body[key].shape[0] for key in ("V", "W") if body[key] is not None})
            kept = body.kept_dofs
            if np.any(kept >= kinds.size) or not np.array_equal(kinds[kept], body.dof_kind):
                raise DataError("the kinds of the kept DOFs differ from dof_kind", None,
                                "full_dof_kind")
            set_(body, "full_dof_kind", kinds)
        set_(body, "settings", json_normal(dict(body.settings), "settings"))
        set_(body, "source", json_normal(dict(body.source), "source"))
        if body.parameters is not None:
            params = {str(k): float(v) for k, v in dict(body.parameters).items()}
            if not all(np.isfinite(v) for v in params.values()):
                raise DataError("parameter values must be finite numbers", None, "parameters")
            set_(body, "parameters", params)
    except (TypeError, ValueError, OverflowError, AttributeError) as exc:
        raise DataError(f"malformed reduced-body data ({type(exc).__name__}: {exc})"
                        ) from None


def _checked_eigenvalues(eigenvalues: Any) -> np.ndarray:
    """``λ = ω²`` of the retained modes: finite, and (real spectra) not negative beyond
    round-off (``λ < −10⁻⁸ max|λ|``: a body that is not stable on its own, or a corrupted
    file; rigid-body modes are ``λ ≈ 0`` of either sign). Complex spectra (two-sided
    reductions of non-symmetric models) may have complex ``λ``."""
    lam = np.asarray(eigenvalues).ravel()
    if lam.dtype.kind not in "fc" and lam.size:
        raise DataError(f"must be numbers, got {lam.dtype}", None, "eigenvalues")
    if not np.all(np.isfinite(lam)):
        raise DataError("has NaN/Inf entries", None, "eigenvalues")
    real = lam.real if np.iscomplexobj(lam) else lam
    if real.size and real.min() < -1e-8 * float(np.abs(lam).max()):
        raise DataError(f"has a negative eigenvalue λ = ω² = {real.min():.6g} (the body "
                        "is not stable on its own)", None, "eigenvalues")
    return lam
