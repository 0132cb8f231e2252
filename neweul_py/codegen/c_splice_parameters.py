"""The parameter derivatives of a model with elastic bodies in C (docs/sensitivity.md).

Fixed C text appended to the derivative library after :data:`.c_splice_jacobians.JACOBIAN_C`
(whose helpers it uses), in the order of :mod:`neweul_py.ffrf.splice`:
``nw_force_parameter_jacobian`` (``ffrf_force_parameter_jacobian``),
``nw_mass_matrix_parameter_derivative`` (``ffrf_mass_matrix_parameter_derivative``) and
``nw_output_parameter_jacobian`` (``ffrf_output_parameter_jacobian``): the symbolic part's
derivatives sandwiched by ``S_W``, the complex step of the traced body terms along the frame
kinematics' ``∂kin/∂p`` (``nw_k_dirp``: every body's forces; ``nw_k_dirm``: the moving
bodies' mass blocks at zero velocities), and the schedules' ``∂σ/∂p`` through the complex step
in ``σ`` (``nw_sigma_terms``). ``∂rhs/∂p`` is composed by the wrapper.
"""

__all__ = ["PARAMETER_C"]

#: The parameter derivatives (needs ``NW_NP`` and the ``nw_s_*parameter*`` functions).
PARAMETER_C = r"""
/* ---- the parameter derivatives (docs/sensitivity.md) */

/* dsigma/dp (NPB x NP) at the base S_V; 0 when the schedules depend on no parameter
   (ffrf_sigma_parameter_sensitivity) */
static int nw_psens(double t, const double *y, const double *p, const double *u, double *Sp)
{
#if NW_NPB && NW_NP
    double ys0[NW_NS + 1];
    int any = 0;
    nw_smap(1, y, ys0);
    nw_s_schedule_parameter_jacobian(t, ys0, p, u, Sp);
    for (int i = 0; i < NW_NPB * NW_NP; ++i) any |= Sp[i] != 0.0;
    return any;
#else
    (void)t; (void)y; (void)p; (void)u; (void)Sp;
    return 0;
#endif
}

/* d(q - k)/dp (n x np) at fixed u: S_W^T of the symbolic part's, the elastic terms of every
   body along dkin/dp (complex step), and through the schedules */
int nw_force_parameter_jacobian(double t, const double *y, const double *yd, const double *p,
                                const double *u, double *out)
{
    static double J[NW_NS * NW_NP + 1], o[NW_NY + NW_NH + 1], Kp[(NW_NY + NW_NH) * NW_NP + 1];
    static double complex kc[NW_NH + 1], fc[NW_N + 1];
    double ys[NW_NS + 1], yds[NW_NS + 1];
    NW_DEFAULT_INPUTS;
    if (!nw_bound) return 2;
    if (nw_at(t, y, p, u)) return 3;
    if (!NW_NP) return 0;
    nw_smap(0, y, ys);
    nw_smap(0, yd, yds);
    nw_s_force_parameter_jacobian(t, ys, yds, p, u, J);
    nw_gemm(NW_N, NW_NP, NW_NS, NW_SW, 1, NW_N, J, NW_NP, 1, out);
    nw_s_outputs(t, ys, yds, p, u, o);
    nw_s_output_parameter_jacobian(t, ys, yds, p, u, Kp);
    for (int j = 0; j < NW_NP; ++j) {
        int used = 0;
        for (int i = 0; i < NW_NH; ++i) {
            const double d = Kp[(NW_NY + i) * NW_NP + j];
            used |= d != 0.0;
            kc[i] = o[NW_NY + i] + I * NW_H * d;
        }
        if (!used) continue;
        nw_k_dirp(kc, y, yd, fc);
        for (int i = 0; i < NW_N; ++i) out[i * NW_NP + j] += cimag(fc[i]) / NW_H;
    }
#if NW_NPB
    {
        static double Sp[NW_NPB * NW_NP + 1], Fs[NW_N * NW_NPB + 1];
        if (nw_psens(t, y, p, u, Sp)) {
            nw_sigma_terms(t, y, yd, p, u, 0, Fs);
            nw_sigma_chain(Fs, Sp, NW_NP, out);
        }
    }
#endif
    return 0;
}

/* d(M(y) a)/dp (n x np) for a fixed a: S_W^T of the symbolic part's, the moving bodies' mass
   blocks along dkin/dp (complex step, at zero velocities), and through the schedules */
int nw_mass_matrix_parameter_derivative(double t, const double *y, const double *p,
                                        const double *a, const double *u, double *out)
{
    static double mm[NW_NS * NW_NP + 1];
    double ys[NW_NS + 1], yds[NW_NS + 1] = {0}, as[NW_NS + 1], zero[NW_N + 1] = {0};
    NW_DEFAULT_INPUTS;
    if (!nw_bound) return 2;
    if (nw_at(t, y, p, u)) return 3;
    if (!NW_NP) return 0;
    nw_smap(0, y, ys);
    nw_smap(0, a, as);
    nw_s_mass_matrix_parameter_derivative(t, ys, p, as, u, mm);
    nw_gemm(NW_N, NW_NP, NW_NS, NW_SW, 1, NW_N, mm, NW_NP, 1, out);
#if NW_MOVING
    {
        static double o[NW_NY + NW_NH + 1], Kp[(NW_NY + NW_NH) * NW_NP + 1];
        static double complex kc[NW_NH + 1], yc[NW_N + 1], fc[NW_N + 1];
        nw_s_outputs(t, ys, yds, p, u, o);
        nw_s_output_parameter_jacobian(t, ys, yds, p, u, Kp);
        for (int i = 0; i < NW_N; ++i) yc[i] = y[i];
        for (int j = 0; j < NW_NP; ++j) {
            int used = 0;
            for (int i = 0; i < NW_NH; ++i) {
                const double d = Kp[(NW_NY + i) * NW_NP + j];
                used |= d != 0.0;
                kc[i] = o[NW_NY + i] + I * NW_H * d;
            }
            if (!used) continue;
            nw_k_dirm(kc, yc, a, fc);
            for (int i = 0; i < NW_N; ++i) out[i * NW_NP + j] += cimag(fc[i]) / NW_H;
        }
    }
#endif
#if NW_NPB
    {
        static double Sp[NW_NPB * NW_NP + 1], Fa[NW_N * NW_NPB + 1];
        if (nw_psens(t, y, p, u, Sp)) {
            nw_sigma_terms(t, y, zero, p, u, a, Fa);
            nw_sigma_chain(Fa, Sp, NW_NP, out);
        }
    }
#endif
    (void)zero; (void)yds;
    return 0;
}

/* dout/dp (ny x np) at fixed state and u: the symbolic part's, and through S_V(sigma) */
int nw_output_parameter_jacobian(double t, const double *x, const double *p, const double *u,
                                 double *out)
{
    static double O[(NW_NY + NW_NH) * NW_NP + 1];
    double ys[NW_NS + 1], yds[NW_NS + 1];
    NW_DEFAULT_INPUTS;
    if (!nw_bound) return 2;
    if (nw_at_sv(t, x, p, u)) return 3;
    if (!NW_NP) return 0;
    nw_smap(0, x, ys);
    nw_smap(0, x + NW_N, yds);
    nw_s_output_parameter_jacobian(t, ys, yds, p, u, O);
    memcpy(out, O, NW_NY * NW_NP * sizeof(double));
#if NW_NPB
    {
        static double Sp[NW_NPB * NW_NP + 1], C[(NW_NY + NW_NH) * NW_NX + 1];
        if (NW_NY && nw_psens(t, x, p, u, Sp)) {
            double d[NW_NS + 1], dd[NW_NS + 1];
            nw_s_output_jacobians(t, ys, yds, p, u, C);
            for (int k = 0; k < NW_NPB; ++k) {
                nw_gemv(NW_NS, NW_N, nw_dsv[k], NW_N, 1, x, 1, d);
                nw_gemv(NW_NS, NW_N, nw_dsv[k], NW_N, 1, x + NW_N, 1, dd);
                for (int i = 0; i < NW_NY; ++i) {
                    double s = 0.0;
                    for (int j = 0; j < NW_NS; ++j)
                        s += C[i * NW_NX + j] * d[j] + C[i * NW_NX + NW_NS + j] * dd[j];
                    for (int j = 0; j < NW_NP; ++j) out[i * NW_NP + j] += s * Sp[k * NW_NP + j];
                }
            }
        }
    }
#endif
    return 0;
}
"""
