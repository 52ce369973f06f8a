"""Coverage of the 95 % intervals on the virtual rig over many seeds (issue 18, item 5).

Each seed runs a small campaign (stepped-sine FRF, dead zone, friction) on a test machine,
identifies everything with ``identify`` and records, per parameter, whether the true value
lies inside its 95 % interval. With 20 seeds a parameter whose intervals hold covers 19 of
20 on average; fewer than 16 (80 %) happens by chance with probability < 2 % (binomial),
so the test asserts at least 16 of 20 for every parameter. The table is printed (run with
``-s``) and recorded in ``docs/architecture_identification.md``.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from hydropwa.identification import IdentificationWarning, identify
from hydropwa.params import get_preset, load_params
from hydropwa.rig import Rig, parse_campaign, run_campaign

MACHINES = Path(__file__).parent.parent / "machines"
SEEDS = 20

#: A small campaign: enough points per estimator for intervals, fast enough for 20 seeds.
CAMPAIGN = {
    "frf": {
        "settle": "0.05 s",
        "periods": 4,
        "margin_periods": 1,
        "start_position": "50 %",
        "sweep": [
            {
                "opening": "10 %",
                "frequencies": [
                    "5 Hz",
                    "15 Hz",
                    "30 Hz",
                    "45 Hz",
                    "60 Hz",
                    "80 Hz",
                    "110 Hz",
                    "150 Hz",
                ],
            },
            {
                "opening": "25 %",
                "frequencies": [
                    "5 Hz",
                    "15 Hz",
                    "30 Hz",
                    "45 Hz",
                    "60 Hz",
                    "80 Hz",
                    "110 Hz",
                    "150 Hz",
                ],
            },
            {
                "opening": "90 %",
                "frequencies": ["5 Hz", "10 Hz", "15 Hz", "25 Hz", "35 Hz", "50 Hz", "70 Hz"],
            },
        ],
    },
    "deadzone": {"inputs": {"start": "1 %", "stop": "14 %", "step": "1 %"}, "duration": "2 s"},
    "friction": {
        "inputs": {"start": "4 %", "stop": "40 %", "step": "3 %"},
        "counter_force": "1 kN",
        "duration": "2.5 s",
    },
}


def _truths(p):
    out = {"valve.zeta": p.valve.zeta}
    for a in (0.1, 0.25, 0.9):
        out[f"valve.omega0 at {100 * a:g} %"] = p.valve.omega0_at(a)
    out["dead_zone.beta"] = p.dead_zone.beta
    out["dead_zone.creep_slope"] = p.dead_zone.creep_slope
    f = p.friction
    out.update(
        {
            "friction.coulomb": f.coulomb,
            "friction.static": f.static,
            "friction.viscous": f.viscous,
            "friction.stribeck_velocity": f.stribeck_velocity,
            "friction.shape": f.shape,
        }
    )
    return out


def _intervals(rep):
    out = {"valve.zeta": rep.valve.zeta_}
    for a, fit in rep.valve.fits_.items():
        out[f"valve.omega0 at {100 * a:g} %"] = fit.omega0
    out["dead_zone.beta"] = rep.dead_zone.fit_.beta
    out["dead_zone.creep_slope"] = rep.dead_zone.fit_.creep_slope
    for k in ("coulomb", "static", "viscous", "stribeck_velocity", "shape"):
        out[f"friction.{k}"] = rep.friction.fit_.estimates[k]
    return out


def coverage(machine: str, seeds, tmp: Path, jobs: int = 1, log=None) -> dict[str, list[bool]]:
    """Per parameter, whether each seed's 95 % interval holds the truth."""
    p = get_preset("paper") if machine == "paper" else load_params(MACHINES / f"{machine}.toml")
    truth = _truths(p)
    hits: dict[str, list[bool]] = {k: [] for k in truth}
    for seed in seeds:
        out = tmp / f"{machine}_{seed}"
        camp = parse_campaign({"campaign": {"name": "coverage", "seed": int(seed)}, **CAMPAIGN})
        run_campaign(Rig(params=p), camp, out, jobs=jobs)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", IdentificationWarning)
            rep = identify(out, params=p)
        est = _intervals(rep)
        for k, v in truth.items():
            lo, hi = est[k].ci
            hits[k].append(bool(lo <= v <= hi))
            if log is not None:
                print(
                    f"{machine} seed {seed} {k}: {est[k].value:.6g} CI [{lo:.6g}, {hi:.6g}] true {v:.6g}",
                    file=log,
                    flush=True,
                )
    return hits


def table(results: dict[str, dict[str, list[bool]]]) -> str:
    machines = list(results)
    lines = ["| parameter | " + " | ".join(machines) + " |", "|---|" + "---|" * len(machines)]
    for k in next(iter(results.values())):
        cells = []
        for m in machines:
            h = results[m][k]
            cells.append(f"{100 * np.mean(h):.0f} % ({sum(h)}/{len(h)})")
        lines.append(f"| {k} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


@pytest.mark.slow
@pytest.mark.study
def test_intervals_cover_the_truth_over_20_seeds(tmp_path):
    results = {m: coverage(m, range(1, SEEDS + 1), tmp_path) for m in ("industrial", "small")}
    print("\n" + table(results))
    for m, hits in results.items():
        for k, h in hits.items():
            assert sum(h) >= 16, (
                f"{m} {k}: {sum(h)}/{len(h)} intervals hold the truth\n{table(results)}"
            )


if (
    __name__ == "__main__"
):  # the table for the docs: python tests/identification/test_coverage.py [seeds]
    import sys
    import tempfile

    n = int(sys.argv[1]) if len(sys.argv) > 1 else SEEDS
    with tempfile.TemporaryDirectory() as d:
        res = {
            m: coverage(m, range(1, n + 1), Path(d), log=sys.stderr)
            for m in sys.argv[2:] or ("industrial", "small")
        }
    print(table(res))
