"""Cost of the closed loop, and the design against two PI baselines on two machines.

Usage::

    python benchmarks/control.py [--repeat 5] [--duration 10] [--no-cost] [--no-compare] [--verify N]
        [--holds N]

**Comparison** (issue 34): on the paper rig (trapezoid 50 → 150 mm, 0.2 m/s, 5 m/s²) and the heavy
axis of ``tests/machines/industrial.toml`` (100 → 400 mm, 0.3 m/s, 3 m/s², 2 kN), full model, one
sample of delay, sensor noise 20 µm / 0.1 bar / 0.1 bar (seed 1) and exact sensors: the default
of ``control design`` (``design_controller(verify=False, delay=True)``: the design below with the
position observer and the quiet band for the default sensor noise), the design without them
(``design_state_feedback(delay=True)``: valve-aware LQR per cell with flow feed-forward),
a textbook PI with velocity feed-forward (crossover min(ω_h, ω0)/3, lowered until the gain margin
on the sampled plant with valve and delay is 6 dB; integral corner at a fifth of it;
k_ff = 1/K_v), and ``design_pi(delay=True)`` (``--method pi``), side by side: peak following
error, hold peak to peak over the last 0.2 s, saturation and command sign changes per second.
A fourth row: the design with the opt-in noise measures (position observer, dead-zone
hysteresis h = 0.005); a fifth: the design with the opt-in per-cell Kalman filter
(``design_cell_estimator`` for the noise below); a sixth: ``control design --spool measured``
(the spool estimate corrected by the measured spool, 0.2 % noise on it in the noisy runs).

**Verification** (``--verify N``, issue 34): the default of ``control design`` and the textbook PI + FF through
``closed_loop_verification`` on each machine (``verify_controller``'s task set on the full model,
sensor noise 20 µm / 0.1 bar / 0.1 bar, one sample of delay, N parameter draws): the verdict, the
worst hold peak to peak, the worst mean hold error, trapezoid error, saturation, sign changes per second and limit cycles,
and the first failed check.

**Holds** (``--holds N``, issue 34): the heavy axis's holds after the task set's steps at ±5 kN
over N parameter draws, the default of ``control design`` against the design without the quiet
band: worst peak to peak, holds above 0.1 mm, limit cycles, sign changes, worst mean hold error.

Case: the paper rig (preset ``paper``), the LQR designed on its PWA model
(``design_state_feedback``, 70 cells, 2 kHz), tracking a 50 mm, 0.5 Hz sine about
mid-stroke for 10 s, outputs at 2 kHz, rtol 1e-3. The controller runs inside the compiled
integrator: the steps end on every sample instant (20 000 of them), the new command is
held constant (ZOH), no Python runs per sample.

Open-loop references, the same model, tolerance and output grid:

* **replay**: the command the controller produced, fed back as a measured input
  (``Sampled`` at the 2 kHz sample instants, linear between them, so the integrator's
  largest step is the sample spacing, as for any measured 2 kHz input). Same input
  information, no controller: the ratio is the controller's own cost (the issue's
  target: at most 1.5).
* **sine**: the package's standard open-loop benchmark input (40 %, 1 Hz sine, largest
  step 10 ms); a smooth input lets the integrator take far fewer steps than a 2 kHz
  command can, so this ratio mostly measures the 20 000 sample instants.

Times are the best of ``--repeat`` calls, for the kernel alone (``stats['wall_time']``)
and end to end (``simulate``).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

# run as a script, this file's folder comes first on sys.path and its name would hide
# python-control (``import control``) from hydropwa: drop the folder
_HERE = Path(__file__).resolve().parent
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != _HERE]

import numpy as np  # noqa: E402

from hydropwa.control import design_state_feedback  # noqa: E402
from hydropwa.linearization import linearize  # noqa: E402
from hydropwa.params import get_preset  # noqa: E402
from hydropwa.simulation import Sampled, simulate  # noqa: E402

REFERENCE = "sine:amplitude=50 mm,frequency=0.5,offset=100 mm"


def _best(fn, repeat):
    best_wall, best_kernel, res = np.inf, np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        res = fn()
        wall = time.perf_counter() - t0
        best_wall = min(best_wall, wall)
        best_kernel = min(best_kernel, res.stats["wall_time"])
    return best_wall, best_kernel, res


MACHINES = {
    "paper rig": (None, "trapezoid:from=50 mm,to=150 mm,v=0.2,a=5,start=0.1", 0.05, 0.9, None),
    "heavy axis": (
        Path(__file__).resolve().parents[1] / "tests" / "machines" / "industrial.toml",
        "trapezoid:from=100 mm,to=400 mm,v=0.3,a=3,start=0.1",
        0.1,
        1.6,
        2000.0,
    ),
}
NOISE = {"x": 20e-6, "p_a": 0.1e5, "p_b": 0.1e5}
#: noise [1] of the measured spool (0.2 % of the opening) in the compare runs: drawn after the
#: others, read only by the row that measures the spool
SPOOL_NOISE = 2e-3


def compare() -> None:
    """The design against the textbook PI and ``--method pi`` on both machines (see the docstring)."""
    import dataclasses

    from hydropwa.control import (
        as_reference,
        design_cell_estimator,
        design_controller,
        design_pi,
        design_textbook_pi,
        tracking_metrics,
    )
    from hydropwa.params import load_params

    print(
        f"{'machine':<11}{'controller':<34}{'sensors':<8}{'peak err mm':>12}{'hold p-p mm':>12}"
        f"{'sat %':>7}{'sign ch./s':>11}"
    )
    for name, (path, spec, x0, dur, force) in MACHINES.items():
        prm = get_preset("paper") if path is None else load_params(path)
        pwa = linearize(prm)
        tbd = design_textbook_pi(pwa, sample_time=5e-4, delay=True)
        tb, wc = tbd.controller, 2 * np.pi * float(tbd.table["crossover_hz"].iloc[0])
        dsf = design_state_feedback(pwa, delay=True)
        ctrls = {
            # the default of `control design` (design_controller): the LQR below with the
            # position observer and the quiet band for the default sensor noise
            "control design (+ quiet band)": design_controller(
                pwa, verify=False, delay=True
            ).controller,
            "design (LQR/cell + feed-forward)": dsf.controller,
            f"textbook PI+FF ({wc / 2 / np.pi:.1f} Hz)": tb,
            "--method pi": design_pi(pwa, delay=True).controller,
            # opt-in noise measures (not the default): the position observer and the
            # dead-zone hysteresis h = 0.005
            "design + observer + DZ hysteresis": design_state_feedback(
                pwa,
                delay=True,
                position_noise=NOISE["x"],
                acceleration_noise=1.0,
                dead_zone_hysteresis=0.005,
            ).controller,
            # opt-in: the per-cell steady-state Kalman filter for the noise below
            "design + per-cell Kalman filter": dataclasses.replace(
                dsf.controller, estimator=design_cell_estimator(pwa, dsf, NOISE)
            ),
            # opt-in: control design --spool measured, the spool filter for 0.2 % noise
            "control design --spool measured": design_controller(
                pwa,
                verify=False,
                delay=True,
                spool="measured",
                sensor_noise=NOISE | {"spool": SPOOL_NOISE},
            ).controller,
        }
        for cname, ctrl in ctrls.items():
            for sensors, noise in (("exact", None), ("noisy", NOISE | {"spool": SPOOL_NOISE})):
                res = simulate(
                    "full",
                    params=prm,
                    duration=dur,
                    controller=ctrl,
                    reference=as_reference(spec),
                    initial_position=x0,
                    load_force=force,
                    sensor_noise=noise,
                    seed=1,
                )
                m = tracking_metrics(res).display()
                hold = tracking_metrics(res, t0=dur - 0.2).display()
                pp = float(np.ptp(res["x"][res.t >= dur - 0.2])) * 1e3
                print(
                    f"{name:<11}{cname:<34}{sensors:<8}{m['max_following_error']:>12.3f}{pp:>12.3f}"
                    f"{m['saturation']:>7.1f}{hold['chattering']:>11.0f}"
                )


def verify(draws: int) -> None:
    """The verification verdict of the default design beside the textbook PI, both machines."""
    from hydropwa.control import closed_loop_verification, design_controller
    from hydropwa.params import load_params

    print(
        f"{'machine':<11}{'controller':<30}{'verdict':>8}{'hold p-p mm':>12}{'mean err mm':>12}"
        f"{'peak err mm':>12}{'sat %':>7}{'sign ch./s':>11}{'cycles':>7}  first failed check"
    )
    for name, (path, *_rest) in MACHINES.items():
        prm = get_preset("paper") if path is None else load_params(path)
        pwa = linearize(prm)
        ctrl = design_controller(pwa, verify=False, delay=True).controller
        tab = closed_loop_verification(pwa, ctrl, draws=draws)
        for cname, r in tab.iterrows():
            print(
                f"{name:<11}{cname:<30}{r['verdict']:>8}{r['hold_peak_to_peak_mm']:>12.3f}"
                f"{r['hold_mean_error_mm']:>12.3f}{r['following_error_mm']:>12.3f}{r['saturation_percent']:>7.1f}"
                f"{r['sign_changes_per_s']:>11.0f}{r['limit_cycles']:>7.0f}  {r['first_failure']}"
            )


def holds(draws: int) -> None:
    """Issue 34's heavy-axis check: the holds of the task set's steps at ±5 kN over ``draws``
    parameter sets (nominal + draws − 1), the default of ``control design`` against the design
    without the quiet band, exact and noisy sensors (20 µm / 0.1 bar), one sample of delay."""
    from hydropwa.control import design_controller, task_set, verify_controller
    from hydropwa.params import load_params

    path = MACHINES["heavy axis"][0]
    prm = load_params(path)
    pwa = linearize(prm)
    f_max = prm.supply.pressure * prm.cylinder.area_a
    tasks = [t for t in task_set(prm, load_fraction=5000.0 / f_max) if t.name.startswith("steps")]
    print(f"heavy axis, steps at +-5 kN, {draws} draws x {len(tasks)} tasks, holds peak to peak")
    for cname, quiet in (("control design (+ quiet band)", True), ("design without", False)):
        ctrl = design_controller(pwa, verify=False, delay=True, quiet=quiet).controller
        for sensors, noise in (("exact", {}), ("noisy", NOISE)):
            v = verify_controller(ctrl, prm, draws=draws, tasks=tasks, sensor_noise=noise)
            pps = [r["hold_pp"] * 1e3 for r in v.runs if "hold_pp" in r]
            print(
                f"  {cname:<31}{sensors:<7} worst {max(pps):.3f} mm, above 0.1 mm "
                f"{sum(p > 0.1 for p in pps)} of {len(pps)}, limit cycles "
                f"{v.metrics['limit_cycles']:.0f}, sign changes <= "
                f"{v.metrics['sign_changes_per_s']:.0f}/s, mean hold error <= "
                f"{v.metrics['hold_mean_error_mm']:.3f} mm"
            )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--duration", type=float, default=10.0)
    ap.add_argument("--no-cost", action="store_true", help="skip the closed- vs open-loop cost")
    ap.add_argument("--no-compare", action="store_true", help="skip the controller comparison")
    ap.add_argument(
        "--verify", type=int, default=0, metavar="N", help="verification verdicts with N draws"
    )
    ap.add_argument(
        "--holds", type=int, default=0, metavar="N", help="heavy-axis +-5 kN holds over N draws"
    )
    args = ap.parse_args()
    if args.holds > 0:
        holds(args.holds)
    if args.verify > 0:
        verify(args.verify)
    if not args.no_compare:
        compare()
    if args.no_cost:
        return
    prm = get_preset("paper")
    ctrl = design_state_feedback(linearize(prm)).controller
    dur = args.duration

    def closed():
        return simulate(
            "full",
            params=prm,
            duration=dur,
            controller=ctrl,
            reference=REFERENCE,
            initial_position=0.1,
        )

    closed()  # compile / warm caches
    cw, ck, cres = _best(closed, args.repeat)
    rec = cres.control
    replay_u = Sampled(rec["t"], rec["u"])

    def replay():
        return simulate("full", replay_u, params=prm, duration=dur, initial_position=0.1)

    def sine():
        return simulate("full", "sine:amplitude=0.4,frequency=1", params=prm, duration=dur)

    replay()
    sine()
    rw, rk, rres = _best(replay, args.repeat)
    sw, sk, sres = _best(sine, args.repeat)
    x_err = np.max(np.abs(rres["x"] - cres["x"])) * 1e3
    print(
        f"full model, {dur:g} s, controller {1 / ctrl.sample_time:g} Hz ({len(ctrl.rows)} gain rows), outputs 2 kHz"
    )
    print(f"{'case':<28}{'steps':>8}{'rhs':>9}{'kernel ms':>11}{'simulate ms':>13}")
    for name, res, k, w in (
        ("closed loop", cres, ck, cw),
        ("open loop, replayed command", rres, rk, rw),
        ("open loop, 40 % 1 Hz sine", sres, sk, sw),
    ):
        print(
            f"{name:<28}{res.stats['steps']:>8}{res.stats['rhs_evaluations']:>9}{k * 1e3:>11.1f}{w * 1e3:>13.1f}"
        )
    print(
        f"ratio closed / replayed command: kernel {ck / rk:.2f}x, simulate {cw / rw:.2f}x (target <= 1.5x)"
    )
    print(f"ratio closed / smooth sine input: kernel {ck / sk:.2f}x, simulate {cw / sw:.2f}x")
    print(
        f"replay reproduces the closed-loop position within {x_err:.3f} mm (linear vs held command between samples)"
    )
    print(f"closed loop: real time factor {dur / cw:.0f}x")


if __name__ == "__main__":
    main()
