"""Grey-box fit benchmark: 6 free parameters, the 9 sine runs of the virtual rig (5 s each, 2 kHz).

Produces the runs on the virtual rig (paper parameters with a piston leakage of 2e-12
m³/(s·Pa), default sensors), starts the fit from perturbed values (E +20 %, C_L −25 %,
K −10 %, F_c +30 %, F_s −15 %, σ +20 %) and fits bulk modulus, leakage, flow coefficient
and the Coulomb, static and viscous friction with one thread and with two. Prints the
wall time of each, the speed-up, and the recovery table (not a timed test).

    python benchmarks/greybox.py [--jobs 1,2] [--seed 1]

Campaign scale (issue 36): ``--campaign FOLDER`` fits the six Stribeck parameters to the
virtual rig's friction campaign (92 constant-counter-force runs, about 244 s at 2 kHz) in
FOLDER/friction, from 15–50 % off the truth in FOLDER/true_params.toml (made by
``hydropwa rig run friction --params paper --out FOLDER`` when missing, about 2 minutes), with the
campaign selection (``Selection``) and 10 % of the runs held out for validation; it prints
the wall time, the CPU time and the machine's load beside the nine-run case's, and whether
the issue's target (F_c, F_s, σ within 10 % in at most 3 minutes on two cores) is met. ``--case sine``,
``campaign`` or ``both`` picks what runs (default: sine, or both with ``--campaign``).

Joint fit (issue 36): ``--case joint --machine paper|industrial`` runs the small whole
campaign of ``tests/machines/joint_campaign.toml`` (FRF, dead zone, friction, sine and load
runs) on the virtual rig of that machine and fits ``free="all"`` with
:func:`~hydropwa.identification.fit_campaign`, started from ``identify all`` (K −10 %,
E +20 % and C_L off for what ``identify all`` does not estimate), 10 % of the runs held out;
it prints the wall time, the table truth / identify all / joint / interval and the
validation. ``--case all`` runs the nine-run case, the friction campaign and the joint fit.
"""

from __future__ import annotations

import argparse
import os
import time
import warnings
from pathlib import Path

from hydropwa.identification import IdentificationWarning, fit_model
from hydropwa.models import FullOrderModel
from hydropwa.params import get_preset
from hydropwa.rig import Rig, RunSpec, execute, run_seed
from hydropwa.simulation import Sine

FREE = (
    "oil.bulk_modulus",
    "cylinder.leakage",
    "flow.K",
    "friction.coulomb",
    "friction.static",
    "friction.viscous",
)
START = {
    "oil.bulk_modulus": 1.2,
    "cylinder.leakage": 0.75,
    "flow.K": 0.9,
    "friction.coulomb": 1.3,
    "friction.static": 0.85,
    "friction.viscous": 1.2,
}


def sine_runs(params, seed: int = 1, duration: float = 5.0):
    """The 9 sine runs (1, 2, 3 Hz × 20, 40, 60 %) of ``duration`` s from 2 cm, measured by the rig."""
    rig = Rig(params=params)
    runs = []
    for f in (1.0, 2.0, 3.0):
        for a in (0.2, 0.4, 0.6):
            spec = RunSpec(
                name=f"sine_f{f:g}_a{round(100 * a)}",
                experiment="sine",
                command=Sine(amplitude=a, frequency=f),
                duration=duration,
                start_position=0.02,
            )
            runs.append(execute(rig, spec, run_seed(seed, "sine", spec.name)))
    return runs


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", default="1,2", help="thread counts to time, comma-separated")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--campaign", type=Path, default=None, help="friction campaign folder")
    ap.add_argument("--case", choices=("sine", "campaign", "both", "joint", "all"), default=None)
    ap.add_argument("--machine", default="paper", help="joint case: paper or industrial")
    args = ap.parse_args()
    case = args.case or ("both" if args.campaign else "sine")
    if case in ("sine", "both", "all"):
        sine_case(args)
    if case in ("campaign", "both", "all"):
        campaign_case(args.campaign or Path("greybox_campaign"), int(args.jobs.split(",")[-1]))
    if case in ("joint", "all"):
        joint_case(args.machine, int(args.jobs.split(",")[-1]), args.seed)


MACHINES = Path(__file__).parent.parent / "tests" / "machines"


def joint_case(machine: str, jobs: int, seed: int) -> None:
    """The joint fit (``free="all"``) of a small whole campaign, from ``identify all``."""
    import tempfile

    from hydropwa.identification import fit_campaign
    from hydropwa.params import load_params
    from hydropwa.rig import load_campaign, run_campaign

    truth = get_preset("paper") if machine == "paper" else load_params(MACHINES / f"{machine}.toml")
    campaign = load_campaign(MACHINES / "joint_campaign.toml")
    nominal = truth.replace(
        **{
            "flow.K": 0.9 * truth.flow.K,
            "oil.bulk_modulus": 1.2 * truth.oil.bulk_modulus,
            "cylinder.leakage": 0.5 * truth.cylinder.leakage or 1e-13,
        }
    )
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        run_campaign(Rig(params=truth), dataclasses_replace_seed(campaign, seed), Path(tmp))
        print(f"virtual rig ({machine}): joint campaign in {time.perf_counter() - t0:.1f} s")
        load0 = os.getloadavg()[0]
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", IdentificationWarning)
            joint = fit_campaign(
                tmp, "all", params=nominal, jobs=jobs, validate=0.1,
                progress=lambda ev: print(f"  {ev}", flush=True) if ev.event == "end" else None,
            )  # fmt: skip
        wall = time.perf_counter() - t0
    fit = joint.fit
    print(
        f"joint fit ({machine}): {len(fit.runs_)} runs fitted, jobs={jobs}: {wall:.1f} s, of "
        f"which identify all {joint.start_time:.1f} s (load average {load0:.1f} → "
        f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores), {fit.message}"
    )
    for note in fit.data_:
        print("  " + note)
    print(
        "\n| parameter | true | identify all | joint | error (identify all → joint) | 95 % interval | truth inside |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for row in joint.table(truth):
        print(
            f"| {row['parameter']} | {row['truth']:.4g} | {row['start']:.4g} | {row['joint']:.4g} | "
            f"{100 * row['start_error']:+.2f} % → {100 * row['joint_error']:+.2f} % | "
            f"[{row['ci_low']:.4g}, {row['ci_high']:.4g}] | {'yes' if row['covered'] else 'no'} |"
        )
    if fit.validation_ is not None:
        print("\n" + fit.validation_.summary())


def dataclasses_replace_seed(campaign, seed: int):
    """The campaign with its noise seed offset by ``seed`` (1: the file's own)."""
    import dataclasses

    return dataclasses.replace(campaign, seed=campaign.seed + seed - 1)


#: the campaign case's start: factors on the truth
CAMPAIGN_START = {
    "friction.coulomb": 1.3,
    "friction.static": 0.6,
    "friction.viscous": 1.15,
    "friction.stribeck_velocity": 1.5,
    "friction.shape": 1.2,
    "friction.smoothness": 0.8,
}


def campaign_case(folder: Path, jobs: int) -> None:
    """The friction campaign with ``--free friction``: wall time, load, recovery, validation."""
    import subprocess
    import sys

    from hydropwa.identification import load_runs
    from hydropwa.params import load_params

    if not (folder / "friction").is_dir():
        t0 = time.perf_counter()
        cmd = [
            sys.executable,
            "-m",
            "hydropwa",
            "rig",
            "run",
            "friction",
            "-p",
            "paper",
            "--out",
            str(folder),
        ]
        subprocess.run([*cmd, "--quiet", "--jobs", str(jobs)], check=True)
        print(f"virtual rig: friction campaign in {time.perf_counter() - t0:.1f} s")
    truth = load_params(folder / "true_params.toml")
    start = truth.replace(**{n: f * _get(truth, n) for n, f in CAMPAIGN_START.items()})
    runs = load_runs(folder / "friction", params=start)
    load0 = os.getloadavg()[0]
    t0, c0 = time.perf_counter(), time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentificationWarning)
        fit = fit_model(
            FullOrderModel(start), runs, "friction", jobs=jobs, validate=0.1,
            progress=lambda ev: print(f"  {ev}", flush=True) if ev.event == "end" else None,
        )  # fmt: skip
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    print(
        f"campaign: {len(runs)} runs, jobs={jobs}: {wall:.1f} s wall, {cpu:.1f} s CPU (load "
        f"average {load0:.1f} → {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores), {fit.message}"
    )
    if {"friction.coulomb", "friction.static", "friction.viscous"} <= set(fit.estimates_):
        worst = max(
            abs(fit.estimates_[n].value / _get(truth, n) - 1)
            for n in ("friction.coulomb", "friction.static", "friction.viscous")
        )
        verdict = "meets" if wall <= 180.0 and worst <= 0.10 else "misses"
        print(
            f"issue 36 target (F_c, F_s, σ within 10 % in ≤ 3 min on two cores): {verdict} "
            f"(worst {100 * worst:.1f} %, {wall:.0f} s)"
        )
    for note in fit.data_:
        print("  " + note)
    print("\n| parameter | true | start | fitted | error | 95 % interval | truth inside |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for n, e in fit.estimates_.items():
        tv = _get(truth, n)
        print(
            f"| {n} | {tv:.4g} | {CAMPAIGN_START[n] * tv:.4g} | {e.value:.4g} | "
            f"{100 * (e.value / tv - 1):+.1f} % | [{e.ci[0]:.4g}, {e.ci[1]:.4g}] | "
            f"{'yes' if e.ci[0] <= tv <= e.ci[1] else 'no'} |"
        )
    if fit.validation_ is not None:
        print("\n" + fit.validation_.summary())


def sine_case(args: argparse.Namespace) -> None:
    """The nine 5 s sine runs with six parameters free, timed per thread count."""
    truth = get_preset("paper").replace(**{"cylinder.leakage": 2e-12})
    t0 = time.perf_counter()
    runs = sine_runs(truth, args.seed)
    print(f"virtual rig: 9 sine runs x 5 s at 2 kHz in {time.perf_counter() - t0:.1f} s")
    start = truth.replace(**{n: START[n] * _get(truth, n) for n in FREE})
    times = {}
    fit = None
    for jobs in (int(j) for j in args.jobs.split(",")):
        t0 = time.perf_counter()
        fit = fit_model(FullOrderModel(start), runs, FREE, jobs=jobs, profile="none")
        times[jobs] = time.perf_counter() - t0
        print(
            f"jobs={jobs}: {times[jobs]:.1f} s ({fit.nfev} residual + {fit.njev} Jacobian evaluations, "
            f"{fit.message})"
        )
    # the cost at the truth (same runs, same noise scaling): a fit that stops well above it
    # has stalled; one at or below it has found the data's optimum
    with warnings.catch_warnings():  # one evaluation on purpose: it "stops short" by design
        warnings.simplefilter("ignore", IdentificationWarning)
        at_truth = _cost_at(truth, runs)
    print(f"cost at the fit {fit.cost:.5g}, at the truth {at_truth.initial_cost:.5g}")
    if fit.identifiability_.unconverged:
        print("flagged not converged: " + ", ".join(fit.identifiability_.unconverged))
    if 1 in times and len(times) > 1:
        for j, t in times.items():
            if j != 1:
                print(f"speed-up on {j} threads: {times[1] / t:.2f}x")
    print("\n| parameter | true | start | fitted | error | 95 % interval | truth inside |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for n, e in fit.estimates_.items():
        tv = _get(truth, n)
        print(
            f"| {n} | {tv:.4g} | {START[n] * tv:.4g} | {e.value:.4g} | {100 * (e.value / tv - 1):+.2f} % | "
            f"[{e.ci[0]:.4g}, {e.ci[1]:.4g}] | {'yes' if e.ci[0] <= tv <= e.ci[1] else 'no'} |"
        )
    sl = fit.sliding_
    if sl.applied:
        print(
            f"\nsliding stage: {', '.join(sl.parameters)} refitted on {sl.stretches} stretches "
            f"above {1e3 * sl.v_min:.3g} mm/s ({sl.nfev} evaluations), "
            f"{', '.join(sl.held) or 'nothing'} held"
        )
    elif sl.skipped:
        print(f"\nsliding stage skipped: {sl.skipped}")
    if fit.widened_:
        print(
            "\nwidened by the interval scan (the cost within the threshold beyond the quadratic interval): "
            + ", ".join(fit.widened_)
        )


def _cost_at(truth, runs):
    """A one-evaluation fit at the true values: its initial cost is the cost at the truth."""
    return fit_model(
        FullOrderModel(truth),
        runs,
        FREE,
        profile="none",
        max_nfev=1,
        initial={n: _get(truth, n) for n in FREE},
        scan_intervals=False,
    )


def _get(params, name):
    comp, fld = name.split(".")
    return getattr(getattr(params, comp), fld)


if __name__ == "__main__":
    main()
