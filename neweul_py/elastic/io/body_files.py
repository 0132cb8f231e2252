"""Body files: the reduced-body and parametric-body ``.npz`` formats.

The formats are documented in ``docs/reduced-body-format.md``.

One uncompressed ``.npz`` per body (read with ``allow_pickle=False``) holding the arrays and,
as the ``uint8`` array ``meta``, the UTF-8 JSON metadata; written atomically, so a reader never
sees a partial body. Every problem is one :class:`~neweul_py.errors.DataError` naming the file
and the array or metadata field.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

import numpy as np

from ...errors import DataError
from ..bodies.parametric import (
    COMPACT_VERSION,
    COORDINATE_VERSION,
    CURVATURE_PREFIX,
    CURVATURES_VERSION,
    MIRROR_VERSION,
    READABLE_VERSIONS,
    SLOPE_PREFIX,
    SLOPES_VERSION,
    ParametricBody,
)
from ..bodies.parametric_format import SINGLE_KEYS, SINGLE_VERSION
from ..bodies.reduced import (
    INVARIANT_PREFIX,
    REDUCED_BODY_VERSION,
    SHARED_INVARIANTS,
    ReducedBody,
)
from ..bodies.static import STATIC_KEYS, STATIC_PREFIX, StaticDeflection
from .layout import MIRROR_SUFFIX, VALUES_SUFFIX, pack, unpack
from .npz import json_from_uint8, json_to_uint8, load_npz, save_npz_atomic

__all__ = [
    "META_FIELDS",
    "PARAMETRIC_ARRAYS",
    "PARAMETRIC_BODY_FORMAT",
    "PARAMETRIC_OPTIONAL",
    "REDUCED_ARRAYS",
    "REDUCED_BODY_FORMAT",
    "REDUCED_OPTIONAL",
    "check_member_types",
    "check_metadata",
    "is_parametric_body_file",
    "load_parametric_body",
    "load_reduced_body",
    "save_parametric_body",
    "save_reduced_body",
    "static_from_arrays",
]


REDUCED_BODY_FORMAT = "neweul-reduced-body"
#: The version this writer writes (2: the compact layout); the reader reads 1 and 2.
REDUCED_FILE_VERSION = 2
REDUCED_READABLE = (1, 2)
REDUCED_ARRAYS = ("M", "D", "K", "B", "C", "nodes", "kept_dofs", "dof_node", "dof_kind", "V_kept",
           "W_kept")
REDUCED_OPTIONAL = ("V", "W", "eigenvalues", "full_dof_kind", "G")

def save_reduced_body(body: ReducedBody, path: str | os.PathLike) -> None:
    """Write ``body`` as a versioned ``.npz`` with embedded JSON metadata, atomically, in the
    compact layout (:mod:`~neweul_py.elastic.io.layout`: no zero array, no array twice)."""
    arrays = {key: body[key] for key in REDUCED_ARRAYS}
    arrays["dof_kind"] = body.dof_kind.astype("U2")
    for key in REDUCED_OPTIONAL:
        if body[key] is not None:
            arrays[key] = body[key]
    names = list(body.invariants or {})
    for name in names:
        arrays[INVARIANT_PREFIX + name] = body.invariants[name]
    if body.static is not None:
        arrays.update(body.static.to_arrays())
    stored, layout = pack(arrays, frozenset(), 1)
    meta = {
        "format": REDUCED_BODY_FORMAT,
        "version": REDUCED_FILE_VERSION,
        "method": body.method,
        "settings": body.settings,
        "input_names": list(body.input_names),
        "output_names": list(body.output_names),
        "source": body.source,
        "parameters": body.parameters,
        "invariants": names if body.invariants is not None else None,
        "layout": layout,
        **({"loss_reference_frequency": body.loss_reference_frequency}
           if body.G is not None else {}),
    }
    stored["meta"] = json_to_uint8(meta)
    save_npz_atomic(path, stored)


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
    if meta.get("version") not in REDUCED_READABLE:
        raise DataError(f"unsupported version {meta.get('version')!r} (this reader: "
                        f"{', '.join(map(str, REDUCED_READABLE))})", file, "meta")
    check_member_types(data, False, file)
    if meta["version"] >= 2:
        data = unpack(data, meta.get("layout"), 1, file)
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
            format_version=REDUCED_BODY_VERSION,
            loss_reference_frequency=meta.get("loss_reference_frequency"),
        )
    except DataError as exc:
        raise DataError(exc.message, file, exc.item) from None

PARAMETRIC_BODY_FORMAT = "neweul-parametric-body"
PARAMETRIC_ARRAYS = ("samples", "M", "D", "K", "B", "C", "nodes", "kept_dofs", "dof_node",
                     "dof_kind", "V_kept", "W_kept", "T", "L", "R", "singular_values",
                     "svd_weights")
PARAMETRIC_OPTIONAL = ("V", "W", "row_scale", "left_row_scale", "full_dof_kind", "G",
                       "coordinate")
#: Arrays of a parametric body that are not stacked over the samples.
UNSTACKED = frozenset({"samples", "nodes", "kept_dofs", "dof_node", "dof_kind", "R",
                       "singular_values", "svd_weights", "row_scale", "left_row_scale",
                       "full_dof_kind", "coordinate"})
#: The version this writer writes (9: the compact layout with the stacks' varying entries,
#: their mirrored ones, the varying entries of the matrices' slopes and curvatures in single
#: precision, every optional group); the reader reads 1 to 9.
PARAMETRIC_FILE_VERSION = SINGLE_VERSION
#: The stacks whose varying entries a version-9 file holds in single precision (the slopes
#: and curvatures of :data:`SINGLE_KEYS`), and their members.
SINGLE_STACKS = frozenset(prefix + key for key in SINGLE_KEYS
                          for prefix in (SLOPE_PREFIX, CURVATURE_PREFIX))
SINGLE_MEMBERS = frozenset(key + VALUES_SUFFIX for key in SINGLE_STACKS)


# ---------------------------------------------------------------------- file format
def save_parametric_body(body: ParametricBody, path: str | os.PathLike) -> None:
    """Write ``body`` as a versioned ``.npz`` with embedded JSON metadata, atomically, in the
    compact layout (:mod:`~neweul_py.elastic.io.layout`: what does not vary over the samples
    once, of a stack only the entries that vary, no zero array — the slopes of what does not
    vary —, no array twice)."""
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
    stacked = frozenset(key for key in arrays if key not in UNSTACKED)
    # a slope's or curvature's entries are on the scale of the values over the range
    span = float(body.samples[-1] - body.samples[0])
    reference = {prefix + key: (key, span ** -order) for key in arrays
                 for order, prefix in ((1, SLOPE_PREFIX), (2, CURVATURE_PREFIX))
                 if prefix + key in arrays}
    # a damping that is the loss factors' at the reference frequency, D = G/ω_ref
    scaled = ({prefix + "D": (prefix + "G", 1.0 / (2.0 * np.pi * body.loss_reference_frequency))
               for prefix in ("", SLOPE_PREFIX, CURVATURE_PREFIX)}
              if body.G is not None else {})
    # the slopes and curvatures carry their central differences' error, far above 2⁻²⁴
    stored, layout = pack(arrays, stacked, body.n_samples, reference, scaled=scaled,
                          single=SINGLE_STACKS)
    meta = {
        "format": PARAMETRIC_BODY_FORMAT,
        "version": PARAMETRIC_FILE_VERSION,
        "parameter": body.parameter,
        "interpolation": body.interpolation,
        "basis": body.basis,
        "two_sided": body.two_sided,
        "row_scaling": body.row_scaling,
        "pressure_weight": body.pressure_weight,
        "input_names": list(body.input_names),
        "output_names": list(body.output_names),
        "sample_sources": list(body.sample_sources),
        "sample_methods": list(body.sample_methods),
        "sample_settings": list(body.sample_settings),
        "invariants": names if body.invariants is not None else None,
        "layout": layout,
        **({"loss_reference_frequency": body.loss_reference_frequency}
           if body.G is not None else {}),
        **({"coordinate_name": body.coordinate_name} if body.coordinate is not None else {}),
        **({"slope_step": body.slope_step, "slope_sources": list(body.slope_sources)}
           if body.slopes is not None else {}),
    }
    stored["meta"] = json_to_uint8(meta)
    save_npz_atomic(path, stored)


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
    mirrored = next((key for key in data if key.endswith(MIRROR_SUFFIX)), None)
    if version < MIRROR_VERSION and mirrored:
        raise DataError(f"a version-{version} file holds no mirrored entries", file, mirrored)
    check_member_types(data, version >= SINGLE_VERSION, file)
    if version >= COMPACT_VERSION:
        samples = data.get("samples")
        k = int(samples.size) if isinstance(samples, np.ndarray) and samples.ndim == 1 else 0
        data = unpack(data, meta.get("layout"), k, file)
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

#: The members of a body file that hold whole numbers, strings, and bits
#: (docs/reduced-body-format.md); the matrices, bases and vectors of :data:`REAL_MEMBERS`
#: (their slopes, curvatures and stored parts alike) hold float64 numbers.
WHOLE_MEMBERS = frozenset({"kept_dofs", "dof_node"})
TEXT_MEMBERS = frozenset({"dof_kind", "full_dof_kind"})
BIT_SUFFIXES = ("@mask", "@mirror", "@nonzero")
REAL_MEMBERS = frozenset({"M", "D", "K", "G", "B", "C", "V_kept", "W_kept", "T", "L", "R",
                          "V", "W", "samples", "singular_values", "svd_weights", "nodes",
                          "row_scale", "left_row_scale", "coordinate", "eigenvalues"})


def _real(a: np.ndarray, itemsize: int) -> bool:
    """Whether ``a`` holds real floats of ``itemsize`` bytes, in either byte order."""
    return a.dtype.kind == "f" and a.dtype.itemsize == itemsize


def check_member_types(data: Mapping[str, np.ndarray], single: bool, file: str) -> None:
    """Each member of a body file has the type its format gives it: ``meta`` and the bit
    members ``uint8``, the DOF numbers integers, the DOF kinds strings, the rest float64 —
    or float32 for :data:`SINGLE_MEMBERS` when ``single`` (a parametric file of version 9
    or later). A :class:`DataError` naming the array otherwise: a bool, integer or text
    matrix is not converted. The invariants and the static group are checked where they
    are read."""
    for key, a in data.items():
        name = key.removeprefix(SLOPE_PREFIX).removeprefix(CURVATURE_PREFIX).split("@")[0]
        if key == "meta" or key.endswith(BIT_SUFFIXES):
            ok, what = a.dtype == np.uint8, "uint8"
        elif key in WHOLE_MEMBERS:
            ok, what = a.dtype.kind in "iu" or _real(a, 8), "integers"
        elif key in TEXT_MEMBERS:
            ok, what = a.dtype.kind in "US", "strings"
        elif key in SINGLE_MEMBERS:
            ok = _real(a, 8) or (single and _real(a, 4))
            what = "float64" + (" or float32" if single else
                                f" (float32 from version {SINGLE_VERSION} of the format)")
        elif name in REAL_MEMBERS:
            ok, what = _real(a, 8), "float64"
        else:
            continue
        if not ok:
            raise DataError(f"is {a.dtype}; the format holds {what} here", file, key)


def static_from_arrays(data: Mapping[str, np.ndarray], file: str | None = None
                       ) -> StaticDeflection | None:
    """The ``static/*`` group of a body file's arrays, ``None`` if it has none; a
    :class:`DataError` naming the file when the group is incomplete."""
    present = [key for key in STATIC_KEYS if STATIC_PREFIX + key in data]
    if not present:
        return None
    missing = [key for key in STATIC_KEYS if key not in present]
    if missing:
        raise DataError(f"the static group lacks {[STATIC_PREFIX + m for m in missing]}",
                        file, STATIC_PREFIX + missing[0])
    try:
        return StaticDeflection(*(data[STATIC_PREFIX + key] for key in STATIC_KEYS))
    except DataError as exc:
        raise DataError(exc.message, file, exc.item) from None
