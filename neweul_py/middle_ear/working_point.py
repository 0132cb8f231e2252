"""The linearized middle-ear FE model at a static working point, its loss factors and its
static state (what a parametric body needs to stand for the nonlinear TM).

Dynamic model at a working point (Eq. (2) of the seed paper, ``docs/equations-middle-ear.md``
§3)::

    [Ms 0; ρCᵀ Mf] [ü; p̈] + [Ks −C; 0 Kf] [u; p] = [f; p_ex]

with ``Ks`` the consistent tangent at the working point (membrane material + stress
stiffening, bending, pressure load stiffness), ``C`` on both TM faces with the normals out of
each air volume evaluated on the deformed TM. Losses are loss factors: in the frequency domain
the stiffness is ``K + iG`` with the hysteretic damping ``G`` (:func:`hysteretic_damping`); the
time-domain equivalent written as ``D`` is ``G/ω_ref`` (exact at ``f_ref``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sps

from ..elastic.fe_model import FEModel
from ..fem.acoustic import surface_load
from ..fem.coupling import assemble_up, coupling_matrix
from ..fem.nonlinear import StaticState
from .chain import chain_tangent_matrix
from .flaccida import flaccida_mass, flaccida_stiffness, flaccida_volume
from .model import MiddleEar
from .parameters import MiddleEarParameters
from .static import interface_forces, malleus_coordinates, support_at, tm_displacements

__all__ = [
    "flaccida_blocks",
    "hysteretic_damping",
    "loss_info",
    "static_data",
    "tm_tangent",
    "working_point_model",
]


def tm_tangent(me: MiddleEar, u: np.ndarray) -> sps.csr_matrix:
    """The TM's tangent about the static displacements ``u`` without the pressure's load
    stiffness: ``K_m(E) + K_σ(S(u; E_s)) + (E/E_s) K_b`` (docs/equations-middle-ear.md §3).

    The static state is solved with ``tm_E_static`` (the shell's material,
    :mod:`neweul_py.middle_ear.static`); the small motions about it see the storage modulus ``tm_E``
    in the material part of the membrane tangent and in the bending, while the membrane
    stress of the stress stiffening is the static one.
    """
    p = me.params
    _, _, km = me.shell.membrane(u, incremental_modulus=p.tm_E)
    return (km + (p.tm_E / p.tm_E_static) * me.shell.bending).tocsr()


def hysteretic_damping(
    me: MiddleEar,
    state: StaticState,
    include_support: bool = False,
    *,
    tm_k: sps.spmatrix | None = None,
    support: sps.spmatrix | None = None,
) -> sps.csr_matrix:
    """``G`` of the frequency-domain stiffness ``K + iG`` (DOFs of :func:`working_point_model`).

    ``G = blockdiag(η_TM (K_m + K_σ + (E/E_s) K_b) [+ η_TM K_sup], η_air Kf_acoustic +
    η_m Kf_aditus)``, with ``η_TM k_pf`` for the pars flaccida's DOF if present: the TM loss
    factor on its tangent (:func:`tm_tangent`: membrane
    material and stress stiffening, bending; not on the load stiffness of the pressure,
    which stores no energy in the tissue), the air loss factor on the acoustic Laplacian, the
    mastoid loss factor on the aditus (its inertance becomes ``M_a (1 − iη_m)``, a
    resistance). ``tm_k``: :func:`tm_tangent` at the state, and ``support``:
    :func:`~neweul_py.middle_ear.static.support_at` at the state, when the caller has them.
    """
    p = me.params
    fi = me.free_dofs
    if tm_k is None:
        tm_k = tm_tangent(me, tm_displacements(me, state))
    gs = p.tm_loss * tm_k
    if include_support:
        gs = gs + p.tm_loss * (support_at(me, state) if support is None else support)
    gs = gs.tocsr()[fi][:, fi]
    gs = 0.5 * (gs + gs.T)
    if me.flaccida is not None:
        gs = sps.block_diag([gs, [[p.tm_loss * flaccida_blocks(me, state.load)[0]]]])
    kad = me.Kf_aditus if me.Kf_aditus is not None else sps.csr_matrix(me.Kf.shape)
    gf = p.air_loss * (me.Kf - kad) + p.mastoid_loss * kad
    return sps.block_diag([gs, gf], format="csr")


def static_data(me: MiddleEar, state: StaticState) -> dict[str, np.ndarray]:
    """The static state of a working point, as the optional ``static`` group of the FE file.

    Keys (``docs/equations-middle-ear.md`` §3, ``examples/middle_ear/README.md``):
    ``dp`` [Pa]; ``node_id``, ``reference`` (n_TM, 3), ``u`` (n_TM, 3): TM nodes, reference
    positions and static displacements [m] (deformed = reference + u); ``x`` (n_dofs): the
    static state on the model's DOFs (TM part ``u``, the pars flaccida's mean displacement
    if present, pressures 0: the static Δp is the
    reference of the acoustic perturbation), from which a reduced body's static coordinates
    are ``q_s = (WᵀV)⁻¹ Wᵀ x``; ``manubrium_node_id`` (m), ``manubrium_force`` (m, 3): static
    forces of the malleus on the manubrium nodes [N]; ``malleus_q`` (6): the static malleus
    translation [m] and rotation [rad] about the umbo; ``chain_tangent`` (6, 6): the chain's
    tangent stiffness at the state [N/m, N m/rad].
    """
    p = me.params
    u = tm_displacements(me, state)
    x = np.zeros(me.n_u + me.n_flaccida + me.n_p)
    x[: me.n_u] = u.ravel()[me.free_dofs]
    if me.flaccida is not None:
        x[me.n_u] = flaccida_volume(state.load, p.pf_compliance, p.pf_stiffening_pressure
                                    ) / p.pf_area
    q = malleus_coordinates(me, state)
    _, kc = chain_tangent_matrix(
        q, p.k_chain, p.tm_radius, p.chain_limit_medial, p.chain_limit_lateral
    )
    return {
        "dp": np.array(float(state.load)),
        "node_id": np.arange(1, me.tm.points.shape[0] + 1),
        "reference": me.tm.points.copy(),
        "u": u,
        "x": x,
        "manubrium_node_id": me.tm.line + 1,
        "manubrium_force": interface_forces(me, state),
        "malleus_q": q,
        "chain_tangent": kc,
    }


def working_point_model(
    me: MiddleEar, state: StaticState, include_support: bool = False
) -> FEModel:
    """The ``up-coupled`` FE model (Eq. (2)) linearized at a static working point.

    Parameters
    ----------
    me
        The middle-ear model.
    state
        A converged static state from :func:`solve_static`.
    include_support
        Keep the ossicular support (the chain tangent at this state, malleus condensed:
        :func:`~neweul_py.middle_ear.static.support_at`) in ``Ks``; by default it is left out
        because the malleus of the multibody model attaches to the manubrium nodes (the static
        interface forces are in :func:`static_data`).

    Returns
    -------
    FEModel
        DOFs ``[u (free TM nodes, ux uy uz); w (the pars flaccida's mean displacement, if
        present: :func:`flaccida_blocks`); p canal; p cavity; p mastoid]``. ``D`` is the
        time-domain equivalent ``G/ω_ref`` of the hysteretic damping ``G``
        (:func:`hysteretic_damping`; exact loss factors at ``f_ref``). Inputs:
        ``canal_volume_acceleration`` (a piston source at the canal entrance, per m³/s² of
        volume acceleration: ``p_ex = ρ/S ∫ N dΓ · Q̇``) and ``manubrium.<node>.u{x,y,z}``
        (forces on the interface nodes). Outputs: ``probe_pressure`` [Pa],
        ``entrance_pressure`` [Pa] (the mean pressure over the piston at the canal entrance,
        the work conjugate of the canal source: a clinical probe's tip),
        ``umbo_u{x,y,z}`` [m], ``tm_volume_displacement`` [m³] (linearized) and
        ``manubrium.<node>.u{x,y,z}`` [m]; with a pars flaccida ``pf_volume_displacement``
        [m³].
    """
    p = me.params
    shell, fi = me.shell, me.free_dofs
    u = tm_displacements(me, state)
    _, _, kp = shell.pressure(u, state.load)
    _, grad_v, _ = shell.pressure(u, 1.0)  # ∂V/∂u: the linearized volume displacement
    kt = tm_tangent(me, u)
    ks = kt + kp
    sup = support_at(me, state) if include_support else None
    if sup is not None:
        ks = ks + sup
    ks = ks.tocsr()[fi][:, fi]
    ks = 0.5 * (ks + ks.T)  # remove round-off asymmetry
    ms = shell.mass()[fi][:, fi]
    x = shell.points + u
    n_tm = shell.points.shape[0]
    nc = me.canal.points.shape[0]
    n_p = me.n_p
    all_nodes = np.arange(n_tm)
    c_canal = coupling_matrix(x, me.tm.triangles, all_nodes, me.canal_tm_nodes, n_tm, n_p, +1.0)
    c_cav = coupling_matrix(x, me.tm.triangles, all_nodes, nc + me.cavity_tm_nodes, n_tm, n_p, -1.0)
    c = (c_canal + c_cav).tocsr()[fi]
    if me.flaccida is not None:
        k_pf, m_pf = flaccida_blocks(me, state.load)
        ks = sps.block_diag([ks, [[k_pf]]], format="csr")
        ms = sps.block_diag([ms, [[m_pf]]], format="csr")
        c = sps.vstack([c, sps.csr_matrix(p.pf_area * me.flaccida[None, :])], format="csr")
    w = 2 * np.pi * p.f_ref
    g = hysteretic_damping(me, state, include_support, tm_k=kt, support=sup)
    m, _, k = assemble_up(ms, ks, me.Mf, me.Kf, c, p.rho_air)
    d = g / w

    # DOF map and node table
    nu = fi.size + me.n_flaccida
    ids_tm = np.arange(1, n_tm + 1)
    ids_canal = n_tm + 1 + np.arange(nc)
    n_cav = me.cavity.points.shape[0]
    ids_cav = n_tm + nc + 1 + np.arange(n_cav)
    ids_mas = n_tm + nc + n_cav + 1 + np.arange(me.n_mastoid)
    mastoid_at = np.array([[0.0, 0.0, p.cavity_length + p.aditus_length]])[: me.n_mastoid]
    ids_pf = n_tm + nc + n_cav + me.n_mastoid + 1 + np.arange(me.n_flaccida)
    pf_at = (np.clip(me.flaccida[:nc], 0.0, None) @ me.canal.points)[None, :] \
        if me.flaccida is not None else np.zeros((0, 3))
    nodes = np.vstack(
        [
            np.column_stack([ids_tm, shell.points]),
            np.column_stack([ids_canal, me.canal.points]),
            np.column_stack([ids_cav, me.cavity.points]),
            np.column_stack([ids_mas, mastoid_at]),
            np.column_stack([ids_pf, pf_at]),
        ]
    )
    kinds = np.array(["ux", "uy", "uz"])
    dof_node = np.concatenate([ids_tm[fi // 3], ids_pf, ids_canal, ids_cav, ids_mas])
    dof_kind = np.concatenate([kinds[fi % 3], np.full(me.n_flaccida, "uz"), np.full(n_p, "p")])

    pos = -np.ones(shell.n_dof, dtype=int)
    pos[fi] = np.arange(fi.size)
    inputs: dict[str, tuple[tuple[int, float], ...]] = {}
    outputs: dict[str, tuple[tuple[int, float], ...]] = {}
    load = surface_load(me.canal.points, me.canal_entrance)
    area = load.sum()
    nz = np.flatnonzero(load)
    inputs["canal_volume_acceleration"] = tuple(
        (int(nu + i), float(p.rho_air / area * load[i])) for i in nz
    )
    outputs["probe_pressure"] = tuple(
        (int(nu + n), float(wt)) for n, wt in zip(me.probe_nodes, me.probe_weights, strict=True)
    )
    outputs["entrance_pressure"] = tuple((int(nu + i), float(load[i] / area)) for i in nz)
    for j, kname in enumerate(kinds):
        outputs[f"umbo_{kname}"] = ((int(pos[3 * me.umbo + j]), 1.0),)
    gv = grad_v.ravel()
    outputs["tm_volume_displacement"] = tuple(
        (int(pos[i]), float(gv[i])) for i in fi if gv[i] != 0.0
    )
    if me.flaccida is not None:
        outputs["pf_volume_displacement"] = ((int(fi.size), float(p.pf_area)),)
    for node in me.tm.line:
        for j, kname in enumerate(kinds):
            name = f"manubrium.{int(ids_tm[node])}.{kname}"
            inputs[name] = ((int(pos[3 * node + j]), 1.0),)
            outputs[name] = ((int(pos[3 * node + j]), 1.0),)
    return FEModel(
        M=m,
        K=k,
        D=d,
        nodes=nodes,
        dof_node=dof_node,
        dof_kind=dof_kind,
        inputs=inputs,
        outputs=outputs,
        kind="up-coupled",
        density=p.rho_air,
        name=f"middle-ear-dp{state.load:+.0f}Pa",
    )


def flaccida_blocks(me: MiddleEar, dp: float) -> tuple[float, float]:
    """Tangent stiffness and mass of the pars flaccida's mean displacement at ``dp``
    (:mod:`neweul_py.middle_ear.flaccida`; coupled to the air by ``A gᵀ``,
    :func:`~neweul_py.middle_ear.model.flaccida_patches`)."""
    p = me.params
    return (flaccida_stiffness(dp, p.pf_area, p.pf_compliance, p.pf_stiffening_pressure),
            flaccida_mass(p.pf_area, p.pf_surface_density))


def loss_info(p: MiddleEarParameters) -> dict[str, Any]:
    """The ``loss_meta`` record: loss factors and the time-domain equivalent."""
    return {
        "tm_loss": p.tm_loss,
        "air_loss": p.air_loss,
        "mastoid_loss": p.mastoid_loss,
        "f_ref_Hz": p.f_ref,
        "frequency_domain": "K + i G",
        "time_domain": "D = G / (2 pi f_ref): the loss factors exact at f_ref, "
        "eta(f) = eta f / f_ref elsewhere",
    }
