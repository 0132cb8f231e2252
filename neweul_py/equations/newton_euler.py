"""Newton–Euler equations with Jacobian matrices (equations.md §1).

```
M = Σ_i J_Tiᵀ m_i J_Ti + J_Riᵀ I_i J_Ri
q − k = Σ_i −J_Tiᵀ m_i (ā_i − g_i) − J_Riᵀ (I_i ᾱ_i + ω̃_i I_i ω_i) + Σ_forces J_Pᵀ f + J_Rᵀ l
```
Everything is resolved in body-fixed components (the body's frame), where the inertia
tensor is constant; ``ā_i``, ``ᾱ_i``, ``ω_i``, ``J`` come from
:mod:`neweul_py.kinematics` (computed recursively parent → child). No global simplification is
applied; expressions stay small by construction.

The two forms evaluate the same sums differently (and so check each other in the tests):

- *closed*: the sums over bodies of Jacobian products above, fully substituted;
- *recursive*: all quantities are intermediates, and the products ``Jᵀ(·)`` are evaluated by a
  backward recursion over the frame tree (:func:`_transpose_jacobian`): the inertia forces
  ``−m(ā − g)``, ``−(I ᾱ + ω̃ I ω)`` once (O(N) for a chain), and each column ``M[:, j]`` as
  ``Σ Jᵀ Θ J[:, j]`` (O(N) per column, O(N²) in all instead of O(N³)).
"""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Sequence
from typing import TYPE_CHECKING, Literal

import sympy as sp

from ..kinematics import Kinematics, absolute_kinematics
from ..model import (
    AXES,
    INERTIAL,
    ExpressionOutput,
    ForceOutput,
    KinematicOutput,
    RigidBody,
    System,
)
from ..model.algebra import (
    ZERO,
    ZERO3,
    Vec3,
    add,
    cross,
    dot,
    is_zero,
    mat_vec,
    scale,
    sub,
    total,
    vec_is_zero,
)
from ..progress import StagedProgress, Steps
from .constraints import check_constraints, derive_constraints
from .energy import energies
from .force_elements import apply_force_element
from .poses import frame_poses
from .result import Equations

if TYPE_CHECKING:
    from .elastic import ElasticEquations

__all__ = ["AUTO_CLOSED_MAX", "clear_cache", "newton_euler"]

Form = Literal["auto", "closed", "recursive"]

#: ``form="auto"`` uses the closed form up to this many coordinates, the recursive one above.
AUTO_CLOSED_MAX = 6

_CACHE: OrderedDict[tuple[str, str], Equations] = OrderedDict()
_CACHE_SIZE = 32


def clear_cache() -> None:
    """Forget all cached derivations."""
    _CACHE.clear()


def _elastic_equations(system: System) -> ElasticEquations | None:
    """:func:`.elastic.elastic_equations`, imported for a model with elastic bodies only (it
    brings the NumPy kernel :mod:`neweul_py.ffrf`, which a rigid model never needs)."""
    if not system.elastic_bodies:
        return None
    from .elastic import elastic_equations

    return elastic_equations(system)


def newton_euler(system: System, form: Form = "auto",
                 progress: StagedProgress = None) -> Equations:
    """Derive ``M``, ``q − k`` and the outputs of ``system`` (equations.md §1).

    Parameters
    ----------
    system
        The model.
    form
        ``"closed"``: fully substituted expressions, no intermediates (small models, insight,
        symbolic linearization). ``"recursive"``: absolute kinematics, Jacobian columns and
        per-body quantities are emitted as ordered intermediate assignments of bounded size,
        so that the derivation grows about linearly in the number of bodies per Jacobian
        column (O(N²) operations for an N-link chain). ``"auto"``: closed for at most
        :data:`AUTO_CLOSED_MAX` coordinates, else recursive.
    progress
        ``progress(stage, done, total)`` after each frame (``"kinematics"``) and each body,
        mass-matrix column and force element (``"equations"``); not called on a cache hit
        (:mod:`neweul_py.progress`).

    Returns
    -------
    Equations
        Cached by ``(system.fingerprint(), form)``; the same system gives the identical object.

    Raises
    ------
    ModelError
        For model features the derivation does not support (e.g. time derivatives of inputs
        in frame kinematics).

    Notes
    -----
    Spring–dampers between coinciding points (distance 0) have no direction; their
    expressions divide by the distance.

    Examples
    --------
    >>> import sympy as sp
    >>> from neweul_py.model import Coordinate, Frame, Parameter, RigidBody, System, symbol
    >>> m, l, g, a = (symbol(x) for x in ("m", "l", "g", "a"))
    >>> s = System("pendulum", coordinates=(Coordinate("a"),),
    ...            parameters=(Parameter("m", 1.0), Parameter("l", 1.0), Parameter("g", 9.81)),
    ...            frames=(Frame("arm", rotation=(("z", a),)),),
    ...            bodies=(RigidBody("bob", "arm", m, sp.ImmutableMatrix([l, 0, 0])),),
    ...            gravity=sp.ImmutableMatrix([0, -g, 0]))
    >>> eq = newton_euler(s)
    >>> eq.mass_matrix, eq.force_vector
    (Matrix([[l**2*m]]), Matrix([[-g*l*m*cos(a)]]))
    """
    if form == "auto":
        form = "closed" if len(system.coordinates) <= AUTO_CLOSED_MAX else "recursive"
    if form not in ("closed", "recursive"):
        raise ValueError(f"form must be 'auto', 'closed' or 'recursive', not {form!r}")
    key = (system.fingerprint(), form)
    cached = _CACHE.get(key)
    if cached is not None:
        _CACHE.move_to_end(key)
        return cached
    result = _derive(system, form, progress)
    _CACHE[key] = result
    while len(_CACHE) > _CACHE_SIZE:
        _CACHE.popitem(last=False)
    return result


# ---------------------------------------------------------------------------- derivation
def _derive(system: System, form: str, progress: StagedProgress = None) -> Equations:
    kin = absolute_kinematics(system, form, progress)  # type: ignore[arg-type]
    n = kin.n
    mass_terms: list[list[list[sp.Expr]]] = [[[] for _ in range(n)] for _ in range(n)]
    force_terms: list[list[sp.Expr]] = [[] for _ in range(n)]

    recursive = form == "recursive"
    # bodies (+ the mass-matrix columns in recursive form), force elements, then outputs,
    # energy, constraints, elastic splice and poses together
    step = Steps(progress, "equations",
                 len(system.bodies) + (n if recursive else 0) + len(system.forces) + 1)
    if recursive:
        # spatial inertia forces at the frame origins, applied through Jᵀ by one backward pass
        seeds: dict[str, list[tuple[Vec3, Vec3]]] = {}
        for body in system.bodies:
            _body(kin, body, None, force_terms, seeds)
            step()
        for j, terms in enumerate(_transpose_jacobian(kin, seeds, "Q", n)):
            force_terms[j].extend(terms)
        factors = _mass_matrix_backward(kin, system.bodies, mass_terms, step)
    else:
        factors = None
        for body in system.bodies:
            _body(kin, body, mass_terms, force_terms)
            step()
    # every element derives its own loads (model/forces); equations/force_elements.py adds
    # them with the element's enabled factor
    reported = {}
    loss: dict[tuple[int, int], list[sp.Expr]] = {}
    omega_ref = sp.Float(2 * math.pi * system.loss_reference_frequency)
    for fe in system.forces:
        reported[fe.name] = apply_force_element(kin, fe, force_terms, loss, omega_ref)
        step()
    outputs = [_output(kin, out, reported) for out in system.outputs]
    energy = energies(kin, system)
    constraints = derive_constraints(system)
    check_constraints(system, constraints)
    poses = frame_poses(kin)  # last: its intermediates come after all the equations need
    elastic = _elastic_equations(system)
    step()

    mass = [[ZERO] * n for _ in range(n)]
    for i in range(n):
        for j in range(i, n):
            mass[i][j] = mass[j][i] = total(mass_terms[i][j])
    return Equations(
        system=system,
        coordinates=system.coordinate_symbols,
        velocities=system.velocity_symbols,
        parameters=system.parameter_symbols,
        inputs=system.input_symbols,
        intermediates=kin.intermediates,
        mass_matrix=sp.ImmutableMatrix(n, n, [e for row in mass for e in row]),
        force_vector=sp.ImmutableMatrix(n, 1, [total(t) for t in force_terms]),
        outputs=sp.ImmutableMatrix(len(outputs), 1, outputs),
        output_names=tuple(o.name for o in system.outputs),
        constraints=constraints,
        energy=energy,
        elastic=elastic,
        poses=poses,
        mass_factors=factors,
        loss_matrix=None if not loss else sp.ImmutableMatrix(
            n, n, lambda i, j: total(loss.get((i, j), []))),
    )


def _com_jacobian(kin: Kinematics, body: RigidBody) -> tuple[Vec3, ...]:
    """``J_T`` of the body's center of mass ``c``: ``J_T,K − c̃ J_R,K`` (frame components)."""
    fk = kin.frames[body.frame]
    c: Vec3 = tuple(body.center_of_mass)  # type: ignore[assignment]
    if vec_is_zero(c):
        return fk.JT
    return tuple(
        kin.workspace.let_vec(add(fk.JT[j], cross(fk.JR[j], c)), f"JTc_{body.name}_{j}")
        for j in range(kin.n)
    )


def _inertia(body: RigidBody) -> tuple[Vec3, Vec3, Vec3]:
    return tuple(tuple(body.inertia[i, j] for j in range(3)) for i in range(3))  # type: ignore


def _body(
    kin: Kinematics,
    body: RigidBody,
    mass_terms: list[list[list[sp.Expr]]] | None,
    force_terms: list[list[sp.Expr]],
    seeds: dict[str, list[tuple[Vec3, Vec3]]] | None = None,
) -> None:
    """Add one body's ``J_Tᵀ m J_T + J_Rᵀ I J_R`` to M (unless ``mass_terms`` is None) and
    ``−J_Tᵀ m (ā − g) − J_Rᵀ (I ᾱ + ω̃ I ω)`` to ``q − k`` (equations.md §1), in the body
    frame's components. With ``seeds`` the latter is not formed with the Jacobians but
    recorded as the spatial force ``(f, n) = (−m (ā − g), −(I ᾱ + ω̃ I ω) + c × f)`` at the
    frame origin, for :func:`_transpose_jacobian`."""
    if body.frame == INERTIAL:
        return  # a body fixed to ISYS neither moves nor contributes
    ws = kin.workspace
    fk = kin.frames[body.frame]
    name = body.name
    m = body.mass
    inertia = _inertia(body)
    c: Vec3 = tuple(body.center_of_mass)  # type: ignore[assignment]
    w = fk.omega
    jt = _com_jacobian(kin, body)
    if vec_is_zero(c):
        abar = fk.abar
    else:
        abar = ws.let_vec(
            add(fk.abar, cross(fk.alphabar, c), cross(w, cross(w, c))), f"abc_{name}"
        )
    jr = fk.JR
    has_inertia = not all(is_zero(x) for row in inertia for x in row)
    has_mass = not is_zero(m)

    force = ws.let_vec(scale(m, sub(abar, fk.gravity)), f"F_{name}") if has_mass else None
    torque = None
    if has_inertia:
        torque = ws.let_vec(
            add(mat_vec(inertia, fk.alphabar), cross(w, mat_vec(inertia, w))), f"L_{name}"
        )
    if seeds is not None:
        f = scale(-1, force) if force is not None else ZERO3
        moment = add(scale(-1, torque) if torque is not None else ZERO3, cross(c, f))
        if not (vec_is_zero(f) and vec_is_zero(moment)):
            seeds.setdefault(body.frame, []).append((f, moment))
        return
    cols_t = [j for j in range(kin.n) if has_mass and not vec_is_zero(jt[j])]
    cols_r = [j for j in range(kin.n) if has_inertia and not vec_is_zero(jr[j])]
    if mass_terms is not None:
        mjt = {j: ws.let_vec(scale(m, jt[j]), f"mJ_{name}_{j}") for j in cols_t}
        ijr = {j: ws.let_vec(mat_vec(inertia, jr[j]), f"IJ_{name}_{j}") for j in cols_r}
        for a, j in enumerate(cols_t):
            for i in cols_t[: a + 1]:
                mass_terms[i][j].append(dot(jt[i], mjt[j]))
        for a, j in enumerate(cols_r):
            for i in cols_r[: a + 1]:
                mass_terms[i][j].append(dot(jr[i], ijr[j]))
    for j in cols_t:
        force_terms[j].append(-dot(jt[j], force))  # type: ignore[arg-type]
    for j in cols_r:
        force_terms[j].append(-dot(jr[j], torque))  # type: ignore[arg-type]


def _mass_matrix_backward(
    kin: Kinematics, bodies: Sequence[RigidBody], mass_terms: list[list[list[sp.Expr]]],
    step: Steps | None = None,
) -> tuple[tuple[sp.Expr, tuple[sp.Expr, ...]], ...]:
    """``M = Σ_K J_Kᵀ Θ_K J_K`` column by column, the products ``J_Kᵀ (·)`` evaluated by a
    backward recursion over the frame tree (recursive form; equations.md §1).

    Column j: every body seeds its frame with the spatial force ``Θ J[:, j]``, i.e.
    ``f = m J_T,c[:, j]`` and the moment about the frame origin ``n = I J_R[:, j] + c × f``.
    Walking children → parents, each frame adds its own Jacobian part to the column,
    ``M[i, j] += (∂r/∂y_i)·(A f) + (∂ω_rel/∂ẏ_i)·n``, and passes ``(A f, A n + r × A f)`` to
    its parent. This equals ``Σ J_Tᵀ m J_T + J_Rᵀ I J_R`` exactly (see
    :class:`~neweul_py.kinematics.FrameKinematics`) at O(N²) instead of O(N³) operations for
    an N-link chain. Only ``i ≤ j`` is formed; M is mirrored.

    Returns the same M as weighted rank-one terms (:func:`_mass_factors`).
    """
    n = kin.n
    seeds = []
    for body in bodies:
        if body.frame == INERTIAL:
            continue
        c: Vec3 = tuple(body.center_of_mass)  # type: ignore[assignment]
        seeds.append((body, c, _com_jacobian(kin, body), _inertia(body)))
    factors = _mass_factors(kin, seeds)
    for j in range(n):
        acc: dict[str, list[tuple[Vec3, Vec3]]] = {}
        for body, c, jt, inertia in seeds:
            jr = kin.frames[body.frame].JR[j]
            f = scale(body.mass, jt[j])
            nc = mat_vec(inertia, jr)
            if vec_is_zero(f) and vec_is_zero(nc):
                continue
            acc.setdefault(body.frame, []).append((f, add(nc, cross(c, f))))
        for i, terms in enumerate(_transpose_jacobian(kin, acc, f"M{j}", j + 1)):
            mass_terms[i][j].extend(terms)
        if step is not None:
            step()
    return factors


def _mass_factors(
    kin: Kinematics, seeds: Sequence[tuple[RigidBody, Vec3, tuple[Vec3, ...], tuple[Vec3, ...]]]
) -> tuple[tuple[sp.Expr, tuple[sp.Expr, ...]], ...]:
    """``M = Σ_r w_r g_r g_rᵀ``: the rows ``g_r`` of the body Jacobians with their weights.

    ``J_Tcᵀ m J_Tc`` gives one row per component of ``J_Tc`` (weight ``m``);
    ``J_Rᵀ I J_R = Σ_a I_aa J_a J_aᵀ + Σ_(a<b) I_ab (J_a J_bᵀ + J_b J_aᵀ)`` one row per
    diagonal entry and, per off-diagonal entry, the two rows ``J_a ± J_b`` with the weights
    ``± I_ab / 2`` (``J_a J_bᵀ + J_b J_aᵀ = ½[(J_a + J_b)(…)ᵀ − (J_a − J_b)(…)ᵀ]``).
    Identically zero rows are left out. Codegen evaluates ``M = Gᵀ diag(w) G`` numerically
    (one matrix product instead of the O(N²) scalar recursion).
    """
    n = kin.n
    rows: list[tuple[sp.Expr, tuple[sp.Expr, ...]]] = []

    def add_row(w: sp.Expr, row: tuple[sp.Expr, ...]) -> None:
        if not is_zero(w) and not all(is_zero(e) for e in row):
            rows.append((w, row))

    for body, _c, jt, inertia in seeds:
        jr = kin.frames[body.frame].JR
        for a in range(3):
            add_row(body.mass, tuple(jt[j][a] for j in range(n)))
        for a in range(3):
            add_row(inertia[a][a], tuple(jr[j][a] for j in range(n)))
        for a in range(3):
            for b in range(a + 1, 3):
                w = (inertia[a][b] + inertia[b][a]) / 4
                add_row(w, tuple(jr[j][a] + jr[j][b] for j in range(n)))
                add_row(-w, tuple(jr[j][a] - jr[j][b] for j in range(n)))
    return tuple(rows)


def _transpose_jacobian(
    kin: Kinematics, acc: dict[str, list[tuple[Vec3, Vec3]]], tag: str, rows: int
) -> list[list[sp.Expr]]:
    """``Σ_K J_Kᵀ (f_K, n_K)`` for spatial forces at frame origins (frame components), by
    the backward recursion ``J_Kᵀ (f, n) = J_Pᵀ (A f, A n + r × A f) + (∂r/∂y)ᵀ A f +
    J_R,relᵀ n`` (see :class:`~neweul_py.kinematics.FrameKinematics`), children → parents.

    Returns the terms of the first ``rows`` generalized forces. ``acc`` is consumed.
    """
    ws = kin.workspace
    out: list[list[sp.Expr]] = [[] for _ in range(rows)]
    for frame in reversed(kin.system.frames_topological):
        name = frame.name
        parts = acc.pop(name, None)
        if not parts:
            continue
        fk = kin.frames[name]
        f = ws.let_vec(add(*(p[0] for p in parts)), f"{tag}f_{name}")
        moment = ws.let_vec(add(*(p[1] for p in parts)), f"{tag}n_{name}")
        f_parent = ws.let_vec(mat_vec(fk.relative_rotation, f), f"{tag}fp_{name}")
        for i in range(rows):
            term = total((dot(fk.local_JT[i], f_parent), dot(fk.local_JR[i], moment)))
            if not is_zero(term):
                out[i].append(term)
        if fk.parent != INERTIAL:
            n_parent = add(
                mat_vec(fk.relative_rotation, moment),
                cross(fk.relative_translation, f_parent),
            )
            acc.setdefault(fk.parent, []).append((f_parent, n_parent))
    return out


def _output(kin: Kinematics, out: object, reported: dict[str, dict[str, sp.Expr]]) -> sp.Expr:
    if isinstance(out, ExpressionOutput):
        return out.expr
    if isinstance(out, ForceOutput):
        return reported[out.force][out.component]
    assert isinstance(out, KinematicOutput)
    axis = AXES.index(out.component)
    point = tuple(out.point)
    if out.quantity == "position":
        return kin.point_position(out.frame, point, out.in_frame)[axis]
    pk = kin.point(out.frame, point, f"outputs.{out.name}.point")
    return kin.express(kin.velocity(pk), out.frame, out.in_frame)[axis]

