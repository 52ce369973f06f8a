"""The compiled entries the package ships (``hydropwa/_prebuilt/``) are current and are loaded.

A fresh installation loads its solvers from these generic-CPU entries instead of compiling them
(``hydropwa._jitcache``). Checked by numba's own cache counters in fresh processes on a copy of the
package in a new folder (a relocated install), never by timing; and the entries must have been
built from the current sources (rebuild with ``python -m hydropwa.simulation._prebuild``).
"""

from __future__ import annotations

import json
import platform
import shutil
import subprocess
import sys
from pathlib import Path

import numba
import pytest

import hydropwa
from hydropwa import _jitcache
from hydropwa.simulation import _kernel as K

PKG = Path(hydropwa.__file__).parent
BUILD = _jitcache.PREBUILT_DIR / "BUILD.json"
REBUILD = "stale: run `python -m hydropwa.simulation._prebuild` and commit hydropwa/_prebuilt/"

PROBE = """
import json
from hydropwa import FullOrderModel, get_preset, simulate
from hydropwa.simulation import _kernel as K
simulate(FullOrderModel(get_preset("paper")), "sine:amplitude=0.4,frequency=1", duration=0.2)
stats = [K._integrate_full.stats, K._outputs_full.stats]
print(json.dumps({"hits": sum(sum(s.cache_hits.values()) for s in stats),
                  "misses": sum(sum(s.cache_misses.values()) for s in stats)}))
"""

#: Whether the full model's solver loads from a cache (without compiling it when it does not).
PROBE_LOAD = """
import json
from hydropwa.simulation import _kernel as K
d, args, _ = K.warmup_calls("full")[0]
sig = tuple(d.typeof_pyval(a) for a in args)
print(json.dumps({"loaded": d._cache.load_overload(sig, d.targetctx) is not None}))
"""


def _built() -> dict:
    assert BUILD.is_file(), f"{BUILD} is missing: {REBUILD}"
    return json.loads(BUILD.read_text())


def _warmup_entries() -> set[str]:
    return {d._cache._impl.filename_base for n in K.WARMUP_NAMES for d, _a, _w in K.warmup_calls(n)}


def test_shipped_entries_are_built_from_the_current_sources():
    built = _built()
    assert built["source_stamp"] == _jitcache.source_stamp().hex(), REBUILD
    assert set(built["warmup_entries"]) == _warmup_entries(), REBUILD
    assert set(built["warmup_entries"]) <= set(built["entries"])
    for base in built["entries"]:
        assert list(_jitcache.PREBUILT_DIR.rglob(f"{base}.nbi")), base
        assert list(_jitcache.PREBUILT_DIR.rglob(f"{base}.*.nbc")), base


def _matches_this_python() -> bool:
    if not BUILD.is_file():  # reported by the first test, not at collection
        return False
    b = _built()
    return (b["numba"], b["python"].rsplit(".", 1)[0], b["machine"]) == (
        numba.__version__,
        platform.python_version().rsplit(".", 1)[0],
        platform.machine(),
    )


needs_match = pytest.mark.skipif(
    not (_jitcache.INSTALLED and _matches_this_python()),
    reason="the shipped entries are for another numba, Python or CPU architecture (they compile)",
)


@needs_match
def test_every_warmup_kernel_has_a_current_shipped_entry():
    for name in K.WARMUP_NAMES:
        for dispatcher, _args, _what in K.warmup_calls(name):
            assert _jitcache.holds_prebuilt(dispatcher._cache), (name, REBUILD)


@needs_match
def test_a_relocated_install_loads_the_shipped_entries_and_an_edit_compiles(tmp_path):
    root = tmp_path / "site"
    shutil.copytree(PKG, root / "hydropwa", ignore=shutil.ignore_patterns("__pycache__"))

    def probe(code: str = PROBE) -> dict:
        env = {"PYTHONPATH": str(root), "PATH": "/usr/bin:/bin", "HYDROPWA_WARMUP": "0"}
        out = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=900
        )
        assert out.returncode == 0, out.stderr
        return json.loads(out.stdout.strip().splitlines()[-1])

    # a new folder, an empty in-tree cache: the solver and its output pass load, nothing compiles
    assert probe() == {"hits": 2, "misses": 0}
    physics = root / "hydropwa" / "components" / "_physics.py"
    physics.write_text(physics.read_text() + "\n# a physics edit\n")
    # the shipped entries' stamp no longer matches: not loaded (so compiled), never reused
    assert probe(PROBE_LOAD) == {"loaded": False}
