"""Characteristics of spring–dampers: force laws in the elongation and its rate, and tables.

A spring–damper's force law is written in the *local* variables ``s`` (elongation: distance
minus free length, or angle minus rest angle) and ``sd`` (its rate). In model expressions they
are the symbols :data:`ELONGATION` and :data:`ELONGATION_RATE`; the element's loads replace
them by its kinematics. ``stiffness`` and ``damping`` are *coefficients*
(force ``stiffness·s + damping·sd``) and may depend on ``s`` and ``sd``; a *table* is a
characteristic curve (force over ``s``, or over ``sd``) and replaces the product
(:func:`table_characteristic`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Literal, Protocol

import sympy as sp

from ...errors import ModelError
from ..functions import TableCurve

if TYPE_CHECKING:
    import numpy as np

__all__ = [
    "ELONGATION",
    "ELONGATION_RATE",
    "Characteristic",
    "characteristic_force",
    "force_law",
    "has_linear_spring",
    "table_characteristic",
    "tangent_stiffness",
]

#: The elongation ``s`` of a spring–damper characteristic.
ELONGATION = sp.Symbol("_elongation", real=True)
#: Its rate ``sd``.
ELONGATION_RATE = sp.Symbol("_elongation_rate", real=True)

Interpolation = Literal["linear", "spline"]


# ----------------------------------------------------------------------------- tables
def _natural_spline_slopes(x: np.ndarray, f: np.ndarray) -> np.ndarray:
    """First derivatives at the knots of the natural cubic spline through ``(x, f)``
    (zero curvature at both ends); tridiagonal system in the slopes."""
    import numpy as np

    m = x.size
    h = np.diff(x)
    delta = np.diff(f) / h
    a = np.zeros((m, m))
    rhs = np.zeros(m)
    a[0, 0], a[0, 1], rhs[0] = 2.0, 1.0, 3.0 * delta[0]
    a[-1, -2], a[-1, -1], rhs[-1] = 1.0, 2.0, 3.0 * delta[-1]
    for i in range(1, m - 1):
        a[i, i - 1] = h[i]
        a[i, i] = 2.0 * (h[i - 1] + h[i])
        a[i, i + 1] = h[i - 1]
        rhs[i] = 3.0 * (h[i] * delta[i - 1] + h[i - 1] * delta[i])
    return np.linalg.solve(a, rhs)


def table_characteristic(
    points: Sequence[Sequence[float]],
    interpolation: Interpolation = "linear",
    variable: sp.Symbol = ELONGATION,
    key_path: str = "",
) -> sp.Expr:
    """A characteristic curve ``F(v)`` through table points, as a sympy ``Piecewise``.

    Parameters
    ----------
    points
        ``[[v0, F0], [v1, F1], …]`` with strictly increasing ``v`` (at least 2 points).
    interpolation
        ``"linear"``: piecewise linear; ``"spline"``: the natural cubic spline (C², zero
        curvature at the end points; at least 3 points).
    variable
        The argument symbol (``s`` or ``sd``).

    Returns
    -------
    TableCurve
        One node whose pieces are polynomials in ``v − v_i`` (:class:`TableCurve`). Outside the
        table the curve is continued linearly with the end slopes (of the end segments, or of
        the spline, which joins C² there), so a spring does not go slack beyond its last point.
        Generated code evaluates it as a chain of comparisons; its derivative (for the force
        Jacobians) is the piecewise derivative.

    Examples
    --------
    >>> curve = table_characteristic([[0, 0], [1, 2], [2, 3]])
    >>> curve.evaluate(0.5), curve.evaluate(3.0)
    (1.0, 4.0)
    """
    import numpy as np

    if interpolation not in ("linear", "spline"):
        raise ModelError(
            f"interpolation must be 'linear' or 'spline', not {interpolation!r}",
            f"{key_path}.interpolation" if key_path else "interpolation",
        )
    try:
        arr = np.array(points, dtype=float)
    except (TypeError, ValueError):
        raise ModelError("a table is a list of [value, force] pairs of numbers", key_path) from None
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ModelError(f"a table is a list of [value, force] pairs, got shape {arr.shape}",
                         key_path)
    need = 3 if interpolation == "spline" else 2
    if arr.shape[0] < need:
        raise ModelError(f"a {interpolation} table needs at least {need} points", key_path)
    if not np.all(np.isfinite(arr)):
        raise ModelError("table values must be finite numbers", key_path)
    x, f = arr[:, 0], arr[:, 1]
    bad = np.nonzero(np.diff(x) <= 0)[0]
    if bad.size:
        raise ModelError(
            f"table arguments must increase strictly (row {bad[0] + 1}: {x[bad[0] + 1]:g} after "
            f"{x[bad[0]]:g})",
            f"{key_path}[{bad[0] + 1}]" if key_path else "",
        )
    if interpolation == "linear":
        slope = np.diff(f) / np.diff(x)
        shifts = x[:-1]
        coeffs = [(f[i], slope[i]) for i in range(x.size - 1)]
        knots = x[1:-1]
    else:
        d = _natural_spline_slopes(x, f)
        h = np.diff(x)
        delta = np.diff(f) / h
        c2 = (3 * delta - 2 * d[:-1] - d[1:]) / h
        c3 = (d[:-1] + d[1:] - 2 * delta) / h**2
        shifts = np.concatenate([[x[0]], x[:-1], [x[-1]]])
        coeffs = [(f[0], d[0])] + [(f[i], d[i], c2[i], c3[i]) for i in range(x.size - 1)] \
            + [(f[-1], d[-1])]
        knots = x
    F = sp.Float
    return TableCurve(
        variable,
        [F(k) for k in knots],
        [F(s) for s in shifts],
        [[F(c) for c in cs] for cs in coeffs],
    )


def characteristic_force(
    stiffness: sp.Expr,
    damping: sp.Expr,
    spring_force: sp.Expr | None = None,
    damper_force: sp.Expr | None = None,
) -> sp.Expr:
    """The force law ``F(s, sd)`` of a spring–damper in :data:`ELONGATION` and
    :data:`ELONGATION_RATE`: ``spring_force`` (a table curve) or ``stiffness·s``, plus
    ``damper_force`` or ``damping·sd``."""
    k_part = spring_force if spring_force is not None else stiffness * ELONGATION
    d_part = damper_force if damper_force is not None else damping * ELONGATION_RATE
    return k_part + d_part


class Characteristic(Protocol):
    """What an element with a characteristic holds (:class:`~neweul_py.model.SpringDamper`,
    :class:`~neweul_py.model.RotationalSpringDamper`)."""

    @property
    def stiffness(self) -> sp.Expr: ...
    @property
    def damping(self) -> sp.Expr: ...
    @property
    def spring_force(self) -> sp.Expr | None: ...
    @property
    def damper_force(self) -> sp.Expr | None: ...


def force_law(c: Characteristic, s: sp.Expr, sd: sp.Expr) -> sp.Expr:
    """``F(s, sd)`` of the characteristic with the element's kinematics substituted."""
    law = characteristic_force(c.stiffness, c.damping, c.spring_force, c.damper_force)
    return law.xreplace({ELONGATION: s, ELONGATION_RATE: sd})


def tangent_stiffness(c: Characteristic, s: sp.Expr, sd: sp.Expr) -> sp.Expr:
    """The tangent stiffness ``∂F_spring/∂s`` of the characteristic (its spring part: the
    table curve or ``stiffness·s``), with the kinematics substituted."""
    spring = characteristic_force(c.stiffness, sp.Integer(0), c.spring_force, None)
    return sp.diff(spring, ELONGATION).xreplace({ELONGATION: s, ELONGATION_RATE: sd})


def has_linear_spring(c: Characteristic) -> bool:
    """Whether the spring part is ``stiffness·s`` with a constant coefficient: no table, no
    ``s`` or ``sd`` in ``stiffness`` (then its potential is ``½ stiffness·s²``)."""
    return c.spring_force is None and not (
        {ELONGATION, ELONGATION_RATE} & c.stiffness.free_symbols)
