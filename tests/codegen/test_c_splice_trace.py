"""The arrays the compiled backend binds (neweul_py/codegen/c_splice_trace.py, ``bound_arrays``).

Reference: the mixing forms themselves — each body's stack, bound in full, is
``ffrf_expand`` of its own compact members.
"""

from __future__ import annotations

import numpy as np

from neweul_py.codegen.c_splice_trace import bound_arrays
from neweul_py.ffrf.data_file import ArrayStore, ffrf_split
from neweul_py.ffrf.parametric import ffrf_stack
from neweul_py.ffrf.varying import ffrf_expand


def test_bodies_that_share_compact_members_keep_their_own_stacks() -> None:
    """Two parametric bodies whose samples do not vary store equal (k, 0) ``varying``
    arrays once in the data file; each is still bound to its own stack (its base)."""
    forms = [ffrf_stack([{"mass": m, "K": m * np.eye(3)}] * 3) for m in (1.0, 5.0)]
    store = ArrayStore()
    skeleton = ffrf_split({"bodies": [{"mixing": f} for f in forms]}, "d", store)
    traced, arrays, expand = bound_arrays(skeleton, store.arrays)
    keys = [b["mixing"]["stack"]["@"] for b in traced["bodies"]]
    assert len(set(keys)) == 2 and set(expand) == set(keys)
    for key, form in zip(keys, forms, strict=True):
        want = ffrf_expand(form["base"], form["base_rows"], form["index"], form["varying"],
                           form["mirror"], form["scaled"])
        np.testing.assert_array_equal(arrays[key], want)
