"""The one condition under which compiled-backend tests do not run: no C compiler on ``PATH``.

The compiled backend builds its library with the system C compiler (``cc`` or ``gcc``), which no
Python package installs; without one a generated module falls back to its NumPy twin (tested
on its own). Every test of the compiled code carries :data:`needs_c_compiler`, so a missing
compiler shows as skips with this reason, not as silently passing tests.
"""

from __future__ import annotations

import shutil

import pytest

HAS_C_COMPILER = shutil.which("cc") is not None or shutil.which("gcc") is not None

needs_c_compiler = pytest.mark.skipif(
    not HAS_C_COMPILER,
    reason="no C compiler (cc or gcc) on PATH: the compiled backend cannot be built here",
)
