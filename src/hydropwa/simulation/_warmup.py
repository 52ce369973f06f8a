"""Compile the solvers a session will need in a background process, while it works.

numba compiles on one core, and a fresh installation compiles one solver per model
(~5-10 s each, then cached on disk). :func:`warm_up` starts one process that compiles the
named kernels into numba's disk cache; a kernel this process then needs is loaded from
there, and if it is still being compiled, :func:`~._kernel.prepare` waits for it instead of
compiling it a second time. On two cores the work and the compilation overlap.

Started automatically (once per process) when a kernel missing from the disk cache is first
compiled: the other open-loop models and the linearization then compile beside it. Set the
environment variable ``HYDROPWA_WARMUP=0`` to turn that off (the command line does, except
for the commands that use several models). The process ends with its parent.
"""

from __future__ import annotations

import atexit
import os
import subprocess
import sys
import threading
from collections.abc import Iterable

from . import _kernel as K

__all__ = ["WarmUp", "warm_up"]

#: Environment variable: ``0`` turns the automatic warm-up off.
ENV = "HYDROPWA_WARMUP"
#: What the automatic warm-up compiles: the open-loop models and the linearization.
AUTO = ("full", "reduced", "point", "pwa")

_auto_started = False


class WarmUp:
    """A background process compiling kernels into numba's disk cache.

    Created by :func:`warm_up`. The process prints one line per kernel it has cached;
    a reader thread releases whoever waits on that kernel in :func:`~._kernel.prepare`.
    """

    def __init__(self, names: Iterable[str]):
        calls = {n: K.warmup_calls(n) for n in names}  # checks the names first
        # only what is not on disk yet (loading costs the process more than it saves)
        self.names = tuple(
            n
            for n, entries in calls.items()
            if not all(K._cached_on_disk(d) for d, _, _ in entries)
        )
        self._events: dict[str, threading.Event] = {}
        self.cached: list[str] = []
        self._proc: subprocess.Popen | None = None
        if not self.names:
            return
        for name in self.names:
            for i, (dispatcher, _args, _what) in enumerate(calls[name]):
                if dispatcher in K._warming:  # another warm-up has it
                    continue
                ev = threading.Event()
                self._events[f"{name}/{i}"] = ev
                K._warming[dispatcher] = ev
        env = dict(os.environ, **{ENV: "0"})
        self._proc = subprocess.Popen(
            [sys.executable, "-m", "hydropwa.simulation._warmup", *self.names],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
            env=env,
        )
        self._reader = threading.Thread(target=self._read, name="hydropwa-warmup", daemon=True)
        self._reader.start()
        atexit.register(self.close)

    def _read(self) -> None:
        assert self._proc.stdout is not None
        for line in self._proc.stdout:
            key = line.strip()
            ev = self._events.get(key)
            if ev is not None:
                self.cached.append(key)
                ev.set()
        self._release()

    def _release(self) -> None:
        """Release every waiter (the process has ended: what it left undone compiles there)."""
        for ev in self._events.values():
            ev.set()
        for dispatcher, ev in list(K._warming.items()):
            if ev in self._events.values():
                K._warming.pop(dispatcher, None)

    @property
    def running(self) -> bool:
        """Whether the process is still compiling."""
        return self._proc is not None and self._proc.poll() is None

    def wait(self, timeout: float | None = None) -> bool:
        """Wait for the process to end; returns whether it has."""
        if self._proc is None:
            return True
        try:
            self._proc.wait(timeout)
        except subprocess.TimeoutExpired:
            return False
        self._reader.join(timeout)
        return True

    def close(self) -> None:
        """Stop the process (what it has cached stays cached)."""
        if self._proc is not None and self._proc.poll() is None:
            self._proc.terminate()
            try:
                self._proc.wait(5)
            except subprocess.TimeoutExpired:  # pragma: no cover
                self._proc.kill()
        self._release()

    def __enter__(self) -> WarmUp:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "running" if self.running else "done"
        names = ", ".join(self.names) or "nothing to compile"
        return f"WarmUp({names}; {state}, {len(self.cached)} kernels cached)"


def warm_up(
    models: Iterable[str] = ("full", "reduced", "pwa"),
    *,
    closed_loop: bool = False,
    linearization: bool = True,
    wait: bool = False,
) -> WarmUp:
    """Compile the solvers of ``models`` in a background process (numba's disk cache).

    Parameters
    ----------
    models : iterable of {"full", "reduced", "pwa"}
        Models whose open-loop solver (default method) and output pass to compile.
    closed_loop : bool
        Also their closed-loop solvers (:mod:`hydropwa.control`).
    linearization : bool
        Also the linearization's point derivatives (:func:`hydropwa.linearize`).
    wait : bool
        Return only once everything is compiled (e.g. to prepare an installation).

    Returns
    -------
    WarmUp
        The running warm-up; kernels it is compiling are waited for, not compiled twice.

    Examples
    --------
    >>> from hydropwa.simulation import warm_up
    >>> w = warm_up(["full", "pwa"], closed_loop=True)  # doctest: +SKIP
    """
    names = [str(m).lower() for m in models]
    bad = [m for m in names if m not in ("full", "reduced", "pwa")]
    if bad:
        raise ValueError(f"unknown model {bad[0]!r}; choose from full, reduced, pwa")
    names += ["point"] if linearization else []
    names += (
        [f"closed-{m}" for m in names if m in ("full", "reduced", "pwa")] if closed_loop else []
    )
    w = WarmUp(names)
    if wait:
        w.wait()
    return w


def _auto(dispatcher) -> None:
    """:data:`~._kernel._cold_hook`: warm up the other models beside the first cold compile."""
    global _auto_started
    if _auto_started or os.environ.get(ENV, "1").strip().lower() in ("0", "off", "false", "no"):
        return
    _auto_started = True
    others = [n for n in AUTO if all(d is not dispatcher for d, _, _ in K.warmup_calls(n))]
    if others:
        WarmUp(others)


def set_auto_warmup(on: bool) -> None:
    """Turn the automatic warm-up on or off for this process (the CLI turns it off)."""
    global _auto_started
    _auto_started = not on


K._cold_hook = _auto


def main(argv: list[str]) -> int:
    """Compile the named kernels (see :func:`~._kernel.warmup_calls`), one line each when cached."""
    try:
        os.nice(5)  # the parent's own work goes first where the cores are shared
    except (AttributeError, OSError):  # pragma: no cover
        pass
    for name in argv:
        for i, (dispatcher, args, what) in enumerate(K.warmup_calls(name)):
            K.prepare(dispatcher, args, what)
            print(f"{name}/{i}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
