"""The fixed C helpers that printed kernels call (:mod:`.c_kernel`).

:data:`C_DOT`: the products ``y = A x``, ``y = x B``, ``C = A B`` with strides, and ``C = A B``
with a block added in the same pass (the rows of ``A x`` in eight partial sums,
:data:`.c_templates.C_DOT8`; a zero entry of ``x`` — the weights of mixed samples — and a
zero row of ``A`` skipped).
:data:`C_MIX`: the compact mixing of a parametric body's samples
(:func:`~neweul_py.ffrf.parametric.ffrf_mix`), by blocks of columns.
"""

from __future__ import annotations

from .c_templates import C_CLONES, C_DOT8

__all__ = ["C_DOT", "C_MIX"]

#: Products of the printed kernels (real operands; the strides are in elements).
C_DOT = C_CLONES + C_DOT8 + r"""
/* ---- products of the traced kernel (codegen/c_kernel_text.py): y = A x, y = x B, C = A B with
   strides; contiguous rows of A in the eight partial sums of nw_dot8; a zero entry of x
   (weights of mixed samples) and a zero row of A are skipped */
__attribute__((optimize("O3"))) NW_CLONES static void nw_gemv(int m, int k,
    const double *restrict A, long sa, long sk, const double *restrict x, long sx,
    double *restrict y)
{
    for (int i = 0; i < m; ++i) {
        const double *a = A + i * sa;
        if (sk == 1 && sx == 1) {
            y[i] = nw_dot8(k, a, x);
            continue;
        }
        double s0 = 0.0;
        for (int j = 0; j < k; ++j) s0 += a[j * sk] * x[j * sx];
        y[i] = s0;
    }
}

__attribute__((optimize("O3"))) NW_CLONES static void nw_vecmat(int k, int n,
    const double *restrict x, long sx, const double *restrict B, long sb, long sn,
    double *restrict y)
{
    int nz[4], m = 0, i = 0;
    for (int j = 0; j < n; ++j) y[j] = 0.0;
    while (i < k) {             /* the nonzero rows four at a time: y is passed once per four */
        for (m = 0; i < k && m < 4; ++i)
            if (x[i * sx] != 0.0) nz[m++] = i;
        if (m == 4 && sn == 1) {
            const double x0 = x[nz[0] * sx], x1 = x[nz[1] * sx], x2 = x[nz[2] * sx],
                         x3 = x[nz[3] * sx];
            const double *b0 = B + nz[0] * sb, *b1 = B + nz[1] * sb, *b2 = B + nz[2] * sb,
                         *b3 = B + nz[3] * sb;
            for (int j = 0; j < n; ++j)
                y[j] += (x0 * b0[j] + x1 * b1[j]) + (x2 * b2[j] + x3 * b3[j]);
            continue;
        }
        for (int r = 0; r < m; ++r) {
            const double xi = x[nz[r] * sx], *b = B + nz[r] * sb;
            if (sn == 1) for (int j = 0; j < n; ++j) y[j] += xi * b[j];
            else for (int j = 0; j < n; ++j) y[j] += xi * b[j * sn];
        }
    }
}

/* C = A B, then s X (s = 1 or -1) added to its block of rows r0 ... r0 + nr - 1 and columns
   c0 ... c0 + nc - 1, in one pass: a zero row of A gives zeros and the block's row */
__attribute__((optimize("O3"))) static void nw_gemm_add(int m, int n, int k,
    const double *restrict A, long sa, long sk, const double *restrict B, long sb, long sn,
    double *restrict C, int r0, int nr, int c0, int nc, const double *restrict X, long sxr,
    long sxc, double s)
{
    for (int i = 0; i < m; ++i) {
        double *c = C + (long)i * n;
        int nz = 0;
        for (int j = 0; j < k && !nz; ++j) nz = A[i * sa + j * sk] != 0.0;
        if (i < r0 || i >= r0 + nr) {
            if (nz) nw_vecmat(k, n, A + i * sa, sk, B, sb, sn, c);
            else memset(c, 0, (size_t)n * sizeof(double));
            continue;
        }
        const double *x = X + (long)(i - r0) * sxr;
        if (nz) {
            nw_vecmat(k, n, A + i * sa, sk, B, sb, sn, c);
            for (int j = 0; j < nc; ++j) c[c0 + j] += s * x[j * sxc];
        } else {
            memset(c, 0, (size_t)c0 * sizeof(double));
            for (int j = 0; j < nc; ++j) c[c0 + j] = 0.0 + s * x[j * sxc];
            memset(c + c0 + nc, 0, (size_t)(n - c0 - nc) * sizeof(double));
        }
    }
}

/* C = A B (a zero row of A, S_W^T of rigid coordinates: zeros) */
static void nw_gemm(int m, int n, int k, const double *restrict A, long sa, long sk,
                    const double *restrict B, long sb, long sn, double *restrict C)
{
    nw_gemm_add(m, n, k, A, sa, sk, B, sb, sn, C, 0, 0, 0, 0, NULL, 0, 0, 0.0);
}
"""


#: The compact mixing of a parametric body's samples (op ``"mix"`` of
#: :class:`~.c_splice_trace.MixedColumns`; :func:`~neweul_py.ffrf.parametric.ffrf_mix`): the
#: varying columns ``lo … hi − 1`` of ``V`` (k, nv) mixed by ``x`` (the zero weights
#: skipped), set at their positions ``index[c] − i0`` of ``out`` and the mirrored entries
#: ``mirror[q] − i0`` from ``mirror[m + q] − i0``; the index tables are bound float64 arrays.
#: A plan made once per binding (``nw_mix_plan``) sets each column's mirrored entry with the
#: column itself, as int positions; where the tables do not allow it (positions not
#: increasing, an entry mirrored twice) the mirrored entries are copied after, as
#: ``ffrf_derived`` does. The caller sets ``(x·r) base`` first (the entries that do not vary).
C_MIX = r"""
/* ---- the compact mixing of a parametric body's samples (codegen/c_kernel_text.py, C_MIX);
   columns by blocks of NW_MIXB, so that the mixed block is scattered while in cache */
#define NW_MIXB 512
#ifndef NW_MIX_PLAN
#define NW_MIX_PLAN 1           /* 0: the mirrored entries always copied after (a test's) */
#endif
typedef struct { long bound; int ok; int *plan; } nw_mixplan;

/* the plan of a mixing, per varying column c: its position plan[2c] and that of its mirrored
   entry plan[2c + 1] (-1: none); 0 (the mirrored entries copied after) unless the positions
   increase and every mirrored entry comes from its own column of lo ... hi - 1 */
static int nw_mix_plan(long lo, long hi, const double *restrict index,
                       const double *restrict mirror, long m, long mlo, long mhi, long i0,
                       int *restrict plan)
{
    if (hi <= lo) return mlo >= mhi;
    for (long c = lo; c < hi; ++c) {
        if (c > lo && !(index[c] > index[c - 1])) return 0;
        plan[2 * (c - lo)] = (int)((long)index[c] - i0);
        plan[2 * (c - lo) + 1] = -1;
    }
    for (long q = mlo; q < mhi; ++q) {
        const double src = mirror[m + q];
        long a = lo, b = hi;                            /* bisection: index[a] <= src */
        while (b - a > 1) {
            const long h = a + (b - a) / 2;
            if (index[h] <= src) a = h; else b = h;
        }
        if (index[a] != src || plan[2 * (a - lo) + 1] >= 0) return 0;
        plan[2 * (a - lo) + 1] = (int)((long)mirror[q] - i0);
    }
    return 1;
}

__attribute__((optimize("O3"))) static void nw_mix(int k, const double *restrict x,
    const double *restrict V, long nv, long lo, long hi, const double *restrict index,
    const double *restrict mirror, long m, long mlo, long mhi, long i0, double *restrict out,
    nw_mixplan *P, long bound)
{
    double tmp[NW_MIXB];
    if (P->bound != bound) {
        P->ok = NW_MIX_PLAN && nw_mix_plan(lo, hi, index, mirror, m, mlo, mhi, i0, P->plan);
        P->bound = bound;
    }
    for (long b = lo; b < hi; b += NW_MIXB) {
        const long e = hi - b < NW_MIXB ? hi : b + NW_MIXB;
        nw_vecmat(k, (int)(e - b), x, 1, V + b, nv, 1, tmp);
        if (P->ok) {
            const int *restrict pl = P->plan + 2 * (b - lo);
            for (long c = 0; c < e - b; ++c) {
                out[pl[2 * c]] = tmp[c];
                if (pl[2 * c + 1] >= 0) out[pl[2 * c + 1]] = tmp[c];
            }
        } else {
            for (long c = b; c < e; ++c) out[(long)index[c] - i0] = tmp[c - b];
        }
    }
    if (!P->ok)
        for (long q = mlo; q < mhi; ++q)
            out[(long)mirror[q] - i0] = out[(long)mirror[m + q] - i0];
}

/* the same for complex weights (the complex step in sigma): real and imaginary parts */
__attribute__((optimize("O3"))) static void nw_mixz(int k, const double complex *restrict x,
    const double *restrict V, long nv, long lo, long hi, const double *restrict index,
    const double *restrict mirror, long m, long mlo, long mhi, long i0,
    double complex *restrict out, nw_mixplan *P, long bound)
{
    double xr[NW_NW + 1], xi[NW_NW + 1], tr[NW_MIXB], ti[NW_MIXB];
    if (P->bound != bound) {
        P->ok = NW_MIX_PLAN && nw_mix_plan(lo, hi, index, mirror, m, mlo, mhi, i0, P->plan);
        P->bound = bound;
    }
    for (int r = 0; r < k; ++r) { xr[r] = creal(x[r]); xi[r] = cimag(x[r]); }
    for (long b = lo; b < hi; b += NW_MIXB) {
        const long e = hi - b < NW_MIXB ? hi : b + NW_MIXB;
        nw_vecmat(k, (int)(e - b), xr, 1, V + b, nv, 1, tr);
        nw_vecmat(k, (int)(e - b), xi, 1, V + b, nv, 1, ti);
        if (P->ok) {
            const int *restrict pl = P->plan + 2 * (b - lo);
            for (long c = 0; c < e - b; ++c) {
                const double complex v = tr[c] + ti[c] * I;
                out[pl[2 * c]] = v;
                if (pl[2 * c + 1] >= 0) out[pl[2 * c + 1]] = v;
            }
        } else {
            for (long c = b; c < e; ++c) out[(long)index[c] - i0] = tr[c - b] + ti[c - b] * I;
        }
    }
    if (!P->ok)
        for (long q = mlo; q < mhi; ++q)
            out[(long)mirror[q] - i0] = out[(long)mirror[m + q] - i0];
}
"""
