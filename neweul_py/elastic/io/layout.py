"""The compact array layout of body files: what a file stores of each array.

A body file (``docs/reduced-body-format.md``, "Compact layout") stores every array once and
no array it can reconstruct exactly. Three rules, applied by :func:`pack` and undone by
:func:`unpack`, each recorded in the file's metadata (``layout``):

* ``zero`` — an all-zero floating-point array is not stored; the metadata keep its shape and
  dtype (e.g. the moving-frame invariants of a body on a fixed frame, the slopes of what does
  not vary over the samples);
* ``constant`` — a stack over the ``k`` samples whose samples are all equal (bit for bit) is
  stored as its one sample, without the sample axis (e.g. a global basis's node rows, the
  identity transformations ``T``, ``L`` of one global basis);
* ``same`` — an array equal (bit for bit, and by the same rule) to one stored before it is
  not stored again; the metadata name that array (e.g. the invariants ``Me.m0``, ``Ke.m0`` of
  a body, which are its own projected ``M``, ``K``).

Reading gives the arrays back as read-only views: a ``constant`` stack is
:func:`numpy.broadcast_to` of its sample (one copy in memory, however many samples), a
``zero`` array a broadcast zero, a ``same`` array the array it names. The layout is exact:
``unpack(*pack(a)) == a`` bit for bit.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping
from typing import Any

import numpy as np

from ...errors import DataError

__all__ = ["LAYOUT_KEYS", "pack", "unpack"]

#: The keys of the metadata's ``layout`` object.
LAYOUT_KEYS = ("zero", "constant", "same")


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


def pack(arrays: Mapping[str, Any], stacked: frozenset[str] | set[str], k: int
         ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """The arrays to store and the ``layout`` metadata of ``arrays`` (module docstring).

    Parameters
    ----------
    arrays
        ``key → array`` to write.
    stacked
        The keys whose first axis is the ``k`` samples (candidates for ``constant``).
    k
        Number of samples (1 for a body without samples).

    Returns
    -------
    tuple
        ``(stored, layout)``: the arrays to write and ``{"zero": {key: [shape, dtype]},
        "constant": [key, …], "same": {key: stored key}}``.
    """
    stored: dict[str, np.ndarray] = {}
    layout: dict[str, Any] = {"zero": {}, "constant": [], "same": {}}
    seen: dict[tuple[str, bool], str] = {}
    for key, value in arrays.items():
        a = np.asarray(value)
        if a.dtype.kind in "fc" and a.size and not np.any(a):
            layout["zero"][key] = [list(a.shape), a.dtype.str]
            continue
        const = key in stacked and _constant(a, k)
        if const:
            a = a[0]
        tag = (_digest(a), const)
        first = seen.get(tag)
        if first is not None and np.array_equal(stored[first], a):
            layout["same"][key] = first
            continue
        if const:
            layout["constant"].append(key)
        seen[tag] = key
        stored[key] = a if a.flags.c_contiguous else a.copy(order="C")
    return stored, layout


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
    zero, constant, same = (layout.get(key) or ({} if key != "constant" else [])
                            for key in LAYOUT_KEYS)
    if not (isinstance(zero, Mapping) and isinstance(same, Mapping)
            and isinstance(constant, list) and all(isinstance(c, str) for c in constant)):
        raise DataError("layout: zero and same are objects, constant a list of names", file,
                        "meta.layout")
    out = dict(data)
    for key in constant:
        if key not in out:
            raise DataError(f"layout names the constant array {key!r}, which the file lacks",
                            file, key)
        out[key] = np.broadcast_to(out[key], (k, *out[key].shape))
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
