"""Atomic output of a pressure sweep: FE models, static results (CSV), manifest, pictures.

Everything is written into a temporary directory ``.DIR.<random>.tmp`` next to the target
``DIR``, which then takes the target's place in one atomic step, so that a reader (or a run
killed at any moment) sees either the old output or the complete new one under ``DIR``:

* an existing ``DIR`` is *exchanged* with the temporary directory (Linux ``renameat2`` with
  ``RENAME_EXCHANGE``), after which the temporary name holds the old output and is removed;
* a new ``DIR`` is created by one ``rename``;
* where the exchange is not available, ``DIR`` is first renamed to ``.DIR.<random>.old``; a
  kill between the two renames is healed by the next run, which renames the old output back.

Stale ``.DIR.*.tmp`` / ``.DIR.*.old`` directories of killed runs are removed by the next run.
A run holds an advisory lock (``flock``) on its own temporary directory while it fills it, and
cleaning skips a temporary directory whose lock is held, so it never removes the directory of a
run still writing; the parent directory is locked only for the short steps that look at or
rename its entries (cleaning, creating the temporary directory, the final exchange), so that
runs into different directories of one parent — two builds side by side — fill at the same
time.
"""

from __future__ import annotations

import contextlib
import csv
import ctypes
import errno
import json
import os
import shutil
import tempfile
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..elastic.fe_model import FEModel
from ..errors import DataError

__all__ = [
    "MANIFEST",
    "check_output_dir",
    "write_directory_atomically",
    "write_model",
    "write_static_csv",
]

#: Name of the manifest that marks a directory as a sweep output.
MANIFEST = "sweep.json"


def write_model(fe: FEModel, path: Path) -> None:
    """Write an FE model as ``.npz`` with the writer of :mod:`neweul_py.elastic` (the
    ``neweul-fe`` format); a minimal writer of the same layout is the fallback."""
    try:
        from ..elastic.io.fe_files import write_fe_model
    except ImportError:  # pragma: no cover - before the elastic I/O landed
        write_fe_model = None
    if write_fe_model is not None:
        write_fe_model(fe, path)
        return
    meta = {  # pragma: no cover
        "format": "neweul-fe",
        "version": 1,
        "name": fe.name,
        "kind": fe.kind,
        "density": fe.density,
        "inputs": {k: [list(p) for p in v] for k, v in fe.inputs.items()},
        "outputs": {k: [list(p) for p in v] for k, v in fe.outputs.items()},
    }
    arrays: dict[str, np.ndarray] = {
        "meta": np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
    }
    for key in ("M", "K", "D"):
        a = getattr(fe, key)
        if a is not None:
            arrays[f"{key}_data"] = a.data
            arrays[f"{key}_indices"] = a.indices.astype(np.int64)
            arrays[f"{key}_indptr"] = a.indptr.astype(np.int64)
            arrays[f"{key}_shape"] = np.asarray(a.shape, dtype=np.int64)
    arrays.update(nodes=fe.nodes, dof_node=fe.dof_node, dof_kind=fe.dof_kind.astype("U2"))
    np.savez(path, **arrays)


#: Significant digits of the numbers in ``static.csv``: identical runs give identical files
#: (the iterative eigensolver's last bits vary from run to run; 12 digits are far above them).
CSV_DIGITS = 12


def write_static_csv(rows: Sequence[Mapping[str, float]], path: Path) -> None:
    """Static results, one row per working point; the header names columns with units.
    Floats are written with :data:`CSV_DIGITS` significant digits (deterministic files)."""
    keys = list(rows[0])
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(keys)
        for r in rows:
            w.writerow([_fmt(r[k]) for k in keys])


def _fmt(value: object) -> object:
    if isinstance(value, float | np.floating):
        return repr(float(f"{float(value):.{CSV_DIGITS}g}") + 0.0)  # + 0.0: no "-0.0"
    return value


def check_output_dir(out_dir: str | os.PathLike, manifest: str = MANIFEST) -> Path:
    """Refuse an output path that is a file or a non-empty directory of other data (one that
    holds no ``manifest``).

    Raises
    ------
    DataError
        ``out_dir`` exists and holds other data, or is not a directory.
    """
    out = Path(out_dir)
    if out.exists():
        if not out.is_dir():
            raise DataError("output path exists and is not a directory", str(out))
        if any(out.iterdir()) and not (out / manifest).is_file():
            raise DataError(
                f"output directory is not empty and holds no {manifest} (not overwriting)",
                str(out),
            )
    return out


def _exchange(a: Path, b: Path) -> bool:
    """Swap the directories ``a`` and ``b`` atomically (Linux ``renameat2(RENAME_EXCHANGE)``);
    False where the system does not offer it."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError):
        return False
    at_fdcwd, rename_exchange = -100, 2
    if renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP, errno.EOPNOTSUPP):
        return False
    raise OSError(err, os.strerror(err), str(b))


#: The temporary directories this process is filling and holds the lock of (device, inode):
#: an output written inside one of them (an FE sweep inside a build) must not wait for the
#: lock its own run holds (``flock`` locks belong to an open file, not to the process).
_HELD: set[tuple[int, int]] = set()


def _key(directory: Path) -> tuple[int, int]:
    st = os.stat(directory)
    return st.st_dev, st.st_ino


@contextlib.contextmanager
def _locked(directory: Path) -> Iterator[None]:
    """An exclusive advisory lock on ``directory``, held until the block ends (no lock file is
    left behind); a directory this process holds already is not locked again."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        yield
        return
    if _key(directory) in _HELD:
        yield
        return
    fd = os.open(directory, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # releases the lock


def _hold(directory: Path) -> tuple[int, tuple[int, int]] | None:
    """Take the lock of ``directory`` until :func:`_release` (``None`` without ``flock``)."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        return None
    fd = os.open(directory, os.O_RDONLY)
    fcntl.flock(fd, fcntl.LOCK_EX)
    key = _key(directory)
    _HELD.add(key)
    return fd, key


def _release(held: tuple[int, tuple[int, int]] | None) -> None:
    """Give up a lock of :func:`_hold`."""
    if held is not None:
        _HELD.discard(held[1])
        os.close(held[0])


def _in_use(directory: Path) -> bool:
    """Whether another run holds the lock of ``directory`` (its temporary directory, which it
    is still filling)."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        return False
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    finally:
        os.close(fd)
    return False


def _recover_and_clean(out: Path, parent: Path, manifest: str) -> None:
    """Heal a run killed between the two renames of the fallback (``DIR`` missing, its old
    content under ``.DIR.*.old``) and remove the temporaries of killed runs."""
    stale = sorted(parent.glob(f".{out.name}.*.old")) + sorted(parent.glob(f".{out.name}.*.tmp"))
    if not out.exists():
        for old in stale:
            if old.suffix == ".old" and (old / manifest).is_file():
                os.rename(old, out)
                stale.remove(old)
                break
    for path in stale:
        if path.is_dir() and not path.is_symlink() and not _in_use(path):
            shutil.rmtree(path, ignore_errors=True)


def _replace(tmp: Path, out: Path, parent: Path) -> None:
    """Put the complete ``tmp`` in the place of ``out`` (module docstring)."""
    if not out.exists():
        os.rename(tmp, out)
    elif _exchange(tmp, out):
        shutil.rmtree(tmp, ignore_errors=True)  # tmp now holds the old output
    else:
        old = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".old", dir=parent))
        os.rmdir(old)
        os.replace(out, old)
        os.replace(tmp, out)  # a kill before this line is healed by the next run
        shutil.rmtree(old, ignore_errors=True)


def write_directory_atomically(
    out_dir: str | os.PathLike, fill: Callable[[Path], Mapping[str, Any]],
    manifest: str = MANIFEST,
) -> Path:
    """Create ``out_dir`` with the content ``fill(tmp)`` writes into a temporary directory.

    ``fill`` returns the manifest (written last as ``manifest``, default :data:`MANIFEST`).
    An existing ``out_dir`` is replaced only if it is empty or a previous output of the same
    kind (it holds ``manifest``); it is replaced in one atomic exchange (see the module
    docstring).

    Raises
    ------
    DataError
        ``out_dir`` exists and holds other data, or is not a directory.
    """
    out = Path(out_dir)
    parent = out.parent if str(out.parent) else Path(".")
    parent.mkdir(parents=True, exist_ok=True)
    with _locked(parent):
        _recover_and_clean(out, parent, manifest)
        out = check_output_dir(out, manifest)
        tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".tmp", dir=parent))
        held = _hold(tmp)  # before the parent is free: no other run may clean it away
    try:
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o777 & ~umask)  # mkdtemp makes it private; the result is ordinary
        record = fill(tmp)
        with open(tmp / manifest, "w") as fh:
            json.dump(record, fh, indent=2, sort_keys=False)
            fh.write("\n")
            fh.flush()
            os.fsync(fh.fileno())
        with _locked(parent):
            out = check_output_dir(out, manifest)
            _replace(tmp, out, parent)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    finally:
        _release(held)
    return out
