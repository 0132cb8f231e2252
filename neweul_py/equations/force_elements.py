"""Generalized forces of the force elements of issue 4 (equations.md §1, "Force elements
contribute through the Jacobians of their points of action").

Each function adds the element's contribution to per-coordinate term lists and returns what
the element *reports* (:class:`~neweul_py.model.ForceOutput`): ``{"force": F}`` for scalar
elements, ``{"fx": …, "mz": …}`` for vector ones. :func:`apply_force_element` dispatches and
applies the element's ``enabled`` factor to both.

Loss factors (equations.md §1.1): an element with ``loss_factor`` η gets the viscous
equivalent ``(η/ω_ref) k_t`` of its tangent stiffness ``k_t`` on its own rate (in ``q − k``),
and adds ``η k_t`` to the hysteretic matrix ``G`` of ``K + iG`` — by construction
``G = −ω_ref ∂(q_loss)/∂ẏ`` of exactly those loss-equivalent forces: ``η k_t (∂s/∂y)ᵀ(∂s/∂y)``
for a spring–damper, ``η (c_jᵀ K_t c_k + J_R,jᵀ K_r J_R,k)`` for a bushing.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import sympy as sp

from ..errors import ModelError
from ..kinematics import Kinematics
from ..model import (
    AXES,
    ELONGATION,
    ELONGATION_RATE,
    Bushing,
    ForceElement,
    GeneralizedForce,
    PointForce,
    RotationalSpringDamper,
    SpringDamper,
    Torque,
    characteristic_force,
)
from ..model.algebra import ZERO, Vec3, add, cross, dot, is_zero, mat_vec, scale, sub, total

__all__ = [
    "LossTerms",
    "apply_force_element",
    "bushing",
    "reported_quantities",
    "rotational_spring_damper",
    "spring_damper",
]

Terms = list[list[sp.Expr]]
#: Entries ``(j, k) → terms`` of the hysteretic matrix ``G`` (only the nonzero ones).
LossTerms = dict[tuple[int, int], list[sp.Expr]]

#: The force elements whose generalized forces this module derives.
HANDLED = (SpringDamper, RotationalSpringDamper, Bushing)


def _law(fe: SpringDamper | RotationalSpringDamper, s: sp.Expr, sd: sp.Expr) -> sp.Expr:
    """``F(s, sd)`` of the element's characteristic with its kinematics substituted."""
    law = characteristic_force(fe.stiffness, fe.damping, fe.spring_force, fe.damper_force)
    return law.xreplace({ELONGATION: s, ELONGATION_RATE: sd})


def _tangent(fe: SpringDamper | RotationalSpringDamper, s: sp.Expr, sd: sp.Expr) -> sp.Expr:
    """The tangent stiffness ``∂F_spring/∂s`` of the characteristic (its spring part: the
    table curve or ``stiffness·s``), with the kinematics substituted."""
    spring = characteristic_force(fe.stiffness, sp.Integer(0), fe.spring_force, None)
    return sp.diff(spring, ELONGATION).xreplace({ELONGATION: s, ELONGATION_RATE: sd})


def _add_loss(loss: LossTerms | None, eta_k: object, rows: list[sp.Expr],
              cols: list[sp.Expr] | None = None) -> None:
    """``G[j, k] += eta_k · rows[j] · cols[k]`` for the nonzero entries."""
    if loss is None:
        return
    cols = rows if cols is None else cols
    for j, a in enumerate(rows):
        if is_zero(a):
            continue
        for k, b in enumerate(cols):
            if not is_zero(b):
                loss.setdefault((j, k), []).append(eta_k * a * b)


def _add_matrix_loss(loss: LossTerms | None, eta: object, K: Sequence[Sequence[object]],
                     cols: list) -> None:
    """``G += η Σ_ab K_ab c_a c_bᵀ`` for a 3×3 stiffness ``K`` acting on the relative
    displacement (or rotation) whose Jacobian columns are ``cols`` (a bushing's translation
    and rotation alike)."""
    for a in range(3):
        for b in range(3):
            if not is_zero(K[a][b]):
                _add_loss(loss, eta * K[a][b], [c[a] for c in cols], [c[b] for c in cols])


def _needs_no_direction(fe: SpringDamper) -> bool:
    """A linear spring of rest length 0 without damping: ``F e = k d`` is defined at ``d = 0``."""
    return (is_zero(fe.length) and is_zero(fe.damping) and is_zero(fe.loss_factor)
            and fe.spring_force is None
            and fe.damper_force is None
            and not ({ELONGATION, ELONGATION_RATE} & fe.stiffness.free_symbols))


def spring_damper(kin: Kinematics, fe: SpringDamper, terms: Terms, path: str,
                  loss: LossTerms | None = None, omega_ref: float = 1.0) -> dict[str, sp.Expr]:
    """A point-to-point spring–damper with a (possibly nonlinear) characteristic.

    With ``d = r_B − r_A``, distance ``ℓ = |d|``, ``e = d/ℓ``, elongation ``s = ℓ − length``
    and ``sd = ∂ℓ/∂y ẏ + e·(v̄_B − v̄_A)``, the tensile force ``F(s, sd)`` pulls the points
    together: ``q += −F ∂ℓ/∂y`` with ``∂ℓ/∂y_j = e·J_B,j − e·J_A,j``.

    Two coinciding points have no direction ``e`` (docs/description-format.md, "Zero-length
    springs"): a linear spring of rest length 0 without damping needs none (``F e = k d``,
    sympy cancels ``ℓ/ℓ``), anything else divides by ``ℓ = 0``. Points that coincide in every
    configuration are refused here (:class:`ModelError`); points that meet at some state make the
    generated module raise ``ZeroDivisionError`` there, which the analysis reports as an error.
    """
    ws = kin.workspace
    name = fe.name
    anc = kin.common_ancestor(fe.frame_a, fe.frame_b)
    pa = kin.relative_position(fe.frame_a, tuple(fe.point_a), anc)
    pb = kin.relative_position(fe.frame_b, tuple(fe.point_b), anc)
    raw = sub(pb, pa)
    if all(is_zero(sp.expand(c)) for c in raw) and not _needs_no_direction(fe):
        raise ModelError(
            "the two points of the spring_damper coincide in every configuration, so its "
            "force has no direction; with a rest length, damping or a characteristic curve "
            "it needs distinct points (see docs/description-format.md, zero-length springs)",
            f"{path}.points",
        )
    d = ws.let_vec(raw, f"d_{name}")
    dist = ws.let(sp.sqrt(dot(d, d)), f"s_{name}")
    e = ws.let_vec(scale(1 / dist, d), f"e_{name}")
    e_a = kin.express(e, anc, fe.frame_a)
    e_b = kin.express(e, anc, fe.frame_b)
    ka = kin.point(fe.frame_a, tuple(fe.point_a), f"{path}.points[0]")
    kb = kin.point(fe.frame_b, tuple(fe.point_b), f"{path}.points[1]")
    ds = [ws.let(dot(kb.J[j], e_b) - dot(ka.J[j], e_a), f"ds_{name}_{j}") for j in range(kin.n)]
    sdot = ws.let(
        total(
            [
                *(sp.Mul(dj, v) for dj, v in zip(ds, kin.velocities, strict=True)
                  if not is_zero(dj)),
                dot(kb.vbar, e_b),
                -dot(ka.vbar, e_a),
            ]
        ),
        f"sd_{name}",
    )
    elongation = ws.let(dist - fe.length, f"el_{name}")
    law = _law(fe, elongation, sdot)
    if not is_zero(fe.loss_factor):
        kt = ws.let(fe.loss_factor * _tangent(fe, elongation, sdot), f"kl_{name}")
        law = law + kt / omega_ref * sdot
        _add_loss(loss, kt, ds)
    force = ws.let(law, f"f_{name}")
    for j in range(kin.n):
        if not is_zero(ds[j]):
            terms[j].append(-force * ds[j])
    return {"force": force}


def _relative_rotation(kin: Kinematics, frame_a: str, frame_b: str) -> tuple[Vec3, Vec3, Vec3]:
    """Rows of ``R = S_Aᵀ S_B`` (B components → A components)."""
    cols = [kin.express(tuple(sp.Integer(int(i == k)) for i in range(3)), frame_b, frame_a)
            for k in range(3)]
    return tuple(tuple(cols[k][i] for k in range(3)) for i in range(3))  # type: ignore[return-value]


def _relative_angular(kin: Kinematics, frame_a: str, frame_b: str, name: str):
    """``ω_rel`` of B relative to A and its Jacobian columns, in A components."""
    ws = kin.workspace
    fa, fb = kin.frames[frame_a], kin.frames[frame_b]
    w_rel = ws.let_vec(sub(kin.express(fb.omega, frame_b, frame_a), fa.omega), f"wr_{name}")
    jr = [
        ws.let_vec(sub(kin.express(fb.JR[j], frame_b, frame_a), fa.JR[j]), f"JRr_{name}_{j}")
        for j in range(kin.n)
    ]
    return w_rel, jr


def rotational_spring_damper(
    kin: Kinematics, fe: RotationalSpringDamper, terms: Terms, index: Mapping[str, int], path: str,
    loss: LossTerms | None = None, omega_ref: float = 1.0,
) -> dict[str, sp.Expr]:
    """A rotational spring–damper (:class:`~neweul_py.model.RotationalSpringDamper`).

    On a coordinate ``c``: ``s = c − angle``, ``sd = ċ − anglė``, ``q_j += −F ∂s/∂y_j``.
    Between frames A, B about axis ``a`` of A: ``s = atan2(R_cb − R_bc, R_bb + R_cc) − angle``
    (``R = S_Aᵀ S_B``, (a, b, c) cyclic; exact for rotations about ``a``, within ``(−π, π]``),
    ``sd = ω_rel·e_a``; the torque ``−F e_a`` acts on B and ``+F e_a`` on A:
    ``q_j += −F (J_R,B,j − J_R,A,j)·e_a`` (A components).
    """
    ws = kin.workspace
    name = fe.name
    if fe.coordinate is not None:
        c = index[fe.coordinate]
        dang, _ = kin.partials(fe.angle)
        ds = [sp.Integer(int(j == c)) - dang[j] for j in range(kin.n)]
        s = ws.let(kin.coordinates[c] - fe.angle, f"el_{name}")
        sd = ws.let(kin.velocities[c] - kin.bar_rate(fe.angle), f"sd_{name}")
    else:
        a = AXES.index(fe.axis)
        b, cc = (a + 1) % 3, (a + 2) % 3
        assert fe.frame_a is not None and fe.frame_b is not None
        R = _relative_rotation(kin, fe.frame_a, fe.frame_b)
        w_rel, jr = _relative_angular(kin, fe.frame_a, fe.frame_b, name)
        s = ws.let(sp.atan2(R[cc][b] - R[b][cc], R[b][b] + R[cc][cc]) - fe.angle, f"el_{name}")
        ds = [col[a] for col in jr]
        sd = ws.let(w_rel[a] - kin.bar_rate(fe.angle), f"sd_{name}")
    law = _law(fe, s, sd)
    if not is_zero(fe.loss_factor):
        kt = ws.let(fe.loss_factor * _tangent(fe, s, sd), f"kl_{name}")
        law = law + kt / omega_ref * sd
        _add_loss(loss, kt, list(ds))
    force = ws.let(law, f"f_{name}")
    for j in range(kin.n):
        if not is_zero(ds[j]):
            terms[j].append(-force * ds[j])
    return {"force": force}


def bushing(kin: Kinematics, fe: Bushing, terms: Terms, path: str,
            loss: LossTerms | None = None, omega_ref: float = 1.0) -> dict[str, sp.Expr]:
    """A linear 6-DOF bushing (:class:`~neweul_py.model.Bushing`), all in A components.

    Translation: ``Δr = S_Aᵀ (r_PB − r_PA)``; its Jacobian columns
    ``c_j = J_PB,j − J_PA,j − J_RA,j × Δr`` (so that ``Δṙ = Σ c_j ẏ_j + c̄`` is the rate of
    ``Δr`` seen in A); ``f = K_t Δr + D_t Δṙ``, ``q_j += −c_j·f``.
    Rotation: ``θ = ½ (R_21 − R_12, R_02 − R_20, R_10 − R_01)`` of ``R = S_Aᵀ S_B``,
    ``l = −(K_r θ + D_r ω_rel)`` on B, ``q_j += (J_RB,j − J_RA,j)·l``.
    """
    ws = kin.workspace
    name = fe.name
    A, B = fe.frame_a, fe.frame_b
    n = kin.n
    out: dict[str, sp.Expr] = {}

    def matrix(m: sp.ImmutableMatrix):
        return tuple(tuple(m[i, j] for j in range(3)) for i in range(3))

    Kt, Dt = matrix(fe.stiffness), matrix(fe.damping)
    Kr, Dr = matrix(fe.rotational_stiffness), matrix(fe.rotational_damping)
    zero = lambda m: all(is_zero(x) for row in m for x in row)  # noqa: E731
    eta = fe.loss_factor
    if not is_zero(eta):        # the viscous equivalent (η/ω_ref) K of the loss factor
        Dt = tuple(tuple(d + eta / omega_ref * k for d, k in zip(dr, kr, strict=True))
                   for dr, kr in zip(Dt, Kt, strict=True))
        Dr = tuple(tuple(d + eta / omega_ref * k for d, k in zip(dr, kr, strict=True))
                   for dr, kr in zip(Dr, Kr, strict=True))

    if not (zero(Kt) and zero(Dt)):
        anc = kin.common_ancestor(A, B)
        pa = kin.relative_position(A, tuple(fe.point_a), anc)
        pb = kin.relative_position(B, tuple(fe.point_b), anc)
        dr = ws.let_vec(kin.express(sub(pb, pa), anc, A), f"dr_{name}")
        ka = kin.point(A, tuple(fe.point_a), f"{path}.points[0]")
        kb = kin.point(B, tuple(fe.point_b), f"{path}.points[1]")
        fa = kin.frames[A]
        cols = [
            ws.let_vec(
                sub(sub(kin.express(kb.J[j], B, A), ka.J[j]), cross(fa.JR[j], dr)),
                f"cb_{name}_{j}",
            )
            for j in range(n)
        ]
        cbar = sub(sub(kin.express(kb.vbar, B, A), ka.vbar), cross(fa.wbar, dr))
        rate = ws.let_vec(
            add(*(scale(v, cols[j]) for j, v in enumerate(kin.velocities)), cbar), f"drd_{name}"
        )
        f = ws.let_vec(add(mat_vec(Kt, dr), mat_vec(Dt, rate)), f"fb_{name}")
        if not is_zero(eta) and not zero(Kt):
            _add_matrix_loss(loss, eta, Kt, cols)
        for j in range(n):
            term = dot(cols[j], f)
            if not is_zero(term):
                terms[j].append(-term)
        out.update({"fx": -f[0], "fy": -f[1], "fz": -f[2]})
    else:
        out.update({"fx": ZERO, "fy": ZERO, "fz": ZERO})

    if not (zero(Kr) and zero(Dr)):
        R = _relative_rotation(kin, A, B)
        theta = ws.let_vec(
            tuple((R[c][b] - R[b][c]) / 2 for b, c in ((1, 2), (2, 0), (0, 1))), f"th_{name}"
        )
        w_rel, jr = _relative_angular(kin, A, B, name)
        if not is_zero(eta) and not zero(Kr):
            _add_matrix_loss(loss, eta, Kr, jr)
        torque = ws.let_vec(
            scale(-1, add(mat_vec(Kr, theta), mat_vec(Dr, w_rel))), f"lb_{name}"
        )
        for j in range(n):
            term = dot(jr[j], torque)
            if not is_zero(term):
                terms[j].append(term)
        out.update({"mx": torque[0], "my": torque[1], "mz": torque[2]})
    else:
        out.update({"mx": ZERO, "my": ZERO, "mz": ZERO})
    return out


def reported_quantities(fe: ForceElement) -> dict[str, sp.Expr]:
    """What the elements of issue 2 report: a force's vector (its ``in`` frame), a torque's
    vector, a generalized force's value (before the ``enabled`` factor)."""
    if isinstance(fe, PointForce):
        return dict(zip(("fx", "fy", "fz"), tuple(fe.vector), strict=True))
    if isinstance(fe, Torque):
        return dict(zip(("mx", "my", "mz"), tuple(fe.vector), strict=True))
    if isinstance(fe, GeneralizedForce):
        return {"force": fe.value}
    return {}


def apply_force_element(
    kin: Kinematics,
    fe: ForceElement,
    force_terms: Terms,
    index: Mapping[str, int],
    path: str,
    base: object = None,
    loss: LossTerms | None = None,
    omega_ref: float = 1.0,
) -> dict[str, sp.Expr]:
    """Add ``fe``'s generalized forces, times its ``enabled`` factor, to ``force_terms``.

    Parameters
    ----------
    base
        ``base(kin, fe, terms, path)`` derives the elements this module does not handle
        (those of :mod:`~neweul_py.equations.newton_euler`).
    loss, omega_ref
        Entries of the hysteretic matrix ``G`` to add to (times ``enabled``; module
        docstring) and the reference angular frequency ``ω_ref = 2π f_ref`` of the
        loss-equivalent viscous forces.

    Returns
    -------
    dict
        The reported quantities (:class:`~neweul_py.model.ForceOutput` components), also
        multiplied by ``enabled``.
    """
    terms: Terms = [[] for _ in range(kin.n)]
    own: LossTerms = {}
    if isinstance(fe, SpringDamper):
        reported = spring_damper(kin, fe, terms, path, own, omega_ref)
    elif isinstance(fe, RotationalSpringDamper):
        reported = rotational_spring_damper(kin, fe, terms, index, path, own, omega_ref)
    elif isinstance(fe, Bushing):
        reported = bushing(kin, fe, terms, path, own, omega_ref)
    elif base is not None:
        base(kin, fe, terms, path)  # type: ignore[operator]
        reported = reported_quantities(fe)
    else:  # pragma: no cover - System validation rejects other types
        raise ModelError(f"unsupported force element {type(fe).__name__}", path)
    enabled = getattr(fe, "enabled", sp.Integer(1))
    for j in range(kin.n):
        if terms[j]:
            value = total(terms[j])
            force_terms[j].append(value if enabled == 1 else enabled * value)
    if enabled != 1:
        reported = {k: enabled * v for k, v in reported.items()}
    if loss is not None:
        for jk, items in own.items():
            value = total(items)
            loss.setdefault(jk, []).append(value if enabled == 1 else enabled * value)
    return reported
