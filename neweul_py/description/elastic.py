"""The ``elastic_bodies`` section of a description (issue 6, equations.md §2).

```yaml
elastic_bodies:
  beam:
    frame: hub                 # reference frame (ISYS: fixed to the ground)
    data: beam.SID_FEM         # SID text file or reduced-body .npz, relative to this file
    nodes: {tip: 1793, root: 1860}   # node frames beam.tip, beam.root
    modes: 4                   # optional: the first 4 modes, or a list of mode numbers
```

The data are read by a reader function that the caller passes in (layering: ``description``
imports only ``model``): :func:`neweul_py.elastic.reader.read_elastic_data`, which
:mod:`neweul_py.api` passes, returns the flat NumPy arrays (never symbolic). Errors in the data
file name the key path and the file (and, for SID syntax errors, the line).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator
from contextvars import ContextVar
from pathlib import Path
from typing import Any

from ..errors import DataError, ModelError
from ..model import ElasticBody

__all__ = ["base_directory", "load_elastic_bodies"]

#: ``reader(path, modes) -> dict of arrays`` (the flat invariants), may raise DataError.
ElasticReader = Callable[[Path, Any], dict]

_CONTEXT: ContextVar[tuple[Path, ElasticReader | None] | None] = ContextVar(
    "neweul_description_elastic", default=None)


@contextlib.contextmanager
def base_directory(filename: str, reader: ElasticReader | None = None) -> Iterator[None]:
    """Resolve the ``data`` files of elastic bodies relative to ``filename``'s directory and
    read them with ``reader``."""
    base = Path(filename).parent if filename and not filename.startswith("<") else Path.cwd()
    token = _CONTEXT.set((base, reader))
    try:
        yield
    finally:
        _CONTEXT.reset(token)


def load_elastic_bodies(b: Any, section: Any, path: str) -> None:
    """Section loader: every entry becomes an :class:`ElasticBody` on the builder ``b``."""
    from .loader import Schema, _items  # local: loader imports this module

    schema = Schema(required=("frame", "data"), optional=("nodes", "modes"))
    for name, spec in _items(section, path, "elastic body definitions"):
        item = f"{path}.{name}"
        spec = schema.check(spec, item, "an elastic body")
        frame = spec["frame"]
        if not isinstance(frame, str):
            raise ModelError(f"expected a frame name, got {frame!r}", f"{item}.frame")
        data_file = spec["data"]
        if not isinstance(data_file, str) or not data_file:
            raise ModelError(f"expected a file name, got {data_file!r}", f"{item}.data")
        nodes = spec.get("nodes") or {}
        if not isinstance(nodes, dict):
            raise ModelError(f"expected a mapping label: node id, got {nodes!r}",
                             f"{item}.nodes")
        pairs = []
        for label, node in nodes.items():
            if isinstance(node, bool) or not isinstance(node, int):
                raise ModelError(f"a node id must be an integer, got {node!r}",
                                 f"{item}.nodes.{label}")
            pairs.append((str(label), node))
        modes = spec.get("modes")
        if modes is not None and not (
            (isinstance(modes, int) and not isinstance(modes, bool))
            or (isinstance(modes, list) and all(isinstance(k, int) for k in modes))
        ):
            raise ModelError(f"modes must be a count or a list of mode numbers, got {modes!r}",
                             f"{item}.modes")
        base, reader = _CONTEXT.get() or (Path.cwd(), None)
        if reader is None:
            raise ModelError("elastic bodies need a data reader: load the description with "
                             "elastic_reader=neweul_py.elastic.reader.read_elastic_data (as "
                             "neweul_py.api does)", item)
        file = Path(data_file) if os.path.isabs(data_file) else base / data_file
        try:
            data = reader(file, modes)
        except DataError as exc:
            key = f"{item}.modes" if exc.item == "modes" else f"{item}.data"
            raise ModelError(f"elastic data: {exc}", key) from None
        b.elastic_body(ElasticBody(str(name), frame, data, tuple(pairs), os.fspath(file)))
