"""Input signals: tabulated from a CSV file, or an expression of ``t`` from the command line.

``inputs: {u: {table: signal.csv, interpolation: linear|cubic, column: u, time: t}}`` makes the
input ``u`` a :class:`~neweul_py.model.functions.SignalTable` of ``t`` — piecewise polynomials
the generated module evaluates with comparisons (NumPy only, deterministic), and whose time
derivatives ``d_u``, ``dd_u`` are again tables (kinematic excitation).

CSV format: UTF-8 text, ``#`` comment lines and blank lines ignored, a header row naming the
columns (a unit in brackets is allowed and ignored: ``t [s]``), then one row of numbers per
sample. ``time`` names the time column (default: ``t`` if there is one, else the first column),
``column`` the signal (default: the input's name). The times must increase strictly; outside
the table the signal holds its first and last values. ``linear`` interpolates linearly,
``cubic`` with the natural cubic spline (C², zero curvature at both ends; at least 3 samples).

:func:`signal_function` turns a parsed expression of ``t`` (``neweul simulate -u F=EXPR``) into
a fast numeric callable by walking the sympy tree once — no ``eval``, no ``lambdify``.
"""

from __future__ import annotations

import math
import os
import stat
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import sympy as sp

from ..errors import ModelError
from ..model import TableCurve, time
from ..model.functions import SignalTable

if TYPE_CHECKING:
    import numpy as np

__all__ = ["MAX_SAMPLES", "read_signal", "signal_function", "table_signal"]

#: Largest number of samples of a tabulated signal (each is a piece of the generated code).
MAX_SAMPLES = 10_000
_MAX_BYTES = 16 * 2**20
_INTERPOLATIONS = ("linear", "cubic")


def _column_name(header: str) -> str:
    """``"t [s]"`` → ``"t"``."""
    name = header.strip()
    if name.endswith("]") and "[" in name:
        name = name[: name.rindex("[")].strip()
    return name


def read_signal(path: Path, column: str, time_column: str | None, key_path: str
                ) -> tuple[np.ndarray, np.ndarray]:
    """Times and values of one column of a signal CSV, validated.

    Raises
    ------
    ModelError
        Naming ``key_path``, the file, the line and the column, for every problem of the table
        (``docs/description-format.md``, "Tabulated input signals").
    """
    import numpy as np

    where = os.fspath(path)
    try:
        info = path.stat()
    except OSError as exc:
        raise ModelError(f"cannot read the signal file {where}: {exc.strerror}", key_path) \
            from None
    if not stat.S_ISREG(info.st_mode):
        raise ModelError(f"the signal file {where} is not a regular file", key_path)
    if info.st_size > _MAX_BYTES:
        raise ModelError(f"the signal file {where} is larger than {_MAX_BYTES // 2**20} MiB",
                         key_path)
    try:
        text = path.read_bytes().decode("utf-8")
    except OSError as exc:
        raise ModelError(f"cannot read the signal file {where}: {exc.strerror}", key_path) \
            from None
    except UnicodeDecodeError:
        raise ModelError(f"the signal file {where} is not UTF-8 text", key_path) from None
    rows = [(k + 1, line) for k, line in enumerate(text.splitlines())
            if line.strip() and not line.lstrip().startswith("#")]
    if not rows:
        raise ModelError(f"the signal file {where} is empty", key_path)
    header_line, header = rows[0]
    names = [_column_name(h) for h in header.split(",")]
    if _is_number(names[0]):
        raise ModelError(f"{where}:{header_line}: the first row must name the columns "
                         "(e.g. t,u)", key_path)
    if time_column is None:
        time_column = "t" if "t" in names else names[0]
    for wanted, what in ((time_column, "time column"), (column, "column")):
        if wanted not in names:
            raise ModelError(f"{where}:{header_line}: no {what} {wanted!r}; columns are: "
                             f"{', '.join(names)}", key_path)
    if len(rows) - 1 > MAX_SAMPLES:
        raise ModelError(f"{where}: {len(rows) - 1} samples, more than {MAX_SAMPLES} (resample "
                         "the signal)", key_path)
    i_t, i_u = names.index(time_column), names.index(column)
    data = np.empty((len(rows) - 1, 2))
    for r, (line_no, line) in enumerate(rows[1:]):
        fields = line.split(",")
        if len(fields) != len(names):
            raise ModelError(f"{where}:{line_no}: {len(fields)} values, the header names "
                             f"{len(names)} columns", key_path)
        for j, (i, name) in enumerate(((i_t, time_column), (i_u, column))):
            try:
                value = float(fields[i])
            except ValueError:
                raise ModelError(f"{where}:{line_no}: column {name!r}: {fields[i].strip()!r} "
                                 "is not a number", key_path) from None
            if not math.isfinite(value):
                raise ModelError(f"{where}:{line_no}: column {name!r}: {fields[i].strip()} is "
                                 "not a finite number", key_path)
            data[r, j] = value
    if data.shape[0] < 2:
        raise ModelError(f"{where}: a signal needs at least 2 samples", key_path)
    bad = np.flatnonzero(np.diff(data[:, 0]) <= 0)
    if bad.size:
        line_no = rows[bad[0] + 2][0]
        raise ModelError(f"{where}:{line_no}: column {time_column!r}: times must increase "
                         f"strictly ({data[bad[0] + 1, 0]:g} after {data[bad[0], 0]:g})",
                         key_path)
    return data[:, 0], data[:, 1]


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def table_signal(t: np.ndarray, u: np.ndarray, interpolation: str = "linear",
                 key_path: str = "") -> SignalTable:
    """The signal through ``(t_i, u_i)`` as a :class:`SignalTable` of the model time ``t``.

    ``linear``: straight segments; ``cubic``: the natural cubic spline
    (``scipy.interpolate.CubicSpline(bc_type="natural")``). Constant before the first and after
    the last sample.
    """
    import numpy as np

    if interpolation not in _INTERPOLATIONS:
        raise ModelError(f"interpolation must be one of {', '.join(_INTERPOLATIONS)}, not "
                         f"{interpolation!r}", f"{key_path}.interpolation")
    if interpolation == "linear":
        slope = np.diff(u) / np.diff(t)
        inner = [(u[i], slope[i]) for i in range(t.size - 1)]
    else:
        if t.size < 3:
            raise ModelError("a cubic signal needs at least 3 samples", key_path)
        from scipy.interpolate import CubicSpline

        c = CubicSpline(t, u, bc_type="natural").c  # c[k, i]: coefficient of (t - t_i)^(3-k)
        inner = [tuple(c[::-1, i]) for i in range(t.size - 1)]
    coeffs = [(u[0],), *inner, (u[-1],)]
    shifts = [t[0], *t[:-1], t[-1]]
    F = sp.Float
    return SignalTable(time, [F(float(k)) for k in t], [F(float(s)) for s in shifts],
                       [[F(float(v)) for v in cs] for cs in coeffs])


def load_table_input(name: str, spec: Mapping[str, object], base: Path, key_path: str
                     ) -> SignalTable:
    """``{table: FILE, interpolation:, column:, time:}`` of ``inputs.NAME`` → the signal."""
    allowed = ("table", "interpolation", "column", "time")
    for key in spec:
        if key not in allowed:
            raise ModelError(f"unknown key {key!r} in a table input; valid keys are: "
                             f"{', '.join(allowed)}", f"{key_path}.{key}")
    for key in ("table", "column", "time", "interpolation"):
        if key in spec and (not isinstance(spec[key], str) or not spec[key]):
            raise ModelError(f"expected a name, got {spec[key]!r}", f"{key_path}.{key}")
    if "table" not in spec:
        raise ModelError("a table input needs the key 'table' (a CSV file)", key_path)
    path = base / str(spec["table"])
    column = str(spec.get("column", name))
    time_column = spec.get("time")
    t, u = read_signal(path, column, None if time_column is None else str(time_column),
                       f"{key_path}.table")
    return table_signal(t, u, str(spec.get("interpolation", "linear")), key_path)


# ------------------------------------------------------------------------- numeric values
_UNARY: Mapping[type, Callable[[float], float]] = {
    sp.sin: math.sin, sp.cos: math.cos, sp.tan: math.tan, sp.asin: math.asin,
    sp.acos: math.acos, sp.atan: math.atan, sp.sinh: math.sinh, sp.cosh: math.cosh,
    sp.tanh: math.tanh, sp.exp: math.exp, sp.log: math.log,
}
_RELATIONS: Mapping[type, Callable[[float, float], bool]] = {
    sp.StrictLessThan: lambda a, b: a < b, sp.LessThan: lambda a, b: a <= b,
    sp.StrictGreaterThan: lambda a, b: a > b, sp.GreaterThan: lambda a, b: a >= b,
}


def signal_function(expr: sp.Basic, values: Mapping[sp.Symbol, float],
                    variable: sp.Symbol = time) -> Callable[[float], float]:
    """A numeric function ``f(t)`` of an expression of the description language.

    The tree is compiled once into nested closures (Add, Mul, Pow, the functions of the
    language, Piecewise with its conditions, Min, Max, Abs, sign, Heaviside, table curves);
    ``values`` gives the numbers of the other symbols (parameters).

    Raises
    ------
    ModelError
        For a symbol without a value or a node outside the language.
    """
    import numpy as np

    def build(e: sp.Basic) -> Callable[[float], float]:
        if e == variable:
            return lambda t: t
        if e.is_Symbol:
            if e not in values:
                raise ModelError(f"{e.name!r} has no value here (only t and parameters)")
            v = float(values[e])
            return lambda t: v
        if e is sp.true or e is sp.false:
            b = bool(e)
            return lambda t: b
        if isinstance(e, sp.Expr) and e.is_number:
            v = float(e)
            return lambda t: v
        args = [build(a) for a in (e.args if not isinstance(e, sp.Piecewise) else ())]
        if e.is_Add:
            return lambda t: math.fsum(f(t) for f in args)
        if e.is_Mul:
            return lambda t: math.prod(f(t) for f in args)
        if e.is_Pow:
            base, expo = args
            return lambda t: base(t) ** expo(t)
        if isinstance(e, sp.Piecewise):
            pairs = [(build(v), build(c)) for v, c in e.args]
            return lambda t: next(v(t) for v, c in pairs if c(t))
        if type(e) in _RELATIONS:
            rel, (lhs, rhs) = _RELATIONS[type(e)], args
            return lambda t: rel(lhs(t), rhs(t))
        if isinstance(e, sp.And):
            return lambda t: all(f(t) for f in args)
        if isinstance(e, sp.Or):
            return lambda t: any(f(t) for f in args)
        if isinstance(e, TableCurve):
            return lambda t: e.evaluate(args[0](t))
        simple = _UNARY.get(type(e))
        if simple is not None:
            (arg,) = args
            return lambda t: simple(arg(t))
        if isinstance(e, sp.atan2):
            y, x = args
            return lambda t: math.atan2(y(t), x(t))
        if e.func.__name__ == "Min":
            return lambda t: min(f(t) for f in args)
        if e.func.__name__ == "Max":
            return lambda t: max(f(t) for f in args)
        if isinstance(e, sp.Abs):
            return lambda t: abs(args[0](t))
        if isinstance(e, sp.sign):
            return lambda t: float(np.sign(args[0](t)))
        if isinstance(e, sp.Heaviside):
            h0 = float(e.args[1]) if len(e.args) > 1 else 0.5
            return lambda t: 1.0 if args[0](t) > 0 else 0.0 if args[0](t) < 0 else h0
        raise ModelError(f"cannot evaluate {type(e).__name__} in an input signal")

    return build(expr)
