/* The public functions: thin wrappers of the generated ones above (no arithmetic here). */
void hydropwa_monitor_init(double sums[HYDROPWA_MONITOR_NS])
{
    int i;
    for (i = 0; i < HYDROPWA_MONITOR_NS; ++i) {
        sums[i] = 0.0;
    }
}

void hydropwa_monitor_row(double sums[HYDROPWA_MONITOR_NS], double nu, double nu_model, double x,
                          double v, double a, double p_a, double p_b, double dp_a, double dp_b,
                          double p_s, double f_l, double r[3])
{
    hp_monitor_row(sums, P, nu, nu_model, x, v, a, p_a, p_b, dp_a, dp_b, p_s, f_l, &r[0], &r[1],
                   &r[2]);
}

int hydropwa_monitor_result(const double sums[HYDROPWA_MONITOR_NS], double value[3], int alarm[3],
                            double rms[3])
{
    double a0, a1, a2;
    hp_monitor_result(sums, P, &value[0], &value[1], &value[2], &a0, &a1, &a2, &rms[0], &rms[1],
                      &rms[2]);
    alarm[0] = a0 > 0.5;
    alarm[1] = a1 > 0.5;
    alarm[2] = a2 > 0.5;
    return alarm[0] + alarm[1] + alarm[2];
}

int hydropwa_monitor_continuity(const double sums[HYDROPWA_MONITOR_NS], double value[4],
                                int alarm[4])
{
    double work[HYDROPWA_MONITOR_NW];
    double a0, a1, a2, a3;
    hp_continuity_result(sums, P, work, &value[0], &value[1], &value[2], &value[3], &a0, &a1, &a2,
                         &a3);
    alarm[0] = a0 > 0.5;
    alarm[1] = a1 > 0.5;
    alarm[2] = a2 > 0.5;
    alarm[3] = a3 > 0.5;
    return alarm[0] + alarm[1] + alarm[2] + alarm[3];
}
