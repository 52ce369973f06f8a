"""The compile notice is on by default in Python too (issue 37), silenced in one documented way,
and silent in worker processes."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest


def _python(code: str, **env: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, **env},
    )


_COLD = """
    from numba import njit

    import hydropwa  # the package installs the default notice
    from hydropwa.simulation import _kernel as K

    K._cached_on_disk = lambda d: False  # a fresh installation
    K.NOTICE_AFTER_S = 0.0

    @njit
    def double(x):
        return 2.0 * x

    K.prepare(double, (1.0,), "test")
    K.prepare(double, (1.0,), "test")  # ready: no second line
    print("done")
"""


def test_python_says_it_compiles_by_default():
    done = _python(_COLD)
    assert done.returncode == 0, done.stderr
    lines = [ln for ln in done.stderr.splitlines() if ln.startswith("hydropwa:")]
    assert len(lines) == 2, done.stderr
    assert lines[0].startswith("hydropwa: compiling the test solver (") and "once" in lines[0]
    assert lines[1].startswith("hydropwa: test solver ready (")
    assert done.stdout.strip() == "done"  # stdout (a notebook's results) stays clean


@pytest.mark.parametrize("how", ["env", "call"])
def test_the_notice_is_silenced_in_one_line(how):
    code = (
        _COLD
        if how == "env"
        else _COLD.replace(
            "import hydropwa  # the package installs the default notice",
            "import hydropwa\n    hydropwa.simulation.set_compile_notice(None)",
        )
    )
    done = _python(code, **({"HYDROPWA_COMPILE_NOTICE": "0"} if how == "env" else {}))
    assert done.returncode == 0, done.stderr
    assert "hydropwa:" not in done.stderr


def test_worker_processes_stay_silent(capfd):
    """A pool worker compiling on its own does not print: its parent speaks for it."""
    import multiprocessing

    from hydropwa.simulation import default_compile_notice

    ctx = multiprocessing.get_context("spawn")
    proc = ctx.Process(target=default_compile_notice, args=("compiling the x solver",))
    proc.start()
    proc.join(60)
    assert proc.exitcode == 0
    default_compile_notice("compiling the y solver")
    err = capfd.readouterr().err
    assert "hydropwa: compiling the y solver" in err and "x solver" not in err
