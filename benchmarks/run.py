"""Speed of hydropwa against scipy, batch scaling and start-up, measured side by side.

Usage::

    python benchmarks/run.py [--quick] [--rtol 1e-3] [--batch N]

Case: the paper rig (preset ``paper``), 10 s of a 40 %, 1 Hz sine, outputs at
2 kHz. For every model:

* **hydropwa**: ``simulate(...)`` end to end (packing, kernel, result), best of
  several calls, at ``--rtol`` (default 1e-3, see ``accuracy`` below), reading the
  states (``res.states``) only: the derived channels are computed on their first read
  (``SimulationResult.channels``), so this time holds no output pass;
  ``with_channels`` is the same call followed by a read of one channel, which runs the
  output pass for all of them; ``kernel`` is the integrator alone (``stats['wall_time']``).
* **scipy**: ``solve_ivp(method="LSODA")`` on the plain Python/NumPy right-hand
  side of ``benchmarks/numpy_rhs.py`` (PWA: ``hydropwa.linearization.pwa_rhs``),
  at the loosest of rtol 1e-3 … 1e-7 (atol = rtol × state scale) whose position
  error is below 0.1 mm, i.e. at matched accuracy.
* **accuracy**: max |x − x_ref| over all samples, x_ref from hydropwa's ROS2(3)
  (a different method from the default ROS34PW2) at rtol 1e-9; the test
  ``tests/performance/test_convergence.py`` checks both against scipy Radau at
  rtol 1e-10.

Then the batch throughput per core against the single-trajectory rate, and the
first-call (cold numba cache, fresh process) and warm-cache process times.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

sys.path.insert(0, str(Path(__file__).parent))

from numpy_rhs import REDUCED_RHS, RHS  # noqa: E402

from hydropwa.models import as_model  # noqa: E402
from hydropwa.params import get_preset  # noqa: E402
from hydropwa.simulation import _kernel as K  # noqa: E402
from hydropwa.simulation import as_signal, simulate, simulate_batch  # noqa: E402
from hydropwa.simulation._simulate import _KERNEL_KIND as KIND  # noqa: E402

U = "sine:amplitude=0.4,frequency=1"
DURATION, FS, TOL_MM = 10.0, 2000.0, 0.1
X_INDEX = {K.FULL: 4, K.REDUCED: 2, K.PWA: 2, K.CHAMBER: 4}


def _models():
    params = get_preset("paper")
    from hydropwa.linearization import linearize
    from hydropwa.models import ReducedModel

    # the default (asymmetric) reduced and PWA models next to the paper's mean-area forms
    return {
        "full": as_model("full", params),
        "reduced": ReducedModel(params),
        "pwa": linearize(params),
        "reduced-paper": ReducedModel(params, "paper"),
        "pwa-paper": linearize(params, form="consistent", breakpoints="paper"),
        "pwa-chamber": linearize(params, form="chamber"),
    }


def _best(fn, repeats: int) -> tuple[float, object]:
    best, res = float("inf"), None
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = fn()
        best = min(best, time.perf_counter() - t0)
    return best, res


def _scipy_rhs(model):
    """Plain-Python RHS f(t, y) of the model and its packed parameters."""
    u, ps, fl = (
        as_signal(U, "", "u"),
        as_signal(model.params.supply.pressure, "Pa", "p_s"),
        as_signal(0.0, "N", "f_l"),
    )
    p = model.pack(command_amplitude=0.4)
    if KIND[model.name] == K.PWA:
        from hydropwa.linearization import pwa_rhs

        return lambda t, y: pwa_rhs(t, y, u(t), ps(t), fl(t), model)
    if KIND[model.name] == K.CHAMBER:
        return lambda t, y: model.rhs(t, y, u(t), ps(t), fl(t))
    f = REDUCED_RHS[model.form] if KIND[model.name] == K.REDUCED else RHS[KIND[model.name]]
    return lambda t, y: f(t, y, p, u, ps, fl)


def _scipy_run(model, t_out, rtol):
    y0 = model.initial_state()
    f = _scipy_rhs(model)
    t0 = time.perf_counter()
    sol = solve_ivp(
        f,
        (0.0, DURATION),
        y0,
        method="LSODA",
        t_eval=t_out,
        rtol=rtol,
        atol=rtol * model.state_scale(),
    )
    return time.perf_counter() - t0, sol


def bench_single(rtol: float, repeats: int, quick: bool) -> list[dict]:
    """One row per model: hydropwa vs scipy LSODA at matched accuracy."""
    rows = []
    t_out = np.linspace(0.0, DURATION, int(DURATION * FS) + 1)
    for name, model in _models().items():
        ix = X_INDEX[KIND[model.name]]
        if KIND[model.name] not in (K.PWA, K.CHAMBER):  # scipy must see the same vector field
            from numpy_rhs import check_against_kernel

            sig = (
                as_signal(U, "", "u"),
                as_signal(model.params.supply.pressure, "Pa", "p_s"),
                as_signal(0.0, "N", "f_l"),
            )
            y = (
                model.initial_state()
                + np.r_[
                    [1e5, 0.01, 0.0] if KIND[model.name] == K.REDUCED else np.zeros(len(K.Y_FULL))
                ]
            )
            assert check_against_kernel(KIND[model.name], model.pack(0.4), sig, y) < 1e-9, name
        ref = simulate(
            model, U, duration=DURATION, fs=FS, rtol=1e-9, solver="ros23", max_steps=50_000_000
        )
        x_ref = ref.states[:, ix]
        simulate(model, U, duration=DURATION, fs=FS, rtol=rtol)  # compile / load cache
        t_h, res = _best(
            lambda m=model: simulate(m, U, duration=DURATION, fs=FS, rtol=rtol), repeats
        )
        t_ch, _ = _best(
            lambda m=model: simulate(m, U, duration=DURATION, fs=FS, rtol=rtol)["friction"],
            repeats,
        )
        kern = min(
            simulate(model, U, duration=DURATION, fs=FS, rtol=rtol).stats["wall_time"]
            for _ in range(repeats)
        )
        err_h = float(np.max(np.abs(res.states[:, ix] - x_ref))) * 1e3
        t_s, err_s, rtol_s = float("nan"), float("nan"), float("nan")
        for r in (1e-3, 1e-4, 1e-5, 1e-6, 1e-7)[: 3 if quick else 5]:
            t_s, sol = _scipy_run(model, t_out, r)
            if not sol.success:
                continue
            err_s = float(np.max(np.abs(sol.y[ix] - x_ref))) * 1e3
            rtol_s = r
            if err_s < TOL_MM:
                break
        rows.append(
            {
                "case": name,
                "hydropwa_s": t_h,
                "with_channels_s": t_ch,
                "kernel_s": kern,
                "scipy_s": t_s,
                "ratio": t_s / t_h,
                "realtime": DURATION / t_h,
                "err_mm": err_h,
                "scipy_err_mm": err_s,
                "scipy_rtol": rtol_s,
                "steps": res.stats["steps"],
            }
        )
    return rows


def bench_batch(n_cases: int, rtol: float) -> list[dict]:
    """Throughput per core of simulate_batch against one-at-a-time runs of the same cases."""
    cores = os.cpu_count() or 1
    amps = np.linspace(0.2, 0.6, n_cases)
    inputs = [f"sine:amplitude={a:.4f},frequency=1" for a in amps]
    rows = []
    paper = get_preset("paper")
    for name in ("full", "reduced"):
        simulate_batch(paper, inputs[:2], model=name, duration=1.0, rtol=rtol)
        t1, _ = _best(
            lambda n=name: simulate_batch(
                paper, inputs, model=n, duration=DURATION, rtol=rtol, jobs=1, summary=True
            ),
            3,
        )
        tp, _ = _best(
            lambda n=name: simulate_batch(
                paper, inputs, model=n, duration=DURATION, rtol=rtol, jobs=cores, summary=True
            ),
            3,
        )
        rows.append(
            {
                "model": name,
                "cases": n_cases,
                "cores": cores,
                "single_per_s": n_cases / t1,
                "batch_per_s": n_cases / tp,
                "per_core_per_s": n_cases / tp / cores,
                "efficiency": t1 / (tp * cores),
            }
        )
    return rows


_CHILD = r"""
import json, time
t0 = time.perf_counter()
import hydropwa
t_import = time.perf_counter() - t0
from hydropwa.params import get_preset
from hydropwa.simulation import simulate
P = get_preset("paper")
t0 = time.perf_counter(); simulate("full", "sine:amplitude=0.4,frequency=1", duration=10.0, rtol=RTOL, params=P)
t_first = time.perf_counter() - t0
t0 = time.perf_counter(); simulate("full", "sine:amplitude=0.4,frequency=1", duration=10.0, rtol=RTOL, params=P)
t_warm = time.perf_counter() - t0
print(json.dumps({"import": t_import, "first": t_first, "warm": t_warm}))
"""


def bench_startup(rtol: float) -> list[dict]:
    """Fresh processes: empty numba cache (compiles), then the cache the first one wrote."""
    rows = []
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        for label in ("cold cache", "warm cache"):
            out = subprocess.run(
                [sys.executable, "-c", _CHILD.replace("RTOL", repr(rtol))],
                env=env,
                capture_output=True,
                text=True,
                check=True,
            )
            rows.append({"process": label, **json.loads(out.stdout.strip().splitlines()[-1])})
    return rows


def _print_table(title: str, rows: list[dict], fmt: dict[str, str]) -> None:
    print(f"\n{title}")
    cols = list(rows[0])
    cells = [[(fmt.get(c, "{}").format(r[c])) for c in cols] for r in rows]
    widths = [max(len(c), *(len(row[i]) for row in cells)) for i, c in enumerate(cols)]
    print("  ".join(c.rjust(w) for c, w in zip(cols, widths, strict=True)))
    for row in cells:
        print("  ".join(v.rjust(w) for v, w in zip(row, widths, strict=True)))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rtol", type=float, default=1e-3, help="hydropwa tolerance (default 1e-3)")
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--batch", type=int, default=0, help="batch size (default 16 × cores)")
    ap.add_argument("--quick", action="store_true", help="fewer repeats and scipy tolerances")
    ap.add_argument("--json", type=Path, help="also write all numbers to this JSON file")
    args = ap.parse_args(argv)
    repeats = 3 if args.quick else args.repeats
    n_batch = args.batch or 16 * (os.cpu_count() or 1)
    print(
        f"paper rig, {DURATION:g} s of a 40 % 1 Hz sine, outputs at {FS:g} Hz; hydropwa rtol {args.rtol:g}"
    )
    single = bench_single(args.rtol, repeats, args.quick)
    _print_table(
        "single trajectory (times in s; ratio = scipy/hydropwa; realtime = simulated/wall)",
        single,
        {
            "hydropwa_s": "{:.4f}",
            "with_channels_s": "{:.4f}",
            "kernel_s": "{:.4f}",
            "scipy_s": "{:.3f}",
            "ratio": "{:.0f}x",
            "realtime": "{:.0f}x",
            "err_mm": "{:.4f}",
            "scipy_err_mm": "{:.4f}",
            "scipy_rtol": "{:.0e}",
        },
    )
    by = {r["case"]: r for r in single}
    for form in ("reduced", "pwa"):
        print(
            f"{form}: asymmetric (default) / paper mean-area form, end-to-end time "
            f"{by[form]['hydropwa_s'] / by[form + '-paper']['hydropwa_s']:.2f}x "
            f"(target <= 1: at least as fast as the paper form)"
        )
    ch = by["pwa-chamber"]
    print(
        f"pwa-chamber: {ch['realtime']:.0f}x real time (target >= 1000x), end-to-end time "
        f"{ch['hydropwa_s'] / by['full']['hydropwa_s']:.2f}x the full model's"
    )
    batch = bench_batch(n_batch, args.rtol)
    _print_table(
        "batch (cases per second)",
        batch,
        {
            "single_per_s": "{:.1f}",
            "batch_per_s": "{:.1f}",
            "per_core_per_s": "{:.1f}",
            "efficiency": "{:.0%}",
        },
    )
    startup = bench_startup(args.rtol)
    _print_table(
        "start-up, fresh processes (s)",
        startup,
        {"import": "{:.3f}", "first": "{:.3f}", "warm": "{:.4f}"},
    )
    if args.json:
        args.json.write_text(
            json.dumps({"single": single, "batch": batch, "startup": startup}, indent=2)
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
