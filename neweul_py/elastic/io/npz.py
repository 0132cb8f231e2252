"""Small file helpers shared by the FE-model and reduced-body formats.

* atomic writes: data go to a temporary file in the target directory, are flushed and
  fsync'ed, and then replace the target with :func:`os.replace` (atomic on POSIX and
  Windows), so an interrupted write never leaves a partial file behind;
* JSON metadata stored *inside* an ``.npz`` as a ``uint8`` array (UTF-8 bytes), so a single
  file carries arrays and metadata and ``numpy.load(..., allow_pickle=False)`` reads both.
"""

from __future__ import annotations

import io
import json
import os
import zipfile
import zlib
from collections.abc import Mapping
from typing import Any

import numpy as np

from ...atomic import atomic_savez, atomic_write
from ...errors import DataError
from ...files import check_npz, check_regular_file

__all__ = [
    "atomic_write",
    "json_from_uint8",
    "json_to_uint8",
    "load_npz",
    "save_npz_atomic",
]


#: First bytes of a zip archive (local file header; empty archive: end of central directory).
_ZIP_MAGIC = (b"PK\x03\x04", b"PK\x05\x06")


def json_to_uint8(obj: Any) -> np.ndarray:
    """Encode a JSON-serializable object as a ``uint8`` array of UTF-8 bytes."""
    text = json.dumps(obj, sort_keys=True, allow_nan=False)
    return np.frombuffer(text.encode("utf-8"), dtype=np.uint8).copy()


def json_from_uint8(arr: np.ndarray, file: str | None = None, item: str = "meta") -> Any:
    """Decode :func:`json_to_uint8`; a :class:`DataError` naming ``file`` on failure."""
    if arr.dtype != np.uint8 or arr.ndim != 1:
        raise DataError("metadata must be a 1-D uint8 array of UTF-8 JSON", file, item)
    try:
        return json.loads(arr.tobytes().decode("utf-8"))
    except RecursionError:
        raise DataError("metadata is nested too deeply", file, item) from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise DataError(f"metadata is not valid UTF-8 JSON ({exc})", file, item) from None


def save_npz_atomic(path: str | os.PathLike, arrays: Mapping[str, np.ndarray]) -> None:
    """Save ``arrays`` as an uncompressed ``.npz`` atomically (no object arrays, no pickles)."""
    atomic_savez(path, **arrays)


def load_npz(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """Load every array of an ``.npz`` with ``allow_pickle=False`` into a dict.

    Raises
    ------
    DataError
        The file is missing, not an ``.npz``, holds pickled objects, or an array of dates,
        durations or records (naming it).
    """
    check_regular_file(path, "file")  # a FIFO or /dev/zero is refused before it is opened
    try:
        with open(path, "rb") as fh:
            magic = fh.read(4)
    except FileNotFoundError:
        raise DataError("file not found", str(path)) from None
    except OSError as exc:
        raise DataError(f"cannot read ({exc.strerror or exc})", str(path)) from None
    if magic not in _ZIP_MAGIC:  # np.load would try .npy / pickle and say "pickled data"
        raise DataError("not a valid .npz file (not a zip archive)", str(path))
    check_npz(path)  # a zip bomb or a forged array header is refused before loading
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {key: data[key] for key in data.files}
    except FileNotFoundError:
        raise DataError("file not found", str(path)) from None
    except (zipfile.BadZipFile, OSError, EOFError, MemoryError) as exc:
        raise DataError(f"not a readable .npz file ({exc})", str(path)) from None
    except ValueError as exc:  # object arrays refuse to load without pickles
        raise DataError(f"unreadable array ({exc})", str(path)) from None
    for key, arr in arrays.items():     # dates, durations and records are no data of ours
        if arr.dtype.kind in "mMV":
            raise DataError(f"array {key!r} has dtype {arr.dtype}, not numbers", str(path),
                            key)
    return arrays


#: Time stamp of every member of a :func:`save_npz_deterministic` archive (the zip epoch).
_ZIP_EPOCH = (1980, 1, 1, 0, 0, 0)


def save_npz_deterministic(path: str | os.PathLike, arrays: Mapping[str, np.ndarray],
                           min_ratio: float | None = 2.0) -> None:
    """Save ``arrays`` as an ``.npz`` atomically, byte for byte the same for the same arrays.

    :func:`numpy.savez` stamps each member with the time of writing; here every member carries
    the zip epoch and the members follow the order of ``arrays``. A member is deflated (level
    6) where that shrinks it by ``min_ratio`` at least and stored otherwise (all are stored for
    ``None``): with the default 2, the indices of sparse matrices, DOF maps and zero states
    (3–300×) are deflated and large arrays of matrix values (1.6×) stored, whose inflating
    would cost a reader more time than it saves space. The ratio is judged by the fastest
    deflate (level 1, a third of the time of level 6 and within 1.5× of its size), so that
    only what is deflated is deflated at level 6. Object arrays are refused (no pickles).
    The file reads with :func:`numpy.load` like any ``.npz``.
    """
    members = {}
    for key, value in arrays.items():
        value = np.asarray(value)
        if value.dtype == object:
            raise TypeError(f"array {key!r} has dtype object; it would need pickling")
        buffer = io.BytesIO()
        np.lib.format.write_array(buffer, value, allow_pickle=False)
        raw = buffer.getvalue()
        small = min_ratio is not None and min_ratio * len(zlib.compress(raw, 1)) <= len(raw)
        members[f"{key}.npy"] = (raw, zipfile.ZIP_DEFLATED if small else zipfile.ZIP_STORED)

    def write(fh) -> None:
        with zipfile.ZipFile(fh, "w", allowZip64=True) as zf:
            for name, (raw, method) in members.items():
                info = zipfile.ZipInfo(name, date_time=_ZIP_EPOCH)
                info.compress_type = method
                info.external_attr = 0o644 << 16
                zf.writestr(info, raw, compress_type=method, compresslevel=6)

    atomic_write(path, write)
