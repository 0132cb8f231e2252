"""Clamped-interface (Craig–Bampton) reduction, one- and two-sided.

With the DOFs split into interface ``b`` (all DOFs of the interface nodes) and interior ``i``,
the right basis is (Craig & Bampton, AIAA J. 6 (1968) 1313–1319; Craig & Kurdila,
*Fundamentals of Structural Dynamics*, 2006, §19.3)

    V = [ I          0  ]        static constraint modes  Ψ_i = −K_ii⁻¹ K_ib,
        [ Ψ_i      Φ_i  ]        fixed-interface modes    K_ii Φ_i = M_ii Φ_i Λ,

and for unsymmetric (u–p coupled) models the left basis is its transposed counterpart: left
constraint modes ``−K_ii⁻ᵀ K_biᵀ`` and the left fixed-interface eigenvectors
(``Wᵢᵀ M_ii Φ_i = I``), the two-sided form of the modal reduction of
:mod:`~neweul_py.elastic.reductors.modal` (symmetric models: ``W = V``). The full matrices are
projected (:func:`~neweul_py.elastic.reductors.projection.build_reduced_body`), so the interface
mass
stays in the reduced mass matrix and in the floating-frame invariants — nothing is cut away.

Floating frame of reference (``skip_rigid``): when the interface holds the body statically
determinate or more (e.g. all DOFs of a root face), the constraint modes contain the rigid-body
motions, which the body's reference frame already carries. ``skip_rigid=True`` keeps only the
constraint-mode combinations whose interface motion is orthogonal to the rigid-body motions
of the interface (``Ψ N`` with ``N`` an orthonormal basis of ``range(T_b)^⊥``, ``T_b`` the
interface rows of the rigid fields); for a single clamped node (or face) this leaves the
fixed-interface (clamped) modes only — the classical clamped FFRF body with the reference
frame at the clamp.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.sparse as sps
import scipy.sparse.linalg as spla

from ...errors import DataError
from ..bodies.reduced import ReducedBody
from ..fe_model import FEModel
from .eigen import PERMC_SPEC, symmetric_pencil
from .interface import rigid_body_fields
from .modal import modal_bases
from .projection import Progress, build_reduced_body

__all__ = ["craig_bampton_bases", "reduce_craig_bampton"]


def _say(progress: Progress, msg: str) -> None:
    if progress is not None:
        progress(msg)


def _interior_model(fe: FEModel, ii: np.ndarray) -> FEModel:
    """The FE model with the interface DOFs held (rows/columns ``ii`` only)."""
    kinds = fe.dof_kind[ii]
    is_p = kinds == "p"
    kind = fe.kind
    if fe.kind == "up-coupled" and (is_p.all() or not is_p.any()):
        kind = "acoustic" if is_p.all() else "structural"
    return FEModel(M=fe.M[ii][:, ii], K=fe.K[ii][:, ii], D=None, nodes=fe.nodes,
                   dof_node=fe.dof_node[ii], dof_kind=kinds, kind=kind,
                   density=fe.density if kind == "up-coupled" else None,
                   name=f"{fe.name} (interface held)", source=fe.source)


def _characteristic(fe: FEModel, bb: np.ndarray, ii: np.ndarray, N: np.ndarray,
                    psi_r: np.ndarray, psi_l: np.ndarray,
                    unsym: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mass-normalized *characteristic constraint modes* (Castanier, Tan & Pierre, AIAA J. 39
    (2001) 1182–1187): the constraint block diagonalized by the small eigenproblem
    ``(Ψᵀ K Ψ, Ψᵀ M Ψ)`` (unsymmetric models: columns scaled to unit ``ψ_lᵀ M ψ_r``). The
    self-equilibrated interface motions left by ``skip_rigid`` are local, with masses many
    orders below the modes'; without this the body mass matrix is needlessly ill conditioned.

    Returns ``(N, Ψ_r, Ψ_l)`` transformed alike (``N``: interface rows).
    """
    n = fe.n_dofs
    R = np.zeros((n, N.shape[1]))
    L = np.zeros_like(R)
    R[bb], R[ii] = N, psi_r
    L[bb], L[ii] = N, psi_l
    if R.shape[1] == 0:
        return N, psi_r, psi_l
    MR = fe.M @ R
    if not unsym:
        G = R.T @ MR
        Kc = R.T @ (fe.K @ R)
        Lc = np.linalg.cholesky(0.5 * (G + G.T))
        Kt = np.linalg.solve(Lc, np.linalg.solve(Lc, 0.5 * (Kc + Kc.T)).T)   # L⁻¹ Kc L⁻ᵀ
        _, Y = np.linalg.eigh(0.5 * (Kt + Kt.T))
        S = np.linalg.solve(Lc.T, Y)                  # Sᵀ G S = I, Sᵀ Kc S diagonal
        return N @ S, psi_r @ S, psi_l @ S
    d = np.sqrt(np.abs(np.einsum("ij,ij->j", L, MR)))
    d = np.where(d > 0, d, 1.0)
    return N / d, psi_r / d, psi_l / d


def _constraint_modes(fe: FEModel, bb: np.ndarray, ii: np.ndarray, two_sided: bool,
                      skip_rigid: bool, progress: Progress
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Right and left static constraint modes ``−K_ii⁻¹ K_ib``, ``−K_ii⁻ᵀ K_biᵀ`` and their
    interface rows (identity, or with ``skip_rigid`` the non-rigid interface motions as
    characteristic constraint modes): ``(Ψ_r, Ψ_l, interface rows)``."""
    _say(progress, f"constraint modes of {bb.size} interface DOFs")
    K = sps.csc_matrix(fe.K)
    try:
        lu = spla.splu(K[ii][:, ii].tocsc(), permc_spec=PERMC_SPEC)
    except RuntimeError as exc:
        raise DataError(f"K is singular on the interior DOFs ({exc})", fe.source,
                        "interface") from None
    kib = K[ii][:, bb].toarray()
    kbi = K[bb][:, ii].toarray()
    psi_r = -lu.solve(kib)
    unsym = two_sided and not symmetric_pencil(fe)
    psi_l = -lu.solve(kbi.T, trans="T") if unsym else psi_r
    eye = np.eye(bb.size)
    if skip_rigid:
        Tb = rigid_body_fields(fe)[bb]
        U, s, _ = np.linalg.svd(Tb, full_matrices=True)
        rank = int(np.count_nonzero(s > 1e-10 * max(s.max(initial=0.0), 1e-300)))
        eye = U[:, rank:]
        psi_r, psi_l = psi_r @ eye, psi_l @ eye
        eye, psi_r, psi_l = _characteristic(fe, bb, ii, eye, psi_r, psi_l, unsym)
    return psi_r, psi_l, eye


def craig_bampton_bases(
    fe: FEModel,
    interface: Sequence[int],
    modes: int,
    two_sided: bool = True,
    skip_rigid: bool = False,
    progress: Progress = None,
    constraint_modes: bool = True,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Right and left Craig–Bampton bases (module docstring).

    Parameters
    ----------
    fe
        The FE model (free, or with its own supports).
    interface
        Node ids of the interface (all their DOFs are interface DOFs).
    modes
        Number of fixed-interface modes (≥ 1).
    two_sided
        Left constraint modes and left eigenvectors for unsymmetric models (symmetric
        models: ``W = V`` either way); ``False``: ``W = V``.
    skip_rigid
        Drop the rigid-body content of the constraint modes (floating frame of reference);
        the self-equilibrated motions of the interface stay free.
    progress
        Called with short messages on long steps.
    constraint_modes
        ``False``: fixed-interface modes only — the interface is clamped (to the reference
        frame of a floating-frame body), as in the classical clamped FFRF body.

    Returns
    -------
    V, W, lam
        (n, nc + modes) bases (constraint modes first) and the fixed-interface eigenvalues.

    Raises
    ------
    DataError
        Naming ``fe.source`` and ``interface``: an empty or unknown interface, an interface
        that holds every DOF, or one that does not fix the body (the interior keeps
        zero-frequency modes: ``K_ii`` singular).
    """
    ids = np.unique(np.asarray(interface, dtype=np.int64))
    if ids.size == 0:
        raise DataError("the interface node set is empty", fe.source, "interface")
    if not (isinstance(modes, int | np.integer) and modes >= 1):
        raise DataError(f"needs at least one fixed-interface mode, got {modes!r}", fe.source,
                        "modes")
    try:
        bb = fe.dofs_of_nodes(ids)
    except DataError as exc:
        raise DataError(exc.message, fe.source, "interface") from None
    if bb.size == 0:
        raise DataError(f"the interface nodes {ids[:5].tolist()} have no DOFs", fe.source,
                        "interface")
    ii = np.setdiff1d(np.arange(fe.n_dofs), bb)
    if ii.size <= modes:
        raise DataError(f"the interface leaves {ii.size} interior DOFs, fewer than "
                        f"{modes} + 1", fe.source, "interface")
    interior = _interior_model(fe, ii)
    _say(progress, f"fixed-interface modes ({ii.size} interior DOFs, {bb.size} interface)")
    Vi, Wi, lam, _ = modal_bases(interior, modes=modes, two_sided=two_sided,
                                 progress=progress)
    # unit modal masses (modal_bases gives unit Euclidean columns): the constraint and
    # fixed-interface blocks then have comparable scales; Wᵢᵀ M_ii Vᵢ = I is kept
    d = np.sqrt(np.abs(np.einsum("ij,ij->j", Vi, interior.M @ Vi)))
    d = np.where(d > 0, d, 1.0)
    Vi, Wi = Vi / d, Wi * d
    zero = np.flatnonzero(np.real(lam) == 0)
    if zero.size:
        raise DataError(
            f"the interface ({ids.size} nodes) does not fix the body: with it held the model "
            f"still has {zero.size} zero-frequency (rigid-body or constant-pressure) "
            "mode(s), K is singular on the interior DOFs; Craig–Bampton needs an interface "
            "(or a supported model) that removes them", fe.source, "interface")
    if constraint_modes:
        psi_r, psi_l, eye = _constraint_modes(fe, bb, ii, two_sided, skip_rigid, progress)
    else:  # clamped interface: no static solves (the interior modes checked K_ii above)
        psi_r = psi_l = np.zeros((ii.size, 0))
        eye = np.zeros((bb.size, 0))
    n, nc = fe.n_dofs, eye.shape[1]
    V = np.zeros((n, nc + Vi.shape[1]))
    W = np.zeros_like(V)
    V[bb, :nc], W[bb, :nc] = eye, eye
    V[ii, :nc], W[ii, :nc] = psi_r, psi_l
    V[ii, nc:] = Vi
    W[ii, nc:] = Wi if two_sided else Vi
    return V, (W if two_sided else V), lam


def reduce_craig_bampton(
    fe: FEModel,
    interface: Sequence[int],
    modes: int,
    two_sided: bool = True,
    skip_rigid: bool = False,
    keep_nodes: Sequence[int] | None = None,
    store_bases: bool = False,
    progress: Progress = None,
    constraint_modes: bool = True,
) -> ReducedBody:
    """Craig–Bampton reduction: interface constraint modes + fixed-interface normal modes.

    Parameters
    ----------
    fe
        The FE model (never densified).
    interface
        Node ids of the interface.
    modes
        Number of fixed-interface modes.
    two_sided
        Petrov–Galerkin with the left (transposed) constraint modes and left eigenvectors.
    skip_rigid
        Leave the rigid-body motions of the interface out of the constraint modes (bodies in
        the floating frame of reference; see the module docstring).
    keep_nodes
        Node ids whose basis rows are stored (default: input/output and interface nodes).
    store_bases
        Also store the full ``V`` and ``W``.
    progress
        Called with messages on long steps.
    constraint_modes
        ``False``: fixed-interface (clamped) modes only.

    Returns
    -------
    ReducedBody
        ``method="craig-bampton"``, ``eigenvalues`` = the fixed-interface ``λ``; the
        coordinates are the interface DOF values (constraint modes) followed by the modal
        coordinates.

    References
    ----------
    Craig & Bampton (1968); Craig & Kurdila (2006) §19.3.

    Examples
    --------
    >>> body = reduce_craig_bampton(fe, interface=[1], modes=8)   # doctest: +SKIP
    """
    V, W, lam = craig_bampton_bases(fe, interface, modes, two_sided, skip_rigid, progress,
                                    constraint_modes)
    ids = np.unique(np.asarray(interface, dtype=np.int64))
    settings = {"modes": int(modes), "interface": ids.tolist(), "two_sided": two_sided,
                "skip_rigid": bool(skip_rigid), "constraint_modes": V.shape[1] - int(modes)}
    if not constraint_modes:
        settings["clamped_interface"] = True
    if keep_nodes is None:
        keep_nodes = np.union1d(fe.io_nodes(), ids)
    _say(progress, f"projecting onto {V.shape[1]} vectors")
    lam = lam.real if np.all(np.imag(lam) == 0) else lam
    return build_reduced_body(fe, V, W, "craig-bampton", settings, keep_nodes, store_bases,
                              lam)
