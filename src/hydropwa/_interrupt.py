"""A Ctrl-C that cannot get lost.

Python runs its SIGINT handler between two bytecodes of whatever the main thread executes.
If that is a finalizer (``__del__``, a weakref callback such as multiprocessing's
``Finalize``, run by the garbage collector at an arbitrary point), the ``KeyboardInterrupt``
is printed as "Exception ignored in ..." and dropped, and the program runs on as if the
user had not pressed Ctrl-C (seen with ``hydropwa paper``, whose process pool leaves such
finalizers: the study ran to the end and exited 0).

The CLI installs :func:`install`: its handler also records the interrupt (and the
``sys.unraisablehook`` it sets records a dropped one instead of printing a traceback), long loops call
:func:`checkpoint` between units of work (a rig run, a study stage, an evaluated run), which
raises ``KeyboardInterrupt`` again if one was recorded, and the CLI reports a recorded
interrupt as exit 130 even if the command returned. Library use without the CLI is
unchanged: nothing is recorded, so :func:`checkpoint` does nothing.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Callable
from types import FrameType
from typing import Any

__all__ = ["install", "uninstall", "checkpoint", "pending"]


class _State:
    """What :func:`install` changed, and whether a Ctrl-C was recorded."""

    pending: bool = False
    installed: bool = False
    hook: Callable[[Any], object] | None = None


_state = _State()


def _on_sigint(signum: int, frame: FrameType | None) -> None:  # noqa: ARG001 - handler signature
    _state.pending = True
    raise KeyboardInterrupt


def _unraisable(args: Any) -> None:
    """``sys.unraisablehook``: a dropped Ctrl-C is recorded, not printed as a traceback."""
    if isinstance(args.exc_value, KeyboardInterrupt):
        _state.pending = True
        return
    (_state.hook or sys.__unraisablehook__)(args)


def install() -> bool:
    """Record every Ctrl-C (and raise it as usual); main thread only, over Python's default handler.

    Returns True if installed. Clears a previously recorded interrupt.
    """
    _state.pending = False
    if threading.current_thread() is not threading.main_thread():
        return False
    if signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        return False  # someone else (a test runner, an embedding application) handles Ctrl-C
    signal.signal(signal.SIGINT, _on_sigint)
    _state.hook = sys.unraisablehook
    sys.unraisablehook = _unraisable
    _state.installed = True
    return True


def uninstall() -> bool:
    """Give SIGINT back to Python's default handler (if :func:`install` took it).

    Returns whether a Ctrl-C was recorded, and forgets it, so later library calls in the
    same process (a notebook that ran the CLI) are not stopped by an old interrupt.
    """
    if _state.installed and threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.default_int_handler)
        sys.unraisablehook = _state.hook or sys.__unraisablehook__
        _state.installed = False
    was, _state.pending = _state.pending, False
    return was


def pending() -> bool:
    """True if a Ctrl-C was recorded since :func:`install` (until :func:`uninstall`)."""
    return _state.pending


def checkpoint() -> None:
    """Raise ``KeyboardInterrupt`` if a Ctrl-C was recorded (one a finalizer may have swallowed)."""
    if _state.pending:
        raise KeyboardInterrupt
