"""False alarms, detection and isolation of the health monitor on the virtual rig (issue 53).

For each machine (the paper rig, the 63/36 × 500 mm heavy axis of tests/machines/industrial.toml)
the monitor is fitted to the machine's **identified** file (``--source identified``, default):
the rig's friction experiment on the true machine and ``hydropwa identify friction`` on it
(F_c, F_s, σ, χ, δ, γ with their 95 % intervals in the file's ``[uncertainty]``; the other
parameters are the nominal ones with the monitor's assumed intervals), kept in ``--cache``
with the default position controller designed on it (``hydropwa control design``, verified).
``--source nominal`` fits it to the nominal parameters with assumed intervals only.

Three run kinds in turn (case index i: i % 3 = 0 a load run, 1 an open-loop sine, 2 a
closed-loop trapezoid): the paper campaign's ``[sine]`` experiment planned for the machine
(two counter-force load runs, nine open-loop sines) and two round trips 25 % ↔ 75 % of the
stroke under the position controller (:func:`trapezoid_reference`). Each is simulated on a
machine drawn uniformly inside the monitor's intervals (:func:`hydropwa.monitor.draw_within`)
with its own noise seed:

- ``healthy``: ``--healthy`` draws per machine: false alarms;
- ``truth``: the machine the identification ran on (not a draw; its parameters may lie outside
  the identified 95 % intervals): false alarms of a real identification;
- faulty: ``--faulty`` draws per fault and machine: internal leakage 0.1 L/min at 50 bar,
  friction +30 %, valve null 0.5 %, supply −10 %: detection and isolation (the fault named
  first), per run kind. The valve null is not run in closed loop (the compiled loop has no
  command offset inside the valve), so those cases are left out;
- ``--width PATH=REL`` sets a parameter's healthy interval to value·(1 ± REL) (the monitor's
  interval and the draws); ``--faults`` picks the cases;
- the smallest detectable internal leakage per run (threshold + 2.33 standard errors, the
  leakage detected in 99 % of runs), its noise and held-parameter parts, against the run's
  excitation (RMS of P_A − P_B) and length.

Prints Markdown tables; with ``--rows FILE`` each run's row is also appended to FILE as one
JSON line as it finishes (a long study stopped early keeps what it did). The issue's statistic
is ``--healthy 1000`` (about 0.5 s per run on one core once compiled)::

    python benchmarks/monitor_study.py --healthy 1000 --faulty 60
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import dataclasses
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from hydropwa.control import DEFAULT_DESIGN, load_controller, maximum_velocity
from hydropwa.models import FullOrderModel
from hydropwa.monitor import HealthMonitor, draw_within
from hydropwa.params import get_preset, load_params
from hydropwa.rig import Fault, Rig, execute, inject, load_campaign, plan, run_seed
from hydropwa.rig._plan_files import positioning_reference
from hydropwa.rig._sensors import measure
from hydropwa.simulation import simulate

ROOT = Path(__file__).resolve().parents[1]
#: the machines as the rig simulates them (the truth the identification sees)
TRUE = {
    "paper": "paper",
    "heavy": str(ROOT / "tests/machines/industrial.toml"),
}
#: where the identified parameter files and the position controllers are kept (--cache)
CACHE = ROOT / "benchmarks" / ".monitor_study"
RUN_KINDS = ("load", "sine", "trapezoid")


def _hydropwa(*args: str) -> None:
    subprocess.run([sys.executable, "-m", "hydropwa", *args], check=True, capture_output=True)


def prepare_machine(machine: str, cache: Path) -> None:
    """The machine's identified file (rig friction runs, ``identify friction``) and controller.

    ``cache/MACHINE/identified.toml``: the rig's friction experiment on the true machine and
    ``hydropwa identify friction`` on it (F_c, F_s, σ, χ, δ, γ with 95 % intervals, written as
    the file's ``[uncertainty]``: the monitor's identified intervals); ``controller.toml``:
    ``hydropwa control design`` (the default design, verified) on that file.
    """
    d = cache / machine
    ident, ctrl = d / "identified.toml", d / "controller.toml"
    if not ident.is_file():
        _hydropwa(
            "rig", "run", "friction", "--params", TRUE[machine], "--out", str(d / "rig"), "-q"
        )
        _hydropwa("identify", "friction", str(d / "rig" / "friction"), "--params", TRUE[machine],
                  "-o", str(ident))  # fmt: skip
    if not ctrl.is_file():
        _hydropwa("control", "design", "--params", str(ident), "--out", str(ctrl))


def _machine(machine: str, source: str, cache: Path):
    """(identified or nominal parameters, controller file) of a machine."""
    if source == "identified":
        return load_params(cache / machine / "identified.toml"), cache / machine / "controller.toml"
    p = get_preset("paper") if TRUE[machine] == "paper" else load_params(TRUE[machine])
    return p, cache / machine / "controller.toml"


def trapezoid_reference(params, rate: float) -> tuple[np.ndarray, np.ndarray]:
    """Two closed-loop round trips 25 % ↔ 75 % of the stroke, each move at half the no-load
    speed reached in 40 ms (the verification's trapezoid, control/_verify.py), 0.5 s holds."""
    L = params.cylinder.stroke
    v = 0.5 * maximum_velocity(params)
    ts, rs, t0 = [np.array([0.0])], [np.array([0.25 * L])], 0.2
    for a, b in ((0.25, 0.75), (0.75, 0.25)) * 2:
        t, r = positioning_reference(a * L, b * L, rate, v, v / 0.04)
        ts.append(t0 + t)
        rs.append(r)
        t0 += t[-1] + 1.0 / rate
    return np.concatenate(ts), np.concatenate(rs)


def closed_loop_run(rig: Rig, ctrl_path: Path, name: str, seed: np.random.SeedSequence):
    """A run under the position controller on :func:`trapezoid_reference`, measured by the
    rig's sensors (the controller reads its own noise of the design's standard deviations)."""
    t, r = trapezoid_reference(rig.params, rig.fs)
    ctl_seed, sensor_rng = seed.spawn(2)
    result = simulate(
        FullOrderModel(rig.params),
        controller=load_controller(ctrl_path),
        reference=(t, r),
        duration=float(t[-1]),
        initial_position=float(r[0]),
        fs=rig.fs,
        rtol=rig.rtol,
        sensor_noise=dict(DEFAULT_DESIGN.sensor_noise),
        seed=int(ctl_seed.generate_state(1)[0]),
    )
    meta = {"experiment": "trapezoid", "kind": "trapezoid", "start_position": float(r[0])}
    return measure(
        result, rig.sensors or {}, np.random.default_rng(sensor_rng), name=name, meta=meta,
        fs=rig.fs,
    )  # fmt: skip


FAULTS = {
    "healthy": (),
    "truth": (),  # healthy: the machine the identification ran on, not a draw
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


def _case(
    machine: str,
    fault: str,
    i: int,
    widths: tuple[tuple[str, float], ...] = (),
    source: str = "identified",
    cache: Path = CACHE,
) -> dict:
    params, ctrl = _machine(machine, source, cache)
    rig = Rig(params)
    monitor = HealthMonitor(intervals=_intervals(rig.params, widths) or None).fit(rig.params)
    kind = RUN_KINDS[i % 3]
    rng = np.random.default_rng([i, len(fault), 53])
    if fault == "truth":
        faulty, offset = Rig(_machine(machine, "nominal", cache)[0]), 0.0
    else:
        true = draw_within(rig.params, monitor.intervals_, rng)
        true, offset, _ = inject(true, FAULTS[fault], 0, 1)
        faulty = dataclasses.replace(rig, params=true, supply=true.supply)
    if kind == "trapezoid":
        if offset:  # the compiled loop has no command offset inside the valve
            return {}
        name = "trapezoid_closed_loop"
        run = closed_loop_run(faulty, ctrl, name, run_seed(i, fault, name))
    else:
        specs = plan(load_campaign("paper")["sine"], rig)
        pick = [s for s in specs if ("load" in s.name) == (kind == "load")]
        spec = pick[(i // 3) % len(pick)]
        name = spec.name
        run = execute(
            faulty, dataclasses.replace(spec, command_offset=offset), run_seed(i, fault, name)
        )
    h = monitor.check(run)
    cl = h.indicators["internal_leakage"]
    dp = np.sqrt(np.mean((run.channels["p_a"] - run.channels["p_b"]) ** 2))
    fr = h.indicators["friction_scale"]
    return {
        "machine": machine,
        "fault": fault,
        "run": name,
        "kind": kind,
        "alarm": h.alarm,
        "named": h.faults[0] if h.faults else "",
        "leak_detectable": (cl.threshold[1] + 2.33 * cl.std) * 50e5 * 6e4,
        "leak_std": cl.std * 50e5 * 6e4,
        "leak_bias": cl.bias * 50e5 * 6e4,
        "dp_rms_bar": dp / 1e5,
        "duration_s": float(run.channels["t"][-1] - run.channels["t"][0]),
        "friction_value": fr.value,
        "friction_threshold": fr.threshold[1],
        "friction_healthy_hi": fr.nominal[1],
        "friction_bias": fr.bias,
        "friction_std": fr.std,
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
        right = "—" if f in ("healthy", "truth") else f"{named}/{alarms}"
        out.append(
            f"| {m} | {f} | {k} | {len(sel)} | {alarms} ({100 * alarms / len(sel):.1f} %) | {right} |"
        )
    return "\n".join(out)


def _leak_table(rows: list[dict]) -> str:
    out = [
        "| machine | run | kind | RMS(P_A − P_B) [bar] | length [s] | detectable leakage, median (range) "
        "[L/min @ 50 bar] | of it: noise (k + 2.33)·σ̂ | held parameters b |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for m in sorted({r["machine"] for r in rows}):
        for name in sorted({r["run"] for r in rows if r["machine"] == m}):
            sel = [
                r
                for r in rows
                if r["machine"] == m and r["run"] == name and r["fault"] == "healthy"
            ]
            if sel:
                q = [r["leak_detectable"] for r in sel]
                med = {
                    k: float(np.median([r[k] for r in sel]))
                    for k in ("dp_rms_bar", "duration_s", "leak_bias")
                }
                noise = float(np.median([r["leak_detectable"] - r["leak_bias"] for r in sel]))
                out.append(
                    f"| {m} | {name} | {sel[0]['kind']} | {med['dp_rms_bar']:.1f} | "
                    f"{med['duration_s']:.1f} | {np.median(q):.3g} ({min(q):.3g}–{max(q):.3g}) | "
                    f"{noise:.3g} | {med['leak_bias']:.3g} |"
                )
    return "\n".join(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--healthy", type=int, default=110, help="healthy runs per machine")
    ap.add_argument("--faulty", type=int, default=22, help="runs per fault and machine")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument(
        "--first", type=int, default=0, help="first case index (to extend a study with new draws)"
    )
    ap.add_argument("--machines", nargs="*", default=list(TRUE))
    ap.add_argument(
        "--source",
        choices=("identified", "nominal"),
        default="identified",
        help="the monitor's machine: the friction identification's file (its intervals) or "
        "the nominal parameters with the assumed intervals",
    )
    ap.add_argument("--cache", type=Path, default=CACHE, help="identified files, controllers")
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
    for m in a.machines:
        prepare_machine(m, a.cache)
    cases = [
        (m, f, i, widths, a.source, a.cache)
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
            if not row:  # a case the run kind cannot carry (valve null in closed loop)
                continue
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
