"""Progress of the long single steps of a command (identification, PWA fitting) on stderr.

On a terminal a spinner with the step's name runs while it works; every finished step is
reported as one line ``<step>: <seconds> s``, so logs show where the time went. Commands made
of many small tasks (rig campaigns, sweeps, the paper study) use progress bars instead.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["step"]


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
