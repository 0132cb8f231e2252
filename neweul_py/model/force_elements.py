"""Force elements of issue 4 and their characteristics: bushings, rotational spring–dampers,
nonlinear (expression or table) characteristics, and outputs that report an element's force.

Characteristics
---------------
A spring–damper's force law is written in the *local* variables ``s`` (elongation: distance
minus free length, or angle minus rest angle) and ``sd`` (its rate). In model expressions they
are the symbols :data:`ELONGATION` and :data:`ELONGATION_RATE`; the equations layer replaces
them by the element's kinematics. ``stiffness`` and ``damping`` are *coefficients*
(force ``stiffness·s + damping·sd``) and may depend on ``s`` and ``sd``; a *table* is a
characteristic curve (force over ``s``, or over ``sd``) and replaces the product
(:func:`table_characteristic`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal

import sympy as sp

from ..errors import ModelError
from .elements import AXES, ForceElement, Output
from .symbols import as_expr

if TYPE_CHECKING:
    import numpy as np

__all__ = [
    "ELONGATION",
    "ELONGATION_RATE",
    "FORCE_COMPONENTS",
    "Bushing",
    "ForceOutput",
    "RotationalSpringDamper",
    "TableCurve",
    "characteristic_force",
    "table_characteristic",
]

#: The elongation ``s`` of a spring–damper characteristic.
ELONGATION = sp.Symbol("_elongation", real=True)
#: Its rate ``sd``.
ELONGATION_RATE = sp.Symbol("_elongation_rate", real=True)

_ONE = sp.Integer(1)
_ZERO = sp.Integer(0)
Axis = Literal["x", "y", "z"]
Interpolation = Literal["linear", "spline"]


def _zero3() -> sp.ImmutableMatrix:
    return sp.ImmutableMatrix.zeros(3, 1)


def _zero33() -> sp.ImmutableMatrix:
    return sp.ImmutableMatrix.zeros(3, 3)


# ----------------------------------------------------------------------------- tables
class TableCurve(sp.Expr):
    """A piecewise-polynomial characteristic curve ``F(v)`` of a table, as one sympy node.

    ``TableCurve(v, knots, shifts, coefficients)``: piece ``i`` is
    ``Σ_k coefficients[i][k] (v − shifts[i])^k``; piece ``i < m`` holds for ``v < knots[i]``
    (and not for the earlier ones), the last piece above the last knot. The node has the single
    argument ``v`` as far as differentiation and common-subexpression elimination see it, so
    derivatives (``F′(v) v′``, again a ``TableCurve``) and generated code grow linearly with
    the table. Generated code evaluates it as a chain of comparisons (``_pythoncode``).
    """

    is_commutative = True
    is_real = True

    def __new__(cls, v: object, knots: object, shifts: object, coefficients: object) -> TableCurve:
        return sp.Expr.__new__(cls, as_expr(v), sp.Tuple(*knots), sp.Tuple(*shifts),
                               sp.Tuple(*(sp.Tuple(*c) for c in coefficients)))

    @property
    def variable(self) -> sp.Expr:
        return self.args[0]

    def pieces(self) -> list[tuple[float, list[float]]]:
        """``(shift, coefficients)`` of every piece, in order."""
        return [(float(x0), [float(c) for c in cs]) for x0, cs in zip(self.args[2], self.args[3],
                                                                     strict=True)]

    def derivative(self) -> TableCurve:
        """``F′`` as a table curve of the same variable."""
        _, knots, shifts, coeffs = self.args
        d = [[k * c for k, c in enumerate(cs) if k > 0] or [sp.Float(0)] for cs in coeffs]
        return TableCurve(self.variable, knots, shifts, d)

    def _eval_derivative(self, x: sp.Symbol) -> sp.Expr:
        dv = self.variable.diff(x)
        return sp.S.Zero if dv == 0 else self.derivative() * dv

    def evaluate(self, value: float) -> float:
        """``F(value)`` numerically (tests, checks)."""
        knots = [float(k) for k in self.args[1]]
        i = next((j for j, k in enumerate(knots) if value < k), len(knots))
        shift, cs = self.pieces()[i]
        w = value - shift
        return sum(c * w**k for k, c in enumerate(cs))

    def _pythoncode(self, printer: object) -> str:
        """``(P0 if (_ncg_tab := v) < k1 else P1 if _ncg_tab < k2 else … else Pm)``."""
        v = printer._print(self.variable)  # type: ignore[attr-defined]
        name = "_ncg_tab"

        def poly(shift: float, cs: list[float]) -> str:
            w = f"({name} - {shift!r})" if shift != 0 else name
            out = repr(cs[-1])
            for c in cs[-2::-1]:
                out = f"{c!r} + {w}*({out})"
            return f"({out})"

        pieces = [poly(x0, cs) for x0, cs in self.pieces()]
        knots = [float(k) for k in self.args[1]]
        if not knots:
            return f"(({name} := {v}), {pieces[0]})[1]"
        chain = f"{pieces[0]} if ({name} := {v}) < {knots[0]!r}"
        for piece, knot in zip(pieces[1:], knots[1:], strict=False):
            chain += f" else {piece} if {name} < {knot!r}"
        return f"({chain} else {pieces[-1]})"

    _numpycode = _pythoncode


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


# ----------------------------------------------------------------------------- elements
@dataclass(frozen=True)
class Bushing(ForceElement):
    """A linear 6-DOF spring–damper (bushing) between ``point_a`` of ``frame_a`` and
    ``point_b`` of ``frame_b``.

    With ``Δr`` the position of B's point relative to A's point and ``θ`` the small-rotation
    measure of ``R = S_Aᵀ S_B`` (``θ = ½ vex(R − Rᵀ)``), both in frame A's components, and
    ``ω_rel`` the angular velocity of B relative to A (A components), the element acts on B
    with the force and torque (A components)

    ``f = −(K_t Δr + D_t Δṙ)``, ``l = −(K_r θ + D_r ω_rel)``

    (``Δṙ`` the derivative of ``Δr`` as seen in A); reactions act on A. The translational
    part is derived from its potential ``½ Δrᵀ K_t Δr`` exactly (generalized force
    ``−(∂Δr/∂y)ᵀ (K_t Δr + D_t Δṙ)``); the rotational part is the small-rotation law. It is at
    rest where the two points coincide and the frames are parallel.

    ``loss_factor`` η ≥ 0 (parameters only): hysteretic damping ``K(1 + iη)`` on both
    stiffness matrices in the frequency domain; in the time domain the viscous equivalent
    ``(η/ω_ref) K_t``, ``(η/ω_ref) K_r`` is added to ``D_t``, ``D_r`` (equations.md §1.1).
    """

    name: str
    frame_a: str
    frame_b: str
    stiffness: sp.ImmutableMatrix = field(default_factory=_zero33)
    damping: sp.ImmutableMatrix = field(default_factory=_zero33)
    rotational_stiffness: sp.ImmutableMatrix = field(default_factory=_zero33)
    rotational_damping: sp.ImmutableMatrix = field(default_factory=_zero33)
    point_a: sp.ImmutableMatrix = field(default_factory=_zero3)
    point_b: sp.ImmutableMatrix = field(default_factory=_zero3)
    enabled: sp.Expr = _ONE
    loss_factor: sp.Expr = _ZERO

    def __post_init__(self) -> None:
        for attr in ("stiffness", "damping", "rotational_stiffness", "rotational_damping"):
            m = getattr(self, attr)
            if not isinstance(m, sp.MatrixBase) or m.shape != (3, 3):
                raise ModelError(
                    f"expected a 3×3 matrix, got {getattr(m, 'shape', type(m).__name__)}",
                    f"forces.{self.name}.{attr}",
                )


@dataclass(frozen=True)
class RotationalSpringDamper(ForceElement):
    """A rotational spring–damper, either on a generalized ``coordinate`` (generalized force
    ``−F(s, sd)`` with ``s = coordinate − angle``, ``sd`` its rate) or between ``frame_a`` and
    ``frame_b`` about ``axis`` (x, y or z of frame A; ``s`` = relative rotation angle about it
    minus ``angle``, ``atan2`` of the relative rotation matrix, ``sd = ω_rel · axis``), with the
    torque ``−F(s, sd)`` about the axis acting on B and its reaction on A.

    ``F`` is :func:`characteristic_force` of ``stiffness``, ``damping`` and the optional table
    curves; ``loss_factor`` as for :class:`~neweul_py.model.SpringDamper` (on ``∂F/∂s``).
    """

    name: str
    stiffness: sp.Expr = _ZERO
    damping: sp.Expr = _ZERO
    angle: sp.Expr = _ZERO
    coordinate: str | None = None
    frame_a: str | None = None
    frame_b: str | None = None
    axis: Axis = "z"
    spring_force: sp.Expr | None = None
    damper_force: sp.Expr | None = None
    enabled: sp.Expr = _ONE
    loss_factor: sp.Expr = _ZERO

    def __post_init__(self) -> None:
        path = f"forces.{self.name}"
        on_coordinate = self.coordinate is not None
        on_frames = self.frame_a is not None or self.frame_b is not None
        if on_coordinate == on_frames:
            raise ModelError(
                "a rotational spring–damper acts either on a 'coordinate' or 'between' two "
                "frames (exactly one of them)",
                path,
            )
        if on_frames and (self.frame_a is None or self.frame_b is None):
            raise ModelError("'between' needs two frames", f"{path}.between")
        if self.axis not in AXES:
            raise ModelError(f"axis must be one of x, y, z, not {self.axis!r}", f"{path}.axis")


#: Components an output may take of each kind of force element (see :class:`ForceOutput`).
FORCE_COMPONENTS: dict[str, tuple[str, ...]] = {
    "PointForce": ("fx", "fy", "fz"),
    "Torque": ("mx", "my", "mz"),
    "GeneralizedForce": ("force",),
    "SpringDamper": ("force",),
    "RotationalSpringDamper": ("force",),
    "Bushing": ("fx", "fy", "fz", "mx", "my", "mz"),
}


@dataclass(frozen=True)
class ForceOutput(Output):
    """An output reporting what force element ``force`` exerts (times its ``enabled`` factor).

    ``component``: ``force`` for scalar elements (a spring–damper's tensile force, a
    rotational spring–damper's torque ``F(s, sd)``, a generalized force's value);
    ``fx fy fz`` / ``mx my mz`` for vector elements: a ``force``/``torque`` element's vector in
    its ``in`` frame, a bushing's force and torque on its second frame in the first frame's
    components.
    """

    name: str
    force: str
    component: str = "force"
