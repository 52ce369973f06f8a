#include <math.h>

/* ---- Right-hand side: translated from the compiled kernel by hydropwa/simulation/_emit_c.py
 * (rhs_full and the component functions of components/_physics.py it calls). ---- */
@RHS@
/* ---- Variables (generated from hydropwa/_layout.py) ---- */
@VARS@

typedef struct {
    double vars[HP_NVARS];
    double p[HP_NP];      /* the kernel's packed parameter vector */
    double y[HP_NY];      /* state */
    double f[HP_NY];      /* rate at (t, y) (first stage of the next step) */
    double h;             /* step size proposal [s] */
    double t;             /* time of y */
    double du[HP_NIN];    /* input rates set by the master (first-order hold) */
    double t_in;          /* time at which the inputs were set */
    int have_f;
} hp_model;

static void hp_model_reset(hp_model *m)
{
    int i;
    for (i = 0; i < HP_NVARS; ++i) {
        m->vars[i] = hp_start[i];
    }
    for (i = 0; i < HP_NIN; ++i) {
        m->du[i] = 0.0;
    }
    m->h = 0.0;
    m->t = 0.0;
    m->t_in = 0.0;
    m->have_f = 0;
}

static void hp_model_outputs(hp_model *m)
{
    int i;
    for (i = 0; i < HP_NOUT; ++i) {
        m->vars[HP_VR_OUT + i] = m->y[hp_out_state[i]];
    }
}

static void hp_model_start(hp_model *m, double t0)
{
    int i;
    for (i = 0; i < HP_NP; ++i) {
        m->p[i] = hp_p_default[i];
    }
    for (i = 0; i < HP_NPAR; ++i) {
        m->p[hp_par_slot[i]] = m->vars[HP_VR_PAR + i];
    }
    for (i = 0; i < HP_NY; ++i) {
        m->y[i] = m->vars[HP_VR_Y0 + i];
    }
    m->t = t0;
    m->t_in = t0;
    m->h = 0.0;
    m->have_f = 0;
    hp_model_outputs(m);
}

static int hp_model_input_derivative(hp_model *m, unsigned int vr, int order, double value)
{
    if (vr >= HP_NIN || order != 1) {
        return 1;
    }
    m->du[vr] = value;
    return 0;
}

static void hp_rhs(hp_model *m, double t, const double *y, double *dy)
{
    const double dt = t - m->t_in;
    const double u = m->vars[HP_VR_U] + m->du[HP_VR_U] * dt;
    const double ps = m->vars[HP_VR_PS] + m->du[HP_VR_PS] * dt;
    const double fl = m->vars[HP_VR_FL] + m->du[HP_VR_FL] * dt;
    hp_rhs_full(y, u, ps, fl, m->p, dy);
}

/* Dormand-Prince 5(4) with the error norm of the package's integrator (atol = rtol x the
 * state's typical magnitude of hydropwa/_layout.py); steps end on t + h exactly. */
static int hp_model_do_step(hp_model *m, double t, double h)
{
    static const double c2 = 1.0 / 5.0, c3 = 3.0 / 10.0, c4 = 4.0 / 5.0, c5 = 8.0 / 9.0;
    static const double a21 = 1.0 / 5.0;
    static const double a31 = 3.0 / 40.0, a32 = 9.0 / 40.0;
    static const double a41 = 44.0 / 45.0, a42 = -56.0 / 15.0, a43 = 32.0 / 9.0;
    static const double a51 = 19372.0 / 6561.0, a52 = -25360.0 / 2187.0, a53 = 64448.0 / 6561.0,
                        a54 = -212.0 / 729.0;
    static const double a61 = 9017.0 / 3168.0, a62 = -355.0 / 33.0, a63 = 46732.0 / 5247.0,
                        a64 = 49.0 / 176.0, a65 = -5103.0 / 18656.0;
    static const double b1 = 35.0 / 384.0, b3 = 500.0 / 1113.0, b4 = 125.0 / 192.0,
                        b5 = -2187.0 / 6784.0, b6 = 11.0 / 84.0;
    static const double e1 = 71.0 / 57600.0, e3 = -71.0 / 16695.0, e4 = 71.0 / 1920.0,
                        e5 = -17253.0 / 339200.0, e6 = 22.0 / 525.0, e7 = -1.0 / 40.0;
    const double rtol = m->vars[HP_VR_RTOL];
    const double t_end = t + h;
    double k2[HP_NY], k3[HP_NY], k4[HP_NY], k5[HP_NY], k6[HP_NY], k7[HP_NY], yt[HP_NY],
        yn[HP_NY];
    long steps = 0;
    int i;
    m->t_in = t; /* the inputs (and their rates) were set at this communication point */
    hp_rhs(m, m->t, m->y, m->f);
    m->have_f = 1;
    if (m->h <= 0.0) {
        m->h = h < 1e-5 ? h : 1e-5;
    }
    while (m->t < t_end) {
        double hs = m->h, err = 0.0, fac;
        int last = 0;
        if (m->t + hs >= t_end - 1e-12 * h) {
            hs = t_end - m->t;
            last = 1;
        }
        for (i = 0; i < HP_NY; ++i) yt[i] = m->y[i] + hs * (a21 * m->f[i]);
        hp_rhs(m, m->t + c2 * hs, yt, k2);
        for (i = 0; i < HP_NY; ++i) yt[i] = m->y[i] + hs * (a31 * m->f[i] + a32 * k2[i]);
        hp_rhs(m, m->t + c3 * hs, yt, k3);
        for (i = 0; i < HP_NY; ++i)
            yt[i] = m->y[i] + hs * (a41 * m->f[i] + a42 * k2[i] + a43 * k3[i]);
        hp_rhs(m, m->t + c4 * hs, yt, k4);
        for (i = 0; i < HP_NY; ++i)
            yt[i] = m->y[i] + hs * (a51 * m->f[i] + a52 * k2[i] + a53 * k3[i] + a54 * k4[i]);
        hp_rhs(m, m->t + c5 * hs, yt, k5);
        for (i = 0; i < HP_NY; ++i)
            yt[i] = m->y[i] + hs * (a61 * m->f[i] + a62 * k2[i] + a63 * k3[i] + a64 * k4[i]
                                    + a65 * k5[i]);
        hp_rhs(m, m->t + hs, yt, k6);
        for (i = 0; i < HP_NY; ++i)
            yn[i] = m->y[i] + hs * (b1 * m->f[i] + b3 * k3[i] + b4 * k4[i] + b5 * k5[i]
                                    + b6 * k6[i]);
        hp_rhs(m, m->t + hs, yn, k7);
        for (i = 0; i < HP_NY; ++i) {
            const double sc = rtol * hp_scale[i] + rtol * fmax(fabs(m->y[i]), fabs(yn[i]));
            const double d = hs * (e1 * m->f[i] + e3 * k3[i] + e4 * k4[i] + e5 * k5[i]
                                   + e6 * k6[i] + e7 * k7[i]) / sc;
            err += d * d;
        }
        err = sqrt(err / HP_NY);
        if (!(err == err)) {
            return 1; /* NaN */
        }
        if (err <= 1.0) {
            m->t = last ? t_end : m->t + hs;
            for (i = 0; i < HP_NY; ++i) {
                m->y[i] = yn[i];
                m->f[i] = k7[i];
            }
        }
        fac = err > 0.0 ? 0.9 * pow(err, -0.2) : 5.0;
        fac = fac < 0.2 ? 0.2 : (fac > 5.0 ? 5.0 : fac);
        if (!last || err > 1.0) {
            m->h = hs * fac;
        }
        if (++steps > 10000000L || m->h < 1e-14) {
            return 1;
        }
    }
    return 0;
}
