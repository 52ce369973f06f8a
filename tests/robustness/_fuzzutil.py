"""Shared harness of the fuzz targets: the contract every boundary must keep.

Contract: an input either loads (returns a value of the expected type) or raises a
:class:`hydropwa.HydropwaError` subclass of the documented type, with a non-empty message.
Any other exception, a warning that escapes, or a call that takes longer than
``HANG_SECONDS`` is a defect. ``COUNTS`` records how many inputs each target tried (reported
at the end of the session by ``conftest.pytest_terminal_summary``).
"""

from __future__ import annotations

import collections
import contextlib
import os
import signal
import traceback

from hydropwa import HydropwaError

#: Wall-clock limit of one call [s]; a parser that needs more on a few-kB input hangs.
HANG_SECONDS = 20.0

#: target name -> [inputs tried, loaded, rejected with the documented error]
COUNTS: dict[str, list[int]] = collections.defaultdict(lambda: [0, 0, 0])

#: FUZZ_COLLECT=1: record contract violations (by exception type and raising line in
#: hydropwa) instead of failing, so one run lists every distinct defect (triage mode).
COLLECT = os.environ.get("FUZZ_COLLECT") == "1"
DEFECTS: dict[tuple, tuple[str, str]] = {}


def _site(exc: BaseException) -> str:
    frames = [f for f in traceback.extract_tb(exc.__traceback__) if "hydropwa" in f.filename
              and "robustness" not in f.filename]
    f = frames[-1] if frames else traceback.extract_tb(exc.__traceback__)[-1]
    return f"{f.filename.split('src/')[-1]}:{f.lineno}"


class Hang(Exception):
    """Raised by the alarm when a call exceeds HANG_SECONDS."""


@contextlib.contextmanager
def _alarm(seconds: float):
    def handler(signum, frame):  # pragma: no cover - only on a hang
        raise Hang(f"call did not return within {seconds} s")

    old = signal.signal(signal.SIGALRM, handler)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def load_or_reject(target: str, error: type[HydropwaError], fn, *args, **kwargs):
    """Call ``fn``; return its value, or ``None`` when it raised ``error`` properly."""
    COUNTS[target][0] += 1
    try:
        with _alarm(HANG_SECONDS):
            value = fn(*args, **kwargs)
    except error as exc:
        assert str(exc).strip(), f"{target}: {type(exc).__name__} without a message"
        COUNTS[target][2] += 1
        return None
    except HydropwaError as exc:  # pragma: no cover - a defect
        if COLLECT:
            DEFECTS.setdefault((target, type(exc).__name__, _site(exc)), (repr(args)[:300], str(exc)[:200]))
            return None
        raise AssertionError(
            f"{target}: raised {type(exc).__name__} ({exc}), documented is {error.__name__}"
        ) from exc
    except Exception as exc:  # pragma: no cover - a defect
        if COLLECT:
            DEFECTS.setdefault((target, type(exc).__name__, _site(exc)), (repr(args)[:300], str(exc)[:200]))
            return None
        raise
    COUNTS[target][1] += 1
    return value
