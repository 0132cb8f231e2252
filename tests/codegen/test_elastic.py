"""Composition of elastic modules (``neweul_py.codegen.elastic``).

Reference: ``inspect.getsource`` of the same kernel functions (the standard library's own
reading of a function's source).
"""

from __future__ import annotations

import inspect

from neweul_py.codegen.elastic import kernel_source
from neweul_py.ffrf import KERNEL_FUNCTIONS, SPLICE_FUNCTIONS


def test_kernel_source_is_getsource():
    """Every embedded kernel function's lines equal ``inspect.getsource``'s, decorators and
    trailing lines alike, so generated modules stay byte-identical."""
    for fn in (*KERNEL_FUNCTIONS, *SPLICE_FUNCTIONS):
        assert kernel_source(fn) == tuple(inspect.getsource(fn).rstrip("\n").splitlines()), \
            fn.__name__
