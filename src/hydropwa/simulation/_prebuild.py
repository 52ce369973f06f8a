"""Build the compiled entries the package ships: ``python -m hydropwa.simulation._prebuild``.

A fresh installation would otherwise compile each solver on first use (tens of CPU-seconds for
the full model). This command compiles every kernel a session loads (:data:`~._kernel.WARMUP_NAMES`:
each model's open- and closed-loop solver with the default method, its output pass, the
linearization's point derivatives) in a child process with ``NUMBA_CPU_NAME=generic``, so the
machine code runs on any x86-64 CPU, and writes numba's cache entries to
``hydropwa/_prebuilt/`` (see :mod:`hydropwa._jitcache`). Run it after a change to a compiled
module (``tests/performance/test_prebuilt.py`` says when the shipped entries are stale) and
commit the folder. It takes a few minutes of one core.
"""

from __future__ import annotations

import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time

import numba

from .. import _jitcache

__all__ = ["build"]


#: Modules whose functions Python calls directly (physics on arrays, signal evaluation): their
#: entries are kept; of the others only the warm-up kernels' entries are (see :func:`_prune`).
CALLED_FROM_PYTHON = ("_physics", "_signals")


def _compile_all() -> None:
    """Compile every warm-up kernel in this process (the child of :func:`build`)."""
    from . import _kernel as K  # deferred: only the build's child compiles

    cpu: dict[str, float] = {}  # CPU time of each entry's compile [s]
    for name in K.WARMUP_NAMES:
        for dispatcher, args, what in K.warmup_calls(name):
            t0 = time.process_time()
            K.prepare(dispatcher, args, what)
            base = dispatcher._cache._impl.filename_base
            cpu[base] = round(cpu.get(base, 0.0) + time.process_time() - t0, 1)
            print(f"  {name}: {dispatcher.__name__}", flush=True)
    manifest = {
        "source_stamp": _jitcache.source_stamp().hex(),
        "numba": numba.__version__,
        "python": platform.python_version(),
        "machine": platform.machine(),
        "cpu": "generic",
        "warmup_entries": sorted(cpu),
        "compile_cpu_seconds": dict(sorted(cpu.items())),
    }
    (_jitcache.PREBUILT_DIR / "BUILD.json").write_text(json.dumps(manifest, indent=1) + "\n")


def _base(f) -> str:
    """The numba cache file's function name base (``_march._march-134.py311``)."""
    return f.name.removesuffix(".nbi") if f.suffix == ".nbi" else f.name.rsplit(".", 2)[0]


def _prune() -> list[str]:
    """Keep the entries Python calls; the others' machine code is inside the entries that call them.

    Each entry holds the linked machine code of everything it calls, so a callee's own entry
    (``_march``, ``_rosenbrock``, the right-hand sides) would serve only a new caller's compile.
    Returns the kept entries' names.
    """
    build = json.loads((_jitcache.PREBUILT_DIR / "BUILD.json").read_text())
    keep = set(build["warmup_entries"])
    kept = set()
    for f in sorted(_jitcache.PREBUILT_DIR.rglob("*")):
        if not f.is_file() or f.name == "BUILD.json":
            continue
        base = _base(f)
        if base in keep or base.split(".", 1)[0] in CALLED_FROM_PYTHON:
            kept.add(base)
        else:
            f.unlink()
    build["entries"] = sorted(kept)
    (_jitcache.PREBUILT_DIR / "BUILD.json").write_text(json.dumps(build, indent=1) + "\n")
    return build["entries"]


def build() -> int:
    """Rebuild :data:`hydropwa._jitcache.PREBUILT_DIR` from the current sources; the exit code.

    Two child processes with the generic CPU: the warm-up kernels (:func:`_compile_all`), then the
    main job (``hydropwa paper``), whose physics and signal calls from Python compile the
    signatures a study uses.
    """
    shutil.rmtree(_jitcache.PREBUILT_DIR, ignore_errors=True)
    env = dict(os.environ)
    env.update(
        NUMBA_CPU_NAME="generic",
        NUMBA_CPU_FEATURES="",
        HYDROPWA_WARMUP="0",
        HYDROPWA_COMPILE_NOTICE="0",
        MPLBACKEND="Agg",
        **{_jitcache.ENV_PREBUILD: "1"},
    )
    code = "from hydropwa.simulation._prebuild import _compile_all; _compile_all()"
    rc = subprocess.call([sys.executable, "-c", code], env=env)
    if rc == 0:
        with tempfile.TemporaryDirectory() as tmp:
            job = [sys.executable, "-m", "hydropwa", "paper", "--out", os.path.join(tmp, "r")]
            rc = subprocess.call(job, env=env, cwd=tmp, stdout=subprocess.DEVNULL)
    for leftover in _jitcache.PREBUILT_DIR.rglob("*.lock"):
        leftover.unlink()
    if rc == 0:
        print(f"{len(_prune())} entries in {_jitcache.PREBUILT_DIR}")
    return rc


if __name__ == "__main__":
    sys.exit(build())
