"""Files validated before use, shared by every layer (like :mod:`neweul_py.errors`).

Every file a command reads — a description, an elastic ``data:`` file, an FE model, a SID file,
a reduced body, an ``.npz`` — goes through :func:`check_regular_file` (or :func:`read_checked`,
which checks and reads from the *same* open file descriptor) first: it must be a regular file
(``/dev/zero``, a FIFO, a directory or a socket is refused at once instead of filling memory or
blocking for ever) of at most a documented size, and a zip archive (``.npz``) must declare no
more than :data:`MAX_NPZ_BYTES` of decompressed data with array headers that fit their members
(:func:`check_npz`, the zip-bomb guard).

Caps (docs/limits.md); each can be raised with an environment variable for big models:

* :data:`MAX_DESCRIPTION_BYTES` — 16 MiB (``NEWEUL_MAX_DESCRIPTION_BYTES``);
* :data:`MAX_DATA_BYTES` — 4 GiB per data file (``NEWEUL_MAX_DATA_BYTES``);
* :data:`MAX_NPZ_BYTES` — 8 GiB decompressed per ``.npz`` (``NEWEUL_MAX_NPZ_BYTES``);
* :data:`MAX_NPZ_RATIO` — compression ratio 100 of a deflated ``.npz`` member of more than
  64 MiB (``NEWEUL_MAX_NPZ_RATIO``).

:func:`load_npz` and :func:`read_text` are the readers of ``.npz`` archives and text files
that do all of it on one open descriptor.
"""

from __future__ import annotations

import hashlib
import os
import stat
import zipfile
from pathlib import Path
from typing import IO, Any

from .errors import DataError, NeweulError

__all__ = [
    "MAX_DATA_BYTES",
    "MAX_DESCRIPTION_BYTES",
    "MAX_NPZ_BYTES",
    "MAX_NPZ_RATIO",
    "NPZ_RATIO_FLOOR",
    "check_npz",
    "check_regular_file",
    "generated_module_name",
    "load_npz",
    "not_own",
    "read_checked",
    "read_text",
]


def _cap(env: str, default: int) -> int:
    try:
        value = int(os.environ.get(env, default))
    except ValueError:
        return default
    return value if value > 0 else default


#: Largest description file read (bytes).
MAX_DESCRIPTION_BYTES = _cap("NEWEUL_MAX_DESCRIPTION_BYTES", 16 * 2**20)
#: Largest data file read (FE model matrices, SID, reduced bodies; bytes).
MAX_DATA_BYTES = _cap("NEWEUL_MAX_DATA_BYTES", 4 * 2**30)
#: Largest total decompressed size of the members of one ``.npz`` (bytes).
MAX_NPZ_BYTES = _cap("NEWEUL_MAX_NPZ_BYTES", 8 * 2**30)
#: Largest compression ratio (declared size / compressed size) of a deflated ``.npz`` member
#: larger than :data:`NPZ_RATIO_FLOOR` (zeros deflate about 1000:1, measured data and FE
#: matrices a few to 20:1; the FE files neweul-py writes deflate their indices 3–10:1 and a zero
#: static state up to 400:1, in members far below :data:`NPZ_RATIO_FLOOR`).
MAX_NPZ_RATIO = _cap("NEWEUL_MAX_NPZ_RATIO", 100)
#: Members declaring at most this many bytes may have any compression ratio.
NPZ_RATIO_FLOOR = 64 * 2**20

_KINDS = (
    (stat.S_ISDIR, "a directory"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISSOCK, "a socket"),
)


def _error(cls: type[NeweulError], message: str, file: str) -> NeweulError:
    if issubclass(cls, DataError):
        return cls(message, file)
    return cls(f"{file}: {message}")


def _check_stat(st: os.stat_result, file: str, what: str, max_bytes: int,
                cls: type[NeweulError]) -> None:
    if not stat.S_ISREG(st.st_mode):
        kind = next((name for test, name in _KINDS if test(st.st_mode)), "not a regular file")
        raise _error(cls, f"the {what} is {kind}, not a regular file", file)
    if st.st_size > max_bytes:
        raise _error(cls, f"the {what} has {st.st_size} bytes, more than the cap of "
                     f"{max_bytes} (docs/limits.md)", file)


def check_regular_file(
    path: str | os.PathLike[str],
    what: str = "data file",
    max_bytes: int | None = None,
    error: type[NeweulError] = DataError,
) -> Path:
    """``path`` if it is an existing regular file of at most ``max_bytes`` bytes.

    Follows symbolic links (a link to a regular file is fine) and never opens the file, so a
    FIFO cannot block.

    Parameters
    ----------
    path
        The file.
    what
        What it is, for the message (``"description"``, ``"FE model"`` …).
    max_bytes
        Size cap; default :data:`MAX_DATA_BYTES`.
    error
        The :class:`NeweulError` subclass raised (``DataError`` by default).

    Raises
    ------
    NeweulError
        Missing, unreadable, not a regular file, or larger than the cap.
    """
    file = os.fspath(path)
    try:
        st = os.stat(file)
    except FileNotFoundError:
        raise _error(error, f"cannot read {what}: file not found (no such file)", file) from None
    except (OSError, ValueError) as exc:  # ValueError: embedded NUL in the name
        raise _error(error, f"cannot read the {what} ({getattr(exc, 'strerror', None) or exc})",
                     file) from None
    _check_stat(st, file, what, MAX_DATA_BYTES if max_bytes is None else max_bytes, error)
    return Path(file)


def not_own(st: os.stat_result) -> str | None:
    """Why a file or directory with status ``st`` could have been written by someone other
    than the current user (``None``: it could not): owned by another user, or writable by
    group or others."""
    if hasattr(os, "getuid") and st.st_uid != os.getuid():
        return f"owned by another user (uid {st.st_uid})"
    if st.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        return f"writable by group or others (mode {stat.S_IMODE(st.st_mode):04o})"
    return None


def _open(file: str, what: str, error: type[NeweulError], own: bool = False) -> int:
    """A read-only descriptor of ``file``, opened non-blocking (a FIFO does not wait for a
    writer); with ``own`` a symbolic link is refused."""
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0)
    if own:
        flags |= getattr(os, "O_NOFOLLOW", 0)
    try:
        return os.open(file, flags)
    except FileNotFoundError:
        raise _error(error, f"cannot read {what}: file not found (no such file)", file) from None
    except (OSError, ValueError) as exc:
        if own and os.path.islink(file):
            raise _error(error, f"the {what} is a symbolic link", file) from None
        raise _error(error, f"cannot read the {what} ({getattr(exc, 'strerror', None) or exc})",
                     file) from None


def read_checked(
    path: str | os.PathLike[str],
    what: str = "data file",
    max_bytes: int | None = None,
    error: type[NeweulError] = DataError,
    *,
    own: bool = False,
) -> bytes:
    """The bytes of a regular file, checked (as :func:`check_regular_file`) on the open file
    descriptor they are read from, so that the file cannot be swapped between check and read.

    The file is opened non-blocking (a FIFO does not wait for a writer) and read up to the
    cap only. With ``own`` (files of the cache) it must moreover not be a symbolic link, and
    belong to the current user with no write permission for group or others
    (:func:`not_own`).
    """
    file = os.fspath(path)
    cap = MAX_DATA_BYTES if max_bytes is None else max_bytes
    fd = _open(file, what, error, own)
    try:
        st = os.fstat(fd)
        _check_stat(st, file, what, cap, error)
        why = not_own(st) if own else None
        if why is not None:
            raise _error(error, f"the {what} is {why}", file)
        chunks, total = [], 0
        while True:
            chunk = os.read(fd, min(1 << 24, cap + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
            if total > cap:
                raise _error(error, f"the {what} grew past the cap of {cap} bytes while being "
                             "read", file)
        return b"".join(chunks)
    except OSError as exc:
        raise _error(error, f"cannot read the {what} ({exc.strerror or exc})", file) from None
    finally:
        os.close(fd)


def check_npz(path: str | os.PathLike[str] | IO[bytes], max_bytes: int | None = None,
              file: str | None = None) -> None:
    """Refuse an ``.npz`` whose members would decompress to more than ``max_bytes`` in total
    (default :data:`MAX_NPZ_BYTES`), a deflated member of more than :data:`NPZ_RATIO_FLOOR`
    bytes declared at more than :data:`MAX_NPZ_RATIO` times its compressed size, or ``.npy``
    headers that claim more data than their member holds — a zip bomb or a forged header is
    refused from the zip directory and the array headers, before any array is inflated.

    The zip reader never returns more than a member's declared size, so bounding the declared
    sizes bounds the work.

    Parameters
    ----------
    path
        The file, or a binary file object open on it (read from its start).
    max_bytes
        Cap of the total declared size.
    file
        The name for the messages (default: ``path``).

    Raises
    ------
    DataError
        Naming the file and the member.
    """
    import numpy as np

    file = file or (os.fspath(path) if isinstance(path, str | os.PathLike) else "<npz>")
    cap = MAX_NPZ_BYTES if max_bytes is None else max_bytes
    try:
        with zipfile.ZipFile(path) as zf:
            infos = zf.infolist()
            total = sum(i.file_size for i in infos)
            if total > cap:
                raise DataError(f"the archive declares {total} bytes of decompressed data, "
                                f"more than the cap of {cap} (docs/limits.md)", file)
            for info in infos:
                if (info.compress_type != zipfile.ZIP_STORED
                        and info.file_size > NPZ_RATIO_FLOOR
                        and info.file_size > MAX_NPZ_RATIO * max(info.compress_size, 1)):
                    raise DataError(
                        f"the member {info.filename} declares {info.file_size} bytes in "
                        f"{info.compress_size} compressed (compression ratio "
                        f"{info.file_size / max(info.compress_size, 1):.0f}, more than the cap "
                        f"of {MAX_NPZ_RATIO}: a zip bomb; docs/limits.md)", file)
            for info in infos:
                if not info.filename.endswith(".npy"):
                    continue
                with zf.open(info) as fh:
                    version = np.lib.format.read_magic(fh)
                    if version == (1, 0):
                        shape, _, dtype = np.lib.format.read_array_header_1_0(fh)
                    elif version in ((2, 0), (3, 0)):
                        shape, _, dtype = np.lib.format.read_array_header_2_0(fh)
                    else:
                        raise ValueError(f"unsupported .npy version {version}")
                count = 1
                for n in shape:
                    count *= int(n)
                if count * dtype.itemsize > info.file_size:
                    raise DataError(f"the header of {info.filename} claims {shape} {dtype} "
                                    f"({count * dtype.itemsize} bytes) in a member of "
                                    f"{info.file_size} bytes", file)
    except DataError:
        raise
    except (zipfile.BadZipFile, zipfile.LargeZipFile, OSError, EOFError, ValueError,
            NotImplementedError, RuntimeError, OverflowError) as exc:
        raise DataError(f"not a readable .npz file ({exc})", file) from None


#: The first bytes of a zip archive (local file header, empty archive).
_ZIP_MAGIC = (b"PK\x03\x04", b"PK\x05\x06")


def load_npz(path: str | os.PathLike[str], what: str = "file",
             max_bytes: int | None = None) -> dict[str, Any]:
    """Every array of an ``.npz`` file, loaded without pickles, after the checks of
    :func:`check_regular_file` and :func:`check_npz` — all on the one open file descriptor
    the arrays are then read from.

    Raises
    ------
    DataError
        Naming the file: not a regular file, larger than ``max_bytes`` (default
        :data:`MAX_DATA_BYTES`), not a zip archive, a zip bomb or a forged header, an object
        array (which would need pickles), or a damaged archive.
    """
    import numpy as np

    file = os.fspath(path)
    cap = MAX_DATA_BYTES if max_bytes is None else max_bytes
    fd = _open(file, what, DataError)
    try:
        _check_stat(os.fstat(fd), file, what, cap, DataError)
        with os.fdopen(fd, "rb") as fh:
            fd = -1                          # closed with fh
            if fh.read(4) not in _ZIP_MAGIC:  # np.load would try .npy or pickle
                raise DataError("not a valid .npz file (not a zip archive)", file)
            fh.seek(0)
            check_npz(fh, file=file)
            fh.seek(0)
            with np.load(fh, allow_pickle=False) as data:
                return {key: data[key] for key in data.files}
    except DataError:
        raise
    except (zipfile.BadZipFile, OSError, EOFError, MemoryError) as exc:
        raise DataError(f"not a readable .npz file ({exc})", file) from None
    except ValueError as exc:  # object arrays refuse to load without pickles
        raise DataError(f"unreadable array ({exc})", file) from None
    finally:
        if fd >= 0:
            os.close(fd)


def read_text(path: str | os.PathLike[str], what: str = "file",
              max_bytes: int | None = None, error: type[NeweulError] = DataError) -> str:
    """The UTF-8 text of a regular file (:func:`read_checked`; a leading byte-order mark is
    dropped).

    Raises
    ------
    NeweulError
        ``error``: as :func:`read_checked`, or the bytes are not UTF-8 (naming the first
        offending byte, its offset and line).
    """
    raw = read_checked(path, what, max_bytes, error)
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise _error(error, f"the {what} is not UTF-8 text (byte 0x{raw[exc.start]:02x} at "
                     f"offset {exc.start}, line {line}); save it as UTF-8", os.fspath(path)
                     ) from None


def generated_module_name(path: str | os.PathLike[str], source: bytes) -> str:
    """The name of a generated module in :data:`sys.modules`:
    ``neweul_generated_<stem>_<digest>``, the digest of its source and of its resolved path.

    The path counts because a compiled module is the same text wherever it is: it finds its
    twin and its data next to itself, so two builds of one description that differ in their
    default parameters have byte-identical wrappers and must not share one import.
    """
    file = Path(path)
    stem = "".join(c if c.isalnum() else "_" for c in file.stem)
    digest = hashlib.sha256(source + b"\0" + str(file.resolve()).encode()).hexdigest()[:16]
    return f"neweul_generated_{stem}_{digest}"
