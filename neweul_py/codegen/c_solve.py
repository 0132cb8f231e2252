"""The linear solve ``M ẍ = f`` of the compiled backend, shaped by the mass matrix's structure.

:func:`c_solver` writes ``nw_solve1(a, b)`` (``a``: the row-major ``n × n`` mass matrix,
destroyed; ``b``: the right-hand side, overwritten by the solution; the ``rhs``'s) or
``nw_factor(a, f)`` and ``nw_factored_solve(a, f, m, b)`` (``b``: ``n × m`` right-hand sides;
one factorization for the two solves of ``rhs_jacobian``) for :mod:`.c_module`, in one of
two forms:

* **dense LU** with partial pivoting of the whole matrix (``nw_lu``/``nw_lu_solve`` of
  :mod:`.c_templates`), ``n³/3`` operations;
* **block elimination** when a set ``E`` of coordinates has a *numeric* (constant) block
  ``D = M[E, E]`` (:func:`constant_block`) — the elastic coordinates of a floating-frame body
  without stress stiffening, whose ``Mee`` is a constant of the reduced-body data
  (docs/equations.md §2). With ``R`` the other coordinates, ``B = M[R, E]``, ``C = M[E, R]``,
  the Schur complement ``S = M[R, R] − B D⁻¹ C`` gives (Golub & Van Loan, *Matrix
  Computations*, §3.2.10, block LU)

  ``S x_R = f_R − B D⁻¹ f_E``,  ``x_E = D⁻¹ (f_E − C x_R)``,

  with ``D⁻¹`` computed once at generation time (``numpy.linalg.inv``) and stored sparse, so a
  call costs ``nnz(D⁻¹)·(|R| + m) + |R|·|E|·(|R| + m)`` operations and the LU of ``S`` only
  (20 modes on two rigid coordinates: ≈ 300 against ≈ 3 500 for the dense LU). Off-diagonal
  entries of ``D⁻¹`` below ``n·ε`` times the geometric mean of their row's and column's
  diagonal entries are dropped (:func:`negligible`: below the rounding error of the product;
  for the mass-normalized modes of a modal body ``D = I + O(ε)`` and ``D⁻¹`` is then
  diagonal — with the earlier rule ``ε·max|D⁻¹|`` its 3e-16 entries stayed and tripled the
  work).

Both forms solve unsymmetric matrices (two-sided bodies); a zero pivot of the dense LU or of
the LU of ``S`` returns 1 (singular matrix).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp

from ..ffrf import MAX_BLOCK_CONDITION

__all__ = ["MIN_BLOCK", "ConstantBlock", "c_solver", "constant_block", "negligible"]

#: Smallest constant block eliminated (a single constant entry gains nothing).
MIN_BLOCK = 2


@dataclass(frozen=True)
class ConstantBlock:
    """A constant diagonal block of the mass matrix and its (sparse) inverse.

    Attributes
    ----------
    rest, block
        The indices ``R`` and ``E`` (ascending; together ``0 … n − 1``).
    inverse
        ``D⁻¹`` (``|E| × |E|``), the entries :func:`negligible` names set to zero.
    """

    rest: tuple[int, ...]
    block: tuple[int, ...]
    inverse: np.ndarray


def constant_block(mass_matrix: sp.MatrixBase) -> ConstantBlock | None:
    """The largest set ``E`` (greedy in index order) of coordinates whose block
    ``M[E, E]`` holds numbers only, with its inverse; ``None`` when it is smaller than
    :data:`MIN_BLOCK`, singular or worse conditioned than
    :data:`~neweul_py.ffrf.splice.MAX_BLOCK_CONDITION` (``1e4``, the threshold of the NumPy
    kernel's elimination too: the explicit inverse is not backward stable, its error grows
    like ``cond(D)``)."""
    n = mass_matrix.shape[0]
    block: list[int] = []
    for j in range(n):
        if all(mass_matrix[i, j].is_Number and mass_matrix[j, i].is_Number
               for i in (*block, j)):
            block.append(j)
    if len(block) < MIN_BLOCK:
        return None
    d = np.array([[float(mass_matrix[i, j]) for j in block] for i in block])
    if not np.all(np.isfinite(d)) or np.linalg.cond(d) > MAX_BLOCK_CONDITION:
        return None
    inv = np.linalg.inv(d)
    inv[negligible(inv)] = 0.0
    rest = tuple(j for j in range(n) if j not in set(block))
    return ConstantBlock(rest, tuple(block), inv)


def negligible(inv: np.ndarray) -> np.ndarray:
    """The off-diagonal entries of an inverse ``X = D⁻¹`` (``n × n``) with
    ``|X_ij| ≤ n·ε·√(|X_ii| |X_jj|)``: in the symmetrically scaled coordinates
    ``X̃ = S X S``, ``S = diag(|X_ii|)^{-1/2}``, dropping them changes ``X̃ b`` by at most
    ``n²ε`` relative to the diagonal's part — the rounding error of the product itself (Higham,
    *Accuracy and Stability of Numerical Algorithms*, 2nd ed., §3.5); the rule does not depend
    on a symmetric scaling ``D → S D S`` (badly scaled blocks keep their entries), but a
    two-sided one ``S₁ D S₂`` (unsymmetric blocks) changes it by ``√(s₁ᵢ s₂ⱼ / (s₂ᵢ s₁ⱼ))``. For
    ``D = I + O(ε)`` (the ``Mee`` of mass-normalized modes) the inverse becomes diagonal."""
    a = np.abs(inv)
    d = np.sqrt(np.outer(np.diag(a), np.diag(a)))
    out = a <= inv.shape[0] * np.finfo(float).eps * d
    np.fill_diagonal(out, False)
    return out


def _ints(values) -> str:
    return "{" + ", ".join(str(int(v)) for v in values) + "}"


def _doubles(values) -> str:
    return "{" + ", ".join(repr(float(v)) for v in values) + "}"


_DENSE = """
/* ---- M x = b: dense LU of the whole mass matrix */
typedef struct {{ int piv[NW_N]; }} nw_fac;
{solve}"""

#: ``nw_solve1`` of the dense LU (the right-hand side of ``rhs``).
_DENSE_SOLVE1 = """
static int nw_solve1(double *a, double *b)
{
    int piv[NW_N];
    if (nw_lu(NW_N, a, piv)) return 1;
    nw_lu_solve(NW_N, a, piv, 1, b);
    return 0;
}
"""

#: ``nw_factor``/``nw_factored_solve`` of the dense LU (``rhs_jacobian``: one factorization
#: for its two solves).
_DENSE_FACTORED = """
static int nw_factor(double *a, nw_fac *f) { return nw_lu(NW_N, a, f->piv); }

static void nw_factored_solve(const double *a, const nw_fac *f, int m, double *b)
{
    nw_lu_solve(NW_N, a, f->piv, m, b);
}
"""

_BLOCK = """
/* ---- M x = b by block elimination of the constant block D = M[E, E] (codegen/c_solve.py):
   S = M[R,R] - M[R,E] D^-1 M[E,R];  S x_R = b_R - M[R,E] D^-1 b_E;  x_E = D^-1 (b_E - M[E,R] x_R);
   NW_IE(e), NW_IR(r): the coordinates of E and R; D^-1 {dform} */
#define NW_NR {nr}
#define NW_NE {ne}
{decls}
/* y (NW_NE x k, row-major) = D^-1 x, x[e] = src[NW_IE(e) * stride + c] for the columns c < k */
__attribute__((always_inline, optimize("O3"))) static inline void nw_dinv(
    int k, const double *src, int stride, double *y)
{{
{dinv}}}

/* the factorization: X = D^-1 M[E,R] and the LU of S (a is only read) */
typedef struct {{ double X[NW_NE * NW_NR + 1], S[NW_NR * NW_NR + 1]; int piv[NW_NR + 1]; }} nw_fac;

__attribute__((always_inline, optimize("O3"))) static inline int nw_block_factor(
    const double *a, nw_fac *f)
{{
{factor_code}}}

/* the solve for m right-hand sides with the factorization; its loops over E vectorized by
   gcc's -O3 (the libraries build with -O1) */
__attribute__((always_inline, optimize("O3"))) static inline void nw_block_apply(
    const double *a, const nw_fac *f, int m, double *b)
{{
    double z[NW_NE * m];
    nw_dinv(m, b, m, z);                                   /* z = D^-1 b_E */
{apply_code}    for (int e = 0; e < NW_NE; ++e)
        for (int c = 0; c < m; ++c) b[NW_IE(e) * m + c] = z[e * m + c];
}}
{solve}"""

#: ``nw_solve1`` of the block elimination: factorization and solve inlined with ``m = 1``.
_BLOCK_SOLVE1 = """
__attribute__((optimize("O3"))) static int nw_solve1(double *a, double *b)
{
    nw_fac f;
    if (nw_block_factor(a, &f)) return 1;
    nw_block_apply(a, &f, 1, b);
    return 0;
}
"""

_BLOCK_FACTORED = """
__attribute__((optimize("O3"))) static int nw_factor(double *a, nw_fac *f)
{
    return nw_block_factor(a, f);
}

__attribute__((optimize("O3"))) static void nw_factored_solve(const double *a, const nw_fac *f,
                                                              int m, double *b)
{
    nw_block_apply(a, f, m, b);
}
"""

#: ``D⁻¹`` applied as a diagonal (``NW_DD``) or in compressed rows (``NW_DP``, ``NW_DJ``,
#: ``NW_DV``).
_DINV_DIAGONAL = """\
    for (int e = 0; e < NW_NE; ++e)
        for (int c = 0; c < k; ++c) y[e * k + c] = NW_DD[e] * src[NW_IE(e) * stride + c];
"""

_DINV_SPARSE = """\
    for (int e = 0; e < NW_NE; ++e)
        for (int c = 0; c < k; ++c) {
            double s = 0.0;
            for (int i = NW_DP[e]; i < NW_DP[e + 1]; ++i)
                s += NW_DV[i] * src[NW_IE(NW_DJ[i]) * stride + c];
            y[e * k + c] = s;
        }
"""

#: :func:`nw_block_factor`'s body when ``R`` is not empty.
_FACTOR_CODE = """\
    nw_dinv(NW_NR, a + NW_IR(0), NW_N, f->X);  /* X = D^-1 M[E,R] (R contiguous) */
    for (int r = 0; r < NW_NR; ++r) {
        const double *row = a + NW_IR(r) * NW_N;
        for (int q = 0; q < NW_NR; ++q) {                  /* S = M[R,R] - M[R,E] X */
            double s = row[NW_IR(q)];
            for (int e = 0; e < NW_NE; ++e) s -= row[NW_IE(e)] * f->X[e * NW_NR + q];
            f->S[r * NW_NR + q] = s;
        }
    }
    return nw_lu(NW_NR, f->S, f->piv);
"""

#: ``X = D⁻¹ M[E, R]`` when ``R`` is not one contiguous range (columns one by one).
_X_SCATTERED = """\
    for (int r = 0; r < NW_NR; ++r) {                  /* X = D^-1 M[E,R], column by column */
        double xr[NW_NE];
        nw_dinv(1, a + NW_IR(r), NW_N, xr);
        for (int e = 0; e < NW_NE; ++e) f->X[e * NW_NR + r] = xr[e];
    }
"""

#: :func:`nw_block_apply`'s part for ``R`` when it is not empty.
_APPLY_CODE = """\
    double g[NW_NR * m];
    for (int r = 0; r < NW_NR; ++r) {
        const double *row = a + NW_IR(r) * NW_N;
        for (int c = 0; c < m; ++c) {                      /* g = b_R - M[R,E] z */
            double s = b[NW_IR(r) * m + c];
            for (int e = 0; e < NW_NE; ++e) s -= row[NW_IE(e)] * z[e * m + c];
            g[r * m + c] = s;
        }
    }
    nw_lu_solve(NW_NR, f->S, f->piv, m, g);                /* x_R */
    for (int e = 0; e < NW_NE; ++e)                        /* x_E = z - X x_R */
        for (int c = 0; c < m; ++c) {
            double s = z[e * m + c];
            for (int r = 0; r < NW_NR; ++r) s -= f->X[e * NW_NR + r] * g[r * m + c];
            z[e * m + c] = s;
        }
    for (int r = 0; r < NW_NR; ++r)
        for (int c = 0; c < m; ++c) b[NW_IR(r) * m + c] = g[r * m + c];
"""


def _index_macro(name: str, var: str, idx: tuple[int, ...]) -> tuple[str, str]:
    """``#define name(var)`` as ``first + var`` for a contiguous ascending range, else a
    table look-up (``(define, table declaration)``)."""
    if idx and idx == tuple(range(idx[0], idx[0] + len(idx))):
        return f"#define {name}({var}) ({idx[0]} + ({var}))", ""
    table = f"NW_{name[3:]}T"
    return (f"#define {name}({var}) ({table}[{var}])",
            f"static const int {table}[{max(len(idx), 1)}] = {_ints(idx or (0,))};")


def c_solver(block: ConstantBlock | None, factored: bool = False) -> str:
    """The C text of the solve of ``M x = b`` (module docstring): ``static int
    nw_solve1(double *a, double *b)`` (one right-hand side, the ``rhs``'s; ``a`` destroyed)
    or, with ``factored``, ``static int nw_factor(double *a, nw_fac *f)`` and ``static void
    nw_factored_solve(const double *a, const nw_fac *f, int m, double *b)`` (one
    factorization for several solves: ``rhs_jacobian``; ``a`` is kept for the second); it
    uses ``nw_lu``/``nw_lu_solve`` and the macro ``NW_N``. The coordinates ``E``, ``R`` are
    offsets when contiguous, ``D⁻¹`` a diagonal when it has no other entries, and the solve
    for one right-hand side is the same loops with ``m = 1`` inlined (a 20-mode beam on two
    rigid coordinates: 5 600 instructions per solve → about 1 200)."""
    if block is None:
        return _DENSE.format(solve=_DENSE_FACTORED if factored else _DENSE_SOLVE1)
    inv = block.inverse
    ie, ie_table = _index_macro("NW_IE", "e", block.block)
    decls = [ie, ie_table]
    if np.count_nonzero(inv - np.diag(np.diag(inv))) == 0:
        dform = "diagonal (NW_DD)"
        decls.append(f"static const double NW_DD[NW_NE] = {_doubles(np.diag(inv))};")
        dinv = _DINV_DIAGONAL
    else:
        dform = "in compressed rows (NW_DP, NW_DJ, NW_DV)"
        rows = [np.flatnonzero(inv[e]) for e in range(inv.shape[0])]
        dp = np.cumsum([0, *(len(r) for r in rows)])
        dj = np.concatenate(rows)
        dv = np.concatenate([inv[e, r] for e, r in enumerate(rows)])
        decls += [f"static const int NW_DP[NW_NE + 1] = {_ints(dp)};",
                  f"static const int NW_DJ[{int(dp[-1])}] = {_ints(dj)};",
                  f"static const double NW_DV[{int(dp[-1])}] = {_doubles(dv)};"]
        dinv = _DINV_SPARSE
    factor_code, apply_code = "    (void)a; (void)f;\n    return 0;\n", "    (void)f;\n"
    if block.rest:
        ir, ir_table = _index_macro("NW_IR", "r", block.rest)
        decls += [ir, ir_table]
        factor_code, apply_code = _FACTOR_CODE, _APPLY_CODE
        if ir_table:
            factor_code = _X_SCATTERED + factor_code.split("\n", 1)[1]
    return _BLOCK.format(nr=len(block.rest), ne=len(block.block), dform=dform,
                         decls="\n".join(d for d in decls if d), dinv=dinv,
                         factor_code=factor_code, apply_code=apply_code,
                         solve=_BLOCK_FACTORED if factored else _BLOCK_SOLVE1)
