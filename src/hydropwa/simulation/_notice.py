"""The default compile notice: a line on stderr while a solver compiles, in Python as on the CLI.

A fresh installation compiles each model's solver the first time it is used (~5–10 s each,
then cached on disk). Without a word a first ``simulate`` looks hung, so the library says so
by default: once per process before the first compilation ("compiling the … solver …"), then
one line for each solver that took over 2 s ("… solver ready (8.1 s)"); a warm cache prints
nothing. In Jupyter the lines go to the cell's stderr area; there are at most one per model
kernel and session, never one per call.

Silence it with ``hydropwa.simulation.set_compile_notice(None)`` or the environment variable
``HYDROPWA_COMPILE_NOTICE=0``; route it elsewhere with ``set_compile_notice(callback)``
(e.g. ``logging.getLogger("hydropwa").info``). Worker processes (a rig pool, a Dask worker,
the background warm-up) stay silent: their parent speaks for them.
"""

from __future__ import annotations

import multiprocessing
import os
import sys

from ._kernel import set_compile_notice

__all__ = ["ENV_NOTICE", "default_compile_notice", "install_default_notice"]

#: Environment variable: ``0`` silences the default compile notice.
ENV_NOTICE = "HYDROPWA_COMPILE_NOTICE"


def default_compile_notice(message: str) -> None:
    """Print ``message`` on stderr, unless silenced or in a worker process."""
    if os.environ.get(ENV_NOTICE, "1").strip().lower() in ("0", "off", "false", "no"):
        return
    if multiprocessing.parent_process() is not None:
        return
    stream = sys.stderr
    if stream is None:  # pythonw and some embedded interpreters have no stderr
        return
    print(f"hydropwa: {message.strip()}", file=stream, flush=True)


def install_default_notice() -> None:
    """Make :func:`default_compile_notice` the notice (done once, when the package loads)."""
    set_compile_notice(default_compile_notice)
