"""Run-time part of compiled modules: build, cache, verify and load the shared library.

The text of this file below the ``runtime begins`` line is copied verbatim into every module
written by :mod:`.c_module`, so a compiled module stays importable on its own (standard
library, NumPy, cffi and a C compiler; no neweul-py, no sympy). It is a normal module as well,
so that it is linted and tested once.

Safety rules: the library is built from the bytes of the C source whose SHA-256 the module
records (fed to the compiler on stdin, so a file changed after the check is never compiled); the
SHA-256 of the library bytes is recorded next to it at build time; a library is loaded only from
bytes whose hash matches that record and whose record names the source hash, and it is loaded
from a private copy of exactly those bytes (no window in which the checked file can be replaced
before ``dlopen``). A stale or foreign library is rebuilt.

The cache directory ``__neweul_c__/`` is created 0700 and its files 0600 whatever the umask.
Before anything is read from it, the directory (a symbolic link is judged by its target) must
belong to the current user and be writable by no one else — otherwise whoever can write there
could replace a library and its record together, and :class:`BackendUnavailable` names it and
the remedy. A library or record that is a symbolic link, not a regular file, owned by another
user or writable by group or others is never read: it is rebuilt in place. Without cffi or
a compiler, on a compiler error, or with an unwritable or untrusted cache
:class:`BackendUnavailable` tells the module to fall back to its NumPy twin (and the API and
the CLI, asked for the compiled backend, to stop with that message).
"""

# ---- runtime begins
import hashlib as _hashlib
import importlib.util as _importlib_util
import os as _os
import shutil as _shutil
import stat as _stat
import subprocess as _subprocess
import tempfile as _tempfile
from pathlib import Path as _Path

#: Compiler flags: position independent; ``-O1`` (as fast as ``-O2`` on this straight-line
#: code, chain N = 10: 1.4 µs per rhs either way, at two thirds of the compile time);
#: ``-fno-math-errno`` lets the compiler share repeated ``sin``/``cos`` calls (errno is never
#: read).
C_FLAGS = ("-O1", "-fPIC", "-shared", "-fno-math-errno")


class BackendUnavailable(Exception):
    """The compiled library cannot be used; the message says why."""


def load_twin(path, name):
    """Import the NumPy module at ``path`` (the fallback and the source of the constants)."""
    spec = _importlib_util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise ImportError(f"cannot import {path}")
    module = _importlib_util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _sha256(data):
    return _hashlib.sha256(data).hexdigest()


def _compiler():
    cc = _os.environ.get("CC") or _shutil.which("cc") or _shutil.which("gcc")
    if not cc:
        raise BackendUnavailable("no C compiler found (set CC or install gcc)")
    return cc


def _untrusted(st):
    """Why a file or directory with status ``st`` could have been written by someone else
    (``None``: only by the current user)."""
    if hasattr(_os, "getuid") and st.st_uid != _os.getuid():
        return f"owned by another user (uid {st.st_uid})"
    if st.st_mode & (_stat.S_IWGRP | _stat.S_IWOTH):
        return f"writable by group or others (mode {_stat.S_IMODE(st.st_mode):04o})"
    return None


def private_directory(path):
    """``path``, created with mode 0700 if missing (whatever the umask), after checking that
    only the current user can write to it (a symbolic link: its target).

    Raises
    ------
    BackendUnavailable
        It cannot be created, is not a directory, or is owned by another user or writable by
        group or others (naming the directory and the remedy).
    """
    try:
        _os.mkdir(path, 0o700)
        _os.chmod(path, 0o700)       # mkdir's mode is narrowed by the umask, never widened
    except FileExistsError:
        pass
    except OSError as exc:
        raise BackendUnavailable(
            f"the library cache {path} is not writable ({exc.strerror})") from None
    try:
        st = _os.stat(path)
    except OSError as exc:
        raise BackendUnavailable(f"cannot use the library cache {path} ({exc.strerror})"
                                 ) from None
    if not _stat.S_ISDIR(st.st_mode):
        raise BackendUnavailable(f"the library cache {path} is not a directory")
    why = _untrusted(st)
    if why is not None:
        raise BackendUnavailable(
            f"refusing the library cache {path}: it is {why}, so anyone who can write there "
            "could replace a library; remove it (it is made again, private to you) or make "
            "it yours with chmod 700")
    return path


def _read_own(path, cap=1 << 30):
    """The bytes of ``path`` if it is a regular file (not a symbolic link) of the current
    user that no one else can write, read from the descriptor that was checked; else
    ``(None, why)``."""
    flags = (_os.O_RDONLY | getattr(_os, "O_NOFOLLOW", 0) | getattr(_os, "O_NONBLOCK", 0)
             | getattr(_os, "O_NOCTTY", 0))
    try:
        fd = _os.open(path, flags)
    except FileNotFoundError:
        return None, "missing"
    except OSError as exc:
        if _os.path.islink(path):
            return None, "a symbolic link"
        return None, f"unreadable ({exc.strerror})"
    try:
        st = _os.fstat(fd)
        if not _stat.S_ISREG(st.st_mode):
            return None, "not a regular file"
        why = _untrusted(st)
        if why is not None:
            return None, why
        if st.st_size > cap:
            return None, f"larger than {cap} bytes"
        chunks = []
        while True:
            chunk = _os.read(fd, 1 << 20)
            if not chunk:
                return b"".join(chunks), None
            chunks.append(chunk)
    except OSError as exc:
        return None, f"unreadable ({exc.strerror})"
    finally:
        _os.close(fd)


def _private_file(directory, suffix):
    """A new file of mode 0600 in ``directory`` (``mkstemp``), its descriptor and path."""
    fd, tmp = _tempfile.mkstemp(suffix=suffix, dir=directory)
    _os.fchmod(fd, 0o600)
    return fd, tmp


def _build(source, lib_path, record, source_sha):
    """Compile ``source`` (bytes) to ``lib_path`` (mode 0600, in a private directory);
    record the library's SHA-256."""
    cc = _compiler()
    try:
        fd, tmp = _private_file(lib_path.parent, ".so.tmp")
        _os.close(fd)
    except OSError as exc:
        raise BackendUnavailable(
            f"the library cache {lib_path.parent} is not writable ({exc.strerror})"
        ) from None
    rec_tmp = None
    try:
        try:
            proc = _subprocess.run([cc, *C_FLAGS, "-x", "c", "-", "-o", tmp, "-lm"],
                                   input=source, capture_output=True, check=False)
        except OSError as exc:
            raise BackendUnavailable(f"cannot run the C compiler {cc} ({exc})") from None
        if proc.returncode != 0:
            lines = proc.stderr.decode(errors="replace").strip().splitlines()
            lines = [ln for ln in lines if "error" in ln] or lines
            raise BackendUnavailable(f"the C compiler {cc} failed: " + " | ".join(lines[:5]))
        _os.chmod(tmp, 0o600)        # the linker makes its output 0777 less the umask
        data, why = _read_own(tmp)
        if data is None:
            raise BackendUnavailable(f"the library just built in {lib_path.parent} is {why}")
        fd, rec_tmp = _private_file(lib_path.parent, ".sha256.tmp")
        with _os.fdopen(fd, "w", encoding="ascii") as fh:
            fh.write(f"{_sha256(data)} {source_sha}\n")
            fh.flush()
            _os.fsync(fh.fileno())
        _os.replace(tmp, lib_path)
        _os.replace(rec_tmp, record)
        return data
    except OSError as exc:
        raise BackendUnavailable(
            f"cannot write the library to {lib_path.parent} ({exc.strerror})"
        ) from None
    finally:
        for leftover in (tmp, rec_tmp):
            if leftover is not None and _os.path.lexists(leftover):
                _os.unlink(leftover)


def _verified(lib_path, record, source_sha):
    """``(bytes, "")`` of the library if it and its record are this user's own files and
    match for this source, else ``(None, why)`` (``why`` empty when there is no library)."""
    text, why_record = _read_own(record, 4096)
    data, why_lib = _read_own(lib_path)
    if why_lib == "missing" and why_record == "missing":
        return None, ""
    for name, why in (("library", why_lib), ("build record", why_record)):
        if why is not None:
            return None, f"the cached {name} is {why}"
    try:
        so_sha, src_sha = text.decode("ascii").split()
    except (UnicodeDecodeError, ValueError):
        return None, "the build record is malformed"
    if src_sha != source_sha or _sha256(data) != so_sha:
        return None, "the cached library did not match its build record (stale or foreign)"
    return data, ""


def _dlopen(ffi, data, directory):
    """``dlopen`` a private copy of the verified bytes (removed again at once)."""
    for where in (directory, None):
        try:
            fd, tmp = _tempfile.mkstemp(suffix=".so", dir=where)
        except OSError:
            continue
        try:
            with _os.fdopen(fd, "wb") as fh:
                fh.write(data)
            return ffi.dlopen(tmp)
        finally:
            _os.unlink(tmp)
    raise BackendUnavailable("no writable directory to load the library from")


def compiled_library(c_path, source_sha, cdef, cache, ffi=None):
    """``(ffi, lib, note)`` of the C source at ``c_path``, built once per content.

    ``note`` is ``""`` (a verified library from the cache was loaded), ``"built"`` (none was
    there) or a message naming a cached library that did not match its record (it was rebuilt
    from the source and replaced).

    Parameters
    ----------
    c_path
        The module's C source.
    source_sha
        Its SHA-256 as recorded by the module; a differing file is refused.
    cdef
        The cffi declarations of the library's functions.
    cache
        Directory of ``<stem>_<sha16>.so`` and its record ``<stem>_<sha16>.sha256``.
    ffi
        An ``FFI`` that already holds the declarations (``cdef`` is then not used), so that
        several libraries of one module share it and its array objects.

    Raises
    ------
    BackendUnavailable
        No cffi, no compiler, a compiler error, an unwritable or untrusted cache
        (:func:`private_directory`), a changed source.
    """
    try:
        import cffi
    except ImportError:
        raise BackendUnavailable("cffi is not installed (pip install cffi)") from None
    c_path, cache = _Path(c_path), _Path(cache)
    try:
        source = c_path.read_bytes()
    except OSError as exc:
        raise BackendUnavailable(f"cannot read {c_path} ({exc.strerror})") from None
    if _sha256(source) != source_sha:
        raise BackendUnavailable(f"{c_path} does not match this module (edited? regenerate)")
    stem = f"{c_path.stem}_{source_sha[:16]}"
    cache = _Path(private_directory(cache))
    lib_path, record = cache / f"{stem}.so", cache / f"{stem}.sha256"
    data, why = _verified(lib_path, record, source_sha)
    note = ""
    if data is None:
        note = "built"
        if why:
            note = (f"{why} ({lib_path}); it was not loaded but rebuilt from the source")
        data = _build(source, lib_path, record, source_sha)
    if ffi is None:
        ffi = cffi.FFI()
        ffi.cdef(cdef)
    try:
        lib = _dlopen(ffi, data, cache)
    except OSError as exc:
        raise BackendUnavailable(f"cannot load the library: {exc}") from None
    return ffi, lib, note
