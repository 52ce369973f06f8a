/* ---- The interface of the law ----
 *
 * hp_law_step and hp_load_pressure above are the package's compiled law
 * (hydropwa/simulation/_controller.py: law_step and its stages, measure's load pressure),
 * translated statement by statement from their numba source by simulation/_emit_c.py: the
 * same floating-point operations in the same order. This part only passes the structs of
 * hydropwa_ctrl.h to it as the law's vectors (the memory cst, the log column, the reference
 * channels rc; indices HP_* generated from hydropwa/_layout_law.py).
 */

double hydropwa_ctrl_load_pressure(double p_a, double p_b, double area_a, double area_b)
{
    return hp_load_pressure(p_a, p_b, area_a, area_b, T[HP_C_PLMEAN]);
}

void hydropwa_ctrl_reset(hydropwa_ctrl_state *s)
{
    int i;
    for (i = 0; i < HP_N_CST; ++i) {
        s->cst[i] = 0.0;
    }
    for (i = 0; i < HP_N_LOG; ++i) {
        s->log[i] = 0.0;
    }
    s->k = 0.0;
    s->row = 0;
    s->c_raw = 0.0;
    s->u_new = 0.0;
    s->c_ff = 0.0;
}

void hydropwa_ctrl_init(hydropwa_ctrl_state *s)
{
    hydropwa_ctrl_reset(s);
}

double hydropwa_ctrl_step(hydropwa_ctrl_state *s, const hydropwa_ctrl_meas *m,
                          const hydropwa_ctrl_ref *ref)
{
    double meas[5], rc[HP_N_RCH], u;
    const double areas[2] = {HP_AREA_A, HP_AREA_B};
    int i;
    for (i = 0; i < HP_N_RCH; ++i) {
        rc[i] = 0.0; /* no sensor noise channels: the noise is in the measurements */
    }
    rc[HP_RC_DR] = ref->r_rate;
    rc[HP_RC_DRFF] = ref->r_rate_ff;
    rc[HP_RC_DDR] = ref->r_acc;
    rc[HP_RC_DRPO] = ref->r_rate_pre;
    meas[0] = m->x;
    meas[1] = m->v;
    meas[2] = m->p_l;
    meas[3] = m->spool;
    meas[4] = 1.0; /* the spool is reported (read only by a controller that measures it) */
    u = hp_law_step(s->k, s->k * T[HP_C_TS], meas, ref->r, T, (double)HYDROPWA_CTRL_N_TABLE,
                    areas, s->cst, rc, s->log);
    s->k += 1.0;
    s->row = (int)s->log[HP_L_ROW];
    s->c_raw = s->log[HP_L_C];
    s->u_new = s->log[HP_L_UNEW];
    s->c_ff = s->log[HP_L_UFF];
    return u;
}
