"""The one condition under which compiled-backend tests do not run: no C compiler on ``PATH``.

The compiled backend builds its library with the system C compiler (``cc`` or ``gcc``), which no
Python package installs; without one a generated module falls back to its NumPy twin (tested
on its own). Every test of the compiled code carries :data:`needs_c_compiler`, so a missing
compiler shows as skips with this reason, not as silently passing tests.
"""

from __future__ import annotations

import hashlib
import shutil
from pathlib import Path
from typing import Any

import pytest

from neweul_py.codegen.c_runtime import compiled_library

HAS_C_COMPILER = shutil.which("cc") is not None or shutil.which("gcc") is not None

needs_c_compiler = pytest.mark.skipif(
    not HAS_C_COMPILER,
    reason="no C compiler (cc or gcc) on PATH: the compiled backend cannot be built here",
)


def compile_c(tmp_path: Path, name: str, src: str, cdef: str) -> tuple[Any, Any]:
    """``(ffi, lib)`` of the C text ``src``, written as ``tmp_path/name.c`` and built as the
    compiled backend builds a model (``codegen.c_runtime.compiled_library``: its flags, a
    cache in ``tmp_path/cache``); ``cdef`` declares the functions to call."""
    path = tmp_path / f"{name}.c"
    path.write_text(src)
    ffi, lib, _note = compiled_library(path, hashlib.sha256(src.encode()).hexdigest(), cdef,
                                       tmp_path / "cache")
    return ffi, lib
