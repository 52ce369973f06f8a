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
import time

import numba

from .. import _jitcache

__all__ = ["build"]


def _compile_all() -> None:
    """Compile every warm-up kernel in this process (the child of :func:`build`)."""
    from . import _kernel as K

    kept: set[str] = set()
    cpu: dict[str, float] = {}  # CPU time of each entry's compile [s]
    for name in K.WARMUP_NAMES:
        for dispatcher, args, what in K.warmup_calls(name):
            t0 = time.process_time()
            K.prepare(dispatcher, args, what)
            base = dispatcher._cache._impl.filename_base
            cpu[base] = round(cpu.get(base, 0.0) + time.process_time() - t0, 1)
            kept.add(base)
            print(f"  {name}: {dispatcher.__name__}", flush=True)
    # only the entries Python calls: each holds the machine code of everything it calls, so the
    # callees' own entries (``_march``, the physics) would only serve a new caller's compile
    for f in _jitcache.PREBUILT_DIR.rglob("*"):
        base = f.name.removesuffix(".nbi") if f.suffix == ".nbi" else f.name.rsplit(".", 2)[0]
        if f.is_file() and base not in kept:
            f.unlink()
    manifest = {
        "source_stamp": _jitcache.source_stamp().hex(),
        "numba": numba.__version__,
        "python": platform.python_version(),
        "machine": platform.machine(),
        "cpu": "generic",
        "entries": sorted(kept),
        "compile_cpu_seconds": dict(sorted(cpu.items())),
    }
    (_jitcache.PREBUILT_DIR / "BUILD.json").write_text(json.dumps(manifest, indent=1) + "\n")


def build() -> int:
    """Rebuild :data:`hydropwa._jitcache.PREBUILT_DIR` from the current sources; the exit code."""
    shutil.rmtree(_jitcache.PREBUILT_DIR, ignore_errors=True)
    env = dict(os.environ)
    env.update(
        NUMBA_CPU_NAME="generic",
        NUMBA_CPU_FEATURES="",
        HYDROPWA_WARMUP="0",
        HYDROPWA_COMPILE_NOTICE="0",
        **{_jitcache.ENV_PREBUILD: "1"},
    )
    code = "from hydropwa.simulation._prebuild import _compile_all; _compile_all()"
    rc = subprocess.call([sys.executable, "-c", code], env=env)
    for leftover in _jitcache.PREBUILT_DIR.rglob("*.lock"):
        leftover.unlink()
    return rc


if __name__ == "__main__":
    sys.exit(build())
