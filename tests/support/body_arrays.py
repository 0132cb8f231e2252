"""Body files as explicit arrays, for tests that edit files array by array.

A body file of the compact layout (docs/reduced-body-format.md) leaves out zero arrays, stores
what is constant over the samples once and no array twice. :func:`explicit_arrays` gives every
array of such a file written out (the layout undone, copies, not views) with the ``meta``
array without its ``layout`` entry: written back with ``numpy.savez`` under any version, it is
a file in the explicit layout of the versions before the compact one.
"""

from __future__ import annotations

import json

import numpy as np

from neweul_py.elastic.io.layout import unpack
from neweul_py.elastic.io.npz import json_to_uint8


def explicit_arrays(path) -> dict[str, np.ndarray]:
    """Every array of the body file ``path``, the compact layout undone (module docstring)."""
    with np.load(path, allow_pickle=False) as z:
        data = {key: z[key] for key in z.files}
    meta = json.loads(data["meta"].tobytes().decode())
    samples = data.get("samples")
    k = int(samples.size) if samples is not None else 1
    out = {key: np.array(a) for key, a in unpack(data, meta.pop("layout", None), k).items()}
    out["meta"] = json_to_uint8(meta)
    return out
