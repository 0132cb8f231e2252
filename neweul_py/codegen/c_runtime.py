"""Run-time part of compiled modules: build, cache, verify and load the shared library.

The text of this file below the ``runtime begins`` line is copied verbatim into every module
written by :mod:`.c_module`, so a compiled module stays importable on its own (standard
library, NumPy, cffi and a C compiler; no neweul-py, no sympy). It is a normal module as well,
so that it is linted and tested once.

Safety rules: the library is built from the bytes of the C source whose SHA-256 the
module records (fed to the compiler on stdin, so a file changed after the check is never
compiled); the SHA-256 of the library bytes is recorded next to it at build time; a library is
loaded only from bytes whose hash matches that record and whose record names the source hash,
and it is loaded from a private copy of exactly those bytes (no window in which the checked
file can be replaced before ``dlopen``). A stale or foreign library is rebuilt. Without cffi or
a compiler, on a compiler error, or with an unwritable cache :class:`BackendUnavailable`
tells the module to fall back to its NumPy twin.
"""

# ---- runtime begins
import hashlib as _hashlib
import importlib.util as _importlib_util
import os as _os
import shutil as _shutil
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


def _build(source, lib_path, record, source_sha):
    """Compile ``source`` (bytes) to ``lib_path``; record the library's SHA-256."""
    cc = _compiler()
    try:
        lib_path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = _tempfile.mkstemp(suffix=".so.tmp", dir=lib_path.parent)
        _os.close(fd)
    except OSError as exc:
        raise BackendUnavailable(
            f"the library cache {lib_path.parent} is not writable ({exc.strerror})"
        ) from None
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
        data = _Path(tmp).read_bytes()
        rec_tmp = f"{tmp}.sha256"
        with open(rec_tmp, "w", encoding="ascii") as fh:
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
        for leftover in (tmp, f"{tmp}.sha256"):
            if _os.path.exists(leftover):
                _os.unlink(leftover)


def _verified(lib_path, record, source_sha):
    """The library bytes if they match their build record for this source, else ``None``."""
    try:
        so_sha, src_sha = record.read_text(encoding="ascii").split()
        data = lib_path.read_bytes()
    except (OSError, ValueError):
        return None
    if src_sha != source_sha or _sha256(data) != so_sha:
        return None
    return data


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
        No cffi, no compiler, a compiler error, an unwritable cache, a changed source.
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
    lib_path, record = cache / f"{stem}.so", cache / f"{stem}.sha256"
    data = _verified(lib_path, record, source_sha)
    note = ""
    if data is None:
        note = "built"
        if lib_path.exists() or record.exists():
            note = (f"the cached library {lib_path} did not match its build record (stale or "
                    "foreign); it was not loaded but rebuilt from the source")
        data = _build(source, lib_path, record, source_sha)
    if ffi is None:
        ffi = cffi.FFI()
        ffi.cdef(cdef)
    try:
        lib = _dlopen(ffi, data, cache)
    except OSError as exc:
        raise BackendUnavailable(f"cannot load the library: {exc}") from None
    return ffi, lib, note
