"""A cache that is trusted by construction: nothing is loaded from it before its bytes are
verified against the SHA-256 recorded when it was written.

Every cached file ``X`` (a generated module ``<stem>_<key>.py``, a compiled shared library next
to it …) has a sidecar ``X.sha256`` holding the SHA-256 of its bytes. A reader gets the bytes
with :func:`verified_bytes` — read once, from one open file descriptor, hashed, compared — and
imports or loads *those bytes* (never the path again, so the file cannot change between check and
use). A missing sidecar, a mismatch, a file owned by another user or writable by group or others
yields ``None`` (and one :class:`CacheWarning`), and the caller regenerates the entry.

The cache directory (:func:`cache_dir`, and any parent it creates) is made with mode 0700 and
its files with mode 0600, whatever the umask; a directory owned by another user or writable by
group or others is refused (:func:`trusted_dir` raises), because whoever can write there could
replace both a file and its sidecar. A file or sidecar that is a symbolic link, owned by another
user or writable by group or others is never read (:func:`neweul_py.files.read_checked` with
``own=True``: checked on the descriptor it is read from).
"""

from __future__ import annotations

import hashlib
import importlib.abc
import importlib.util
import os
import stat
import sys
import warnings
from pathlib import Path
from types import ModuleType

from .atomic import atomic_write
from .errors import DataError, NeweulError
from .files import generated_module_name, not_own, read_checked

__all__ = [
    "SIDECAR_SUFFIX",
    "CacheError",
    "CacheWarning",
    "cache_dir",
    "import_verified",
    "sha256_hex",
    "trusted_dir",
    "trusted_entry",
    "verified_bytes",
    "write_cached",
]

#: Suffix of the file holding the SHA-256 (hex) of a cached file's bytes.
SIDECAR_SUFFIX = ".sha256"
#: Largest cached file read (a generated module of a big model, a shared library).
_MAX_CACHED_BYTES = 512 * 2**20


class CacheError(NeweulError):
    """The cache directory cannot be trusted or written."""


class CacheWarning(UserWarning):
    """A cache entry did not verify and is regenerated."""


def sha256_hex(data: bytes) -> str:
    """SHA-256 of ``data`` as 64 hex digits."""
    return hashlib.sha256(data).hexdigest()


def cache_dir() -> Path:
    """The default cache directory: ``$NEWEUL_CACHE``, else ``$XDG_CACHE_HOME/neweul-py``, else
    ``~/.cache/neweul-py`` (not created here; see :func:`trusted_dir`)."""
    if os.environ.get("NEWEUL_CACHE"):
        return Path(os.environ["NEWEUL_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "neweul-py"


def _private_parents(path: Path) -> None:
    """Create ``path`` and its missing parents with mode 0700 whatever the umask
    (``Path.mkdir(parents=True)`` makes the parents with the umask's mode, 0777 under 000)."""
    missing = []
    for p in (path, *path.parents):
        if os.path.lexists(p):
            break
        missing.append(p)
    for p in reversed(missing):
        try:
            os.mkdir(p, 0o700)
        except FileExistsError:
            continue
        os.chmod(p, 0o700)


def trusted_dir(directory: str | os.PathLike[str] | None = None) -> Path:
    """The cache directory, created with mode 0700 if missing, after checking that only the
    current user can write to it.

    Raises
    ------
    CacheError
        The directory cannot be created, is not a directory, is owned by another user or is
        writable by group or others (say which, and how to fix it).
    """
    path = Path(directory) if directory is not None else cache_dir()
    try:
        _private_parents(path)
        st = os.stat(path)  # follows a symbolic link: the target is what gets written
    except OSError as exc:
        raise CacheError(f"cannot create the cache directory {path}: {exc.strerror}") from None
    if not stat.S_ISDIR(st.st_mode):
        raise CacheError(f"the cache {path} is not a directory")
    why = not_own(st)
    if why is not None:
        raise CacheError(
            f"refusing the cache directory {path}: it is {why}; anyone who can write there "
            "could replace a cached module. Use a private directory (chmod 700, or set "
            "NEWEUL_CACHE to another path)"
        )
    return path


def _warn(message: str) -> None:
    warnings.warn(message, CacheWarning, stacklevel=3)


def verified_bytes(path: str | os.PathLike[str], expected_sha256: str | None = None
                   ) -> bytes | None:
    """The bytes of the cached file ``path`` if they hash to ``expected_sha256`` (default: the
    digest recorded in its sidecar ``path.sha256``), else ``None``.

    ``None`` without a warning when the entry does not exist; with one :class:`CacheWarning`
    when it exists but cannot be trusted (digest mismatch, no sidecar, owned by someone else,
    writable by others, not a regular file). Load or import the returned bytes, never the path.
    """
    path = Path(path)
    if not os.path.lexists(path):
        return None
    if expected_sha256 is None:
        side = path.with_name(path.name + SIDECAR_SUFFIX)
        try:
            expected_sha256 = read_checked(side, "digest", 200, own=True).decode("ascii").strip()
        except DataError as exc:
            _warn(f"cache entry {path} has no readable digest of its own ({exc.message}); "
                  "regenerating it")
            return None
        except UnicodeDecodeError:
            _warn(f"cache entry {path} has no readable digest; regenerating it")
            return None
    try:
        raw = read_checked(path, "cached file", _MAX_CACHED_BYTES, own=True)
    except DataError as exc:
        _warn(f"cache entry {path} cannot be trusted ({exc.message}); regenerating it")
        return None
    if sha256_hex(raw) != expected_sha256:
        _warn(f"cache entry {path} does not match its recorded SHA-256 (modified or damaged); "
              "regenerating it")
        return None
    return raw


def trusted_entry(path: str | os.PathLike[str], expected_sha256: str) -> bool:
    """Whether the cached file ``path`` may be handed to a reader that checks its bytes
    itself: a regular file of this user, writable by nobody else, whose sidecar records
    ``expected_sha256``. Its bytes are *not* read here: the data file of a generated module
    is hashed by the module as it maps it (:func:`neweul_py.ffrf.data_file.ffrf_load_data`),
    once. ``False`` (with one :class:`CacheWarning` when the file exists) otherwise."""
    path = Path(path)
    if not os.path.lexists(path):
        return False
    side = path.with_name(path.name + SIDECAR_SUFFIX)
    try:
        st = os.lstat(path)
        recorded = read_checked(side, "digest", 200, own=True).decode("ascii").strip()
    except (OSError, NeweulError, UnicodeDecodeError):
        _warn(f"cache entry {path} has no readable digest of its own; regenerating it")
        return False
    why = "not a regular file" if not stat.S_ISREG(st.st_mode) else not_own(st)
    if why is None and recorded != expected_sha256:
        why = "recorded with another SHA-256 than its module names"
    if why is not None:
        _warn(f"cache entry {path} is {why}; regenerating it")
        return False
    return True


def write_cached(path: str | os.PathLike[str], data: bytes | str) -> str:
    """Write ``data`` to the cached file ``path`` and its digest to the sidecar, both
    atomically (sidecar first: a reader that sees the new file also sees its digest, and a
    reader that sees an old file with the new digest regenerates it). Returns the SHA-256.

    Raises
    ------
    CacheError
        The cache cannot be written.
    """
    path = Path(path)
    raw = data.encode("utf-8") if isinstance(data, str) else data
    digest = sha256_hex(raw)
    try:
        atomic_write(path.with_name(path.name + SIDECAR_SUFFIX), digest + "\n", mode=0o600)
        atomic_write(path, raw, mode=0o600)
    except (NeweulError, OSError) as exc:
        raise CacheError(f"cannot write to the cache {path.parent}: "
                         f"{getattr(exc, 'strerror', None) or exc}") from None
    return digest


class _BytesLoader(importlib.abc.SourceLoader):
    """Import a module from source bytes already verified (no second read of the file, no
    bytecode cache next to it)."""

    def __init__(self, path: str, source: bytes) -> None:
        self.path = path
        self.source = source

    def get_filename(self, fullname: str) -> str:
        return self.path

    def get_data(self, path: str) -> bytes:
        if path != self.path:
            raise OSError(f"no data for {path}")
        return self.source


def import_verified(path: str | os.PathLike[str], source: bytes, name: str | None = None
                    ) -> ModuleType:
    """Import the module whose verified source is ``source`` (the bytes of ``path``), under
    ``name`` (default :func:`~neweul_py.files.generated_module_name`, the naming of
    :func:`neweul_py.analysis.load_generated`, so both share :data:`sys.modules`).

    Raises
    ------
    NeweulError
        The module fails to import.
    """
    file = os.fspath(path)
    if name is None:
        name = generated_module_name(file, source)
    if name in sys.modules:
        return sys.modules[name]
    loader = _BytesLoader(file, source)
    spec = importlib.util.spec_from_loader(name, loader, origin=file)
    assert spec is not None
    module = importlib.util.module_from_spec(spec)
    module.__file__ = file
    try:
        loader.exec_module(module)
    except Exception as exc:
        raise NeweulError(f"{file}: importing the generated module failed: "
                          f"{type(exc).__name__}: {exc}") from None
    sys.modules[name] = module
    return module
