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
HANG_SECONDS = 60.0  # generous: the first call of a target may compile numba kernels (~50 s cold on 2 busy cores)

#: target name -> [inputs tried, loaded, rejected with the documented error, contract
#: violations (only counted in FUZZ_COLLECT mode; otherwise the first one fails the test)]
COUNTS: dict[str, list[int]] = collections.defaultdict(lambda: [0, 0, 0, 0])

#: FUZZ_COLLECT=1: record contract violations (by exception type and raising line in
#: hydropwa) instead of failing, so one run lists every distinct defect (triage mode).
COLLECT = os.environ.get("FUZZ_COLLECT") == "1"
DEFECTS: dict[tuple, tuple[str, str]] = {}


def _site(exc: BaseException) -> str:
    frames = [
        f
        for f in traceback.extract_tb(exc.__traceback__)
        if "hydropwa" in f.filename and "robustness" not in f.filename
    ]
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
            COUNTS[target][3] += 1
            DEFECTS.setdefault(
                (target, type(exc).__name__, _site(exc)), (repr(args)[:300], str(exc)[:200])
            )
            return None
        raise AssertionError(
            f"{target}: raised {type(exc).__name__} ({exc}), documented is {error.__name__}"
        ) from exc
    except Exception as exc:  # pragma: no cover - a defect
        if COLLECT:
            COUNTS[target][3] += 1
            DEFECTS.setdefault(
                (target, type(exc).__name__, _site(exc)), (repr(args)[:300], str(exc)[:200])
            )
            return None
        raise
    COUNTS[target][1] += 1
    return value


# ----------------------------------------------------------------------------- CLI
#: The documented outcomes of a command: 0 done, 1 ``data check`` found issues (listed on
#: stdout, no ``error:`` line), 2 a user error as exactly one ``error: ...`` line on stderr.
CLI_CODES = (0, 1, 2)


def run_cli(argv: list[str], cwd) -> tuple[int, str, str]:
    """Run ``hydropwa argv`` in this process (in ``cwd``); return (code, stdout, stderr)."""
    import io
    import warnings

    from hydropwa.cli import main

    out, err = io.StringIO(), io.StringIO()
    old = os.getcwd()
    os.chdir(cwd)
    try:
        with (
            warnings.catch_warnings(),
            contextlib.redirect_stdout(out),
            contextlib.redirect_stderr(err),
        ):
            warnings.simplefilter("default")  # the CLI prints warnings as 'warning:' lines
            with _alarm(HANG_SECONDS * 3):
                code = main(argv)
    finally:
        os.chdir(old)
    return code, out.getvalue(), err.getvalue()


def cli_violation(argv: list[str], code: int, out: str, err: str) -> str | None:
    """What breaks the CLI contract in one result, or None."""
    lines = [ln for ln in err.splitlines() if ln.strip()]
    errors = [ln for ln in lines if ln.startswith("error: ")]
    others = [ln for ln in lines if not ln.startswith(("error: ", "warning: "))]
    if "Traceback" in err or "Traceback" in out:
        return "a traceback"
    if any("internal error" in ln for ln in errors):
        return f"an internal error: {errors[0][:200]}"
    if code not in CLI_CODES:
        return f"exit code {code}"
    if code == 2:
        if len(errors) != 1:
            return f"exit 2 with {len(errors)} error lines: {lines[:4]}"
        if others:
            return f"exit 2 with other text on stderr: {others[:3]}"
    if code == 1 and (errors or argv[:2] != ["data", "check"]):
        return f"exit 1 outside `data check` or with an error line: {errors[:1]}"
    if code == 0 and errors:
        return f"exit 0 with an error line: {errors[0][:200]}"
    return None


def check_cli(target: str, argv: list[str], cwd) -> tuple[int, str, str]:
    """Run a command and hold it to the CLI contract; counts as loaded (0/1) or rejected (2)."""
    COUNTS[target][0] += 1
    try:
        code, out, err = run_cli(argv, cwd)
    except BaseException as exc:  # SystemExit, a hang, anything main() let through
        if COLLECT:
            COUNTS[target][3] += 1
            DEFECTS.setdefault(
                (target, type(exc).__name__, _site(exc)), (repr(argv)[:300], str(exc)[:200])
            )
            return -1, "", ""
        raise AssertionError(
            f"{target}: hydropwa {argv} raised {type(exc).__name__}: {exc}"
        ) from exc
    problem = cli_violation(argv, code, out, err)
    if problem is not None:
        violation(target, argv, f"{problem}; stderr: {err[-300:]}")
        return code, out, err
    COUNTS[target][1 if code in (0, 1) else 2] += 1
    return code, out, err


def violation(target: str, args, problem: str) -> None:
    """A broken contract: fail, or in FUZZ_COLLECT mode count and record it."""
    if COLLECT:
        COUNTS[target][3] += 1
        DEFECTS.setdefault((target, problem[:50], ""), (repr(args)[:300], problem[:300]))
        return
    raise AssertionError(f"{target}: {args!r}: {problem}")
