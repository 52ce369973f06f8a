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
- the smallest detectable internal leakage per run (threshold + 2.33 standard errors, the
  leakage detected in 99 % of runs), against the run's excitation (RMS of P_A − P_B).

Prints Markdown tables; writes nothing. The issue's statistic is ``--healthy 1000``
(about 2 s per run on one core)::

    python benchmarks/monitor_study.py --healthy 1000 --faulty 100 --jobs 8
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import dataclasses
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


def _case(machine: str, fault: str, i: int) -> dict:
    params = MACHINES[machine]()
    rig = Rig(params)
    monitor = HealthMonitor().fit(rig.params)
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
    a = ap.parse_args()
    cases = [
        (m, f, i)
        for m in a.machines
        for f in FAULTS
        for i in range(a.first, a.first + (a.healthy if f == "healthy" else a.faulty))
    ]
    t0 = time.perf_counter()
    with cf.ProcessPoolExecutor(a.jobs) if a.jobs > 1 else _Serial() as pool:
        rows = list(pool.map(_case, *zip(*cases, strict=True)))
    print(f"{len(rows)} runs in {time.perf_counter() - t0:.0f} s\n")
    print(_table(rows), "\n")
    print(_leak_table(rows))


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
