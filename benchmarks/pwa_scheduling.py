"""Cost of online supply-pressure scheduling of the PWA model (NOTES.md item 10).

The paper reports that recalculating the linearization at the time-varying P_S "fails due
to an exponential increase in simulation time". With cells in p̃ = P_L/P_S the schedule is
two multiplications per right-hand-side call. This script times

* fixed P_S (the paper's average),
* scheduled with a constant P_S input (isolates the cost of the schedule itself),
* scheduled with a varying P_S(t) (Fig. 9-like ripple; the integrator may take more steps),

and reports wall time per simulated second and per step. Run: ``python benchmarks/pwa_scheduling.py``.
"""

from __future__ import annotations

import time

import numpy as np

from hydropwa.linearization import linearize
from hydropwa.params import get_preset
from hydropwa.simulation import simulate


def _time(model, ps, u, duration, repeat=5):
    simulate(model, u, duration=duration, supply_pressure=ps)  # compile / warm up
    best, res = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        res = simulate(model, u, duration=duration, supply_pressure=ps)
        best = min(best, time.perf_counter() - t0)
    return best, res


def main(duration: float = 4.0) -> dict[str, float]:
    p = get_preset("paper")
    u = "sine:amplitude=0.4,frequency=2"
    tt = np.linspace(0.0, duration, int(duration * 2000) + 1)
    ripple = (tt, 95e5 + 3e5 * np.sin(2 * np.pi * 1.0 * tt))
    cases = {
        "fixed": (linearize(p, supply_pressure=95e5), 95e5),
        "scheduled, constant input": (linearize(p, supply_pressure=95e5, scheduled=True), 95e5),
        "scheduled, varying P_S(t)": (linearize(p, supply_pressure=95e5, scheduled=True), ripple),
    }
    out = {}
    for name, (model, ps) in cases.items():
        wall, res = _time(model, ps, u, duration)
        steps = getattr(res, "stats", {}).get("steps", float("nan")) if isinstance(getattr(res, "stats", None), dict) else float("nan")
        out[name] = wall
        print(f"{name:28s} {wall * 1e3:8.2f} ms  ({wall / duration * 1e3:6.2f} ms per simulated s, steps {steps})")
    ratio = out["scheduled, constant input"] / out["fixed"]
    print(f"scheduled / fixed (same inputs): {ratio:.2f}  (target <= 1.5)")
    return out


if __name__ == "__main__":
    main()
