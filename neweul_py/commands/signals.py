"""``-u NAME=EXPR`` of ``neweul simulate``: inputs as expressions of ``t`` (docs/analysis.md).

An expression is parsed by the description language's safe parser (names: ``t`` and the
model's parameters) and evaluated by walking its tree
(:func:`neweul_py.description.signals.signal_function`); an input that drives the kinematics
also gets its rates ``d_NAME``, ``dd_NAME`` from the analytic time derivatives. Plain numbers
hold the input constant and need no sympy (a generated ``.py`` stays sympy-free).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

from ..errors import NeweulError

if TYPE_CHECKING:
    import numpy as np


def input_assignment(text: str) -> tuple[str, str]:
    """``NAME=EXPR`` → ``(name, expr text)`` (an argparse type)."""
    name, sep, value = text.partition("=")
    if not sep or not name.strip() or not value.strip():
        raise argparse.ArgumentTypeError(f"expected NAME=EXPRESSION, got {text!r}")
    return name.strip(), value.strip()


def _number(text: str) -> float | None:
    try:
        value = float(text)
    except ValueError:
        return None
    if not math.isfinite(value):
        raise NeweulError(f"-u: {text!r} is not a finite number")
    return value


def input_function(module: Any, assignments: Sequence[tuple[str, str]],
                   overrides: Mapping[str, float] | None = None
                   ) -> Callable[[float], np.ndarray] | dict[str, float] | None:
    """The ``u`` argument of :func:`~neweul_py.analysis.simulate.simulate` for ``-u`` options:
    ``None`` (none given), constants ``{name: value}``, or ``u(t)`` over the default inputs;
    ``overrides`` are the ``-p`` parameter values.

    Raises
    ------
    NeweulError
        For an unknown input, a rate given directly, or an expression that does not parse.
    """
    if not assignments:
        return None
    names = list(module.INPUTS)
    rates = dict(getattr(module, "INPUT_RATES", {}) or {})
    rate_names = {r for rs in rates.values() for r in rs}
    for name, _ in assignments:
        if name not in names or name in rate_names:
            valid = [n for n in names if n not in rate_names]
            raise NeweulError(f"-u: unknown input {name!r}; inputs are: "
                              f"{', '.join(valid) or '(none)'}")
    constants = {name: _number(text) for name, text in assignments}
    if all(v is not None for v in constants.values()) and not rates:
        return constants  # type: ignore[return-value]
    import numpy as np  # here: the parser of every command is built without NumPy

    from ..description import parse_expression
    from ..description.signals import signal_function
    from ..errors import ModelError
    from ..model import symbol, time

    p = np.asarray(module.default_parameters(), dtype=float).copy()
    for k, v in (overrides or {}).items():
        if k in module.PARAMETERS:  # unknown names are reported by simulate
            p[list(module.PARAMETERS).index(k)] = float(v)
    params = {n: symbol(n) for n in module.PARAMETERS}
    values = {params[n]: float(v) for n, v in zip(module.PARAMETERS, p, strict=True)}
    signals: list[tuple[int, Callable[[float], float]]] = []
    for name, text in assignments:
        try:
            expr = parse_expression(text, {"t": time, **params}, key_path=f"-u {name}")
            derivatives = [expr] + [expr.diff(time, k) for k in (1, 2)]
            targets = [name, *rates.get(name, [])]
            for target, d in zip(targets, derivatives, strict=False):
                signals.append((names.index(target), signal_function(d, values)))
        except ModelError as exc:
            raise NeweulError(str(exc)) from None

    def u(t: float) -> np.ndarray:
        out = np.asarray(module.default_inputs(t, p), dtype=float).reshape(-1).copy()
        for index, f in signals:
            out[index] = f(t)
        return out

    return u
