"""Atomic file writes, shared by every layer (like :mod:`neweul_py.errors`).

A file is written to a temporary file in the target's directory, flushed and ``fsync``-ed, and
moved over the target with :func:`os.replace` (atomic on POSIX and Windows): readers see either
the old file or the complete new one, never a partial write, and on any error (including an
interrupt) the old file is untouched and the temporary file removed.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import IO

from .errors import NeweulError

__all__ = ["atomic_savez", "atomic_write"]


def atomic_write(
    path: str | os.PathLike[str], content: bytes | str | Callable[[IO[bytes]], object],
    mode: int = 0o644,
) -> Path:
    """Write ``content`` to ``path`` atomically and return the path.

    Parameters
    ----------
    path
        The target file; missing parent directories are created.
    content
        Bytes, text (written as UTF-8), or a callable that writes the whole content to the
        binary file handle it receives (e.g. ``lambda fh: numpy.savez(fh, **arrays)``).

    Raises
    ------
    NeweulError
        When the directory cannot be created or written to.
    """
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:
        raise NeweulError(f"{path}: cannot write ({exc.strerror})") from None
    try:
        os.fchmod(fd, mode)
        with os.fdopen(fd, "wb") as fh:
            if callable(content):
                content(fh)
            else:
                fh.write(content.encode("utf-8") if isinstance(content, str) else content)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    return path


def atomic_savez(path: str | os.PathLike[str], **arrays: object) -> Path:
    """Write ``arrays`` as an uncompressed ``.npz`` atomically (:func:`atomic_write`), refusing
    object arrays: every file the project writes loads with ``allow_pickle=False``."""
    import numpy as np

    for key, value in arrays.items():
        if np.asarray(value).dtype == object:
            raise TypeError(f"array {key!r} has dtype object; it would need pickling")
    return atomic_write(path, lambda fh: np.savez(fh, **arrays))
