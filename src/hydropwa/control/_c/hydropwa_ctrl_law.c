/* ---- The control law: one small function per element of simulation/_controller.py ----
 *
 * Each function below mirrors the numba function of the same name in
 * hydropwa/simulation/_controller.py, operation for operation (same order of the
 * floating-point operations, so the commands agree to the last bits with the package's
 * compiled loop). Indices into the table T come from the HP_* macros above, which are
 * generated from the packed layout's constants in that module.
 */

/* Valve command u [1] that opens the orifice by c [1] through the dead zone (Eq. (2)). */
static double hp_dead_zone_inverse(double c, double offset, double width)
{
    double a;
    if (width <= 0.0) {
        if (c == 0.0) {
            return 0.0;
        }
        return c > 0.0 ? c + offset : c - offset;
    }
    a = c < 0.0 ? -c : c;
    if (a >= width) {
        return c > 0.0 ? c + offset : c - offset;
    }
    return c * (width + offset) / width;
}

/* Dead-zone inverse with hysteresis h: keeps the side *side (+-1) of the last command until
 * c leaves the band +-h; the inverse with the blend on that side (and before the first
 * |c| >= h, side 0), u = 0 on the other side within the band. */
static double hp_dead_zone_hysteresis(double c, double offset, double width, double hyst,
                                      double *side)
{
    double s = *side;
    if (c >= hyst) {
        s = 1.0;
    } else if (c <= -hyst) {
        s = -1.0;
    }
    *side = s;
    if (s == 0.0 || c * s >= 0.0) {
        return hp_dead_zone_inverse(c, offset, width);
    }
    return 0.0;
}

/* The reference at rest: |r'| <= HP_REST_RATE [m/s] (1 um/s) and |r''| <= HP_REST_ACCELERATION
 * [m/s^2], not exactly 0: a real reference generator leaves ~1e-12 m/s at rest. */
static int hp_rate_at_rest(double rate)
{
    return (rate < 0.0 ? -rate : rate) <= HP_REST_RATE;
}

/* Pre-opening: while r'(t_k) is at rest and r'(t_k + tau_o) is not the opening is at least the
 * blend width toward the coming move (the spool waits at the dead zone's edge, no flow yet). */
static double hp_pre_open(double c, double width, double rate_now, double rate_ahead)
{
    if (!hp_rate_at_rest(rate_now) || hp_rate_at_rest(rate_ahead)) {
        return c;
    }
    if (rate_ahead > 0.0) {
        return c > width ? c : width;
    }
    return c < -width ? c : -width;
}

/* Quiet band q: the opening asked for is 0 for |c| <= q, sign(c)*2(|c| - q) up to |c| = 2q and c
 * beyond; *hold is set where the opening is 0 and |ex| = |k_x e| < HP_QUIET_HOLD*q (the integral
 * then holds its value). */
static double hp_quiet_band(double c, double band, double ex, int *hold)
{
    const double a = c < 0.0 ? -c : c;
    const double aex = ex < 0.0 ? -ex : ex;
    *hold = 0;
    if (a >= 2.0 * band) {
        return c;
    }
    if (a <= band) {
        *hold = aex < HP_QUIET_HOLD * band;
        return 0.0;
    }
    return c > 0.0 ? 2.0 * (c - band) : 2.0 * (c + band);
}

/* Opening delay n = samples of the quiet band q: *count, the signed run of samples beyond the
 * band on one side (+k: c > q, -k: c < -q, 0 within), extended or restarted by this one; while
 * |*count| < n the band reads c limited to [-q, q] (parked, or the pressure vent's opening), from
 * the n-th sample of a run on c itself; far (|e| > e_I): c, the run counted all the same. */
static double hp_quiet_open(double c, double band, double *count, double samples, int far)
{
    double k;
    if (c > band) {
        *count = *count > 0.0 ? *count + 1.0 : 1.0;
    } else if (c < -band) {
        *count = *count < 0.0 ? *count - 1.0 : -1.0;
    } else {
        *count = 0.0;
    }
    k = *count < 0.0 ? -*count : *count;
    if (k < samples && !far) {
        return c > band ? band : (c < -band ? -band : c);
    }
    return c;
}

/* The pressure vent's share with the opening delay: 0 where it would push the rod away from the
 * target while the position share |ex| = |k_x e| is beyond the band q; else the share. */
static double hp_vent_toward_target(double share, double band, double ex)
{
    const double a = ex < 0.0 ? -ex : ex;
    if (share * ex < 0.0 && a > band) {
        return 0.0;
    }
    return share;
}

/* Opening of the low-passed pressure share s = -k_pl*p_low inside the quiet band q:
 * sign(s)*(|s| - HP_QUIET_VENT*q) beyond the dead band HP_QUIET_VENT*q, 0 inside, at most q. */
static double hp_quiet_vent(double share, double band)
{
    const double w = HP_QUIET_VENT * band;
    if (share > w) {
        return share - w < band ? share - w : band;
    }
    if (share < -w) {
        return share + w > -band ? share + w : -band;
    }
    return 0.0;
}

/* The quiet band q with the pressure vent, share = -k_pl*p_low the low-passed pressure share:
 * for |c| <= q the opening is v = hp_quiet_vent(share, q), for q < |c| < 2q
 * sign(c)*2(|c| - q) + (2 - |c|/q)*v, from 2q on c. *hold as in hp_quiet_band; *leak where
 * |c| < 2q. */
static double hp_pressure_vent(double c, double band, double share, double ex, int *hold,
                               int *leak)
{
    const double a = c < 0.0 ? -c : c;
    const double aex = ex < 0.0 ? -ex : ex;
    double vent, ramp;
    *hold = 0;
    *leak = 0;
    if (a >= 2.0 * band) {
        return c;
    }
    *leak = 1;
    vent = hp_quiet_vent(share, band);
    if (a <= band) {
        *hold = aex < HP_QUIET_HOLD * band;
        return vent;
    }
    ramp = c > 0.0 ? 2.0 * (c - band) : 2.0 * (c + band);
    return ramp + (2.0 - a / band) * vent;
}

/* Scaled L1 distance of [P_L, v, x, c] from the box of gain row r (0 inside; boxes closed). */
static double hp_box_distance(int r, double pl, double v, double x, double c)
{
    const double *b = T + HP_C_ROWS + HP_ROW * r;
    const double m[4] = {pl, v, x, c};
    double d = 0.0;
    int j;
    for (j = 0; j < 4; ++j) {
        const double lo = b[HP_R_LO + j];
        const double hi = b[HP_R_HI + j];
        if (m[j] < lo) {
            d += (lo - m[j]) / T[HP_C_SCALE + j];
        } else if (m[j] > hi) {
            d += (m[j] - hi) / T[HP_C_SCALE + j];
        }
    }
    return d;
}

/* Gain row whose box holds [P_L, v, x, c]: the last row first, then all in order, else the nearest. */
static int hp_select_row(double pl, double v, double x, double c, int last)
{
    const int n = HYDROPWA_CTRL_N_ROWS;
    int best = 0;
    double best_d = HUGE_VAL;
    int r;
    if (n <= 1) {
        return 0;
    }
    if (last >= 0 && last < n && hp_box_distance(last, pl, v, x, c) == 0.0) {
        return last;
    }
    for (r = 0; r < n; ++r) {
        const double d = hp_box_distance(r, pl, v, x, c);
        if (d == 0.0) {
            return r;
        }
        if (d < best_d) {
            best_d = d;
            best = r;
        }
    }
    return best;
}

/* Filtered backward difference of P_L [Pa/s] (first-order low-pass, coefficient a). */
static double hp_pressure_rate(const hydropwa_ctrl_state *s, double pl)
{
    const double a = T[HP_C_FILT];
    return a * s->dp_l + (1.0 - a) * (pl - s->p_l_prev) / T[HP_C_TS];
}

/* P_L the pressure gains act on: P_L − P̄_L with the washout (updates P̄_L), else P_L. */
static double hp_washout(hydropwa_ctrl_state *s, double pl)
{
    const double aw = T[HP_C_WASH];
    if (aw > 0.0) {
        s->p_l_bar = aw * s->p_l_bar + (1.0 - aw) * pl;
        return pl - s->p_l_bar;
    }
    return pl;
}

/* Opening c_ff [1] that passes the flow A_A*v_ff at the load pressure pl [Pa]: Eqs. (5)/(6)
 * inverted per flow direction (flow_feedforward). The mean-area P_L is converted with
 * A_B = alpha*A_A from the table (the package uses the areas of the parameter set: the same
 * number to an ulp). */
static double hp_flow_feedforward(double v_ff, double pl)
{
    const double aa = X[HP_X_AA];
    double pla, sgn, drop;
    if (v_ff == 0.0) {
        return 0.0;
    }
    pla = T[HP_C_PLMEAN] != 0.0 ? pl * (0.5 * (aa + X[HP_X_ALPHA] * aa)) / aa : pl;
    sgn = v_ff > 0.0 ? 1.0 : -1.0;
    drop = hp_load_flow_drop(sgn, pla, X[HP_X_PS], X[HP_X_ALPHA], X[HP_X_PT]);
    drop = X[HP_X_DPMIN] > drop ? X[HP_X_DPMIN] : drop;
    return aa * v_ff / (X[HP_X_K] * hp_signed_sqrt(drop, X[HP_X_PTR]));
}

/* Position observer: steady-state Kalman filter of [x, v] driven by the reference
 * acceleration of the last sample; replaces the measured x and v (x_kf = x, v_kf = r_rate
 * at the first step). */
static void hp_position_observer(hydropwa_ctrl_state *s, double *x, double *v, double r_rate)
{
    const double ts = T[HP_C_TS];
    double acc, xp, vp, inn;
    if (!s->started) {
        s->x_kf = *x;
        s->v_kf = r_rate;
    } else {
        acc = s->acc_prev;
        xp = s->x_kf + ts * s->v_kf + 0.5 * ts * ts * acc;
        vp = s->v_kf + ts * acc;
        inn = *x - xp;
        s->x_kf = xp + X[HP_X_KFX] * inn;
        s->v_kf = vp + X[HP_X_KFV] * inn;
    }
    *x = s->x_kf;
    *v = s->v_kf;
}

/* The reported spool position mapped to the opening by the inverse of the dead-zone inverse
 * (spool_opening): nu - offset*sign(nu) outside the blend, nu*w/(w + offset) inside. */
static double hp_spool_opening(double spool)
{
    const double off = T[HP_C_DZOFF];
    const double w = T[HP_C_DZW];
    const double a = spool < 0.0 ? -spool : spool;
    if (T[HP_C_DZINV] < 0.5) {
        return spool;
    }
    if (a >= w + off) {
        return spool > 0.0 ? spool - off : spool + off;
    }
    if (w <= 0.0) {
        return 0.0;
    }
    return spool * (w / (w + off));
}

/* Per-cell steady-state Kalman filter (cell_kalman_filter): prediction with the filter of the
 * row used at the last sample, z- = Phi z + Gamma c_in + phi0, update z = z- + L [P_L - z-_0,
 * x - z-_2]; at the first step z = [P_L, r_rate, x, 0, 0, -a_vp P_L - f_a, -a_pp P_L - f_p].
 * Replaces the measured P_L, v and x by the estimates. */
static void hp_cell_kalman_filter(hydropwa_ctrl_state *s, double *pl, double *v, double *x,
                                  double v0, int row, double spool)
{
    const double *b = E + HP_EROW * row;
    const int msp = HP_EXT && X[HP_X_ESTNU] > 0.5; /* the spool measured: y = [P_L, x, nu_m] */
    const double nu_m = msp ? hp_spool_opening(spool) : 0.0;
    double zp[HP_NZ];
    double acc, ip, ix, in;
    int i, j;
    if (!s->started) {
        s->z[0] = *pl;
        s->z[1] = v0;
        s->z[2] = *x;
        s->z[3] = nu_m;
        s->z[4] = 0.0;
        s->z[5] = -b[HP_E_INIT] * *pl - b[HP_E_INIT + 2];
        s->z[6] = -b[HP_E_INIT + 1] * *pl - b[HP_E_INIT + 3];
        s->c_in = 0.0;
    } else {
        for (i = 0; i < HP_NZ; ++i) {
            acc = b[HP_E_GAM + i] * s->c_in + b[HP_E_AFF + i];
            for (j = 0; j < HP_NZ; ++j) {
                acc += b[HP_E_PHI + HP_NZ * i + j] * s->z[j];
            }
            zp[i] = acc;
        }
        ip = *pl - zp[0];
        ix = *x - zp[2];
        for (i = 0; i < HP_NZ; ++i) {
            s->z[i] = zp[i] + b[HP_E_L + 2 * i] * ip + b[HP_E_L + 2 * i + 1] * ix;
        }
        if (msp) { /* the measured spool's innovation */
            in = nu_m - zp[3];
            for (i = 0; i < HP_NZ; ++i) {
                s->z[i] += EN[HP_NZ * row + i] * in;
            }
        }
    }
    *pl = s->z[0];
    *v = s->z[1];
    *x = s->z[2];
}

/* Velocity from the position samples: v_hat = a_v v_hat + (1 - a_v)(x_k - x_{k-1})/T_s. */
static double hp_velocity_filter(hydropwa_ctrl_state *s, double x)
{
    const double av = X[HP_X_VEST];
    s->v_hat = av * s->v_hat + (1.0 - av) * (x - s->x_prev) / T[HP_C_TS];
    s->x_prev = x;
    return s->v_hat;
}

/* Spool filter (spool_feedback): the measured spool mapped to the opening by the inverse of
 * the dead-zone inverse (spool_opening), then the valve model's prediction corrected by the
 * steady-state Kalman gain [L_nu, L_dnu]. */
static void hp_spool_filter(hydropwa_ctrl_state *s, double spool)
{
    const double nu_m = hp_spool_opening(spool);
    double inn;
    inn = nu_m - s->nu;
    s->nu = s->nu + X[HP_X_SPLN] * inn;
    s->dnu = s->dnu + X[HP_X_SPLD] * inn;
}

/* Schema-2 terms added to c: the flow feed-forward, the reference state [P_ref, r'] of the
 * row's k_v and k_pl, and the spool-state feedback on the valve model's estimate. */
static double hp_extension(hydropwa_ctrl_state *s, const double *b, int row, double pl,
                           double spool, const hydropwa_ctrl_ref *ref)
{
    const double *xb = X + HP_N_EXT + HP_XROW * row;
    const double aw = T[HP_C_WASH];
    double c_fl = 0.0, c_ff, dr, p_ref, kup;
    s->p_ref_w = 0.0;
    if (X[HP_X_FF] > 0.5) {
        c_fl = hp_flow_feedforward(ref->r_rate_ff, pl);
    }
    c_ff = c_fl;
    if (X[HP_X_REFST] > 0.5) { /* the gains act on the deviation from the reference state */
        dr = ref->r_rate;
        p_ref = (X[HP_X_MASS] * ref->r_acc + X[HP_X_BV] * dr) / X[HP_X_AA];
        if (aw > 0.0) {
            s->p_ref_bar = aw * s->p_ref_bar + (1.0 - aw) * p_ref;
            p_ref -= s->p_ref_bar;
        }
        s->p_ref_w = p_ref;
        c_ff += b[HP_R_KV] * dr + b[HP_R_KPL] * p_ref;
        if (X[HP_X_SPOOL] > 0.5) { /* the spool and the pending command follow c_fl */
            kup = T[HP_C_DELAY] > 0.5 ? xb[HP_XR_KUP] : 0.0;
            c_ff += (xb[HP_XR_KNU] + kup) * c_fl;
        }
    }
    if (X[HP_X_SPOOL] > 0.5) { /* spool-state feedback on the valve model's estimate */
        if (X[HP_X_EST] > 0.5) { /* or on the Kalman filter's */
            c_ff -= xb[HP_XR_KNU] * s->z[3] + xb[HP_XR_KDNU] * s->z[4];
        } else {
            if (X[HP_X_SPOOL] < 1.5 && X[HP_X_SPLN] > 0.0) { /* corrected by the measured spool */
                hp_spool_filter(s, spool);
            }
            c_ff -= xb[HP_XR_KNU] * s->nu + xb[HP_XR_KDNU] * s->dnu;
        }
        if (T[HP_C_DELAY] > 0.5) {
            c_ff -= xb[HP_XR_KUP] * s->c_pending;
        }
    }
    return c_ff;
}

/* The discrete valve model [nu, nu']+ = Phi [nu, nu'] + Gamma c_apply (ZOH of Eq. (1)). */
static void hp_spool_update(hydropwa_ctrl_state *s, double c_apply)
{
    const double nu = s->nu;
    const double dnu = s->dnu;
    const double *f = X + HP_X_PHI;
    const double *g = X + HP_X_GAM;
    s->nu = f[0] * nu + f[1] * dnu + g[0] * c_apply;
    s->dnu = f[2] * nu + f[3] * dnu + g[1] * c_apply;
}

/* Integral update with the anti-windup of the table (none, clamping, back-calculation); schema 2:
 * where the quiet band parks the valve (c_open = 0), or with the pressure vent wherever
 * |c| < 2q (leak), it decays by the leak a_l if one is set, and beyond the integral band
 * |e| > e_I it does not run. */
static void hp_integrate(hydropwa_ctrl_state *s, double e, double ki, double u_raw, double u,
                         double c_raw, double c_sat, int held, int leak)
{
    const double ts = T[HP_C_TS];
    const int aw = (int)T[HP_C_AW];
    const double ae = e < 0.0 ? -e : e;
    const int far = HP_EXT && X[HP_X_IBAND] > 0.0 && ae > X[HP_X_IBAND];
    const int parked
        = leak || (HP_EXT && X[HP_X_DZQ] > 0.0 && c_raw == 0.0 && T[HP_C_DZINV] > 0.5);
    if (parked && X[HP_X_ILEAK] > 0.0) { /* the valve parked: the integral decays toward 0 */
        s->integral *= X[HP_X_ILEAK];
        return;
    }
    if (ki == 0.0 || held || far) {
        return;
    }
    if (aw == HP_AW_CLAMP) {
        /* integrate unless saturated and the error would drive further into the limit */
        if (u == u_raw || (u_raw > u && e * ki < 0.0) || (u_raw < u && e * ki > 0.0)) {
            s->integral += ts * e;
        }
    } else if (aw == HP_AW_BACK) {
        s->integral += ts * (e + T[HP_C_KT] * (c_sat - c_raw) / ki);
    } else {
        s->integral += ts * e;
    }
}

double hydropwa_ctrl_load_pressure(double p_a, double p_b, double area_a, double area_b)
{
    const double area = T[HP_C_PLMEAN] != 0.0 ? 0.5 * (area_a + area_b) : area_a;
    return (p_a * area_a - p_b * area_b) / area;
}

void hydropwa_ctrl_reset(hydropwa_ctrl_state *s)
{
    int i;
    s->integral = 0.0;
    s->p_l_prev = 0.0;
    s->dp_l = 0.0;
    s->pending = 0.0;
    s->c_prev = 0.0;
    s->p_l_bar = 0.0;
    s->row = 0;
    s->started = 0;
    s->c_raw = 0.0;
    s->u_new = 0.0;
    s->x_prev = 0.0;
    s->v_hat = 0.0;
    s->p_ref_bar = 0.0;
    s->nu = 0.0;
    s->dnu = 0.0;
    s->c_pending = 0.0;
    s->x_kf = 0.0;
    s->v_kf = 0.0;
    s->acc_prev = 0.0;
    s->c_ff = 0.0;
    s->dz_side = 0.0;
    for (i = 0; i < 7; ++i) {
        s->z[i] = 0.0;
    }
    s->c_in = 0.0;
    s->p_ref_w = 0.0;
    s->p_low = 0.0;
    s->dz_open = 0.0;
}

void hydropwa_ctrl_init(hydropwa_ctrl_state *s)
{
    hydropwa_ctrl_reset(s);
}

double hydropwa_ctrl_step(hydropwa_ctrl_state *s, const hydropwa_ctrl_meas *m,
                          const hydropwa_ctrl_ref *ref)
{
    double x = m->x;
    double v = m->v;
    double pl = m->p_l;
    const double r = ref->r;
    double e = r - x;
    double dpl, pl_fb, ki, c_raw, c_ff, c_open, c_band, share, u_raw, u, c_sat, u_apply, c_apply;
    double p_dev;
    const double *b;
    int row, kal, held, leak, vented, far;
    if (!s->started) {
        s->p_l_prev = pl;
        s->dp_l = 0.0;
        s->p_l_bar = pl;
        s->x_prev = x;
        s->v_hat = 0.0;
        s->p_ref_bar = 0.0;
        s->nu = 0.0;
        s->dnu = 0.0;
        s->dz_side = 0.0;
        s->dz_open = 0.0;
    }
    kal = HP_EXT && X[HP_X_EST] > 0.5;
    if (kal) { /* per-cell Kalman filter: the law uses the estimates */
        row = s->started ? s->row : hp_select_row(pl, ref->r_rate, x, 0.0, -1);
        hp_cell_kalman_filter(s, &pl, &v, &x, ref->r_rate, row, m->spool);
        e = r - x;
    }
    if (HP_EXT && X[HP_X_KF] > 0.5) {
        hp_position_observer(s, &x, &v, ref->r_rate);
        e = r - x;
    }
    if (HP_EXT && X[HP_X_VEST] > 0.0) {
        v = hp_velocity_filter(s, x);
    }
    dpl = hp_pressure_rate(s, pl);
    pl_fb = hp_washout(s, pl);
    row = hp_select_row(pl, v, x, s->c_prev, s->started ? s->row : -1);
    b = T + HP_C_ROWS + HP_ROW * row;
    ki = b[HP_R_KI];
    c_raw = b[HP_R_UFF] + b[HP_R_KP] * e + ki * s->integral + b[HP_R_KFF] * ref->r_rate
            - b[HP_R_KV] * v - b[HP_R_KPL] * pl_fb - b[HP_R_KDPL] * dpl;
    c_ff = 0.0;
    p_dev = pl_fb; /* the load-pressure deviation the gains k_pl act on */
    if (HP_EXT) {
        c_ff = hp_extension(s, b, row, pl, m->spool, ref);
        c_raw += c_ff;
        p_dev = pl_fb - s->p_ref_w;
    }
    c_open = c_raw; /* the opening asked for (with the quiet band, schema 2) */
    held = 0;
    leak = 0;
    if (T[HP_C_DZINV] < 0.5) {
        u_raw = c_raw;
    } else {
        vented = HP_EXT && X[HP_X_DZQ] > 0.0 && X[HP_X_DZPV] > 0.0;
        if (vented) { /* the pressure vent's low-pass runs every sample */
            s->p_low = s->started ? X[HP_X_DZPV] * s->p_low + (1.0 - X[HP_X_DZPV]) * p_dev : p_dev;
        }
        /* with X_DZQR = 1 the band acts only while the reference is at rest */
        if (HP_EXT && X[HP_X_DZQ] > 0.0
            && (X[HP_X_DZQR] < 0.5
                || (hp_rate_at_rest(ref->r_rate) && hp_rate_at_rest(ref->r_rate_ff)
                    && (ref->r_acc < 0.0 ? -ref->r_acc : ref->r_acc) <= HP_REST_ACCELERATION))) {
            c_band = c_raw;
            if (X[HP_X_DZQO] > 0.0) { /* the band opens only after n samples beyond q */
                far = X[HP_X_IBAND] > 0.0 && (e < 0.0 ? -e : e) > X[HP_X_IBAND];
                c_band = hp_quiet_open(c_raw, X[HP_X_DZQ], &s->dz_open, X[HP_X_DZQO], far);
            }
            if (vented) { /* inside the band the low-passed pressure share vents */
                share = -b[HP_R_KPL] * s->p_low;
                if (X[HP_X_DZQO] > 0.0) { /* with the delay the vent does not push outward */
                    share = hp_vent_toward_target(share, X[HP_X_DZQ], b[HP_R_KP] * e);
                }
                c_open = hp_pressure_vent(c_band, X[HP_X_DZQ], share, b[HP_R_KP] * e, &held,
                                          &leak);
            } else {
                c_open = hp_quiet_band(c_band, X[HP_X_DZQ], b[HP_R_KP] * e, &held);
            }
        } else if (HP_EXT) {
            s->dz_open = 0.0;
        }
        if (HP_EXT && X[HP_X_DZPO] > 0.0) {
            c_open = hp_pre_open(c_open, T[HP_C_DZW], ref->r_rate, ref->r_rate_pre);
        }
        if (HP_EXT && X[HP_X_DZH] > 0.0) {
            u_raw = hp_dead_zone_hysteresis(c_open, T[HP_C_DZOFF], T[HP_C_DZW], X[HP_X_DZH],
                                            &s->dz_side);
        } else {
            u_raw = hp_dead_zone_inverse(c_open, T[HP_C_DZOFF], T[HP_C_DZW]);
        }
    }
    u = u_raw > T[HP_C_UMIN] ? u_raw : T[HP_C_UMIN];
    u = u < T[HP_C_UMAX] ? u : T[HP_C_UMAX];
    c_sat = c_open - (u_raw - u); /* the inverse has slope 1 where the command saturates */
    hp_integrate(s, e, ki, u_raw, u, c_open, c_sat, held, leak);
    if (T[HP_C_DELAY] > 0.5) {
        u_apply = s->pending;
        s->pending = u;
        c_apply = s->c_pending;
        s->c_pending = c_sat;
    } else {
        u_apply = u;
        c_apply = c_sat;
    }
    if (HP_EXT && X[HP_X_SPOOL] > 0.5) {
        hp_spool_update(s, c_apply);
    }
    if (kal) {
        s->c_in = c_apply;
    }
    s->p_l_prev = pl;
    s->dp_l = dpl;
    s->c_prev = c_sat;
    s->row = row;
    s->c_raw = c_raw;
    s->c_ff = c_ff;
    s->u_new = u;
    s->acc_prev = ref->r_acc;
    s->started = 1;
    return u_apply;
}
