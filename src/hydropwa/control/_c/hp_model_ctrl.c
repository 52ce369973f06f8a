#include "hydropwa_ctrl.h"

/* Variables (value references): inputs x [m], v [m/s], p_l [Pa], r [m], r_rate [m/s],
 * r_rate_ff [m/s] (the rate at t + HYDROPWA_CTRL_LEAD), r_acc [m/s^2], r_rate_pre [m/s] (the
 * rate at t + HYDROPWA_CTRL_PRE_OPEN); output u [1]; input spool [1] (the reported spool
 * position, appended after u so that the earlier value references stay). */
#define HP_NVARS 10
enum { VR_X, VR_V, VR_PL, VR_R, VR_RRATE, VR_RRATEFF, VR_RACC, VR_RRATEPRE, VR_U, VR_SPOOL };
static const int hp_model_settable[HP_NVARS] = {1, 1, 1, 1, 1, 1, 1, 1, 0, 1};

typedef struct {
    double vars[HP_NVARS];
    hydropwa_ctrl_state s;
    double t0;   /* start time: sample instants are t0 + k*T_s */
    double time; /* current communication point */
    long k;      /* next sample */
    double held; /* command held since the last sample */
} hp_model;

static void hp_model_reset(hp_model *m)
{
    int i;
    for (i = 0; i < HP_NVARS; ++i) {
        m->vars[i] = 0.0;
    }
    hydropwa_ctrl_init(&m->s);
    m->t0 = 0.0;
    m->time = 0.0;
    m->k = 0;
    m->held = 0.0;
}

static void hp_model_start(hp_model *m, double t0)
{
    m->t0 = t0;
    m->time = t0;
    m->k = 0;
    hydropwa_ctrl_reset(&m->s);
}

static double hp_sample_time(const hp_model *m, long k)
{
    return m->t0 + (double)k * HYDROPWA_CTRL_SAMPLE_TIME;
}

static double hp_sample(hp_model *m, hydropwa_ctrl_state *s)
{
    hydropwa_ctrl_meas meas;
    hydropwa_ctrl_ref ref;
    meas.x = m->vars[VR_X];
    meas.v = m->vars[VR_V];
    meas.p_l = m->vars[VR_PL];
    meas.spool = m->vars[VR_SPOOL]; /* read only by a controller that measures the spool */
    ref.r = m->vars[VR_R];
    ref.r_rate = m->vars[VR_RRATE];
    ref.r_rate_ff = m->vars[VR_RRATEFF];
    ref.r_acc = m->vars[VR_RACC];
    ref.r_rate_pre = m->vars[VR_RRATEPRE];
    return hydropwa_ctrl_step(s, &meas, &ref);
}

/* u: the command of the last sample, held (no direct feedthrough: doStep(t_k, h) samples
 * the inputs set at t_k, and the command is an output from then on, for the master to
 * pass to the plant before the plant's step from t_k). */
static void hp_model_outputs(hp_model *m)
{
    m->vars[VR_U] = m->held;
}

/* The inputs are sampled: their rates are not used. */
static int hp_model_input_derivative(hp_model *m, unsigned int vr, int order, double value)
{
    (void)m;
    (void)vr;
    (void)order;
    (void)value;
    return 1;
}

/* Every sample instant in [t, t + h) with the inputs held over the step. */
static int hp_model_do_step(hp_model *m, double t, double h)
{
    const double tol = 1e-9 * HYDROPWA_CTRL_SAMPLE_TIME;
    while (hp_sample_time(m, m->k) < t + h - tol) {
        m->held = hp_sample(m, &m->s);
        m->k += 1;
    }
    m->time = t + h;
    return 0;
}
