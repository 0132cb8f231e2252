"""Splicing elastic bodies into the equations of motion (equations.md §2).

An elastic body's equations, in the components of its reference frame K::

    [ m I    m̃dᵀ   md¹  ] [ a ]   [ ω̃ω̃ md + 2 ω̃ md¹ q̇          ]   [ 0              ]
    [ m̃d     J     Crvᵀ ] [ α ] + [ ω̃ J ω + Σ_k Gr_k q̇_k ω       ] + [ 0              ] = h
    [ Ct     Cr    Me   ] [ q̈ ]   [ Oe(q) ω_q + Σ_k Ge_k q̇_k ω    ]   [ Ke q + De q̇ + kσ ]

(conventions of :mod:`neweul_py.elastic.invariants`). The reference frame moves like a rigid
body: ``a = J_T ÿ + ā``, ``α = J_R ÿ + ᾱ`` (frame components, equations.md §1) and
``q̈ = E ÿ`` with ``E`` selecting the body's own coordinates. Stacking ``J_b = [J_T; J_R; E]``
and premultiplying the rigid rows by ``[J_T; J_R]ᵀ`` and the elastic rows by ``Eᵀ``::

    M   += J_bᵀ M_b(q) J_b
    q−k −= J_bᵀ ( M_b(q) [ā − g; ᾱ; 0] + h_ω(q, q̇, ω) + [0; 0; Ke q + De q̇ + kσ] )

Gravity enters as the acceleration ``−g`` of the frame (``g`` in frame components), so the
body's weight ``m g``, its moment ``m̃d g`` and the modal loads ``Ct g`` (with their
first-order terms) all follow from the mass blocks. The rows of ``M_b`` are not those of its
transpose for two-sided data (``Ct``, ``Cr``, ``Me`` use ``Wᵀ``), nor when ``Ct¹``/``Cr¹``
hold geometric stiffening, so ``M`` is unsymmetric in general.

What stays symbolic here is only the reference frame's kinematics — ``J_T``, ``J_R``, ``ā``,
``ᾱ``, ``ω`` and ``g`` in frame components (:class:`ElasticSplice`); the invariants stay
numeric arrays (the flat form carried by :class:`~neweul_py.model.ElasticBody`) and
:mod:`neweul_py.codegen.elastic` emits the matrix products with them. The node frames
(``NAME.label``) are ordinary symbolic frames of the system (first order in ``q``), so forces
on nodes enter through their Jacobians like any force (see the Notes of
:func:`elastic_splices` for two-sided data).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp

from ..kinematics import absolute_kinematics
from ..model import INERTIAL, Coordinate, ElasticBody, System, symbol, velocity_name

__all__ = ["ElasticSplice", "elastic_splices", "two_sided_node_loads"]


@dataclass(frozen=True, eq=False)
class ElasticSplice:
    """What the generated code needs to splice one elastic body into ``M`` and ``q − k``.

    Attributes
    ----------
    body
        The elastic body (numeric invariants in ``body.data``).
    first
        Index in ``y`` of its first elastic coordinate (its coordinates are consecutive).
    JT, JR
        (3, n) Jacobians of the reference frame's origin velocity and angular velocity,
        frame components.
    abar, alphabar, omega, gravity
        (3, 1) ``ā``, ``ᾱ``, ``ω`` of the frame and the gravitational acceleration, frame
        components.
    """

    body: ElasticBody
    first: int
    JT: sp.ImmutableMatrix
    JR: sp.ImmutableMatrix
    abar: sp.ImmutableMatrix
    alphabar: sp.ImmutableMatrix
    omega: sp.ImmutableMatrix
    gravity: sp.ImmutableMatrix

    def expressions(self) -> list[sp.Expr]:
        """``[J_T (row-major), J_R, ā, ᾱ, ω, g]``: 6n + 12 expressions, in this order."""
        out: list[sp.Expr] = list(self.JT) + list(self.JR)
        for v in (self.abar, self.alphabar, self.omega, self.gravity):
            out += list(v)
        return out


def elastic_splices(system: System) -> tuple[ElasticSplice, ...]:
    """The reference-frame kinematics of every elastic body of ``system`` (equations.md §2).

    Parameters
    ----------
    system
        The model (with ``elastic_bodies``).

    Returns
    -------
    tuple of ElasticSplice
        In the order of ``system.elastic_bodies``; the frame kinematics in closed form
        (expressions of ``y``, ``ẏ``, ``p``, ``u``, ``t`` only).

    Notes
    -----
    Node forces act on the elastic coordinates through the node frames' Jacobians, i.e. with
    the right basis ``Φ_P`` (``V``); for two-sided data :func:`two_sided_node_loads` turns
    these modal loads into ``W_Pᵀ f``.
    """
    if not system.elastic_bodies:
        return ()
    # only the reference frames' chains (not the node frames, whose symbolic derivatives
    # are expensive): a sub-system with the same coordinates, parameters and inputs
    needed: dict[str, object] = {}
    for body in system.elastic_bodies:
        if body.frame != INERTIAL:
            for f in system.frame_chain(body.frame):
                needed[f.name] = f
    sub = System(name=system.name, coordinates=system.coordinates,
                 parameters=system.parameters, inputs=system.inputs,
                 frames=tuple(f for f in system.frames if f.name in needed),
                 gravity=system.gravity)
    kin = absolute_kinematics(sub, "closed")
    n = kin.n
    index = {c.name: j for j, c in enumerate(system.coordinates)}
    out = []
    for body in system.elastic_bodies:
        first = index[body.coordinate_names[0]]
        if body.frame == INERTIAL:
            zero = sp.ImmutableMatrix.zeros(3, n)
            z3 = sp.ImmutableMatrix.zeros(3, 1)
            out.append(ElasticSplice(body, first, zero, zero, z3, z3, z3,
                                     sp.ImmutableMatrix(system.gravity)))
            continue
        fk = kin.frames[body.frame]

        def cols(J: tuple) -> sp.ImmutableMatrix:
            return sp.ImmutableMatrix(3, n, [J[j][a] for a in range(3) for j in range(n)])

        out.append(ElasticSplice(
            body, first, cols(fk.JT), cols(fk.JR), sp.ImmutableMatrix(fk.abar),
            sp.ImmutableMatrix(fk.alphabar), sp.ImmutableMatrix(fk.omega),
            sp.ImmutableMatrix(fk.gravity)))
    return tuple(out)


def two_sided_node_loads(equations: Any, derive: Any) -> Any:
    """Equations whose elastic rows take node loads with the left basis, ``W_Pᵀ f`` (§2).

    The node frames are symbolic frames with ``origin = x_P + Φ_P q`` (right basis), so the
    derivation gives the elastic rows ``Φ_Pᵀ F_P + Ψ_Pᵀ L_P`` for the total force ``F_P`` and
    moment ``L_P`` that the rest of the system exerts on node P (forces, and the inertia of
    bodies hanging on the node, both in ``M`` and ``q − k``). Two-sided data want
    ``W_Pᵀ``-rows. ``F_P``, ``L_P`` are obtained exactly as the generalized forces of six probe
    coordinates ``ε`` added to the node frame (``origin + ε[:3]``, small angles
    ``Ψ_P q + ε[3:]``) at ``ε = 0``; then, for every row (of ``M`` and of ``q − k``),

        row_q += (Φ_W − Φ_V)ᵀ row_ε[:3] + (Ψ_W − Ψ_V)ᵀ row_ε[3:],

    and the probe coordinates are removed. Each elastic row gains six terms per node (the
    node loads are intermediates ``FP_<body>_<label>_<i>``).

    Parameters
    ----------
    equations
        The :class:`~neweul_py.equations.Equations` of the system (without this correction).
    derive
        ``newton_euler``-like function ``(system, form) -> Equations``.

    Returns
    -------
    Equations
        ``equations`` itself when no two-sided body has node frames; else the corrected ones.
    """
    system: System = equations.system
    bodies = [b for b in system.elastic_bodies if b.two_sided and b.nodes]
    if not bodies:
        return equations
    probes: dict[tuple[str, str], tuple[sp.Symbol, ...]] = {}
    extra: list[Coordinate] = []
    taken = {c.name for c in system.coordinates}
    for b in bodies:
        for label, _node in b.nodes:
            names = []
            for a in range(6):
                name = f"eps_{b.name}_{label}_{a}"
                while name in taken:
                    name = "z" + name
                taken.add(name)
                names.append(name)
            extra += [Coordinate(n) for n in names]
            probes[(b.name, label)] = tuple(symbol(n) for n in names)
    frames = {}
    for b in bodies:
        own = {label: probes[(b.name, label)] for label, _ in b.nodes}
        for f in b.node_frames(own):
            frames[f.name] = f
    aug = dataclasses.replace(
        system, coordinates=(*system.coordinates, *extra),
        frames=tuple(frames.get(f.name, f) for f in system.frames))
    form = "closed" if equations.is_closed_form else "recursive"
    eq = derive(aug, form)
    n = len(system.coordinates)
    zero = {symbol(c.name): sp.Integer(0) for c in extra}
    zero.update({symbol(velocity_name(c.name)): sp.Integer(0) for c in extra})
    inter = [(s, e.xreplace(zero)) for s, e in eq.intermediates]
    na = len(aug.coordinates)
    M = [[eq.mass_matrix[i, j].xreplace(zero) for j in range(n)] for i in range(na)]
    f = [eq.force_vector[i].xreplace(zero) for i in range(na)]
    index = {c.name: j for j, c in enumerate(aug.coordinates)}
    for b in bodies:
        first = index[b.coordinate_names[0]]
        for label, node in b.nodes:
            i = b.node_index(node)
            d = b.data
            diff = np.vstack((d["nodes.phi_w"][i] - d["nodes.phi"][i],
                              d["nodes.psi_w"][i] - d["nodes.psi"][i]))       # (6, nq)
            rows = [index[s.name] for s in probes[(b.name, label)]]
            loads = []
            for a, r in enumerate(rows):
                if f[r] == 0 or not np.any(diff[a]):
                    loads.append(sp.Integer(0))
                    continue
                sym = sp.Symbol(f"FP_{b.name}_{label}_{a}", real=True)
                inter.append((sym, f[r]))
                loads.append(sym)
            for k in range(b.nq):
                row = first + k
                terms = [sp.Float(float(diff[a, k])) * loads[a] for a in range(6)
                         if diff[a, k] != 0.0 and loads[a] != 0]
                if terms:
                    f[row] = sp.Add(f[row], *terms)
                for j in range(n):
                    mt = [sp.Float(float(diff[a, k])) * M[rows[a]][j] for a in range(6)
                          if diff[a, k] != 0.0 and M[rows[a]][j] != 0]
                    if mt:
                        M[row][j] = sp.Add(M[row][j], *mt)
    return dataclasses.replace(
        equations,
        intermediates=tuple(inter),
        mass_matrix=sp.ImmutableMatrix(n, n, [M[i][j] for i in range(n) for j in range(n)]),
        force_vector=sp.ImmutableMatrix(n, 1, f[:n]),
        outputs=sp.ImmutableMatrix(eq.outputs.shape[0], 1,
                                   [e.xreplace(zero) for e in eq.outputs]),
    )
