"""Optional groups of a working-point FE file: the static state and the loss factors.

A working point (an FE model linearized about a static state, e.g. of ``neweul fem
middle-ear``) is a ``neweul-fe`` ``.npz`` (:func:`neweul_py.elastic.io.fe_files.write_fe_model`)
with two optional groups that readers of the format may ignore (backward compatible:
:func:`~neweul_py.elastic.io.fe_files.read_fe_model` reads only its own arrays):

* ``static_*`` — the static state the model is linearized about: ``static_dp`` [Pa],
  ``static_node_id``, ``static_reference``, ``static_u`` (TM nodes, reference positions and
  static displacements [m]), ``static_x`` (the static state on the model's DOFs),
  ``static_manubrium_node_id``, ``static_manubrium_force`` (static forces of the malleus on the
  manubrium nodes [N]), ``static_malleus_q`` (6), ``static_chain_tangent`` (6×6);
* ``loss_*`` — the hysteretic damping ``G`` of the frequency-domain stiffness ``K + iG``
  (``loss_G_data``, ``loss_G_indices``, ``loss_G_indptr``, ``loss_G_shape``: CSR) and
  ``loss_meta`` (UTF-8 JSON: the loss factors, ``f_ref`` and how ``D = G/ω_ref`` was made).

An FRF should use ``K + iG − ω² M`` (``D`` ignored); a time integration uses ``D``.

The working points of one mesh are best stored as delta files of one complete working point
(``base``; :mod:`~neweul_py.elastic.io.fe_delta`): the readers here merge a delta with its base.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sps

from ...errors import DataError
from ..fe_model import FEModel
from .fe_delta import write_fe_arrays
from .fe_files import fe_arrays, load_fe_arrays, loss_group

__all__ = [
    "read_loss",
    "read_static",
    "static_loads",
    "write_working_point",
]


def write_working_point(
    fe: FEModel,
    path: str | os.PathLike,
    g: sps.spmatrix | None = None,
    loss: dict[str, Any] | None = None,
    static: dict[str, np.ndarray] | None = None,
    base: str | os.PathLike | None = None,
) -> None:
    """Write ``fe`` as a ``neweul-fe`` ``.npz`` plus the optional ``loss_*``/``static_*`` groups,
    in one atomic, deterministic write; with ``base`` (a complete FE file in the same or a
    sibling directory) as a delta file of it.
    """
    arrays = fe_arrays(fe)
    if g is not None:
        arrays.update(loss_group(g, loss or {}))
    for key, value in (static or {}).items():
        arrays[f"static_{key}"] = np.asarray(value)
    write_fe_arrays(Path(path), arrays, base)


def read_loss(path: str | os.PathLike) -> tuple[sps.csr_matrix, dict[str, Any]] | None:
    """``(G, loss_meta)`` of a working-point file, or ``None`` if it has no ``loss`` group."""
    data = load_fe_arrays(path)
    if "loss_G_data" not in data:
        return None
    try:
        shape = tuple(int(s) for s in data["loss_G_shape"])
        g = sps.csr_matrix(
            (data["loss_G_data"], data["loss_G_indices"], data["loss_G_indptr"]), shape=shape
        )
        meta = json.loads(data["loss_meta"].tobytes().decode("utf-8"))
    except (KeyError, ValueError, TypeError, UnicodeDecodeError) as exc:
        raise DataError(f"inconsistent loss group ({exc})", str(path), "loss_G") from None
    return g, meta


def static_loads(path: str | os.PathLike, kept: set[int] | None = None
                 ) -> dict[str, Any] | None:
    """The keywords of :func:`neweul_py.elastic.reductors.static_state.static_deflection` for the
    working point in ``path``: ``x`` (``static_x``) and ``node_force`` (the static manubrium
    forces at the node ids in ``kept``, all of them for ``None``); ``None`` for a file without
    a static state (or not ``.npz``)."""
    st = read_static(path) if str(path).endswith(".npz") else None
    if st is None or "x" not in st:
        return None
    ids = [int(i) for i in st.get("manubrium_node_id", ())]
    forces = {i: f for i, f in zip(ids, st.get("manubrium_force", ()), strict=True)
              if kept is None or i in kept}
    return {"x": st["x"], "node_force": forces}


def read_static(path: str | os.PathLike) -> dict[str, np.ndarray] | None:
    """The ``static`` group (keys without the ``static_`` prefix), or ``None`` if absent."""
    data = load_fe_arrays(path)
    out = {k[len("static_") :]: v for k, v in data.items() if k.startswith("static_")}
    return out or None
