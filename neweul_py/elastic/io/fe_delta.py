"""FE files stored as the difference from a base file (``neweul-fe`` version 2).

The working points of a pressure sweep share their mesh, DOF maps and sparsity patterns, and
most matrix entries (air, ossicles) do not depend on the working point: only the prestressed
rows of the membrane change. A *delta* file stores one model as what differs from a complete
*base* file (``docs/fe-file-format.md``):

* the ``meta`` array (JSON) names the base, ``"base": {"file": …, "sha256": …, "drop": […]}``:
  its file name relative to the delta's directory (``name.npz`` or ``../dir/name.npz``), the
  SHA-256 of its bytes and the names of the base's arrays the model does not have;
* an array equal to the base's (same dtype, shape and bytes) is left out;
* a 1-D array that differs from the base's in a few entries is stored as the pair
  ``patch.pos.<name>`` (positions, int32 where they fit) and ``patch.val.<name>`` (the values
  at those positions, in the array's dtype), compared bit for bit;
* any other array is stored whole.

Reading applies the same rules backwards, so the arrays (and the model) read from a delta
equal the ones written bit for bit. A base is always a complete file (no chains). A missing
base, a base whose SHA-256 differs from the recorded one, or a delta whose patches do not fit
its base is one :class:`~neweul_py.errors.DataError` naming the delta and the base.
"""

from __future__ import annotations

import hashlib
import io
import os
import re
import zipfile
from collections.abc import Mapping
from pathlib import Path, PurePosixPath
from typing import Any

import numpy as np

from ...errors import DataError
from ...files import MAX_DATA_BYTES, check_npz, read_checked
from .npz import json_from_uint8, json_to_uint8, save_npz_deterministic

__all__ = ["PATCH_POS", "PATCH_VAL", "base_name", "check_base", "delta_arrays",
           "merge_delta", "write_fe_arrays"]

#: Prefixes of the two arrays of a patched array ``<name>`` in a delta file.
PATCH_POS, PATCH_VAL = "patch.pos.", "patch.val."
_HEX64 = re.compile(r"[0-9a-f]{64}")
#: Smallest gain for which a member of a complete file is deflated: indices and DOF maps are,
#: large arrays of matrix values (1.6×: inflating them would slow every read) are not.
COMPLETE_RATIO = 2.0
#: The same for a delta file, whose members are small: everything that shrinks by a fifth.
DELTA_RATIO = 1.25


def base_name(delta: str | os.PathLike, base: str | os.PathLike) -> str:
    """The name of ``base`` relative to the directory of ``delta``: ``name.npz`` (same
    directory) or ``../dir/name.npz`` (a sibling directory).

    Raises
    ------
    DataError
        ``base`` is elsewhere (naming both files).
    """
    d, b = Path(os.path.abspath(Path(delta).parent)), Path(os.path.abspath(base))
    if b.parent == d:
        return b.name
    if b.parent.parent == d.parent:
        return f"../{b.parent.name}/{b.name}"
    raise DataError(f"the base {base} must be in the same directory or in a sibling directory",
                    str(delta), "base")


def _identical(a: np.ndarray, b: np.ndarray) -> bool:
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def _changed(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Positions where the 1-D arrays ``a`` and ``b`` (same dtype and size) differ bit for
    bit (so ``-0.0`` and ``0.0``, or two NaNs of other payloads, count as different)."""
    width = a.dtype.itemsize
    ra = np.ascontiguousarray(a).view(np.uint8).reshape(a.size, width)
    rb = np.ascontiguousarray(b).view(np.uint8).reshape(b.size, width)
    return np.flatnonzero(np.any(ra != rb, axis=1))


def delta_arrays(arrays: Mapping[str, np.ndarray], base: Mapping[str, np.ndarray]
                 ) -> tuple[dict[str, np.ndarray], list[str]]:
    """The arrays of a delta file holding ``arrays`` against ``base`` (module docstring), and
    the names of the base's arrays that ``arrays`` lacks. ``meta`` is always stored."""
    out: dict[str, np.ndarray] = {}
    for key, value in arrays.items():
        value = np.asarray(value)
        old = base.get(key)
        if key != "meta" and old is not None and _identical(value, old):
            continue
        if (key != "meta" and old is not None and value.ndim == 1 and old.ndim == 1
                and value.dtype == old.dtype and value.size == old.size
                and value.dtype.kind in "biuf"):
            pos = _changed(value, old)
            index = np.int32 if value.size < 2**31 else np.int64
            if pos.size * (np.dtype(index).itemsize + value.dtype.itemsize) < value.nbytes:
                out[PATCH_POS + key] = pos.astype(index)
                out[PATCH_VAL + key] = value[pos]
                continue
        out[key] = value
    return out, sorted(set(base) - set(arrays))


def write_fe_arrays(path: str | os.PathLike, arrays: Mapping[str, np.ndarray],
                    base: str | os.PathLike | None = None) -> None:
    """Write the arrays of an ``.npz`` FE file (deterministic, atomic; members deflated where
    that pays: :data:`COMPLETE_RATIO`, :data:`DELTA_RATIO`), complete or, with ``base`` (a
    complete FE file), as a delta of it.

    Raises
    ------
    DataError
        ``base`` is not a complete FE file in the same or a sibling directory.
    """
    if base is None:
        save_npz_deterministic(path, arrays, COMPLETE_RATIO)
        return
    name = base_name(path, base)
    if os.path.abspath(path) == os.path.abspath(base):
        raise DataError("a file cannot be the base of itself", str(path), "base")
    digest, ref = _read_base(Path(base), str(path))
    meta = json_from_uint8(arrays["meta"], str(path))
    stored, drop = delta_arrays(arrays, ref)
    meta["base"] = {"file": name, "sha256": digest, "drop": drop}
    stored["meta"] = json_to_uint8(meta)
    save_npz_deterministic(path, stored, DELTA_RATIO)


def check_base(base: str | os.PathLike, delta: str | os.PathLike) -> None:
    """Refuse ``base`` as the base of the future file ``delta`` before any work: not in the
    same or a sibling directory, missing, unreadable, or itself a delta file.

    Raises
    ------
    DataError
        Naming the file at fault.
    """
    base_name(delta, base)
    _read_base(Path(base), str(delta))


#: The arrays of the last base read, by its SHA-256. A sweep writes and reads dozens of
#: deltas of one base: hashing its bytes is a fraction of parsing them.
_LAST_BASE: dict[str, dict[str, np.ndarray]] = {}


def _read_base(base: Path, delta: str) -> tuple[str, dict[str, np.ndarray]]:
    """The SHA-256 (hex) and the arrays (read-only, kept between calls: a caller that hands
    them on copies them) of the base ``base`` of ``delta`` (a complete file); its bytes are
    parsed again only when their hash differs from the last base's."""
    if not base.exists():
        raise DataError(f"its base {base} is missing (this file holds only what differs from "
                        "it)", delta, "base")
    raw = read_checked(base, "base FE file", MAX_DATA_BYTES)
    digest = hashlib.sha256(raw).hexdigest()
    if digest not in _LAST_BASE:
        arrays = _parse_base(raw, base, delta)
        for value in arrays.values():
            value.setflags(write=False)
        _LAST_BASE.clear()
        _LAST_BASE[digest] = arrays
    return digest, dict(_LAST_BASE[digest])


def _parse_base(raw: bytes, base: Path, delta: str) -> dict[str, np.ndarray]:
    """The arrays of the base file ``base`` from its bytes ``raw`` (checked: a complete FE
    file)."""
    buffer = io.BytesIO(raw)
    check_npz(buffer, file=str(base))
    buffer.seek(0)
    try:
        with np.load(buffer, allow_pickle=False) as data:
            arrays = {key: data[key] for key in data.files}
    except (zipfile.BadZipFile, OSError, EOFError, ValueError, MemoryError) as exc:
        raise DataError(f"not a readable .npz file ({exc})", str(base)) from None
    meta = json_from_uint8(arrays["meta"], str(base)) if "meta" in arrays else None
    if not isinstance(meta, dict):
        raise DataError("the base of a delta must be an FE file with a \"meta\" object",
                        str(base), "meta")
    if "base" in meta:
        raise DataError(f"the base of {delta} is itself a delta file (a base must be "
                        "complete)", str(base), "base")
    return arrays


def _record(meta: Mapping[str, Any], file: str) -> tuple[str, str, list[str]]:
    """``(file, sha256, drop)`` of a delta's ``base`` record, checked."""
    rec = meta["base"]
    if not isinstance(rec, dict) or set(rec) != {"file", "sha256", "drop"}:
        raise DataError("must be an object with \"file\", \"sha256\" and \"drop\"", file,
                        "meta.base")
    name, digest, drop = rec["file"], rec["sha256"], rec["drop"]
    parts = PurePosixPath(name).parts if isinstance(name, str) else ()
    sibling = len(parts) == 3 and parts[0] == ".." and parts[1] not in ("", ".", "..")
    if not (isinstance(name, str) and name.endswith(".npz") and "\\" not in name
            and (len(parts) == 1 or sibling) and parts[-1] not in (".", "..")
            and "\0" not in name):
        raise DataError(f"the base must be a .npz file name in the same directory or in a "
                        f"sibling one (\"name.npz\" or \"../dir/name.npz\"), got {name!r}", file,
                        "meta.base.file")
    if not (isinstance(digest, str) and _HEX64.fullmatch(digest)):
        raise DataError(f"must be 64 lower-case hex digits, got {digest!r}", file,
                        "meta.base.sha256")
    if not (isinstance(drop, list) and all(isinstance(k, str) for k in drop)):
        raise DataError("must be a list of array names", file, "meta.base.drop")
    return name, digest, drop


def merge_delta(path: str | os.PathLike, data: Mapping[str, np.ndarray],
                meta: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """The arrays of the delta file ``path`` (its arrays ``data``, its decoded ``meta`` with
    the ``base`` record) merged with its base's: equal to the arrays written, bit for bit,
    ``meta`` without the record (module docstring) — the arrays of the complete file.

    Raises
    ------
    DataError
        The base is missing, unreadable, changed since the delta was written (SHA-256) or
        itself a delta; the record is malformed; a patch does not fit the base.
    """
    path = Path(path)
    file = str(path)
    name, digest, drop = _record(meta, file)
    base = Path(os.path.normpath(path.parent / name))
    actual, arrays = _read_base(base, file)
    if actual != digest:
        raise DataError(f"its base {base} has changed since it was written (SHA-256 "
                        f"{actual[:16]}…, recorded {digest[:16]}…): this file holds only what "
                        "differs from that base; rewrite both together", file, "base")
    for key in drop:
        if key not in arrays:
            raise DataError(f"drops the array {key!r}, which its base {base} does not have",
                            file, "meta.base.drop")
        del arrays[key]
    for key, value in data.items():
        if key.startswith(PATCH_VAL):
            continue
        if key.startswith(PATCH_POS):
            target = key[len(PATCH_POS):]
            arrays[target] = _patched(arrays.get(target), value, data.get(PATCH_VAL + target),
                                      target, file, base)
        else:
            arrays[key] = value
    for key in data:
        if key.startswith(PATCH_VAL) and PATCH_POS + key[len(PATCH_VAL):] not in data:
            raise DataError("a patch without positions", file, key)
    arrays["meta"] = json_to_uint8({k: v for k, v in meta.items() if k != "base"})
    # the base's arrays the delta keeps as they are are read-only and shared: the model's own
    return {key: value if value.flags.writeable else value.copy()
            for key, value in arrays.items()}


def _patched(old: np.ndarray | None, pos: np.ndarray, val: np.ndarray | None, key: str,
             file: str, base: Path) -> np.ndarray:
    """``old`` with ``val`` at the positions ``pos``; one error naming the delta and the base
    when the patch does not fit."""
    if old is None:
        raise DataError(f"patches an array its base {base} does not have", file, key)
    if val is None:
        raise DataError("a patch without values", file, PATCH_VAL + key)
    if (old.ndim != 1 or pos.ndim != 1 or val.ndim != 1 or pos.dtype.kind not in "iu"
            or val.dtype != old.dtype or pos.size != val.size):
        raise DataError(f"the patch (positions {pos.dtype} {pos.shape}, values {val.dtype} "
                        f"{val.shape}) does not fit the array of its base {base} "
                        f"({old.dtype} {old.shape})", file, key)
    if pos.size and (pos.min() < 0 or pos.max() >= old.size):
        raise DataError(f"patch positions outside 0 … {old.size - 1} of the array of its base "
                        f"{base}", file, key)
    out = old.copy()
    out[pos] = val
    return out
