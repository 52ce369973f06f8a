"""False alarms, detection and isolation of the health monitor on the virtual rig (issue 53).

For each machine (the paper rig, the 63/36 × 500 mm heavy axis of tests/machines/industrial.toml)
the runs of the paper campaign's ``[sine]`` experiment (nine open-loop sines and the two
counter-force load runs, planned for the machine; even cases a load run, odd ones a sine) are simulated on machines drawn uniformly
inside the monitor's intervals (:func:`hydropwa.monitor.draw_within`), each with its own noise
seed, and checked by a :class:`~hydropwa.monitor.HealthMonitor` fitted to the nominal
(identified) machine:

- healthy: ``--healthy`` draws per machine (run kinds in turn): false alarms;
- faulty: ``--faulty`` draws per fault and machine: internal leakage 0.1 L/min at 50 bar,
  friction +30 %, valve null 0.5 %, supply −10 %: detection and isolation (the fault named
  first), per run kind (``sine`` without load, ``load`` with the counter-force profile);
- ``--width PATH=REL`` sets a parameter's healthy interval to value·(1 ± REL), as an
  identification would give it (the monitor's interval and the draws), e.g. the Stribeck
  velocity's (docs/monitoring.md: what finds friction on the paper rig); ``--faults`` picks
  the cases;
- the smallest detectable internal leakage per run (threshold + 2.33 standard errors, the
  leakage detected in 99 % of runs), against the run's excitation (RMS of P_A − P_B).

Prints Markdown tables; with ``--rows FILE`` each run's row is also appended to FILE as one
JSON line as it finishes (a long study stopped early keeps what it did). The issue's statistic
is ``--healthy 1000`` (about 2 s per run on one core)::

    python benchmarks/monitor_study.py --healthy 1000 --faulty 100 --jobs 8
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import dataclasses
import json
import time
from pathlib import Path

import numpy as np

from hydropwa.monitor import HealthMonitor, draw_within
from hydropwa.params import get_preset, load_params
from hydropwa.rig import Fault, Rig, execute, inject, load_campaign, plan, run_seed

ROOT = Path(__file__).resolve().parents[1]
MACHINES = {
    "paper": lambda: get_preset("paper"),
    "heavy": lambda: load_params(ROOT / "tests/machines/industrial.toml"),
}
FAULTS = {
    "healthy": (),
    "internal_leakage": (Fault("internal_leakage", 0.1e-3 / 60.0, at=50e5),),
    "friction": (Fault("friction", 0.30),),
    "valve_null": (Fault("valve_null", 0.005),),
    "supply": (Fault("supply", 0.10),),
}


def _intervals(params, widths: tuple[tuple[str, float], ...]) -> dict:
    """``--width PATH=REL``: the healthy interval value·(1 ± REL) of a parameter."""
    out = {}
    for path, rel in widths:
        comp, fld = path.split(".")
        v = float(getattr(getattr(params, comp), fld))
        out[path] = (v * (1.0 - rel), v * (1.0 + rel))
    return out


def _case(machine: str, fault: str, i: int, widths: tuple[tuple[str, float], ...] = ()) -> dict:
    params = MACHINES[machine]()
    rig = Rig(params)
    monitor = HealthMonitor(intervals=_intervals(rig.params, widths) or None).fit(rig.params)
    specs = plan(load_campaign("paper")["sine"], rig)
    loads = [s for s in specs if "load" in s.name]
    sines = [s for s in specs if "load" not in s.name]
    spec = loads[(i // 2) % len(loads)] if i % 2 == 0 else sines[(i // 2) % len(sines)]
    rng = np.random.default_rng([i, len(fault), 53])
    true = draw_within(rig.params, monitor.intervals_, rng)
    true, offset, _ = inject(true, FAULTS[fault], 0, 1)
    faulty = dataclasses.replace(rig, params=true, supply=true.supply)
    run = execute(
        faulty, dataclasses.replace(spec, command_offset=offset), run_seed(i, fault, spec.name)
    )
    h = monitor.check(run)
    cl = h.indicators["internal_leakage"]
    dp = np.sqrt(np.mean((run.channels["p_a"] - run.channels["p_b"]) ** 2))
    return {
        "machine": machine,
        "fault": fault,
        "run": spec.name,
        "kind": "load" if "load" in spec.name else "sine",
        "alarm": h.alarm,
        "named": h.faults[0] if h.faults else "",
        "leak_detectable": (cl.threshold[1] + 2.33 * cl.std) * 50e5 * 6e4,
        "dp_rms_bar": dp / 1e5,
        "friction_threshold": h.indicators["friction_scale"].threshold[1],
        "friction_bias": h.indicators["friction_scale"].bias,
    }


def _table(rows: list[dict]) -> str:
    out = [
        "| machine | case | run kind | runs | alarms | named correctly |",
        "|---|---|---|---|---|---|",
    ]
    keys = sorted({(r["machine"], r["fault"], r["kind"]) for r in rows})
    for m, f, k in keys:
        sel = [r for r in rows if (r["machine"], r["fault"], r["kind"]) == (m, f, k)]
        alarms = sum(r["alarm"] for r in sel)
        named = sum(r["named"] == f for r in sel if r["alarm"])
        right = "—" if f == "healthy" else f"{named}/{alarms}"
        out.append(
            f"| {m} | {f} | {k} | {len(sel)} | {alarms} ({100 * alarms / len(sel):.1f} %) | {right} |"
        )
    return "\n".join(out)


def _leak_table(rows: list[dict]) -> str:
    out = [
        "| machine | run | RMS(P_A − P_B) [bar] | leakage detected in 99 % [L/min @ 50 bar], median |",
        "|---|---|---|---|",
    ]
    for m in sorted({r["machine"] for r in rows}):
        for name in sorted({r["run"] for r in rows if r["machine"] == m}):
            sel = [
                r
                for r in rows
                if r["machine"] == m and r["run"] == name and r["fault"] == "healthy"
            ]
            if sel:
                dp = np.median([r["dp_rms_bar"] for r in sel])
                q = np.median([r["leak_detectable"] for r in sel])
                out.append(f"| {m} | {name} | {dp:.1f} | {q:.3g} |")
    return "\n".join(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--healthy", type=int, default=110, help="healthy runs per machine")
    ap.add_argument("--faulty", type=int, default=22, help="runs per fault and machine")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument(
        "--first", type=int, default=0, help="first case index (to extend a study with new draws)"
    )
    ap.add_argument("--machines", nargs="*", default=list(MACHINES))
    ap.add_argument("--rows", type=Path, default=None, help="append each run's row (JSON lines)")
    ap.add_argument(
        "--width",
        action="append",
        default=[],
        help="PATH=REL: healthy interval value·(1 ± REL) of a parameter, as an identification "
        "would give it (e.g. friction.stribeck_velocity=0.05); repeatable",
    )
    ap.add_argument("--faults", nargs="*", default=list(FAULTS), help="cases to run")
    a = ap.parse_args()
    widths = tuple((w.split("=")[0], float(w.split("=")[1])) for w in a.width)
    cases = [
        (m, f, i, widths)
        for m in a.machines
        for f in a.faults
        for i in range(a.first, a.first + (a.healthy if f == "healthy" else a.faulty))
    ]
    # interleaved (by draw index, then machine and case): a study stopped early is balanced
    cases.sort(key=lambda c: (c[2], c[0], c[1]))
    t0 = time.perf_counter()
    with cf.ProcessPoolExecutor(a.jobs) if a.jobs > 1 else _Serial() as pool:
        rows = []
        for row in pool.map(_case, *zip(*cases, strict=True)):
            rows.append(row)
            if a.rows is not None:
                with a.rows.open("a") as fh:
                    fh.write(json.dumps({k: _plain(v) for k, v in row.items()}) + "\n")
    print(f"{len(rows)} runs in {time.perf_counter() - t0:.0f} s\n")
    print(_table(rows), "\n")
    print(_leak_table(rows))


def _plain(v):
    return v.item() if isinstance(v, np.generic) else v


class _Serial:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    @staticmethod
    def map(fn, *its):
        return map(fn, *its)


if __name__ == "__main__":
    main()
