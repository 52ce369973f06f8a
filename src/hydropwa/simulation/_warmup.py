"""Compile the solvers a session will need in a background process, while it works.

numba compiles on one core, and a fresh installation compiles one solver per model
(~5-10 s each, then cached on disk). :func:`warm_up` starts one process that compiles the
named kernels into numba's disk cache; a kernel this process then needs is loaded from
there, and if it is still being compiled, :func:`~._kernel.prepare` waits for it instead of
compiling it a second time. On two cores the work and the compilation overlap.

Started automatically (once per process) when a kernel missing from the disk cache is first
compiled: the other open-loop models and the linearization then compile beside it. Set the
environment variable ``HYDROPWA_WARMUP=0`` to turn that off (the command line does, and
starts its own where it pays: ``simulate`` compiles the output pass beside the solver, the
commands that use several models their models; worker processes of a pool or a Dask cluster
never start one). The process ends with its parent.
"""

from __future__ import annotations

import atexit
import multiprocessing
import os
import subprocess
import sys
import threading
from collections.abc import Iterable

from .._layout import FULL_KIND, MODEL_NAMES, PWA_KIND, REDUCED_KIND
from . import _kernel as K

__all__ = ["WarmUp", "warm_up"]

#: Environment variable: ``0`` turns the automatic warm-up off.
ENV = "HYDROPWA_WARMUP"
#: What the automatic warm-up compiles: the open-loop models and the linearization.
AUTO = (FULL_KIND.name, REDUCED_KIND.name, "point", PWA_KIND.name)

_auto_started = False


class WarmUp:
    """A background process compiling kernels into numba's disk cache.

    Created by :func:`warm_up`. The kernels form one queue shared with this process: the
    background process takes them in order and announces each (``start``) and each it has
    cached; when this process needs a kernel (:func:`~._kernel.prepare` calls
    :meth:`acquire`) it loads it once cached, compiles it itself if the background process
    has not started it, and while it waits compiles the next kernels not yet started
    (claimed over the process's stdin), so neither core idles.
    """

    def __init__(self, names: Iterable[str]):
        global _auto_started
        calls = {n: K.warmup_calls(n) for n in names}  # checks the names first
        # only what is not on disk yet (loading costs the process more than it saves)
        self.names = tuple(
            n
            for n, entries in calls.items()
            if not all(K._cached_on_disk(d) for d, _, _ in entries)
        )
        self.cached: list[str] = []
        self.compiled_here: list[str] = []
        self._lock = threading.Lock()
        self._queue: dict[str, tuple] = {}  # key -> (dispatcher, args, what), in order
        self._state: dict[str, str] = {}  # key -> pending | started | cached | here
        self._done: dict[str, threading.Event] = {}
        self._proc: subprocess.Popen | None = None
        if not self.names:
            return
        _auto_started = True  # one warm-up at a time: no automatic one beside this
        for name in self.names:
            for i, call in enumerate(calls[name]):
                if call[0] in K._warming:  # another warm-up has it
                    continue
                key = f"{name}/{i}"
                self._queue[key] = call
                self._state[key] = "pending"
                self._done[key] = threading.Event()
                K._warming[call[0]] = self
        env = dict(os.environ, **{ENV: "0"})
        self._proc = subprocess.Popen(
            [sys.executable, "-m", "hydropwa.simulation._warmup", *self.names],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
            env=env,
        )
        self._reader = threading.Thread(target=self._read, name="hydropwa-warmup", daemon=True)
        self._reader.start()
        atexit.register(self.close)

    def _read(self) -> None:
        assert self._proc is not None and self._proc.stdout is not None
        for line in self._proc.stdout:
            word, _, key = line.strip().partition(" ")
            with self._lock:
                if key not in self._state or self._state[key] == "here":
                    continue
                if word == "start":
                    self._state[key] = "started"
                elif word == "cached":
                    self._state[key] = "cached"
                    self.cached.append(key)
                    self._done[key].set()
        self._release()

    def _release(self) -> None:
        """Release every waiter (the process has ended: what it left undone compiles here)."""
        with self._lock:
            for key, ev in self._done.items():
                if self._state[key] in ("pending", "started"):
                    self._state[key] = "ended"
                ev.set()
            for dispatcher, owner in list(K._warming.items()):
                if owner is self:
                    K._warming.pop(dispatcher, None)

    def _claim_next(self, exclude: str) -> tuple | None:
        """Claim the first kernel the background process has not started; None if none."""
        with self._lock:
            for key, state in self._state.items():
                if state == "pending" and key != exclude:
                    return self._claim(key)
        return None

    def _claim(self, key: str) -> tuple:
        # under self._lock: the kernel is this process's to compile from now on
        self._state[key] = "here"
        K._warming.pop(self._queue[key][0], None)
        self.compiled_here.append(key)
        try:
            assert self._proc is not None and self._proc.stdin is not None
            self._proc.stdin.write(f"claim {key}\n")
            self._proc.stdin.flush()
        except (OSError, ValueError):  # the process has ended: nothing to tell it
            pass
        return self._queue[key]

    def acquire(self, dispatcher) -> None:
        """Called by :func:`~._kernel.prepare` before ``dispatcher`` is loaded or compiled.

        Returns once the background process has cached it, or has not started it (then
        the caller compiles it); while that process compiles it, compiles the next kernels
        it has not started.
        """
        key = next((k for k, c in self._queue.items() if c[0] is dispatcher), None)
        if key is None:
            return
        while True:
            with self._lock:
                state = self._state[key]
                if state == "pending":
                    self._claim(key)
                    return
            if state != "started":  # cached, ended, or compiled here
                return
            other = self._claim_next(key)
            if other is None:
                self._done[key].wait(K.WARMUP_WAIT)
                return
            K.prepare(*other)  # compile a later kernel here while the background one finishes

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
    models: Iterable[str] = (FULL_KIND.name, REDUCED_KIND.name, PWA_KIND.name),
    *,
    closed_loop: bool = False,
    linearization: bool = True,
    wait: bool = False,
) -> WarmUp:
    """Compile the solvers of ``models`` in a background process (numba's disk cache).

    Parameters
    ----------
    models : iterable of {"full", "reduced", "pwa", "pwa-chamber"}
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
    bad = [m for m in names if m not in MODEL_NAMES]
    if bad:
        raise ValueError(f"unknown model {bad[0]!r}; choose from {', '.join(MODEL_NAMES)}")
    names += ["point"] if linearization else []
    names += [f"closed-{m}" for m in names if m in MODEL_NAMES] if closed_loop else []
    w = WarmUp(names)
    if wait:
        w.wait()
    return w


def _env_disabled() -> bool:
    """Whether ``HYDROPWA_WARMUP`` turns background compilation off (``0``, ``off``, ...)."""
    return os.environ.get(ENV, "1").strip().lower() in ("0", "off", "false", "no")


def _auto(dispatcher) -> None:
    """:data:`~._kernel._cold_hook`: warm up the other models beside the first cold compile."""
    global _auto_started
    if _auto_started or _env_disabled():
        return
    _auto_started = True
    if multiprocessing.parent_process() is not None:
        return  # a pool or Dask worker: its parent (or a sibling) already compiles the rest
    others = [n for n in AUTO if all(d is not dispatcher for d, _, _ in K.warmup_calls(n))]
    if others:
        WarmUp(others)


def set_auto_warmup(on: bool) -> None:
    """Turn the automatic warm-up on or off for this process (the CLI turns it off)."""
    global _auto_started
    _auto_started = not on


K._cold_hook = _auto


def main(argv: list[str]) -> int:
    """Compile the named kernels (see :func:`~._kernel.warmup_calls`) in order.

    Prints ``start <key>`` before and ``cached <key>`` after each; skips the kernels the
    parent claims on stdin (``claim <key>``: it compiles them itself).
    """
    try:
        os.nice(5)  # the parent's own work goes first where the cores are shared
    except (AttributeError, OSError):  # pragma: no cover
        pass
    claimed: set[str] = set()
    lock = threading.Lock()

    def listen() -> None:
        for line in sys.stdin:
            word, _, key = line.strip().partition(" ")
            if word == "claim":
                with lock:
                    claimed.add(key)

    threading.Thread(target=listen, daemon=True).start()
    for name in argv:
        for i, (dispatcher, args, what) in enumerate(K.warmup_calls(name)):
            key = f"{name}/{i}"
            with lock:
                if key in claimed:
                    continue
                print(f"start {key}", flush=True)
            K.prepare(dispatcher, args, what)
            print(f"cached {key}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
