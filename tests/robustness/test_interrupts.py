"""Ctrl-C that lands inside a compiled kernel is a Ctrl-C, not a crash.

When Python's SIGINT handler runs while numba boxes a kernel's result, the dispatcher
returns with the ``KeyboardInterrupt`` set and Python raises
``SystemError("CPUDispatcher(...) returned a result with an exception set")`` caused by
it (seen with ``hydropwa paper`` interrupted in its evaluation stage). The kernel
wrapper turns it back into ``KeyboardInterrupt``; the CLI reports exit 130 and its
one line. The fake kernels below raise exactly that chain.
"""

from __future__ import annotations

import os
import signal

import pytest

from hydropwa import ReducedModel, _interrupt, get_preset, simulate
from hydropwa._errors import interrupt_cause
from hydropwa.cli import main
from hydropwa.simulation import _kernel as K


def _kernel_reporting(exc_cause):
    def fake(*args):
        try:
            raise exc_cause
        except BaseException as inner:
            raise SystemError(
                "CPUDispatcher(<function _integrate_reduced>) returned a result with an exception set"
            ) from inner

    return fake


def test_interrupt_cause_walks_the_chain():
    try:
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as ki:
            raise SystemError("x") from ki
    except SystemError as exc:
        assert isinstance(interrupt_cause(exc), KeyboardInterrupt)
    assert interrupt_cause(SystemError("a plain one")) is None
    assert interrupt_cause(ValueError("v")) is None


def test_kernel_interrupt_reaches_the_caller_as_keyboard_interrupt(monkeypatch):
    monkeypatch.setitem(K._ENTRY, K.REDUCED, _kernel_reporting(KeyboardInterrupt()))
    with pytest.raises(KeyboardInterrupt):
        simulate(ReducedModel(get_preset("paper")), "sine:amplitude=0.4,frequency=1", duration=0.1)


def test_other_kernel_system_errors_are_not_hidden(monkeypatch):
    monkeypatch.setitem(K._ENTRY, K.REDUCED, _kernel_reporting(ValueError("a real bug")))
    with pytest.raises(SystemError, match="returned a result with an exception set"):
        simulate(ReducedModel(get_preset("paper")), "sine:amplitude=0.4,frequency=1", duration=0.1)


def test_cli_reports_kernel_interrupt_as_ctrl_c(monkeypatch, tmp_path, capsys):
    # bypass the wrapper so the SystemError itself reaches the CLI (another compiled call)
    monkeypatch.setattr(K, "_interruptible", _passthrough)
    monkeypatch.setitem(K._ENTRY, K.REDUCED, _kernel_reporting(KeyboardInterrupt()))
    code = main(
        ["simulate", "-m", "reduced", "-p", "paper", "-d", "0.1", "-o", str(tmp_path / "r.csv")]
    )
    err = capsys.readouterr().err
    assert code == 130
    assert err.strip() == "error: interrupted; finished files are kept, rerun to resume"
    assert not (tmp_path / "r.csv").exists()


class _passthrough:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


# --- a Ctrl-C that a finalizer swallows -------------------------------------------------
# Python runs its SIGINT handler in whatever the main thread executes; inside a finalizer
# (here a __del__, in `hydropwa paper` multiprocessing's Finalize callbacks) the
# KeyboardInterrupt is reported as "Exception ignored" and dropped. Seen in CI: the study
# ran to the end after Ctrl-C and exited 0.


def _swallowed_ctrl_c():
    """Deliver SIGINT so that its handler runs inside a finalizer, which drops the interrupt."""

    class Dropper:
        def __del__(self):
            os.kill(os.getpid(), signal.SIGINT)
            for _ in range(1000):  # the handler runs at one of these bytecodes, inside __del__
                pass

    Dropper()  # collected at once (reference count 0)


@pytest.fixture
def default_sigint():
    """SIGINT at Python's default handler for the test (a test run started in the background
    by a non-interactive shell has it ignored, and then the CLI leaves Ctrl-C alone)."""
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, old)


@pytest.fixture
def recording(default_sigint):
    assert _interrupt.install()
    yield
    _interrupt.uninstall()


def test_an_ignored_sigint_stays_ignored():
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)  # e.g. `hydropwa paper &` from a script
    try:
        assert _interrupt.install() is False
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, old)


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_a_swallowed_ctrl_c_is_recorded_and_raised_at_the_next_checkpoint(recording, capsys):
    _swallowed_ctrl_c()  # returns normally: the finalizer dropped the KeyboardInterrupt
    assert _interrupt.pending()
    assert "Traceback" not in capsys.readouterr().err  # recorded by the hook, not printed
    with pytest.raises(KeyboardInterrupt):
        _interrupt.checkpoint()


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_a_study_stage_does_not_start_after_a_swallowed_ctrl_c(recording, tmp_path):
    from hydropwa.studies.paper._stages import StageRunner

    _swallowed_ctrl_c()
    ran = []
    with pytest.raises(KeyboardInterrupt):
        StageRunner(tmp_path).run("identify", "inputs", lambda: ran.append(1) or ([], {}))
    assert not ran


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_uninstall_reports_and_forgets_the_interrupt(recording):
    _swallowed_ctrl_c()
    assert _interrupt.uninstall() is True
    assert not _interrupt.pending()
    _interrupt.checkpoint()  # library use after the CLI: a no-op
    assert _interrupt.uninstall() is False


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_cli_reports_a_swallowed_ctrl_c_even_if_the_command_ran_to_the_end(
    monkeypatch, tmp_path, capsys, default_sigint
):
    real = K._ENTRY[K.REDUCED]

    def kernel_during_which_ctrl_c_is_swallowed(*args):
        _swallowed_ctrl_c()
        return real(*args)

    monkeypatch.setitem(K._ENTRY, K.REDUCED, kernel_during_which_ctrl_c_is_swallowed)
    code = main(
        ["simulate", "-m", "reduced", "-p", "paper", "-d", "0.1", "-o", str(tmp_path / "r.csv")]
    )
    assert code == 130
    assert (
        capsys.readouterr()
        .err.strip()
        .endswith("error: interrupted; finished files are kept, rerun to resume")
    )
    # main() gives SIGINT back and forgets the interrupt: later library calls are not stopped
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    assert not _interrupt.pending()
    _interrupt.checkpoint()
