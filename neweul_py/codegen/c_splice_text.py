"""Fixed C text of compiled modules with elastic bodies (:mod:`.c_splice`).

The splice of the elastic bodies in the order of :mod:`neweul_py.ffrf.splice`, written once:
the bound arrays and the weights (:data:`GLOBALS_C`); the weights of the parametric bodies by
Horner's rule, the context at the schedule, the dynamics, the schedule's sensitivities and the
binding (:data:`SPLICE_C`); the block solve with the kept factorization of the elastic block
(:data:`ESOLVE_C`); the protocol functions of the core library (:data:`CORE_C`); those of the
derivative library are in :mod:`.c_splice_jacobians`. The body equations are not here: they
are the traced kernel functions ``nw_k_*`` these texts call (:mod:`.c_splice_trace`,
:mod:`.c_kernel`).
The ``NW_*`` macros are defined per model by :mod:`.c_splice`.
"""

from __future__ import annotations

__all__ = ["CORE_C", "ESOLVE_C", "GLOBALS_C", "POLY_C", "SMAP_C", "SPLICE_C", "WMAP_C"]

#: The splice of both libraries: binding, weights, the context at the schedule, the
#: dynamics and the sensitivities of the schedule (mirrors neweul_py/ffrf/splice.py).
GLOBALS_C = r"""
/* the bound arrays of the data file and the weights of the parametric bodies */
static const double *nw_D[NW_ND + 1];
static int nw_bound;
static double nw_w[NW_NW + 1], nw_dw[NW_NW + 1];
static double complex nw_wc[NW_NW + 1];
static int nw_have_w;
static long nw_wversion;   /* counts the mixes at new weights (and the bindings) */
static long nw_binds;      /* counts the bindings (the compact mixing's constant entries) */
"""

#: ``y_s = S_V x`` and ``y_s(0) = S_V(0) x`` by the rows' nonzero spans (part of
#: :data:`SPLICE_C`; uses ``nw_gemv``, ``nw_dot8`` and ``NW_CLONES`` of
#: :data:`.c_kernel_text.C_DOT`, ``nw_spans`` of :data:`WMAP_C`, ``nw_binds`` and
#: ``nw_wversion`` of :data:`GLOBALS_C` and the macros ``NW_NS``, ``NW_N``, ``NW_SV``,
#: ``NW_SV0``, ``NW_SV_SIGMA``).
SMAP_C = r"""
/* y_s = S_V x (which 0) or y_s(0) = S_V(0) x (which 1) along the nonzero span of each row:
   the maps are unit rows but for the rows of the node coordinates (ffrf/splice.py). The
   spans are found again when a map may have changed: S_V(0) at a binding, S_V with the
   weights too when it depends on them (NW_SV_SIGMA). An x that is not finite takes the
   dense product, so that NaN and inf reach every row as in the NumPy module's S_V @ x. */
static int nw_sp_lo[2][NW_NS + 1], nw_sp_hi[2][NW_NS + 1];
static long nw_sp_at[2] = {-1, -1};
__attribute__((optimize("O3"))) NW_CLONES static void nw_smap(int which,
    const double *restrict x, double *restrict y)
{
    const double *A = which ? NW_SV0 : NW_SV;
    const long at = (which || !NW_SV_SIGMA) ? nw_binds : nw_wversion;
    int *lo = nw_sp_lo[which], *hi = nw_sp_hi[which];
    int finite = 1;
    for (int j = 0; j < NW_N; ++j) finite &= isfinite(x[j]) != 0;
    if (!finite) {
        nw_gemv(NW_NS, NW_N, A, NW_N, 1, x, 1, y);
        return;
    }
    if (nw_sp_at[which] != at) {
        nw_spans(A, lo, hi);
        nw_sp_at[which] = at;
    }
    for (int i = 0; i < NW_NS; ++i)
        y[i] = nw_dot8(hi[i] - lo[i], A + (long)i * NW_N + lo[i], x + lo[i]);
}
"""

#: ``y = x S_W`` for the first ``k`` rows of ``S_W`` along the nonzero span of each row, as
#: :data:`SMAP_C` multiplies by ``S_V``, and ``nw_spans``, the spans of a map's rows (placed
#: before the traced kernels, which call it for their products ``x @ S_W``, and before
#: :data:`SMAP_C`; uses ``nw_vecmat`` and ``NW_CLONES`` of
#: :data:`.c_kernel_text.C_DOT`, ``nw_binds`` and ``nw_wversion`` of :data:`GLOBALS_C` and
#: the macros ``NW_NS``, ``NW_N``, ``NW_SW``, ``NW_SW_SIGMA``).
WMAP_C = r"""
/* y = x S_W for the first k rows of S_W (x: k entries of stride sx) along the nonzero span of
   each row: the rows are unit rows but for those of the node coordinates (ffrf/splice.py),
   so the product reads the node rows and one entry of every other row instead of k dense
   rows. The spans are found again when S_W may have changed: at a binding, and with the
   mixes when it depends on the weights (NW_SW_SIGMA). An x that is not finite takes the
   dense product, so that NaN and inf reach every column as in the NumPy module's x @ S_W. */
static int nw_wp_lo[NW_NS + 1], nw_wp_hi[NW_NS + 1];
static long nw_wp_at = -1;

/* the nonzero span lo[i] ... hi[i] - 1 of each row i of a map A (NW_NS x NW_N) */
static void nw_spans(const double *A, int *lo, int *hi)
{
    for (int i = 0; i < NW_NS; ++i) {
        const double *a = A + (long)i * NW_N;
        int l = 0, h = NW_N;
        while (l < NW_N && a[l] == 0.0) ++l;
        while (h > l && a[h - 1] == 0.0) --h;
        lo[i] = l;
        hi[i] = h;
    }
}
__attribute__((optimize("O3"))) NW_CLONES static void nw_wmap(int k, const double *restrict x,
    long sx, double *restrict y)
{
    const long at = NW_SW_SIGMA ? nw_wversion : nw_binds;
    int finite = 1;
    for (int i = 0; i < k; ++i) finite &= isfinite(x[i * sx]) != 0;
    if (!finite) {
        nw_vecmat(k, NW_N, x, sx, NW_SW, NW_N, 1, y);
        return;
    }
    if (nw_wp_at != at) {
        nw_spans(NW_SW, nw_wp_lo, nw_wp_hi);
        nw_wp_at = at;
    }
    for (int j = 0; j < NW_N; ++j) y[j] = 0.0;
    for (int i = 0; i < k; ++i) {
        const double xi = x[i * sx], *a = NW_SW + (long)i * NW_N;
        if (xi != 0.0)
            for (int j = nw_wp_lo[i]; j < nw_wp_hi[i]; ++j) y[j] += xi * a[j];
    }
}
"""

#: ``nw_poly``: the rows ``P = C_j V`` (``nd × nv``) and powers ``pw`` with which a mix by a
#: parametric body's weights ``w = pw C_j`` (their polynomial on the interval ``j`` of the
#: schedule, :func:`~neweul_py.ffrf.parametric.ffrf_weights`) reads ``nd`` rows instead of the
#: ``ncol`` of ``V``: ``w V = pw (C_j V)``, equal to round-off; and ``nw_interval``, the
#: interval of the schedule (``nw_weights`` finds it so too). Placed at ``NW_POLY`` in
#: :data:`SPLICE_C`; needs ``nw_vecmat`` (:data:`.c_kernel_text.C_DOT`), ``NW_MIXB`` and
#: ``nw_binds``.
POLY_C = r"""
/* the interval j of x on the breakpoints b (nb): b_j <= x < b_{j+1}, the last one closed */
static int nw_interval(double x, const double *b, int nb)
{
    for (int i = 0; i < nb - 2; ++i)
        if (x < b[i + 1]) return i;
    return nb - 2;
}

/* A mix by the weights at x from nd rows instead of ncol: on the interval j of x the weights
   are w = pw C_j, pw = (dx^(nd-1), ..., dx, 1) and C_j the rows of c at j (nw_weights'
   Horner), so w V = pw P with P = C_j V (nd x nv). P is made again when j or the binding
   changes (*at), in one pass over V by blocks; pw at every call (nw_mixed calls it before
   it mixes). x in [b_0, b_{nb-1}] */
__attribute__((optimize("O3"))) static void nw_poly(double x, const double *b, const double *c,
    int nb, int nd, int ncol, const double *V, long nv, double *P, double *pw, long *at)
{
    const int j = nw_interval(x, b, nb);
    const long key = nw_binds * nb + j;
    if (*at != key) {
        for (long s = 0; s < nv; s += NW_MIXB) {
            const int e = nv - s < NW_MIXB ? (int)(nv - s) : NW_MIXB;
            for (int m = 0; m < nd; ++m)
                nw_vecmat(ncol, e, c + ((long)m * (nb - 1) + j) * ncol, 1, V + s, nv, 1,
                          P + (long)m * nv + s);
        }
        *at = key;
    }
    const double dx = x - b[j];
    pw[nd - 1] = 1.0;
    for (int m = nd - 2; m >= 0; --m) pw[m] = pw[m + 1] * dx;
}
"""

SPLICE_C = r"""
/* ---- the splice of the elastic bodies (codegen/c_splice.py; neweul_py/ffrf/splice.py) */

NW_POLY
/* the weights w (ncol) at x and their derivative: the piecewise polynomials c (nd, nb-1, ncol)
   on the breakpoints b (ffrf_weights; Horner); 1 outside [b_0, b_{nb-1}] */
static int nw_weights(double x, const double *b, const double *c, int nb, int nd, int ncol,
                      double *w, double *dw)
{
    if (!(b[0] <= x && x <= b[nb - 1])) return 1;
    const int j = nw_interval(x, b, nb);
    const double dx = x - b[j];
    for (int col = 0; col < ncol; ++col) {
        double v = c[(long)j * ncol + col], d = 0.0;
        for (int m = 1; m < nd; ++m) {
            d = d * dx + v;
            v = v * dx + c[((long)m * (nb - 1) + j) * ncol + col];
        }
        w[col] = v;
        dw[col] = d;
    }
    return 0;
}

NW_SMAP
/* the weights of the parametric bodies at their schedules at (t, y, p, u) (ffrf_at); 3
   outside the samples. What is mixed with the weights is made when a function reads it
   (nw_mixed): outputs and constraints at a new schedule need no mix (NW_SV_MIXED 0) */
static double nw_sigma[NW_NPB + 1];
static int nw_mix_due;
static int nw_weights_at(double t, const double *y, const double *p, const double *u)
{
#if NW_NPB
    double ys0[NW_NS + 1], sigma[NW_NPB], w[NW_NW], dw[NW_NW];
    nw_smap(1, y, ys0);
    nw_s_schedule(t, ys0, p, u, sigma);
NW_WEIGHTS
    if (!nw_have_w || memcmp(w, nw_w, sizeof w)) {
        memcpy(nw_w, w, sizeof w);
        memcpy(nw_dw, dw, sizeof dw);
        memcpy(nw_sigma, sigma, sizeof sigma);
        nw_have_w = 1;
        nw_mix_due = 1;
    }
#else
    (void)t; (void)y; (void)p; (void)u;
#endif
    return 0;
}

/* the mixed samples at the weights of the last nw_weights_at: mixed when these differ from
   the weights of the last mix (kept while they are the same; nw_wversion counts the mixes) */
static double nw_wmix[NW_NW + 1], nw_dwmix[NW_NW + 1];
static int nw_have_mix;
static void nw_mixed(void)
{
#if NW_NPB
    if (!nw_mix_due) return;
    nw_mix_due = 0;
    if (nw_have_mix && !memcmp(nw_wmix, nw_w, NW_NW * sizeof(double))
            && !memcmp(nw_dwmix, nw_dw, NW_NW * sizeof(double)))
        return;                                          /* back at the mixed weights */
    const double *sigma = nw_sigma;
    ++nw_wversion;             /* first: what the mix reads by spans keyed on it is new */
NW_POLY_ROWS
    nw_k_sigma();
    memcpy(nw_wmix, nw_w, NW_NW * sizeof(double));
    memcpy(nw_dwmix, nw_dw, NW_NW * sizeof(double));
    nw_have_mix = 1;
    (void)sigma;
#endif
}

/* the context at (t, y, p, u): the parametric bodies mixed at their schedules (ffrf_at) */
static int nw_at(double t, const double *y, const double *p, const double *u)
{
    if (nw_weights_at(t, y, p, u)) return 3;
    nw_mixed();
    return 0;
}

/* the context of the functions of the symbolic part alone (outputs, constraints and their
   derivatives): the weights, and the mix only when S_V or dS_V/dsigma is mixed */
static int nw_at_sv(double t, const double *y, const double *p, const double *u)
{
    if (nw_weights_at(t, y, p, u)) return 3;
    if (NW_SV_MIXED) nw_mixed();
    return 0;
}

/* The context and the symbolic part at the state: y_s = S_V y, its frame kinematics, M_s
   and (q - k)_s into parts (ffrf_dynamics). parts is zero at load; nw_s_rhs_parts writes
   the entries that are not zero by construction, the same ones at every call (c_splice.py) */
static double parts[NW_NH + NW_NS * NW_NS + NW_NS + 1];
static int nw_sym(double t, const double *y, const double *yd, const double *p,
                  const double *u)
{
    double ys[NW_NS + 1], yds[NW_NS + 1];
    if (nw_at(t, y, p, u)) return 3;
    nw_smap(0, y, ys);
    nw_smap(0, yd, yds);
    nw_s_rhs_parts(t, ys, yds, p, u, parts);
    return 0;
}

/* (M, q - k) at the state: the symbolic part and the bodies (ffrf_dynamics) */
static int nw_dyn(double t, const double *y, const double *yd, const double *p,
                  const double *u, double *M, double *f)
{
    if (nw_sym(t, y, yd, p, u)) return 3;
    nw_k_dyn(parts, y, yd, parts + NW_NH, parts + NW_NH + NW_NS * NW_NS, M, f);
    return 0;
}

/* dsigma/dy (NPB x n, through y_s = S_V(0) y) and dsigma/du (ffrf_sigma_sensitivity); 0 when
   both are zero */
static int nw_sens(double t, const double *y, const double *p, const double *u, double *Sy,
                   double *Su)
{
#if NW_NPB
    double ys0[NW_NS + 1], J[NW_NPB * (NW_NS + NW_NU) + 1];
    int any = 0;
    memset(J, 0, sizeof J);
    nw_smap(1, y, ys0);
    nw_s_schedule_jacobians(t, ys0, p, u, J);
    for (int i = 0; i < NW_NPB * (NW_NS + NW_NU); ++i) any |= J[i] != 0.0;
    nw_gemm(NW_NPB, NW_N, NW_NS, J, NW_NS, 1, NW_SV0, NW_N, 1, Sy);
    memcpy(Su, J + NW_NPB * NW_NS, NW_NPB * NW_NU * sizeof(double));
    return any;
#else
    (void)t; (void)y; (void)p; (void)u; (void)Sy; (void)Su;
    return 0;
#endif
}

/* M x = b for m right-hand sides (b: n x m, overwritten; M kept) */
""" + "{esolve}" + r"""
int nw_bind(int count, const double *const *data, const long *sizes)
{
    static const long expect[NW_ND + 1] = {NW_SIZES};
    if (count != NW_ND) return 1;
    for (int i = 0; i < NW_ND; ++i)
        if (sizes[i] != expect[i]) return 1;
    for (int i = 0; i < NW_ND; ++i) nw_D[i] = data[i];
    ++nw_binds;
NW_BIND
    nw_bound = 1;
    nw_have_w = 0;
    nw_have_mix = 0;
    nw_mix_due = 0;
    ++nw_wversion;
    return 0;
}
"""

#: The block elimination of the elastic coordinates with the kept factorization of D.
ESOLVE_C = r"""
static const int nw_E[NW_NE] = {NW_ETABLE};
static const int nw_R[NW_NR + 1] = {NW_RTABLE};
static double nw_Dcur[NW_NE * NW_NE], nw_Dlu[NW_NE * NW_NE], nw_Dnorm;
static int nw_Dpiv[NW_NE], nw_Dok, nw_Dfresh;
static long nw_Dversion = -1;

/* factor the current D = M[E,E] (nw_Dfresh: the factors are of it) */
__attribute__((optimize("O3"))) static int nw_dfactor(void)
{
    memcpy(nw_Dlu, nw_Dcur, sizeof nw_Dlu);
    nw_Dok = nw_Dfresh = !nw_lu(NW_NE, nw_Dlu, nw_Dpiv);
    return !nw_Dok;
}

/* D = M[E,E] when it may have changed: with NW_DSIGMA it is blockdiag(Me(sigma)) by
   construction (ffrf_block_constant) and changes with the weights alone; else compared */
static int nw_dupdate(const double *M)
{
    static double D[NW_NE * NW_NE];
    if (NW_DSIGMA && nw_Dok && nw_Dversion == nw_wversion) return 0;
    for (int i = 0; i < NW_NE; ++i)
        for (int j = 0; j < NW_NE; ++j) D[i * NW_NE + j] = M[nw_E[i] * NW_N + nw_E[j]];
    nw_Dversion = nw_wversion;
    if (nw_Dok && !memcmp(D, nw_Dcur, sizeof D)) return 0;
    memcpy(nw_Dcur, D, sizeof D);
    nw_Dfresh = 0;
    nw_Dnorm = 0.0;                                       /* |D| (infinity norm) */
    for (int i = 0; i < NW_NE; ++i) {
        double s = 0.0;
        for (int j = 0; j < NW_NE; ++j) s += fabs(D[i * NW_NE + j]);
        nw_Dnorm = fmax(nw_Dnorm, s);
    }
    return nw_Dok ? 0 : nw_dfactor();
}

/* z = D^-1 z for m columns (NE x m, row-major). The factors of an earlier D are kept while
   iterative refinement against the current D reaches the backward error of a fresh
   factorization (Higham, Accuracy and Stability of Numerical Algorithms, ch. 12:
   fixed-precision refinement with a stale factorization, a stationary iteration with
   contraction |I - LU^-1 D|), each step two products of order NE^2 instead of a factorization
   of order NE^3. It stops when the normwise backward error |b - D z| / (|D| |z| + |b|) is at
   the round-off of the residual, 4 sqrt(NE) eps, or no longer halves below 64 sqrt(NE) eps;
   otherwise (slow contraction: the factors are too old), after six steps, or for more than
   four columns the current D is factored. For an ill-conditioned D the corrections then stay
   at the size cond(D) eps that a fresh factorization's solution has too. */
__attribute__((optimize("O3"))) static int nw_dsolve(double *z, int m)
{
    static double b[NW_NE * 4], r[NW_NE * 4];
    if (!nw_Dfresh && m <= 4) {
        const double floor = 4.0 * sqrt((double)NW_NE) * DBL_EPSILON;
        double prev = INFINITY, bmax = 0.0;
        memcpy(b, z, (size_t)NW_NE * m * sizeof(double));
        for (int i = 0; i < NW_NE * m; ++i) bmax = fmax(bmax, fabs(b[i]));
        nw_lu_solve(NW_NE, nw_Dlu, nw_Dpiv, m, z);
        for (int it = 0; it < 6; ++it) {
            double rmax = 0.0, xmax = 0.0;
            for (int i = 0; i < NW_NE; ++i) {
                const double *row = nw_Dcur + (long)i * NW_NE;
                if (m == 1) {                           /* one column: nw_dot8 */
                    r[i] = b[i] - nw_dot8(NW_NE, row, z);
                    rmax = fmax(rmax, fabs(r[i]));
                    continue;
                }
                for (int c = 0; c < m; ++c) {
                    double s0 = b[i * m + c], s1 = 0.0;
                    int j = 0;
                    for (; j + 2 <= NW_NE; j += 2) {
                        s0 -= row[j] * z[j * m + c];
                        s1 -= row[j + 1] * z[(j + 1) * m + c];
                    }
                    for (; j < NW_NE; ++j) s0 -= row[j] * z[j * m + c];
                    r[i * m + c] = s0 + s1;
                    rmax = fmax(rmax, fabs(r[i * m + c]));
                }
            }
            for (int i = 0; i < NW_NE * m; ++i) xmax = fmax(xmax, fabs(z[i]));
            const double eta = rmax / (nw_Dnorm * xmax + bmax + DBL_MIN);
            if (eta <= floor) return 0;                              /* converged */
            if (eta > 0.5 * prev) {
                if (eta <= 16.0 * floor) return 0;                   /* the round-off floor */
                break;                                               /* the factors too old */
            }
            prev = eta;
            nw_lu_solve(NW_NE, nw_Dlu, nw_Dpiv, m, r);
            for (int i = 0; i < NW_NE * m; ++i) z[i] += r[i];
        }
        memcpy(z, b, (size_t)NW_NE * m * sizeof(double));
    }
    if (!nw_Dfresh && nw_dfactor()) return 1;
    nw_lu_solve(NW_NE, nw_Dlu, nw_Dpiv, m, z);
    return 0;
}

__attribute__((optimize("O3"))) static int nw_esolve(const double *M, double *b, int m)
{
    static double z[NW_NE * 2 * NW_N];
    if (nw_dupdate(M)) return 1;
    for (int i = 0; i < NW_NE; ++i)
        for (int c = 0; c < m; ++c) z[i * m + c] = b[nw_E[i] * m + c];
    if (nw_dsolve(z, m)) return 1;                              /* z = D^-1 b_E */
#if NW_NR
    static double X[NW_NE * NW_NR], S[NW_NR * NW_NR], g[NW_NR * 2 * NW_N];
    int piv[NW_NR], coupled = 0;
    for (int i = 0; i < NW_NE; ++i)
        for (int r = 0; r < NW_NR; ++r) {
            X[i * NW_NR + r] = M[nw_E[i] * NW_N + nw_R[r]];
            coupled |= X[i * NW_NR + r] != 0.0;
        }
    if (coupled && nw_dsolve(X, NW_NR)) return 1;              /* X = D^-1 M[E,R] */
    for (int r = 0; r < NW_NR; ++r) {
        const double *row = M + nw_R[r] * NW_N;
        for (int q = 0; q < NW_NR; ++q) {                       /* S = M[R,R] - M[R,E] X */
            double s = row[nw_R[q]];
            if (coupled) for (int e = 0; e < NW_NE; ++e) s -= row[nw_E[e]] * X[e * NW_NR + q];
            S[r * NW_NR + q] = s;
        }
        for (int c = 0; c < m; ++c) {                           /* g = b_R - M[R,E] z */
            double s = b[nw_R[r] * m + c];
            for (int e = 0; e < NW_NE; ++e) s -= row[nw_E[e]] * z[e * m + c];
            g[r * m + c] = s;
        }
    }
    if (nw_lu(NW_NR, S, piv)) return 1;
    nw_lu_solve(NW_NR, S, piv, m, g);                          /* x_R */
    if (coupled)                                                /* x_E = z - X x_R */
        for (int e = 0; e < NW_NE; ++e)
            for (int c = 0; c < m; ++c) {
                double s = z[e * m + c];
                for (int r = 0; r < NW_NR; ++r) s -= X[e * NW_NR + r] * g[r * m + c];
                z[e * m + c] = s;
            }
    for (int r = 0; r < NW_NR; ++r)
        for (int c = 0; c < m; ++c) b[nw_R[r] * m + c] = g[r * m + c];
#endif
    for (int i = 0; i < NW_NE; ++i)
        for (int c = 0; c < m; ++c) b[nw_E[i] * m + c] = z[i * m + c];
    return 0;
}
"""

#: The protocol functions of the core library.
CORE_C = r"""
int nw_default_inputs(double t, const double *p, double *out)
{
    return nw_s_default_inputs(t, p, out);
}

int nw_mass_matrix(double t, const double *y, const double *p, const double *u, double *out)
{
    static double f[NW_N + 1];
    double yd[NW_N + 1] = {0};
    if (!nw_bound) return 2;
    return nw_dyn(t, y, yd, p, u, out, f);
}

int nw_force_vector(double t, const double *y, const double *yd, const double *p,
                    const double *u, double *out)
{
    static double M[NW_N * NW_N + 1];
    if (!nw_bound) return 2;
    return nw_dyn(t, y, yd, p, u, M, out);
}

int nw_rhs(double t, const double *x, const double *p, const double *u, double *out)
{
    static double M[NW_N * NW_N + 1], f[NW_N + 1];
    int r;
    if (!nw_bound) return 2;
    if ((r = nw_dyn(t, x, x + NW_N, p, u, M, f))) return r;
    if (nw_esolve(M, f, 1)) return 1;
    memmove(out, x + NW_N, NW_N * sizeof(double));
    memcpy(out + NW_N, f, NW_N * sizeof(double));
    return 0;
}

int nw_outputs(double t, const double *x, const double *p, const double *u, double *out)
{
    double ys[NW_NS + 1], yds[NW_NS + 1], o[NW_NY + NW_NH + 1];
    if (!nw_bound) return 2;
    if (nw_at_sv(t, x, p, u)) return 3;
    nw_smap(0, x, ys);
    nw_smap(0, x + NW_N, yds);
    nw_s_outputs(t, ys, yds, p, u, o);
    memcpy(out, o, NW_NY * sizeof(double));
    return 0;
}

int nw_constraints(double t, const double *y, const double *p, const double *u, double *out)
{
    double ys[NW_NS + 1];
    if (!nw_bound) return 2;
    if (nw_at_sv(t, y, p, u)) return 3;
    nw_smap(0, y, ys);
    return nw_s_constraints(t, ys, p, u, out);
}

int nw_constraint_time_derivative(double t, const double *y, const double *p, const double *u,
                                  double *out)
{
    double ys[NW_NS + 1];
    if (!nw_bound) return 2;
    if (nw_at_sv(t, y, p, u)) return 3;
    nw_smap(0, y, ys);
    return nw_s_constraint_time_derivative(t, ys, p, u, out);
}

int nw_constraint_gamma(double t, const double *y, const double *yd, const double *p,
                        const double *u, double *out)
{
    double ys[NW_NS + 1], yds[NW_NS + 1];
    if (!nw_bound) return 2;
    if (nw_at_sv(t, y, p, u)) return 3;
    nw_smap(0, y, ys);
    nw_smap(0, yd, yds);
    return nw_s_constraint_gamma(t, ys, yds, p, u, out);
}

/* G = G_s S_V (+ G_s dS_V/dsigma y dsigma/dy) (ffrf_constraint_jacobian) */
int nw_constraint_jacobian(double t, const double *y, const double *p, const double *u,
                           double *out)
{
    static double Gs[NW_NC * NW_NS + 1];
    double ys[NW_NS + 1];
    NW_DEFAULT_INPUTS;
    if (!nw_bound) return 2;
    if (nw_at_sv(t, y, p, u)) return 3;
    nw_smap(0, y, ys);
    nw_s_constraint_jacobian(t, ys, p, u, Gs);
    nw_gemm(NW_NC, NW_N, NW_NS, Gs, NW_NS, 1, NW_SV, NW_N, 1, out);
#if NW_NPB
    static double Sy[NW_NPB * NW_N + 1], Su[NW_NPB * NW_NU + 1];
    if (NW_NC && nw_sens(t, y, p, u, Sy, Su)) {
        double d[NW_NS + 1], v[NW_NC + 1];
        for (int k = 0; k < NW_NPB; ++k) {
            nw_gemv(NW_NS, NW_N, nw_dsv[k], NW_N, 1, y, 1, d);
            nw_gemv(NW_NC, NW_NS, Gs, NW_NS, 1, d, 1, v);
            for (int i = 0; i < NW_NC; ++i)
                for (int j = 0; j < NW_N; ++j) out[i * NW_N + j] += v[i] * Sy[k * NW_N + j];
        }
    }
#endif
    return 0;
}
"""
