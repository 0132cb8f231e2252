"""Force elements from their description mappings, by each element's schema.

A ``forces.NAME`` mapping names its ``type``; the element class of that type
(:data:`~neweul_py.model.FORCE_TYPES`) lists its keys (:attr:`~neweul_py.model.ForceElement.keys`,
:class:`~neweul_py.model.Key`). Each key's value is checked by its kind when the element is
added (:func:`check_value`) and parsed into the element's fields when the system is built
(:func:`parse_value`), with the names of its scope. An optional key given as ``null`` is the
same as an absent one: its field keeps the element's default.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import sympy as sp

from ..errors import ModelError
from ..model import (
    AXES,
    ELONGATION,
    ELONGATION_RATE,
    FORCE_TYPES,
    ForceElement,
    Key,
    table_characteristic,
)
from .expressions import as_expression
from .schema import Schema
from .values import (
    KIND_WORDS,
    Names,
    check_frame_name,
    check_inertia,
    check_points,
    check_vector,
    constant_number,
    is_sequence,
    parse_points,
    two_frames,
    type_name,
)

__all__ = ["check_value", "force_schema", "force_type", "given_values", "parse_value"]

#: The local names of a characteristic's expressions.
_LOCAL = {"s": ELONGATION, "sd": ELONGATION_RATE}
_TABLE_KEYS = ("table", "interpolation")


def force_type(spec: object, path: str) -> type[ForceElement]:
    """The element class of a ``forces.NAME`` mapping's ``type``."""
    if not isinstance(spec, dict) or "type" not in spec:
        raise ModelError(f"a force needs a 'type', one of: {', '.join(FORCE_TYPES)}", path)
    kind = spec["type"]
    if not isinstance(kind, str) or kind not in FORCE_TYPES:
        raise ModelError(f"unknown force type {kind!r}; types are: {', '.join(FORCE_TYPES)}",
                         f"{path}.type")
    return FORCE_TYPES[kind]


def force_schema(element: type[ForceElement]) -> Schema:
    """The keys of the element's mapping: ``type``, its schema's keys and ``report``."""
    keys = element.schema()
    return Schema(required=("type", *(k.name for k in keys if k.required)),
                  optional=(*(k.name for k in keys if not k.required), "report"))


def given_values(element: type[ForceElement], spec: Mapping[str, Any]) -> dict[Key, Any]:
    """The keys given in ``spec`` (an optional key that is ``None`` is not given)."""
    return {k: spec[k.name] for k in element.schema()
            if k.name in spec and (k.required or spec[k.name] is not None)}


# ----------------------------------------------------------------------------- checks
def _check_coordinate(value: object, key_path: str) -> None:
    if not isinstance(value, str):
        raise ModelError(f"expected a coordinate name, got {type_name(value)}", key_path)


def _check_axis(value: object, key_path: str) -> None:
    if value not in AXES:
        raise ModelError(f"axis must be one of x, y, z, not {value!r}", key_path)


def _check_matrix(value: object, key_path: str) -> None:
    """One value, ``{diag: [a, b, c]}`` or a 3×3 list of lists."""
    if isinstance(value, int | float | str | sp.Expr) and not isinstance(value, bool):
        return
    check_inertia(value, key_path)


def _no_check(value: object, key_path: str) -> None:
    """Expressions are checked when they are parsed."""


_CHECKS: Mapping[str, Callable[[object, str], object]] = {
    "frame": check_frame_name,
    "frames": two_frames,
    "coordinate": _check_coordinate,
    "axis": _check_axis,
    "expression": _no_check,
    "vector": check_vector,
    "points": check_points,
    "matrix": _check_matrix,
    "characteristic": _no_check,
    "loss_factor": _no_check,
}


def check_value(key: Key, value: object, key_path: str) -> None:
    """The shape of a key's value, when the element is added (no names needed)."""
    _CHECKS[key.kind](value, key_path)


# ----------------------------------------------------------------------------- parsing
def _matrix(n: Names, value: object, scope: str, key_path: str) -> sp.ImmutableMatrix:
    if isinstance(value, Mapping):
        diag = n.vector(value["diag"], scope, f"{key_path}.diag")
        return sp.ImmutableMatrix(sp.diag(*diag))
    if isinstance(value, int | float | str | sp.Expr):
        return sp.ImmutableMatrix(sp.eye(3) * n.expr(value, scope, key_path))
    if isinstance(value, sp.MatrixBase):
        value = value.tolist()
    return sp.ImmutableMatrix(
        [
            [n.expr(v, scope, f"{key_path}[{i}][{j}]") for j, v in enumerate(row)]
            for i, row in enumerate(value)  # type: ignore[arg-type]
        ]
    )


def _loss_factor(n: Names, value: object, key_path: str) -> sp.Expr:
    """The loss factor η (parameters only). A number must be finite and ≥ 0 here; an
    expression is checked at the parameter defaults when the system is built."""
    if isinstance(value, int | float) and not isinstance(value, bool) and value == 0:
        return sp.Integer(0)
    if isinstance(value, float | int) and not isinstance(value, bool) and not (
            math.isfinite(value) and value >= 0):
        raise ModelError(f"a loss factor is a finite number ≥ 0, got {value!r}", key_path)
    return n.expr(value, "constant", key_path)


def _table(value: Mapping, variable: sp.Symbol, key_path: str) -> sp.Expr:
    """A characteristic curve ``{table: [[v, F], …], interpolation: linear|spline}``."""
    unknown = [str(k) for k in value if k not in _TABLE_KEYS]
    if unknown:
        raise ModelError(
            f"unknown key {unknown[0]!r}; a characteristic table has the keys "
            f"{', '.join(_TABLE_KEYS)}",
            f"{key_path}.{unknown[0]}",
        )
    if "table" not in value:
        raise ModelError("a characteristic table needs the key 'table'", key_path)
    rows = value["table"]
    if not is_sequence(rows):
        raise ModelError(f"expected a list of [value, force] pairs, got {type_name(rows)}",
                         f"{key_path}.table")
    numbers = []
    for i, row in enumerate(rows):
        if not is_sequence(row) or len(row) != 2:
            raise ModelError(f"expected a pair [value, force], got {row!r}",
                             f"{key_path}.table[{i}]")
        numbers.append([constant_number(v, f"{key_path}.table[{i}][{j}]")
                        for j, v in enumerate(row)])
    return table_characteristic(numbers, value.get("interpolation", "linear"), variable,
                                f"{key_path}.table")


def _characteristic(n: Names, key: Key, value: object, key_path: str
                    ) -> tuple[sp.Expr, sp.Expr | None]:
    """A stiffness or damping: ``(coefficient, None)`` for an expression (which may use the
    local names ``s`` and ``sd``), ``(0, curve)`` for a table."""
    if isinstance(value, Mapping):
        return sp.Integer(0), _table(value, _LOCAL[key.variable or "s"], key_path)
    if isinstance(value, sp.Basic) and not isinstance(value, sp.MatrixBase):
        return value, None
    namespace = {**n.namespace(key.scope or "dynamic"), **_LOCAL}
    unavailable = {k: KIND_WORDS[v] for k, v in n.kinds.items() if k not in namespace}
    return as_expression(value, namespace, key_path=key_path, unavailable=unavailable), None


_Parse = Callable[[Names, Key, Any, str], tuple[object, ...]]

_PARSERS: Mapping[str, _Parse] = {
    "frame": lambda n, key, v, path: (v,),
    "frames": lambda n, key, v, path: tuple(v),
    "coordinate": lambda n, key, v, path: (v,),
    "axis": lambda n, key, v, path: (v,),
    "expression": lambda n, key, v, path: (n.expr(v, key.scope or "dynamic", path),),
    "vector": lambda n, key, v, path: (n.vector(v, key.scope or "dynamic", path),),
    "points": lambda n, key, v, path: parse_points(n, v, path),
    "matrix": lambda n, key, v, path: (_matrix(n, v, key.scope or "dynamic", path),),
    "characteristic": _characteristic,
    "loss_factor": lambda n, key, v, path: (_loss_factor(n, v, path),),
}


def parse_value(n: Names, key: Key, value: Any, key_path: str) -> dict[str, object]:
    """The element's fields of one key (:attr:`Key.attrs`), its expressions parsed with the
    names of the key's scope, when the system is built."""
    return dict(zip(key.attrs, _PARSERS[key.kind](n, key, value, key_path), strict=True))
