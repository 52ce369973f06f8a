"""Progress of the long single steps of a command (identification, PWA fitting) on stderr.

On a terminal a spinner with the step's name runs while it works; every finished step is
reported as one line ``<step>: <seconds> s``, so logs show where the time went. Commands made
of many small tasks (rig campaigns, sweeps, the paper study) use progress bars instead.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["fit_progress", "step"]


@contextmanager
def step(message: str) -> Iterator[None]:
    """Show ``message`` with a spinner while the block runs; print its time when it is done."""
    from rich.console import Console  # deferred: loaded only when this command runs (a fast --help)

    console = Console(stderr=True)
    t0 = time.perf_counter()
    if console.is_terminal:
        with console.status(f"{message} …"):
            yield
        console.print(f"{message}: {time.perf_counter() - t0:.1f} s", highlight=False)
    else:  # logs get the time on stdout; stderr stays for the one `error:` line of a failure
        yield
        print(f"{message}: {time.perf_counter() - t0:.1f} s", flush=True)


@contextmanager
def fit_progress(message: str, quiet: bool = False) -> Iterator[Any]:
    """A progress callback for the grey-box fit's stages and starts (``FitProgress`` events).

    On a terminal a spinner shows the running stage; every finished stage is one line on
    stderr (``[elapsed] start k/n stage: cost … (evaluations)``), also in logs, so a long
    campaign fit shows where it is and where the time went. ``quiet``: no output.
    """
    from rich.console import Console  # deferred: loaded only when this command runs (a fast --help)

    console = Console(stderr=True)
    if quiet:
        yield None
        return
    if not console.is_terminal:

        def to_log(ev: Any) -> None:
            if ev.event == "end":
                print(f"{message}: {ev}", file=sys.stderr, flush=True)

        yield to_log
        return
    with console.status(f"{message} …") as status:

        def show(ev: Any) -> None:
            if ev.event == "begin":
                status.update(f"{message}: {ev}")
            else:
                console.print(f"{message}: {ev}", highlight=False)

        yield show
