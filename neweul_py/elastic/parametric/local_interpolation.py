"""Local-basis interpolation in common coordinates (Panzer et al. 2010; ``docs/equations.md`` §4).

A parameter-dependent elastic body — in the seed paper the tympanic membrane, whose
linearization depends on the static pressure difference — is represented by local reduced
models at samples ``p_1 < … < p_k`` (Panzer, Mohring, Eid & Lohmann 2010). The local
coordinates differ from sample to sample (eigenvectors reorder, change sign, rotate within
clusters), so the local matrices cannot be interpolated directly. :func:`interpolate` first
brings every local model to common coordinates::

    R    = first r left singular vectors of [w_1 Q_1 … w_k Q_k]     (span Q_i = span S V_i)
    T_i  = Rᵀ S V_i,      L_i = (W_iᵀ S_W R)⁻¹    (Galerkin data: L_i = T_i⁻ᵀ)
    X̃_i  = L_i X_r,i T_i⁻¹  (X = M, D, K),   B̃_i = L_i B_r,i,   C̃_i = C_r,i T_i⁻¹

and :meth:`ParametricBody.at` interpolates ``X(p) = Σ_i w_i(p) X̃_i`` with weights summing
to one (piecewise linear between neighbouring samples, or cubic-spline cardinal functions).

Because ``T_i`` and ``L_i`` are invertible, each transformed local model is a state-space
equivalent of the original (``K̃ − λM̃ = L_i (K − λM) T_i⁻¹``): eigenvalues and transfer
function are unchanged, so the interpolated body reproduces every sample exactly.

Every quantity of the body is transformed by the same rule (§2, two-sided data, and §4
step 6): *displacement-like* quantities — ``C``, the basis rows ``V_kept`` (node ``Φ``,
``Ψ``), the full ``V`` — by ``T_i⁻¹`` from the right (``q_i = T_i⁻¹ q̃``); *elastic-equation
rows* — ``M``, ``D``, ``K``, ``B``, the left-basis rows ``W_kept`` (modal loads) and the full
``W`` as ``W̃ = W Lᵀ`` — by ``L_i`` from the left; the floating-frame invariants with
:meth:`~neweul_py.elastic.bodies.invariants.Invariants.transformed` (``right = T_i⁻¹``,
``left = L_i``).

Which rows enter the SVD (``basis``)
------------------------------------
``"full"`` uses the full bases ``V_i`` (bodies reduced with ``store_bases=True``), as in the
paper. ``"kept"`` uses only the rows the bodies always store, ``V_kept`` (the DOFs of the
kept nodes): then ``R`` spans a subspace of the kept DOFs and ``q̃ = Rᵀ S x_kept`` — usable when
the kept nodes carry at least ``r`` independent DOFs (e.g. ``keep_nodes`` = a set of
observation nodes), exact at the samples in any case, but the common coordinates are only
as consistent between samples as the kept rows resolve the shapes. ``"auto"`` (default)
takes ``"full"`` when every body holds its full bases and ``"kept"`` otherwise. Each ``S V_i``
is orthonormalized (``Q_i``) before stacking, so that every sample's subspace counts by its
SVD weight ``w_i`` only, not by the scaling of its basis columns.

Row scaling ``S`` (``row_scaling``)
-----------------------------------
The SVD measures the rows of the bases in one Euclidean metric, but the rows of a u–p model
mix units: displacements (m; ~1e-7 in the unit-norm mode shapes of the middle ear) and
pressures (Pa; ~1e-2). In the plain metric (``"none"``) the structural rows are numerically
invisible, the common coordinates are aligned by the pressure fields alone, and the result
depends on the unit of pressure. ``S`` is a positive diagonal scaling of the rows,
``x̂ = S x``, applied before the SVD. ``"kind"`` (default whenever the DOF kinds of the rows
are known):

1. one factor per *group* of DOF kinds — translations ``ux uy uz`` (one factor, so that
   displacement stays isotropic), rotations ``rx ry rz``, pressure ``p`` — *balanced*
   (:func:`kind_row_scale`): in the scaled, orthonormalized stacked bases the entries of
   every group have the same RMS (the self-consistent form of "divide each kind's rows by
   the RMS of its entries"; it does not depend on the units);
2. for u–p rows, the pressure factor times ``pressure_weight`` (default
   :data:`PRESSURE_WEIGHT` = 1e-3): *structure first* — the structural rows determine the
   common coordinates, pressure rows only the directions with (almost) no structural
   motion (acoustic modes). Measured between samples against the full or a directly
   reduced model (median relative FRF error): middle ear (``neweul fem middle-ear``
   refine 1, samples −2500/−1500 Pa, 30 modes + static correction, at −2000 Pa, canal
   input, up to 2/4/8 kHz) umbo 51/70/86 % plain, 12/38/40 % balanced, 2.3/2.4/3.3 %
   structure first (nearest sample alone 3.6/3.3/3.2 %), probe pressure 6.3/15/20 %,
   4.3/6.7/10 %, 0.9/0.8/3.7 % (nearest 0.2/0.3/0.9 %); the piston–duct and
   membrane–cavity models of ``tests/elastic/parametric/test_interpolation.py`` 1–100 % plain or
   balanced, < 0.03 % structure first.

The factor of the first present group (translations, rotations, pressure) is 1, so a model
of one group is not changed at all. ``"none"`` is ``S = I``; an array gives ``S`` row by row.

The left side is scaled the same way on its own bases, ``S_W`` = the balanced scaling of
the ``W_i`` with the same pressure weight: ``T_i = Rᵀ S V_i``, ``L_i = (W_iᵀ S_W R)⁻¹``
(``V_i → S V_i``, ``W_i → S_W W_i``; the reduced matrices are unchanged). The left vectors
of a u–p model are ``[ρλu; p]`` for right vectors ``[u; p]``, so their balance differs from
that of the ``V_i`` by about ``ρλ`` (1e9 in SI units, measured): with ``S`` on both sides,
or ``S⁻¹`` on the left, the left subspaces are nearly orthogonal to ``R`` in some directions
(principal-angle cosines down to 1e-7, exactness at the samples lost to 1e-5). Galerkin data
(``W_i = V_i``) gives ``S_W = S`` and ``L_i = T_i⁻ᵀ``. A change of units ``x = D x'`` (``D``
diagonal per DOF kind, e.g. pressure in kPa) turns an Eq. (2) model into ``D M D``,
``D K D`` with bases ``D⁻¹ V``, ``D⁻¹ W``; the ``"kind"`` scalings become ``S D``, ``S_W D``,
so ``S V_i``, ``S_W W_i`` and all transformed matrices are unchanged: the parametric body
does not depend on the units (to round-off). Both scalings are stored (``row_scale``,
``left_row_scale``), so ``T_i`` and ``L_i`` are reproducible; at the samples the result is
exact for any scaling. An array ``row_scaling`` is used on both sides.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ...errors import DataError, SolverError
from ...progress import report
from ..bodies.invariants import FLAT_FORMAT, Invariants
from ..bodies.parametric import (
    BASES,
    GROUP_ORDER,
    INTERPOLATIONS,
    KIND_GROUPS,
    STACKED,
    ParametricBody,
)
from ..bodies.reduced import ReducedBody
from ..bodies.static import StaticDeflection
from ..reductors.projection import Progress
from .samples import body_label, check_samples, sample_values, stacked_loss

__all__ = ["PRESSURE_WEIGHT", "ROW_SCALINGS", "interpolate", "kind_row_scale"]

#: Row scalings of :func:`interpolate` (module docstring); ``"given"`` is stored for an array.
ROW_SCALINGS = ("auto", "kind", "none")
#: Default factor of the pressure rows relative to their balanced scale (``"kind"``).
PRESSURE_WEIGHT = 1e-3


def _say(progress: Progress, msg: str) -> None:
    if progress is not None:
        progress(msg)


def _orth(V: np.ndarray) -> np.ndarray:
    Q, _ = np.linalg.qr(V)
    return Q


def kind_row_scale(bases: Sequence[np.ndarray], kinds: np.ndarray, *, rtol: float = 1e-10,
                   max_iter: int = 20) -> np.ndarray:
    """Row scaling ``S`` per group of DOF kinds that balances the stacked bases (§4).

    One factor per group — translations (``ux uy uz``), rotations (``rx ry rz``), pressure
    (``p``) — such that in the orthonormalized scaled bases ``Q_i = orth(S V_i)`` the
    entries of every group have the same RMS over all samples, i.e. group ``g`` holds the
    share ``Σ_i ‖Q_i[g]‖²_F / Σ_i r_i = n_g / n`` of the bases (``n_g`` its rows). Dividing
    each group's rows once by the RMS of its entries in ``orth(V_i)`` is the first step
    towards this; the balanced ``S`` is its fixed point, which does not depend on the units
    of the DOFs (bases ``D⁻¹ V_i`` give ``S D``) nor on the choice of basis vectors
    (``V_i A_i``). Groups whose rows are zero in every basis keep factor 1 and do not
    count; the first present group (in the order above) has factor 1.

    Each iteration orthonormalizes the bases in the current metric and solves for the
    factors on the ``r×r`` Gram blocks ``G_ig = Q_i[g]ᵀ Q_i[g]`` (share of ``g`` in sample
    ``i`` under extra factors ``d``: ``tr(d_g² G_ig (Σ_h d_h² G_ih)⁻¹)``, monotone in
    ``d_g``), group by group with Brent's method on ``log d_g``; it stops when the new
    factors are 1 to ``rtol``. A share that cannot be reached (rows of too low rank) moves
    its factor by at most 8 decades per iteration.

    Parameters
    ----------
    bases
        The k (n_rows, r_i) bases ``V_i``.
    kinds
        (n_rows,) DOF kind of every row.
    rtol
        Relative tolerance of the factors.
    max_iter
        Iterations (re-orthonormalizations); typically 2–4.

    Returns
    -------
    numpy.ndarray
        (n_rows,) positive factors (the diagonal of ``S``).
    """
    from scipy.optimize import brentq

    kinds = np.asarray(kinds).astype("U2")
    try:
        groups = np.array([KIND_GROUPS[k] for k in kinds])
    except KeyError as exc:
        raise DataError(f"unknown DOF kind {exc.args[0]!r}", None, "dof_kind") from None
    rows = [groups == g for g in GROUP_ORDER]
    present = [j for j, m in enumerate(rows) if np.any([np.any(V[m]) for V in bases])]
    scale = np.ones(kinds.size)
    if len(present) < 2:
        return scale
    masks = [rows[j] for j in present]
    counts = np.array([np.count_nonzero(m) for m in masks], dtype=np.float64)
    target = counts / counts.sum()
    y = np.zeros(len(present))                      # log factors, y[0] = 0
    for _ in range(max_iter):
        d_rows = np.ones(kinds.size)
        for j, m in enumerate(masks):
            d_rows[m] = np.exp(y[j])
        Qs = [_orth(d_rows[:, None] * V) for V in bases]
        total = sum(Q.shape[1] for Q in Qs)
        gram = [[Q[m].T @ Q[m] for m in masks] for Q in Qs]

        def shares(z: np.ndarray, gram: list = gram, total: int = total) -> np.ndarray:
            d2 = np.exp(2 * (z - z.max()))          # a common factor is irrelevant
            out = np.zeros(len(z))
            for G in gram:
                A = sum(d * Gj for d, Gj in zip(d2, G, strict=True))
                lam, U = np.linalg.eigh(A)          # A⁺: singular only at extreme ratios
                keep = lam > 1e-14 * lam.max()
                Ainv = (U[:, keep] / lam[keep]) @ U[:, keep].T
                out += [d * np.sum(Gj * Ainv) for d, Gj in zip(d2, G, strict=True)]
            return out / total

        # start: divide each group by the RMS of its entries in the current bases
        rms = np.sqrt(np.array([sum(np.trace(G[j]) for G in gram) for j in range(len(y))])
                      / (counts * total))
        z = -np.log(np.where(rms > 0, rms, 1.0) / (rms[0] if rms[0] > 0 else 1.0))
        for _sweep in range(2 if len(z) > 2 else 1):
            for j in range(1, len(z)):
                def f(t: float, j: int = j, z: np.ndarray = z) -> float:
                    zz = z.copy()
                    zz[j] = t
                    return float(np.log(max(shares(zz)[j], 1e-300) / target[j]))

                z0, f0 = z[j], f(z[j])
                if f0 == 0:
                    continue
                step = np.log(10.0) * (-1.0 if f0 > 0 else 1.0)
                prev, fprev = z0, f0
                for m in range(1, 9):               # widen decade by decade (≤ 8)
                    t = z0 + m * step
                    ft = f(t)
                    if ft == 0 or (ft > 0) != (fprev > 0):
                        z[j] = t if ft == 0 else brentq(
                            f, min(prev, t), max(prev, t), xtol=1e-14,
                            rtol=4 * np.finfo(float).eps)
                        break
                    prev, fprev = t, ft
                else:
                    z[j] = prev
        y = y + z - z[0]
        if np.all(np.abs(z - z[0]) <= rtol):
            break
    for j, m in enumerate(masks):
        scale[m] = float(np.exp(y[j] - y[0]))
    return scale


def _fix_signs(U: np.ndarray) -> np.ndarray:
    """Make the largest-magnitude entry of each column positive (deterministic output)."""
    if U.size == 0:
        return U
    rows = np.argmax(np.abs(U), axis=0)
    sign = np.sign(U[rows, np.arange(U.shape[1])])
    return U * np.where(sign == 0, 1.0, sign)


def _inverse(A: np.ndarray, Q: np.ndarray, R: np.ndarray, what: str, i: int, p: float,
             cond_max: float, min_cosine: float, axis: int) -> np.ndarray:
    """``A⁻¹`` for ``A = Rᵀ V_i`` or ``W_iᵀ R``, refused when ``R`` misses part of ``span Q``.

    The condition number is that of ``A`` with its local basis vectors (``axis``: the
    columns of ``Rᵀ V_i``, the rows of ``W_iᵀ R``) scaled to unit length: the transformed
    model does not depend on the lengths of the local basis vectors, which can differ by
    orders of magnitude in the scaled rows (pressure-dominated vectors under a small
    pressure weight). ``cond`` cannot see a basis (nearly) orthogonal to ``R`` (``A`` is
    then round-off with any condition number), so the cosines of the principal angles
    between ``span R`` and ``span Q`` (``Q`` orthonormal) are checked as well.
    """
    cos = np.linalg.svd(R.T @ Q, compute_uv=False).min() if Q.size else 1.0
    norms = np.linalg.norm(A, axis=1 - axis, keepdims=True)
    cond = np.linalg.cond(A / np.where(norms > 0, norms, 1.0)) if A.size else 1.0
    if not np.isfinite(cond) or cond > cond_max or cos < min_cosine:
        raise SolverError(f"sample {i + 1} (p = {p:g}): {what} is singular or ill-conditioned "
                          f"(condition number {cond:.3g}, smallest principal-angle cosine "
                          f"{cos:.3g} between the common subspace and the sample's basis); "
                          "the common subspace does not represent this sample — sample more "
                          "densely, weight this sample more, or use the full bases",
                          residual=cond)
    return np.linalg.inv(A)


def interpolate(
    bodies: Sequence[ReducedBody],
    samples: Sequence[float] | None = None,
    *,
    parameter: str = "p",
    basis: str = "auto",
    row_scaling: str | Sequence[float] | np.ndarray = "auto",
    pressure_weight: float = PRESSURE_WEIGHT,
    weights: Sequence[float] | None = None,
    interpolation: str = "linear",
    store_bases: bool = False,
    cond_max: float = 1e10,
    min_cosine: float = 1e-8,
    progress: Progress = None,
    labels: Sequence[str] | None = None,
) -> ParametricBody:
    """Bring local reduced models to common coordinates for matrix interpolation (§4).

    Steps 1–4 and 6 of ``docs/equations.md`` §4 (Panzer et al. 2010)::

        R   = first r left singular vectors of [w_1 Q_1 … w_k Q_k],  span Q_i = span S V_i
        T_i = Rᵀ S V_i,   L_i = (W_iᵀ S_W R)⁻¹   (Galerkin data W_i = V_i: L_i = T_i⁻ᵀ)
        X̃_i = L_i X_r,i T_i⁻¹,  B̃_i = L_i B_r,i,  C̃_i = C_r,i T_i⁻¹,
        V_kept T_i⁻¹ (Φ, Ψ rows),  W_kept L_iᵀ (modal loads),  invariants transformed;

    step 5 (the weighted sum) is :meth:`ParametricBody.at`.

    Parameters
    ----------
    bodies
        k ≥ 2 local reduced bodies of one FE discretization (same order ``r``, kept DOFs,
        inputs, outputs; one- or two-sided alike), in the order of the parameter.
    samples
        (k,) strictly increasing parameter values; default: each body's
        ``parameters[parameter]``. A body that records a different value is refused.
    parameter
        Name of the parameter.
    basis
        ``"full"``, ``"kept"`` or ``"auto"``: which basis rows determine ``R`` (module
        docstring). ``"full"`` needs bodies reduced with ``store_bases=True``.
    row_scaling
        Diagonal row scalings ``S``, ``S_W`` before the SVD (module docstring): ``"kind"``
        — one factor per group of DOF kinds, balanced by :func:`kind_row_scale` on the
        ``V_i`` and on the ``W_i`` (the kinds of the rows: ``full_dof_kind`` of the bodies
        for ``basis="full"``, ``dof_kind`` for ``"kept"``), pressure rows times
        ``pressure_weight``; ``"none"`` — ``S = I`` (the plain metric); an array — the
        factors of the rows for both sides (n for ``"full"``, the kept DOFs for
        ``"kept"``); ``"auto"`` (default) —
        ``"kind"`` when the kinds of the rows are known (always for ``"kept"``; for
        ``"full"`` when every body carries ``full_dof_kind``, i.e. was reduced by this
        version), else ``"none"``.
    pressure_weight
        For ``"kind"``: factor of the pressure rows on top of the balanced scaling
        (module docstring), default :data:`PRESSURE_WEIGHT`; 1 gives the balanced metric.
    weights
        (k,) non-negative SVD weights ``w_i`` (default all 1): how much each sample counts
        in the common subspace (e.g. more near the operating range).
    interpolation
        Default weight function of :meth:`ParametricBody.at` (``"linear"``, ``"cubic"``).
    store_bases
        Keep the transformed full bases ``V_i T_i⁻¹``, ``W_i L_iᵀ`` (k·n·r numbers each).
    cond_max, min_cosine
        Largest accepted condition number of ``T_i`` and ``W_iᵀ R``, and smallest accepted
        cosine of the principal angles between ``span R`` and ``span V_i`` (``span W_i``):
        below it, ``R`` misses part of the sample's subspace.
    progress
        Called with short messages (the CLI prints them to stderr).
    labels
        Names of the bodies in errors (e.g. their files; default "body i").

    Returns
    -------
    ParametricBody

    Raises
    ------
    DataError
        Bodies that are not samples of one family, or bad options
        (``docs/reduced-body-format.md``, "Checks of a parametric body").
    SolverError
        ``T_i`` or ``W_iᵀ R`` singular (beyond ``cond_max``).

    References
    ----------
    ``docs/equations.md`` §4; H. Panzer, J. Mohring, R. Eid, B. Lohmann, "Parametric
    model order reduction by matrix interpolation", *at – Automatisierungstechnik* 58 (2010)
    475–484.

    Examples
    --------
    >>> bodies = [reduce_modal(fe_at(p), modes=8, store_bases=True)
    ...           for p in (0.0, 0.5, 1.0)]                       # doctest: +SKIP
    >>> pb = interpolate(bodies, [0.0, 0.5, 1.0], parameter="pressure")  # doctest: +SKIP
    >>> pb.at(0.25).K                                              # doctest: +SKIP
    """
    bodies = list(bodies)
    s, w = _checked_samples(bodies, samples, str(parameter), basis, interpolation, weights,
                            labels)
    k, r, two = len(bodies), bodies[0].order, bodies[0].two_sided
    basis, Vs, Ws, kinds = _sample_bases(bodies, basis, store_bases)
    full_kinds = bodies[0].full_dof_kind if all(
        b.full_dof_kind is not None for b in bodies) else None
    scaling, scale, left = _row_scaling(row_scaling, kinds, Vs, Ws if two else None, basis,
                                        pressure_weight)
    if scale is not None:
        for side, sc in (("right", scale), ("left", left)):
            if sc is not None:
                _say(progress, f"{side} row scaling " + ", ".join(
                    f"{g} {v:.4g}" for g, v in _group_values(sc, kinds).items()))
        Vs = [scale[:, None] * V for V in Vs]       # x̂ = S x: T_i = Rᵀ S V_i
        SW = scale if left is None else left
        Ws = [SW[:, None] * W for W in Ws]          # L_i = (W_iᵀ S_W R)⁻¹

    # 1. common right subspace
    Qs = [_orth(V) for V in Vs]
    stacked = np.hstack([wi * Q for wi, Q in zip(w, Qs, strict=True)])
    _say(progress, f"common subspace: SVD of the {stacked.shape[0]}×{stacked.shape[1]} "
                   f"stacked {basis} bases, r = {r}")
    U, sv, _ = np.linalg.svd(stacked, full_matrices=False)
    if U.shape[1] < r:
        raise DataError(f"the stacked bases have only {U.shape[1]} columns for r = {r}",
                        None, "V")
    R = _fix_signs(U[:, :r])

    # 2.–4. and 6.: transform every sample
    out: dict[str, list[np.ndarray]] = {key: [] for key in (*STACKED, "T", "L", "V", "W")}
    invs: list[dict[str, np.ndarray]] = []
    for i, b in enumerate(bodies):
        T = R.T @ Vs[i]
        Tinv = _inverse(T, Qs[i], R, "T_i = Rᵀ S V_i", i, s[i], cond_max, min_cosine, 1)
        L = (_inverse(Ws[i].T @ R, _orth(Ws[i]), R, "W_iᵀ S_W R", i, s[i], cond_max,
                      min_cosine, 0) if two else Tinv.T)
        report(progress, f"sample {i + 1}/{k} ({parameter} = {s[i]:g}): cond T = "
               f"{np.linalg.cond(T):.3g}", i + 1, k)
        _transform_sample(b, T, Tinv, L, two, store_bases, out)
        if b.invariants is not None:
            invs.append(_transform_invariants(b, Tinv, L, two, i))
    static = _stacked_static(bodies, out["T"], labels)
    inv = _stacked_invariants(invs)
    return ParametricBody(
        parameter=str(parameter), samples=s,
        **{key: np.stack(out[key]) for key in (*STACKED, "T", "L")},
        input_names=bodies[0].input_names, output_names=bodies[0].output_names,
        nodes=bodies[0].nodes, kept_dofs=bodies[0].kept_dofs, dof_node=bodies[0].dof_node,
        dof_kind=bodies[0].dof_kind, R=R, singular_values=sv, svd_weights=w, basis=basis,
        two_sided=two, V=np.stack(out["V"]) if store_bases else None,
        W=np.stack(out["W"]) if store_bases else None, row_scaling=scaling, row_scale=scale,
        left_row_scale=left,
        pressure_weight=float(pressure_weight) if scaling == "kind" else None,
        full_dof_kind=full_kinds if (basis == "full" or store_bases) else None,
        invariants=inv, static=static,
        interpolation=interpolation,
        **({"G": np.stack(out["G"]),
            "loss_reference_frequency": stacked_loss(bodies)["loss_reference_frequency"]}
           if "G" in out else stacked_loss(bodies)),
        sample_sources=tuple(b.source for b in bodies),
        sample_methods=tuple(b.method for b in bodies),
        sample_settings=tuple(b.settings for b in bodies),
    )


def _checked_samples(bodies: list[ReducedBody], samples: Sequence[float] | None,
                     parameter: str, basis: str, interpolation: str,
                     weights: Sequence[float] | None, labels: Sequence[str] | None
                     ) -> tuple[np.ndarray, np.ndarray]:
    """The options of :func:`interpolate` and the bodies as samples of one family; the
    sample values and the SVD weights."""
    if len(bodies) < 2:
        raise DataError(f"need at least 2 sample bodies, got {len(bodies)}", None, "bodies")
    if not all(isinstance(b, ReducedBody) for b in bodies):
        raise DataError("bodies must be ReducedBody objects", None, "bodies")
    if basis not in BASES:
        raise DataError(f"must be one of {', '.join(BASES)}, got {basis!r}", None, "basis")
    if interpolation not in INTERPOLATIONS:
        raise DataError(f"must be one of {', '.join(INTERPOLATIONS)}, got {interpolation!r}",
                        None, "interpolation")
    s = sample_values(bodies, samples, parameter)
    check_samples(bodies, labels)
    k = len(bodies)
    w = np.ones(k) if weights is None else np.asarray(weights, dtype=np.float64).ravel()
    if w.shape != (k,) or not np.all(np.isfinite(w)) or np.any(w < 0) or not w.any():
        raise DataError(f"need {k} finite non-negative weights, not all zero; got "
                        f"{np.asarray(weights).tolist()}", None, "weights")
    return s, w


def _sample_bases(bodies: list[ReducedBody], basis: str, store_bases: bool
                  ) -> tuple[str, list[np.ndarray], list[np.ndarray], np.ndarray | None]:
    """The basis rows that determine ``R`` (``"auto"`` resolved): the basis, the right and
    left bases of the samples and the DOF kinds of their rows (``None`` if unknown)."""
    two, r = bodies[0].two_sided, bodies[0].order

    def has_full(b: ReducedBody) -> bool:
        return b.V is not None and (not two or b.W is not None)

    full = all(has_full(b) for b in bodies)
    if basis == "auto":
        basis = "full" if full else "kept"
    if (basis == "full" or store_bases) and not full:
        missing = [i + 1 for i, b in enumerate(bodies) if not has_full(b)]
        raise DataError(f"bodies {missing} hold no full bases V{', W' if two else ''} "
                        "(reduce with store_bases=True / --store-bases)", None, "V")
    if basis == "kept":
        nk = bodies[0].kept_dofs.size
        if nk < r:
            raise DataError(f"the {nk} kept DOFs cannot determine {r} common coordinates "
                            "(basis='kept' needs at least r kept DOFs): reduce with "
                            "store_bases=True or keep more nodes", None, "V_kept")
        return (basis, [b.V_kept for b in bodies], [b.W_kept for b in bodies],
                bodies[0].dof_kind)
    shapes = {b.V.shape for b in bodies}
    if len(shapes) > 1:
        raise DataError(f"full bases of different shapes {sorted(shapes)}", None, "V")
    kinds = bodies[0].full_dof_kind
    if any(b.full_dof_kind is None for b in bodies):
        kinds = None
    return basis, [b.V for b in bodies], [b.W if two else b.V for b in bodies], kinds


def _transform_sample(b: ReducedBody, T: np.ndarray, Tinv: np.ndarray, L: np.ndarray,
                      two: bool, store_bases: bool, out: dict[str, list[np.ndarray]]
                      ) -> None:
    """Append the sample's ``X̃ = L X T⁻¹``, ``B̃ = L B``, ``C̃ = C T⁻¹`` and transformed
    basis rows (§4, steps 2–4) to the stacks ``out``."""
    out["T"].append(T)
    out["L"].append(L)
    for key in ("M", "D", "K"):
        out[key].append(L @ b[key] @ Tinv)
    if b.G is not None:
        out.setdefault("G", []).append(L @ b.G @ Tinv)
    out["B"].append(L @ b.B)
    out["C"].append(b.C @ Tinv)
    out["V_kept"].append(b.V_kept @ Tinv)
    out["W_kept"].append(b.W_kept @ L.T)
    if store_bases:
        out["V"].append(b.V @ Tinv)
        out["W"].append((b.W if two else b.V) @ L.T)


def _stacked_static(bodies: list[ReducedBody], Ts: list[np.ndarray],
                    labels: Sequence[str] | None) -> StaticDeflection | None:
    """The samples' static states in the common coordinates, stacked (all or none)."""
    if all(b.static is None for b in bodies):
        return None
    if not all(b.static is not None for b in bodies):
        raise DataError("some samples carry a static state and some do not: "
                        + ", ".join(body_label(labels, i) for i, b in enumerate(bodies)
                                    if b.static is None) + " lack it", None, "static")
    return StaticDeflection.stack([b.static.transformed(T) for b, T in
                                   zip(bodies, Ts, strict=True)])


def _stacked_invariants(invs: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray] | None:
    """The transformed invariants of the samples, stacked (``None`` without any)."""
    if not invs:
        return None
    keys = list(invs[0])
    if any(list(x) != keys for x in invs[1:]):
        raise DataError("the transformed invariants of the samples have different "
                        "arrays (order-1 terms in some samples only?)", None, "invariants")
    try:
        return {key: np.stack([x[key] for x in invs]) for key in keys}
    except ValueError as exc:
        raise DataError(f"invariants of different shapes ({exc})", None,
                        "invariants") from None


def _row_scaling(option: Any, kinds: np.ndarray | None, Vs: Sequence[np.ndarray],
                 Ws: Sequence[np.ndarray] | None, basis: str, pressure_weight: float
                 ) -> tuple[str, np.ndarray | None, np.ndarray | None]:
    """The stored ``(row_scaling, row_scale, left_row_scale)`` for the ``row_scaling`` option
    (``Ws`` ``None`` for Galerkin data: the left scaling is the right one)."""
    n_rows = Vs[0].shape[0]
    try:
        pw = float(pressure_weight)
    except (TypeError, ValueError):
        pw = float("nan")
    if not (np.isfinite(pw) and pw > 0):
        raise DataError(f"must be a positive number, got {pressure_weight!r}", None,
                        "pressure_weight")
    if isinstance(option, str):
        if option not in ROW_SCALINGS:
            raise DataError(f"must be one of {', '.join(ROW_SCALINGS)} or an array of "
                            f"factors, got {option!r}", None, "row_scaling")
        if option == "auto":
            option = "kind" if kinds is not None else "none"
        if option == "none":
            return "none", None, None
        if kinds is None:
            raise DataError("row_scaling='kind' needs the DOF kinds of the full bases, which "
                            "bodies reduced before full_dof_kind existed do not hold: reduce "
                            "again, or use row_scaling='none' or an array", None,
                            "full_dof_kind")
        is_p = np.asarray(kinds).astype("U2") == "p"
        weight = np.where(is_p, pw, 1.0) if is_p.any() and not is_p.all() else 1.0
        scale = weight * kind_row_scale(Vs, kinds)  # u–p rows: structure first
        left = None if Ws is None else weight * kind_row_scale(Ws, kinds)
        return "kind", scale, left
    try:
        scale = np.array(option, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise DataError(f"must be 'kind', 'none' or an array of numbers, got {option!r}",
                        None, "row_scaling") from None
    if scale.shape != (n_rows,) or not np.all(np.isfinite(scale)) or np.any(scale <= 0):
        raise DataError(f"an array row_scaling needs {n_rows} finite positive factors (one "
                        f"per row of the {basis} bases), got shape {scale.shape}", None,
                        "row_scaling")
    return "given", scale, None


def _group_values(scale: np.ndarray, kinds: np.ndarray | None) -> dict[str, float]:
    if kinds is None:
        return {"rows": float(np.exp(np.log(scale).mean()))}   # geometric mean
    groups = np.array([KIND_GROUPS[k] for k in np.asarray(kinds).astype("U2")])
    return {g: float(np.exp(np.log(scale[groups == g]).mean())) for g in GROUP_ORDER
            if np.any(groups == g)}


def _transform_invariants(body: ReducedBody, Tinv: np.ndarray, L: np.ndarray, two: bool,
                          i: int) -> dict[str, np.ndarray]:
    """Step 6: the invariants in common coordinates, ``q = T_i⁻¹ q̃``, rows ``L_i``."""
    flat = body.invariants
    fmt = str(np.asarray(flat.get("format", ""))) if "format" in flat else None
    if fmt != FLAT_FORMAT:
        raise DataError(f"body {i + 1}: the invariants slot does not hold "
                        f"{FLAT_FORMAT!r} data (format {fmt!r}); only the invariants of "
                        "neweul_py.elastic.bodies.invariants can be transformed", None,
                        "invariants")
    try:
        inv = Invariants.from_flat(flat)
    except DataError as exc:
        raise DataError(f"body {i + 1}: {exc.message}", None, exc.item) from None
    if inv.nq != Tinv.shape[0]:
        raise DataError(f"body {i + 1}: invariants for {inv.nq} elastic coordinates, the "
                        f"body has {Tinv.shape[0]}", None, "invariants")
    left = L if (two or inv.two_sided) else None   # None: one-sided stays one-sided (Rᵀ)
    return inv.transformed(Tinv, left).to_flat()
