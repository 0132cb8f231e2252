"""Fixed C text of the derivative library of compiled modules with elastic bodies.

The Jacobians of the derivative library (``*_jac.c``, :mod:`.c_splice`) by the chain rule
through the splice of :mod:`.c_splice_text`, in the order of :mod:`neweul_py.ffrf.splice`:
the frame kinematics' Jacobians, the schedule's terms by the complex step in ``σ``
(``nw_sigma_terms``, as ``ffrf_sigma_terms``), ``∂(q − k)/∂(y, ẏ, u)``,
``∂(M a)/∂y``, ``∂rhs/∂x`` and the output Jacobians. The parameter derivatives follow in
:data:`.c_splice_parameters.PARAMETER_C`. The body equations are the traced kernel
functions ``nw_k_*`` these texts call; the ``NW_*`` macros are defined per model by
:mod:`.c_splice`.
"""

from __future__ import annotations

__all__ = ["JACOBIAN_C"]

#: The derivatives (mirrors ffrf_force_jacobians, ffrf_mass_matrix_times_derivative,
#: ffrf_rhs_jacobian, ffrf_output_jacobians and ffrf_sigma_terms).
JACOBIAN_C = r"""
#define NW_H 1e-30
#define NW_NX (2 * NW_NS + NW_NU)

/* kin (nh), dkin/dy = Cs[:, :ns] S_V, dkin/dyd, dkin/du (ffrf_kin_jacobians) */
static void nw_kin_jacobians(double t, const double *ys, const double *yds, const double *p,
                             const double *u, double *kin, double *Ky, double *Kyd, double *Ku)
{
    static double o[NW_NY + NW_NH + 1], C[(NW_NY + NW_NH) * NW_NX + 1];
    nw_s_outputs(t, ys, yds, p, u, o);
    memcpy(kin, o + NW_NY, NW_NH * sizeof(double));
    nw_s_output_jacobians(t, ys, yds, p, u, C);
    const double *Cs = C + NW_NY * NW_NX;
    nw_gemm(NW_NH, NW_N, NW_NS, Cs, NW_NX, 1, NW_SV, NW_N, 1, Ky);
    nw_gemm(NW_NH, NW_N, NW_NS, Cs + NW_NS, NW_NX, 1, NW_SV, NW_N, 1, Kyd);
    for (int i = 0; i < NW_NH; ++i)
        for (int k = 0; k < NW_NU; ++k) Ku[i * NW_NU + k] = Cs[i * NW_NX + 2 * NW_NS + k];
}

/* out (n x n) = S_W^T A S_V for A (ns x ns) with row stride lda */
static void nw_sandwich(const double *A, long lda, double *out)
{
    static double T[NW_NS * NW_N + 1];
    nw_gemm(NW_NS, NW_N, NW_NS, A, lda, 1, NW_SV, NW_N, 1, T);
    nw_gemm(NW_N, NW_N, NW_NS, NW_SW, 1, NW_N, T, NW_N, 1, out);
}

#if NW_NPB
/* d(q - k)/dsigma (n x NPB) or, with a, d(M a)/dsigma: the complex step in each sigma_k of the
   mixed bodies and S_V, S_W with the symbolic part's Jacobians (ffrf_sigma_terms) */
static void nw_sigma_terms(double t, const double *y, const double *yd, const double *p,
                           const double *u, const double *a, double *out)
{
    static double o[NW_NY + NW_NH + 1], C[(NW_NY + NW_NH) * NW_NX + 1], fs[NW_NS + 1];
    static double J[NW_NS * NW_NX + 1], Ms[NW_NS * NW_NS + 1], mm[NW_NS * NW_NS + 1];
    static double complex kinc[NW_NH + 1], fsc[NW_NS + 1], f[NW_N + 1];
    double ys[NW_NS + 1], yds[NW_NS + 1], as[NW_NS + 1], dys[NW_NS + 1], dyds[NW_NS + 1];
    double dk[NW_NH + 1], v[NW_NS + 1], mmd[NW_NS + 1];
    nw_smap(0, y, ys);
    nw_smap(0, yd, yds);
    nw_s_output_jacobians(t, ys, yds, p, u, C);
    nw_s_outputs(t, ys, yds, p, u, o);
    const double *Cs = C + NW_NY * NW_NX, *kin = o + NW_NY;
    if (!a) {
        nw_s_force_vector(t, ys, yds, p, u, fs);
        nw_s_force_jacobians(t, ys, yds, p, u, J);
    } else {
        nw_smap(0, a, as);
        nw_s_mass_matrix(t, ys, p, u, Ms);
        nw_s_mass_matrix_times_derivative(t, ys, p, as, u, mm);
    }
    for (int k = 0; k < NW_NPB; ++k) {
        static double complex last[NW_NW];
        static long bound = -1;
        for (int i = 0; i < NW_NW; ++i) nw_wc[i] = nw_w[i];
        for (int i = nw_woff[k]; i < nw_woff[k + 1]; ++i) nw_wc[i] += I * NW_H * nw_dw[i];
        if (bound != nw_binds || memcmp(last, nw_wc, sizeof last)) {  /* once per weights */
            nw_k_sigma_c();
            memcpy(last, nw_wc, sizeof last);
            bound = nw_binds;
        }
        nw_gemv(NW_NS, NW_N, nw_dsv[k], NW_N, 1, y, 1, dys);
        nw_gemv(NW_NS, NW_N, nw_dsv[k], NW_N, 1, yd, 1, dyds);
        for (int i = 0; i < NW_NH; ++i) {           /* dkin = Cs[:, :ns] dys + Cs[:, ns:2ns] dyds */
            double s = 0.0;
            for (int j = 0; j < NW_NS; ++j)
                s += Cs[i * NW_NX + j] * dys[j] + Cs[i * NW_NX + NW_NS + j] * dyds[j];
            dk[i] = s;
            kinc[i] = kin[i] + I * NW_H * s;
        }
        if (!a) {
            for (int i = 0; i < NW_NS; ++i) {       /* fs + ih (fys dys + fyds dyds) */
                double s = 0.0;
                for (int j = 0; j < NW_NS; ++j)
                    s += J[i * NW_NX + j] * dys[j] + J[i * NW_NX + NW_NS + j] * dyds[j];
                v[i] = s;
                fsc[i] = fs[i] + I * NW_H * s;
            }
            nw_k_sigf(kinc, y, yd, fsc, f);
        } else {
            nw_gemv(NW_NS, NW_NS, mm, NW_NS, 1, dys, 1, mmd);
            nw_k_sigm(kinc, y, a, Ms, mmd, f);
        }
        for (int i = 0; i < NW_N; ++i) out[i * NW_NPB + k] = cimag(f[i]) / NW_H;
    }
    (void)dk; (void)v;
}

/* out (n x nc) += F S: the terms of nw_sigma_terms F (n x NPB) along dsigma/dx S (NPB x nc),
   the chain rule through the schedules */
static void nw_sigma_chain(const double *F, const double *S, int nc, double *out)
{
    for (int i = 0; i < NW_N; ++i)
        for (int k = 0; k < NW_NPB; ++k)
            for (int j = 0; j < nc; ++j) out[i * nc + j] += F[i * NW_NPB + k] * S[k * nc + j];
}
#endif

int nw_force_jacobians(double t, const double *y, const double *yd, const double *p,
                       const double *u, double *out)
{
    static double J[NW_NS * NW_NX + 1], fy[NW_N * NW_N + 1], fyd[NW_N * NW_N + 1];
    static double fu[NW_N * NW_NU + 1], T[NW_NS * NW_NU + 1];
    double ys[NW_NS + 1], yds[NW_NS + 1];
    NW_DEFAULT_INPUTS;
    if (!nw_bound) return 2;
    if (nw_at(t, y, p, u)) return 3;
    nw_smap(0, y, ys);
    nw_smap(0, yd, yds);
    nw_s_force_jacobians(t, ys, yds, p, u, J);
    nw_sandwich(J, NW_NX, fy);
    nw_sandwich(J + NW_NS, NW_NX, fyd);
    for (int i = 0; i < NW_NS; ++i)
        for (int k = 0; k < NW_NU; ++k) T[i * NW_NU + k] = J[i * NW_NX + 2 * NW_NS + k];
    nw_gemm(NW_N, NW_NU, NW_NS, NW_SW, 1, NW_N, T, NW_NU, 1, fu);
NW_FIXED_JACOBIANS
#if NW_MOVING
    {   /* complex steps of the bodies on moving frames (ffrf_force_directional) */
        static double kin[NW_NH + 1], Ky[NW_NH * NW_N + 1], Kyd[NW_NH * NW_N + 1];
        static double Ku[NW_NH * NW_NU + 1];
        static double complex kc[NW_NH + 1], yc[NW_N + 1], ydc[NW_N + 1], fc[NW_N + 1];
        nw_kin_jacobians(t, ys, yds, p, u, kin, Ky, Kyd, Ku);
        for (int j = 0; j < 2 * NW_N + NW_NU; ++j) {
            const double *K = j < NW_N ? Ky : (j < 2 * NW_N ? Kyd : Ku);
            const int col = j < NW_N ? j : (j < 2 * NW_N ? j - NW_N : j - 2 * NW_N);
            const int ld = j < 2 * NW_N ? NW_N : NW_NU;
            for (int i = 0; i < NW_NH; ++i) kc[i] = kin[i] + I * NW_H * K[i * ld + col];
            for (int i = 0; i < NW_N; ++i) { yc[i] = y[i]; ydc[i] = yd[i]; }
            if (j < NW_N) yc[col] += I * NW_H;
            else if (j < 2 * NW_N) ydc[col] += I * NW_H;
            nw_k_dirf(kc, yc, ydc, fc);
            double *target = j < NW_N ? fy : (j < 2 * NW_N ? fyd : fu);
            const int ldt = j < 2 * NW_N ? NW_N : NW_NU;
            for (int i = 0; i < NW_N; ++i) target[i * ldt + col] += cimag(fc[i]) / NW_H;
        }
    }
#endif
#if NW_NPB
    {   /* the weights move with y and u */
        static double Sy[NW_NPB * NW_N + 1], Su[NW_NPB * NW_NU + 1], Fs[NW_N * NW_NPB + 1];
        if (nw_sens(t, y, p, u, Sy, Su)) {
            nw_sigma_terms(t, y, yd, p, u, 0, Fs);
            nw_sigma_chain(Fs, Sy, NW_N, fy);
            nw_sigma_chain(Fs, Su, NW_NU, fu);
        }
    }
#endif
    for (int i = 0; i < NW_N; ++i) {
        memcpy(out + i * (2 * NW_N + NW_NU), fy + i * NW_N, NW_N * sizeof(double));
        memcpy(out + i * (2 * NW_N + NW_NU) + NW_N, fyd + i * NW_N, NW_N * sizeof(double));
        memcpy(out + i * (2 * NW_N + NW_NU) + 2 * NW_N, fu + i * NW_NU, NW_NU * sizeof(double));
    }
    return 0;
}

int nw_mass_matrix_times_derivative(double t, const double *y, const double *p,
                                    const double *a, const double *u, double *out)
{
    static double mm[NW_NS * NW_NS + 1];
    double ys[NW_NS + 1], yds[NW_NS + 1] = {0}, as[NW_NS + 1], zero[NW_N + 1] = {0};
    NW_DEFAULT_INPUTS;
    if (!nw_bound) return 2;
    if (nw_at(t, y, p, u)) return 3;
    nw_smap(0, y, ys);
    nw_smap(0, a, as);
    nw_s_mass_matrix_times_derivative(t, ys, p, as, u, mm);
    nw_sandwich(mm, NW_NS, out);
#if NW_MOVING
    {   /* complex steps of the moving bodies' mass blocks times a */
        static double kin[NW_NH + 1], Ky[NW_NH * NW_N + 1], Kyd[NW_NH * NW_N + 1];
        static double Ku[NW_NH * NW_NU + 1];
        static double complex kc[NW_NH + 1], yc[NW_N + 1], fc[NW_N + 1];
        nw_kin_jacobians(t, ys, yds, p, u, kin, Ky, Kyd, Ku);
        for (int j = 0; j < NW_N; ++j) {
            for (int i = 0; i < NW_NH; ++i) kc[i] = kin[i] + I * NW_H * Ky[i * NW_N + j];
            for (int i = 0; i < NW_N; ++i) yc[i] = y[i];
            yc[j] += I * NW_H;
            nw_k_dirm(kc, yc, a, fc);
            for (int i = 0; i < NW_N; ++i) out[i * NW_N + j] += cimag(fc[i]) / NW_H;
        }
    }
#endif
#if NW_NPB
    {
        static double Sy[NW_NPB * NW_N + 1], Su[NW_NPB * NW_NU + 1], Fa[NW_N * NW_NPB + 1];
        if (nw_sens(t, y, p, u, Sy, Su)) {
            nw_sigma_terms(t, y, zero, p, u, a, Fa);
            nw_sigma_chain(Fa, Sy, NW_N, out);
        }
    }
#endif
    (void)zero; (void)yds;
    return 0;
}

int nw_rhs_jacobian(double t, const double *x, const double *p, const double *u, double *out)
{
    static double M[NW_N * NW_N + 1], f[NW_N + 1], fj[NW_N * (2 * NW_N + NW_NU) + 1];
    static double dMa[NW_N * NW_N + 1], b[NW_N * 2 * NW_N + 1];
    const double *y = x, *yd = x + NW_N;
    int r;
    NW_DEFAULT_INPUTS;
    if (!nw_bound) return 2;
    if ((r = nw_dyn(t, y, yd, p, u, M, f))) return r;
    if (nw_esolve(M, f, 1)) return 1;                          /* ydd */
    if ((r = nw_force_jacobians(t, y, yd, p, u, fj))) return r;
    if ((r = nw_mass_matrix_times_derivative(t, y, p, f, u, dMa))) return r;
    for (int i = 0; i < NW_N; ++i)
        for (int j = 0; j < 2 * NW_N; ++j)
            b[i * 2 * NW_N + j] = fj[i * (2 * NW_N + NW_NU) + j]
                                  - (j < NW_N ? dMa[i * NW_N + j] : 0.0);
    if (nw_esolve(M, b, 2 * NW_N)) return 1;
    memset(out, 0, NW_STATE_SIZE * NW_STATE_SIZE * sizeof(double));
    for (int i = 0; i < NW_N; ++i) out[i * NW_STATE_SIZE + NW_N + i] = 1.0;
    memcpy(out + NW_N * NW_STATE_SIZE, b, NW_N * 2 * NW_N * sizeof(double));
    return 0;
}

/* dout/dx = [Cs_y S_V, Cs_yd S_V] (+ the schedule's), dout/du (ffrf_output_jacobians) */
int nw_output_jacobians(double t, const double *x, const double *p, const double *u,
                        double *out)
{
    static double C[(NW_NY + NW_NH) * NW_NX + 1], Cy[NW_NY * NW_N + 1], Cyd[NW_NY * NW_N + 1];
    double ys[NW_NS + 1], yds[NW_NS + 1];
    const int ld = 2 * NW_N + NW_NU;
    NW_DEFAULT_INPUTS;
    if (!nw_bound) return 2;
    if (nw_at_sv(t, x, p, u)) return 3;
    nw_smap(0, x, ys);
    nw_smap(0, x + NW_N, yds);
    nw_s_output_jacobians(t, ys, yds, p, u, C);
    nw_gemm(NW_NY, NW_N, NW_NS, C, NW_NX, 1, NW_SV, NW_N, 1, Cy);
    nw_gemm(NW_NY, NW_N, NW_NS, C + NW_NS, NW_NX, 1, NW_SV, NW_N, 1, Cyd);
    for (int i = 0; i < NW_NY; ++i) {
        memcpy(out + i * ld, Cy + i * NW_N, NW_N * sizeof(double));
        memcpy(out + i * ld + NW_N, Cyd + i * NW_N, NW_N * sizeof(double));
        for (int k = 0; k < NW_NU; ++k) out[i * ld + 2 * NW_N + k] = C[i * NW_NX + 2 * NW_NS + k];
    }
#if NW_NPB
    static double Sy[NW_NPB * NW_N + 1], Su[NW_NPB * NW_NU + 1];
    if (NW_NY && nw_sens(t, x, p, u, Sy, Su)) {
        double d[NW_NS + 1], dd[NW_NS + 1];
        for (int k = 0; k < NW_NPB; ++k) {
            nw_gemv(NW_NS, NW_N, nw_dsv[k], NW_N, 1, x, 1, d);
            nw_gemv(NW_NS, NW_N, nw_dsv[k], NW_N, 1, x + NW_N, 1, dd);
            for (int i = 0; i < NW_NY; ++i) {
                double s = 0.0;
                for (int j = 0; j < NW_NS; ++j)
                    s += C[i * NW_NX + j] * d[j] + C[i * NW_NX + NW_NS + j] * dd[j];
                for (int j = 0; j < NW_N; ++j) out[i * ld + j] += s * Sy[k * NW_N + j];
                for (int j = 0; j < NW_NU; ++j) out[i * ld + 2 * NW_N + j] += s * Su[k * NW_NU + j];
            }
        }
    }
#endif
    return 0;
}
"""
