"""The library cache of compiled modules (codegen/c_runtime.py): private whatever the umask,
and nothing loaded from it that another user could have written.

References: POSIX file modes and owners (``stat``), and a shared library whose constructor
creates a marker file — the marker exists exactly when that library was loaded.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import stat
import subprocess
import warnings
from pathlib import Path

import pytest

from neweul_py.analysis.module import load_generated
from neweul_py.codegen import generate_module
from neweul_py.codegen.c_module import write_c_module
from neweul_py.codegen.c_runtime import BackendUnavailable, compiled_library
from neweul_py.description import load_description
from neweul_py.equations import newton_euler

ROOT = Path(__file__).resolve().parents[2]
CC = shutil.which("cc") or shutil.which("gcc")
pytestmark = pytest.mark.skipif(CC is None, reason="no C compiler")
CDEF = "int nw_rhs(double, const double *, const double *, const double *, double *);"
AS_ROOT = pytest.mark.skipif(not hasattr(os, "getuid") or os.getuid() != 0,
                             reason="changing the owner needs root")
OTHER_UID = 4242


def _mode(path: Path) -> int:
    return stat.S_IMODE(os.lstat(path).st_mode)


@pytest.fixture
def pendulum_c(tmp_path):
    """The C source of the pendulum's core library and its SHA-256 (nothing built yet)."""
    eq = newton_euler(load_description(ROOT / "examples" / "pendulum.yaml"))
    npath = generate_module(eq, "h", tmp_path / "pendulum.py")
    write_c_module(eq, npath)
    c_path = tmp_path / "pendulum_c.c"
    return c_path, hashlib.sha256(c_path.read_bytes()).hexdigest()


def _evil_library(directory: Path, marker: Path) -> bytes:
    """A shared library whose constructor creates ``marker`` when it is loaded."""
    src = directory / "evil.c"
    src.write_text('#include <stdio.h>\n__attribute__((constructor)) static void run(void) '
                   f'{{ FILE *f = fopen("{marker}", "w"); if (f) fclose(f); }}\n'
                   "int nw_rhs(double t, const double *x, const double *p, const double *u, "
                   "double *o) { return 0; }\n")
    subprocess.run([CC, "-shared", "-fPIC", str(src), "-o", str(directory / "evil.so")],
                   check=True)
    return (directory / "evil.so").read_bytes()


def _plant(cache: Path, c_path: Path, sha: str, data: bytes) -> tuple[Path, Path]:
    """Put ``data`` in the cache as the library of ``c_path``, with a build record that
    matches it (what a writer of the cache could do)."""
    stem = f"{c_path.stem}_{sha[:16]}"
    lib, record = cache / f"{stem}.so", cache / f"{stem}.sha256"
    lib.write_bytes(data)
    record.write_text(f"{hashlib.sha256(data).hexdigest()} {sha}\n")
    return lib, record


def test_cache_is_private_whatever_the_umask(pendulum_c, tmp_path):
    """Under umask 000 the directory is 0700 and the library and its record 0600 (they were
    0777, 0711 and 0666)."""
    c_path, sha = pendulum_c
    old = os.umask(0)
    try:
        _, lib, note = compiled_library(c_path, sha, CDEF, tmp_path / "__neweul_c__")
    finally:
        os.umask(old)
    assert note == "built" and lib.nw_rhs is not None
    cache = tmp_path / "__neweul_c__"
    assert _mode(cache) == 0o700
    files = sorted(cache.iterdir())
    assert [f.suffix for f in files] == [".sha256", ".so"]
    assert all(_mode(f) == 0o600 for f in files)


def test_module_import_under_umask_000_keeps_the_cache_private(tmp_path, fresh_modules):
    """The same through the generated wrapper, as ``simulate --backend c`` imports it."""
    eq = newton_euler(load_description(ROOT / "examples" / "pendulum.yaml"))
    npath = generate_module(eq, "h", tmp_path / "pendulum.py")
    old = os.umask(0)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            module = load_generated(write_c_module(eq, npath))
    finally:
        os.umask(old)
    assert module.BACKEND == "c"
    cache = tmp_path / "__neweul_c__"
    assert _mode(cache) == 0o700 and all(_mode(f) == 0o600 for f in cache.iterdir())


@pytest.mark.parametrize("mode", [0o777, 0o770, 0o702])
def test_directory_writable_by_others_is_refused(pendulum_c, tmp_path, mode):
    """A cache that group or others can write is never read: one clear reason, naming the
    directory and the remedy; the library planted there is not loaded."""
    c_path, sha = pendulum_c
    cache = tmp_path / "__neweul_c__"
    cache.mkdir()
    marker = tmp_path / "ran"
    _plant(cache, c_path, sha, _evil_library(tmp_path, marker))
    os.chmod(cache, mode)
    with pytest.raises(BackendUnavailable, match="writable by group or others") as info:
        compiled_library(c_path, sha, CDEF, cache)
    assert str(cache) in str(info.value) and "remove it" in str(info.value)
    assert not marker.exists()


@AS_ROOT
def test_directory_of_another_user_is_refused(pendulum_c, tmp_path):
    c_path, sha = pendulum_c
    cache = tmp_path / "__neweul_c__"
    cache.mkdir(mode=0o700)
    marker = tmp_path / "ran"
    _plant(cache, c_path, sha, _evil_library(tmp_path, marker))
    os.chown(cache, OTHER_UID, -1)
    with pytest.raises(BackendUnavailable, match="owned by another user"):
        compiled_library(c_path, sha, CDEF, cache)
    assert not marker.exists()


@AS_ROOT
def test_directory_linked_to_another_users_directory_is_refused(pendulum_c, tmp_path):
    """A symbolic link is judged by the directory it leads to."""
    c_path, sha = pendulum_c
    theirs = tmp_path / "theirs"
    theirs.mkdir(mode=0o700)
    marker = tmp_path / "ran"
    _plant(theirs, c_path, sha, _evil_library(tmp_path, marker))
    os.chown(theirs, OTHER_UID, -1)
    (tmp_path / "__neweul_c__").symlink_to(theirs)
    with pytest.raises(BackendUnavailable, match="owned by another user"):
        compiled_library(c_path, sha, CDEF, tmp_path / "__neweul_c__")
    assert not marker.exists()


def _tamper(how: str, lib: Path, record: Path, tmp_path: Path, data: bytes) -> None:
    if how == "another user's files":
        os.chown(lib, OTHER_UID, -1)
        os.chown(record, OTHER_UID, -1)
    elif how == "writable by others":
        os.chmod(lib, 0o666)
        os.chmod(record, 0o666)
    elif how == "links to another user's files":
        theirs = tmp_path / "theirs"
        theirs.mkdir()
        for f in (lib, record):
            shutil.move(f, theirs / f.name)
            os.chown(theirs / f.name, OTHER_UID, -1)
            f.symlink_to(theirs / f.name)


@pytest.mark.parametrize("how", [
    pytest.param("another user's files", marks=AS_ROOT),
    "writable by others",
    pytest.param("links to another user's files", marks=AS_ROOT),
])
def test_tampered_library_and_record_are_never_loaded(pendulum_c, tmp_path, how):
    """The attack: a library and a build record that match each other and the source's hash,
    but that this user did not write (another owner, writable by others, or links to another
    user's files). Never loaded (the constructor's marker stays absent): the library is
    rebuilt from the source in place, with a note naming why."""
    c_path, sha = pendulum_c
    cache = tmp_path / "__neweul_c__"
    compiled_library(c_path, sha, CDEF, cache)      # the cache, made by this user
    marker = tmp_path / "ran"
    lib, record = _plant(cache, c_path, sha, _evil_library(tmp_path, marker))
    _tamper(how, lib, record, tmp_path, lib.read_bytes())
    _, loaded, note = compiled_library(c_path, sha, CDEF, cache)
    assert not marker.exists()
    assert "was not loaded but rebuilt" in note
    assert loaded.nw_rhs is not None
    for f in (lib, record):
        st = os.lstat(f)
        assert stat.S_ISREG(st.st_mode) and st.st_uid == os.getuid()
        assert _mode(f) == 0o600
    _, _, note = compiled_library(c_path, sha, CDEF, cache)
    assert note == "" and not marker.exists()     # the rebuilt library is reused
