"""Ctrl-C that lands inside a compiled kernel is a Ctrl-C, not a crash.

When Python's SIGINT handler runs while numba boxes a kernel's result, the dispatcher
returns with the ``KeyboardInterrupt`` set and Python raises
``SystemError("CPUDispatcher(...) returned a result with an exception set")`` caused by
it (seen with ``hydropwa paper`` interrupted in its evaluation stage). The kernel
wrapper turns it back into ``KeyboardInterrupt``; the CLI reports exit 130 and its
one line. The fake kernels below raise exactly that chain.
"""

from __future__ import annotations

import pytest

from hydropwa import ReducedModel, get_preset, simulate
from hydropwa._errors import interrupt_cause
from hydropwa.cli import main
from hydropwa.simulation import _kernel as K


def _kernel_reporting(exc_cause):
    def fake(*args):
        try:
            raise exc_cause
        except BaseException as inner:
            raise SystemError("CPUDispatcher(<function _integrate_reduced>) returned a result with an exception set") from inner

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
    code = main(["simulate", "-m", "reduced", "-d", "0.1", "-o", str(tmp_path / "r.csv")])
    err = capsys.readouterr().err
    assert code == 130
    assert err.strip() == "error: interrupted; finished files are kept, rerun to resume"
    assert not (tmp_path / "r.csv").exists()


class _passthrough:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False
