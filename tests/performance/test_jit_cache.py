"""Compiled kernels are cached on disk, and a change to any compiled module recompiles all.

numba stamps a cache entry with its own source file only; the kernels inline the physics
of another file. ``hydropwa._jitcache`` stamps every entry with one hash over all
compiled modules. Checked here through numba's own cache counters in fresh processes on a
copy of the package, not by timing.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import hydropwa
from hydropwa import _jitcache
from hydropwa.components import _physics
from hydropwa.simulation import _kernel, _signals

PKG = Path(hydropwa.__file__).parent

PROBE = """
import json
from hydropwa import ReducedModel, get_preset, simulate
from hydropwa.simulation import _kernel as K
simulate(ReducedModel(get_preset("paper")), "sine:amplitude=0.4,frequency=1", duration=0.2)
s = K._integrate_reduced.stats
print(json.dumps({"hits": sum(s.cache_hits.values()), "misses": sum(s.cache_misses.values())}))
"""


@pytest.mark.skipif(not _jitcache.INSTALLED, reason="this numba's caching internals differ")
def test_every_cached_kernel_uses_the_package_stamp():
    for fn in (
        _physics.stribeck_friction,
        _signals.eval_signal,
        _kernel._integrate_full,
        _kernel._outputs_full,
    ):
        assert isinstance(fn._cache._impl.locator, _jitcache.PackageCacheLocator), fn
        assert fn._cache._impl.locator.get_source_stamp() == _jitcache.source_stamp()


def test_stamp_changes_with_any_compiled_module(tmp_path):
    for m in _jitcache.STAMPED_MODULES:
        (tmp_path / m).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(PKG / m, tmp_path / m)
    base = _jitcache.source_stamp(tmp_path)
    assert base == _jitcache.source_stamp(PKG)
    for m in _jitcache.STAMPED_MODULES:
        text = (tmp_path / m).read_text()
        (tmp_path / m).write_text(text + "\n# edited\n")
        assert _jitcache.source_stamp(tmp_path) != base, m
        (tmp_path / m).write_text(text)
    assert _jitcache.source_stamp(tmp_path) == base


@pytest.mark.skipif(not _jitcache.INSTALLED, reason="this numba's caching internals differ")
def test_second_process_loads_the_cache_and_a_physics_edit_recompiles(tmp_path):
    root = tmp_path / "site"
    # without the shipped entries (tests/performance/test_prebuilt.py loads those)
    ignore = shutil.ignore_patterns("__pycache__", "_prebuilt")
    shutil.copytree(PKG, root / "hydropwa", ignore=ignore)

    def probe() -> dict:
        env = {"PYTHONPATH": str(root), "PATH": "/usr/bin:/bin", "NUMBA_CACHE_DIR": ""}
        out = subprocess.run(
            [sys.executable, "-c", PROBE], capture_output=True, text=True, env=env, timeout=600
        )
        assert out.returncode == 0, out.stderr
        return json.loads(out.stdout.strip().splitlines()[-1])

    first = probe()
    assert first["misses"] >= 1 and first["hits"] == 0  # empty cache: compiled
    second = probe()
    assert second == {"hits": 1, "misses": 0}  # a second process pays no compile time
    physics = root / "hydropwa" / "components" / "_physics.py"
    physics.write_text(physics.read_text() + "\n# a physics edit\n")  # _kernel.py untouched
    third = probe()
    assert third["misses"] >= 1 and third["hits"] == 0  # the kernel is rebuilt, not reused


@pytest.mark.skipif(not _jitcache.SAVES_LOCKED, reason="no inter-process lock for numba's cache")
def test_concurrent_cache_saves_keep_each_overload_with_its_own_code(tmp_path, monkeypatch):
    """Two compilers saving different overloads of one function at once (the warm-up's case).

    Unlocked, numba reads the index, picks the first free data file and writes index and data:
    both saves pick ``.1``, the index keeps the second key and the data file the first save's
    code, so loading the second overload returns the first one's machine code. The delays force
    that interleaving; with the lock the second save waits and takes ``.2``.
    """
    import threading
    import time

    from numba.core.caching import IndexDataCacheFile

    real_index, real_data = IndexDataCacheFile._save_index, IndexDataCacheFile._save_data

    def slow_index(self, overloads):
        time.sleep(0.2)
        real_index(self, overloads)

    def slow_data(self, name, data):
        time.sleep(0.6 if data == "code of X" else 0.0)
        real_data(self, name, data)

    monkeypatch.setattr(IndexDataCacheFile, "_save_index", slow_index)
    monkeypatch.setattr(IndexDataCacheFile, "_save_data", slow_data)
    cache = [IndexDataCacheFile(str(tmp_path), "f-1.py311", b"stamp") for _ in range(2)]
    first = threading.Thread(target=cache[0].save, args=("X", "code of X"))
    second = threading.Thread(target=cache[1].save, args=("Y", "code of Y"))
    first.start()
    time.sleep(0.05)  # the second save starts while the first writes its index
    second.start()
    first.join()
    second.join()
    reader = IndexDataCacheFile(str(tmp_path), "f-1.py311", b"stamp")
    assert reader.load("X") == "code of X"
    assert reader.load("Y") == "code of Y"
