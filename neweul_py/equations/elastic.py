"""Splicing elastic bodies into the equations of motion (equations.md §2).

An elastic body's equations, in the components of its reference frame K::

    [ m I    m̃dᵀ   md¹  ] [ a ]   [ ω̃ω̃ md + 2 ω̃ md¹ q̇          ]   [ 0              ]
    [ m̃d     J     Crvᵀ ] [ α ] + [ ω̃ J ω + Σ_k Gr_k q̇_k ω       ] + [ 0              ] = h
    [ Ct     Cr    Me   ] [ q̈ ]   [ Oe(q) ω_q + Σ_k Ge_k q̇_k ω    ]   [ Ke q + De q̇ + kσ ]

(conventions of :mod:`neweul_py.elastic.bodies.invariants`). The reference frame moves like a rigid
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
(``NAME.label``) are ordinary symbolic frames moving with six dependent node coordinates
each, mapped to the modes numerically (:func:`node_coordinate_map`: ``S_V`` for motion,
``S_W`` — the left basis — for the node loads of two-sided data). An elastic body hung on such
a node frame has ``J_b`` in those coordinates: its rows enter with ``(J_b S_W)ᵀ``, its motion
with ``J_b S_V``, like a rigid body there.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import sympy as sp

from ..ffrf import frame_stiffening
from ..kinematics import absolute_kinematics
from ..model import INERTIAL, ElasticBody, System
from ..model.system import iter_expressions

__all__ = ["ElasticEquations", "ElasticSplice", "elastic_equations", "elastic_splices",
           "node_coordinate_map", "node_coordinate_parts", "schedule_jacobian",
           "used_elastic_coordinates"]


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
    velocity
        (3, 1) ``v = J_T ẏ + v̄`` of the frame origin, frame components (for the energy).
    potential
        ``e = −g·r_O``: potential of gravity per unit mass at the frame origin.
    """

    body: ElasticBody
    first: int
    JT: sp.ImmutableMatrix
    JR: sp.ImmutableMatrix
    abar: sp.ImmutableMatrix
    alphabar: sp.ImmutableMatrix
    omega: sp.ImmutableMatrix
    gravity: sp.ImmutableMatrix
    velocity: sp.ImmutableMatrix
    potential: sp.Expr

    @property
    def fixed_frame(self) -> bool:
        """Whether the reference frame never moves (``J_T``, ``J_R``, ``ā``, ``ᾱ``, ``ω``,
        ``v`` identically zero: ``ISYS`` or a constant offset of it): the body's equations
        are then its elastic rows alone (equations.md §2.2)."""
        return all(e == 0 for m in (self.JT, self.JR, self.abar, self.alphabar, self.omega,
                                    self.velocity) for e in m)

    @property
    def elastic_rows_only(self) -> bool:
        """A fixed frame and no stiffening the (gravitational) frame acceleration acts
        through: the body is its elastic rows alone (``FIXED_ARRAYS`` suffice)."""
        data = self.body.samples if self.body.parametric else (self.body.data,)
        return self.fixed_frame and not any(frame_stiffening(d) for d in data)

    def expressions(self, columns: list[int] | None = None) -> list[sp.Expr]:
        """``[J_T (row-major), J_R, ā, ᾱ, ω, g, v, e]``: 6n + 16 expressions, in this order
        (``columns``: only these Jacobian columns), the layout of
        :func:`neweul_py.ffrf.splice.ffrf_frame`."""
        cols = list(range(self.JT.shape[1])) if columns is None else list(columns)
        out: list[sp.Expr] = [self.JT[a, j] for a in range(3) for j in cols]
        out += [self.JR[a, j] for a in range(3) for j in cols]
        for v in (self.abar, self.alphabar, self.omega, self.gravity, self.velocity):
            out += list(v)
        return [*out, self.potential]


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
    The columns of ``J_T``, ``J_R`` refer to all coordinates of the system, including the
    dependent node coordinates (see :func:`node_coordinate_map`).
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
    g_inertial = sp.ImmutableMatrix(system.gravity)
    out = []
    for body in system.elastic_bodies:
        first = index[body.coordinate_names[0]]
        if body.frame == INERTIAL:
            zero = sp.ImmutableMatrix.zeros(3, n)
            z3 = sp.ImmutableMatrix.zeros(3, 1)
            out.append(ElasticSplice(body, first, zero, zero, z3, z3, z3, g_inertial, z3,
                                     sp.Integer(0)))
            continue
        fk = kin.frames[body.frame]

        def cols(J: tuple) -> sp.ImmutableMatrix:
            return sp.ImmutableMatrix(3, n, [J[j][a] for a in range(3) for j in range(n)])

        zero = (sp.Integer(0),) * 3
        origin = kin.point_position(body.frame, zero, INERTIAL)
        velocity = kin.velocity(kin.point(body.frame, zero, f"elastic_bodies.{body.name}"))
        potential = -sum((g_inertial[a] * origin[a] for a in range(3)), sp.Integer(0))
        out.append(ElasticSplice(
            body, first, cols(fk.JT), cols(fk.JR), sp.ImmutableMatrix(fk.abar),
            sp.ImmutableMatrix(fk.alphabar), sp.ImmutableMatrix(fk.omega),
            sp.ImmutableMatrix(fk.gravity), sp.ImmutableMatrix(velocity), potential))
    return tuple(out)


def node_coordinate_map(system: System) -> tuple[tuple[int, ...], np.ndarray, np.ndarray]:
    """The linear map from the independent coordinates to the symbolic ones (§2, node frames).

    The node frames move with dependent node coordinates ``[u; θ] = [Φ_P; Ψ_P] q``
    (:meth:`~neweul_py.model.ElasticBody.node_frames`). With ``y`` the coordinates without
    them and ``y_s`` all coordinates of the system (those of the symbolic equations):

        y_s = S_V y,   ẏ_s = S_V ẏ,   ÿ_s = S_V ÿ            (S_V constant)

    and by the principle of virtual work, with the *test* directions of two-sided data,

        M = S_Wᵀ M_s S_V,   q − k = S_Wᵀ (q − k)_s,

    where ``S_W`` has the rows of the left basis ``[Φ_W; Ψ_W]`` at the node coordinates: node
    loads reach the elastic equations as ``W_Pᵀ f`` (one-sided data: ``S_W = S_V``). Parametric
    bodies contribute their first sample's maps here (see :func:`node_coordinate_parts`).

    Returns
    -------
    keep, S_V, S_W
        Indices in ``y_s`` of the independent coordinates, and the two (n_s, n) maps.
    """
    keep, SV, SW, parts = node_coordinate_parts(system)
    for SVs, SWs in parts:
        SV = SV + SVs[0]
        SW = SW + SWs[0]
    return keep, SV, SW


def node_coordinate_parts(system: System) -> tuple[tuple[int, ...], np.ndarray, np.ndarray,
                                                   tuple[tuple[np.ndarray, np.ndarray], ...]]:
    """:func:`node_coordinate_map` split for parametric bodies (equations.md §2.3).

    Returns
    -------
    keep, S_V, S_W, parts
        ``S_V``, ``S_W`` without the node rows of parametric bodies, and per parametric body
        (in the order of ``system.elastic_bodies``) the stacks ``(k, n_s, n)`` of its node
        rows at each sample, so that ``S_V(σ) = S_V + Σ_i w_i(σ) S_V,i`` (the weights sum to
        one, the maps are linear in the node data).
    """
    ns = len(system.coordinates)
    index = {c.name: j for j, c in enumerate(system.coordinates)}
    dependent = {n for b in system.elastic_bodies for n in b.all_node_coordinate_names}
    keep = tuple(j for j, c in enumerate(system.coordinates) if c.name not in dependent)
    col = {j: k for k, j in enumerate(keep)}
    SV = np.zeros((ns, len(keep)))
    SW = np.zeros((ns, len(keep)))
    for j in keep:
        SV[j, col[j]] = SW[j, col[j]] = 1.0
    parts = []
    for b in system.elastic_bodies:
        cols = [col[index[n]] for n in b.coordinate_names]
        samples = range(len(b.datasets)) if b.parametric else (None,)
        SVs = np.zeros((len(samples), ns, len(keep)))
        SWs = np.zeros_like(SVs)
        for i, sample in enumerate(samples):
            for label, _node in b.nodes:
                tv, tw = b.node_maps(label, sample)
                rows = [index[n] for n in b.node_coordinate_names(label)]
                SVs[i][np.ix_(rows, cols)] = tv
                SWs[i][np.ix_(rows, cols)] = tw
        if b.parametric:
            parts.append((SVs, SWs))
        else:
            SV += SVs[0]
            SW += SWs[0]
    return keep, SV, SW, tuple(parts)


@dataclass(frozen=True, eq=False)
class ElasticEquations:
    """Everything code generation needs to splice the elastic bodies (equations.md §2).

    Attributes
    ----------
    splices
        The reference-frame kinematics of every body.
    keep, SV, SW, parts
        :func:`node_coordinate_parts`: the independent coordinates among the symbolic ones,
        the maps ``y_s = S_V y`` (motion) and ``S_W`` (loads, left basis) without the node
        rows of parametric bodies, and those rows per parametric body and sample.
    schedules
        The scheduling expressions ``σ`` of the parametric bodies (parameters, inputs, ``t``
        and the active coordinates), in order.
    schedule_jacobians
        ``∂σ/∂y_s`` (k × active) and ``∂σ/∂u`` (k × inputs): the dependence of the
        interpolation weights on the state and the inputs, for the analytic Jacobians.
    schedule_parameter_jacobian
        ``∂σ/∂p`` (k × parameters), for the parameter derivatives (docs/sensitivity.md).
    active
        Indices of the symbolic coordinates that are not elastic coordinates (the node
        frames move with the dependent node coordinates, so the elastic ones appear in no
        symbolic expression): the coordinates of the symbolic part.
    hidden
        The hidden outputs ``[kin of body 1, kin of body 2, …]`` in the active columns
        (:meth:`ElasticSplice.expressions`; none for a body on a fixed frame,
        ``elastic_rows_only``), and ``offsets`` where each body's starts.
    """

    splices: tuple[ElasticSplice, ...]
    keep: tuple[int, ...]
    SV: np.ndarray
    SW: np.ndarray
    parts: tuple[tuple[np.ndarray, np.ndarray], ...]
    schedules: tuple[sp.Expr, ...]
    active: tuple[int, ...]
    hidden: tuple[sp.Expr, ...]
    offsets: tuple[int, ...]
    schedule_jacobians: tuple[sp.ImmutableMatrix, sp.ImmutableMatrix] | None = None
    schedule_parameter_jacobian: sp.ImmutableMatrix | None = None


def used_elastic_coordinates(system: System, elastic_q: set[str]) -> set[str]:
    """The elastic coordinates that the symbolic part itself uses: the coordinates force
    elements act on (generalized forces: modal loads such as the body's own FE inputs,
    ``W_jᵀ b``; rotational spring–dampers on a coordinate) and coordinates or velocities named
    in any expression (outputs such as ``C V q``). They join the active coordinates of the
    symbolic part, whose rows and columns for them hold only these terms (the splice adds the
    body's own equations); without this a force on an elastic coordinate would be dropped."""
    used = {name for f in system.forces for key in type(f).keys if key.kind == "coordinate"
            for _, name in f.entries(key) if name in elastic_q}
    by_symbol = {}
    for c in system.coordinates:
        if c.name in elastic_q:
            by_symbol[c.symbol] = c.name
            by_symbol[c.velocity_symbol] = c.name
    for expr in iter_expressions(system):
        used.update(by_symbol[s] for s in expr.free_symbols if s in by_symbol)
    return used


def schedule_jacobian(sigma: sp.ImmutableMatrix, symbols: Sequence[sp.Symbol]
                      ) -> sp.ImmutableMatrix:
    """``∂σ/∂x`` of the scheduling expressions ``sigma`` (k × 1) for the symbols ``x``.

    Parameters
    ----------
    sigma
        The k scheduling expressions, a column.
    symbols
        The variables ``x`` (coordinates or inputs); may be empty.

    Returns
    -------
    sympy.ImmutableMatrix
        (k, len(symbols)); for no symbols the empty (k, 0) matrix — a model without inputs
        or without rigid coordinates (SymPy's ``jacobian`` refuses an empty list).
    """
    symbols = list(symbols)
    if not symbols:
        return sp.ImmutableMatrix.zeros(sigma.rows, 0)
    return sp.ImmutableMatrix(sigma.jacobian(symbols))


def elastic_equations(system: System) -> ElasticEquations | None:
    """The complete elastic splice of ``system`` (``None`` without elastic bodies)."""
    if not system.elastic_bodies:
        return None
    splices = elastic_splices(system)
    keep, SV, SW, parts = node_coordinate_parts(system)
    elastic_q = {n for b in system.elastic_bodies for n in b.coordinate_names}
    used = used_elastic_coordinates(system, elastic_q)
    active = tuple(j for j, c in enumerate(system.coordinates)
                   if c.name not in elastic_q or c.name in used)
    hidden: list[sp.Expr] = []
    offsets = []
    for s in splices:
        offsets.append(len(hidden))
        # a body on a fixed frame needs no Jacobian columns (they are zero): 16 entries
        # instead of 6·len(active) + 16, whose output Jacobians codegen would otherwise
        # differentiate and print (quadratic in the coordinates the symbolic part carries)
        hidden += s.expressions([] if s.elastic_rows_only else list(active))
    schedules = tuple(b.schedule for b in system.elastic_bodies if b.parametric)
    jacobians = parameter_jacobian = None
    if schedules:
        sigma = sp.ImmutableMatrix(schedules)
        jacobians = (schedule_jacobian(sigma, [system.coordinates[j].symbol for j in active]),
                     schedule_jacobian(sigma, [u.symbol for u in system.inputs]))
        parameter_jacobian = schedule_jacobian(sigma, [p.symbol for p in system.parameters])
    return ElasticEquations(splices, keep, SV, SW, parts, schedules, active, tuple(hidden),
                            tuple(offsets), jacobians, parameter_jacobian)
