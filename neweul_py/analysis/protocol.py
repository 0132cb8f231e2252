"""Small helpers shared by the analysis tools.

Everything here works on a generated model (:class:`~neweul_py.analysis.module.GeneratedModel`,
the protocol of ``docs/generated-module-protocol.md``) and on plain NumPy arrays. Nothing here
knows about sympy or the symbolic layers.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from ..errors import ModelError, NeweulError
from .module import GeneratedModel

__all__ = [
    "ParameterLike",
    "constraint_reaction_jacobian",
    "name_index",
    "null_space",
    "override_vector",
    "participating_names",
    "redundant_constraints",
    "resolve_inputs",
    "resolve_parameters",
]

ParameterLike = Mapping[str, float] | Sequence[float] | np.ndarray | None

def name_index(names: Sequence[str], name: str, kind: str) -> int:
    """Position of ``name`` in ``names``; else a :class:`NeweulError` listing the valid names."""
    try:
        return list(names).index(name)
    except ValueError:
        valid = ", ".join(names) if len(names) else "(none)"
        raise NeweulError(f"unknown {kind} {name!r}; valid {kind}s: {valid}") from None


def override_vector(
    default: np.ndarray, names: Sequence[str], value: Any, kind: str
) -> np.ndarray:
    """``default`` (for None), overridden by name (mapping), or replaced (full-length sequence).

    Unknown names are an error listing the valid ``kind`` names.
    """
    if value is None:
        return default
    if isinstance(value, Mapping):
        for key, v in value.items():
            default[name_index(names, key, kind)] = float(v)
            if not np.isfinite(default[name_index(names, key, kind)]):
                raise NeweulError(f"{kind} {key} must be a finite number, got {v!r}")
        return default
    arr = np.asarray(value, dtype=float).reshape(-1)
    if arr.size != len(names):
        raise NeweulError(f"{kind} vector has {arr.size} entries, the model has {len(names)}")
    if not np.all(np.isfinite(arr)):
        raise NeweulError(f"{kind} vector must hold finite numbers")
    return arr


def resolve_parameters(model: GeneratedModel, p: ParameterLike = None) -> np.ndarray:
    """The parameter vector ``p`` (ordered as ``PARAMETERS``).

    ``None`` gives the defaults; a mapping overrides defaults by name (unknown names are an error
    listing the valid ones); a sequence must have one entry per parameter.
    """
    names = list(model.PARAMETERS)
    default = np.asarray(model.default_parameters(), dtype=float).reshape(-1).copy()
    if default.size != len(names):
        raise NeweulError(
            f"{model.MODEL_NAME}: default_parameters returns {default.size} value(s) for "
            f"{len(names)} PARAMETERS; the generated module is inconsistent (regenerate it)"
        )
    return override_vector(default, names, p, "parameter")


def resolve_inputs(
    model: GeneratedModel, t: float, p: np.ndarray,
    u: Mapping[str, float] | Sequence[float] | None,
) -> np.ndarray:
    """The input vector ``u`` at time ``t``.

    ``None`` gives ``default_inputs(t, p)``; a mapping overrides the default excitation by name;
    a sequence must have one entry per input.
    """
    names = list(model.INPUTS)
    base = np.asarray(model.default_inputs(t, p), dtype=float).reshape(-1).copy()
    if base.size != len(names):
        raise NeweulError(
            f"{model.MODEL_NAME}: default_inputs returns {base.size} value(s) for the "
            f"{len(names)} INPUTS ({', '.join(names)}); the generated module is inconsistent "
            "(regenerate it)"
        )
    return override_vector(base, names, u, "input")


def input_function(
    model: GeneratedModel,
    p: np.ndarray,
    u: Callable[[float], Any] | Mapping[str, float] | Sequence[float] | None,
) -> Callable[[float], np.ndarray]:
    """``u`` as a function of time (callables are called, constants held, None: the default)."""
    if callable(u):
        return lambda t: np.asarray(u(t), dtype=float).reshape(-1)
    if u is None:
        return lambda t: resolve_inputs(model, t, p, None)
    fixed = resolve_inputs(model, 0.0, p, u)
    return lambda t: fixed


def null_space(a: np.ndarray, rtol: float = 1e-10, scale: float = 0.0
               ) -> tuple[np.ndarray, int]:
    """Orthonormal basis of the right null space of ``a`` and the numerical rank of ``a``.

    The rank counts singular values above ``rtol`` times the largest one, or times ``scale``
    when that is larger (the size of the matrix ``a`` was reduced from: a 1 × 1 reduced mass
    of 2e-83 is zero next to a mass matrix of order 1).
    """
    a = np.atleast_2d(np.asarray(a))
    if a.size == 0:
        return np.eye(a.shape[1]), 0
    _, s, vh = np.linalg.svd(a)
    smax = max(s[0] if s.size else 0.0, scale)
    rank = int(np.sum(s > rtol * smax)) if smax > 0 else 0
    return vh[rank:].conj().T, rank


def participating_names(basis: np.ndarray, names: Sequence[str], share: float = 1e-3) -> list[str]:
    """Names of the rows of ``basis`` (columns: null-space vectors) that take part in it.

    A row takes part when its norm is at least ``share`` times the largest row norm.
    """
    if basis.size == 0:
        return []
    rows = np.linalg.norm(basis, axis=1)
    top = rows.max()
    return [n for n, r in zip(names, rows, strict=True) if top > 0 and r >= share * top]


def redundant_constraints(
    g_jac: np.ndarray, names: Sequence[str], rtol: float = 1e-10
) -> list[str]:
    """Describe the constraints whose Jacobian rows depend on the others (rank analysis of G).

    QR with column pivoting of ``Gᵀ`` picks a maximal independent set of rows of ``G``; every other
    row is reported with the rows it is a combination of.

    Returns
    -------
    list of str
        One entry per redundant constraint, e.g. ``"c3 (= combination of c1, c2)"``; empty when
        ``G`` has full row rank.
    """
    g_jac = np.atleast_2d(g_jac)
    nc = g_jac.shape[0]
    if nc == 0:
        return []
    import scipy.linalg as sla  # ~0.2 s of import: only here

    _, r, piv = sla.qr(g_jac.T, mode="economic", pivoting=True)
    diag = np.abs(np.diag(r))
    rank = int(np.sum(diag > rtol * diag[0])) if diag.size and diag[0] > 0 else 0
    if rank == nc:
        return []
    indep = piv[:rank]
    report = []
    for row in piv[rank:]:
        if rank == 0:
            report.append(f"{names[row]} (zero Jacobian row)")
            continue
        coef, *_ = np.linalg.lstsq(g_jac[indep].T, g_jac[row], rcond=None)
        big = np.abs(coef) > 1e-8 * max(np.abs(coef).max(), 1e-300)
        partners = [names[i] for i, b in zip(indep, big, strict=True) if b]
        if partners:
            report.append(f"{names[row]} (= combination of {', '.join(partners)})")
        else:
            report.append(f"{names[row]} (zero Jacobian row)")
    return report


def check_mass_matrix(m: np.ndarray, names: Sequence[str], basis: np.ndarray | None = None,
                      left: np.ndarray | None = None) -> None:
    """Raise :class:`ModelError` naming the coordinates without inertia when ``M`` is singular.

    With ``basis`` (columns spanning the admissible motions, e.g. the null space of ``G``), the
    check is made for ``leftᵀ M basis`` (``left``: the test directions free of reactions, the
    null space of the reaction Jacobian ``G_R``; default ``basis``): a coordinate may be
    massless if the constraints fix it. The augmented matrix ``[M −G_Rᵀ; G 0]`` is regular
    exactly when ``G``, ``G_R`` have full row rank and this matrix is regular. Unsymmetric
    matrices (and those with their own test directions) are equilibrated
    (:func:`equilibrated`) before the rank test.
    """
    if basis is not None and left is not None and left.shape != basis.shape:
        raise ModelError(
            "the constraint reactions are linearly dependent (rank of the reaction Jacobian "
            f"G_R: {m.shape[0] - left.shape[1]}, of G: {m.shape[0] - basis.shape[1]})"
        )
    scaled = left is not None and left is not basis
    left = basis if left is None else left
    mr = m if basis is None else left.T @ m @ basis
    if mr.size == 0:
        return
    scale = float(np.abs(m).max(initial=0.0)) if basis is not None else 0.0
    if scaled or not np.array_equal(m, m.T):
        # test directions of their own, or two-sided elastic data (left and right bases
        # scaled independently): rows and columns may be scaled very differently
        mr, scale = equilibrated(mr), 0.0
    # relative to M itself where the bases are orthonormal (Vᵀ M V of a massless motion is
    # round-off of M's size, not zero)
    ns, _ = null_space(mr, rtol=1e-12, scale=scale)
    if ns.shape[1]:
        motions = ns if basis is None else basis @ ns
        who = participating_names(motions, names)
        raise ModelError(
            "singular mass matrix: no inertia in the motion of coordinate(s) " + ", ".join(who)
        )


def equilibrated(a: np.ndarray, sweeps: int = 30) -> np.ndarray:
    """``D_r a D_c`` with positive diagonal ``D_r``, ``D_c`` such that every nonzero row and
    column has largest magnitude ≈ 1 (Ruiz's iteration, SIAM J. Matrix Anal. Appl. 2001 /
    RAL-TR-2001-034), so that a rank test does not mistake the scales of the rows (equations)
    and columns (coordinates) for a near-singularity. Zero rows and columns stay zero."""
    a = np.array(a, dtype=float)
    for _ in range(sweeps):
        r = np.abs(a).max(axis=1)
        c = np.abs(a).max(axis=0)
        r[r == 0] = 1.0
        c[c == 0] = 1.0
        if max(np.abs(r - 1).max(initial=0.0), np.abs(c - 1).max(initial=0.0)) < 1e-3:
            break
        a = a / np.sqrt(r)[:, None] / np.sqrt(c)[None, :]
    return a


def constraint_reaction_jacobian(model: GeneratedModel, t: float, y: np.ndarray,
                                 p: np.ndarray) -> np.ndarray:
    """``G_R`` (nc, n) of the constraint reactions ``G_Rᵀ λ``: the module's
    ``constraint_reaction_jacobian`` where it has one, else ``G = constraint_jacobian``.

    The two differ only for constraints on node frames of two-sided elastic bodies: the
    constraint ``g``, ``G ẏ``, ``γ`` moves with the right basis (``G = G_s S_V``), the reactions
    enter the elastic equation rows through the left one (``G_R = G_s S_W``; equations.md §2,
    docs/generated-module-protocol.md). Modules without the function (rigid models, modules
    written before it existed) have ``G_R = G``.
    """
    fn = model.constraint_reaction_jacobian or model.constraint_jacobian
    return np.asarray(fn(t, y, p), dtype=float).reshape(-1, y.size)


def constraint_force_jacobian(
    model: GeneratedModel, t: float, y: np.ndarray, p: np.ndarray, lam: np.ndarray
) -> np.ndarray:
    """``∂(G_R(y)ᵀ λ)/∂y`` at fixed ``λ`` (equations.md §1), by central differences of the
    analytic reaction Jacobian ``G_R`` (:func:`constraint_reaction_jacobian`; ``G`` for
    modules without one).

    The protocol offers ``G_R`` but not its derivative; differencing the analytic ``G_R`` costs
    ``2n`` evaluations and is accurate to about ``1e-10`` relative.
    """
    n = y.size
    out = np.empty((n, n))
    for j in range(n):
        h = 1e-6 * max(1.0, abs(y[j]))
        yp = y.copy()
        ym = y.copy()
        yp[j] += h
        ym[j] -= h
        gp = constraint_reaction_jacobian(model, t, yp, p)
        gm = constraint_reaction_jacobian(model, t, ym, p)
        out[:, j] = (gp - gm).T @ lam / (2 * h)
    return out


def constraint_time_derivative(model: GeneratedModel, t: float, y: np.ndarray,
                               p: np.ndarray) -> np.ndarray:
    """``∂g/∂t`` at ``(t, y)``.

    Uses the module's ``constraint_time_derivative`` when it has one; otherwise a central
    difference of ``constraints`` in ``t`` (exactly zero for scleronomic constraints).
    """
    if model.constraint_time_derivative is not None:
        return np.asarray(model.constraint_time_derivative(t, y, p), dtype=float)
    h = 1e-5 * max(1.0, abs(t))
    gp = np.asarray(model.constraints(t + h, y, p), dtype=float)
    gm = np.asarray(model.constraints(t - h, y, p), dtype=float)
    return (gp - gm) / (2 * h)


def augmented_solve(
    m: np.ndarray, g_jac: np.ndarray, force: np.ndarray, c_rhs: np.ndarray,
    reaction: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Accelerations and multipliers from ``M ÿ = F + G_Rᵀ λ``, ``G ÿ = c`` (equations.md §1).

    ``reaction`` is the reaction Jacobian ``G_R`` (:func:`constraint_reaction_jacobian`;
    ``None``: ``G_R = G``).

    Returns
    -------
    ydd, lam
        ``ÿ`` (n,) and ``λ`` (nc,).
    """
    n = m.shape[0]
    nc = g_jac.shape[0]
    if nc == 0:
        return np.linalg.solve(m, force), np.zeros(0)
    kkt = np.zeros((n + nc, n + nc))
    kkt[:n, :n] = m
    kkt[:n, n:] = -(g_jac if reaction is None else reaction).T
    kkt[n:, :n] = g_jac
    sol = np.linalg.solve(kkt, np.concatenate([force, c_rhs]))
    return sol[:n], sol[n:]


def project_onto_constraints(
    g: Callable[[np.ndarray], np.ndarray],
    g_jac: Callable[[np.ndarray], np.ndarray],
    y: np.ndarray,
    tol: float,
    *,
    moved: np.ndarray | None = None,
    winv: np.ndarray | None = None,
    maxiter: int = 30,
) -> tuple[np.ndarray, np.ndarray]:
    """Move ``y`` onto ``g(y) = 0`` (equations.md §1, drift control): Gauss–Newton steps of
    least change ``Δ = W⁻¹ Gᵀ (G W⁻¹ Gᵀ)⁻¹ g`` in the metric ``W`` (``winv`` = ``W⁻¹``,
    identity by default) on the coordinates ``moved`` (all by default); with a square block
    ``G[:, moved]`` this is Newton's method on the dependent coordinates (coordinate
    partitioning). Returns the last finite iterate and its ``g``: the caller decides whether
    a remaining residual above ``tol`` is an error."""
    y = np.array(y, dtype=float)
    idx = np.arange(y.size) if moved is None else np.asarray(moved, dtype=int)
    gv = np.asarray(g(y), dtype=float)
    for _ in range(maxiter):
        if np.abs(gv).max(initial=0.0) <= tol:
            break
        gj = np.asarray(g_jac(y), dtype=float)[:, idx]
        w = np.eye(idx.size) if winv is None else winv
        try:
            step = w @ gj.T @ np.linalg.solve(gj @ w @ gj.T, gv)
        except np.linalg.LinAlgError:
            break
        if not np.all(np.isfinite(step)):
            break
        y[idx] -= step
        gv = np.asarray(g(y), dtype=float)
    return y, gv


def partition(
    g_jac: np.ndarray, names: Sequence[str], independent: Sequence[str] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Split the coordinates into independent and dependent ones for the constraints ``G``.

    Parameters
    ----------
    g_jac
        ``G = ∂g/∂y`` (nc, n) with full row rank.
    names
        Coordinate names.
    independent
        Names to keep independent. ``None`` keeps the *first* coordinates independent where
        possible: dependent ones are taken from the end of the list whenever they raise the rank
        of the chosen columns of ``G`` (coordinate partitioning).

    Returns
    -------
    indep, dep
        Index arrays (in coordinate order).
    """
    n = g_jac.shape[1]
    nc = g_jac.shape[0]
    if independent is not None:
        ind = sorted({name_index(names, nm, "coordinate") for nm in independent})
        dep = [j for j in range(n) if j not in ind]
        if len(dep) != nc or (nc and np.linalg.matrix_rank(g_jac[:, dep]) < nc):
            raise NeweulError(
                f"independent coordinates {', '.join(independent)} do not fix the others: "
                f"{nc} constraint(s) need {nc} dependent coordinate(s) with a regular "
                "constraint Jacobian block"
            )
        return np.array(ind, dtype=int), np.array(dep, dtype=int)
    scale = max(np.abs(g_jac).max(), 1e-300) if g_jac.size else 1.0

    def greedy(rtol: float) -> list[int]:
        chosen: list[int] = []
        for j in range(n - 1, -1, -1):
            if len(chosen) == nc:
                break
            trial = [*chosen, j]
            if np.linalg.svd(g_jac[:, trial], compute_uv=False)[-1] > rtol * scale:
                chosen = trial
        return chosen

    # Well-conditioned dependent blocks first: a coordinate whose G column is tiny (e.g. an
    # elastic mode coordinate, Φ_P q with small mode amplitudes) would make δy_dep = −G_dep⁻¹
    # G_indep δy_indep amplify round-off and difference errors by 1/σ_min.
    dep = greedy(1e-3)
    if len(dep) < nc:
        dep = greedy(1e-8)
    if len(dep) < nc:
        raise NeweulError("constraint Jacobian has deficient rank; cannot partition coordinates")
    dep_arr = np.array(sorted(dep), dtype=int)
    ind_arr = np.array([j for j in range(n) if j not in dep], dtype=int)
    return ind_arr, dep_arr


def partition_basis(g_jac: np.ndarray, indep: np.ndarray, dep: np.ndarray) -> np.ndarray:
    """Basis ``N`` (n, n − nc) of admissible motions ``δy = N δy_indep`` with ``G N = 0``."""
    n = g_jac.shape[1]
    basis = np.zeros((n, indep.size))
    basis[indep, np.arange(indep.size)] = 1.0
    if dep.size:
        basis[dep] = -np.linalg.solve(g_jac[:, dep], g_jac[:, indep])
    return basis


def reaction_free_basis(g_reaction: np.ndarray, g_jac: np.ndarray, indep: np.ndarray,
                        dep: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """Test directions ``N_R`` (n, n − nc) free of the reactions, ``G_R N_R = 0``.

    Projecting ``M ÿ = F + G_Rᵀ λ`` with ``N_Rᵀ`` eliminates ``λ``. Where ``G_R = G`` this is
    ``basis`` itself (:func:`partition_basis` of ``G``); otherwise the same partition
    (``N_R[indep] = I``) when ``G_R[:, dep]`` is well conditioned, else an orthonormal basis
    of the null space of ``G_R``. Any choice gives the same motions (a regular combination
    of the projected equations).
    """
    if g_reaction.shape == g_jac.shape and np.array_equal(g_reaction, g_jac):
        return basis
    if dep.size and np.linalg.cond(g_reaction[:, dep]) < 1e8:
        return partition_basis(g_reaction, indep, dep)
    ns, rank = null_space(g_reaction)
    if rank < g_reaction.shape[0]:
        raise ModelError(
            f"the constraint reactions are linearly dependent (rank of the reaction Jacobian "
            f"G_R: {rank} < {g_reaction.shape[0]} constraints)"
        )
    return ns
