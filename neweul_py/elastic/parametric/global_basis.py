"""Parametric reduction with one global basis for all samples (``reference/equations.md`` §4).

Local bases of neighbouring samples (e.g. the middle-ear working points 1 kPa apart) span
different subspaces (``σ_{r+1}/σ_1 ≈ 0.7`` of their stacked bases), so bringing local
reduced models to common coordinates (Panzer et al. 2010,
:func:`~neweul_py.elastic.parametric.local_interpolation.interpolate`) leaves a large part of each
sample
outside the common subspace, and the interpolated model loses to the nearest sample. Here
instead one basis serves every sample (Baur, Beattie, Benner & Gugercin 2011, *SIAM J. Sci.
Comput.* 33, "Interpolatory projection methods for parameterized model reduction", §3
"global basis"; Benner, Gugercin & Willcox 2015, *SIAM Rev.* 57, §4.1)::

    X_i = Vᵀ X(p_i) V  (X = M, D, K),   B_i = Vᵀ B(p_i),   C_i = C(p_i) V

from the *full* FE matrices of every sample. Entrywise interpolation
``X(p) = Σ w_i(p) X_i = Vᵀ (Σ w_i(p) X(p_i)) V`` is then the projection of the interpolated
FE matrices: consistent by construction (no coordinate alignment), and its error between
samples is that of interpolating the FE matrices themselves plus the projection error.

Which basis. The columns of every local right basis ``V_i`` and left basis ``W_i`` are split
into their structural rows ``[u; 0]`` and their pressure rows ``[0; p]``, and ``V`` is
block-diagonal: ``V = blockdiag(V_u, V_p)``, Galerkin (``W = V``). Two reasons:

* the left vectors of the u–p pencil are ``[ρλu; p]`` for right vectors ``[u; p]``
  (§3), so ``span{V_i, W_i} = span{[u; 0], [0; p]}`` for the modes: the split space is what
  right and left bases span together, and a Galerkin projection onto it contains every
  local right *and* left eigenvector (exact eigenvalues at the samples for any test space
  containing them);
* a block-diagonal Galerkin projection keeps the u–p structure of Eq. (2):
  ``M_r = [V_uᵀMsV_u 0; ρ(V_uᵀCV_p)ᵀ V_pᵀMfV_p]``, ``K_r = [V_uᵀKsV_u −V_uᵀCV_p; 0 V_pᵀKfV_p]``.
  With ``ψ = ∫p dt`` the u–p equations are gyroscopic with the energy
  ``½u̇ᵀMsu̇ + ½uᵀKsu + (ψ̇ᵀMfψ̇ + ψᵀKfψ)/(2ρ)``, non-increasing for positive semi-definite
  ``Ds``, ``Df``; the reduced model keeps that form, so it is stable for every sample and
  every interpolated parameter value (a Petrov–Galerkin pair of independently truncated
  global ``V``, ``W`` was not: max Re s = 4e4 on the string–cavity test model).

Each block is POD-compressed in the energy metric of its physics, derived, not tuned::

    ‖u‖² = uᵀ K̄s u   (twice the strain energy),   ‖p‖² = pᵀ M̄f p / ρ   (twice the
    acoustic potential energy ∫ p²/(2ρc²) dV, Mf = ∫ N Nᵀ/c² dV)

with ``K̄s``, ``M̄f`` the means over the samples; both are Joules, so the result does not
depend on units, and the directions of both blocks are ordered together by POD energy.
Purely structural models use ``K̄`` (the mass ``M̄`` for a free structure), purely acoustic
ones ``M̄``. The columns are scaled to unit energy first; directions whose POD energy lies
below ``rank_rtol`` (default 1e-12: numerical rank) are dropped, or the ``order`` most
energetic are kept.

Sample slopes (equations.md §4.2). With FE models next to every sample, ``σ_i ± δ``, the
parametric body also carries ``X_i′ = (Vᵀ X(σ_i + δ) V − Vᵀ X(σ_i − δ) V)/(2δ)`` (the same
``V``, so the slope of the projection is the projection of the FE slope, O(δ²)), and
``hermite`` weights interpolate values and slopes (:func:`global_slopes`); their second
differences, with the samples themselves, give the curvatures of ``quintic-hermite`` weights.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Mapping, Sequence

import numpy as np
import scipy.sparse as sps

from ...errors import DataError
from ..bodies.parametric import ParametricBody, checked_slope_step
from ..bodies.reduced import ReducedBody
from ..bodies.static import STATIC_KEYS, STATIC_PREFIX, StaticDeflection
from ..fe_model import FEModel
from ..reductors.invariants import attach_invariants
from ..reductors.projection import Progress, build_reduced_body
from ..reductors.static_state import static_deflection
from .samples import (
    bodies_stack,
    central_curvatures,
    central_slopes,
    check_samples,
    hermite_kind,
    model_sources,
    sample_values,
    stacked_loss,
)

__all__ = [
    "GLOBAL_RANK_RTOL",
    "energy_metric",
    "g_orthonormal",
    "global_bases",
    "global_parametric_body",
    "global_sample_bodies",
    "global_static",
]

#: Relative POD energy (eigenvalue of the Gram matrix of unit-energy columns, i.e. a
#: singular value of 1e-6) below which a direction of the stacked local bases is numerically
#: absent (a rank decision, not a tuning knob).
GLOBAL_RANK_RTOL = 1e-12


def _say(progress: Progress, msg: str) -> None:
    if progress is not None:
        progress(msg)


#: Columns per chunk of the two-stage POD of :func:`g_orthonormal`.
POD_CHUNK = 400
#: Relative eigenvalue (of the chunk's largest) below which a chunk's direction is round-off
#: of the Gram matrix and is dropped before the global POD.
CHUNK_RTOL = 1e-14


def energy_metric(fes: Sequence[FEModel]) -> sps.csr_matrix:
    """``G = blockdiag(K̄s, M̄f/ρ)`` on the u and p DOFs (module docstring), sparse SPD."""
    K = M = first = None
    for fe in fes:                      # one pass: a lazy sequence reads each model once
        K, M = (fe.K, fe.M) if K is None else (K + fe.K, M + fe.M)
        first = fe if first is None else first
    K, M = K / len(fes), M / len(fes)
    kinds = first.dof_kind
    is_p = kinds == "p"
    if is_p.all():
        return sps.csr_matrix(M)
    u = sps.diags((~is_p).astype(float))
    p = sps.diags(is_p.astype(float))
    Ks = u @ K @ u
    Ks = 0.5 * (Ks + Ks.T)
    if not is_p.any():
        G = Ks
        # a free structure: K singular (rigid motion) → the kinetic-energy norm instead
        if np.any(Ks.diagonal() <= 0):
            G = 0.5 * (M + M.T)
        return sps.csr_matrix(G)
    rho = first.density
    if not rho or rho <= 0:
        raise DataError("the u–p energy metric needs the fluid density", first.source,
                        "density")
    Mf = p @ M @ p
    return sps.csr_matrix(Ks + 0.5 * (Mf + Mf.T) / rho)


def g_orthonormal(X: np.ndarray, G: sps.spmatrix, rtol: float,
                  rows: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """G-orthonormal basis of span X by the eigen-decomposition of ``XᵀGX`` (POD).

    The columns are scaled to unit energy first (the cut is a rank decision), then the
    directions with ``λ > rtol·λ_max`` of the Gram matrix ``XᵀGX = Z Λ Zᵀ`` are kept as
    ``X Z Λ^{-1/2}``. Only the rows where ``X`` is nonzero take part (``G`` is block-diagonal
    in the callers' u/p blocks; ``rows``: the rows of ``X`` that take part, the others
    counting as zero — a block of ``X`` without a copy of the whole). With fewer such rows
    than columns the same ``Λ`` and ``Z``
    come from the SVD of ``Lᵀ X`` (``G_rr = L Lᵀ`` from the eigen-decomposition of the
    dense row block), which costs ``O(rows²·cols)`` instead of ``O(cols³)``; with more rows
    than columns, many columns are first compressed chunk by chunk
    (:func:`_chunk_directions`).

    Returns
    -------
    Q, lam
        The basis (n, k) and the eigenvalues ``λ`` in decreasing order (the first ``k``
        belong to ``Q``'s columns).
    """
    rows = np.arange(X.shape[0]) if rows is None else np.asarray(rows)
    nonzero = np.zeros(rows.size, dtype=bool)
    for start in range(0, X.shape[1], POD_CHUNK):          # column chunks: no full copy
        nonzero |= np.any(X[rows, start:start + POD_CHUNK] != 0, axis=1)
    rows = rows[nonzero]
    Xr = X[rows]
    Gr = sps.csr_matrix(G)[rows][:, rows]
    norms = np.empty(Xr.shape[1])
    for start in range(0, Xr.shape[1], POD_CHUNK):
        Xc = Xr[:, start:start + POD_CHUNK]
        norms[start:start + POD_CHUNK] = np.einsum("ij,ij->j", Xc, Gr @ Xc)
    norms = np.sqrt(np.maximum(norms, 0.0))
    ok = norms > 0
    if not ok.any():
        return np.zeros((X.shape[0], 0)), np.zeros(0)
    if not ok.all():
        Xr = Xr[:, ok]
    Xr /= norms[ok]                 # a copy of the rows already: scaled in place
    if rows.size < Xr.shape[1]:
        g, Qg = np.linalg.eigh(Gr.toarray())
        Y = (Qg * np.sqrt(np.maximum(g, 0.0))).T @ Xr
        _, s, Zt = np.linalg.svd(Y, full_matrices=False)
        lam, U = s**2, Zt.T
    else:
        if Xr.shape[1] > 2 * POD_CHUNK:
            Xr = _chunk_directions(Xr, Gr)
        gram = Xr.T @ (Gr @ Xr)
        lam, U = np.linalg.eigh(0.5 * (gram + gram.T))
        order = np.argsort(lam)[::-1]
        lam, U = lam[order], U[:, order]
    keep = lam > rtol * lam[0]
    Q = np.zeros((X.shape[0], int(keep.sum())))
    Q[rows] = Xr @ (U[:, keep] / np.sqrt(lam[keep]))
    return Q, lam


def _chunk_directions(X: np.ndarray, G: sps.spmatrix) -> np.ndarray:
    """The POD directions of every :data:`POD_CHUNK` columns of ``X``, scaled by their
    energy: ``X_c U_c`` with ``X_cᵀ G X_c = U_c Λ_c U_cᵀ``, dropping ``λ ≤`` :data:`CHUNK_RTOL`
    ``· max λ_c``. The result has the correlation ``Σ x xᵀ`` of ``X`` up to what is
    dropped, hence the same POD (two-stage method of snapshots), from smaller Gram matrices.
    """
    parts = []
    for start in range(0, X.shape[1], POD_CHUNK):
        Xc = X[:, start:start + POD_CHUNK]
        gram = Xc.T @ (G @ Xc)
        lam, U = np.linalg.eigh(0.5 * (gram + gram.T))
        parts.append(Xc @ U[:, lam > CHUNK_RTOL * lam.max()])
    return np.hstack(parts)


def global_bases(fes: Sequence[FEModel], bodies: Sequence[ReducedBody],
                 rank_rtol: float = GLOBAL_RANK_RTOL, order: int | None = None,
                 progress: Progress = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The global basis ``V`` (``W = V``) and the POD energies of its directions.

    Every local right and left basis vector is split into its structural rows and its
    pressure rows (module docstring); each block is POD-compressed in its energy metric
    (:func:`energy_metric`), and the directions of both blocks are ordered together by
    their POD energy (both are Joules per unit energy, so the order is meaningful).

    Parameters
    ----------
    fes, bodies
        The FE model of every sample and its local reduced body (with full bases,
        ``store_bases=True``).
    rank_rtol
        Relative POD energy of the numerically absent directions.
    order
        Keep at most this many directions (the most energetic); default all above
        ``rank_rtol``.

    Returns
    -------
    V, W, energy
        ``W = V`` (Galerkin) and the POD energy of each column.
    """
    G = energy_metric(fes)
    kinds = fes[0].dof_kind
    cols = [b.V for b in bodies] + [b.W for b in bodies if b.two_sided and b.W is not None]
    stacked = np.hstack(cols)
    blocks = [kinds == "p", kinds != "p"] if fes[0].kind == "up-coupled" else [
        np.ones(kinds.size, dtype=bool)]
    Vs, energies = [], []
    for rows in blocks:
        if not rows.any():
            continue
        Q, lam = g_orthonormal(stacked, G, rank_rtol, rows=np.flatnonzero(rows))
        Vs.append(Q)
        energies.append(lam[:Q.shape[1]])
    V, energy = np.hstack(Vs), np.concatenate(energies)
    idx = np.argsort(-energy, kind="stable")
    if order is not None:
        idx = idx[:int(order)]
    V, energy = V[:, idx], energy[idx]
    n_p = int(np.count_nonzero(np.any(V[kinds == "p"] != 0, axis=0)))
    _say(progress, f"global basis: {V.shape[1]} directions ({V.shape[1] - n_p} structural, "
                   f"{n_p} pressure) from {stacked.shape[1]} local vectors (energy metric, "
                   f"POD cut {rank_rtol:g})")
    return V, V, energy


def check_same_models(fes: Iterable[FEModel], what: str = "FE model") -> None:
    """One DOF map and one set of inputs/outputs for all ``fes``; otherwise a
    :class:`DataError` naming the first model that differs."""
    it = iter(fes)
    ref = next(it, None)
    for i, fe in enumerate(it, start=2):
        if (fe.n_dofs != ref.n_dofs or not np.array_equal(fe.dof_node, ref.dof_node)
                or not np.array_equal(fe.dof_kind, ref.dof_kind)):
            raise DataError(f"{what} {i} ({fe.source or fe.name}) has another DOF map than "
                            f"{what} 1 ({ref.source or ref.name}): the samples must share "
                            "one discretization",
                            fe.source, "dof_node")
        if fe.input_names != ref.input_names or fe.output_names != ref.output_names:
            raise DataError(f"{what} {i} ({fe.source}) has other inputs/outputs than "
                            f"{what} 1", fe.source, "inputs")


def global_sample_bodies(fes: Sequence[FEModel], bodies: Sequence[ReducedBody],
                         rank_rtol: float = GLOBAL_RANK_RTOL, order: int | None = None,
                         progress: Progress = None) -> tuple[list[ReducedBody], np.ndarray]:
    """Every sample's full FE model projected onto the same global ``(V, W)``.

    The kept nodes and the invariants follow the local bodies: a sample whose local body
    carries invariants gets them recomputed from its FE model and the global bases
    (:func:`~neweul_py.elastic.reductors.invariants.attach_invariants`), so every floating-frame
    quantity of every sample refers to the same coordinates.

    Returns
    -------
    bodies, energy
        The sample bodies in global coordinates (``method = "global"``, full bases stored)
        and the POD energies of the right basis.
    """
    if len(fes) != len(bodies):
        raise DataError(f"{len(fes)} FE models for {len(bodies)} bodies", None, "models")
    check_same_models(fes)
    for i, (fe, b) in enumerate(zip(fes, bodies, strict=True)):
        if b.V is None or (b.two_sided and b.W is None):
            raise DataError(f"body {i + 1} holds no full bases (reduce with --store-bases)",
                            None, "V")
        if b.V.shape[0] != fe.n_dofs:
            raise DataError(f"body {i + 1} has bases of {b.V.shape[0]} rows, its FE model "
                            f"{fe.source} {fe.n_dofs} DOFs", fe.source, "n_dofs")
    V, W, energy = global_bases(fes, bodies, rank_rtol, order, progress)
    out = []
    for i, (fe, b) in enumerate(zip(fes, bodies, strict=True)):
        settings = {"global": True, "order": int(V.shape[1]), "rank_rtol": rank_rtol,
                    "local_settings": dict(b.settings), "two_sided": False}
        g = build_reduced_body(fe, V, W, "global", settings,
                               keep_nodes=b.nodes[:, 0].astype(np.int64), store_bases=True)
        g = g.with_(parameters=dict(b.parameters)) if b.parameters else g
        if b.invariants is not None:
            _say(progress, f"sample {i + 1}: invariants in the global coordinates")
            g = attach_invariants(g, fe)
        if b.static is not None:
            g = g.with_(static=global_static(b, g, energy_metric(fes)))
        out.append(g)
    if 0 < sum(b.static is not None for b in bodies) < len(bodies):
        raise DataError("some sample bodies carry a static state and some do not", None,
                        "static")
    return out, energy


def global_static(local: ReducedBody, body: ReducedBody, G: sps.spmatrix) -> StaticDeflection:
    """The local body's static state in the global coordinates of ``body``: ``q`` the
    Ḡ-projection of the local state ``V_l q_l`` on the global basis; node displacements,
    interface forces and outputs unchanged (physical); residual ``r_l + r_g`` — the local one
    plus that of the second projection, a bound on ``‖x_s − V q‖_Ḡ/‖x_s‖_Ḡ`` (``x_s`` itself
    is not in the local body file)."""
    st = local.static
    x = local.V @ st.q
    g = static_deflection(body, x, metric=G)
    return StaticDeflection(q=g.q, node_u=st.node_u, node_force=st.node_force,
                            outputs=st.outputs, residual=st.residual + g.residual)


def global_slopes(fes: Sequence[FEModel], minus: Sequence[FEModel], plus: Sequence[FEModel],
                  step: float, gb: Sequence[ReducedBody],
                  statics: tuple[Sequence[Mapping], Sequence[Mapping]] | None = None,
                  progress: Progress = None, *, curvatures: bool = False,
                  sample_statics: Sequence[Mapping] | None = None
                  ) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray] | None]:
    """The sample slopes (and curvatures) of the global sample bodies ``gb`` of the FE
    models ``fes`` (module docstring): the FE models ``minus`` at ``σ_i − δ`` and ``plus`` at
    ``σ_i + δ``, ``step`` = ``δ``, projected on the
    global basis of ``gb`` like the samples (same kept nodes, invariants when the samples
    carry them), central differences of every stack :meth:`ParametricBody.slope_keys` names
    (the bases themselves are constant: zero slopes); with ``curvatures``, also the central
    second differences ``(X(σ_i+δ) − 2X(σ_i) + X(σ_i−δ))/δ²`` (equations.md §4.2). Samples
    with static states need ``statics`` = the
    :func:`~neweul_py.elastic.reductors.static_state.static_deflection` keywords
    (``x``, ``node_force``, ``outputs``) of every slope model, ``(minus, plus)``: their
    states are projected on the global basis in the energy metric of the samples, and the
    slopes of ``q``, the node displacements and forces and the outputs are their central
    differences (of the projection of the FE static state; residual slope zero). Their
    curvatures need the samples' own FE static states (``sample_statics``, the same
    keywords) projected alike: a second difference of states defined in two ways (the
    samples' ``q`` is the projection of the local body's state) would be a difference of
    the definitions over ``δ²``.

    Returns
    -------
    slopes, curvatures
        ``key → (k, …)``; ``curvatures`` is ``None`` unless asked for.

    Raises
    ------
    DataError
        Models, step or static states that do not fit the samples
        (``docs/reduced-body-format.md``, "Checks of a parametric body").
    """
    k = len(gb)
    if len(minus) != k or len(plus) != k:
        raise DataError(f"the slopes need one FE model on each side of each of the {k} "
                        f"samples, got {len(minus)} and {len(plus)}", None, "slopes")
    checked_slope_step(step)                      # the step, before any projection
    if (gb[0].static is not None) != (statics is not None):
        raise DataError("the samples carry static states: their slopes need the static "
                        "states of the slope models (slope_statics; an FE model does not "
                        "carry its own)" if statics is None else "static states of the slope "
                        "models given for samples without static states", None, "static")
    if statics is not None and any(len(st) != k for st in statics):
        raise DataError(f"one static state per slope model ({k} on each side), got "
                        f"{[len(st) for st in statics]}", None, "static")
    centre_statics = sample_statics if curvatures and statics is not None else None
    if curvatures and statics is not None and (sample_statics is None
                                               or len(sample_statics) != k):
        raise DataError("the curvatures of the samples' static states need the samples' own "
                        f"FE static states (sample_statics, {k}), projected like those of "
                        "the slope models", None, "static")
    V, W = gb[0].V, gb[0].W
    check_same_models(itertools.chain(fes, minus, plus),
                      "FE model (samples, then slope models)")
    G = energy_metric(fes) if statics is not None else None

    def projected(fe: FEModel, i: int, state: Mapping | None) -> ReducedBody:
        b = build_reduced_body(fe, V, W, "global", {"global": True},
                               keep_nodes=gb[i].nodes[:, 0].astype(np.int64),
                               store_bases=True)
        if gb[i].invariants is not None:
            b = attach_invariants(b, fe)
        if state is not None:
            b = b.with_(static=static_deflection(b, output_rows=fe.C(), metric=G, **state))
        return b

    side: list[list[ReducedBody]] = [[], []]
    for j, models in enumerate((minus, plus)):
        side[j] = [projected(fe, i, None if statics is None else statics[j][i])
                   for i, fe in enumerate(models)]
        _say(progress, f"slopes: {'minus' if j == 0 else 'plus'} side projected ({k} models)")
    keys = ["M", "D", "K", "B", "C", "V_kept", "W_kept", *(["G"] if gb[0].G is not None
                                                            else [])]
    keys += ["invariants/" + name for name, a in (gb[0].invariants or {}).items()
             if np.asarray(a).dtype.kind == "f"]
    keys += [STATIC_PREFIX + key for key in STATIC_KEYS] if statics is not None else []
    slopes = central_slopes(lambda key: bodies_stack(side[0], key),
                            lambda key: bodies_stack(side[1], key), step, keys)
    if not curvatures:
        return slopes, None
    centre = list(gb) if centre_statics is None else [
        gb[i].with_(static=projected(fe, i, centre_statics[i]).static)
        for i, fe in enumerate(fes)]
    return slopes, central_curvatures(lambda key: bodies_stack(side[0], key),
                                      lambda key: bodies_stack(centre, key),
                                      lambda key: bodies_stack(side[1], key), step, keys)


def global_parametric_body(fes: Sequence[FEModel], bodies: Sequence[ReducedBody],
                           samples: Sequence[float] | None = None, *, parameter: str = "p",
                           interpolation: str | None = None,
                           rank_rtol: float = GLOBAL_RANK_RTOL,
                           order: int | None = None, store_bases: bool = False,
                           labels: Sequence[str] | None = None,
                           slope_models: tuple[Sequence[FEModel], Sequence[FEModel]] | None
                           = None, slope_step: float | None = None,
                           slope_statics: tuple[Sequence[Mapping], Sequence[Mapping]] | None
                           = None, sample_statics: Sequence[Mapping] | None = None,
                           progress: Progress = None) -> ParametricBody:
    """The parametric body of the global basis (module docstring).

    The samples' bodies of :func:`global_sample_bodies` share their coordinates, so the
    common-coordinate transformations are the identity (``T_i = L_i = I``, ``R = V``); the
    result is a :class:`~neweul_py.elastic.bodies.parametric.ParametricBody` like that of the
    local method (``basis = "full"``, ``row_scaling = "none"``, ``sample_methods`` =
    ``"global"``), interpolated entrywise by :meth:`ParametricBody.at`. The samples are
    checked as :func:`~neweul_py.elastic.parametric.local_interpolation.interpolate` checks them
    (same
    layout, increasing values, ``labels`` naming the bodies in errors).

    ``interpolation`` (the default weights of :meth:`ParametricBody.at`) is by default
    ``"cubic"``, and ``"quintic-hermite"`` with slope models:
    the FE matrices of the middle ear depend on the static pressure nonlinearly (stress
    stiffening); between samples 1 kPa apart cubic weights in Δp give at worst 4.1 % median /
    35 % max FRF error against 15.6 % / 122 % for linear weights, and cubic weights in the
    static volume displacement (``ParametricBody.with_(coordinate=…)``, equations.md §4.1)
    0.56 % / 5.9 % (``benchmarks/bench_interpolation.py``, refine 1).

    ``slope_models = (minus, plus)`` with ``slope_step = δ``: the FE models at ``σ_i ∓ δ``
    give the sample slopes (:func:`global_slopes`; ``slope_statics`` their static states
    when the samples carry one), and the same models also give the sample curvatures
    (``sample_statics``: the samples' own FE static states, when they carry one) for the
    default ``"quintic-hermite"`` weights (equations.md §4.2); ``interpolation="hermite"``
    keeps the slopes alone, and weights without derivatives are refused with slope models
    (a DataError naming ``interpolation``). Figures on today's physics:
    ``benchmarks/bench_interpolation.py``, whose README table quotes them.
    """
    bodies = list(bodies)
    if len(bodies) < 2:
        raise DataError(f"need at least 2 sample bodies, got {len(bodies)}", None, "bodies")
    check_samples(bodies, labels)
    s = sample_values(bodies, samples, str(parameter))
    gb, energy = global_sample_bodies(fes, bodies, rank_rtol, order, progress)
    k, r = len(gb), gb[0].order
    eye = np.broadcast_to(np.eye(r), (k, r, r)).copy()
    inv = None
    if gb[0].invariants is not None:
        inv = {name: np.stack([np.asarray(b.invariants[name]) for b in gb])
               for name in gb[0].invariants}
    g0 = gb[0]
    slopes = curvatures = None
    interpolation = hermite_kind(interpolation, slope_models is not None)
    if slope_models is not None:
        slopes, curvatures = global_slopes(
            fes, *slope_models, slope_step, gb, slope_statics, progress,
            curvatures=interpolation == "quintic-hermite", sample_statics=sample_statics)
        for data in (slopes, curvatures) if store_bases else ():
            if data is not None:
                data.update(V=np.zeros((k, *g0.V.shape)), W=np.zeros((k, *g0.W.shape)))
    return ParametricBody(
        parameter=str(parameter), samples=s,
        **stacked_loss(gb),
        **{key: np.stack([b[key] for b in gb]) for key in ("M", "D", "K", "B", "C",
                                                            "V_kept", "W_kept")},
        T=eye, L=eye.copy(), R=g0.V, singular_values=np.sqrt(np.maximum(energy, 0.0)),
        svd_weights=np.ones(k), basis="full", two_sided=False,
        input_names=g0.input_names, output_names=g0.output_names, nodes=g0.nodes,
        kept_dofs=g0.kept_dofs, dof_node=g0.dof_node, dof_kind=g0.dof_kind,
        V=np.stack([b.V for b in gb]) if store_bases else None,
        W=np.stack([b.W for b in gb]) if store_bases else None,
        full_dof_kind=fes[0].dof_kind, invariants=inv, interpolation=interpolation,
        static=(StaticDeflection.stack([b.static for b in gb]) if gb[0].static is not None
                else None),
        sample_sources=tuple(b.source for b in gb),
        sample_methods=tuple(b.method for b in gb),
        sample_settings=tuple(b.settings for b in gb), slopes=slopes,
        curvatures=curvatures,
        slope_step=None if slopes is None else float(slope_step),
        slope_sources=() if slopes is None else model_sources(
            itertools.chain(*slope_models)),
    )
