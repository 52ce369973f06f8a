"""The background warm-up compiles exactly what the public paths load, and nothing twice.

A fresh process with an empty numba cache starts a warm-up, then runs the public paths
(open-loop and closed-loop simulation, the output pass, linearization). numba's own cache
counters of each kernel show whether it was loaded from what the warm-up process wrote
(a hit) or compiled in the process itself (a miss): a miss would mean the warm-up compiled
a different signature, or that ``prepare`` did not wait for it.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numba
import pytest

from hydropwa import _jitcache
from hydropwa.simulation import WarmUp, warm_up

PROBE = """
import json, sys
import numpy as np
from hydropwa import ReducedModel, get_preset, simulate
from hydropwa.linearization import linearize
from hydropwa.control import PIController
from hydropwa.simulation import warm_up
from hydropwa.simulation import _kernel as K

w = warm_up(["reduced"], closed_loop=True, linearization=True, wait=sys.argv[1] == "wait")
params = get_preset("paper")
simulate(ReducedModel(params), "sine:amplitude=0.4,frequency=1", duration=0.2)
simulate(ReducedModel(params), controller=PIController(kp=20.0), reference=0.1, duration=0.2)
linearize(params).rhs(0.0, np.array([1e5, 0.0, 0.1]), 0.2)
# "overlap": the public paths may finish before the background process has cached the kernels
# they do not use (point/2); the queue's accounting is complete once it has ended
assert w.wait(900)
out = {"names": list(w.names), "cached": sorted(w.cached), "here": sorted(w.compiled_here)}
for name in ("_integrate_reduced", "_outputs_reduced", "_closed_reduced", "_point_pwa"):
    s = getattr(K, name).stats
    out[name] = [sum(s.cache_hits.values()), sum(s.cache_misses.values())]
print(json.dumps(out))
"""


def _probe(tmp_path, mode: str) -> dict:
    # the compile path (without the shipped entries, which would load everything)
    env = dict(
        os.environ,
        NUMBA_CACHE_DIR=str(tmp_path / "cache"),
        HYDROPWA_WARMUP="0",
        HYDROPWA_PREBUILT="0",
    )
    out = subprocess.run(
        [sys.executable, "-c", PROBE, mode], capture_output=True, text=True, env=env, timeout=900
    )
    assert out.returncode == 0, out.stderr[-3000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.slow
@pytest.mark.skipif(not _jitcache.INSTALLED, reason="this numba's caching internals differ")
@pytest.mark.parametrize("mode", ["wait", "overlap"])
def test_warm_up_compiles_what_the_public_paths_load(tmp_path, mode):
    # "wait": everything compiled before the first call; "overlap": the calls start at once
    # and wait for each kernel the background process has not cached yet
    res = _probe(tmp_path, mode)
    assert res["names"] == ["reduced", "point", "closed-reduced"]
    keys = ["closed-reduced/0", "point/0", "point/1", "point/2", "reduced/0", "reduced/1"]
    # every kernel of the queue was compiled exactly once: by the background process or here
    assert sorted(res["cached"] + res["here"]) == keys
    if mode == "wait":
        assert res["here"] == []
    kernels = {
        "_integrate_reduced": "reduced/0",
        "_outputs_reduced": "reduced/1",
        "_closed_reduced": "closed-reduced/0",
        "_point_pwa": "point/0",
    }
    for name, key in kernels.items():
        # loaded from the warm-up's cache (a hit), or compiled here once (a miss), never both
        assert res[name] == ([0, 1] if key in res["here"] else [1, 0]), (name, res)


def test_warm_up_rejects_unknown_models():
    with pytest.raises(ValueError, match="unknown model 'ful'"):
        warm_up(["ful"])


def test_nothing_to_compile_starts_no_process(monkeypatch):
    from hydropwa.simulation import _kernel as K
    from hydropwa.simulation import _warmup

    monkeypatch.setattr(K, "_cached_on_disk", lambda dispatcher: True)
    monkeypatch.setattr(_warmup, "_auto_started", False)
    w = WarmUp(["full", "point"])
    assert w.names == () and not w.running and w.wait(0)
    assert "nothing to compile" in repr(w)
    assert not _warmup._auto_started  # a later cold compile may still start the automatic one


def test_automatic_warm_up_starts_once_for_the_other_models(monkeypatch):
    from hydropwa.simulation import _kernel as K
    from hydropwa.simulation import _warmup

    started = []
    monkeypatch.setattr(_warmup, "WarmUp", lambda names: started.append(tuple(names)))
    monkeypatch.setattr(_warmup, "_auto_started", False)
    monkeypatch.setenv("HYDROPWA_WARMUP", "0")
    _warmup._auto(K._integrate_full)
    assert started == []  # turned off by the environment
    monkeypatch.setattr(_warmup, "_auto_started", False)
    monkeypatch.setenv("HYDROPWA_WARMUP", "1")
    _warmup._auto(K._integrate_full)  # the first cold compile: the full model's solver
    _warmup._auto(K._integrate_reduced)  # later ones start nothing more
    assert started == [("reduced", "point", "pwa")]


def test_output_pass_alone_can_be_warmed_up():
    """``output-<model>``: the output pass only, the call ``outputs`` makes (the CLI's
    ``simulate`` compiles it in the background while it compiles the solver itself)."""
    from hydropwa.simulation import _kernel as K

    for model, kind in (("full", K.FULL), ("reduced", K.REDUCED), ("pwa", K.PWA)):
        calls = K.warmup_calls(f"output-{model}")
        assert [c[0] for c in calls] == [K.OUTPUTS[kind]]
        own = K.warmup_calls(model)[1]  # the model's own output call: the same signature
        assert own[0] is calls[0][0]
        assert [numba.typeof(a) for a in own[1]] == [numba.typeof(a) for a in calls[0][1]]
    assert "output-full" in K.WARMUP_NAMES


def test_compile_notice_says_when_compiling_starts_and_each_solver_is_ready(monkeypatch):
    """The CLI's compile notice: one line before the first compilation, then one per kernel whose
    wait exceeded NOTICE_AFTER_S (here 0 s), so a cold run never sits silent (issue 37)."""
    from numba import njit

    from hydropwa.simulation import _kernel as K

    @njit
    def _double(x):
        return 2.0 * x

    lines: list[str] = []
    monkeypatch.setattr(K, "_cached_on_disk", lambda d: False)
    monkeypatch.setattr(K, "NOTICE_AFTER_S", 0.0)
    previous = K.set_compile_notice(lines.append)
    try:
        K.prepare(_double, (1.0,), "test")
        assert K.prepare(_double, (1.0,), "test") == 0.0  # ready: no second compilation
    finally:
        K.set_compile_notice(previous)
    assert len(lines) == 2, lines
    assert lines[0].startswith("compiling the test solver (") and "once" in lines[0]
    assert lines[1].startswith("  test solver ready (") and lines[1].endswith(" s)")
