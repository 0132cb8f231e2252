"""Fixed C text of the compiled backend: the dense LU solve and the Dormand–Prince loop.

Both are appended to the generated C sources by :mod:`.c_module` (self-contained: one file,
one shared library, no linking against anything but ``libm``).

* ``nw_lu`` / ``nw_lu_solve``: LU decomposition with partial (row) pivoting of a dense,
  row-major ``n × n`` matrix, in place (Golub & Van Loan, *Matrix Computations*, Alg. 3.4.1);
  no symmetry assumed, so the unsymmetric mass matrices of two-sided elastic bodies are
  solved as well. A zero pivot returns 1 (singular matrix).
* ``nw_integrate_galpha``: steps of the generalized-α method of
  :mod:`neweul_py.analysis.generalized_alpha` (the driver there rebuilds the iteration
  matrix ``S`` when the loop asks for it), Newton's method on the residual
  ``M(y₊) ÿ₊ − (q − k)(t₊, y₊, ẏ₊)`` with the kept inverse of ``S`` (:data:`C_GALPHA`).
* ``nw_integrate_dopri5``: the explicit Runge–Kutta pair of Dormand & Prince, 5(4), with
  exactly the step-size control, initial step (Hairer, Nørsett & Wanner, *Solving ODEs I*,
  §II.4) and 4th-order dense output of ``scipy.integrate.RK45`` (SciPy 1.x, ``rk.py``), so that
  it takes the same steps as ``solve_ivp(method="RK45")`` on the same right-hand side; the
  states at the requested output times are interpolated with the dense output.
"""

from __future__ import annotations

__all__ = ["C_CLONES", "C_DOPRI5", "C_DOPRI5_TABLEAU", "C_DOT8", "C_GALPHA", "C_GALPHA_RESIDUAL",
           "C_LU", "C_SUPPORT_DECLARATIONS"]

#: Declarations (cffi ``cdef``) of the support functions.
C_SUPPORT_DECLARATIONS = """
int nw_integrate_dopri5(double t0, double t_end, const double *x0, const double *p,
                        const double *u, double rtol, double atol, double max_step,
                        int n_eval, const double *t_eval, double *x_eval,
                        long *nfev, double *t_reached);
int nw_integrate_galpha(double t0, double t1, long first, long last, long steps,
                        const double *cf, const double *p, const double *u, const double *Si,
                        double rtol, const double *atol, double *state, double *flags,
                        double *work, int n_eval, const double *t_eval, double *x_eval,
                        long *k_eval, long *nfev, long *done);
"""

#: ``NW_CLONES``: with gcc and glibc on x86-64 a function also built as an AVX2 clone, chosen
#: at load time (AVX2 without FMA: the same operations in the same order, so the same
#: results); elsewhere nothing. Defined once, before the first helper that uses it.
C_CLONES = r"""
#ifndef NW_CLONES
#if defined(__x86_64__) && defined(__GLIBC__) && defined(__GNUC__) && !defined(__clang__)
#define NW_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define NW_CLONES
#endif
#endif
"""

#: ``nw_dot8``: the dot product of the products' helpers (:data:`C_LU`,
#: :data:`.c_kernel_text.C_DOT`).
C_DOT8 = r"""
#ifndef NW_DOT8
#define NW_DOT8
/* a . b of n entries in eight partial sums, s_q over the entries k = q mod 8, added as
   ((s0 + s4) + (s1 + s5)) + ((s2 + s6) + (s3 + s7)), then the tail: independent chains of
   additions, so that a long dot product runs at the rate the cache delivers its rows rather
   than at the latency of one chain (two AVX2 vectors; four partial sums ran at half the
   rate: 0.027 against 0.015 ms for a 372 x 372 matrix times a vector) */
__attribute__((always_inline)) static inline double nw_dot8(int n, const double *restrict a,
                                                            const double *restrict b)
{
    double s[8] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0}, t = 0.0;
    int k = 0;
    for (; k + 8 <= n; k += 8)
        for (int q = 0; q < 8; ++q) s[q] += a[k + q] * b[k + q];
    for (; k < n; ++k) t += a[k] * b[k];
    return (((s[0] + s[4]) + (s[1] + s[5])) + ((s[2] + s[6]) + (s[3] + s[7]))) + t;
}
#endif
"""

C_LU = C_CLONES + C_DOT8 + r"""
/* ---- a . b of n entries (nw_dot8), vectorized (-O3; the substitutions of a large solve,
   where the library's -O1 would leave them scalar) */
__attribute__((optimize("O3"), noinline)) NW_CLONES static double nw_dotn(int n,
    const double *restrict a, const double *restrict b)
{
    return nw_dot8(n, a, b);
}

/* ---- the elimination below the pivot row k of an LU (-O3, vectorized; large factors) */
__attribute__((optimize("O3"), noinline)) NW_CLONES static void nw_lu_rows(int n, int k,
                                                                double *restrict a)
{
    const double inv = 1.0 / a[k * n + k];
    const double *restrict p = a + (long)k * n;
    for (int i = k + 1; i < n; ++i) {
        double *restrict r = a + (long)i * n;
        const double l = r[k] * inv;
        r[k] = l;
        if (l != 0.0)
            for (int j = k + 1; j < n; ++j) r[j] -= l * p[j];
    }
}

/* ---- dense LU with partial pivoting (Golub & Van Loan, Alg. 3.4.1), row-major, in place;
   inlined into each solve (the block elimination's small LU of S then has constant sizes;
   from 64 unknowns on the elimination is nw_lu_rows') */
__attribute__((always_inline)) static inline int nw_lu(int n, double *a, int *piv)
{
    for (int k = 0; k < n; ++k) {
        int r = k;
        double big = fabs(a[k * n + k]);
        for (int i = k + 1; i < n; ++i) {
            double v = fabs(a[i * n + k]);
            if (v > big) { big = v; r = i; }
        }
        piv[k] = r;
        if (big == 0.0 || big != big) return 1;
        if (r != k)
            for (int j = 0; j < n; ++j) {
                double s = a[k * n + j]; a[k * n + j] = a[r * n + j]; a[r * n + j] = s;
            }
        if (n >= 64) {
            nw_lu_rows(n, k, a);
            continue;
        }
        double inv = 1.0 / a[k * n + k];
        for (int i = k + 1; i < n; ++i) {
            double l = a[i * n + k] * inv;
            a[i * n + k] = l;
            if (l != 0.0)
                for (int j = k + 1; j < n; ++j) a[i * n + j] -= l * a[k * n + j];
        }
    }
    return 0;
}

/* solve A X = B for m right-hand sides; b is row-major n x m, overwritten by X (one
   right-hand side: dot products along the rows of the factors, two partial sums; nw_dotn's
   eight from 64 unknowns on) */
__attribute__((always_inline)) static inline void nw_lu_solve(int n, const double *lu,
                                                              const int *piv, int m, double *b)
{
    if (m == 1) {
        for (int k = 0; k < n; ++k)
            if (piv[k] != k) { double s = b[k]; b[k] = b[piv[k]]; b[piv[k]] = s; }
        if (n >= 64) {
            for (int i = 1; i < n; ++i) b[i] -= nw_dotn(i, lu + (long)i * n, b);
            for (int i = n - 1; i >= 0; --i) {
                const double *r = lu + (long)i * n;
                b[i] = (b[i] - nw_dotn(n - i - 1, r + i + 1, b + i + 1)) * (1.0 / r[i]);
            }
            return;
        }
        for (int i = 1; i < n; ++i) {
            const double *r = lu + (long)i * n;
            double s0 = 0.0, s1 = 0.0;
            int k = 0;
            for (; k + 2 <= i; k += 2) { s0 += r[k] * b[k]; s1 += r[k + 1] * b[k + 1]; }
            for (; k < i; ++k) s0 += r[k] * b[k];
            b[i] -= s0 + s1;
        }
        for (int i = n - 1; i >= 0; --i) {
            const double *r = lu + (long)i * n;
            double s0 = 0.0, s1 = 0.0;
            int k = i + 1;
            for (; k + 2 <= n; k += 2) { s0 += r[k] * b[k]; s1 += r[k + 1] * b[k + 1]; }
            for (; k < n; ++k) s0 += r[k] * b[k];
            b[i] = (b[i] - (s0 + s1)) * (1.0 / r[i]);
        }
        return;
    }
    for (int k = 0; k < n; ++k)
        if (piv[k] != k)
            for (int j = 0; j < m; ++j) {
                double s = b[k * m + j]; b[k * m + j] = b[piv[k] * m + j]; b[piv[k] * m + j] = s;
            }
    for (int i = 1; i < n; ++i)
        for (int k = 0; k < i; ++k) {
            double l = lu[i * n + k];
            if (l != 0.0)
                for (int j = 0; j < m; ++j) b[i * m + j] -= l * b[k * m + j];
        }
    for (int i = n - 1; i >= 0; --i) {
        for (int k = i + 1; k < n; ++k) {
            double l = lu[i * n + k];
            if (l != 0.0)
                for (int j = 0; j < m; ++j) b[i * m + j] -= l * b[k * m + j];
        }
        double inv = 1.0 / lu[i * n + i];
        for (int j = 0; j < m; ++j) b[i * m + j] *= inv;
    }
}
"""

C_DOPRI5_TABLEAU = r"""
/* ---- Dormand-Prince 5(4) with the step control and dense output of scipy's RK45 */
static const double NW_C[6] = {0.0, 0.2, 0.3, 0.8, 0.8888888888888888, 1.0};
static const double NW_A[6][5] = {
    {0.0, 0.0, 0.0, 0.0, 0.0},
    {0.2, 0.0, 0.0, 0.0, 0.0},
    {0.075, 0.225, 0.0, 0.0, 0.0},
    {0.9777777777777777, -3.7333333333333334, 3.5555555555555554, 0.0, 0.0},
    {2.9525986892242035, -11.595793324188385, 9.822892851699436, -0.2908093278463649, 0.0},
    {2.8462752525252526, -10.757575757575758, 8.906422717743473, 0.2784090909090909,
     -0.2735313036020583}};
static const double NW_B[6] = {0.09114583333333333, 0.0, 0.44923629829290207,
                               0.6510416666666666, -0.322376179245283, 0.13095238095238096};
static const double NW_E[7] = {-0.0012326388888888888, 0.0, 0.0042527702905061394,
                               -0.03697916666666667, 0.05086379716981132, -0.0419047619047619,
                               0.025};
static const double NW_P[7][4] = {
    {1.0, -2.8535800653862835, 3.0717434641059005, -1.1270175653862835},
    {0.0, 0.0, 0.0, 0.0},
    {0.0, 4.023133379230305, -6.249321565289, 2.675424484351598},
    {0.0, -3.7324019615885042, 10.068970589843675, -5.685526961588504},
    {0.0, 2.5548038301849423, -6.399112377351017, 3.5219323679207912},
    {0.0, -1.3744241142186024, 3.272657752246729, -1.7672812570757455},
    {0.0, 1.3824689317781436, -3.764937863556287, 2.382468931778144}};

static double nw_rms(int n, const double *v, const double *scale)
{
    double s = 0.0;
    for (int i = 0; i < n; ++i) { double r = v[i] / scale[i]; s += r * r; }
    return sqrt(s / n);
}

"""

#: The loop of :data:`C_DOPRI5` (after the tableau).
_C_DOPRI5_LOOP = r"""/* returns 0: reached t_end; 1: step size too small; 2: singular mass matrix;
   3: non-finite state */
int nw_integrate_dopri5(double t0, double t_end, const double *x0, const double *p,
                        const double *u, double rtol, double atol, double max_step,
                        int n_eval, const double *t_eval, double *x_eval,
                        long *nfev, double *t_reached)
{
    enum { S = NW_STATE_SIZE };
    double x[S], xn[S], f[S], fn[S], K[7][S], tmp[S], scale[S];
    int ie = 0;
    long ev = 0;
    double t = t0;
    *t_reached = t0;
    memcpy(x, x0, sizeof x);
    if (nw_rhs(t, x, p, u, f)) { *nfev = 1; return 2; }
    ev = 1;
    /* initial step: scipy.integrate._ivp.common.select_initial_step, error order 4 */
    double interval = fabs(t_end - t0), h_abs;
    {
        for (int i = 0; i < S; ++i) scale[i] = atol + fabs(x[i]) * rtol;
        double d0 = nw_rms(S, x, scale), d1 = nw_rms(S, f, scale), h0;
        h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
        if (h0 > interval) h0 = interval;
        for (int i = 0; i < S; ++i) tmp[i] = x[i] + h0 * f[i];
        if (nw_rhs(t0 + h0, tmp, p, u, fn)) { *nfev = 2; return 2; }
        ev++;
        for (int i = 0; i < S; ++i) tmp[i] = fn[i] - f[i];
        double d2 = nw_rms(S, tmp, scale) / h0, h1;
        if (d1 <= 1e-15 && d2 <= 1e-15) h1 = fmax(1e-6, h0 * 1e-3);
        else h1 = pow(0.01 / fmax(d1, d2), 1.0 / 5.0);
        h_abs = fmin(fmin(100 * h0, h1), fmin(interval, max_step));
    }
    while (ie < n_eval && t_eval[ie] <= t) {   /* output times at t0 */
        memcpy(x_eval + (long)ie * S, x, sizeof x);
        ie++;
    }
    while (t < t_end) {
        double min_step = 10 * fabs(nextafter(t, INFINITY) - t), h, t_new;
        if (h_abs > max_step) h_abs = max_step;
        else if (h_abs < min_step) h_abs = min_step;
        int rejected = 0;
        for (;;) {
            if (h_abs < min_step) { *nfev = ev; *t_reached = t; return 1; }
            h = h_abs;
            t_new = t + h;
            if (t_new - t_end > 0) t_new = t_end;
            h = t_new - t;
            h_abs = fabs(h);
            memcpy(K[0], f, sizeof f);
            for (int s = 1; s < 6; ++s) {
                for (int i = 0; i < S; ++i) {
                    double d = 0.0;
                    for (int j = 0; j < s; ++j) d += K[j][i] * NW_A[s][j];
                    tmp[i] = x[i] + d * h;
                }
                if (nw_rhs(t + NW_C[s] * h, tmp, p, u, K[s])) {
                    *nfev = ev + s; *t_reached = t; return 2;
                }
            }
            for (int i = 0; i < S; ++i) {
                double d = 0.0;
                for (int j = 0; j < 6; ++j) d += K[j][i] * NW_B[j];
                xn[i] = x[i] + h * d;
            }
            if (nw_rhs(t + h, xn, p, u, fn)) { *nfev = ev + 6; *t_reached = t; return 2; }
            ev += 6;
            memcpy(K[6], fn, sizeof fn);
            for (int i = 0; i < S; ++i) {
                double e = 0.0;
                for (int j = 0; j < 7; ++j) e += K[j][i] * NW_E[j];
                tmp[i] = e * h;
                scale[i] = atol + fmax(fabs(x[i]), fabs(xn[i])) * rtol;
            }
            double err = nw_rms(S, tmp, scale);
            if (err != err) { *nfev = ev; *t_reached = t; return 3; }
            if (err < 1) {
                double factor = err == 0 ? 10.0 : fmin(10.0, 0.9 * pow(err, -0.2));
                if (rejected) factor = fmin(1.0, factor);
                h_abs *= factor;
                break;
            }
            h_abs *= fmax(0.2, 0.9 * pow(err, -0.2));
            rejected = 1;
        }
        /* dense output on (t, t_new]: y_old + h Q [s, s^2, s^3, s^4], Q = K^T P */
        while (ie < n_eval && t_eval[ie] <= t_new) {
            double s = (t_eval[ie] - t) / h, pw[4] = {s, s * s, s * s * s, s * s * s * s};
            double *out = x_eval + (long)ie * S;
            for (int i = 0; i < S; ++i) {
                double acc = 0.0;
                for (int k = 0; k < 4; ++k) {
                    double q = 0.0;
                    for (int j = 0; j < 7; ++j) q += K[j][i] * NW_P[j][k];
                    acc += q * pw[k];
                }
                out[i] = x[i] + h * acc;
            }
            ie++;
        }
        t = t_new;
        memcpy(x, xn, sizeof x);
        memcpy(f, fn, sizeof f);
        *t_reached = t;
        for (int i = 0; i < S; ++i)
            if (!isfinite(x[i])) { *nfev = ev; return 3; }
    }
    *nfev = ev;
    return 0;
}
"""

#: The whole integrator: :data:`C_DOPRI5_TABLEAU` and the loop ``nw_integrate_dopri5``.
C_DOPRI5 = C_DOPRI5_TABLEAU + _C_DOPRI5_LOOP


#: The residual ``M a − (q − k)`` from ``M`` and ``q − k`` (``nw_mass_force``), for
#: :data:`C_GALPHA` in a module without elastic bodies (one with them has its own, which does
#: not form ``M``: :mod:`.c_splice`).
C_GALPHA_RESIDUAL = r"""
__attribute__((optimize("O3"))) static int nw_ga_residual(double t, const double *z,
    const double *a, const double *p, const double *u, double *r)
{
    static double M[NW_N * NW_N + 1], f[NW_N + 1];
    int code = nw_mass_force(t, z, z + NW_N, p, u, M, f);
    if (code) return code;
    for (int i = 0; i < NW_N; ++i) r[i] = nw_dotn(NW_N, M + (long)i * NW_N, a) - f[i];
    return 0;
}
"""

#: Steps of the generalized-α method (:mod:`neweul_py.analysis.generalized_alpha`, whose
#: module docstring gives the method, the stopping rule and the outputs) in C: the same
#: predictor, Newton iteration, contraction test, rebuild protocol and cubic Hermite outputs,
#: with Newton's method on the residual ``r = M(y₊) ÿ₊ − (q − k)(t₊, y₊, ẏ₊)`` and the kept
#: inverse of the iteration matrix ``S = M + c_v C_t + c_y K_t`` (Arnold & Brüls, Multibody
#: Syst. Dyn. 18 (2007) 185–202, Eq. (14)): ``Δ = S⁻¹ r`` as ``n`` independent row products
#: (``nw_dotn``; the two substitutions of a factorization ran row after row: the middle ear's
#: 0.02 s ramp took about 10 % longer with them), one evaluation of the residual
#: (``nw_ga_residual``, placed before: :data:`C_GALPHA_RESIDUAL`, or that of :mod:`.c_splice`)
#: and no solve with ``M`` per iteration. The Python loop
#: iterates on ``ÿ₊ − M⁻¹ (q − k)`` with ``S⁻¹ M`` of the rebuild; both are Newton's method
#: with the same matrix at the rebuild and converge to the same step to the tolerance.
#: ``cf``: ``h, c_y, c_v, ya, yy, va, vy, α_m, α_f`` (``GeneralizedAlpha``) and the stopping
#: rule's iterations, contraction, round-off and small increment (the Python loop's
#: constants, passed by its driver); ``state``:
#: ``y, ẏ, ÿ, a`` (4n, in and out); ``flags``: ``θ``, fresh, retry (in and out); ``Si``
#: (n × n), the inverse of ``S`` (the driver's ``numpy.linalg.inv``, LAPACK), copied on entry
#: into ``work`` (the caller's, ``n² + 3n + 1``: ``S⁻¹``, unused, the point where the model
#: failed, whether ``Si`` was finite — a matrix with a NaN, passed as it is, makes the
#: iterations fail, as in the Python loop), or ``NULL`` to keep the inverse in ``work``.
#: Returns 0 (steps ``first …
#: last − 1`` done), 1 (Newton's method failed with an old matrix at step ``*done``: rebuild
#: ``S`` at the predictor and call again with fresh and retry set), 2 (failed with a rebuilt
#: matrix) or 4 + the model's error code (3 is no longer returned: a singular ``S`` is the
#: driver's ``LinAlgError``).
C_GALPHA = r"""
/* ---- generalized-alpha steps (codegen/c_templates.py, C_GALPHA; nw_ga_residual before) */

/* Newton's method of one step (analysis/generalized_alpha.py, _newton): 0 converged, 1 not */
static int nw_ga_newton(double tn, const double *yh, const double *vh, const double *cf,
                        const double *scale, const double *p, const double *u, double *x,
                        double *theta, int fresh, double *work, long *nfev, int *code)
{
    const double *Si = work;
    double *zfail = work + NW_N * NW_N + NW_N;
    const double cy = cf[1], cv = cf[2], slow = cf[10], round_off = cf[11], small = cf[12];
    double z[2 * NW_N], r[NW_N], previous = INFINITY;
    for (int k = 0; k < (int)cf[9]; ++k) {
        for (int i = 0; i < NW_N; ++i) {
            z[i] = yh[i] + cy * x[i];
            z[NW_N + i] = vh[i] + cv * x[i];
        }
        ++*nfev;
        if ((*code = nw_ga_residual(tn, z, x, p, u, r))) {
            memcpy(zfail, z, sizeof z);                  /* where the model failed */
            return 1;
        }
        if (work[NW_N * NW_N + 3 * NW_N] == 0.0) return 1;   /* S not finite: as NaN steps */
        double err = 0.0, dmax = 0.0, xmax = 0.0;
        int finite = 1;                  /* fmax drops a NaN: the increments checked apart */
        for (int i = 0; i < NW_N; ++i) {
            const double d = nw_dotn(NW_N, Si + (long)i * NW_N, r);     /* (S^-1 r)_i */
            x[i] -= d;
            finite &= isfinite(d) != 0;
            err = fmax(err, fabs(d) * scale[i]);
            dmax = fmax(dmax, fabs(d));
            xmax = fmax(xmax, fabs(x[i]));
        }
        if (!finite || !isfinite(err)) return 1;
        if (k) {
            *theta = err / previous;
            if (*theta >= 1.0 || (*theta > slow && !fresh)) return 1;
        }
        if (((k || fresh) && *theta < 1.0 && *theta / (1.0 - *theta) * err <= 1.0)
                || err <= small || dmax <= round_off * xmax)
            return 0;
        previous = err;
    }
    return 1;
}

static void nw_ga_hermite(double t0, double t1, const double *p0, const double *d0,
                          const double *p1, const double *d1, double t, double *out)
{
    const double h = t1 - t0, s = (t - t0) / h;
    const double h00 = 2 * s * s * s - 3 * s * s + 1, h10 = s * s * s - 2 * s * s + s;
    const double h01 = -2 * s * s * s + 3 * s * s, h11 = s * s * s - s * s;
    for (int i = 0; i < NW_N; ++i)
        out[i] = h00 * p0[i] + h10 * h * d0[i] + h01 * p1[i] + h11 * h * d1[i];
}

int nw_integrate_galpha(double t0, double t1, long first, long last, long steps,
                        const double *cf, const double *p, const double *u, const double *Si,
                        double rtol, const double *atol, double *state, double *flags,
                        double *work, int n_eval, const double *t_eval, double *x_eval,
                        long *k_eval, long *nfev, long *done)
{
    const double h = cf[0], cy = cf[1], cv = cf[2], ya = cf[3], yy = cf[4], va = cf[5],
                 vy = cf[6], am = cf[7], af = cf[8];
    double *y = state, *v = state + NW_N, *ydd = state + 2 * NW_N, *a = state + 3 * NW_N;
    double yh[NW_N], vh[NW_N], x[NW_N], scale[NW_N], yn[NW_N], vn[NW_N];
    double theta = flags[0];
    int fresh = flags[1] != 0.0, retry = flags[2] != 0.0, code = 0;
    long k = *k_eval;
    *done = first;
    if (Si) {                 /* the caller's work: S^-1, a flag, the failing point */
        int finite = 1;
        for (long j = 0; j < (long)NW_N * NW_N; ++j) finite &= isfinite(Si[j]) != 0;
        work[NW_N * NW_N + 3 * NW_N] = finite;
        memcpy(work, Si, NW_N * NW_N * sizeof(double));
    }
    for (long i = first; i < last; ++i) {
        const double t = t0 + i * h, tn = i + 1 < steps ? t0 + (i + 1) * h : t1;
        for (int j = 0; j < NW_N; ++j) {
            yh[j] = y[j] + h * v[j] + ya * a[j] + yy * ydd[j];
            vh[j] = v[j] + va * a[j] + vy * ydd[j];
            scale[j] = fmax(cy / (atol[j] + rtol * fabs(y[j])),
                            cv / (atol[NW_N + j] + rtol * fabs(v[j])));
        }
        memcpy(x, ydd, sizeof x);
        int failed = nw_ga_newton(tn, yh, vh, cf, scale, p, u, x, &theta, fresh, work, nfev,
                                  &code);
        flags[0] = theta;
        if (code) return 4 + code;
        if (failed) {
            flags[1] = 0.0;
            return retry ? 2 : 1;
        }
        fresh = retry;            /* the step after a rebuild keeps its fresh matrix */
        retry = 0;
        for (int j = 0; j < NW_N; ++j) {
            a[j] = ((1 - af) * x[j] + af * ydd[j] - am * a[j]) / (1 - am);
            yn[j] = yh[j] + cy * x[j];
            vn[j] = vh[j] + cv * x[j];
        }
        for (; k < n_eval && (i + 1 == steps || t_eval[k] <= tn); ++k) {
            nw_ga_hermite(t, tn, y, v, yn, vn, t_eval[k], x_eval + k * NW_STATE_SIZE);
            nw_ga_hermite(t, tn, v, ydd, vn, x, t_eval[k], x_eval + k * NW_STATE_SIZE + NW_N);
        }
        memcpy(y, yn, sizeof yn);
        memcpy(v, vn, sizeof vn);
        memcpy(ydd, x, sizeof x);
        *done = i + 1;
        *k_eval = k;
    }
    flags[1] = fresh;
    flags[2] = retry;
    return 0;
}
"""
