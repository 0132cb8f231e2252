"""Read YAML into plain Python data plus the line of every key path.

PyYAML's safe loader forgets where things came from and silently keeps the last of duplicate
keys. Here the node graph is composed with :class:`yaml.SafeLoader` (no arbitrary objects), then
walked by hand: scalars are constructed by PyYAML's ``SafeConstructor``, mappings and sequences
by this module, which records ``key path → line`` and rejects duplicate keys.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import yaml
from yaml.constructor import SafeConstructor

from .errors import DescriptionError
from .yaml_shape import MAX_DEPTH, MAX_NODES, check_shape

__all__ = ["MAX_DEPTH", "MAX_NODES", "YamlTree", "check_shape", "read_description", "read_yaml"]

_MAX_NODES = 1_000_000  # guards against alias bombs ("billion laughs")
#: The safe loader with libyaml's C parser when PyYAML has it (the same resolver and the same
#: marks; the pure-Python scanner was 60 % of loading a 10-link chain), else the Python one.
_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
_MERGE_TAG = "tag:yaml.org,2002:merge"
_SEQ_TAG = "tag:yaml.org,2002:seq"
_MAP_TAG = "tag:yaml.org,2002:map"


@dataclass
class YamlTree:
    """Plain data (dicts, lists, scalars) and the 1-based line of each key path."""

    data: Any
    lines: dict[str, int] = field(default_factory=dict)
    file: str = "<description>"

    def line(self, key_path: str) -> int | None:
        """Line of ``key_path`` or, if it is not in the file, of its nearest ancestor."""
        path = key_path
        while True:
            if path in self.lines:
                return self.lines[path]
            if not path:
                return None
            path = _parent(path)


def _parent(path: str) -> str:
    """``a.b[1][2]`` → ``a.b[1]`` → ``a.b`` → ``a`` → ``""``."""
    if path.endswith("]"):
        return path[: path.rindex("[")]
    return path[: path.rindex(".")] if "." in path else ""


def _child(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


class _Walker:
    def __init__(self, file: str) -> None:
        self.file = file
        self.lines: dict[str, int] = {}
        self.constructor = SafeConstructor()
        self.count = 0
        self.active: set[int] = set()
        self.flattened: set[int] = set()

    def error(self, message: str, path: str, node: yaml.Node) -> DescriptionError:
        line = self.lines.get(path, node.start_mark.line + 1)
        return DescriptionError(message, path, self.file, line)

    def walk(self, node: yaml.Node, path: str) -> Any:
        self.count += 1
        if self.count > _MAX_NODES:
            raise self.error("the document is too large (alias expansion?)", path, node)
        if isinstance(node, yaml.ScalarNode):
            value = self.scalar(node, path)
            if isinstance(value, int) and not isinstance(value, bool) and abs(value) > _MAX_INT:
                raise self.error(f"the integer {node.value[:20]}… is beyond the range of a "
                                 "double-precision number", path, node)
            return value
        if node.tag not in (_SEQ_TAG, _MAP_TAG):
            raise self.error(f"YAML tag {node.tag!r} is not allowed", path, node)
        if id(node) in self.active:
            raise self.error("recursive YAML alias", path, node)
        self.active.add(id(node))
        try:
            if isinstance(node, yaml.SequenceNode):
                items = []
                for i, item in enumerate(node.value):
                    item_path = f"{path}[{i}]"
                    self.lines[item_path] = item.start_mark.line + 1
                    items.append(self.walk(item, item_path))
                return items
            if isinstance(node, yaml.MappingNode):
                return self.mapping(node, path)
            raise self.error(f"unsupported YAML node {node.tag}", path, node)
        finally:
            self.active.discard(id(node))

    def scalar(self, node: yaml.ScalarNode, path: str) -> Any:
        """The value of a scalar (PyYAML's safe constructor); an integer of more digits than
        Python converts (4300) is one error, like any integer beyond the range of doubles."""
        try:
            return self.constructor.construct_object(node)
        except ValueError as exc:
            digits = sum(c.isdigit() for c in node.value)
            what = (f"the integer of {digits} digits is beyond the range of a double-precision "
                    "number" if digits > 400 else f"the value {node.value[:20]!r} cannot be "
                    f"read ({exc})")
            raise self.error(what, path, node) from None

    def mapping(self, node: yaml.MappingNode, path: str) -> dict[str, Any]:
        if id(node) not in self.flattened:  # an aliased mapping is checked and merged once
            self.check_duplicates(node, path)
            self.constructor.flatten_mapping(node)  # resolve "<<" merge keys; own keys win
            self.flattened.add(id(node))
        result: dict[str, Any] = {}
        for key_node, value_node in node.value:
            key = self.key(key_node, path)
            key_path = _child(path, key)
            self.lines[key_path] = key_node.start_mark.line + 1
            result[key] = self.walk(value_node, key_path)
        return result

    def check_duplicates(self, node: yaml.MappingNode, path: str) -> None:
        seen: dict[object, int] = {}
        for key_node, _ in node.value:
            if key_node.tag == _MERGE_TAG:
                continue
            key = self.key(key_node, path)
            line = key_node.start_mark.line + 1
            if key in seen:
                raise self.error(
                    f"duplicate key {key!r} (first defined on line {seen[key]})",
                    _child(path, str(key)),
                    key_node,
                )
            seen[key] = line

    def key(self, node: yaml.Node, path: str) -> str:
        if not isinstance(node, yaml.ScalarNode):
            raise DescriptionError(
                "a key must be a plain name, not a list or mapping", path, self.file,
                node.start_mark.line + 1,
            )
        key = self.scalar(node, path)
        if not isinstance(key, str):
            hint = (
                " (YAML reads yes/no/on/off/true/false as booleans; quote the key)"
                if isinstance(key, bool)
                else ""
            )
            raise DescriptionError(
                f"a key must be a name, got {key!r}{hint}", path, self.file,
                node.start_mark.line + 1,
            )
        return key


#: Largest integer accepted (beyond it ``float(value)`` overflows).
_MAX_INT = 2**1023


def read_yaml(text: str, file: str = "<description>") -> YamlTree:
    """Parse YAML ``text`` safely into a :class:`YamlTree`.

    Raises
    ------
    DescriptionError
        For malformed YAML (with PyYAML's line), duplicate keys, non-string keys and
        recursive aliases.
    """
    try:
        check_shape(text, file)
        node = yaml.compose(text, Loader=_LOADER)
        if node is None:
            return YamlTree(None, {"": 1}, file)
        walker = _Walker(file)
        walker.lines[""] = 1
        data = walker.walk(node, "")
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        problem = " ".join(str(p) for p in (exc.context, exc.problem) if p)
        if "maximum nesting depth" in problem:  # libyaml ≥ 0.2.5's scanner looks ahead
            raise DescriptionError(f"the document is nested more than {MAX_DEPTH} levels "
                                   "deep", "", file, mark.line + 1 if mark else None) from None
        raise DescriptionError(
            f"malformed YAML: {problem or exc}", "", file, mark.line + 1 if mark else None
        ) from None
    except yaml.YAMLError as exc:
        raise DescriptionError(f"malformed YAML: {exc}", "", file) from None
    except RecursionError:
        raise DescriptionError(f"the document is nested more than {MAX_DEPTH} levels deep",
                               "", file) from None
    return YamlTree(data, walker.lines, file)


def read_description(text: str | bytes, file: str = "<description>") -> YamlTree:
    """Parse a description's text (bytes are decoded as UTF-8) into a :class:`YamlTree`, once:
    the loader (:func:`neweul_py.description.load_description_tree`) and the module cache
    (:mod:`neweul_py.api`, which needs the data files a description names) share the tree.

    Raises
    ------
    DescriptionError
        For text that is not UTF-8 and everything :func:`read_yaml` refuses.
    """
    if isinstance(text, bytes):
        try:
            text = text.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise DescriptionError(f"not UTF-8 text ({exc.reason})", "", file) from None
    return read_yaml(text, file)
