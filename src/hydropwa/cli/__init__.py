"""The ``hydropwa`` command line: thin wrappers over the public API.

Every command module defines one typer app made by :func:`~hydropwa.cli._app.new_app` and
registers its commands with ``@app.command("name")``; this module adds each app with
``app.add_typer(module.app)`` (see ``_app`` for the one error path and the warning lines).
Every user error (:class:`~hydropwa.HydropwaError`) is printed as one line ``error: ...``
on stderr with exit code 2; warnings as ``warning: ...`` while a command runs.
"""

from __future__ import annotations

import multiprocessing
import os
import sys

import typer

from .. import _interrupt
from . import (
    _control,
    _core,
    _data,
    _export,
    _identify,
    _linearize,
    _monitor,
    _paper,
    _rig,
    _sweep,
)
from ._app import INTERRUPTED, INTERRUPTED_CODE, exit_code, new_app

__all__ = ["app", "main"]

app = new_app(
    "hydropwa", help="Model, identify and linearize valve-controlled hydraulic cylinders."
)


def _version(value: bool) -> None:
    if value:
        from .. import __version__  # deferred: loaded only when this command runs (a fast --help)

        typer.echo(f"hydropwa {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(
        False, "--version", help="Print the version and exit.", callback=_version, is_eager=True
    ),
) -> None:
    """Model, identify and linearize valve-controlled hydraulic cylinders."""


# Named apps are command groups (`hydropwa data ...`); unnamed ones add top-level commands.
for _module in (
    _core,
    _data,
    _rig,
    _identify,
    _linearize,
    _sweep,
    _paper,
    _control,
    _export,
    _monitor,
):
    app.add_typer(_module.app)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``hydropwa`` command; returns the exit code."""
    from ..simulation import (  # deferred: loaded only when this command runs (a fast --help)
        set_auto_warmup,
        set_compile_notice,
    )

    set_compile_notice(lambda msg: print(msg, file=sys.stderr, flush=True))
    # a command compiles what it uses; those that use several models warm them up themselves
    set_auto_warmup(False)
    command = typer.main.get_command(app)
    _interrupt.install()  # a Ctrl-C swallowed by a finalizer is still a Ctrl-C (see _interrupt)
    try:
        rv = command.main(args=argv, prog_name="hydropwa", standalone_mode=False)
    except (Exception, KeyboardInterrupt) as exc:
        code = exit_code(exc)
    else:
        code = rv if isinstance(rv, int) else 0
    finally:
        interrupted = _interrupt.uninstall()
    if interrupted:  # a Ctrl-C was recorded, even if the command ran on and returned
        code = INTERRUPTED_CODE
    if code == INTERRUPTED_CODE:  # Ctrl-C, however it arrived: typer (>= 0.20) returns Exit(130)
        print(INTERRUPTED, file=sys.stderr)
    if argv is None:
        if code == INTERRUPTED_CODE:
            _leave_now(code)
        sys.exit(code)
    return code


def _leave_now(code: int) -> None:
    """End the process after a Ctrl-C without Python's exit-time joins.

    At a normal exit Python joins the threads of every process pool and every non-daemon
    child. After a Ctrl-C one of those may never end (a pool worker that the interrupt
    reached while it was being forked, a queue a dead worker left half written), and the
    command then hung after printing that it was interrupted. Finished files are already on
    disk (each written atomically), so nothing is lost by ending here: children are
    terminated (pool workers also exit on their own once this process is gone, see
    ``rig._runner``), the streams flushed, and the process ends with ``code``.
    """
    for child in multiprocessing.active_children():
        child.terminate()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe: nothing more can be said
            pass
    os._exit(code)
