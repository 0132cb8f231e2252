"""Symbol conventions shared by every layer.

All symbols are real sympy ``Symbol`` objects created by these helpers, so that two symbols with
the same name are the same object everywhere (sympy caches symbols by name and assumptions).
"""

from __future__ import annotations

import keyword
import re

import sympy as sp

__all__ = [
    "INERTIAL",
    "RESERVED_NAMES",
    "as_expr",
    "check_name",
    "input_rate_name",
    "symbol",
    "time",
    "velocity_name",
]

#: Name of the inertial frame.
INERTIAL = "ISYS"

#: The time symbol ``t``.
time = sp.Symbol("t", real=True)

#: Names of the functions of the expression language and other reserved words.
RESERVED_NAMES = frozenset(
    {
        "t",
        INERTIAL,
        "pi",
        "E",
        "I",
        "sin",
        "cos",
        "tan",
        "asin",
        "acos",
        "atan",
        "atan2",
        "sinh",
        "cosh",
        "tanh",
        "exp",
        "log",
        "sqrt",
        "abs",
        "sign",
        "min",
        "max",
        "heaviside",
    }
)

_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


def symbol(name: str) -> sp.Symbol:
    """Return the real symbol named ``name`` (the same object for the same name)."""
    return sp.Symbol(name, real=True)


def velocity_name(coordinate: str) -> str:
    """Name of the time derivative of a coordinate: ``d_<name>``."""
    return f"d_{coordinate}"


def input_rate_name(name: str, order: int) -> str:
    """Name of the ``order``-th time derivative of an input: ``d_<name>`` (1), ``dd_<name>`` (2).

    Inputs used in kinematics (kinematic excitation) need their derivatives; the generated
    module takes them as further entries of the input vector ``u``
    (``docs/generated-module-protocol.md``, "Inputs used as kinematic excitation").
    """
    if order not in (1, 2):
        raise ValueError(f"order must be 1 or 2, not {order!r}")
    return f"{'d' * order}_{name}"


def check_name(name: object) -> str | None:
    """Return why ``name`` cannot name a model item, or ``None`` when it can.

    A name is an ASCII identifier that starts with a letter, is no Python keyword and no
    reserved word of the expression language, and does not start with ``d_`` (which names
    velocities).
    """
    if not isinstance(name, str):
        return f"a name must be a string, not {type(name).__name__}"
    if not _NAME.fullmatch(name):
        return f"{name!r} is not a valid name (letters, digits and _, starting with a letter)"
    if keyword.iskeyword(name) or name in RESERVED_NAMES:
        return f"{name!r} is a reserved word"
    if name.startswith("d_"):
        return f"{name!r} starts with 'd_', which is reserved for velocities"
    return None


def as_expr(value: object) -> sp.Basic:
    """Return ``value`` as a sympy object: sympy objects unchanged, Python numbers as exact
    sympy numbers (``int`` → ``Integer``, ``float`` → ``Float``).

    This is the only conversion the symbolic layers use. Unlike ``sympify`` it never parses
    text: a string raises ``TypeError`` (user text goes through the description parser).
    """
    if isinstance(value, sp.Basic):
        return value
    if isinstance(value, bool):
        raise TypeError("a boolean is not an expression")
    if isinstance(value, int):
        return sp.Integer(value)
    if isinstance(value, float):
        return sp.Float(value)
    raise TypeError(f"expected a sympy expression or a number, got {type(value).__name__}")
