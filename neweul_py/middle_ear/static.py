"""The static state of the middle ear: the nonlinear TM held by the ossicular chain under Δp.

Static load: the static pressure difference ``Δp = p_canal − p_cavity`` (positive pushes the TM
medially, as a *negative middle-ear pressure* does) is a follower load on the TM; the TM is a
total-Lagrangian St. Venant–Kirchhoff facet shell (:mod:`neweul_py.fem.shell`); the manubrium is
held by a rigid malleus on the stiffening ossicular chain (:mod:`neweul_py.middle_ear.chain`).
Equilibrium (``docs/equations-middle-ear.md`` §2)::

    R_u = f_int(u) + K_b u − f_p(u; Δp) + k Pᵀ(P u − T q) = 0,
    R_q = −k Tᵀ (P u − T q) + F_c(q) = 0,

``P`` picking the manubrium DOFs; solved by Newton's method with load stepping
(:func:`neweul_py.fem.nonlinear.load_path`), each load step checked against the validity bounds
(:func:`static_validity`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sps
import scipy.sparse.linalg as spla

from ..elastic.reductors.eigen import SparseLU
from ..elastic.reductors.projection import Progress
from ..errors import ModelError, SolverError
from ..fem.nonlinear import NewtonOptions, StaticState, load_path
from .chain import chain_tangent_matrix, condensed_support
from .model import MiddleEar
from .parameters import MAX_DISPLACEMENT_FRACTION, MAX_VOLUME_FRACTION

__all__ = [
    "ValidityBound",
    "interface_forces",
    "lowest_tangent_eigenvalue",
    "malleus_coordinates",
    "solve_static",
    "static_residual",
    "static_summary",
    "static_validity",
    "support_at",
    "tm_displacements",
    "tm_dofs",
]


def tm_dofs(me: MiddleEar, state: StaticState) -> np.ndarray:
    """The free TM displacement DOFs of a static state."""
    return state.u[: me.n_u]


def malleus_coordinates(me: MiddleEar, state: StaticState) -> np.ndarray:
    """The malleus coordinates ``q = (q_t [m], θ [rad])`` of a static state (zeros if absent)."""
    q = state.u[me.n_u :]
    return q.copy() if q.size == 6 else np.zeros(6)


def tm_displacements(me: MiddleEar, state: StaticState) -> np.ndarray:
    """(n_TM, 3) displacements of all TM nodes (zero on the clamped rim)."""
    u = np.zeros(me.shell.n_dof)
    u[me.free_dofs] = tm_dofs(me, state)
    return u.reshape(-1, 3)


_full = tm_displacements


def _chain(me: MiddleEar, q: np.ndarray):
    p = me.params
    return chain_tangent_matrix(
        q, p.k_chain, p.tm_radius, p.chain_limit_medial, p.chain_limit_lateral
    )


def static_residual(me: MiddleEar):
    """``residual(x, Δp) -> (R, K, f_scale)`` for :func:`~neweul_py.fem.nonlinear.load_path`.

    ``x = [u_free; q]``; ``R`` and its consistent tangent ``K`` as in the module docstring.
    """
    shell, fi = me.shell, me.free_dofs
    kb = shell.bending.tocsr()
    n_u = me.n_u
    t = me.malleus_T
    md = me.manubrium_dofs
    k_att = me.params.k_tm_manubrium / me.tm.line.size
    pos = -np.ones(shell.n_dof, dtype=int)
    pos[fi] = np.arange(n_u)
    mdf = pos[md]  # manubrium DOFs in the free numbering (all free: the umbo is not clamped)
    p_sel = sps.csr_matrix((np.ones(md.size), (np.arange(md.size), mdf)), shape=(md.size, n_u))
    k_uu_att = k_att * (p_sel.T @ p_sel)
    k_uq = sps.csr_matrix(-k_att * (p_sel.T @ t))
    scale0 = me.params.tm_area / math.sqrt(me.tm.points.shape[0])

    def residual(x: np.ndarray, dp: float):
        u = np.zeros(shell.n_dof)
        u[fi] = x[:n_u]
        q = x[n_u:]
        _, fint, km = shell.membrane(u)
        _, fp, kp = shell.pressure(u, dp)
        d = u[md] - t @ q
        fc, kc = _chain(me, q)
        r_u = (fint + kb @ u - fp)[fi]
        r_u[mdf] += k_att * d
        r_q = -k_att * (t.T @ d) + fc
        k_tm = (km + kb + kp).tocsr()[fi][:, fi]
        k = sps.bmat(
            [[k_tm + k_uu_att, k_uq], [k_uq.T, sps.csr_matrix(k_att * t.T @ t + kc)]],
            format="csr",
        )
        return np.concatenate([r_u, r_q]), k, max(abs(dp), 1.0) * scale0

    return residual


def support_at(me: MiddleEar, state: StaticState) -> sps.csr_matrix:
    """The condensed chain support of the manubrium (3n × 3n, TM DOFs) linearized at a state.

    ``K_sup(q_s) = k I − k² T (k TᵀT + K_c(q_s))⁻¹ Tᵀ`` with the chain tangent ``K_c`` at the
    static malleus position (:func:`~neweul_py.middle_ear.chain.condensed_support`): what
    the working-point model needs to stand for the TM with the chain *at this Δp*.
    """
    _, kc = _chain(me, malleus_coordinates(me, state))
    ks = condensed_support(me.malleus_T, me.params.k_tm_manubrium, kc)
    md = me.manubrium_dofs
    rows, cols = np.meshgrid(md, md, indexing="ij")
    n = me.shell.n_dof
    return sps.csr_matrix((ks.ravel(), (rows.ravel(), cols.ravel())), shape=(n, n))


def _residual(me: MiddleEar):
    return static_residual(me)


@dataclass(frozen=True)
class ValidityBound:
    """One validity bound of a static state, ``value ≤ limit`` (SI units).

    ``text`` describes a violation; its ``{value}`` and ``{limit}`` are printed multiplied by
    ``scale`` (to mm, µm, mm³).
    """

    name: str
    value: float
    limit: float
    text: str
    scale: float = 1.0

    @property
    def ok(self) -> bool:
        """The bound holds."""
        return self.value <= self.limit

    def describe(self) -> str:
        """The violation in words, with the value and the limit."""
        return self.text.format(value=self.value * self.scale, limit=self.limit * self.scale)


def static_validity(me: MiddleEar, state: StaticState) -> tuple[ValidityBound, ...]:
    """The physical-validity bounds of a static TM state (all must hold, ``bound.ok``).

    The working-point models keep the air meshes in the reference geometry and take ``C`` on
    the deformed TM; that is consistent only while the TM moves little compared with the air
    spaces. Checked (``x = X + u`` the deformed TM nodes, ``ΔV`` the swept volume):

    * **walls**: every TM node stays inside the tympanic cavity (``z ≤ L_c``, ``r ≤ a``, ``r``
      from the rim's centre) and the ear canal (``z ≥ −L``, inside the canal's conical wall)
      — penetration depth ≤ 0;
    * **no inversion of the cone**: ``max |u| ≤`` :data:`MAX_DISPLACEMENT_FRACTION` ``· H``,
      ``H = max z − min z`` of the reference TM (the cone inverts when its apex has moved by
      about ``H``; not checked for a flat TM);
    * **small volume change**: ``|ΔV| ≤`` :data:`MAX_VOLUME_FRACTION` ``·`` (mesh volume) of
      the canal and of the cavity (linear acoustics on the reference mesh; the compression of
      the cavity air by ``ΔV`` is itself a static pressure change of ``ρc²ΔV/V_c``, 7 kPa at
      5 % — the order of the static pressures modelled).

    At ±4 kPa (default model) ``|ΔV| ≈ 8 mm³`` (1.7 % of the cavity) and ``max |u| ≈ 0.26 mm``
    (0.13 of ``H = 2 mm``).

    Returns
    -------
    tuple of ValidityBound
        Walls of the cavity and of the canal, cone inversion, volume vs. canal and cavity.
    """
    p = me.params
    a, length, lc = p.tm_radius, p.canal_length, p.cavity_length
    u = _full(me, state)
    x = me.shell.points + u
    r = np.hypot(*(x[:, :2] - me.tm.rim_centre).T)  # from the canal's and cavity's axis
    z = x[:, 2]
    tol = 1e-9 * a
    # canal wall: the extruded rim, r = a + (d/2 − a)·(−z/L) for −L ≤ z ≤ 0
    r_canal = a + (0.5 * p.canal_diameter - a) * np.clip(-z / length, 0.0, 1.0)
    above, below = z >= 0.0, z < 0.0
    cav = np.concatenate([[z.max() - lc], (r - a)[above]]).max()
    can = np.concatenate([[-length - z.min()], (r - r_canal)[below]]).max()
    depth = float(np.ptp(me.shell.points[:, 2]))
    umax = float(np.linalg.norm(u, axis=1).max())
    dv = abs(me.shell.pressure(u.ravel(), 0.0)[0])
    frac = f"{100 * MAX_VOLUME_FRACTION:g} %"
    return (
        ValidityBound(
            "cavity wall",
            cav,
            tol,
            "the TM penetrates the tympanic cavity wall by {value:.3g} mm",
            1e3,
        ),
        ValidityBound(
            "canal wall", can, tol, "the TM penetrates the ear-canal wall by {value:.3g} mm", 1e3
        ),
        ValidityBound(
            "cone inversion",
            umax,
            MAX_DISPLACEMENT_FRACTION * depth if depth > 0 else math.inf,
            "cone inversion: the largest TM displacement {value:.1f} µm exceeds "
            f"{MAX_DISPLACEMENT_FRACTION:g} × the cone depth " + "({limit:.1f} µm)",
            1e6,
        ),
        ValidityBound(
            "canal volume",
            dv,
            MAX_VOLUME_FRACTION * me.info["canal_volume_m3"],
            f"|ΔV| = {{value:.3f}} mm³ exceeds {frac} of the ear-canal volume ({{limit:.3f}} mm³)",
            1e9,
        ),
        ValidityBound(
            "cavity volume",
            dv,
            MAX_VOLUME_FRACTION * me.info["cavity_volume_m3"],
            f"|ΔV| = {{value:.3f}} mm³ exceeds {frac} of the tympanic cavity volume "
            "({limit:.3f} mm³)",
            1e9,
        ),
    )


def solve_static(
    me: MiddleEar,
    pressures: Sequence[float],
    options: NewtonOptions | None = None,
    check_stability: bool = True,
    check_validity: bool = True,
    progress: Progress = None,
) -> list[StaticState]:
    """Static equilibria of the TM held by the ossicular chain at the pressures ``Δp`` [Pa].

    The unknowns are the free TM displacements and the six malleus coordinates; the chain
    carries the load with its stiffening characteristic (:func:`static_residual`).

    The positive and the negative branch are each followed from the unloaded state with Newton's
    method and adaptive load steps (:func:`~neweul_py.fem.nonlinear.load_path`). With
    ``check_validity`` every converged load step is checked against the physical-validity
    bounds of :func:`static_validity` (so that an absurd load stops at the first invalid step).
    With ``check_stability`` every returned state is checked to have a positive definite tangent
    (:func:`lowest_tangent_eigenvalue`), so that a passed bifurcation is not returned as a
    working point.

    Parameters
    ----------
    progress
        Called with a short message after every converged load step.

    Returns
    -------
    list of StaticState
        In the order of ``pressures``; ``u`` = ``[free TM displacement DOFs; malleus q (6)]``
        (split with :func:`tm_dofs` and :func:`malleus_coordinates`).

    Raises
    ------
    SolverError
        A pressure could not be reached (the message names the last converged load step), a
        load step violates a validity bound (the message names the load step, the bound with its
        value and the last valid load step; ``last_iterate`` is that state), or a reached state
        is unstable.

    Examples
    --------
    >>> me = build_middle_ear(refine=0)
    >>> [s.load for s in solve_static(me, [-1000.0, 0.0, 1000.0])]
    [-1000.0, 0.0, 1000.0]
    """
    dps = np.asarray(pressures, dtype=float)
    if dps.ndim != 1 or dps.size == 0 or not np.all(np.isfinite(dps)):
        raise ModelError("pressures must be a non-empty list of finite numbers", "pressures")
    res = _residual(me)
    out: list[StaticState | None] = [None] * dps.size
    for branch in (np.flatnonzero(dps >= 0), np.flatnonzero(dps < 0)):
        if branch.size == 0:
            continue
        goal = float(dps[branch][np.argmax(np.abs(dps[branch]))])
        last_valid = [StaticState(0.0, np.zeros(me.n_u + 6), 0, 0.0)]

        def on_step(state: StaticState, goal: float = goal, last_valid=last_valid) -> None:
            if check_validity:
                bad = [b for b in static_validity(me, state) if not b.ok]
                if bad:
                    raise SolverError(
                        f"the static state at the load step Δp = {state.load:+g} Pa (of "
                        f"{goal:+g} Pa) is outside the model's validity ("
                        + "; ".join(b.describe() for b in bad)
                        + f"); last valid load step Δp = {last_valid[0].load:+g} Pa",
                        last_iterate=last_valid[0],
                        residual=last_valid[0].residual,
                    )
            last_valid[0] = state
            if progress is not None:
                dv = me.shell.pressure(_full(me, state).ravel(), 0.0)[0]
                progress(
                    f"Δp = {state.load:+9.1f} Pa (of {goal:+g}): {state.iterations} Newton "
                    f"iterations, ΔV = {dv * 1e9:+.4g} mm³"
                )

        try:
            states = load_path(res, me.n_u + 6, dps[branch], options, on_step)
        except SolverError as exc:
            raise SolverError(
                f"TM static solution: {exc.message}", exc.last_iterate, exc.residual
            ) from None
        for i, s in zip(branch, states, strict=True):
            if check_stability:
                lam = lowest_tangent_eigenvalue(me, s)
                s = replace(s, lowest_eigenvalue=lam)          # for static_summary
                if lam < 0:
                    raise SolverError(
                        f"TM static solution at Δp = {s.load:g} Pa is unstable (the tangent "
                        f"with support has the eigenvalue ω² = {lam:.4g} 1/s² < 0: the load "
                        "path passed a bifurcation)",
                        last_iterate=s,
                        residual=s.residual,
                    )
            out[i] = s
    return [s for s in out if s is not None]


def lowest_tangent_eigenvalue(me: MiddleEar, state: StaticState) -> float:
    """The eigenvalue ``ω²`` nearest 0 of the TM tangent (with the chain support linearized at
    the state, malleus condensed) and the TM mass.

    Negative: the static state is unstable. Found by shift-invert Lanczos about 0, unless
    :func:`solve_static` recorded it in ``state.lowest_eigenvalue``.
    """
    if state.lowest_eigenvalue is not None:
        return float(state.lowest_eigenvalue)
    shell, fi = me.shell, me.free_dofs
    u = tm_displacements(me, state).ravel()
    _, _, km = shell.membrane(u)
    _, _, kp = shell.pressure(u, state.load)
    k = (km + shell.bending + kp + support_at(me, state)).tocsr()[fi][:, fi]
    k = 0.5 * (k + k.T)
    ms = shell.mass()[fi][:, fi]
    k = k.tocsc()
    lu = SparseLU(k)                    # symmetric ordering: 30 % less than eigsh's own LU
    inverse = spla.LinearOperator(k.shape, matvec=lu.solve, dtype=float)
    lam = spla.eigsh(k, M=ms.tocsc(), k=1, sigma=0.0, which="LM", OPinv=inverse)[0]
    return float(lam[0])


def interface_forces(me: MiddleEar, state: StaticState) -> np.ndarray:
    """(m, 3) static forces [N] of the malleus on the manubrium nodes (order of ``tm.line``):
    ``−k (u_i − (T q)_i)``; their sum balances the net pressure force the TM passes on."""
    u = tm_displacements(me, state).ravel()
    d = u[me.manubrium_dofs] - me.malleus_T @ malleus_coordinates(me, state)
    k_att = me.params.k_tm_manubrium / me.tm.line.size
    return (-k_att * d).reshape(-1, 3)


def static_summary(me: MiddleEar, state: StaticState) -> dict[str, float]:
    """Volume displacement [m³] (positive medially), umbo displacement [m], the force of the TM
    on the chain [N], the chain's tangent stiffness along the TM axis [N/m] and the lowest
    in-vacuo TM frequency with the chain support at the working point [Hz] (negative if the
    state were unstable)."""
    u = tm_displacements(me, state)
    dv, _, _ = me.shell.pressure(u.ravel(), 0.0)
    lam = lowest_tangent_eigenvalue(me, state)
    f_chain = -interface_forces(me, state).sum(axis=0)
    q = malleus_coordinates(me, state)
    _, kc = _chain(me, q)
    return {
        "dp_Pa": state.load,
        "volume_displacement_m3": dv,
        "umbo_ux_m": u[me.umbo, 0],
        "umbo_uy_m": u[me.umbo, 1],
        "umbo_uz_m": u[me.umbo, 2],
        "malleus_qz_m": q[2],
        "support_force_z_N": f_chain[2],
        "chain_tangent_z_N_per_m": kc[2, 2],
        "tm_f1_support_Hz": math.copysign(math.sqrt(abs(lam)), lam) / (2 * math.pi),
        "newton_iterations_last_step": state.iterations,
    }
