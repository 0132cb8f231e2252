"""What a valid parametric body is: its format versions, vocabularies and validator.

The constants name the versions of the parametric-body format
(``docs/reduced-body-format.md``), the weight functions, bases and row scalings of
:class:`~neweul_py.elastic.bodies.parametric.ParametricBody`, and
:func:`validate_parametric` is its one validator: the shared fields of every body
(:func:`~neweul_py.elastic.bodies.fields.check_body_fields`, stacked over the samples), then
what only a parametric body has — the samples, the common subspace and transformations, the
row scaling, the interpolation coordinate (``docs/equations.md`` §4.1), the sample slopes and
curvatures (§4.2) and where they came from.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ...errors import DataError
from ...ffrf.parametric import HERMITE_ORDERS, coordinate_problem, weight_polynomials
from .fields import CARRIED_INVARIANTS, check_body_fields, checked_dof_kinds, real_array
from .reduced import INVARIANT_PREFIX, json_normal
from .static import STATIC_PREFIX

__all__ = [
    "BASES",
    "COMPACT_VERSION",
    "COORDINATE_VERSION",
    "CURVATURES_VERSION",
    "CURVATURE_PREFIX",
    "GROUP_ORDER",
    "INTERPOLATIONS",
    "KIND_GROUPS",
    "MIRROR_VERSION",
    "PARAMETRIC_BODY_VERSION",
    "READABLE_VERSIONS",
    "SINGLE_KEYS",
    "SINGLE_VERSION",
    "SLOPES_VERSION",
    "SLOPE_PREFIX",
    "STACKED",
    "VARYING_VERSION",
    "checked_slope_step",
    "validate_parametric",
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
#: Version 6 (the compact layout of docs/reduced-body-format.md) holds every optional group;
#: version 7 adds the layout's ``varying`` rule (a stack's base and the entries that vary),
#: version 8 its mirrored entries (``<key>@mirror``: of a stack of square matrices, the
#: varying entries below the diagonal that are their transposed entry's), version 9 the
#: varying entries of the slopes and curvatures of ``M``, ``D``, ``K``, ``G`` in single
#: precision (``SINGLE_KEYS``).
COMPACT_VERSION = 6
VARYING_VERSION = 7
MIRROR_VERSION = 8
SINGLE_VERSION = 9
READABLE_VERSIONS = (1, 2, 3, 4, 5, 6, 7, 8, 9)
#: The matrices whose slopes and curvatures a version-9 file may hold in single precision.
SINGLE_KEYS = ("M", "D", "K", "G")
#: Weight functions of :meth:`ParametricBody.at
#: <neweul_py.elastic.bodies.parametric.ParametricBody.at>`.
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
#: Quantities interpolated in :meth:`ParametricBody.at
#: <neweul_py.elastic.bodies.parametric.ParametricBody.at>` (stacked over the samples).
STACKED = ("M", "D", "K", "B", "C", "V_kept", "W_kept")


def validate_parametric(body: Any) -> None:
    """Check and normalize a :class:`~neweul_py.elastic.bodies.parametric.ParametricBody`
    under construction (frozen: fields are set in place); a :class:`DataError` naming the
    field on the first problem. Versions 3–5 mean "has a coordinate / slopes / curvatures":
    ``format_version`` follows what the body holds."""
    set_ = object.__setattr__
    set_(body, "parameter", str(body.parameter))
    if not body.parameter:
        raise DataError("the parameter needs a name", None, "parameter")
    s = real_array(body.samples, "samples", ndim=1)
    if s.size < 2:
        raise DataError(f"need at least 2 samples, got {s.size}", None, "samples")
    if np.any(np.diff(s) <= 0):
        raise DataError(f"samples must be strictly increasing, got {s.tolist()}", None,
                        "samples")
    set_(body, "samples", s)
    k = s.size
    r = check_body_fields(body, k)
    for key in ("T", "L"):
        set_(body, key, real_array(body[key], key, (k, r, r)))
    if (body.V is None) != (body.W is None):
        raise DataError("V and W are stored together or not at all", None, "V")
    R = real_array(body.R, "R", ndim=2)
    if R.shape[1] != r:
        raise DataError(f"must have {r} columns, got {R.shape}", None, "R")
    set_(body, "R", R)
    set_(body, "singular_values", real_array(body.singular_values, "singular_values", ndim=1))
    set_(body, "svd_weights", real_array(body.svd_weights, "svd_weights", (k,)))
    if body.basis not in BASES[1:]:
        raise DataError(f"must be one of {BASES[1:]}, got {body.basis!r}", None, "basis")
    if body.interpolation not in INTERPOLATIONS:
        raise DataError(f"must be one of {INTERPOLATIONS}, got {body.interpolation!r}",
                        None, "interpolation")
    _check_coordinate(body)
    set_(body, "two_sided", bool(body.two_sided))
    _check_row_scaling(body, R.shape[0])
    for key, default in (("sample_sources", {}), ("sample_settings", {}),
                         ("sample_methods", "")):
        vals = tuple(body[key]) or (default,) * k
        if len(vals) != k:
            raise DataError(f"{len(vals)} entries for {k} samples", None, key)
        set_(body, key, tuple(str(v) for v in vals) if key == "sample_methods"
             else tuple(json_normal(dict(v), key) for v in vals))
    _check_slopes(body)


def _check_coordinate(body: Any) -> None:
    """The interpolation coordinate ``ξ(σ)`` (§4.1): a table the samples fit
    (:func:`~neweul_py.ffrf.parametric.coordinate_problem`), cubic or Hermite weights, a
    name; ``format_version`` 3 exactly when there is one (unless a later version)."""
    set_ = object.__setattr__
    if not isinstance(body.coordinate_name, str):
        raise DataError(f"must be a string, got {body.coordinate_name!r}", None,
                        "coordinate_name")
    if body.coordinate is None:
        if body.coordinate_name:
            raise DataError("a coordinate name without a coordinate table", None,
                            "coordinate_name")
        if body.format_version == COORDINATE_VERSION:   # version 3 means "has one"
            set_(body, "format_version", PARAMETRIC_BODY_VERSION)
        return
    why = coordinate_problem(body.samples, body.coordinate)
    if why is not None:
        raise DataError(why, None, "coordinate")
    if body.interpolation not in ("cubic", *HERMITE_ORDERS):
        raise DataError("an interpolation coordinate needs cubic or Hermite weights, got "
                        f"{body.interpolation!r}", None, "coordinate")
    if not body.coordinate_name:
        raise DataError("an interpolation coordinate needs a name (what ξ is)", None,
                        "coordinate_name")
    set_(body, "coordinate", np.array(body.coordinate, dtype=np.float64))
    try:
        weight_polynomials(body.samples, body.interpolation, body.coordinate)
    except ValueError as exc:
        raise DataError(str(exc), None, "coordinate") from None
    if body.format_version < COORDINATE_VERSION:
        set_(body, "format_version", COORDINATE_VERSION)


def _check_row_scaling(body: Any, n_rows: int) -> None:
    """The format version, the row scaling of the SVD (``row_scale``, ``left_row_scale``:
    one positive factor per row of ``R``; ``pressure_weight`` of a ``"kind"`` scaling) and
    the DOF kinds of the FE rows."""
    set_ = object.__setattr__
    if body.format_version not in READABLE_VERSIONS:
        raise DataError(f"unsupported version {body.format_version!r} (this reader: "
                        f"{', '.join(map(str, READABLE_VERSIONS))})", None, "format_version")
    if body.row_scaling not in ("none", "kind", "given"):
        raise DataError(f"must be 'none', 'kind' or 'given', got {body.row_scaling!r}",
                        None, "row_scaling")
    if body.row_scaling == "none":
        if body.row_scale is not None or body.left_row_scale is not None:
            raise DataError("row_scaling 'none' stores no row_scale", None, "row_scale")
    elif body.row_scale is None:
        raise DataError(f"row_scaling {body.row_scaling!r} needs row_scale", None,
                        "row_scale")
    for key in ("row_scale", "left_row_scale"):
        if body[key] is not None:
            sc = real_array(body[key], key, ndim=1)
            if sc.shape != (n_rows,) or np.any(sc <= 0):
                raise DataError(f"must be {n_rows} positive factors (one per row of R), "
                                f"got shape {sc.shape}", None, key)
            set_(body, key, sc)
    if body.pressure_weight is not None:
        pw = float(body.pressure_weight)
        if body.row_scaling != "kind" or not (np.isfinite(pw) and pw > 0):
            raise DataError(f"a positive pressure weight of a 'kind' scaling, got {pw!r} "
                            f"with row_scaling {body.row_scaling!r}", None, "pressure_weight")
        set_(body, "pressure_weight", pw)
    if body.full_dof_kind is not None:
        rows = {key: body[key].shape[1] for key in ("V", "W") if body[key] is not None}
        if body.basis == "full":
            rows["R"] = n_rows
        set_(body, "full_dof_kind", checked_dof_kinds(body.full_dof_kind, rows))
    if body.format_version == 1 and (body.row_scaling != "none"
                                     or body.full_dof_kind is not None
                                     or body.pressure_weight is not None):
        raise DataError("format version 1 holds no row scaling or full_dof_kind", None,
                        "format_version")


def _check_slopes(body: Any) -> None:
    """Hermite weights and their data come together (``hermite``: the sample slopes;
    ``quintic-hermite``: slopes and curvatures, §4.2); ``format_version`` 4 or 5 exactly
    when the body has them."""
    set_ = object.__setattr__
    need = HERMITE_ORDERS.get(body.interpolation, 0)
    have = (body.slopes is not None) + (body.curvatures is not None)
    if body.curvatures is not None and body.slopes is None:
        raise DataError("sample curvatures (curvature/*) without sample slopes (slope/*)",
                        None, "interpolation")
    if need != have:
        given = {0: "no sample slopes", 1: "sample slopes (slope/*)",
                 2: "sample slopes and curvatures (slope/*, curvature/*)"}[have]
        raise DataError(f"Hermite weights and their data come together (hermite: the "
                        f"sample slopes; quintic-hermite: the slopes and curvatures): "
                        f"interpolation {body.interpolation!r} with {given}", None,
                        "interpolation")
    _check_slope_provenance(body)
    if body.slopes is None:
        if body.format_version in (SLOPES_VERSION, CURVATURES_VERSION):
            set_(body, "format_version", COORDINATE_VERSION if body.coordinate is not None
                 else PARAMETRIC_BODY_VERSION)      # versions 4, 5 mean "has them"
        return
    set_(body, "slopes", _checked_derivatives(body, body.slopes, SLOPE_PREFIX, "slope"))
    if body.curvatures is None:
        set_(body, "format_version", SLOPES_VERSION)
        return
    set_(body, "curvatures", _checked_derivatives(body, body.curvatures, CURVATURE_PREFIX,
                                                  "curvature"))
    set_(body, "format_version", CURVATURES_VERSION)


def _check_slope_provenance(body: Any) -> None:
    """``slope_step``: a positive finite number or ``None``; ``slope_sources``: none or
    ``2k`` mappings; both only with slopes."""
    sources = tuple(body.slope_sources or ())
    if body.slopes is None and (body.slope_step is not None or sources):
        raise DataError("a slope step or slope sources without sample slopes", None,
                        "slope_step" if body.slope_step is not None else "slope_sources")
    if body.slope_step is not None:
        object.__setattr__(body, "slope_step", checked_slope_step(body.slope_step))
    if sources and (len(sources) != 2 * body.samples.size
                    or not all(isinstance(x, Mapping) for x in sources)):
        raise DataError(f"must be {2 * body.samples.size} mappings (the models at every "
                        f"sample − step, then + step), got {len(sources)}", None,
                        "slope_sources")
    object.__setattr__(body, "slope_sources", tuple(dict(x) for x in sources))


def _checked_derivatives(body: Any, given: Any, prefix: str, what: str
                         ) -> dict[str, np.ndarray]:
    """The sample slopes or curvatures, checked: a mapping of every
    :meth:`~neweul_py.elastic.bodies.parametric.ParametricBody.slope_keys` key to a finite
    real array of its stack's shape, zero for the static residual and for the values common
    to all samples."""
    if not isinstance(given, Mapping):
        raise DataError(f"must be a mapping key → (k, …) array, got "
                        f"{type(given).__name__}", None, prefix.rstrip("/") + "s")
    want = body.slope_keys()
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
        shape = body.stack(key).shape
        if a.dtype.kind not in "fi" or a.shape != shape:
            raise DataError(f"must be real of shape {shape}, got {a.dtype} {a.shape}",
                            None, prefix + key)
        a = a.astype(np.float64)
        if not np.all(np.isfinite(a)):
            raise DataError("holds a value that is not a finite number", None,
                            prefix + key)
        out[key] = a
    if body.static is not None and np.any(out[STATIC_PREFIX + "residual"]):
        raise DataError(f"the {what} of a residual is not stored (must be zero)", None,
                        f"{prefix}{STATIC_PREFIX}residual")
    for name in CARRIED_INVARIANTS:
        key = INVARIANT_PREFIX + name
        if key in out and np.any(out[key]):
            raise DataError(f"the {what} of a value common to all samples is zero", None,
                            prefix + key)
    return out


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
