"""The equations of a model with elastic bodies as closed symbolic expressions (for printers
that cannot embed the floating-frame kernel, such as the C backend).

The NumPy module splices the elastic bodies in numerically at every call
(:mod:`neweul_py.ffrf.splice`). Here the *same* kernel functions run once on arrays of sympy
expressions — the elastic coordinates as symbols, the reference-frame kinematics as the
symbolic part's expressions — so that they return ``M`` and ``q − k`` of the whole model as
expressions in the independent coordinates (equations.md §2, "splice"); the body equations
still exist only in :mod:`neweul_py.ffrf`. The node coordinates ``y_s = S_V y`` are
substituted into the symbolic part, its ``M_s``, ``(q − k)_s`` enter as
``S_Wᵀ M_s S_V``, ``S_Wᵀ (q − k)_s``, and the outputs and constraints follow ``y_s``.

The expressions grow with the mode count (polynomials of degree up to three in ``q``, ``q̇``,
``ω``), so this form is for bodies of a few tens of modes; parametric bodies (mixed at every
call) are not expanded.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import sympy as sp

from ..errors import GenerationError
from ..ffrf import ffrf_add_force, ffrf_add_mass, ffrf_system, ffrf_terms
from ..ffrf.body import ffrf_loss_matrix
from .constraints import ConstraintEquations
from .result import Equations

__all__ = ["MAX_EXPANDED_MODES", "expanded_equations"]

#: Elastic coordinates above which the expansion is refused (its expressions and their
#: derivatives would take minutes to generate; the NumPy module handles any size).
MAX_EXPANDED_MODES = 40


def _matrix(a: np.ndarray) -> sp.ImmutableMatrix:
    """A numeric (float) array as a sympy matrix of ``Float``."""
    return sp.ImmutableMatrix(a.shape[0], a.shape[1], [sp.Float(float(v)) for v in a.ravel()])


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
    M = np.array(_matrix(SW.T) * put(Ms) * _matrix(SV), dtype=object)
    f = np.array(_matrix(SW.T) * put(fs), dtype=object).reshape(-1)
    entries = []
    for s, offset in zip(el.splices, el.offsets, strict=True):
        entries.append({**s.body.data, "name": s.body.name, "first": index[s.first],
                        "kin": offset, "inertia": s.body.inertia,
                        "fixed": s.elastic_rows_only})
    S = ffrf_system(entries, len(active), SV, SW, 0, {}, None)
    kin = np.array([put(e) for e in el.hidden], dtype=object)
    terms = ffrf_terms(S, kin, np.array(y, dtype=object), np.array(yd, dtype=object))
    M = ffrf_add_mass(S, M, terms)
    f = ffrf_add_force(S, f, terms)
    loss = None
    n = len(y)
    if eq.loss_matrix is not None or any("Le" in b for b in S["bodies"]):
        # the bodies' Le from the kernel, the elements' G through S_Wᵀ G_s S_V
        loss = _matrix(ffrf_loss_matrix(S, 0.0, np.zeros(n), None))
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
        intermediates=tuple((s, put(e)) for s, e in eq.intermediates),
        mass_matrix=sp.ImmutableMatrix(n, n, list(M.ravel())),
        force_vector=sp.ImmutableMatrix(n, 1, list(f)),
        outputs=put(eq.outputs), constraints=ce, energy=None, elastic=None,
        mass_factors=None, loss_matrix=loss)
