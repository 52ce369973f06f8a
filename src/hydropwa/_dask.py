"""One way to open a Dask client: a local cluster or a scheduler's address, closed on exit.

Used by every layer that offers ``--scheduler`` (sweeps, controller verification), so the
cluster's settings, the connection error and the clean-up are written once.
"""

from __future__ import annotations

import contextlib
import os
import socket
from collections.abc import Callable, Iterator
from typing import Any

from ._errors import HydropwaError

#: Address schemes a scheduler may be given with: plain TCP (``tcp://HOST:PORT`` or
#: ``HOST:PORT``); from Python also ``inproc://`` (a cluster in the same process). TLS, websockets and UCX need security or transport settings this package
#: does not take, so they are refused in one line rather than failing inside Dask.
SCHEMES = ("tcp",)


def parse_address(
    scheduler: str, error: Callable[[str], Exception], option: str
) -> tuple[str, int]:
    """``(host, port)`` of a scheduler address ``tcp://HOST:PORT`` or ``HOST:PORT``.

    Raises ``error`` with one line for another scheme, a missing host or a port outside
    1-65535.
    """
    text = scheduler.strip()
    scheme, sep, rest = text.partition("://")
    if not sep:
        scheme, rest = "tcp", text
    if scheme.lower() not in SCHEMES:
        raise error(
            f"{option} {scheduler!r}: the scheme {scheme}:// is not supported; give "
            "tcp://HOST:PORT (or HOST:PORT), or 'local' for a cluster on this machine"
        )
    host, _, port = rest.rstrip("/").rpartition(":")
    host = host.strip("[]")
    if not host or not port.isdigit() or not 1 <= int(port) <= 65535:
        raise error(
            f"{option} {scheduler!r} is not a Dask scheduler address (HOST:PORT, a port "
            "1-65535); give tcp://HOST:PORT (e.g. tcp://10.0.0.5:8786) or 'local'"
        )
    return host, int(port)


def probe_scheduler(host: str, port: int, timeout_s: float) -> str | None:
    """Why ``host:port`` is no Dask scheduler, or None: it must accept a connection and send
    its handshake (a Dask server speaks first) within ``timeout_s``; a silent listener would
    otherwise hang the client past its own time-out."""
    try:
        with socket.create_connection((host, port), timeout=timeout_s) as sock:
            sock.settimeout(timeout_s)
            if not sock.recv(1):
                return "the connection was closed without a Dask handshake"
    except TimeoutError:
        return f"no answer within {timeout_s:g} s"
    except OSError as exc:
        return exc.strerror or str(exc) or type(exc).__name__
    return None


def _connect(
    client_class: Any,
    scheduler: str,
    timeout_s: float,
    error: Callable[[str], Exception],
    option: str,
    hint: str,
) -> Any:
    """A client on an address: ``inproc://`` (a cluster of this process, from Python) as is,
    a TCP address once it answers (:func:`probe_scheduler`); in both, a worker within
    ``timeout_s``."""
    if scheduler.startswith("inproc://"):
        client = client_class(scheduler, timeout=f"{timeout_s:g}s")
    else:
        host, port = parse_address(scheduler, error, option)
        why = probe_scheduler(host, port, timeout_s)
        if why is not None:
            raise error(
                f"{option} {scheduler!r}: cannot connect ({why}); check the address, or {hint}"
            )
        client = client_class(f"tcp://{host}:{port}", timeout=f"{timeout_s:g}s")
    try:
        client.wait_for_workers(1, timeout=timeout_s)
    except (OSError, TimeoutError) as exc:
        with contextlib.suppress(Exception):
            client.close()
        raise error(
            f"{option} {scheduler!r}: the scheduler has no workers ({exc}); start workers for "
            f"it, or {hint}"
        ) from None
    return client


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
        Time-out [s] of each step with an address: the connection, the scheduler's handshake
        and its first worker. The address is ``tcp://HOST:PORT`` or ``HOST:PORT``
        (:func:`parse_address`); other schemes are refused in one line.
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
    quiet = _QuietLoggers()  # a lost scheduler is the caller's one line, not Dask's traceback
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
            client = _connect(Client, scheduler, timeout_s, error, option, hint)
    except HydropwaError:
        if cluster is not None:
            cluster.close()
        raise
    except (OSError, TimeoutError, ValueError, TypeError, MemoryError) as exc:
        if cluster is not None:
            cluster.close()
        raise error(
            f"{option} {scheduler!r}: cannot connect ({type(exc).__name__}: {exc}); check the "
            f"address, or {hint}"
        ) from None
    try:
        with quiet:
            yield client
    finally:
        with quiet, contextlib.suppress(Exception):
            client.close()
        if cluster is not None:
            with contextlib.suppress(Exception):
                cluster.close()


class _QuietLoggers:
    """Dask's client and comm loggers held at CRITICAL inside the block: where the scheduler
    goes away they log a traceback per retry, while the caller reports the loss in one line."""

    names = ("distributed.client", "distributed.comm", "distributed.utils", "distributed.core")

    def __enter__(self) -> None:
        import logging  # deferred: only with a cluster

        self._saved = {n: logging.getLogger(n).level for n in self.names}
        for n in self.names:
            logging.getLogger(n).setLevel(logging.CRITICAL)

    def __exit__(self, *exc: object) -> None:
        import logging  # deferred: as above

        for n, level in self._saved.items():
            logging.getLogger(n).setLevel(level)
