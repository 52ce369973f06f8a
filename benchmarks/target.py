"""The generated C on a target: controller time per step, and the axis FMU against real time.

Usage::

    python benchmarks/target.py [--repeat 5]

Controller: the default design of ``hydropwa control design`` on the paper rig's PWA model
(schema 2: valve-aware LQR, 70 gain rows, 2 kHz, one sample of delay, with the flow
feed-forward, the reference state and the spool estimate), and beside it the schema-1 LQR
(no valve model, no feed-forward), each exported with ``export_c`` and compiled with
``gcc -std=c99 -O2``; a C driver steps it over the measurement sequence of a 0.6 s
closed-loop trapezoid of the full model (1201 samples, 20 µm / 5 mm/s / 0.1 bar noise) 200
times and reports the best mean time per step, and the same with measurements outside every
box (each step then searches all 70 rows: the worst case of the header's cost bound). The
ratio to the 2 kHz period (500 µs) is the share of the loop's budget the controller takes.

Axis FMU: ``export_axis_fmu`` of the paper rig; a C driver instantiates the FMU's own sources
(the FMI functions, no Python) and steps it through 10 s of a 40 %, 2 Hz sine at 1 ms
communication steps (rtol 1e-6): simulated time over wall time is the speed against real time.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

# run as a script, this file's folder comes first on sys.path and its name would hide
# python-control (``import control``) from hydropwa: drop the folder
_HERE = Path(__file__).resolve().parent
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != _HERE]

import numpy as np  # noqa: E402

from hydropwa.control import MotionProfile, design_state_feedback, export_c  # noqa: E402
from hydropwa.linearization import linearize  # noqa: E402
from hydropwa.params import get_preset  # noqa: E402
from hydropwa.simulation import export_axis_fmu, simulate  # noqa: E402

CTRL_DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "hydropwa_ctrl.h"

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

int main(int argc, char **argv)
{
    long n, k, rep, reps = atol(argv[1]);
    double *in, sink = 0.0, t0, best = 1e30;
    hydropwa_ctrl_state s;
    (void)argc;
    if (fread(&n, sizeof(long), 1, stdin) != 1) return 2;
    in = malloc(sizeof(double) * 7 * n);
    if (fread(in, sizeof(double), 7 * n, stdin) != (size_t)(7 * n)) return 3;
    for (rep = 0; rep < 5; ++rep) {
        long r;
        t0 = now();
        for (r = 0; r < reps; ++r) {
            hydropwa_ctrl_init(&s);
            for (k = 0; k < n; ++k) {
                hydropwa_ctrl_meas m;
                hydropwa_ctrl_ref ref;
                m.x = in[7 * k];
                m.v = in[7 * k + 1];
                m.p_l = in[7 * k + 2];
                ref.r = in[7 * k + 3];
                ref.r_rate = in[7 * k + 4];
                ref.r_rate_ff = in[7 * k + 5];
                ref.r_acc = in[7 * k + 6];
                ref.r_rate_pre = 0.0; /* the pre-opening's test only (a compare) */
                sink += hydropwa_ctrl_step(&s, &m, &ref);
            }
        }
        t0 = (now() - t0) / (double)(reps * n);
        if (t0 < best) best = t0;
    }
    printf("%.6e %g\n", best, sink);
    free(in);
    return 0;
}
"""

FMU_DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include <math.h>
#include <time.h>

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String cat, fmi2String msg, ...)
{
    (void)env; (void)name; (void)status; (void)cat;
    fprintf(stderr, "%s\n", msg);
}

int main(int argc, char **argv)
{
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    double T = atof(argv[1]), h = 1e-3, t = 0.0, x = 0.0;
    unsigned int vr_u = 0, vr_x = 3;
    struct timespec a, b;
    fmi2Component c = fmi2Instantiate("axis", fmi2CoSimulation, HP_GUID, "", &cb, 0, 0);
    if (c == NULL) return 2;
    fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
    fmi2EnterInitializationMode(c);
    fmi2ExitInitializationMode(c);
    clock_gettime(CLOCK_MONOTONIC, &a);
    while (t < T - 0.5 * h) {
        double u = 0.4 * sin(2.0 * 3.141592653589793 * 2.0 * t);
        fmi2SetReal(c, &vr_u, 1, &u);
        if (fmi2DoStep(c, t, h, 1) != fmi2OK) return 3;
        t += h;
    }
    clock_gettime(CLOCK_MONOTONIC, &b);
    fmi2GetReal(c, &vr_x, 1, &x);
    fmi2FreeInstance(c);
    printf("%.6f %.6f\n", (b.tv_sec - a.tv_sec) + 1e-9 * (b.tv_nsec - a.tv_nsec), x);
    return 0;
}
"""


def _measurements(prm, ctrl):
    rng = np.random.default_rng(1)
    x0 = 0.08
    ref = MotionProfile(
        start_position=x0, end_position=x0 + 0.04, start_time=0.02, max_velocity=0.1
    )
    tk = ctrl.sample_time * np.arange(1201)
    res = simulate(
        "full", timepts=tk, params=prm, controller=ctrl, reference=ref, initial_position=x0
    )
    a_a, a_b = prm.cylinder.area_a, prm.cylinder.area_b
    lead = ctrl.feedforward.lead if ctrl.feedforward is not None else 0.0
    pa = np.asarray(res["p_a"]) + rng.normal(0, 0.1e5, tk.size)
    pb = np.asarray(res["p_b"]) + rng.normal(0, 0.1e5, tk.size)
    return np.column_stack(
        [
            np.asarray(res["x"]) + rng.normal(0, 20e-6, tk.size),
            np.asarray(res["v"]) + rng.normal(0, 5e-3, tk.size),
            (pa * a_a - pb * a_b) / a_a,
            ref(tk),
            ref.rate(tk),
            ref.rate(tk + lead),
            ref.acceleration(tk),
        ]
    )


def _gcc(out: Path, *sources: Path) -> None:
    cmd = ["gcc", "-std=gnu99", "-O2", "-ffp-contract=off", "-o", str(out), *map(str, sources)]
    subprocess.run([*cmd, "-lm"], check=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=200, help="passes over the sequence")
    args = ap.parse_args(argv)
    prm = get_preset("paper")
    model = linearize(prm)
    designs = (
        ("schema 2 (default design)", design_state_feedback(model, delay=True).controller),
        (
            "schema 1 (no valve model, no feed-forward)",
            design_state_feedback(model, delay=True, valve=False, feedforward=False).controller,
        ),
    )
    with tempfile.TemporaryDirectory() as tmp:
        for label, ctrl in designs:
            meas = _measurements(prm, ctrl)
            d = export_c(ctrl, Path(tmp) / label.split()[1])
            (d / "bench.c").write_text(CTRL_DRIVER)
            _gcc(d / "bench", d / "bench.c", d / "hydropwa_ctrl.c")
            rows = []
            outside = meas.copy()
            outside[:, 2] = 1e9  # P_L far outside every box: every step searches all rows
            for name, m in (("closed-loop sequence", meas), ("outside every box", outside)):
                data = np.int64(len(m)).tobytes() + np.ascontiguousarray(m).tobytes()
                out = subprocess.run(
                    [str(d / "bench"), str(args.repeat)],
                    input=data,
                    capture_output=True,
                    check=True,
                )
                per_step = float(out.stdout.split()[0])
                rows.append((name, per_step))
            print(f"C controller, {label}: {len(ctrl.rows)} gain rows, gcc -O2, time per step:")
            for name, t in rows:
                print(f"  {name:22s} {t * 1e9:8.1f} ns   {t / 500e-6:.2e} of the 500 µs period")

        fmu = export_axis_fmu(prm, Path(tmp) / "axis.fmu")
        src = Path(tmp) / "axis"
        with zipfile.ZipFile(fmu) as z:
            z.extractall(src)
        drv = src / "sources" / "drive.c"
        drv.write_text('#include "hydropwa_axis_fmi2.c"\n' + FMU_DRIVER)
        _gcc(src / "drive", drv)
        T = 10.0
        out = subprocess.run(
            [str(src / "drive"), str(T)], capture_output=True, text=True, check=True
        )
        wall = float(out.stdout.split()[0])
        print(
            f"axis FMU (paper rig, 40 % 2 Hz sine, 1 ms steps, rtol 1e-6): {T:g} s simulated in "
            f"{wall * 1e3:.1f} ms, {T / wall:.0f}x real time"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
