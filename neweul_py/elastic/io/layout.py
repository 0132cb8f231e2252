"""The compact array layout of body files: what a file stores of each array.

A body file (``docs/reduced-body-format.md``, "Compact layout") stores every array once and
no array it can reconstruct. Six rules, applied by :func:`pack` and undone by
:func:`unpack`, each recorded in the file's metadata (``layout``):

* ``zero`` — an all-zero floating-point array is not stored; the metadata keep its shape and
  dtype (e.g. the moving-frame invariants of a body on a fixed frame, the slopes of what does
  not vary over the samples);
* ``constant`` — a stack over the ``k`` samples whose samples are all equal is stored as its
  one sample, without the sample axis (e.g. a global basis's node rows, the identity
  transformations ``T``, ``L`` of one global basis);
* ``varying`` — a floating-point stack over the samples of which only some entries vary is
  stored as its base (the entries that do not vary, of one sample's shape) and the entries
  that do, ``<key>@mask`` (which: one bit per entry of a sample in C order,
  :func:`numpy.packbits`) and ``<key>@values`` (k, nv), the one encoding
  of :mod:`neweul_py.ffrf.varying` (e.g. the membrane's rows of ``K``, ``D``, ``G`` and the
  coupling block of ``M`` of the middle ear, whose air blocks are the same in every
  sample); of a stack of square matrices, the varying entries below the diagonal that equal
  their transposed entry within the tolerance are not stored but named by
  ``<key>@mirror`` (one bit per entry; version 8); the ``@values`` of the stacks named
  ``single`` (a parametric body's slopes and curvatures of ``M``, ``D``, ``K``, ``G``;
  version 9) are stored in single precision when each entry is then within ``2⁻²⁴`` of
  itself (no overflow, no subnormal);
* ``scaled`` — a stack that is a given factor times another one (within the tolerance below)
  is not stored; the metadata name the other and the factor (e.g. the ``D = G/ω_ref`` of a
  body whose damping is its loss factors' at the reference frequency);
* ``sparse`` (files with samples) — a floating-point matrix (or array of more axes) stored
  as its nonzero entries
  and ``<key>@nonzero`` (one bit per entry, :func:`numpy.packbits`) when that is smaller by
  a tenth (e.g. the common basis ``R`` of a u–p body, whose pressure rows are zero in the
  structural columns; the base of a ``varying`` stack); zeros read back as ``+0``;
* ``same`` — an array equal (bit for bit) to one stored before it is not stored again; the
  metadata name that array (e.g. the invariants ``Me.m0``, ``Ke.m0`` of a body, which are
  its own projected ``M``, ``K``).

``constant`` and ``varying`` take an entry as the same in every sample when no sample
deviates from the first by more than ``tolerance`` (``layout.tolerance``, default
:data:`~neweul_py.ffrf.varying.VARYING_TOLERANCE` = 1e-13) times the entry's scale
(:func:`~neweul_py.ffrf.varying.entry_scale`: for matrices the smaller of its row's and
its column's largest magnitude over the samples); for the slopes and curvatures of a stack
(``reference``) the scale is the values' divided by the sampled range, or its square.
``scaled`` applies when the factor times the other array, as read back, is within the same
bound. So what a file drops is bounded entry by entry: ``|X̂_s − X_s| ≤ tolerance · scale``.
The other rules are exact.

Reading gives the arrays back: a ``scaled`` stack as the factor times the other, a
``constant`` stack as a read-only
:func:`numpy.broadcast_to` of its sample (one copy in memory, however many samples), a
``zero`` array a broadcast zero, a ``same`` array the array it names, a ``varying`` stack in
full (:func:`~neweul_py.ffrf.varying.ffrf_expand`).
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping
from typing import Any

import numpy as np

from ...errors import DataError
from ...ffrf.varying import (
    VARYING_TOLERANCE,
    entry_scale,
    ffrf_expand,
    mirror_varying,
    split_varying,
)

__all__ = ["LAYOUT_KEYS", "MASK_SUFFIX", "MIRROR_SUFFIX", "NONZERO_SUFFIX", "SINGLE_ROUNDING",
           "VALUES_SUFFIX", "pack", "unpack"]

#: The keys of the metadata's ``layout`` object.
LAYOUT_KEYS = ("zero", "constant", "same", "varying", "scaled", "sparse", "tolerance")
#: The largest relative rounding error of a value stored in single precision (``2⁻²⁴``).
SINGLE_ROUNDING = 2.0**-24
#: The members of a ``varying`` stack besides its base (stored under its own key).
MASK_SUFFIX = "@mask"
#: The member of a ``sparse`` array besides its nonzero values (stored under its own key).
NONZERO_SUFFIX = "@nonzero"
VALUES_SUFFIX = "@values"
#: The member of a ``varying`` stack of square matrices naming the entries below the
#: diagonal that are their transposed entry's (:func:`~neweul_py.ffrf.varying.mirror_varying`).
MIRROR_SUFFIX = "@mirror"


def _digest(a: np.ndarray) -> str:
    h = hashlib.sha256(f"{a.dtype.str}{a.shape}".encode())
    h.update(a.tobytes())
    return h.hexdigest()


def _constant(a: np.ndarray, k: int) -> bool:
    """Whether ``a`` is a stack over ``k > 1`` samples whose samples are all equal."""
    if k < 2 or a.ndim < 1 or a.shape[0] != k:
        return False
    if a.strides[0] == 0:             # a broadcast view: equal by construction
        return True
    return all(np.array_equal(a[0], a[i]) for i in range(1, k))


def pack(arrays: Mapping[str, Any], stacked: frozenset[str] | set[str], k: int,
         reference: Mapping[str, tuple[str, float]] | None = None,
         tol: float = VARYING_TOLERANCE,
         scaled: Mapping[str, tuple[str, float]] | None = None,
         single: frozenset[str] | set[str] = frozenset()
         ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """The arrays to store and the ``layout`` metadata of ``arrays`` (module docstring).

    Parameters
    ----------
    arrays
        ``key → array`` to write.
    stacked
        The keys whose first axis is the ``k`` samples (candidates for ``constant`` and
        ``varying``).
    k
        Number of samples (1 for a body without samples).
    reference
        ``key → (values key, factor)``: the scale of the entries of ``key`` (a slope or a
        curvature) is ``factor`` times that of the entries of ``values key``; the others
        take their own.
    tol
        The relative tolerance of ``constant``, ``varying`` and ``scaled`` (``0``: exact).
    scaled
        ``key → (other key, factor)``: candidates for ``scaled`` (``key`` is not stored when
        ``factor`` times ``other`` as read back is ``key`` within the tolerance).
    single
        Keys whose ``varying`` values are stored in single precision (``float32``: each
        entry rounded to nearest, relative error at most ``2⁻²⁴``); decided after the other
        rules, which compare the values in double precision.

    Returns
    -------
    tuple
        ``(stored, layout)``: the arrays to write and ``{"zero": {key: [shape, dtype]},
        "constant": [key, …], "same": {key: stored key}, "varying": [key, …],
        "tolerance": tol}``.
    """
    stored: dict[str, np.ndarray] = {}
    layout: dict[str, Any] = {"zero": {}, "constant": [], "same": {}, "varying": [],
                              "scaled": {}, "tolerance": float(tol)}
    seen: dict[str, list[str]] = {}
    reference = reference or {}
    for key, value in arrays.items():
        a = np.asarray(value)
        if a.dtype.kind in "fc" and a.size and not np.any(a):
            layout["zero"][key] = [list(a.shape), a.dtype.str]
            continue
        tag = _digest(a)
        first = next((f for f in seen.get(tag, ()) if np.array_equal(arrays[f], a)), None)
        if first is not None:
            layout["same"][key] = first
            continue
        seen.setdefault(tag, []).append(key)
        if key in stacked and a.dtype.kind == "f" and a.ndim and k > 1 and a.shape[0] == k \
                and a.strides[0] != 0:
            ref, factor = reference.get(key, (key, 1.0))
            scale = factor * entry_scale(np.asarray(arrays[ref]))
            base, index, values = split_varying(a, scale, tol=tol)
            if not index.size:
                layout["constant"].append(key)
                stored[key] = base
                continue
            members = {}
            if a.ndim == 3 and a.shape[1] == a.shape[2] > 1:     # square: mirrored entries
                allowed = tol * np.broadcast_to(scale, a.shape[1:]).reshape(-1)
                index, values, mirror = mirror_varying(index, values, [(0, a.shape[1])],
                                                       allowed)
                if mirror.size:
                    members[MIRROR_SUFFIX] = _bits(mirror[0], base.size)
            members = {"": base, MASK_SUFFIX: _bits(index, base.size),
                       VALUES_SUFFIX: values, **members}
            if sum(m.nbytes for m in members.values()) < a.nbytes:
                layout["varying"].append(key)
                stored.update({key + suffix: m for suffix, m in members.items()})
                continue
        elif key in stacked and _constant(a, k):
            layout["constant"].append(key)
            a = a[0]
        stored[key] = a if a.flags.c_contiguous else a.copy(order="C")
    for key, (other, factor) in (scaled or {}).items():
        if key not in stored or other not in stored or other in layout["scaled"]:
            continue
        a = np.asarray(arrays[key])
        approx = float(factor) * _read_back(stored, layout, other, k)
        ref, ref_factor = reference.get(key, (key, 1.0))
        if approx.shape == a.shape and np.all(
                np.abs(a - approx) <= tol * ref_factor * entry_scale(np.asarray(arrays[ref]))):
            for member in (key, key + MASK_SUFFIX, key + VALUES_SUFFIX, key + MIRROR_SUFFIX):
                stored.pop(member, None)
            for rule in ("constant", "varying"):
                if key in layout[rule]:
                    layout[rule].remove(key)
            layout["scaled"][key] = [other, float(factor)]
    for key in layout["varying"]:
        if key in single:
            values = stored[key + VALUES_SUFFIX]
            with np.errstate(over="ignore"):
                narrow = values.astype(np.float32)
            # kept in double precision where single would overflow or lose relative digits
            if np.all(np.abs(narrow - values) <= SINGLE_ROUNDING * np.abs(values)):
                stored[key + VALUES_SUFFIX] = narrow
    if k == 1:                      # no samples: the layout of a reduced body (version 2)
        del layout["varying"], layout["scaled"], layout["tolerance"]
        return stored, layout
    layout["sparse"] = {}
    for key in list(stored):
        a = stored[key]
        if MASK_SUFFIX in key or VALUES_SUFFIX in key or a.dtype.kind != "f" or a.ndim < 2:
            continue
        nonzero = a.reshape(-1) != 0
        mask = np.packbits(nonzero)
        if mask.nbytes + 8 * int(nonzero.sum()) < 0.9 * a.nbytes:
            stored[key] = np.ascontiguousarray(a.reshape(-1)[nonzero])
            stored[key + NONZERO_SUFFIX] = mask
            layout["sparse"][key] = list(a.shape)
    return stored, layout


def _bits(index: np.ndarray, size: int) -> np.ndarray:
    """One bit per entry of ``size`` entries, set at ``index`` (:func:`numpy.packbits`)."""
    mask = np.zeros(size, dtype=bool)
    mask[index] = True
    return np.packbits(mask)


def _read_back(stored: dict[str, np.ndarray], layout: dict[str, Any], key: str, k: int
               ) -> np.ndarray:
    """The array ``key`` as :func:`unpack` gives it back from ``stored``."""
    if key in layout["varying"]:
        return _expanded(dict(stored), key, k, None)
    if key in layout["constant"]:
        return np.broadcast_to(stored[key], (k, *stored[key].shape))
    return stored[key]


def unpack(data: Mapping[str, np.ndarray], layout: Any, k: int, file: str | None = None
           ) -> dict[str, np.ndarray]:
    """The arrays of a file written with :func:`pack` (module docstring).

    Raises
    ------
    DataError
        A ``layout`` that is not of the documented form, or names an array the file lacks.
    """
    if layout is None:
        return dict(data)
    if not isinstance(layout, Mapping) or set(layout) - set(LAYOUT_KEYS):
        raise DataError(f"layout must be an object with the keys {list(LAYOUT_KEYS)}", file,
                        "meta.layout")
    zero, same = (layout.get(key) or {} for key in ("zero", "same"))
    constant, varying = (layout.get(key) or [] for key in ("constant", "varying"))
    if not (isinstance(zero, Mapping) and isinstance(same, Mapping)
            and all(isinstance(c, list) and all(isinstance(n, str) for n in c)
                    for c in (constant, varying))):
        raise DataError("layout: zero and same are objects, constant and varying lists of "
                        "names", file, "meta.layout")
    out = dict(data)
    sparse = layout.get("sparse") or {}
    if not isinstance(sparse, Mapping):
        raise DataError("layout: sparse is an object", file, "meta.layout")
    for key, shape in sparse.items():
        out[key] = _dense(out, key, shape, file)
    for key in constant:
        if key not in out:
            raise DataError(f"layout names the constant array {key!r}, which the file lacks",
                            file, key)
        out[key] = np.broadcast_to(out[key], (k, *out[key].shape))
    for key in varying:
        out[key] = _expanded(out, key, k, file)
    stray = next((key for key in out if key.endswith(MIRROR_SUFFIX)), None)
    if stray is not None:
        raise DataError(f"{stray!r} belongs to no varying array of the layout", file, stray)
    scaled = layout.get("scaled") or {}
    if not isinstance(scaled, Mapping):
        raise DataError("layout: scaled is an object", file, "meta.layout")
    for key, spec in scaled.items():
        try:
            other, factor = spec
            out[key] = float(factor) * out[other]
        except (TypeError, ValueError, KeyError):
            raise DataError(f"layout: the scaled array {key!r} needs [stored key, factor], got "
                            f"{str(spec)[:60]!r}", file, key) from None
    for key, first in same.items():
        if not isinstance(first, str) or first not in out:
            raise DataError(f"layout: {key!r} is the same as {first!r}, which the file lacks",
                            file, key)
        out[key] = out[first]
    for key, spec in zero.items():
        try:
            shape, dtype = tuple(int(n) for n in spec[0]), np.dtype(spec[1])
            if dtype.kind not in "fc" or any(n < 0 for n in shape):
                raise ValueError
            np.broadcast_to(np.zeros((), dtype), shape)     # a shape NumPy can represent
        except (TypeError, ValueError, IndexError, OverflowError):
            raise DataError(f"layout: the zero array {key!r} needs [shape, float dtype], got "
                            f"{str(spec)[:60]!r}", file, key) from None
        out[key] = np.broadcast_to(np.zeros((), dtype), shape)
    return out


def _expanded(data: dict[str, np.ndarray], key: str, k: int, file: str | None) -> np.ndarray:
    """The ``varying`` stack ``key`` of ``data`` in full; its members are removed."""
    bits = data.pop(key + MIRROR_SUFFIX, None)
    parts = [data.pop(key + suffix, None) for suffix in ("", MASK_SUFFIX, VALUES_SUFFIX)]
    if any(p is None for p in parts):
        raise DataError(f"layout names the varying array {key!r}, whose members {key!r}, "
                        f"{key + MASK_SUFFIX!r} and {key + VALUES_SUFFIX!r} the file lacks",
                        file, key)
    base, mask, values = parts
    index = (np.flatnonzero(np.unpackbits(mask, count=base.size))
             if mask.dtype == np.uint8 and mask.ndim == 1 and mask.size == -(-base.size // 8)
             else None)
    if not (base.dtype.kind == "f" and index is not None and values.dtype.kind == "f"
            and values.shape == (k, index.size)):
        raise DataError(f"the varying array {key!r} needs a float base, a mask of one bit per "
                        f"entry and ({k}, entries that vary) values, got {base.dtype} "
                        f"{base.shape}, {mask.dtype} {mask.shape}, {values.dtype} "
                        f"{values.shape}", file, key)
    return ffrf_expand(base, np.ones(k), index, values,
                       None if bits is None else _mirror(bits, base, index, key, file))


def _mirror(bits: np.ndarray, base: np.ndarray, index: np.ndarray, key: str,
            file: str | None) -> np.ndarray:
    """``mirror`` (2, m) of a square stack from its member ``<key>@mirror``: the entries
    ``[i, j]``, ``i > j``, that are set from ``[j, i]`` (a varying entry; ``index``)."""
    n = base.shape[-1] if base.ndim == 2 else 0
    dst = (np.flatnonzero(np.unpackbits(bits, count=base.size))
           if bits.dtype == np.uint8 and bits.ndim == 1 and bits.size == -(-base.size // 8)
           and base.ndim == 2 and base.shape[0] == n else None)
    src = None if dst is None else dst % n * n + dst // n
    if (dst is None or np.any(dst // n <= dst % n) or np.any(np.isin(dst, index))
            or not np.all(np.isin(src, index))):
        raise DataError(f"the varying array {key!r}: {key + MIRROR_SUFFIX!r} needs one bit per "
                        "entry of a square matrix, set below its diagonal only where the "
                        "transposed entry varies and the entry itself is not stored", file, key)
    return np.vstack([dst, src])


def _dense(data: dict[str, np.ndarray], key: str, shape: Any, file: str | None) -> np.ndarray:
    """The ``sparse`` array ``key`` of ``data`` in full; its mask member is removed."""
    values, mask = data.get(key), data.pop(key + NONZERO_SUFFIX, None)
    try:
        shape = tuple(int(n) for n in shape)
        size = int(np.prod(shape, dtype=np.int64))
        if (values is None or mask is None or min(shape, default=0) < 0
                or mask.dtype != np.uint8 or mask.shape != (-(-size // 8),)):
            raise ValueError
        index = np.flatnonzero(np.unpackbits(mask, count=size))
        if values.dtype.kind != "f" or values.shape != index.shape:
            raise ValueError
    except (TypeError, ValueError):
        raise DataError(f"the sparse array {key!r} needs its shape, its nonzero values and "
                        f"{key + NONZERO_SUFFIX!r} (one bit per entry)", file, key) from None
    out = np.zeros(shape, dtype=values.dtype)
    out.reshape(-1)[index] = values
    return out
