"""Values of description keys: numbers, names, vectors, inertias, and expressions parsed with
the names of their scope (:class:`Names`).

Shape checks (``check_*``) run when an item is added to the builder; :class:`Names` parses
expression strings when the system is built, when every name is known. Every error is a
:class:`~neweul_py.errors.ModelError` naming the key path.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import sympy as sp

from ..errors import ModelError
from .expressions import ExpressionError, as_expression, parse_expression

__all__ = [
    "KIND_WORDS",
    "SCOPES",
    "Names",
    "check_frame_name",
    "check_inertia",
    "check_points",
    "check_vector",
    "constant_number",
    "is_sequence",
    "parse_points",
    "two_frames",
    "type_name",
]

#: The scopes of expressions: which kinds of names each may use.
SCOPES: Mapping[str, tuple[str, ...]] = {
    "constant": ("parameter",),
    "excitation": ("parameter", "time"),
    "kinematic": ("parameter", "coordinate", "input", "time"),
    "dynamic": ("parameter", "coordinate", "input", "time", "velocity", "input_rate"),
}

KIND_WORDS = {
    "parameter": "a parameter",
    "coordinate": "a coordinate",
    "velocity": "a velocity",
    "input": "an input",
    "input_rate": "a time derivative of an input",
    "time": "the time",
    "frame": "a frame",
    "body": "a body",
    "elastic_body": "an elastic body",
    "force": "a force element",
    "output": "an output",
}


# ----------------------------------------------------------------------------- values
def is_sequence(value: object) -> bool:
    return isinstance(value, Sequence) and not isinstance(value, str | bytes)


def type_name(value: object) -> str:
    return f"{type(value).__name__} {value!r}"


def constant_number(value: object, key_path: str, what: str = "value") -> float:
    """A finite number from an ``int``, ``float`` or a constant expression string (``"2*pi"``).

    YAML reads ``1e-3`` (without a dot) as a string, so numeric strings must be accepted.

    Raises
    ------
    ModelError
        For anything else (``bool``, NaN, inf, names, lists…), naming ``what`` and the value.
    """
    if isinstance(value, bool):
        raise ModelError(f"{what} must be a number, got {type_name(value)}", key_path)
    if isinstance(value, int | float):
        if not math.isfinite(value):
            raise ModelError(f"{what} must be a finite number, got {value!r}", key_path)
        return float(value)
    if isinstance(value, sp.Basic) and value.is_number:
        try:
            result = float(value)
        except (TypeError, ValueError):
            raise ModelError(f"{what} must be a real number, got {value}", key_path) from None
    elif isinstance(value, str):
        try:
            expr = parse_expression(value, {})
        except ExpressionError as exc:
            raise ModelError(
                f"{what} must be a number (or a constant expression such as 2*pi), got "
                f"{value!r} ({exc.reason})",
                key_path,
            ) from None
        result = float(expr)
    else:
        raise ModelError(f"{what} must be a number, got {type_name(value)}", key_path)
    if not math.isfinite(result):
        raise ModelError(f"{what} must be a finite number, got {value!r}", key_path)
    return result


def check_vector(value: object, key_path: str, length: int = 3) -> None:
    """Check the shape of a vector given as a sequence or a sympy matrix."""
    if isinstance(value, sp.MatrixBase):
        if value.shape not in ((length, 1), (1, length)):
            raise ModelError(
                f"expected a vector of {length} expressions, got a matrix of shape {value.shape}",
                key_path,
            )
        return
    if not is_sequence(value):
        raise ModelError(
            f"expected a list of {length} expressions, got {type_name(value)}", key_path
        )
    if len(value) != length:
        raise ModelError(
            f"expected a list of {length} expressions, got {len(value)}", key_path
        )


def check_inertia(value: object, key_path: str) -> None:
    if isinstance(value, Mapping):
        unknown = sorted(str(k) for k in value if k != "diag")
        if unknown:
            raise ModelError(
                f"unknown key {unknown[0]!r}; inertia is a 3×3 list of lists or "
                "{diag: [Ixx, Iyy, Izz]}",
                f"{key_path}.{unknown[0]}",
            )
        if "diag" not in value:
            raise ModelError("missing key 'diag'", key_path)
        check_vector(value["diag"], f"{key_path}.diag")
        return
    if isinstance(value, sp.MatrixBase):
        if value.shape != (3, 3):
            raise ModelError(f"expected a 3×3 matrix, got shape {value.shape}", key_path)
        return
    if not is_sequence(value) or len(value) != 3:
        raise ModelError(
            "expected a 3×3 list of lists or {diag: [Ixx, Iyy, Izz]}, got "
            + (f"{len(value)} rows" if is_sequence(value) else type_name(value)),
            key_path,
        )
    for i, row in enumerate(value):
        check_vector(row, f"{key_path}[{i}]")


def check_frame_name(value: object, key_path: str) -> str:
    if not isinstance(value, str):
        raise ModelError(f"expected a frame name, got {type_name(value)}", key_path)
    return value


# ----------------------------------------------------------------------------- names
@dataclass(frozen=True)
class Names:
    """All names of the model, and the parsing of values in a scope."""

    symbols: Mapping[str, sp.Symbol]  # every name that stands for a symbol
    kinds: Mapping[str, str]  # every name of the model → its kind
    #: Expression strings parsed so far, ``(text, scope) → expression`` (a description
    #: repeats the same few: ``m``, ``-l``, ``m*l**2/12`` … once per body); failures are not
    #: kept (their error names the key path).
    parsed: dict[tuple[str, str], sp.Expr] = dataclasses.field(
        default_factory=dict, compare=False, repr=False)

    def namespace(self, scope: str) -> dict[str, sp.Symbol]:
        kinds = SCOPES[scope]
        return {n: s for n, s in self.symbols.items() if self.kinds[n] in kinds}

    def expr(self, value: object, scope: str, key_path: str) -> sp.Expr:
        if isinstance(value, str):
            hit = self.parsed.get((value, scope))
            if hit is None:
                hit = self.parsed[value, scope] = self._parse(value, scope, key_path)
            return hit
        return self._parse(value, scope, key_path)

    def _parse(self, value: object, scope: str, key_path: str) -> sp.Expr:
        namespace = self.namespace(scope)
        if isinstance(value, sp.Basic) and not isinstance(value, sp.MatrixBase):
            # Symbols created by a user with other assumptions stand for the model's symbols.
            swap = {
                s: namespace[s.name]
                for s in value.free_symbols
                if isinstance(s, sp.Symbol) and s.name in namespace and s != namespace[s.name]
            }
            return value.xreplace(swap) if swap else value
        unavailable = {n: KIND_WORDS[k] for n, k in self.kinds.items() if n not in namespace}
        return as_expression(value, namespace, key_path=key_path, unavailable=unavailable)

    def vector(self, value: object, scope: str, key_path: str) -> sp.ImmutableMatrix:
        if isinstance(value, sp.MatrixBase):
            value = list(value)
        return sp.ImmutableMatrix(
            [self.expr(v, scope, f"{key_path}[{i}]") for i, v in enumerate(value)]
        )

    def inertia(self, value: object, key_path: str) -> sp.ImmutableMatrix:
        if isinstance(value, Mapping):
            diag = list(self.vector(value["diag"], "constant", f"{key_path}.diag"))
            k = len(diag)  # = sp.diag(*diag), without the general block-diagonal builder
            return sp.ImmutableMatrix(k, k, [diag[i] if i == j else sp.S.Zero
                                             for i in range(k) for j in range(k)])
        if isinstance(value, sp.MatrixBase):
            value = value.tolist()
        return sp.ImmutableMatrix(
            [
                [self.expr(v, "constant", f"{key_path}[{i}][{j}]") for j, v in enumerate(row)]
                for i, row in enumerate(value)
            ]
        )


def check_points(points: object, key_path: str) -> None:
    """``points: [pointA, pointB]`` (``None``: the frames' origins) at ``key_path``."""
    if points is not None:
        if not is_sequence(points) or len(points) != 2:  # type: ignore[arg-type]
            raise ModelError(f"expected two points [pointA, pointB], got {points!r}", key_path)
        for i, p in enumerate(points):  # type: ignore[arg-type]
            check_vector(p, f"{key_path}[{i}]")


def two_frames(between: object, key_path: str) -> tuple[str, str]:
    """``[frameA, frameB]``."""
    if not is_sequence(between) or len(between) != 2:  # type: ignore[arg-type]
        raise ModelError(f"expected two frame names [frameA, frameB], got {between!r}",
                         key_path)
    a, b = between  # type: ignore[misc]
    return check_frame_name(a, f"{key_path}[0]"), check_frame_name(b, f"{key_path}[1]")


def parse_points(n: Names, points: object, key_path: str
                 ) -> tuple[sp.ImmutableMatrix, sp.ImmutableMatrix]:
    """The two points of ``points`` (kinematic expressions; ``None``: origins)."""
    if points is None:
        return sp.ImmutableMatrix.zeros(3, 1), sp.ImmutableMatrix.zeros(3, 1)
    pa, pb = (n.vector(p, "kinematic", f"{key_path}[{i}]")
              for i, p in enumerate(points))  # type: ignore[arg-type]
    return pa, pb
