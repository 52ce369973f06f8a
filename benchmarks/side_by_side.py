"""This tree's simulate against an earlier commit's, model by model, in one run.

Usage::

    python benchmarks/side_by_side.py [--base c7a5ce2] [--rounds 3] [--repeats 5]
        [--models full,pwa] [--no-cold]

The base commit is checked out into a temporary ``git worktree`` and imported from
its ``src`` folder by worker processes (``PYTHONPATH``), with this environment's
libraries; this tree's workers import this checkout's ``src``. Each worker builds the
six models of ``benchmarks/run.py`` (paper rig: full, reduced, pwa, the paper's
mean-area reduced and PWA, pwa-chamber), simulates each once to compile or load its
kernel, then times ``simulate(model, U, duration=10, fs=2000, rtol=1e-3)`` (the
case of ``run.py``) best of ``--repeats``, reading the states only. Workers of the
two trees alternate (base, this, base, this, …) for ``--rounds`` rounds, so a change
of the machine's load falls on both; each model's time is its best over the rounds.

Two variants of this tree: ``this``, compiled for this CPU (``HYDROPWA_PREBUILT=0``), as the
base is; ``shipped``, the shipped generic x86-64 entries a fresh install loads first.

Printed per model: the times, the ratios to the base (< 1: this tree is faster), the
step counts and the largest position difference between the two trees' results
(the same equations and tolerances give the same trajectory up to rounding and FMA
contraction; a difference above the solver's tolerance would be a change of the
model, not of its speed).

Then the **cold compile** of each tree: one worker per tree with an empty numba cache
(``NUMBA_CACHE_DIR`` a fresh folder, ``HYDROPWA_PREBUILT=0`` so that this tree's
shipped entries are not used), timing the first ``simulate`` of the full model, in
CPU seconds of the process.

Written as JSON with ``--json PATH``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

WORKER = r"""
import json, sys, time, resource
import numpy as np
mode = sys.argv[1]
repeats = int(sys.argv[2])
only = set(sys.argv[3].split(",")) if len(sys.argv) > 3 and sys.argv[3] else None
from hydropwa.params import get_preset
from hydropwa.models import as_model, ReducedModel
from hydropwa.linearization import linearize
from hydropwa.simulation import simulate
U = "sine:amplitude=0.4,frequency=1"
p = get_preset("paper")
def cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime
if mode == "cold":
    m = as_model("full", p)
    c0, w0 = cpu(), time.perf_counter()
    simulate(m, U, duration=10.0, fs=2000.0, rtol=1e-3)
    print(json.dumps({"cpu_s": cpu() - c0, "wall_s": time.perf_counter() - w0}))
    raise SystemExit
# the models of benchmarks/run.py's _models(), written out: the worker runs against the base
# tree's package, so it cannot import this checkout's run.py (which reads newer private names)
models = {
    "full": as_model("full", p),
    "reduced": ReducedModel(p),
    "pwa": linearize(p),
    "reduced-paper": ReducedModel(p, "paper"),
    "pwa-paper": linearize(p, form="consistent", breakpoints="paper"),
    "pwa-chamber": linearize(p, form="chamber"),
}
out = {}
for name, m in models.items():
    if only is not None and name not in only:
        continue
    res = simulate(m, U, duration=10.0, fs=2000.0, rtol=1e-3)
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = simulate(m, U, duration=10.0, fs=2000.0, rtol=1e-3)
        res.states
        best = min(best, time.perf_counter() - t0)
    st = np.asarray(res.states)
    ix = 4 if st.shape[1] >= 6 else 2
    out[name] = {"s": best, "steps": int(res.stats["steps"]), "x": st[::200, ix].tolist()}
print(json.dumps(out))
"""


def _worker(
    src: Path, mode: str, repeats: int, env_extra: dict[str, str], models: str = ""
) -> dict:
    env = {**os.environ, "PYTHONPATH": str(src), **env_extra}
    proc = subprocess.run(
        [sys.executable, "-c", WORKER, mode, str(repeats), models],
        capture_output=True,
        text=True,
        env=env,
        cwd=src.parent,
        check=False,
    )
    if proc.returncode != 0:
        raise SystemExit(f"worker for {src} failed:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--base", default="c7a5ce2", help="the commit to compare against")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--no-cold", action="store_true", help="skip the cold-compile timing")
    ap.add_argument("--models", default="", help="comma-separated subset (default: all six)")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()

    with tempfile.TemporaryDirectory(prefix="hydropwa-base-") as tmp:
        base_dir = Path(tmp) / "base"
        subprocess.run(
            ["git", "-C", str(ROOT), "worktree", "add", "--detach", str(base_dir), args.base],
            check=True,
            capture_output=True,
        )
        try:
            trees = {"base": base_dir / "src", "this": ROOT / "src", "shipped": ROOT / "src"}
            best: dict[str, dict] = {k: {} for k in trees}
            for r in range(args.rounds):
                for tree, src in trees.items():
                    env = {"NUMBA_CACHE_DIR": str(Path(tmp) / f"cache-{tree}")}
                    if tree != "shipped":  # compiled for this CPU, as the base is
                        env["HYDROPWA_PREBUILT"] = "0"
                    res = _worker(src, "warm", args.repeats, env, args.models)
                    for name, row in res.items():
                        old = best[tree].get(name)
                        if old is None or row["s"] < old["s"]:
                            best[tree][name] = row
                    print(f"round {r + 1}/{args.rounds}: {tree} done", file=sys.stderr)
            rows = []
            for name in best["this"]:
                b, t, sh = best["base"][name], best["this"][name], best["shipped"][name]
                dx = max(abs(u - v) for u, v in zip(b["x"], t["x"], strict=True)) * 1e3
                rows.append(
                    {
                        "model": name,
                        "base_ms": b["s"] * 1e3,
                        "this_ms": t["s"] * 1e3,
                        "ratio": t["s"] / b["s"],
                        "shipped_ms": sh["s"] * 1e3,
                        "shipped_ratio": sh["s"] / b["s"],
                        "base_steps": b["steps"],
                        "this_steps": t["steps"],
                        "max_dx_mm": dx,
                    }
                )
            cold = {}
            if not args.no_cold:
                for tree in ("base", "this"):
                    src = trees[tree]
                    env = {
                        "NUMBA_CACHE_DIR": str(Path(tmp) / f"cold-{tree}"),
                        "HYDROPWA_PREBUILT": "0",
                    }
                    cold[tree] = _worker(src, "cold", 1, env)
        finally:
            subprocess.run(
                ["git", "-C", str(ROOT), "worktree", "remove", "--force", str(base_dir)],
                check=False,
                capture_output=True,
            )

    print(f"simulate, paper rig, 10 s sine at rtol 1e-3, best of {args.rounds}×{args.repeats}")
    print(f"base {args.base} against this tree (ratio this/base; < 1 is faster)\n")
    print("this: compiled for this CPU as the base is; shipped: the shipped generic entries\n")
    print(
        f"{'model':<14}{'base ms':>9}{'this ms':>9}{'ratio':>7}{'shipped ms':>11}{'ratio':>7}"
        f"{'steps':>13}{'max Δx mm':>11}"
    )
    for r in rows:
        steps = f"{r['base_steps']}/{r['this_steps']}"
        print(
            f"{r['model']:<14}{r['base_ms']:9.2f}{r['this_ms']:9.2f}{r['ratio']:7.3f}"
            f"{r['shipped_ms']:11.2f}{r['shipped_ratio']:7.3f}{steps:>13}{r['max_dx_mm']:11.2e}"
        )
    for tree, c in cold.items():
        print(
            f"cold first simulate of the full model, {tree}: {c['cpu_s']:.1f} CPU-s, "
            f"{c['wall_s']:.1f} s wall"
        )
    if cold:
        print(f"cold compile ratio this/base: {cold['this']['cpu_s'] / cold['base']['cpu_s']:.3f}")
    if args.json:
        args.json.write_text(json.dumps({"rows": rows, "cold": cold}, indent=1))


if __name__ == "__main__":
    main()
