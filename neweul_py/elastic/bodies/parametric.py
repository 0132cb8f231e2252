"""Parametric elastic bodies: samples, interpolation weights, file (``docs/equations.md`` §4).

A :class:`ParametricBody` holds ``k`` samples ``X̃_i`` of a reduced body in common coordinates
at the sample values ``p_1 < … < p_k`` of its parameter, and :meth:`ParametricBody.at`
interpolates ``X(p) = Σ_i w_i(p) X̃_i`` — every stored quantity with the same weights (§4,
step 6), which sum to one: linear, the cubic spline's cardinal functions (in an
interpolation coordinate ``ξ(p)`` if the body has one, §4.1), or the cubic or quintic
Hermite bases with the samples' slopes and curvatures (§4.2), all from
:mod:`neweul_py.ffrf.parametric` (one home, the generated module uses the same). Two
builders make the samples: :func:`~neweul_py.elastic.parametric.local_interpolation.interpolate`
(Panzer et al. 2010, the local bodies brought to common coordinates) and
:func:`~neweul_py.elastic.parametric.global_basis.global_parametric_body` (one global basis). This
module also holds what both share — the checks of the samples, their stacked loss data, the
central differences of the slopes and curvatures, the coordinate table — and the file format
(``docs/reduced-body-format.md``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...errors import DataError
from ...ffrf.parametric import HERMITE_ORDERS, coordinate_problem, ffrf_weights, weight_polynomials
from ..fe_model import loss_reference
from .reduced import INVARIANT_PREFIX, ReducedBody, json_normal
from .static import STATIC_KEYS, STATIC_PREFIX, StaticDeflection, residual_bound

__all__ = [
    "BASES",
    "CARRIED_INVARIANTS",
    "COMPACT_VERSION",
    "COORDINATE_VERSION",
    "CURVATURES_VERSION",
    "CURVATURE_PREFIX",
    "GROUP_ORDER",
    "INTERPOLATIONS",
    "KIND_GROUPS",
    "PARAMETRIC_BODY_VERSION",
    "READABLE_VERSIONS",
    "SLOPES_VERSION",
    "SLOPE_PREFIX",
    "STACKED",
    "ParametricBody",
    "checked_slope_step",
]


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
#: Version 6 (the compact layout of docs/reduced-body-format.md) holds every optional group.
COMPACT_VERSION = 6
READABLE_VERSIONS = (1, 2, 3, 4, 5, 6)
#: Weight functions of :meth:`ParametricBody.at`.
INTERPOLATIONS = ("linear", "cubic", *HERMITE_ORDERS)
#: Rows of the bases that determine the common subspace
#: (:mod:`~neweul_py.elastic.parametric.local_interpolation`).
BASES = ("auto", "full", "kept")
#: DOF kind → group sharing one row-scaling factor, in the order of normalization.
KIND_GROUPS = {"ux": "translation", "uy": "translation", "uz": "translation",
               "rx": "rotation", "ry": "rotation", "rz": "rotation", "p": "pressure"}
GROUP_ORDER = ("translation", "rotation", "pressure")
SLOPE_PREFIX = "slope/"
CURVATURE_PREFIX = "curvature/"
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
    :class:`~neweul_py.elastic.bodies.reduced.ReducedBody` at a parameter value. ``k`` =
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
        (:class:`~neweul_py.elastic.bodies.static.StaticDeflection`, stacked; ``q`` in the
        common coordinates), mixed by :meth:`at` with the same weights (the residual: the
        largest of the samples mixed).
    slopes
        Optional sample slopes ``dX/dσ`` at every sample (``docs/equations.md`` §4.2), the
        data of ``hermite`` weights (present exactly when :attr:`interpolation` is
        ``"hermite"``): ``key → (k, …)`` for every interpolated stack — ``M``,
        ``D``, ``K``, ``B``, ``C``, ``V_kept``, ``W_kept`` (and ``G``, ``V``, ``W`` when
        stored), ``invariants/<name>`` for the floating-point invariants and
        ``static/<key>`` for the static state (``static/residual`` zero) — each of the shape
        of its stack
        (:func:`~neweul_py.elastic.parametric.global_basis.global_parametric_body` makes
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
        (:func:`~neweul_py.elastic.bodies.static.residual_bound`).

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
