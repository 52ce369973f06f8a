/* The instance core shared by the FMI 2.0 and FMI 3.0 interfaces (fmi2_cs.c, fmi3_cs.c):
 * the generator inserts it after the model file, where each interface has defined
 * hp_vref (its value-reference type). Written once here, so both FMUs read, write and step
 * the model the same way; each interface keeps only the standard's signatures and logging.
 */
#if defined(_WIN32)
#define HP_EXPORT __declspec(dllexport)
#else
#define HP_EXPORT __attribute__((visibility("default")))
#endif

/* The model, the time of the last communication point, and whether the outputs are those of
 * the present inputs and memory (hp_model_outputs has no side effect, so it runs lazily). */
typedef struct {
    hp_model model;
    double time;
    int outputs_current;
} hp_core;

static void hp_core_reset(hp_core *core)
{
    hp_model_reset(&core->model);
    core->time = 0.0;
    core->outputs_current = 0;
}

static void hp_core_start(hp_core *core)
{
    hp_model_start(&core->model, core->time);
    core->outputs_current = 0;
}

/* Variables vr[0..n-1] into value[]; with_time: the reference HP_NVARS reads the time (the
 * independent variable of FMI 3.0). Returns 0, or 1 at a reference that names no variable. */
static int hp_core_get(hp_core *core, const hp_vref vr[], size_t n, double value[], int with_time)
{
    size_t i;
    if (!core->outputs_current) {
        hp_model_outputs(&core->model);
        core->outputs_current = 1;
    }
    for (i = 0; i < n; ++i) {
        if (with_time && vr[i] == HP_NVARS) {
            value[i] = core->time;
        } else if (vr[i] < HP_NVARS) {
            value[i] = core->model.vars[vr[i]];
        } else {
            return 1;
        }
    }
    return 0;
}

/* value[] into the inputs and parameters vr[]; returns 1 at a reference that is neither. */
static int hp_core_set(hp_core *core, const hp_vref vr[], size_t n, const double value[])
{
    size_t i;
    for (i = 0; i < n; ++i) {
        if (vr[i] >= HP_NVARS || !hp_model_settable[vr[i]]) {
            return 1;
        }
        core->model.vars[vr[i]] = value[i];
    }
    core->outputs_current = 0;
    return 0;
}

/* Advance from t to t + h; returns 1 (the time unchanged) if the model's step failed. */
static int hp_core_step(hp_core *core, double t, double h)
{
    if (hp_model_do_step(&core->model, t, h) != 0) {
        return 1;
    }
    core->time = t + h;
    core->outputs_current = 0;
    return 0;
}
