"""Shared test configuration: the reference builders of ``tests/support`` are importable by name
(``from fe_builders import piston_duct``) from every test directory, and BLAS runs one thread.

The tests' matrices are small: BLAS threads only add work. On a machine whose cores are shared
(the development machine, CI), idle OpenBLAS threads spin: the refine-0 middle-ear build and the
measured-ear sweep took 77 s of CPU with the default threads and 6 s with one. Set before NumPy
is first imported; the command-line tests' subprocesses inherit it. An explicit setting wins.
"""

import os
import sys
from pathlib import Path

import pytest

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

SUPPORT = Path(__file__).resolve().parent / "support"
if str(SUPPORT) not in sys.path:
    sys.path.insert(0, str(SUPPORT))


@pytest.fixture
def fresh_modules():
    """No generated module imported by an earlier test is reused: ``load_generated`` and the
    cache import modules under a name made of their content, so a test that changes what an
    import finds (the library cache, cffi) starts without them, and leaves none behind."""
    before = {k: m for k, m in sys.modules.items() if k.startswith("neweul_generated_")}
    for k in before:
        del sys.modules[k]
    yield
    for k in [k for k in sys.modules if k.startswith("neweul_generated_")]:
        del sys.modules[k]
    sys.modules.update(before)
