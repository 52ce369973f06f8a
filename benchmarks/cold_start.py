"""First-run (cold) and cached (warm) times of what a new user runs first, against the targets.

Each case runs in a fresh process, first with an empty numba cache (``NUMBA_CACHE_DIR`` pointed
at a new folder: a fresh installation, which loads the package's shipped generic-CPU entries,
``hydropwa/_prebuilt/``), then again with that cache filled. ``--no-shipped`` ignores the shipped
entries (``HYDROPWA_PREBUILT=0``: everything compiles, as on a machine they do not fit).
Prints a Markdown table for the README:

    python benchmarks/cold_start.py              # all cases (a few minutes on 2 cores)
    python benchmarks/cold_start.py --no-paper   # without the main job
    python benchmarks/cold_start.py --no-shipped # the compile path
    python benchmarks/cold_start.py --wheel      # also from a wheel of this checkout

Cases: ``import hydropwa`` (best of 5), ``hydropwa simulate --params paper --duration 1`` (the full model),
the README's Python example (extracted from README.md), and the main job ``hydropwa paper``;
then the first ``simulate`` call of the full model inside a process (the call, and the process
from its start with the imports): in a first process (empty cache), a second one (best of 3),
and from a copy of the package in a new folder with its own empty cache (a second install of
the same version).
Timings on a shared machine vary by tens of per cent; the script reports, it does not assert.
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TARGETS = {"first simulate": 3.0, "README example": 25.0, "main job (paper)": 45.0}
#: Extra environment of every timed command (``--no-shipped`` adds ``HYDROPWA_PREBUILT=0``).
EXTRA_ENV: dict[str, str] = {}


def _bin(name: str) -> str:
    return str(Path(sys.executable).with_name(name))


def readme_python() -> str:
    """The README's first ```python block."""
    text = (ROOT / "README.md").read_text()
    return re.search(r"```python\n(.*?)```", text, re.S).group(1)


def _cpu() -> float:
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def _env(**extra: str) -> dict[str, str]:
    """This process's environment for a timed child, as a user's shell has it: without
    ``PYTHONDONTWRITEBYTECODE`` (set on some CI and sandbox machines, it makes every process
    compile the sources of every module it imports, ~1.5 CPU-s a command here; a user's
    install writes the bytecode once), with ``extra`` added."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    return {**env, **extra}


def timed(cmd: list[str], cwd: Path, cache: Path) -> tuple[float, float]:
    """(wall, CPU) seconds of ``cmd`` and its child processes.

    CPU time is what the command costs on an idle machine with one core per busy process; on
    a shared machine the wall time grows with the load, the CPU time much less.
    """
    env = _env(NUMBA_CACHE_DIR=str(cache), MPLBACKEND="Agg", **EXTRA_ENV)
    c0, t0 = _cpu(), time.perf_counter()
    proc = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True)
    wall, cpu = time.perf_counter() - t0, _cpu() - c0
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
    return wall, cpu


def import_time() -> float:
    code = "import time; t = time.perf_counter(); import hydropwa; print(time.perf_counter() - t)"
    runs = [
        float(subprocess.check_output([sys.executable, "-c", code], text=True, env=_env()))
        for _ in range(5)
    ]
    return min(runs)


#: The first ``simulate`` of the full model inside a process (1 s of the paper rig's sine), timed
#: in that process: the call alone, and the process's CPU from its start to the call's end
SIMULATE_CALL = """
import resource, time
t0 = time.perf_counter()
from hydropwa.params import get_preset
from hydropwa.simulation import simulate
p = get_preset("paper")
t1 = time.perf_counter()
simulate("full", "sine:amplitude=0.4,frequency=1", params=p, duration=1.0)
t2 = time.perf_counter()
ru = resource.getrusage(resource.RUSAGE_SELF)
print(t2 - t1, t2 - t0, ru.ru_utime + ru.ru_stime)
"""


def simulate_call(cache: Path, pythonpath: Path | None = None) -> tuple[float, float, float]:
    """(the call [s], import + call [s], process CPU [s]) of :data:`SIMULATE_CALL` in a fresh
    process with the numba cache ``cache``; ``pythonpath``: import hydropwa from there."""
    extra = {"NUMBA_CACHE_DIR": str(cache), **EXTRA_ENV}
    if pythonpath is not None:
        extra["PYTHONPATH"] = str(pythonpath)
    out = subprocess.check_output(
        [sys.executable, "-c", SIMULATE_CALL], text=True, env=_env(**extra), cwd=cache.parent
    )
    call, total, cpu = (float(v) for v in out.split())
    return call, total, cpu


def process_rows(tmp: Path, wheel: bool = False) -> list[str]:
    """The simulate call in a first, a second process and in a copy of the package in a new
    folder (a second install of the same version: its numba cache is empty); ``wheel``: also
    from a wheel of this checkout installed into a folder of its own (``pip wheel``)."""
    import shutil

    import hydropwa

    cache = tmp / "cache-calls"
    first = simulate_call(cache)
    second = min(simulate_call(cache) for _ in range(3))
    new = tmp / "new-install"
    shutil.copytree(
        Path(hydropwa.__file__).parent,
        new / "hydropwa",
        ignore=shutil.ignore_patterns("__pycache__"),
    )
    moved = simulate_call(tmp / "cache-new-install", pythonpath=new)
    targets = {"first process": 3.0, "second process": 0.5, "install in a new folder": 3.0}
    runs = [first, second, moved]
    if wheel:  # a wheel built from this checkout, installed into a folder of its own
        dist, site = tmp / "dist", tmp / "wheel-install"
        pip = [sys.executable, "-m", "pip", "-q"]
        subprocess.run([*pip, "wheel", "--no-deps", "-w", str(dist), str(ROOT)], check=True)
        whl = next(dist.glob("hydropwa-*.whl"))
        subprocess.run([*pip, "install", "--no-deps", "--target", str(site), str(whl)], check=True)
        targets["installed from a wheel"] = 3.0
        runs.append(simulate_call(tmp / "cache-wheel", pythonpath=site))
    rows = []
    for name, (call, total, cpu) in zip(targets, runs, strict=True):
        lim = targets[name]
        marks = [("met" if v <= lim else "missed") for v in (call, total)]
        rows.append(
            f"| `simulate` (full model), {name} | call {call:.2f} s, with imports "
            f"{total:.2f} s ({cpu:.2f} s CPU) | | ≤ {lim:g} s (call {marks[0]}, "
            f"with imports {marks[1]}) |"
        )
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-paper", action="store_true", help="skip the main job (the longest case)")
    ap.add_argument(
        "--no-shipped", action="store_true", help="ignore the shipped entries: everything compiles"
    )
    ap.add_argument(
        "--wheel", action="store_true", help="also time a wheel of this checkout (builds one)"
    )
    args = ap.parse_args()
    if args.no_shipped:
        EXTRA_ENV["HYDROPWA_PREBUILT"] = "0"
    cases = {
        "first simulate": lambda d: [
            _bin("hydropwa"),
            "simulate",
            "--params",
            "paper",
            "--duration",
            "1",
            "--out",
            str(d / "run.csv"),
        ],
        "README example": lambda d: [sys.executable, str(d / "example.py")],
    }
    if not args.no_paper:
        cases["main job (paper)"] = lambda d: [
            _bin("hydropwa"),
            "paper",
            "--out",
            str(d / "report"),
        ]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name, make in cases.items():
            cache = tmp / f"cache-{len(rows)}"
            times = []
            for attempt in ("cold", "warm"):
                work = tmp / f"{len(rows)}-{attempt}"
                work.mkdir()
                (work / "example.py").write_text(readme_python())
                times.append(timed(make(work), work, cache))
            rows.append((name, *times))
            print(
                f"{name}: cold {times[0][0]:.1f} s wall / {times[0][1]:.1f} s CPU, "
                f"warm {times[1][0]:.1f} s / {times[1][1]:.1f} s",
                file=sys.stderr,
                flush=True,
            )
    with tempfile.TemporaryDirectory() as tmp:
        calls = process_rows(Path(tmp), wheel=args.wheel)
    imp = import_time()
    load = os.getloadavg()[0]
    print(f"Load average during the run: {load:.1f} on {os.cpu_count()} cores.\n")
    print("| case | cold: wall (CPU) | warm: wall (CPU) | target (cold wall) |")
    print("| --- | --- | --- | --- |")
    for name, (cold, cold_cpu), (warm, warm_cpu) in rows:
        target = TARGETS[name]
        mark = "met" if cold <= target else "missed"
        print(
            f"| {name} | {cold:.1f} s ({cold_cpu:.1f} s) | {warm:.1f} s ({warm_cpu:.1f} s) | "
            f"≤ {target:g} s ({mark}, {cold / target:.2f}×) |"
        )
    print(f"| `import hydropwa` | {imp:.2f} s | | ≤ 0.5 s ({'met' if imp <= 0.5 else 'missed'}) |")
    for row in calls:
        print(row)


if __name__ == "__main__":
    main()
