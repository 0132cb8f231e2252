"""Parametric elastic bodies: samples, interpolation weights, file (``docs/equations.md`` §4).

A :class:`ParametricBody` holds ``k`` samples ``X̃_i`` of a reduced body in common coordinates
at the sample values ``p_1 < … < p_k`` of its parameter, and :meth:`ParametricBody.at`
interpolates ``X(p) = Σ_i w_i(p) X̃_i`` — every stored quantity with the same weights (§4,
step 6), which sum to one: linear, the cubic spline's cardinal functions (in an
interpolation coordinate ``ξ(p)`` if the body has one, §4.1), or the cubic or quintic
Hermite bases with the samples' slopes and curvatures (§4.2), all from
:mod:`neweul_py.ffrf.parametric` (one home, the generated module uses the same). Two
builders make the samples: :func:`~neweul_py.elastic.local_interpolation.interpolate`
(Panzer et al. 2010, the local bodies brought to common coordinates) and
:func:`~neweul_py.elastic.global_basis.global_parametric_body` (one global basis). This
module also holds what both share — the checks of the samples, their stacked loss data, the
central differences of the slopes and curvatures, the coordinate table — and the file format
(``docs/reduced-body-format.md``).
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import DataError
from ..ffrf.parametric import HERMITE_ORDERS, coordinate_problem, ffrf_weights, weight_polynomials
from ._io import json_from_uint8, json_to_uint8, load_npz, save_npz_atomic
from .fe_model import loss_reference
from .reduced_body import INVARIANT_PREFIX, ReducedBody, json_normal
from .static_state import (
    STATIC_KEYS,
    STATIC_PREFIX,
    StaticDeflection,
    residual_bound,
    static_from_arrays,
)

__all__ = [
    "BASES",
    "CARRIED_INVARIANTS",
    "GROUP_ORDER",
    "INTERPOLATIONS",
    "KIND_GROUPS",
    "PARAMETRIC_BODY_FORMAT",
    "PARAMETRIC_BODY_VERSION",
    "STACKED",
    "ParametricBody",
    "bodies_stack",
    "body_label",
    "central_curvatures",
    "central_slopes",
    "check_samples",
    "checked_slope_step",
    "coordinate_table",
    "hermite_kind",
    "is_parametric_body_file",
    "load_parametric_body",
    "model_sources",
    "sample_values",
    "save_parametric_body",
]

PARAMETRIC_BODY_FORMAT = "neweul-parametric-body"
#: Version 2 added the row scaling (``row_scaling``, ``row_scale``) and ``full_dof_kind``;
#: version-1 files are read with ``row_scaling = "none"``. Version 3 is written only for a
#: body with an interpolation coordinate (``coordinate``), so that older readers refuse it
#: instead of weighting in the parameter itself.
#: Version 4 is written only for a body with sample slopes (``slopes``, Hermite weights),
#: version 5 only for one with sample curvatures too (``curvatures``, quintic Hermite).
PARAMETRIC_BODY_VERSION = 2
COORDINATE_VERSION = 3
SLOPES_VERSION = 4
CURVATURES_VERSION = 5
READABLE_VERSIONS = (1, 2, 3, 4, 5)
#: Weight functions of :meth:`ParametricBody.at`.
INTERPOLATIONS = ("linear", "cubic", *HERMITE_ORDERS)
#: Rows of the bases that determine the common subspace (:mod:`.local_interpolation`).
BASES = ("auto", "full", "kept")
#: DOF kind → group sharing one row-scaling factor, in the order of normalization.
KIND_GROUPS = {"ux": "translation", "uy": "translation", "uz": "translation",
               "rx": "rotation", "ry": "rotation", "rz": "rotation", "p": "pressure"}
GROUP_ORDER = ("translation", "rotation", "pressure")
SLOPE_PREFIX = "slope/"
CURVATURE_PREFIX = "curvature/"
PARAMETRIC_ARRAYS = ("samples", "M", "D", "K", "B", "C", "nodes", "kept_dofs", "dof_node",
                     "dof_kind", "V_kept", "W_kept", "T", "L", "R", "singular_values",
                     "svd_weights")
PARAMETRIC_OPTIONAL = ("V", "W", "row_scale", "left_row_scale", "full_dof_kind", "G",
                       "coordinate")
#: Quantities interpolated in :meth:`ParametricBody.at` (stacked over the samples).
STACKED = ("M", "D", "K", "B", "C", "V_kept", "W_kept")
#: Floating-point invariants that are one value for all samples (checked when the body is
#: built, their slopes zero): :meth:`ParametricBody.at` carries them, it does not mix them
#: (weights that sum to one only to round-off would turn 1000 Hz into 1000.0000000000001).
CARRIED_INVARIANTS = ("loss.f_ref",)


def _floats(a: Any, key: str, ndim: int) -> np.ndarray:
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim != ndim:
        raise DataError(f"must have {ndim} dimensions, got shape {arr.shape}", None, key)
    if not np.all(np.isfinite(arr)):
        raise DataError("has NaN/Inf entries", None, key)
    return arr


@dataclass(frozen=True, eq=False)
class ParametricBody:
    """A parametric elastic body: local reduced models at samples, in common coordinates.

    Built by :func:`interpolate` (``docs/equations.md`` §4); :meth:`at` gives the
    :class:`~neweul_py.elastic.reduced_body.ReducedBody` at a parameter value. ``k`` =
    number of samples, ``r`` = order, ``nk`` = kept DOFs. All stacked arrays have the
    sample as their first axis.

    Parameters
    ----------
    parameter
        Name of the parameter (e.g. ``"pressure"``).
    samples
        (k,) strictly increasing sample values ``p_1 < … < p_k``.
    M, D, K
        (k, r, r) transformed local matrices ``X̃_i = L_i X_r,i T_i⁻¹``.
    B, C
        (k, r, n_in) ``B̃_i = L_i B_r,i`` and (k, n_out, r) ``C̃_i = C_r,i T_i⁻¹``.
    input_names, output_names
        Names of the columns of ``B`` and rows of ``C`` (common to all samples).
    nodes, kept_dofs, dof_node, dof_kind
        The kept nodes and DOFs (common to all samples), as in ``ReducedBody``.
    V_kept, W_kept
        (k, nk, r) transformed basis rows ``V_kept T_i⁻¹`` (node ``Φ``, ``Ψ``) and
        ``W_kept L_iᵀ`` (modal loads).
    T, L
        (k, r, r) right and left transformations ``T_i = Rᵀ S V_i``,
        ``L_i = (W_iᵀ S_W R)⁻¹``; the local coordinates map to the common ones as
        ``q̃ = T_i q_i``.
    R
        (n or nk, r) common right subspace, orthonormal in the scaled rows ``S x`` (rows of
        the FE model for ``basis="full"``, of the kept DOFs for ``"kept"``);
        ``q̃ = Rᵀ S x``.
    singular_values
        Singular values of the (weighted) stacked sample bases; ``σ_{r+1}/σ_1`` measures
        how much of the sample subspaces the ``r`` common coordinates leave out.
    svd_weights
        (k,) weights ``w_i`` of the samples in the SVD.
    basis
        ``"full"`` or ``"kept"`` (module docstring).
    two_sided
        Petrov–Galerkin (``True``) or Galerkin data.
    V, W
        Optional (k, n, r) transformed full bases ``V_i T_i⁻¹``, ``W_i L_iᵀ``.
    row_scaling, row_scale, left_row_scale, pressure_weight
        How the rows were scaled before the SVD (module docstring): ``"none"``
        (``row_scale`` is ``None``, ``S = S_W = I``), ``"kind"`` or ``"given"`` (an array
        passed to :func:`interpolate`), with ``row_scale`` = the diagonal of ``S`` and
        ``left_row_scale`` that of ``S_W`` (``None``: ``S_W = S``), one positive factor per
        row of ``R``; ``pressure_weight`` of a ``"kind"`` scaling (``None`` otherwise).
    full_dof_kind
        Optional (n,) DOF kinds of the FE rows (of ``R`` for ``basis="full"``, of ``V``,
        ``W``), when the sample bodies carry them.
    invariants
        Optional flat invariants (:meth:`Invariants.to_flat` names) of the transformed
        samples, each stacked to (k, …); entries that are not floating point (format tag,
        names, node ids, flags) and :data:`CARRIED_INVARIANTS` (``loss.f_ref``) are equal
        for all samples.
    interpolation
        Default weight function of :meth:`at`: ``"linear"``, ``"cubic"``, ``"hermite"``
        (with :attr:`slopes`, and only then) or ``"quintic-hermite"`` (with :attr:`slopes`
        and :attr:`curvatures`, and only then).
    coordinate, coordinate_name
        Optional interpolation coordinate ``ξ(σ)`` (``docs/equations.md`` §4.1): a (2, n)
        table of knots ``σ_j`` (including every sample, spanning exactly their range) and
        strictly monotone values ``ξ_j``; the cubic weights are then taken in ``ξ``
        (:func:`~neweul_py.ffrf.parametric.weight_polynomials`), and its name (e.g.
        ``tm_volume_displacement``) says what ``ξ`` is.
    sample_sources, sample_methods, sample_settings
        Per sample: the ``source``, ``method`` and ``settings`` of the local body.
    G, loss_reference_frequency
        Optional (k, r, r) transformed hysteretic matrices ``G̃_i = L_i G_r,i T_i⁻¹`` of
        ``K + iG`` (loss factors, ``docs/equations.md`` §1.1), interpolated like ``K``,
        and their common reference frequency [Hz].
    static
        Optional static states of the samples
        (:class:`~neweul_py.elastic.static_state.StaticDeflection`, stacked; ``q`` in the
        common coordinates), mixed by :meth:`at` with the same weights (the residual: the
        largest of the samples mixed).
    slopes
        Optional sample slopes ``dX/dσ`` at every sample (``docs/equations.md`` §4.2), the
        data of ``hermite`` weights (present exactly when :attr:`interpolation` is
        ``"hermite"``): ``key → (k, …)`` for every interpolated stack — ``M``,
        ``D``, ``K``, ``B``, ``C``, ``V_kept``, ``W_kept`` (and ``G``, ``V``, ``W`` when
        stored), ``invariants/<name>`` for the floating-point invariants and
        ``static/<key>`` for the static state (``static/residual`` zero) — each of the shape
        of its stack (:func:`~neweul_py.elastic.global_basis.global_parametric_body` makes
        them from FE models next to the samples).
    curvatures
        Optional sample curvatures ``d²X/dσ²`` of the same keys and shapes (the data of
        ``quintic-hermite`` weights, with :attr:`slopes`; ``static/residual`` zero): second
        differences of the same FE models next to the samples (equations.md §4.2).
    slope_step, slope_sources
        Where the slopes came from (optional, with :attr:`slopes` only): the step ``δ`` of
        the models next to the samples and their sources (``file``, ``fingerprint``),
        ``2k`` of them, every sample's ``σ_i − δ`` model, then every ``σ_i + δ`` one.
    """

    parameter: str
    samples: np.ndarray
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
    T: np.ndarray
    L: np.ndarray
    R: np.ndarray
    singular_values: np.ndarray
    svd_weights: np.ndarray
    basis: str = "full"
    two_sided: bool = True
    V: np.ndarray | None = None
    W: np.ndarray | None = None
    row_scaling: str = "none"
    row_scale: np.ndarray | None = None
    left_row_scale: np.ndarray | None = None
    pressure_weight: float | None = None
    full_dof_kind: np.ndarray | None = None
    invariants: Mapping[str, np.ndarray] | None = None
    interpolation: str = "linear"
    sample_sources: tuple[Mapping[str, Any], ...] = ()
    sample_methods: tuple[str, ...] = ()
    sample_settings: tuple[Mapping[str, Any], ...] = ()
    static: StaticDeflection | None = None
    format_version: int = PARAMETRIC_BODY_VERSION
    G: np.ndarray | None = None
    loss_reference_frequency: float | None = None
    coordinate: np.ndarray | None = None
    coordinate_name: str = ""
    slopes: Mapping[str, np.ndarray] | None = None
    curvatures: Mapping[str, np.ndarray] | None = None
    slope_step: float | None = None
    slope_sources: tuple[Mapping[str, Any], ...] = ()

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "parameter", str(self.parameter))
        if not self.parameter:
            raise DataError("the parameter needs a name", None, "parameter")
        s = _floats(self.samples, "samples", 1)
        if s.size < 2:
            raise DataError(f"need at least 2 samples, got {s.size}", None, "samples")
        if np.any(np.diff(s) <= 0):
            raise DataError(f"samples must be strictly increasing, got {s.tolist()}", None,
                            "samples")
        set_(self, "samples", s)
        k = s.size
        M = _floats(self.M, "M", 3)
        r = M.shape[1]
        want = {"M": (k, r, r), "D": (k, r, r), "K": (k, r, r), "T": (k, r, r),
                "L": (k, r, r)}
        for key, shape in want.items():
            a = _floats(self[key], key, 3)
            if a.shape != shape:
                raise DataError(f"must be {shape}, got {a.shape}", None, key)
            set_(self, key, a)
        set_(self, "input_names", tuple(str(x) for x in self.input_names))
        set_(self, "output_names", tuple(str(x) for x in self.output_names))
        for key, shape in (("B", (k, r, len(self.input_names))),
                           ("C", (k, len(self.output_names), r))):
            a = _floats(self[key], key, 3)
            if a.shape != shape:
                raise DataError(f"must be {shape} (samples, inputs/outputs by name), got "
                                f"{a.shape}", None, key)
            set_(self, key, a)
        set_(self, "nodes", _floats(np.asarray(self.nodes, dtype=np.float64).reshape(-1, 4),
                                    "nodes", 2))
        set_(self, "kept_dofs", np.asarray(self.kept_dofs, dtype=np.int64).ravel())
        nk = self.kept_dofs.size
        set_(self, "dof_node", np.asarray(self.dof_node, dtype=np.int64).ravel())
        set_(self, "dof_kind", np.asarray(self.dof_kind).astype("U2").ravel())
        if self.dof_node.size != nk or self.dof_kind.size != nk:
            raise DataError("dof_node/dof_kind must match kept_dofs", None, "kept_dofs")
        for key in ("V_kept", "W_kept"):
            a = _floats(self[key], key, 3)
            if a.shape != (k, nk, r):
                raise DataError(f"must be {(k, nk, r)}, got {a.shape}", None, key)
            set_(self, key, a)
        for key in ("V", "W"):
            if self[key] is not None:
                a = _floats(self[key], key, 3)
                if a.shape[0] != k or a.shape[2] != r:
                    raise DataError(f"must be (k={k}, n, r={r}), got {a.shape}", None, key)
                set_(self, key, a)
        if (self.V is None) != (self.W is None):
            raise DataError("V and W are stored together or not at all", None, "V")
        Rm = _floats(self.R, "R", 2)
        if Rm.shape[1] != r:
            raise DataError(f"must have {r} columns, got {Rm.shape}", None, "R")
        set_(self, "R", Rm)
        set_(self, "singular_values", _floats(self.singular_values, "singular_values", 1))
        w = _floats(self.svd_weights, "svd_weights", 1)
        if w.shape != (k,):
            raise DataError(f"must have {k} entries, got {w.shape}", None, "svd_weights")
        set_(self, "svd_weights", w)
        if self.basis not in BASES[1:]:
            raise DataError(f"must be one of {BASES[1:]}, got {self.basis!r}", None, "basis")
        if self.interpolation not in INTERPOLATIONS:
            raise DataError(f"must be one of {INTERPOLATIONS}, got {self.interpolation!r}",
                            None, "interpolation")
        self._check_coordinate()
        set_(self, "two_sided", bool(self.two_sided))
        self._check_row_scaling(Rm.shape[0])
        for key, default in (("sample_sources", {}), ("sample_settings", {}),
                             ("sample_methods", "")):
            vals = tuple(self[key]) or (default,) * k
            if len(vals) != k:
                raise DataError(f"{len(vals)} entries for {k} samples", None, key)
            if key == "sample_methods":
                vals = tuple(str(v) for v in vals)
            else:
                vals = tuple(json_normal(dict(v), key) for v in vals)
            set_(self, key, vals)
        if self.invariants is not None:
            set_(self, "invariants", _check_stacked(self.invariants, k))
        f = loss_reference(self.G, self.loss_reference_frequency, self.D, None)
        if self.G is not None:
            g = _floats(self.G, "G", 3)
            if g.shape != (k, r, r):
                raise DataError(f"must be {(k, r, r)}, got {g.shape}", None, "G")
            set_(self, "G", g)
            set_(self, "loss_reference_frequency", f)
        if self.static is not None:
            if not isinstance(self.static, StaticDeflection):
                raise DataError(f"must be a StaticDeflection, got {type(self.static).__name__}",
                                None, "static")
            self.static.check(r, self.nodes.shape[0], len(self.output_names), k)
        self._check_slopes()

    def slope_keys(self) -> tuple[str, ...]:
        """The keys :attr:`slopes` must hold (every interpolated stack of this body)."""
        keys = [*STACKED, *(key for key in ("G", "V", "W") if self[key] is not None)]
        keys += [INVARIANT_PREFIX + n for n, a in (self.invariants or {}).items()
                 if a.dtype.kind == "f"]
        if self.static is not None:
            keys += [STATIC_PREFIX + key for key in STATIC_KEYS]
        return tuple(keys)

    def stack(self, key: str) -> np.ndarray:
        """The sample stack (k, …) of a :meth:`slope_keys` key."""
        if key.startswith(INVARIANT_PREFIX):
            return self.invariants[key[len(INVARIANT_PREFIX):]]
        if key.startswith(STATIC_PREFIX):
            return self.static[key[len(STATIC_PREFIX):]]
        return self[key]

    def _check_slopes(self) -> None:
        set_ = object.__setattr__
        need = HERMITE_ORDERS.get(self.interpolation, 0)
        have = (self.slopes is not None) + (self.curvatures is not None)
        if self.curvatures is not None and self.slopes is None:
            raise DataError("sample curvatures (curvature/*) without sample slopes (slope/*)",
                            None, "interpolation")
        if need != have:
            given = {0: "no sample slopes", 1: "sample slopes (slope/*)",
                     2: "sample slopes and curvatures (slope/*, curvature/*)"}[have]
            raise DataError(f"Hermite weights and their data come together (hermite: the "
                            f"sample slopes; quintic-hermite: the slopes and curvatures): "
                            f"interpolation {self.interpolation!r} with {given}", None,
                            "interpolation")
        self._check_slope_provenance()
        if self.slopes is None:
            if self.format_version in (SLOPES_VERSION, CURVATURES_VERSION):
                set_(self, "format_version", COORDINATE_VERSION if self.coordinate is not None
                     else PARAMETRIC_BODY_VERSION)      # versions 4, 5 mean "has them"
            return
        set_(self, "slopes", self._checked_derivatives(self.slopes, SLOPE_PREFIX, "slope"))
        if self.curvatures is None:
            set_(self, "format_version", SLOPES_VERSION)
            return
        set_(self, "curvatures", self._checked_derivatives(self.curvatures, CURVATURE_PREFIX,
                                                           "curvature"))
        set_(self, "format_version", CURVATURES_VERSION)

    def _check_slope_provenance(self) -> None:
        """``slope_step``: a positive finite number or ``None``; ``slope_sources``: none or
        ``2k`` mappings; both only with slopes."""
        sources = tuple(self.slope_sources or ())
        if self.slopes is None and (self.slope_step is not None or sources):
            raise DataError("a slope step or slope sources without sample slopes", None,
                            "slope_step" if self.slope_step is not None else "slope_sources")
        if self.slope_step is not None:
            object.__setattr__(self, "slope_step", checked_slope_step(self.slope_step))
        if sources and (len(sources) != 2 * self.samples.size
                        or not all(isinstance(x, Mapping) for x in sources)):
            raise DataError(f"must be {2 * self.samples.size} mappings (the models at every "
                            f"sample − step, then + step), got {len(sources)}", None,
                            "slope_sources")
        object.__setattr__(self, "slope_sources", tuple(dict(x) for x in sources))

    def _checked_derivatives(self, given: Any, prefix: str, what: str
                             ) -> dict[str, np.ndarray]:
        """The sample slopes or curvatures, checked: a mapping of every
        :meth:`slope_keys` key to a finite real array of its stack's shape, zero for the
        static residual and for the values common to all samples."""
        if not isinstance(given, Mapping):
            raise DataError(f"must be a mapping key → (k, …) array, got "
                            f"{type(given).__name__}", None, prefix.rstrip("/") + "s")
        want = self.slope_keys()
        extra = sorted(set(given) - set(want))
        missing = [key for key in want if key not in given]
        if extra or missing:
            def keys(names: list[str]) -> list[str]:
                return [prefix + name for name in names]

            raise DataError(f"must hold the {what} of every interpolated stack "
                            f"({len(want)} for this body, ParametricBody.slope_keys)"
                            + (f"; missing {keys(missing)}" if missing else "")
                            + (f"; unknown {keys(extra)}" if extra else ""), None,
                            prefix + (missing or extra)[0])
        out = {}
        for key in want:
            a = np.asarray(given[key])
            shape = self.stack(key).shape
            if a.dtype.kind not in "fi" or a.shape != shape:
                raise DataError(f"must be real of shape {shape}, got {a.dtype} {a.shape}",
                                None, prefix + key)
            a = a.astype(np.float64)
            if not np.all(np.isfinite(a)):
                raise DataError("holds a value that is not a finite number", None,
                                prefix + key)
            out[key] = a
        if self.static is not None and np.any(out[STATIC_PREFIX + "residual"]):
            raise DataError(f"the {what} of a residual is not stored (must be zero)", None,
                            f"{prefix}{STATIC_PREFIX}residual")
        for name in CARRIED_INVARIANTS:
            key = INVARIANT_PREFIX + name
            if key in out and np.any(out[key]):
                raise DataError(f"the {what} of a value common to all samples is zero", None,
                                prefix + key)
        return out

    def _check_coordinate(self) -> None:
        set_ = object.__setattr__
        if not isinstance(self.coordinate_name, str):
            raise DataError(f"must be a string, got {self.coordinate_name!r}", None,
                            "coordinate_name")
        if self.coordinate is None:
            if self.coordinate_name:
                raise DataError("a coordinate name without a coordinate table", None,
                                "coordinate_name")
            if self.format_version == COORDINATE_VERSION:   # version 3 means "has one"
                set_(self, "format_version", PARAMETRIC_BODY_VERSION)
            return
        why = coordinate_problem(self.samples, self.coordinate)
        if why is not None:
            raise DataError(why, None, "coordinate")
        if self.interpolation not in ("cubic", *HERMITE_ORDERS):
            raise DataError("an interpolation coordinate needs cubic or Hermite weights, got "
                            f"{self.interpolation!r}", None, "coordinate")
        if not self.coordinate_name:
            raise DataError("an interpolation coordinate needs a name (what ξ is)", None,
                            "coordinate_name")
        set_(self, "coordinate", np.array(self.coordinate, dtype=np.float64))
        try:
            weight_polynomials(self.samples, self.interpolation, self.coordinate)
        except ValueError as exc:
            raise DataError(str(exc), None, "coordinate") from None
        if self.format_version < COORDINATE_VERSION:
            set_(self, "format_version", COORDINATE_VERSION)

    def _check_row_scaling(self, n_rows: int) -> None:
        set_ = object.__setattr__
        if self.format_version not in READABLE_VERSIONS:
            raise DataError(f"unsupported version {self.format_version!r} (this reader: "
                            f"{', '.join(map(str, READABLE_VERSIONS))})", None,
                            "format_version")
        if self.row_scaling not in ("none", "kind", "given"):
            raise DataError(f"must be 'none', 'kind' or 'given', got {self.row_scaling!r}",
                            None, "row_scaling")
        if self.row_scaling == "none":
            if self.row_scale is not None or self.left_row_scale is not None:
                raise DataError("row_scaling 'none' stores no row_scale", None, "row_scale")
        else:
            if self.row_scale is None:
                raise DataError(f"row_scaling {self.row_scaling!r} needs row_scale", None,
                                "row_scale")
            for key in ("row_scale", "left_row_scale"):
                if self[key] is None:
                    continue
                sc = _floats(self[key], key, 1)
                if sc.shape != (n_rows,) or np.any(sc <= 0):
                    raise DataError(f"must be {n_rows} positive factors (one per row of R), "
                                    f"got shape {sc.shape}", None, key)
                set_(self, key, sc)
        if self.pressure_weight is not None:
            pw = float(self.pressure_weight)
            if self.row_scaling != "kind" or not (np.isfinite(pw) and pw > 0):
                raise DataError(f"a positive pressure weight of a 'kind' scaling, got {pw!r} "
                                f"with row_scaling {self.row_scaling!r}", None,
                                "pressure_weight")
            set_(self, "pressure_weight", pw)
        if self.full_dof_kind is not None:
            kinds = np.asarray(self.full_dof_kind)
            if kinds.ndim != 1 or kinds.dtype.kind not in "US":
                raise DataError("must be a 1-D array of DOF kinds", None, "full_dof_kind")
            kinds = kinds.astype("U2")
            unknown = sorted(set(np.unique(kinds).tolist()) - set(KIND_GROUPS))
            if unknown:
                raise DataError(f"unknown DOF kinds {unknown}", None, "full_dof_kind")
            rows = [a.shape[1] for a in (self.V, self.W) if a is not None]
            if self.basis == "full":
                rows.append(n_rows)
            if any(m != kinds.size for m in rows):
                raise DataError(f"{kinds.size} DOF kinds for FE arrays of {rows} rows", None,
                                "full_dof_kind")
            set_(self, "full_dof_kind", kinds)
        if self.format_version == 1 and (self.row_scaling != "none"
                                         or self.full_dof_kind is not None
                                         or self.pressure_weight is not None):
            raise DataError("format version 1 holds no row scaling or full_dof_kind", None,
                            "format_version")

    def __getitem__(self, key: str) -> Any:
        return getattr(self, key)

    # ------------------------------------------------------------------ properties
    @property
    def row_kinds(self) -> np.ndarray | None:
        """DOF kinds of the rows of ``R`` (``full_dof_kind`` or ``dof_kind``), if known."""
        return self.dof_kind if self.basis == "kept" else self.full_dof_kind

    @property
    def group_scales(self) -> dict[str, float]:
        """The factor of ``S`` per group of DOF kinds (translation, rotation, pressure).

        Empty when the kinds of the rows are not known; for ``"given"`` scalings, a group
        whose rows have different factors is reported as NaN.
        """
        return self._groups(self.row_scale)

    @property
    def left_group_scales(self) -> dict[str, float]:
        """As :attr:`group_scales`, for the left scaling ``S_W``."""
        return self._groups(self.row_scale if self.left_row_scale is None
                            else self.left_row_scale)

    def _groups(self, scale: np.ndarray | None) -> dict[str, float]:
        kinds = self.row_kinds
        if kinds is None:
            return {}
        groups = np.array([KIND_GROUPS[k] for k in kinds])
        scale = np.ones(kinds.size) if scale is None else scale
        out = {}
        for g in GROUP_ORDER:
            v = scale[groups == g]
            if v.size:
                out[g] = float(v[0]) if np.all(v == v[0]) else float("nan")
        return out

    @property
    def name(self) -> str:
        """The FE model name the samples share (``sample_sources``), ``"FIRST … LAST"``
        when they differ, ``"?"`` when none is recorded."""
        names = [str(src.get("name")) for src in self.sample_sources if src.get("name")]
        if not names:
            return "?"
        return names[0] if len(set(names)) == 1 else f"{names[0]} … {names[-1]}"

    @property
    def order(self) -> int:
        """Order ``r`` of the common coordinates."""
        return self.M.shape[1]

    @property
    def n_samples(self) -> int:
        """Number of samples ``k``."""
        return self.samples.size

    @property
    def range(self) -> tuple[float, float]:
        """The sampled parameter range ``(p_1, p_k)``; :meth:`at` refuses values outside."""
        return float(self.samples[0]), float(self.samples[-1])

    def with_(self, **changes: Any) -> ParametricBody:
        """A validated copy with some fields changed."""
        return dataclasses.replace(self, **changes)

    # ------------------------------------------------------------------ evaluation
    def weights(self, p: float, interpolation: str | None = None) -> np.ndarray:
        """Interpolation weights ``w_i(p)`` of the samples (they sum to one).

        ``"linear"``: the hat functions of the samples, i.e. linear between the two
        neighbouring samples, zero elsewhere. ``"cubic"``: the cardinal functions of the
        not-a-knot cubic spline through the samples (``S_i(p_j) = δ_ij``; two samples give
        the linear weights, three a parabola), in the interpolation coordinate
        :attr:`coordinate` when the body has one. ``"hermite"`` (a body with
        :attr:`slopes`): ``2k`` weights, the first ``k`` of the samples and the last ``k`` of
        their slopes — the piecewise cubic Hermite basis (equations.md §4.2);
        ``"quintic-hermite"`` (with :attr:`curvatures` too): ``3k``, the third ``k`` of the
        curvatures — the piecewise quintic Hermite basis. At a sample
        the weight vector is exactly the unit vector, so the sample's matrices are returned
        bit for bit. The weights are those of the generated module
        (:mod:`neweul_py.ffrf.parametric`, one home).

        Raises
        ------
        DataError
            ``p`` not finite or outside ``[p_1, p_k]`` (no extrapolation), or an unknown
            interpolation.
        """
        kind = self.interpolation if interpolation is None else interpolation
        if kind not in INTERPOLATIONS:
            raise DataError(f"unknown interpolation {kind!r} (one of "
                            f"{', '.join(INTERPOLATIONS)})", None, "interpolation")
        blocks = 1 + HERMITE_ORDERS.get(kind, 0)
        if blocks > 1 + (self.slopes is not None) + (self.curvatures is not None):
            raise DataError(f"parametric body {self.name!r} holds no sample "
                            f"{'slopes' if self.slopes is None else 'curvatures'}: {kind} "
                            "weights need them", None, "interpolation")
        if kind != self.interpolation and self.coordinate is not None:
            raise DataError(f"parametric body {self.name!r} has the interpolation "
                            f"coordinate {self.coordinate_name!r}: its weights are "
                            f"{self.interpolation!r}", None, "interpolation")
        try:
            p = float(p)
        except (TypeError, ValueError):
            raise DataError(f"must be a number, got {p!r}", None, self.parameter) from None
        s = self.samples
        lo, hi = self.range
        if not np.isfinite(p) or p < lo or p > hi:
            raise DataError(f"parametric body {self.name!r}: {self.parameter} = {p:g} is "
                            f"outside the sampled range [{lo:g}, {hi:g}]; the parametric "
                            "body does not extrapolate (add a sample)", None, self.parameter)
        w = np.zeros(blocks * s.size)
        hit = np.flatnonzero(s == p)
        if hit.size:
            w[hit[0]] = 1.0
            return w
        if kind == "linear":
            j = int(np.searchsorted(s, p)) - 1      # s[j] < p < s[j + 1]
            t = (p - s[j]) / (s[j + 1] - s[j])
            w[j], w[j + 1] = 1.0 - t, t
            return w
        breaks, c = weight_polynomials(s, kind, self.coordinate)
        return np.asarray(ffrf_weights(breaks, c, p, self.name), dtype=np.float64)

    def at(self, p: float, interpolation: str | None = None) -> ReducedBody:
        """The reduced body at parameter value ``p``: ``X(p) = Σ_i w_i(p) X̃_i`` (§4, step 5).

        Every stored quantity — ``M``, ``D``, ``K``, ``B``, ``C``, ``V_kept``, ``W_kept``, the
        full bases, the invariants and the static state — is interpolated with the same
        weights (:meth:`weights`), so the body stays consistent (§4, step 6). What is one
        value for all samples is carried: the non-float invariants and
        :data:`CARRIED_INVARIANTS` (the loss reference frequency ``loss.f_ref``). The static
        state's relative residual is not: a ratio of norms, mixed with signed (cubic)
        weights it can turn negative; the body's ``static.residual`` is the bound
        ``max_i r_i`` over the samples with a nonzero weight
        (:func:`~neweul_py.elastic.static_state.residual_bound`).

        Parameters
        ----------
        p
            Parameter value in ``[p_1, p_k]``.
        interpolation
            One of :data:`INTERPOLATIONS` the body has the data of (default:
            :attr:`interpolation`).

        Returns
        -------
        ReducedBody
            ``method="interpolated"``, ``parameters={name: p}``; ``settings`` name the
            parameter, the samples and the weights. ``source`` holds what all samples share
            (model name, kind, ``n_dofs``, density) and the samples' fingerprints; at a sample
            it is that sample's source, fingerprint included (the body there is a
            state-space equivalent of the local model, so ``compare_frf`` against the FE
            model of that sample is meaningful).

        Examples
        --------
        >>> pb = interpolate(bodies, [0.0, 0.5, 1.0], parameter="pressure")  # doctest: +SKIP
        >>> body = pb.at(0.3)                                                # doctest: +SKIP
        """
        kind = self.interpolation if interpolation is None else interpolation
        w = self.weights(p, kind)
        idx = np.flatnonzero(w)
        k = self.n_samples

        def mix(key: str) -> np.ndarray:
            stack = self.stack(key)
            if idx.size == 1 and idx[0] < k:
                return stack[idx[0]].copy()
            out = np.einsum("i,i...->...", w[idx[idx < k]], stack[idx[idx < k]])
            for b, data in enumerate((self.slopes, self.curvatures)[:w.size // k - 1], 1):
                j = idx[(idx >= b * k) & (idx < (b + 1) * k)] - b * k   # Hermite blocks
                out += np.einsum("i,i...->...", w[j + b * k], data[key][j])
            return out

        arrays = {key: mix(key) for key in STACKED}
        if self.G is not None:
            arrays.update(G=mix("G"), loss_reference_frequency=self.loss_reference_frequency)
        V = None if self.V is None else mix("V")
        W = None if self.W is None else mix("W")
        inv = None
        if self.invariants is not None:
            inv = {}
            for name, a in self.invariants.items():
                mixed = a.dtype.kind == "f" and name not in CARRIED_INVARIANTS
                inv[name] = mix(INVARIANT_PREFIX + name) if mixed else a[0].copy()
        hit = np.flatnonzero(self.samples == float(p))
        if hit.size:
            source = dict(self.sample_sources[hit[0]])
        else:
            first, rest = self.sample_sources[0], self.sample_sources[1:]
            source = {key: v for key, v in first.items() if key != "fingerprint"
                      and all(s.get(key) == v for s in rest)}
            prints = [s.get("fingerprint") for s in self.sample_sources]
            if any(f is not None for f in prints):
                source["sample_fingerprints"] = prints
        settings = {
            "two_sided": self.two_sided, "parameter": self.parameter, "value": float(p),
            "interpolation": kind, "samples": self.samples.tolist(), "weights": w.tolist(),
            **({"coordinate": self.coordinate_name} if self.coordinate is not None else {}),
            "basis": self.basis, "row_scaling": self.row_scaling,
            "pressure_weight": self.pressure_weight,
            "sample_methods": list(self.sample_methods),
        }
        return ReducedBody(
            **arrays, input_names=self.input_names, output_names=self.output_names,
            nodes=self.nodes.copy(), kept_dofs=self.kept_dofs.copy(),
            dof_node=self.dof_node.copy(), dof_kind=self.dof_kind.copy(), V=V, W=W,
            full_dof_kind=None if V is None else self.full_dof_kind,
            method="interpolated", settings=settings, source=source, invariants=inv,
            parameters={self.parameter: float(p)},
            static=None if self.static is None else StaticDeflection(
                **{key: mix(STATIC_PREFIX + key) for key in STATIC_KEYS if key != "residual"},
                residual=residual_bound(self.static.residual, w)),
        )

    # ------------------------------------------------------------------ file I/O


def bodies_stack(bodies: Sequence[ReducedBody], key: str) -> np.ndarray:
    """The (k, …) stack over reduced bodies of a :meth:`ParametricBody.slope_keys` key
    (``M`` …, ``invariants/<name>``, ``static/<key>``)."""
    if key.startswith(INVARIANT_PREFIX):
        return np.stack([np.asarray(b.invariants[key[len(INVARIANT_PREFIX):]]) for b in bodies])
    if key.startswith(STATIC_PREFIX):
        return np.stack([b.static[key[len(STATIC_PREFIX):]] for b in bodies])
    return np.stack([b[key] for b in bodies])


def model_sources(fes: Sequence[Any]) -> tuple[dict[str, Any], ...]:
    """``{"file", "fingerprint"}`` of each FE model (the :attr:`ParametricBody.slope_sources`
    of its slope models)."""
    return tuple({"file": fe.source, "fingerprint": fe.fingerprint} for fe in fes)


def hermite_kind(interpolation: str | None, slopes: bool) -> str:
    """The weights of a parametric body built with (``slopes``) or without models next to
    its samples: by default ``"quintic-hermite"`` (the models give the slopes and the
    curvatures, equations.md §4.2) or ``"cubic"``; with the models only Hermite weights.

    Raises
    ------
    DataError
        Weights without derivatives asked for with the models (naming ``interpolation``).
    """
    if interpolation is None:
        return "quintic-hermite" if slopes else "cubic"
    if slopes and interpolation not in HERMITE_ORDERS:
        raise DataError(f"the models next to the samples give Hermite weights "
                        f"({', '.join(HERMITE_ORDERS)}), not {interpolation!r}", None,
                        "interpolation")
    return interpolation


def checked_slope_step(step: Any) -> float:
    """The step of the models next to the samples, a positive finite number."""
    try:
        step = float(step)
    except (TypeError, ValueError):
        raise DataError(f"the slope step must be a number, got {step!r}", None,
                        "slope_step") from None
    if not (np.isfinite(step) and step > 0):
        raise DataError(f"the slope step must be a positive number, got {step!r}", None,
                        "slope_step")
    return step


def central_slopes(minus: Any, plus: Any, step: float, keys: Sequence[str]
                   ) -> dict[str, np.ndarray]:
    """Sample slopes by central differences (``docs/equations.md`` §4.2): per key
    ``(plus(key) − minus(key)) / (2 step)``, ``minus``/``plus`` giving the (k, …) stacks at
    the samples ∓ ``step`` (:meth:`ParametricBody.stack`, or :func:`bodies_stack` of
    their bodies); the residual of a static state gets no slope (zero).

    Raises
    ------
    DataError
        A step that is not a positive finite number.
    """
    step = checked_slope_step(step)
    return {key: (plus(key) - minus(key)) / (2.0 * step)
            * (0.0 if key == STATIC_PREFIX + "residual" else 1.0) for key in keys}


def central_curvatures(minus: Any, centre: Any, plus: Any, step: float,
                       keys: Sequence[str]) -> dict[str, np.ndarray]:
    """Sample curvatures by central second differences (``docs/equations.md`` §4.2): per
    key ``(plus(key) − 2 centre(key) + minus(key)) / step²`` (O(step²)), the stacks as in
    :func:`central_slopes` and ``centre`` those of the samples themselves, defined alike
    (the same projection); the residual of a static state gets none (zero).

    Raises
    ------
    DataError
        A step that is not a positive finite number.
    """
    step = checked_slope_step(step)
    return {key: (plus(key) - 2.0 * centre(key) + minus(key)) / step**2
            * (0.0 if key == STATIC_PREFIX + "residual" else 1.0) for key in keys}


def stacked_loss(bodies: Sequence[ReducedBody]) -> dict[str, Any]:
    """``{"G": (k, r, r), "loss_reference_frequency": f}`` of sample bodies that all carry
    a hysteretic matrix, ``{}`` when none does; a :class:`DataError` naming the sample when
    only some do or their reference frequencies differ."""
    has = [b.G is not None for b in bodies]
    if not any(has):
        return {}
    if not all(has):
        i = has.index(False)
        raise DataError(f"sample {i + 1} has no hysteretic matrix G, sample "
                        f"{has.index(True) + 1} has one (loss factors in some samples only)",
                        None, "G")
    f = {b.loss_reference_frequency for b in bodies}
    if len(f) != 1:
        raise DataError(f"the samples' loss reference frequencies differ: {sorted(f)} Hz",
                        None, "loss_reference_frequency")
    return {"G": np.stack([b.G for b in bodies]), "loss_reference_frequency": f.pop()}


def _check_stacked(inv: Mapping[str, np.ndarray], k: int) -> dict[str, np.ndarray]:
    out = {}
    for name, v in inv.items():
        a = np.asarray(v)
        item = f"invariants.{name}"
        if a.dtype == object:
            raise DataError("object arrays cannot be stored", None, item)
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


# ---------------------------------------------------------------------- interpolate
def body_label(labels: Sequence[str] | None, i: int) -> str:
    """``body i`` (1-based) and its label, for errors about the samples."""
    return f"body {i + 1}" + (f" ({labels[i]})" if labels is not None else "")


def check_samples(bodies: Sequence[ReducedBody], labels: Sequence[str] | None = None) -> None:
    """Refuse bodies that are not samples of one family (same FE discretization, DOFs, I/O);
    ``labels`` (e.g. the file names) name the bodies in the error."""
    ref = bodies[0]

    def fail(i: int, what: str) -> None:
        raise DataError(f"{body_label(labels, i)} does not match {body_label(labels, 0)}: {what}; "
                        "the samples of a "
                        "parametric body must be reductions of one FE discretization with "
                        "the same order, kept nodes, inputs and outputs", None,
                        f"bodies[{i}]")

    for i, b in enumerate(bodies[1:], start=1):
        if b.order != ref.order:
            fail(i, f"order {b.order} vs {ref.order} (T_i = Rᵀ V_i must be square)")
        if b.two_sided != ref.two_sided:
            fail(i, "one-sided vs two-sided data")
        for key in ("n_dofs", "kind", "density"):
            a, c = b.source.get(key), ref.source.get(key)
            if a is not None and c is not None and a != c:
                fail(i, f"source {key} {a!r} vs {c!r}")
        if b.input_names != ref.input_names or b.output_names != ref.output_names:
            fail(i, f"inputs/outputs {list(b.input_names)}/{list(b.output_names)} vs "
                    f"{list(ref.input_names)}/{list(ref.output_names)}")
        if not (np.array_equal(b.kept_dofs, ref.kept_dofs)
                and np.array_equal(b.dof_node, ref.dof_node)
                and np.array_equal(b.dof_kind, ref.dof_kind)):
            fail(i, "kept DOFs (index, node, kind) differ")
        if not np.array_equal(b.nodes, ref.nodes):
            fail(i, "kept node table (ids, coordinates) differs")
        if (b.invariants is None) != (ref.invariants is None):
            fail(i, "invariants present in one and not the other")
        if b.invariants is not None and list(b.invariants) != list(ref.invariants):
            fail(i, "different invariant arrays")
        if (b.full_dof_kind is not None and ref.full_dof_kind is not None
                and not np.array_equal(b.full_dof_kind, ref.full_dof_kind)):
            fail(i, "DOF kinds of the full bases (full_dof_kind) differ")
    prints = [b.source.get("fingerprint") for b in bodies]
    for i, fp in enumerate(prints):
        if fp is not None and fp in prints[:i]:
            j = prints.index(fp)
            raise DataError(f"{body_label(labels, j)} and {body_label(labels, i)} were "
                            "reduced from the same FE model "
                            f"(fingerprint {str(fp)[:12]}…): two samples of one model (the "
                            "same file given twice?)", None, f"bodies[{i}]")


def sample_values(bodies: Sequence[ReducedBody], samples: Sequence[float] | None,
                  parameter: str) -> np.ndarray:
    """The checked sample values: given, or recorded in the bodies' ``parameters``."""
    if samples is None:
        missing = [i + 1 for i, b in enumerate(bodies)
                   if not b.parameters or parameter not in b.parameters]
        if missing:
            raise DataError(f"no sample values given and bodies {missing} record no value "
                            f"of {parameter!r} in their parameters", None, "samples")
        samples = [b.parameters[parameter] for b in bodies]
    try:
        s = np.asarray(samples, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise DataError(f"must be numbers, got {samples!r}", None, "samples") from None
    if s.size != len(bodies):
        raise DataError(f"{s.size} sample values for {len(bodies)} bodies", None, "samples")
    if not np.all(np.isfinite(s)):
        raise DataError(f"must be finite, got {s.tolist()}", None, "samples")
    if np.any(np.diff(s) <= 0):
        raise DataError(f"must be strictly increasing (give the bodies in the order of the "
                        f"parameter), got {s.tolist()}", None, "samples")
    for i, b in enumerate(bodies):
        v = (b.parameters or {}).get(parameter)
        if v is not None and v != s[i]:
            raise DataError(f"body {i + 1} records {parameter} = {v:g}, but is given as the "
                            f"sample {s[i]:g}", None, "samples")
    return s


def coordinate_table(samples: Sequence[float], sigma: Sequence[float], xi: Sequence[float],
                     source: str | None = None) -> np.ndarray:
    """The (2, n) interpolation-coordinate table of :class:`ParametricBody` from a curve
    ``(σ_j, ξ_j)`` (e.g. ``static_curve.csv`` of ``neweul fem middle-ear --static-curve``):
    sorted, cut to the samples' range, the knots that match a sample within 1e-9 of the range
    set to it exactly.

    Raises
    ------
    DataError
        Curve and values of different lengths, a value that is not finite, a repeated
        ``σ``, a sample that is not on the curve (naming ``source``), or a table that
        :func:`~neweul_py.ffrf.parametric.coordinate_problem` refuses.
    """
    s = np.asarray(samples, dtype=np.float64)
    sig, val = np.asarray(sigma, dtype=np.float64), np.asarray(xi, dtype=np.float64)
    if sig.shape != val.shape or sig.ndim != 1:
        raise DataError(f"{sig.size} knots for {val.size} coordinate values", source,
                        "coordinate")
    if not (np.all(np.isfinite(sig)) and np.all(np.isfinite(val))):
        raise DataError("the curve holds a value that is not a finite number", source,
                        "coordinate")
    order = np.argsort(sig, kind="stable")
    sig, val = sig[order], val[order]
    if np.any(np.diff(sig) == 0):
        raise DataError("the curve repeats a parameter value", source, "coordinate")
    tol = 1e-9 * max(float(s[-1] - s[0]), 1e-300)
    keep = np.ones(sig.size, dtype=bool)
    for v in s:
        near = np.flatnonzero(np.abs(sig - v) <= tol)
        if not near.size:
            raise DataError(f"the sample {v:g} is not on the curve (it must hold every "
                            "sample value)", source, "coordinate")
        best = near[np.argmin(np.abs(sig[near] - v))]
        sig[best] = v                      # the sample exactly; its near-duplicates go
        keep[near[near != best]] = False
    keep &= (sig >= s[0]) & (sig <= s[-1])
    table = np.vstack([sig[keep], val[keep]])
    why = coordinate_problem(s, table)
    if why is not None:
        raise DataError(why, source, "coordinate")
    return table


# ---------------------------------------------------------------------- file format
def save_parametric_body(body: ParametricBody, path: str | os.PathLike) -> None:
    """Write ``body`` as a versioned ``.npz`` with embedded JSON metadata, atomically."""
    arrays = {key: body[key] for key in PARAMETRIC_ARRAYS}
    for key in PARAMETRIC_OPTIONAL:
        if body[key] is not None:
            arrays[key] = body[key]
    names = list(body.invariants or {})
    for name in names:
        arrays[INVARIANT_PREFIX + name] = body.invariants[name]
    if body.static is not None:
        arrays.update(body.static.to_arrays())
    for key, a in (body.slopes or {}).items():
        arrays[SLOPE_PREFIX + key] = a
    for key, a in (body.curvatures or {}).items():
        arrays[CURVATURE_PREFIX + key] = a
    meta = {
        "format": PARAMETRIC_BODY_FORMAT,
        "version": body.format_version,
        "parameter": body.parameter,
        "interpolation": body.interpolation,
        "basis": body.basis,
        "two_sided": body.two_sided,
        **({"row_scaling": body.row_scaling, "pressure_weight": body.pressure_weight}
           if body.format_version >= 2 else {}),
        "input_names": list(body.input_names),
        "output_names": list(body.output_names),
        "sample_sources": list(body.sample_sources),
        "sample_methods": list(body.sample_methods),
        "sample_settings": list(body.sample_settings),
        "invariants": names if body.invariants is not None else None,
        **({"loss_reference_frequency": body.loss_reference_frequency}
           if body.G is not None else {}),
        **({"coordinate_name": body.coordinate_name} if body.coordinate is not None else {}),
        **({"slope_step": body.slope_step, "slope_sources": list(body.slope_sources)}
           if body.slopes is not None else {}),
    }
    arrays["meta"] = json_to_uint8(meta)
    save_npz_atomic(path, arrays)


def is_parametric_body_file(path: str | os.PathLike) -> bool:
    """Whether ``path`` is a parametric-body file (its ``meta`` names the format); a
    :class:`DataError` for an unreadable file."""
    data = load_npz(path)
    if "meta" not in data:
        return False
    meta = json_from_uint8(data["meta"], str(path))
    return isinstance(meta, dict) and meta.get("format") == PARAMETRIC_BODY_FORMAT


def load_parametric_body(path: str | os.PathLike) -> ParametricBody:
    """Read a parametric body; a :class:`DataError` naming the file and array on any problem."""
    file = str(path)
    data = load_npz(path)
    if "meta" not in data:
        raise DataError("missing the \"meta\" array (not a parametric-body file?)", file,
                        "meta")
    meta = json_from_uint8(data["meta"], file)
    if not isinstance(meta, dict) or meta.get("format") != PARAMETRIC_BODY_FORMAT:
        got = meta.get("format") if isinstance(meta, dict) else None
        hint = " (a single reduced body: use load_reduced_body)" if got == "neweul-reduced-body" \
            else ""
        raise DataError(f"\"format\" must be {PARAMETRIC_BODY_FORMAT!r}, got {got!r}{hint}",
                        file, "meta")
    version = meta.get("version")
    if version not in READABLE_VERSIONS:
        raise DataError(f"unsupported version {version!r} (this reader: "
                        f"{', '.join(map(str, READABLE_VERSIONS))})", file, "meta")
    extra = [key for key in ("row_scale", "left_row_scale", "full_dof_kind") if key in data]
    if version == 1 and extra:
        raise DataError(f"a version-1 file holds no {extra}", file, extra[0])
    if version < COORDINATE_VERSION and "coordinate" in data:
        raise DataError(f"a version-{version} file holds no interpolation coordinate", file,
                        "coordinate")
    slopes = {key[len(SLOPE_PREFIX):]: a for key, a in data.items()
              if key.startswith(SLOPE_PREFIX)}
    if version < SLOPES_VERSION and slopes:
        raise DataError(f"a version-{version} file holds no sample slopes", file,
                        SLOPE_PREFIX + next(iter(slopes)))
    curvatures = {key[len(CURVATURE_PREFIX):]: a for key, a in data.items()
                  if key.startswith(CURVATURE_PREFIX)}
    if version < CURVATURES_VERSION and curvatures:
        raise DataError(f"a version-{version} file holds no sample curvatures", file,
                        CURVATURE_PREFIX + next(iter(curvatures)))
    missing = [key for key in PARAMETRIC_ARRAYS if key not in data]
    if missing:
        raise DataError(f"missing arrays {missing}", file, missing[0])
    names = meta.get("invariants")
    invariants = None
    if names is not None:
        absent = [n for n in names if INVARIANT_PREFIX + n not in data]
        if absent:
            raise DataError(f"missing invariant arrays {absent}", file, "invariants")
        invariants = {n: data[INVARIANT_PREFIX + n] for n in names}
    try:
        return ParametricBody(
            **{key: data[key] for key in PARAMETRIC_ARRAYS},
            **{key: data.get(key) for key in PARAMETRIC_OPTIONAL},
            parameter=meta.get("parameter", ""),
            interpolation=meta.get("interpolation", "linear"),
            basis=meta.get("basis", ""),
            two_sided=bool(meta.get("two_sided", True)),
            row_scaling=meta.get("row_scaling", "none") if version >= 2 else "none",
            pressure_weight=meta.get("pressure_weight") if version >= 2 else None,
            input_names=tuple(meta.get("input_names", ())),
            output_names=tuple(meta.get("output_names", ())),
            sample_sources=tuple(meta.get("sample_sources") or ()),
            sample_methods=tuple(meta.get("sample_methods") or ()),
            sample_settings=tuple(meta.get("sample_settings") or ()),
            invariants=invariants,
            static=static_from_arrays(data, file),
            format_version=int(meta["version"]),
            loss_reference_frequency=meta.get("loss_reference_frequency"),
            coordinate_name=meta.get("coordinate_name", "") if version >= 3 else "",
            slopes=slopes or None,
            curvatures=curvatures or None,
            slope_step=meta.get("slope_step"),
            slope_sources=tuple(meta.get("slope_sources") or ()),
        )
    except DataError as exc:
        raise DataError(exc.message, file, exc.item) from None
    except (TypeError, ValueError) as exc:
        raise DataError(f"inconsistent arrays ({' '.join(str(exc).split())})", file,
                        "meta") from None
