"""One way to open a Dask client: a local cluster or a scheduler's address, closed on exit.

Used by every layer that offers ``--scheduler`` (sweeps, controller verification), so the
cluster's settings, the connection error and the clean-up are written once.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator
from typing import Any


@contextlib.contextmanager
def dask_client(
    scheduler: str,
    jobs: int | None,
    *,
    timeout_s: float,
    error: Callable[[str], Exception],
    option: str,
    hint: str,
) -> Iterator[Any]:
    """A ``dask.distributed.Client`` on ``scheduler`` (``"local"``: a LocalCluster), closed after.

    Parameters
    ----------
    scheduler : str
        ``"local"`` for a cluster of ``jobs`` single-threaded worker processes on this machine
        (all cores when ``jobs`` is None), otherwise the scheduler's address.
    jobs : int or None
        Number of local workers.
    timeout_s : float
        Connection time-out [s] for an address.
    error : callable
        The error class of the calling layer; raised with one line when no client can be had.
    option, hint : str
        How the caller names the scheduler in that line (``"--scheduler"``) and what to do
        instead (``"run in-process without --scheduler"``).
    """
    from dask.distributed import (  # deferred: dask.distributed costs ~1 s, only for a cluster
        Client,
        LocalCluster,
    )

    cluster = None
    try:
        if scheduler == "local":
            cluster = LocalCluster(
                n_workers=jobs or os.cpu_count() or 1,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
            )
            client = Client(cluster)
        else:
            client = Client(scheduler, timeout=f"{timeout_s:g}s")
    except (OSError, TimeoutError, ValueError) as exc:
        if cluster is not None:
            cluster.close()
        raise error(
            f"{option} {scheduler!r}: cannot connect ({type(exc).__name__}: {exc}); check the "
            f"address, or {hint}"
        ) from None
    try:
        yield client
    finally:
        with contextlib.suppress(Exception):
            client.close()
        if cluster is not None:
            with contextlib.suppress(Exception):
                cluster.close()
