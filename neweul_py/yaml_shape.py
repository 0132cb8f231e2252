"""The shape of a YAML document — nesting depth and node count — checked from the parser's
event stream before any node is built, shared by the description loader and the cache key of
:mod:`neweul_py.api` (which must not import the symbolic layers on a cache hit).

libyaml's parser (PyYAML's ``CSafeLoader`` where available) streams events fast; building and
resolving nodes is what takes the time of a big document, and the composer recurses once per
level. Caps (docs/limits.md): :data:`MAX_DEPTH` levels, :data:`MAX_NODES` nodes.
"""

from __future__ import annotations

import yaml

from .errors import DescriptionError

__all__ = ["MAX_DEPTH", "MAX_NODES", "check_shape"]

#: The safe loader with libyaml's C parser when PyYAML has it, else the Python one.
_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)

#: Deepest nesting of mappings and sequences in a description (docs/limits.md).
MAX_DEPTH = 64
#: Most YAML nodes of a description (keys, values, list entries; an alias counts once):
#: a description of 10 000 parameters has 20 000 (docs/limits.md).
MAX_NODES = 100_000


def check_shape(text: str | bytes, file: str = "<description>") -> None:
    """Refuse nesting deeper than :data:`MAX_DEPTH` and more than :data:`MAX_NODES` nodes from
    the event stream, before any node is built (PyYAML's parser is iterative and libyaml's
    fast; its composer recurses once per level, and so does the walker; building and
    resolving nodes is what takes the time of a big document)."""
    depth = nodes = 0
    for event in yaml.parse(text, Loader=_LOADER):
        if isinstance(event, yaml.NodeEvent):
            nodes += 1
            if nodes > MAX_NODES:
                raise DescriptionError(f"the document has more than the cap of {MAX_NODES} "
                                       "YAML nodes (keys, values and list entries; "
                                       "docs/limits.md)", "", file, event.start_mark.line + 1)
        if isinstance(event, yaml.CollectionStartEvent):
            depth += 1
            if depth > MAX_DEPTH:
                raise DescriptionError(f"the document is nested more than {MAX_DEPTH} levels "
                                       "deep", "", file, event.start_mark.line + 1)
        elif isinstance(event, yaml.CollectionEndEvent):
            depth -= 1
