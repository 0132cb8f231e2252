"""A small global basis from frequency-response snapshots of the interface-loaded FE models.

The global basis of :mod:`~neweul_py.elastic.parametric.global_basis` (the local bases of all
samples,
POD-compressed) is accurate between samples but large: on the middle-ear sweep (refine 1,
9 samples, 30 modes + static correction each) it keeps 600 directions, and truncating it by
POD energy loses the response (100 % error at 200 directions) because the energy of a
basis vector says nothing about its share in the transfer functions the model is used for.

Here the basis is built from the responses themselves (rational-interpolation snapshots,
Baur, Beattie, Benner & Gugercin 2011, *SIAM J. Sci. Comput.* 33, §3; Benner, Gugercin &
Willcox 2015, *SIAM Rev.* 57, §3.3): for every sample ``i`` and snapshot frequency ``ω_j``

    X_ij = (K_i + K_x + iω_j D_i − ω_j² M_i)⁻¹ F_i          (full FE model, sparse LU)

with ``F_i`` the loads the body will see and ``K_x`` a stiffness the body will be attached
with (the middle ear: the canal sound source, and the TM–manubrium springs ``K_x`` loaded by
the six rigid motions ``K_x T`` of the malleus — every response of the TM with *any* chain
attached through a rigid malleus is such a combination, so the basis serves every chain). The
real and imaginary parts are split into their structural and pressure rows and each block is
compressed in its energy metric (:func:`~neweul_py.elastic.parametric.global_basis.energy_metric`,
:func:`~neweul_py.elastic.parametric.global_basis.g_orthonormal`): the block-diagonal Galerkin basis
keeps the u–p structure and stability of Eq. (2) at every parameter value, as in
:mod:`~neweul_py.elastic.parametric.global_basis`. ``K_x`` is used for the snapshots only; the
reduced
body is the projection of the FE model itself.
"""

from __future__ import annotations

import itertools
import multiprocessing
import os
from collections import deque
from collections.abc import Iterable, Iterator, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np
import scipy.sparse as sps

from ...errors import DataError
from ..bodies.invariants import Invariants
from ..bodies.parametric import ParametricBody, checked_slope_step
from ..bodies.reduced import ReducedBody
from ..bodies.static import StaticDeflection
from ..fe_model import FEModel
from ..reductors.eigen import SparseLU
from ..reductors.projection import Progress, build_reduced_body
from ..reductors.static_state import metric_gram, static_deflection
from ..reductors.up_transpose import adjoint_from_primal, mirrored_loads, up_similarity
from .global_basis import energy_metric, g_orthonormal
from .samples import (
    central_curvatures,
    central_slopes,
    hermite_kind,
    stacked_loss,
    structured_derivatives,
)

__all__ = ["ProjectionCache", "basis_parametric_body", "check_same_mesh", "fixed_frame_invariants",
           "frequency_snapshots", "sample_snapshots", "snapshot_basis"]


def _say(progress: Progress, msg: str) -> None:
    if progress is not None:
        progress(msg)


def frequency_snapshots(fes: Sequence[FEModel], loads: Sequence[np.ndarray],
                        freqs_hz: Sequence[float],
                        extra_stiffness: sps.spmatrix | None = None,
                        adjoint: Sequence[np.ndarray] | None = None,
                        progress: Progress = None, workers: int = 1, moments: int = 1
                        ) -> Iterator[tuple[np.ndarray, np.ndarray | None, float]]:
    """The primal and adjoint frequency-response snapshots of every sample (module
    docstring), sample by sample, frequency by frequency: ``(X_ij, Y_ij, ω_j)`` with

        X_ij = A_ij⁻¹ F_i,   Y_ij = A_ij⁻ᵀ c_i,   A_ij = K_i + K_x + iω_j D_i − ω_j² M_i

    (complex, one sparse LU per sample and frequency; ``Y_ij`` ``None`` without
    ``adjoint``). Arguments as in :func:`snapshot_basis`; a count of load sets or output
    sets that is not one per FE model, or a frequency that is not positive and finite, is a
    :class:`DataError` before any solve. ``workers > 1``: the samples are solved in that many
    processes (one BLAS thread each), the snapshots come in the same order and are the same.
    ``moments`` (1, 2 or 3): per frequency the snapshots and their first ``moments − 1``
    scaled derivatives in ``ω`` (:func:`sample_snapshots`), in that order.
    """
    if len(loads) != len(fes) or (adjoint is not None and len(adjoint) != len(fes)):
        raise DataError(f"{len(loads)} load sets for {len(fes)} FE models", None, "loads")
    f = np.asarray(freqs_hz, dtype=float)
    if f.size == 0 or np.any(f <= 0) or not np.all(np.isfinite(f)):
        raise DataError("snapshot frequencies must be positive and finite", None, "freqs")
    if int(workers) < 1:
        raise DataError(f"workers: a positive number of processes, got {workers!r}", None,
                        "workers")
    if int(moments) not in (1, 2, 3):
        raise DataError(f"moments: 1, 2 or 3 per frequency, got {moments!r}", None, "moments")
    return _solves(fes, loads, f, extra_stiffness, adjoint, progress, int(workers),
                   int(moments))


def sample_snapshots(fe: FEModel, F: np.ndarray, adjoint: np.ndarray | None, f: np.ndarray,
                     extra_stiffness: sps.spmatrix | None, moments: int = 1
                     ) -> list[tuple[np.ndarray, np.ndarray | None, float]]:
    """The snapshots ``(X_j, Y_j, ω_j)`` of one sample (:func:`frequency_snapshots`); with
    ``moments = 2`` or ``3`` after each also its scaled derivatives in ``ω`` from the same
    factorization (Hermite interpolation, Baur et al. 2011, §3)::

        ω X′ = −ω A⁻¹ A′ X,       ω² X″/2 = −ω² A⁻¹ (A′ X′ + ½ A″ X),
        A′ = iD − 2ωM,            A″ = −2M

    and likewise ``Y`` with ``Aᵀ`` (a projection whose space holds ``X`` and its first
    ``m − 1`` derivatives at ``ω_j`` matches the transfer function and as many derivatives
    there). An adjoint load of a u–p model that is also a primal load and has no pressure
    rows gets its responses from the primal ones (``Y = S X``,
    :mod:`~neweul_py.elastic.reductors.up_transpose`) instead of a transposed solve."""
    K = fe.K if extra_stiffness is None else fe.K + extra_stiffness
    D = fe.D if fe.D is not None else sps.csr_matrix(fe.K.shape)
    F = np.asarray(F, dtype=complex)
    c = None if adjoint is None else np.asarray(adjoint, dtype=complex)
    rho = None if c is None else up_similarity(fe, K, D)
    is_p = fe.dof_kind == "p"
    mirror = mirrored_loads(F, c, is_p) if rho is not None and F.ndim == c.ndim == 2 else {}
    solved = [j for j in range(0 if c is None else c.shape[-1]) if j not in mirror]
    out = []
    for w in 2 * np.pi * f:
        lu = SparseLU(sps.csr_matrix(K + 1j * w * D - w * w * fe.M, dtype=complex))
        Xs = [lu.solve(F)]
        Ys = None if c is None else [lu.solve(c[..., solved] if mirror else c, transpose=True)]
        if moments > 1:
            A1 = sps.csr_matrix(1j * D - 2 * w * fe.M, dtype=complex)
            Xs.append(-lu.solve(A1 @ Xs[0]))
            if Ys is not None:
                Ys.append(-lu.solve(A1.T @ Ys[0], transpose=True))
            if moments > 2:
                Xs.append(-lu.solve(A1 @ Xs[1] - fe.M @ Xs[0]))
                if Ys is not None:
                    Ys.append(-lu.solve(A1.T @ Ys[1] - fe.M.T @ Ys[0], transpose=True))
        del lu                          # before the next factorization, not after it
        if Ys is not None and mirror:
            js, ks = list(mirror), list(mirror.values())
            full = [np.empty((F.shape[0], c.shape[1]), dtype=complex) for _ in Ys]
            from_primal = adjoint_from_primal([X[:, ks] for X in Xs], float(w), rho, is_p)
            for Y, part, mirrored in zip(full, Ys, from_primal, strict=True):
                Y[:, solved], Y[:, js] = part, mirrored
            Ys = full
        for m, X in enumerate(Xs):
            scale = (1.0, w, w * w)[m]
            out.append((scale * X if m else X,
                        None if Ys is None else (scale * Ys[m] if m else Ys[m]), float(w)))
    return out


#: The environment of the worker processes of :func:`frequency_snapshots`: one BLAS thread.
_WORKER_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def _solves(fes: Sequence[FEModel], loads: Sequence[np.ndarray], f: np.ndarray,
            extra_stiffness: sps.spmatrix | None, adjoint: Sequence[np.ndarray] | None,
            progress: Progress, workers: int, moments: int = 1
            ) -> Iterator[tuple[np.ndarray, np.ndarray | None, float]]:
    """The snapshots of sample after sample; ``fes[i]`` is taken only when sample ``i`` is
    solved or sent to a worker (a lazy sequence of models is never held whole), and at most
    ``workers + 1`` samples are in the pool at a time."""
    def args(i: int) -> tuple[Any, ...]:
        return (fes[i], loads[i], None if adjoint is None else adjoint[i], f, extra_stiffness,
                moments)

    n = len(fes)
    if workers == 1 or n == 1:
        for i in range(n):
            yield from sample_snapshots(*args(i))
            _say(progress, f"snapshots: sample {i + 1} of {n}")
        return
    saved = {k: os.environ.get(k) for k in _WORKER_ENV}
    os.environ.update(_WORKER_ENV)          # the spawned workers start with one BLAS thread
    try:
        with ProcessPoolExecutor(max_workers=min(workers, n),
                                 mp_context=multiprocessing.get_context("spawn")) as pool:
            pending = deque(pool.submit(sample_snapshots, *args(i))
                            for i in range(min(workers + 1, n)))
            for i in range(n):
                done = pending.popleft().result()
                if i + len(pending) + 1 < n:
                    pending.append(pool.submit(sample_snapshots, *args(i + len(pending) + 1)))
                yield from done
                del done                                      # held once, then released
                _say(progress, f"snapshots: sample {i + 1} of {n}")
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def snapshot_basis(fes: Sequence[FEModel], loads: Sequence[np.ndarray],
                   freqs_hz: Sequence[float], extra_stiffness: sps.spmatrix | None = None,
                   rtol: float = 1e-8, order: int | None = None,
                   progress: Progress = None,
                   prior: np.ndarray | None = None,
                   adjoint: Sequence[np.ndarray] | None = None,
                   workers: int = 1, moments: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """The G-orthonormal, u/p block-diagonal snapshot basis (module docstring).

    Parameters
    ----------
    fes
        The FE model of every sample (one discretization).
    loads
        Per sample the (n, k) loads ``F_i``.
    freqs_hz
        Snapshot frequencies [Hz] (> 0: the u–p stiffness of closed air volumes is singular).
    extra_stiffness
        ``K_x`` (n × n) added for the snapshots only (``None``: none).
    rtol
        Relative POD energy (eigenvalue of the Gram matrix of unit-energy snapshots) below
        which a direction is dropped.
    order
        Keep at most this many directions (the most energetic over both blocks).
    adjoint
        Per sample (n, l) output rows ``c`` (transposed): the adjoint snapshots
        ``A_ijᵀ y = c`` join the others (same factorization, transposed solve). With primal
        and dual solutions in one Galerkin space the transfer-function error is of second
        order in the projection error (Petrov–Galerkin accuracy from a Galerkin basis; the
        u–p model is unsymmetric).
    prior
        Columns of an earlier basis of the same models (e.g. the snapshots at other
        frequencies, compressed): they join the new snapshots, so a basis can be extended
        by further frequencies without solving the old ones again.
    workers
        Processes solving the samples (:func:`frequency_snapshots`).
    moments
        Snapshots per frequency: the response and its first ``moments − 1`` derivatives in
        ``ω`` (:func:`sample_snapshots`; one factorization serves them all).

    Returns
    -------
    V, energy
        (n, r) basis and the POD energy of each column.
    """
    n = fes[0].n_dofs
    width = [np.asarray(F).reshape(n, -1).shape[1]
             + (np.asarray(adjoint[i]).reshape(n, -1).shape[1] if adjoint is not None else 0)
             for i, F in enumerate(loads)]
    first = 0 if prior is None else np.asarray(prior).shape[1]
    # filled in place: one copy
    S = np.empty((n, first + 2 * int(moments) * len(freqs_hz) * sum(width)))
    if prior is not None:
        S[:, :first] = prior
    col = first
    for X, Y, _w in frequency_snapshots(fes, loads, freqs_hz, extra_stiffness, adjoint,
                                        progress, workers, moments):
        for part in (X, Y):
            if part is not None:
                part = part.reshape(n, -1)
                k = part.shape[1]
                S[:, col:col + k], S[:, col + k:col + 2 * k] = part.real, part.imag
                col += 2 * k
    G = energy_metric(fes)
    kinds = fes[0].dof_kind
    blocks = [kinds == "p", kinds != "p"] if fes[0].kind == "up-coupled" else [
        np.ones(kinds.size, dtype=bool)]
    Vs, energies = [], []
    for block in blocks:
        Q, lam = g_orthonormal(S, G, rtol, rows=np.flatnonzero(block))
        Vs.append(Q)
        energies.append(lam[:Q.shape[1]])
    V, energy = np.hstack(Vs), np.concatenate(energies)
    idx = np.argsort(-energy, kind="stable")[:order]
    _say(progress, f"snapshot basis: {idx.size} directions from {S.shape[1]} snapshots")
    return V[:, idx], energy[idx]


def _rigid_mass(fe: FEModel) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass, first moment and inertia about the origin of the structural DOFs of ``fe``
    (``rᵀ M_uu r`` of the rigid translations and rotations)."""
    kinds = fe.dof_kind
    xyz = {int(r[0]): r[1:4] for r in fe.nodes}
    u = np.flatnonzero(np.isin(kinds, ("ux", "uy", "uz")))
    pos = np.array([xyz[int(n)] for n in fe.dof_node[u]])
    axis = np.searchsorted(["ux", "uy", "uz"], kinds[u])
    Muu = fe.M[u][:, u]
    R = np.zeros((u.size, 6))
    R[np.arange(u.size), axis] = 1.0
    e = np.eye(3)
    for a in range(3):                      # rotation about a: displacement e_a × x
        R[:, 3 + a] = np.cross(e[a], pos)[np.arange(u.size), axis]
    Mr = R.T @ (Muu @ R)
    m = float(np.max(np.diag(Mr[:3, :3])))   # a model may lack some translation DOFs
    md = np.array([Mr[1, 5], Mr[2, 3], Mr[0, 4]]).reshape(3, 1)   # ∫ x dm from the couplings
    return m, md, 0.5 * (Mr[3:, 3:] + Mr[3:, 3:].T)


def fixed_frame_invariants(body: ReducedBody, fe: FEModel) -> ReducedBody:
    """The body with the invariants of an elastic body on a **fixed** frame.

    On a frame that does not move (``a = α = ω = 0``) and without gravity, the body's
    equations (``docs/equations.md`` §2) reduce to ``Me q̈ + De q̇ + Ke q = node loads``:
    the frame-coupling invariants (``Ct``, ``Cr``, ``Crv``, ``Gr``, ``Ge``, ``Oe``,
    ``kσ``, the first- and second-order parts) multiply zero and are stored as zeros
    (a few bytes compressed instead of ``O(nq²)`` per sample). Mass, first moment and
    inertia are the rigid properties of the structure. **Only valid for a body whose
    reference frame is ISYS in a description with zero gravity.** Node frames: the kept
    nodes, ``Φ_P`` / ``Φ_W`` from the body's kept rows, no rotations (``Ψ = 0``: translation
    DOFs only).
    """
    nq = body.order
    m, md, J = _rigid_mass(fe)
    z = np.zeros
    nodes = body.nodes
    nk = nodes.shape[0]
    phi, phi_w = z((nk, 3, nq)), z((nk, 3, nq))
    for k, nid in enumerate(nodes[:, 0].astype(np.int64)):
        for a, kind in enumerate(("ux", "uy", "uz")):
            hit = np.flatnonzero((body.dof_node == nid) & (body.dof_kind == kind))
            if hit.size:
                phi[k, a] = body.V_kept[hit[0]]
                phi_w[k, a] = body.W_kept[hit[0]]
    flat = {
        "format": np.array("neweul-invariants-1"), "m": np.array(m),
        "names": np.array([f"q{i + 1}" for i in range(nq)], dtype=str),
        "two_sided": np.array(bool(body.two_sided)),
        "md.m0": md, "J.m0": J, "Ct.m0": z((nq, 3)), "Cr.m0": z((nq, 3)),
        "Crv.m0": z((nq, 3)), "Me.m0": np.asarray(body.M), "Gr.m0": z((3, 3 * nq)),
        "Ge.m0": z((nq, 3 * nq)), "Oe.m0": z((nq, 6)), "ksigma.m0": z((nq, 1)),
        "Ke.m0": np.asarray(body.K), "De.m0": np.asarray(body.D),
        **({"Le.m0": np.asarray(body.G), "loss.f_ref": np.array(body.loss_reference_frequency)}
           if body.G is not None else {}),
        "nodes.id": nodes[:, 0].astype(np.int64),
        "nodes.origin.m0": nodes[:, 1:4].reshape(nk, 3, 1).copy(),
        "nodes.origin.m1": phi.reshape(nk, 3, nq, 1).copy(),
        "nodes.phi": phi, "nodes.psi": z((nk, 3, nq)), "nodes.phi_w": phi_w,
        "nodes.psi_w": z((nk, 3, nq)), "nodes.AP.m0": np.broadcast_to(np.eye(3),
                                                                       (nk, 3, 3)).copy(),
        "nodes.AP.m1": z((nk, 3, nq, 3)),
    }
    Invariants.from_flat(flat)          # checked against the schema
    return body.with_(invariants=flat)


class ProjectionCache:
    """FE models projected on one basis pair: the bodies by FE fingerprint, and the first
    model with its body as the base whose difference the others project
    (:func:`~neweul_py.elastic.reductors.projection.build_reduced_body`)."""

    def __init__(self) -> None:
        self.bodies: dict[str, ReducedBody] = {}
        self.base: tuple[FEModel, ReducedBody] | None = None

    def add(self, fe: FEModel, body: ReducedBody) -> None:
        """Remember ``body``, the projection of ``fe`` (the base when it is the first)."""
        self.bodies[fe.fingerprint] = body
        if self.base is None:
            self.base = (fe, body)

    def body(self, fe: FEModel, V: np.ndarray, W: np.ndarray | None = None,
             keep_nodes: Sequence[int] | None = None, remember: bool = True) -> ReducedBody:
        """``fe`` projected on ``V`` (``W``: the left basis of a two-sided pair, ``None``
        for Galerkin), with :func:`fixed_frame_invariants`: remembered, or projected against
        the base (and remembered unless ``remember`` is false and there is a base: a model
        used once, e.g. a refinement's midpoint, does not stay in memory)."""
        b = self.bodies.get(fe.fingerprint)
        if b is None:
            settings = {"order": int(V.shape[1])} | ({"two_sided": True} if W is not None
                                                     else {})
            b = fixed_frame_invariants(build_reduced_body(
                fe, V, V if W is None else W, "snapshot", settings, keep_nodes=keep_nodes,
                base=self.base), fe)
            if remember or self.base is None:
                self.add(fe, b)
        return b


def check_same_mesh(fes: Iterable[FEModel], samples: Sequence[float]) -> None:
    """One :class:`DataError` naming the first sample whose nodes or DOFs differ from the
    first sample's: the samples of a parametric body share one mesh (one ``V`` for all).
    ``fes`` is iterated once (a lazy sequence of models is not held whole)."""
    ref = None
    for fe, p in zip(fes, samples, strict=True):
        ref = fe if ref is None else ref
        if not (fe.n_dofs == ref.n_dofs and np.array_equal(fe.dof_node, ref.dof_node)
                and np.array_equal(fe.dof_kind, ref.dof_kind)
                and np.array_equal(fe.nodes, ref.nodes)):
            raise DataError(f"the sample at {p:g} ({fe.n_dofs} DOFs, {fe.nodes.shape[0]} nodes) "
                            f"has other nodes or DOFs than the one at {samples[0]:g} "
                            f"({ref.n_dofs} DOFs, {ref.nodes.shape[0]} nodes): the samples of a "
                            "parametric body must share one mesh", fe.source, "nodes")


def basis_parametric_body(fes: Sequence[FEModel], V: np.ndarray, samples: Sequence[float], *,
                          parameter: str = "p", keep_nodes: Sequence[int] | None = None,
                          interpolation: str | None = None,
                          energy: np.ndarray | None = None,
                          static: Sequence[Mapping[str, Any]] | None = None,
                          slope_models: tuple[Sequence[FEModel], Sequence[FEModel]] | None
                          = None, slope_step: float | None = None,
                          slope_static: tuple[Sequence[Mapping[str, Any]],
                                              Sequence[Mapping[str, Any]]] | None = None,
                          metric: sps.spmatrix | None = None,
                          W: np.ndarray | None = None,
                          progress: Progress = None,
                          projections: ProjectionCache | None = None) -> ParametricBody:
    """The parametric body of one basis pair for every sample, ``X_i = Wᵀ X_i V`` — one
    Galerkin basis ``V`` (``W`` ``None``: ``W = V``) or a two-sided pair ``(V, W)``
    (:func:`~neweul_py.elastic.parametric.two_sided_basis.balanced_snapshot_basis`) — with
    :func:`fixed_frame_invariants`; interpolated entrywise as in
    :func:`~neweul_py.elastic.parametric.global_basis.global_parametric_body`.

    ``slope_models = (minus, plus)``: the FE models at every sample ∓ ``slope_step``
    (``slope_static`` their static states, needed with ``static``) projected on the same
    ``V`` — the same kept nodes, and the static states in the samples' energy metric — give
    the samples' slopes by central differences and, for the default ``"quintic-hermite"``
    weights, the curvatures by central second differences (the samples and their slope
    models are projected alike; ``interpolation="hermite"``: the slopes alone; docs/
    equations.md §4.2). Without slope models the default weights are ``"cubic"``.
    ``metric``: the energy metric of the static projection (default: that of ``fes``).

    ``projections``: a :class:`ProjectionCache` the caller keeps across calls with the same
    ``V``, ``W`` and kept nodes, so that a model projected once — a sample, or a slope model,
    of an earlier body of a refinement — is not projected again; the first model projected is
    the base of the others (only their differences to it are projected).

    ``static`` gives per sample the static state it is linearized about, as the keyword
    arguments of :func:`~neweul_py.elastic.reductors.static_state.static_deflection` (``x`` — the FE
    static state; ``node_force``, ``outputs``; the output rows are the FE model's and the
    projection is ``Ḡ``-orthogonal in the energy metric of the samples, ``q = (VᵀḠV)⁻¹VᵀḠx``,
    for a two-sided pair too: the best approximation of the static state in the span of
    ``V``): the body then carries it (``static/*``, docs/equations-middle-ear.md §5).
    """
    s = np.asarray(samples, dtype=float)
    kind = hermite_kind(interpolation, slope_models is not None)
    if s.size != len(fes) or s.size < 2 or np.any(np.diff(s) <= 0):
        raise DataError("need at least two increasing sample values, one per FE model",
                        None, "samples")
    check_same_mesh(fes, s)
    first = fes[0]                      # once: a lazy sequence reads a model per access
    n_dofs, dof_kind = first.n_dofs, first.dof_kind
    del first
    if V.shape[0] != n_dofs:
        raise DataError(f"the basis has {V.shape[0]} rows for FE models of {n_dofs} DOFs",
                        None, "V")
    two = W is not None
    if two and W.shape != V.shape:
        raise DataError(f"the left basis is {W.shape}, the right one {V.shape}", None, "W")
    Wb = W if two else V
    if static is not None and len(static) != len(fes):
        raise DataError(f"{len(static)} static states for {len(fes)} samples", None, "static")
    if (slope_models is None) != (slope_step is None) or (
            slope_models is not None and (static is None) != (slope_static is None)):
        raise DataError("slope models go with a slope step, and with their static states "
                        "exactly when the samples carry static states", None, "slopes")
    if slope_models is not None:
        checked_slope_step(slope_step)                  # the step, before any projection
        if any(len(m) != s.size for m in slope_models):
            raise DataError(f"one slope model on each side of each of the {s.size} samples, "
                            f"got {[len(m) for m in slope_models]}", None, "slopes")
        d = float(slope_step)
        check_same_mesh(itertools.chain(fes, *slope_models), [*s, *(s - d), *(s + d)])
    G = (metric if metric is not None else energy_metric(fes)) if static is not None else None
    bodies, states = [], []
    cache = ProjectionCache() if projections is None else projections
    gram = metric_gram(G, V) if G is not None else None    # once for all the states
    for i, fe in enumerate(fes):
        b = cache.body(fe, V, W, keep_nodes)
        bodies.append(b.with_(parameters={parameter: float(s[i])}))
        if static is not None:
            states.append(static_deflection(b, V=V, W=Wb, output_rows=fe.C(), metric=G,
                                            gram=gram, **static[i]))
        _say(progress, f"projected sample {i + 1} of {len(fes)}")
    k, r = len(bodies), V.shape[1]
    eye = np.broadcast_to(np.eye(r), (k, r, r))          # read-only: one copy in memory
    stacks = {key: np.stack([b[key] for b in bodies]) for key in ("M", "D", "K", "B", "C",
                                                                  "V_kept", "W_kept")}
    stacks.update(stacked_loss(bodies))
    # the invariants that are the bodies' own M, K, D, G share their stacks (no copies)
    own = {"Me.m0": "M", "Ke.m0": "K", "De.m0": "D", "Le.m0": "G"}
    inv = {name: stacks[own[name]] if name in own and own[name] in stacks and all(
               b.invariants[name] is b[own[name]] for b in bodies)
           else np.stack([np.asarray(b.invariants[name]) for b in bodies])
           for name in bodies[0].invariants}
    g0 = bodies[0]
    sv = np.sqrt(np.maximum(energy, 0.0)) if energy is not None else np.ones(r)
    pb = ParametricBody(
        parameter=str(parameter), samples=s, **stacks,
        T=eye, L=eye, R=V, singular_values=sv, svd_weights=np.ones(k), basis="full",
        two_sided=two, input_names=g0.input_names, output_names=g0.output_names,
        nodes=g0.nodes, kept_dofs=g0.kept_dofs, dof_node=g0.dof_node, dof_kind=g0.dof_kind,
        V=None, W=None, full_dof_kind=dof_kind, invariants=inv,
        interpolation=kind if slope_models is None else "cubic",
        sample_sources=tuple(dict(b.source) for b in bodies),
        sample_methods=("snapshot",) * k, sample_settings=tuple(b.settings for b in bodies),
        static=StaticDeflection.stack(states) if states else None,
    )
    if slope_models is None:
        return pb
    side = [basis_parametric_body(models, V, s + sign * float(slope_step), parameter=parameter,
                                  keep_nodes=keep_nodes, energy=energy, metric=G, W=W,
                                  static=None if slope_static is None else slope_static[j],
                                  progress=progress, projections=projections)
            for j, (models, sign) in enumerate(zip(slope_models, (-1.0, 1.0), strict=True))]
    # the derivatives keep the samples' symmetric blocks and D = G/ω_ref (samples.py)
    proportional = {}
    if pb.G is not None:
        c = 1.0 / (2.0 * np.pi * pb.loss_reference_frequency)
        proportional = {"D": ("G", c), "invariants/De.m0": ("invariants/Le.m0", c)}
    keys = pb.slope_keys()
    found = [central_slopes(side[0].stack, side[1].stack, slope_step, keys)]
    if kind == "quintic-hermite":
        found.append(central_curvatures(side[0].stack, pb.stack, side[1].stack, slope_step,
                                        keys))
    slopes, *curvatures = structured_derivatives(pb.stack, found, proportional)
    where = {"slope_step": float(slope_step),      # the sources the side bodies recorded:
             "slope_sources": tuple({"file": x["file"], "fingerprint": x["fingerprint"]}
                                    for b in side for x in b.sample_sources)}
    if kind != "quintic-hermite":
        return pb.with_(interpolation="hermite", slopes=slopes, **where)
    return pb.with_(interpolation="quintic-hermite", slopes=slopes, **where,
                    curvatures=curvatures[0])
