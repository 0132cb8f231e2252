"""Floating-frame invariants computed from an FE model and a basis (``docs/equations.md`` §2).

:func:`compute_invariants` evaluates the volume integrals of Wallrapp (1994) and
Schwertassek & Wallrapp (1999, ch. 6) with the FE mass matrix (the conventions and the
symmetric cross-product forms are those of :mod:`neweul_py.elastic.bodies.invariants`);
:func:`stress_stiffening` and :func:`inertia_loads` give the geometric stiffness of the 12 unit
inertia load cases; :func:`attach_invariants` stores the invariants of a reduced body in its
invariants slot.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sps

from ...errors import DataError
from ..bodies.invariants import (
    LEVI_CIVITA,
    LOAD_CASES,
    OMEGA_PRODUCTS,
    Invariants,
    NodeFrame,
    skew,
)
from ..bodies.taylor import Taylor

__all__ = [
    "attach_invariants",
    "compute_invariants",
    "inertia_loads",
    "inertia_responses",
    "stress_stiffening",
]


def _omega_q_coefficients(Q: np.ndarray) -> np.ndarray:
    """A quadratic form ``Σ_ab Q[..., a, b] ω_a ω_b`` as coefficients of ω_q: (..., 6)."""
    cols = [Q[..., a, a] if a == b else Q[..., a, b] + Q[..., b, a] for a, b in OMEGA_PRODUCTS]
    return np.stack(cols, axis=-1)


# ------------------------------------------------------------------------ DOF map
@dataclass(frozen=True)
class _Dofs:
    """Node table and, per node and direction, the DOF index (−1: no such DOF)."""

    n: int
    ids: np.ndarray            # (nn,)
    xyz: np.ndarray            # (nn, 3)
    trans: np.ndarray          # (nn, 3) int
    rot: np.ndarray            # (nn, 3) int
    where: dict = field(default_factory=dict)

    @classmethod
    def of(cls, fe) -> _Dofs:
        nodes = np.asarray(fe.nodes, dtype=np.float64)
        ids = nodes[:, 0].astype(np.int64)
        order = np.argsort(ids)
        dof_node = np.asarray(fe.dof_node).astype(np.int64)
        kinds = np.asarray(fe.dof_kind).astype(str)
        n = dof_node.size
        pos = np.searchsorted(ids[order], dof_node)
        pos = np.clip(pos, 0, ids.size - 1)
        if np.any(ids[order][pos] != dof_node):
            bad = dof_node[ids[order][pos] != dof_node][0]
            raise DataError(f"DOF on unknown node {bad}", fe.source, "dof_node")
        node_of = order[pos]
        trans = np.full((ids.size, 3), -1, dtype=np.int64)
        rot = np.full((ids.size, 3), -1, dtype=np.int64)
        for a, (tk, rk) in enumerate((("ux", "rx"), ("uy", "ry"), ("uz", "rz"))):
            sel = np.nonzero(kinds == tk)[0]
            trans[node_of[sel], a] = sel
            sel = np.nonzero(kinds == rk)[0]
            rot[node_of[sel], a] = sel
        return cls(n, ids, nodes[:, 1:4], trans, rot,
                   {int(i): k for k, i in enumerate(ids)})

    def gather(self, U: np.ndarray, which: str = "trans") -> np.ndarray:
        """(n, p) DOF vectors → (nn, p, 3) node triplets (0 where a DOF is missing)."""
        idx = self.trans if which == "trans" else self.rot
        ok = idx >= 0
        out = np.zeros((idx.shape[0], U.shape[1], 3))
        nodes, comps = np.nonzero(ok)
        out[nodes, :, comps] = U[idx[nodes, comps], :]
        return out

    def scatter(self, T: np.ndarray, which: str = "trans") -> np.ndarray:
        """(nn, p, 3) node triplets → (n, p) DOF vectors (missing DOFs dropped)."""
        idx = self.trans if which == "trans" else self.rot
        nodes, comps = np.nonzero(idx >= 0)
        out = np.zeros((self.n, T.shape[1]))
        out[idx[nodes, comps], :] = T[nodes, :, comps]
        return out

    def rigid_fields(self) -> tuple[np.ndarray, np.ndarray]:
        """``T_t`` and ``T_r`` (n, 3): rigid translation and rotation about the origin."""
        nn = self.ids.size
        eye = np.broadcast_to(np.eye(3), (nn, 3, 3))
        Tt = self.scatter(eye)
        # T_r[:, b] translational = e_b × x: (e_b × x)_a = ε_abk x_k
        tr = np.einsum("abk,ik->iba", LEVI_CIVITA, self.xyz)
        Tr = self.scatter(tr) + self.scatter(eye, "rot")
        return Tt, Tr


def _cross_pair(dofs: _Dofs, F: np.ndarray, MtF: np.ndarray, G: np.ndarray,
                MG: np.ndarray) -> np.ndarray:
    """``C[p, k, b] = ∫ f_p·(e_b × g_k) dm ≈ ½ [Fᵀ M P_b G − (P_b F)ᵀ M G]`` (p, k, 3)."""
    f, g = dofs.gather(F), dofs.gather(G)
    mtf, mg = dofs.gather(MtF), dofs.gather(MG)
    pair = (np.tensordot(mtf, g, axes=([0], [0])).transpose(0, 2, 1, 3)
            - np.tensordot(mg, f, axes=([0], [0])).transpose(2, 0, 1, 3))
    return 0.5 * np.einsum("abc,pkac->pkb", LEVI_CIVITA, pair)


def _cross_fields(dofs: _Dofs, G: np.ndarray) -> list[np.ndarray]:
    """``[P_0 G, P_1 G, P_2 G]``: ``e_b × g`` at the translational DOFs (each (n, k))."""
    g = dofs.gather(G)
    return [dofs.scatter(np.cross(np.eye(3)[b], g)) for b in range(3)]


def _cross_cross(dofs: _Dofs, F: np.ndarray, mpg: np.ndarray) -> np.ndarray:
    """``Q[i, k, a, b] = (P_a F_i)ᵀ M (P_b G_k)`` (nq, nq, 3, 3) from ``mpg`` = the node
    triplets of ``M P_b G`` (nn, nq, 3b, 3c): ``∫ (e_a × f_i)·(e_b × g_k) dm``."""
    f_t = dofs.gather(F)
    pf = np.stack([np.cross(np.eye(3)[a], f_t) for a in range(3)], axis=2)  # (nn,nq,3a,3c)
    nn, nf = f_t.shape[0], F.shape[1]
    ng = mpg.shape[1]
    Q = (pf.transpose(0, 3, 1, 2).reshape(3 * nn, 3 * nf).T
         @ mpg.transpose(0, 3, 1, 2).reshape(3 * nn, 3 * ng))
    return Q.reshape(nf, 3, ng, 3).transpose(0, 2, 1, 3)


def _as_operator(A, n: int, item: str):
    if A is None:
        return None
    if sps.issparse(A):
        A = sps.csr_matrix(A)
    else:
        A = np.asarray(A, dtype=np.float64)
    if A.shape != (n, n):
        raise DataError(f"shape {A.shape}, expected ({n}, {n})", item=item)
    return A


# ---------------------------------------------------------------------------- API
def inertia_loads(fe) -> dict[str, np.ndarray]:
    """The d'Alembert nodal loads of the 12 unit load cases of :data:`LOAD_CASES`.

    Frame acceleration ``e_a``: ``f = −M T_t e_a``; angular acceleration ``e_b``:
    ``f = −M T_r e_b``; centrifugal case ``ω_q[c] = 1``: ``f = −Σ_ab B_c,ab g_ab`` with
    ``g_ab = ½ [M P_a t_b + P_a (M t_b)]`` (``t_b = T_r e_b``; the symmetric cross-product
    form of the module docstring), so that the modal loads are exactly the order-0 terms of
    the elastic rows: ``Wᵀ f = −Ct⁰ e_a``, ``−Cr⁰ e_b``, ``−Oe⁰[:, c]``. Apply them to the body
    supported at its reference frame, compute the stress state and its geometric stiffness
    ``K_G,c``, and pass these to :func:`compute_invariants` (``geometric_stiffness``).

    Returns
    -------
    dict
        Case name → (n,) load vector.
    """
    dofs = _Dofs.of(fe)
    M = sps.csr_matrix(fe.M)
    Tt, Tr = dofs.rigid_fields()
    MTr = M @ Tr
    out = {}
    for a, name in enumerate(("ax", "ay", "az")):
        out[name] = -(M @ Tt[:, a])
    for b, name in enumerate(("alphax", "alphay", "alphaz")):
        out[name] = -MTr[:, b]
    P_t = _cross_fields(dofs, Tr)            # P_t[a][:, b] = P_a t_b
    P_mt = _cross_fields(dofs, MTr)          # P_mt[a][:, b] = P_a (M t_b)
    g = np.stack([0.5 * (M @ P_t[a] + P_mt[a]) for a in range(3)], axis=1)   # (n, 3a, 3b)
    coeff = _omega_q_coefficients(g)                                          # (n, 6)
    for c, name in enumerate(LOAD_CASES[6:]):
        out[name] = -coeff[:, c]
    return out


def inertia_responses(fe, support: Sequence[int],
                      cases: Sequence[str] = LOAD_CASES) -> dict[str, np.ndarray]:
    """The static displacements ``u_c`` of the unit inertia load cases (:func:`inertia_loads`)
    with the DOFs ``support`` fixed: ``K u_c = f_c`` on the others, ``u_c = 0`` on them.

    They span the second-order displacement field of a stiffened body
    (:func:`neweul_py.elastic.reductors.second_order.second_order_field`) and give its geometric
    stiffness (:func:`stress_stiffening`).

    Raises
    ------
    DataError
        Unknown cases or support DOFs, or a support that leaves ``K`` singular.
    """
    import scipy.sparse.linalg as spla

    n = fe.K.shape[0]
    bad = [c for c in cases if c not in LOAD_CASES]
    if bad:
        raise DataError(f"unknown load cases {bad}", fe.source, "cases")
    fixed = np.asarray(support, dtype=np.int64)
    if fixed.size and (fixed.min() < 0 or fixed.max() >= n):
        raise DataError(f"support DOFs outside 0…{n - 1}", fe.source, "support")
    free = np.setdiff1d(np.arange(n), fixed)
    Kf = sps.csc_matrix(fe.K)[free][:, free]
    try:
        lu = spla.splu(Kf)
    except RuntimeError as exc:
        raise DataError(f"K is singular on the unsupported DOFs ({exc})", fe.source,
                        "support") from None
    loads = inertia_loads(fe)
    out = {}
    for c in cases:
        u = np.zeros(n)
        u[free] = lu.solve(loads[c][free])
        if not np.all(np.isfinite(u)):
            raise DataError("K is singular on the unsupported DOFs", fe.source, "support")
        out[c] = u
    return out


def stress_stiffening(fe, geometric_stiffness_of, support: Sequence[int],
                      cases: Sequence[str] = LOAD_CASES) -> dict[str, object]:
    """The geometric stiffness of each unit load case, body supported at ``support``.

    Wallrapp's procedure: the d'Alembert loads of a unit frame acceleration, angular
    acceleration or ω-product (:func:`inertia_loads`) are applied to the body held at its
    reference frame (the DOFs ``support`` fixed), the static displacement ``u_c`` solves
    ``K u_c = f_c`` on the remaining DOFs (:func:`inertia_responses`), and
    ``geometric_stiffness_of(u_c)`` — the element formulation's stress stiffness of that
    state — is ``K_G,c``.

    Parameters
    ----------
    fe
        The FE model.
    geometric_stiffness_of
        Callable ``u (n,) → K_G`` (n×n, sparse or dense) of the element formulation.
    support
        DOF indices fixed in the static solutions (e.g. all DOFs of the node at the frame
        origin); must make ``K`` nonsingular on the others.
    cases
        Load cases to compute (default all of :data:`LOAD_CASES`).

    Returns
    -------
    dict
        Case → ``K_G,c``, ready for ``compute_invariants(…, geometric_stiffness=…)``.

    Raises
    ------
    DataError
        Unknown cases or support DOFs, or a support that leaves ``K`` singular.
    """
    return {c: geometric_stiffness_of(u)
            for c, u in inertia_responses(fe, support, cases).items()}


def compute_invariants(
    fe,
    V: np.ndarray,
    W: np.ndarray | None = None,
    *,
    nodes: Sequence[int] = (),
    node_orientations: Mapping[int, np.ndarray] | None = None,
    geometric_stiffness: Mapping[str, object] | None = None,
    ksigma: np.ndarray | None = None,
    names: Sequence[str] | None = None,
) -> Invariants:
    """The floating-frame invariants of §2 from an FE model and bases ``V``, ``W``.

    Parameters
    ----------
    fe
        The :class:`~neweul_py.elastic.fe_model.FEModel` (``M``, ``K``, ``D``, nodes, DOF map);
        the body reference frame is the FE coordinate system.
    V
        (n, nq) right basis: ``x = V q``.
    W
        (n, nq) left basis (test functions); ``None`` for one-sided data (``W = V``).
    nodes
        Ids of the nodes that get node frames (interfaces, outputs).
    node_orientations
        Node id → 3×3 orientation ``AP⁰`` of the node frame (default identity).
    geometric_stiffness
        Load case (:data:`LOAD_CASES`) → n×n geometric stiffness ``K_G,c`` of the stress
        state of a unit value of that case (see :func:`inertia_loads`); missing cases have
        none. Adds ``Wᵀ K_G,c V`` to the first-order parts of ``Ct``, ``Cr``, ``Oe``.
    ksigma
        (nq,) modal forces of reference stresses (default 0).
    names
        Names of the elastic coordinates (default ``q1 … qnq``).

    Returns
    -------
    Invariants

    Raises
    ------
    DataError
        Bases of the wrong shape or not finite, unknown node ids or load cases.

    References
    ----------
    ``docs/equations.md`` §2; Wallrapp 1994; Schwertassek & Wallrapp 1999, ch. 6.

    Examples
    --------
    >>> inv = compute_invariants(fe, V, nodes=[tip_id])           # doctest: +SKIP
    >>> inv.Me.m0, inv.node(tip_id).phi.m0                        # doctest: +SKIP
    """
    dofs = _Dofs.of(fe)
    n = dofs.n
    M = sps.csr_matrix(fe.M)
    Mt = sps.csr_matrix(M.T)
    V, W, two_sided = _checked_bases(V, W, n, fe.source)
    nq = V.shape[1]
    KG = _checked_stiffening(geometric_stiffness, n, fe.source)

    Tt, Tr = dofs.rigid_fields()
    MTt, MTr = M @ Tt, M @ Tr                 # fields multiplied by M
    MtTt, MtTr = Mt @ Tt, Mt @ Tr             # test fields: Xᵀ M = (Mᵀ X)ᵀ
    MV, MtV = M @ V, Mt @ V
    MtW = MtV if not two_sided else Mt @ W

    # --- mass, first moment, inertia (exact rigid fields)
    m, md0, J0 = _rigid_moments(dofs, Tt, Tr, MTt, MTr)
    md1 = MtTt.T @ V                          # ∫ Φ dm (3, nq), V

    # --- one-cross-product integrals
    Gr_c = _cross_pair(dofs, Tr, MtTr, V, MV)          # (3, nq, 3): ∫ t_a·(e_b × Φ_k)
    Gr = 2.0 * Gr_c                                    # Gr_k[a, b]
    J1 = 0.5 * (Gr + np.swapaxes(Gr, 0, 2))            # J¹_k = sym Gr_k, as (a, k, b)
    Cr_kin = _cross_pair(dofs, W, MtW, V, MV)          # (nq, nq, 3), W rows
    Crv1 = Cr_kin if not two_sided else _cross_pair(dofs, V, MtV, V, MV)
    Oe0_q = _cross_pair(dofs, W, MtW, Tr, MTr)         # [i, b, a] = ∫ w_i·(e_a × t_b)
    Oe0 = _omega_q_coefficients(np.swapaxes(Oe0_q, 1, 2))

    # --- two-cross-product integrals: Oe¹ = −(P_a W)ᵀ M (P_b V), C2 = (P_a V)ᵀ M (P_b V)
    mpv = np.stack([dofs.gather(M @ P) for P in _cross_fields(dofs, V)], axis=2)
    Q = _cross_cross(dofs, W, mpv)
    Oe1 = -_omega_q_coefficients(Q)                    # (nq, nq, 6)
    C2 = Q if not two_sided else _cross_cross(dofs, V, mpv)

    # --- geometric stiffening (elastic rows; Oe¹ in place)
    Ct1, Cr1, C2g = _stiffening_terms(KG, V, W, Cr_kin, Oe1)

    K = sps.csr_matrix(fe.K)
    Ke = W.T @ (K @ V)
    De = np.zeros((nq, nq)) if fe.D is None else W.T @ (sps.csr_matrix(fe.D) @ V)
    Le = None if getattr(fe, "G", None) is None else W.T @ (sps.csr_matrix(fe.G) @ V)
    ks = np.zeros((nq, 1)) if ksigma is None else np.asarray(ksigma, float).reshape(nq, 1)

    def T(m0, m1=None) -> Taylor:
        return Taylor.from_arrays(m0, m1, nq=nq)

    inv_nodes = _node_frames(dofs, V, W if two_sided else None, nodes,
                             node_orientations or {}, fe.source)
    return Invariants(
        m=m,
        md=T(md0[:, None], md1[:, :, None]),
        J=T(J0, J1),
        Ct=T(MtW.T @ Tt, Ct1),
        Cr=T(MtW.T @ Tr, Cr1),
        Crv=T(MtV.T @ Tr, Crv1),
        Me=T(MtW.T @ V),
        Gr=T(Gr.reshape(3, 3 * nq)),
        Ge=T(2.0 * Cr_kin.reshape(nq, 3 * nq)),
        Oe=T(Oe0, Oe1),
        ksigma=T(ks),
        Ke=T(Ke),
        De=T(De),
        nodes=inv_nodes,
        names=tuple(names) if names is not None else (),
        two_sided=two_sided,
        J2=0.5 * (C2 + C2.transpose(1, 0, 3, 2)) + C2g,
        Le=Le, loss_f_ref=None if Le is None else fe.loss_reference_frequency,
    )


def _checked_bases(V: np.ndarray, W: np.ndarray | None, n: int, source: str | None
                   ) -> tuple[np.ndarray, np.ndarray, bool]:
    """``V`` (n, nq) and ``W`` (``V`` for one-sided data), finite; and whether two-sided."""
    V = np.asarray(V, dtype=np.float64)
    if V.ndim != 2 or V.shape[0] != n:
        raise DataError(f"V has shape {V.shape}, expected ({n}, nq)", source, "V")
    two_sided = W is not None
    W = V if W is None else np.asarray(W, dtype=np.float64)
    if W.shape != V.shape:
        raise DataError(f"W has shape {W.shape}, V has {V.shape}", source, "W")
    for key, X in (("V", V), ("W", W)):
        if not np.all(np.isfinite(X)):
            raise DataError("not finite", source, key)
    return V, W, two_sided


def _checked_stiffening(geometric_stiffness: Mapping[str, object] | None, n: int,
                        source: str | None) -> dict[str, object]:
    """Load case → n×n operator ``K_G,c``; an unknown load case is a :class:`DataError`."""
    KG = {}
    for case, A in (geometric_stiffness or {}).items():
        if case not in LOAD_CASES:
            raise DataError(f"unknown load case {case!r} (one of {', '.join(LOAD_CASES)})",
                            source, "geometric_stiffness")
        KG[case] = _as_operator(A, n, f"geometric_stiffness.{case}")
    return KG


def _rigid_moments(dofs: _Dofs, Tt: np.ndarray, Tr: np.ndarray, MTt: np.ndarray,
                   MTr: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass ``m``, first moment ``md⁰`` and inertia ``J⁰`` from the exact rigid fields (the
    mean over the directions present in a planar model)."""
    m3 = Tt.T @ MTt
    present = dofs.trans.max(axis=0) >= 0
    m = float(np.mean(np.diag(m3)[present])) if present.any() else 0.0
    S = Tr.T @ MTt                            # S[b, a] = ε_abk md_k
    md0 = np.zeros(3)
    for k in range(3):
        vals = [LEVI_CIVITA[a, b, k] * S[b, a] for a in range(3) for b in range(3)
                if LEVI_CIVITA[a, b, k] != 0 and present[a]]
        md0[k] = np.mean(vals) if vals else 0.0
    J0 = Tr.T @ MTr
    J0 = 0.5 * (J0 + J0.T)
    return m, md0, J0


def _stiffening_terms(KG: Mapping[str, object], V: np.ndarray, W: np.ndarray,
                      Cr_kin: np.ndarray, Oe1: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Geometric stiffening of the elastic rows (module docstring): ``Ct¹``, ``Cr¹`` (the
    kinematic ``Cr_kin`` plus stiffening), ``Oe¹`` updated in place, and the same
    ω-stiffening as the centrifugal potential ``C2g`` of the inertia tensor."""
    nq = V.shape[1]
    Ct1 = np.zeros((nq, nq, 3))
    Cr1 = Cr_kin.copy()
    for a in range(3):
        if (A := KG.get(LOAD_CASES[a])) is not None:
            Ct1[:, :, a] += W.T @ (A @ V)
        if (A := KG.get(LOAD_CASES[3 + a])) is not None:
            Cr1[:, :, a] += W.T @ (A @ V)
    C2g = np.zeros((nq, nq, 3, 3))
    for c, (a, b) in enumerate(OMEGA_PRODUCTS):
        if (A := KG.get(LOAD_CASES[6 + c])) is not None:
            Oe1[:, :, c] += W.T @ (A @ V)
            # the same stiffening as a centrifugal potential −½ ωᵀ J_G(q) ω in the inertia
            # tensor (equations.md §2.1), so that the rotational rows carry its reaction
            kv = V.T @ (A @ V)
            kv = 0.5 * (kv + kv.T)
            if a == b:
                C2g[:, :, a, a] -= kv
            else:
                C2g[:, :, a, b] -= 0.5 * kv
                C2g[:, :, b, a] -= 0.5 * kv
    return Ct1, Cr1, C2g


def _node_frames(dofs: _Dofs, V: np.ndarray, W: np.ndarray | None, ids: Sequence[int],
                 orientations: Mapping[int, np.ndarray], source) -> tuple[NodeFrame, ...]:
    ids = [int(i) for i in ids]
    missing = [i for i in ids if i not in dofs.where]
    if missing:
        raise DataError(f"unknown node ids {missing}", source, "nodes")
    bad = [i for i in orientations if int(i) not in dofs.where]
    if bad:
        raise DataError(f"orientation for unknown node ids {bad}", source, "node_orientations")
    if not ids:
        return ()
    nq = V.shape[1]
    rows = np.array([dofs.where[i] for i in ids])
    sub = _Dofs(dofs.n, dofs.ids[rows], dofs.xyz[rows], dofs.trans[rows], dofs.rot[rows])
    phi = sub.gather(V).transpose(0, 2, 1)             # (nk, 3, nq)
    psi = sub.gather(V, "rot").transpose(0, 2, 1)
    phw = psw = None
    if W is not None:
        phw = sub.gather(W).transpose(0, 2, 1)
        psw = sub.gather(W, "rot").transpose(0, 2, 1)
    out = []
    for j, node_id in enumerate(ids):
        AP0 = np.asarray(orientations.get(node_id, np.eye(3)), dtype=np.float64)
        if AP0.shape != (3, 3):
            raise DataError(f"orientation of node {node_id} has shape {AP0.shape}",
                            source, "node_orientations")
        AP1 = np.einsum("kab,bc->akc", skew(psi[j].T), AP0)   # ψ̃_k AP⁰ as (3, nq, 3)
        out.append(NodeFrame(
            node_id,
            Taylor.from_arrays(sub.xyz[j][:, None], phi[j][:, :, None]),
            Taylor.from_arrays(phi[j], nq=nq), Taylor.from_arrays(psi[j], nq=nq),
            Taylor.from_arrays(AP0, AP1),
            None if phw is None else phw[j], None if psw is None else psw[j]))
    return tuple(out)


# ------------------------------------------------------------------ reduced bodies
def attach_invariants(body, fe, *, nodes: Sequence[int] | None = None, **kwargs):
    """The reduced body with its invariants slot filled from ``fe`` and its full bases.

    Parameters
    ----------
    body
        A :class:`~neweul_py.elastic.bodies.reduced.ReducedBody` holding the full bases
        (``store_bases=True`` in the reductor).
    fe
        The FE model it was reduced from.
    nodes
        Node-frame ids (default: the body's kept nodes).
    **kwargs
        Passed to :func:`compute_invariants` (``geometric_stiffness``, ``ksigma``, …).

    Returns
    -------
    ReducedBody
        ``body.with_(invariants=inv.to_flat())``; read back with :func:`body_invariants`.

    Raises
    ------
    DataError
        The body has no full bases, or they do not fit the FE model.
    """
    if body.V is None or (body.two_sided and body.W is None):
        raise DataError("the reduced body holds no full bases (reduce with store_bases=True)",
                        item="V")
    ids = [int(i) for i in np.asarray(body.nodes)[:, 0]] if nodes is None else nodes
    inv = compute_invariants(fe, body.V, body.W if body.two_sided else None, nodes=ids,
                             **kwargs)
    flat = inv.to_flat()
    # Me, Ke, De are the body's projected M, K, D (same bases): keep the projection's bits, so
    # that the file stores them once (reduced_body.SHARED_INVARIANTS)
    for key, own in (("Me.m0", body.M), ("Ke.m0", body.K), ("De.m0", body.D),
                     ("Le.m0", body.G)):
        if own is not None and key in flat and own.shape == flat[key].shape and np.allclose(
                own, flat[key], rtol=1e-9, atol=1e-12 * max(float(np.abs(own).max()), 1e-300)):
            flat[key] = np.array(own, dtype=np.float64)
    return body.with_(invariants=flat)
