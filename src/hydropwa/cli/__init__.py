"""The ``hydropwa`` command line: thin wrappers over the public API.

Every user error (:class:`~hydropwa.HydropwaError`) is printed as one line
``error: ...`` on stderr with exit code 2; warnings as ``warning: ...``.
"""

from __future__ import annotations

import importlib
import sys
import warnings

import click
import typer

from .. import _interrupt
from .._errors import HydropwaError, interrupt_cause
from .._io import os_error_message
from ._core import params_app, simulate_command

__all__ = ["app", "main"]

app = typer.Typer(
    name="hydropwa",
    help="Model, identify and linearize valve-controlled hydraulic cylinders.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)


def _version(value: bool) -> None:
    if value:
        from .. import __version__

        typer.echo(f"hydropwa {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(
        False, "--version", help="Print the version and exit.", callback=_version, is_eager=True
    ),
) -> None:
    """Model, identify and linearize valve-controlled hydraulic cylinders."""


app.add_typer(params_app, name="params")
app.command("simulate")(simulate_command)

# Sub-applications: (module, attribute, name) — each module defines a typer app or a command.
_SUBAPPS = (
    ("._data", "app", "data"),
    ("._rig", "app", "rig"),
    ("._identify", "app", "identify"),
    ("._linearize", "register", "linearize"),
    ("._sweep", "sweep_command", "sweep"),
    ("._paper", "paper_command", "paper"),
    ("._control", "app", "control"),
)
for _mod, _attr, _name in _SUBAPPS:
    try:
        _m = importlib.import_module(_mod, __name__)
    except ModuleNotFoundError as _exc:  # a layer not installed in this build
        if _exc.name and _exc.name.startswith("hydropwa.cli."):
            continue
        raise
    _obj = getattr(_m, _attr)
    if isinstance(_obj, typer.Typer):
        app.add_typer(_obj, name=_name)
    elif _attr == "register":
        _obj(app)
    else:
        app.command(_name)(_obj)


def _showwarning(message, category, filename, lineno, file=None, line=None):
    print(f"warning: {message}", file=sys.stderr)


def _exception_types():
    """Exit/abort/usage-error classes of click and of typer's vendored click (typer >= 0.20)."""
    exits, aborts, usage = [click.exceptions.Exit], [click.exceptions.Abort], [click.ClickException]
    exits.append(getattr(typer, "Exit", click.exceptions.Exit))
    aborts.append(getattr(typer, "Abort", click.exceptions.Abort))
    try:
        from typer._click import exceptions as _vendored  # type: ignore[import-not-found]

        usage.append(_vendored.ClickException)
    except ImportError:  # typer that uses click itself
        pass
    return tuple(exits), tuple(aborts), tuple(usage)


_EXITS, _ABORTS, _USAGE = _exception_types()
_INTERRUPTED = "error: interrupted; finished files are kept, rerun to resume"


def _error_line(message: str) -> None:
    """Print ``error: message`` as one line on stderr."""
    print("error: " + " ".join(message.split()), file=sys.stderr)


def _usage_error(exc) -> int:
    """A click/typer usage error as one ``error:`` line (exit 2); bare group names show help."""
    ctx = getattr(exc, "ctx", None)
    if type(exc).__name__ == "NoArgsIsHelpError" and ctx is not None:
        print(ctx.get_help())
        return 0
    where = f"; see '{ctx.command_path} --help'" if ctx is not None else ""
    _error_line(f"{exc.format_message()}{where}")
    return 2


def _internal_error(exc: BaseException) -> int:
    """An exception the package did not mean to raise: one line, exit 1."""
    import os

    if os.environ.get("HYDROPWA_DEBUG"):
        import traceback

        traceback.print_exception(exc)
    _error_line(
        f"internal error ({type(exc).__name__}: {exc}); this is a bug in hydropwa, please report "
        "it with the command line (HYDROPWA_DEBUG=1 prints the traceback)"
    )
    return 1


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``hydropwa`` command; returns the exit code."""
    warnings.showwarning = _showwarning
    from ..simulation import set_compile_notice

    set_compile_notice(lambda msg: print(msg, file=sys.stderr, flush=True))
    command = typer.main.get_command(app)
    _interrupt.install()  # a Ctrl-C swallowed by a finalizer is still a Ctrl-C (see _interrupt)
    try:
        rv = command.main(args=argv, prog_name="hydropwa", standalone_mode=False)
    except HydropwaError as exc:
        _error_line(str(exc))
        code = 2
    except _EXITS as exc:
        code = getattr(exc, "exit_code", getattr(exc, "code", 0))
    except _ABORTS:  # click turns Ctrl-C (and EOF at a prompt) into Abort
        code = 130
    except _USAGE as exc:
        code = _usage_error(exc)
    except KeyboardInterrupt:
        code = 130
    except SystemError as exc:  # a Ctrl-C reported by a compiled call (see interrupt_cause)
        if interrupt_cause(exc) is None:
            code = _internal_error(exc)
        else:
            code = 130
    except OSError as exc:  # read-only file system, disk full, a file where a folder is expected...
        _error_line(os_error_message(exc))
        code = 2
    except MemoryError:
        _error_line("out of memory; ask for less (shorter --duration, lower --fs, fewer cases)")
        code = 2
    except RecursionError:
        _error_line(
            "an input file is nested too deeply to read; check that it is the file you meant"
        )
        code = 2
    except Exception as exc:  # a bug: still one line, exit 1 (HYDROPWA_DEBUG=1 shows the traceback)
        code = _internal_error(exc)
    else:
        code = rv if isinstance(rv, int) else 0
    finally:
        interrupted = _interrupt.uninstall()
    if interrupted:  # a Ctrl-C was recorded, even if the command ran on and returned
        code = 130
    if code == 130:  # Ctrl-C, however it arrived: typer (>= 0.20) returns it as Exit(130)
        print(_INTERRUPTED, file=sys.stderr)
    if argv is None:
        sys.exit(code)
    return code
