"""The equations of a model with elastic bodies as closed symbolic expressions (for printers
that cannot embed the floating-frame kernel, such as the C backend).

The NumPy module splices the elastic bodies in numerically at every call
(:mod:`neweul_py.ffrf.splice`). Here the *same* kernel functions run once on arrays of sympy
expressions — the elastic coordinates as symbols, the reference-frame kinematics as symbols
for the symbolic part's expressions — so that they return ``M`` and ``q − k`` of the whole model as
expressions in the independent coordinates (equations.md §2, "splice"); the body equations
still exist only in :mod:`neweul_py.ffrf`. The frame kinematics are intermediates
(``_ncg_kin<i>``), so that the kernel's numbers multiply symbols, not sums that sympy would
distribute into every term (a 20-mode beam's compiled rhs: 2 900 → 2 000 instructions
besides the rows of ``nw_rows``). The node coordinates ``y_s = S_V y`` are
substituted into the symbolic part, its ``M_s``, ``(q − k)_s`` enter as
``S_Wᵀ M_s S_V``, ``S_Wᵀ (q − k)_s``, and the outputs and constraints follow ``y_s``.

The expressions grow with the mode count (polynomials of degree up to three in ``q``, ``q̇``,
``ω``), so this form is for bodies of a few tens of modes; parametric bodies (mixed at every
call) are not expanded.
"""

from __future__ import annotations

import dataclasses
import numbers

import numpy as np
import sympy as sp

from ..errors import GenerationError
from ..ffrf import ffrf_add_force, ffrf_add_mass, ffrf_bodies, ffrf_system, ffrf_terms
from ..ffrf.body import ffrf_loss_matrix
from .constraints import ConstraintEquations
from .result import Equations

__all__ = ["MAX_EXPANDED_MODES", "Terms", "expanded_equations"]

#: Elastic coordinates above which the expansion is refused (its expressions and their
#: derivatives would take minutes to generate; the NumPy module handles any size).
MAX_EXPANDED_MODES = 40


def _matrix(a: np.ndarray) -> sp.ImmutableMatrix:
    """A numeric (float) array as a sympy matrix of ``Float``."""
    return sp.ImmutableMatrix(a.shape[0], a.shape[1], [sp.Float(float(v)) for v in a.ravel()])


class Terms:
    """A sympy sum kept as the list of its terms while the kernel's NumPy code computes with it.

    NumPy's products of object arrays add one product at a time (``s = s + a_k b_k``), and a
    sympy ``Add`` re-flattens all its terms at every step, so a sum of ``n`` products cost
    ``O(n²)``; here ``+`` only joins term lists and the ``Add`` is built once, when a product
    or :meth:`expr` needs it (the same expression up to the order in which equal terms'
    numeric coefficients are added). Numbers times a sum distribute, as in sympy.
    """

    __slots__ = ("_expr", "terms")

    def __init__(self, terms: list) -> None:
        self.terms = terms
        self._expr = None

    def expr(self) -> sp.Expr:
        """The sum as one sympy expression."""
        if self._expr is None:
            self._expr = sp.Add(*self.terms)
        return self._expr

    @staticmethod
    def _of(o) -> list:
        return o.terms if isinstance(o, Terms) else [o]

    def __add__(self, o):
        if isinstance(o, numbers.Number) and o == 0:
            return self
        return Terms(self.terms + self._of(o))

    __radd__ = __add__

    def __neg__(self):
        return Terms([-t for t in self.terms])

    def __sub__(self, o):
        return self + (-o)

    def __rsub__(self, o):
        return (-self) + o

    def __mul__(self, o):
        if isinstance(o, numbers.Number) or getattr(o, "is_Number", False):
            if o == 0:
                return 0.0
            if o == 1:
                return self
        other = o.expr() if isinstance(o, Terms) else o
        mine = self.expr()
        if mine == 0 or other == 0:        # 0·e: no product (sympy would test e for ∞)
            return 0.0
        return Terms([mine * other])

    __rmul__ = __mul__

    def __truediv__(self, o):
        return self * (1.0 / o)


def _expr(e):
    """A value of the kernel's arrays as a sympy expression: a lazy sum, a sympy object or a
    number of the body's float arrays (never text)."""
    if isinstance(e, Terms):
        return e.expr()
    if isinstance(e, sp.Basic):
        return e
    if isinstance(e, int | np.integer):
        return sp.Integer(int(e))
    return sp.Float(float(e))


def expanded_equations(eq: Equations) -> Equations:
    """``eq`` (with ``eq.elastic``) as equations in the independent coordinates whose ``M``,
    ``q − k``, outputs and constraints contain the elastic bodies' terms (module docstring).

    Raises
    ------
    GenerationError
        Parametric bodies, or more than :data:`MAX_EXPANDED_MODES` elastic coordinates.
    """
    el = eq.elastic
    if el is None:
        return eq
    bodies = [s.body for s in el.splices]
    if any(b.parametric for b in bodies):
        raise GenerationError("parametric elastic bodies are mixed at every call and cannot be "
                              "expanded into closed expressions")
    nq = sum(b.nq for b in bodies)
    if nq > MAX_EXPANDED_MODES:
        raise GenerationError(f"{nq} elastic coordinates: at most {MAX_EXPANDED_MODES} are "
                              "expanded into closed expressions")
    keep, active = list(el.keep), list(el.active)
    index = {j: k for k, j in enumerate(keep)}
    y = tuple(eq.coordinates[j] for j in keep)
    yd = tuple(eq.velocities[j] for j in keep)
    sub: dict[sp.Symbol, sp.Expr] = {}
    for j, (s, sd) in enumerate(zip(eq.coordinates, eq.velocities, strict=True)):
        if j not in index:                      # a dependent node coordinate: S_V row j
            row = [(float(v), k) for k, v in enumerate(el.SV[j]) if v != 0]
            sub[s] = sp.Add(*(sp.Float(v) * y[k] for v, k in row))
            sub[sd] = sp.Add(*(sp.Float(v) * yd[k] for v, k in row))

    def put(e: sp.Basic) -> sp.Basic:
        return e.xreplace(sub) if sub else e

    SV, SW = el.SV[active], el.SW[active]
    Ms = sp.ImmutableMatrix(eq.mass_matrix).extract(active, active)
    fs = sp.ImmutableMatrix([eq.force_vector[j, 0] for j in active])
    def lazy(values) -> np.ndarray:
        out = np.empty(len(values), dtype=object)
        out[:] = [Terms([v]) for v in values]
        return out

    # S_Wᵀ M_s S_V and S_Wᵀ (q − k)_s with float matrices (their zeros cost nothing here;
    # sympy checks every factor of a product by 0.0 for infinities)
    M = SW.T @ lazy(list(put(Ms))).reshape(Ms.shape) @ SV
    f = SW.T @ lazy(list(put(fs)))
    entries = []
    for s, offset in zip(el.splices, el.offsets, strict=True):
        entries.append({**s.body.data, "name": s.body.name, "first": index[s.first],
                        "kin": offset, "inertia": s.body.inertia,
                        "fixed": s.elastic_rows_only})
    S = ffrf_system(ffrf_bodies(entries), len(active), SV, SW, 0, {}, None)
    # the frame kinematics as intermediates: the kernel multiplies them by the body's numbers,
    # and a number times a sum would be distributed into every term (sympy), so each elastic
    # row got its own copy of the monomials of ā − g, ω² … (20 modes: 9 products of three
    # factors per row); as symbols a row is a short sum over them
    kin, kin_inter = [], []
    for i, e in enumerate(el.hidden):
        e = put(e) if isinstance(e, sp.Basic) else sp.Number(e)   # numbers: a zero row
        if not e.is_Atom:
            kin_inter.append((sp.Symbol(f"_ncg_kin{i}", real=True), e))
            e = kin_inter[-1][0]
        kin.append(e)
    kin = lazy(kin)
    terms = ffrf_terms(S, kin, lazy(y), lazy(yd))
    M = np.vectorize(_expr, otypes=[object])(ffrf_add_mass(S, M, terms))
    f = np.vectorize(_expr, otypes=[object])(ffrf_add_force(S, f, terms))
    loss = None
    n = len(y)
    if eq.loss_matrix is not None or any("Le" in b for b in S["bodies"]):
        # the bodies' Le from the kernel, the elements' G through S_Wᵀ G_s S_V
        loss = _matrix(np.vectorize(_expr, otypes=[object])(
            ffrf_loss_matrix(S, 0.0, np.zeros(n), None)))
        if eq.loss_matrix is not None:
            Gs = put(sp.ImmutableMatrix(eq.loss_matrix).extract(active, active))
            loss = loss + _matrix(SW.T) * Gs * _matrix(SV)
    ce = eq.constraints
    if ce is not None:
        ce = ConstraintEquations(
            names=ce.names, g=put(ce.g), G=put(ce.G)[:, active] * _matrix(SV),
            g_t=put(ce.g_t), gamma=put(ce.gamma))
    return dataclasses.replace(
        eq, coordinates=y, velocities=yd,
        intermediates=(*((s, put(e)) for s, e in eq.intermediates), *kin_inter),
        mass_matrix=sp.ImmutableMatrix(n, n, list(M.ravel())),
        force_vector=sp.ImmutableMatrix(n, 1, list(f)),
        outputs=put(eq.outputs), constraints=ce, energy=None, elastic=None,
        mass_factors=None, loss_matrix=loss)
