"""How every ``hydropwa`` command is made, and the one error path of the command line.

Every typer app of the CLI comes from :func:`new_app`: a sub-command group (``data``,
``identify``...) is ``new_app("data", help=...)``, the top-level commands of a module live in
an unnamed ``new_app()``, and each module registers its commands with ``@app.command("name")``.
The root app adds them all with ``app.add_typer(module.app)`` (an unnamed app's commands are
merged into the root).

The apps share one group class, :class:`CommandGroup`, whose ``invoke`` runs the command

- with warnings printed as one ``warning: ...`` line each, only while the command runs
  (importing the CLI changes nothing for library users), and
- with every exception turned into its exit code by :func:`exit_code`, the one mapping from
  errors to what the user sees: a :class:`~hydropwa.HydropwaError` or an ``OSError`` as one
  line ``error: ...`` and exit 2, Ctrl-C as exit 130, anything else as an internal error,
  exit 1.

So ``hydropwa.cli.main``, typer's ``CliRunner`` on any app, and the docs hook that reads the
command tree all see the same behaviour. Help texts are shown literally (no rich markup), so
``[grid]`` or ``[s]`` in a help text stays as written.
"""

from __future__ import annotations

import contextlib
import os
import re
import sys
import warnings
from typing import Any

import click
import typer
from typer.core import TyperCommand, TyperGroup

from .._errors import HydropwaError, interrupt_cause
from .._io import os_error_message

__all__ = [
    "Command",
    "CommandGroup",
    "INTERRUPTED",
    "INTERRUPTED_CODE",
    "error_line",
    "exit_code",
    "new_app",
]

#: Exit code of a command stopped by Ctrl-C (128 + SIGINT), as shells report it.
INTERRUPTED_CODE = 130
#: The line printed after a Ctrl-C, however it arrived.
INTERRUPTED = "error: interrupted; finished files are kept, rerun to resume"


_Types = tuple[type[BaseException], ...]


def _click_types() -> tuple[_Types, _Types, _Types]:
    """Exit, abort and usage-error classes of click and of typer's vendored click (>= 0.20)."""
    exits: list[type[BaseException]] = [click.exceptions.Exit, typer.Exit]
    aborts: list[type[BaseException]] = [
        click.exceptions.Abort,
        typer.Abort,
    ]
    usage: list[type[BaseException]] = [click.ClickException]
    try:
        from typer._click import (
            exceptions as vendored,  # deferred: loaded only when this command runs (a fast --help)
        )

        usage.append(vendored.ClickException)
    except ImportError:  # a typer that uses click itself
        pass
    return tuple(exits), tuple(aborts), tuple(usage)


_EXITS, _ABORTS, _USAGE = _click_types()
#: What click itself raises for parsing, help and exits: passed on, never re-mapped.
_CLICK_FLOW = _EXITS + _ABORTS + _USAGE


#: The Python spelling a library message gives beside the option (``--force (force=True)``):
#: the command line shows the option only.
_API_SPELLING = re.compile(r" \((?:force|overwrite)=True\)")


def error_line(message: str) -> None:
    """Print ``error: message`` as one line on stderr (the option, not the keyword argument)."""
    text = _API_SPELLING.sub("", " ".join(str(message).split()))
    print("error: " + text, file=sys.stderr)


def _usage_error(exc: Any) -> int:
    """A click/typer usage error as one ``error:`` line (exit 2); bare group names show help."""
    ctx = getattr(exc, "ctx", None)
    if type(exc).__name__ == "NoArgsIsHelpError" and ctx is not None:
        print(ctx.get_help())
        return 0
    where = f"; see '{ctx.command_path} --help'" if ctx is not None else ""
    error_line(f"{exc.format_message().rstrip('. ')}{where}")
    return 2


def _internal_error(exc: BaseException) -> int:
    """An exception the package did not mean to raise: one line, exit 1."""
    if os.environ.get("HYDROPWA_DEBUG"):
        import traceback  # deferred: loaded only when this command runs (a fast --help)

        traceback.print_exception(exc)
    error_line(
        f"internal error ({type(exc).__name__}: {exc}); this is a bug in hydropwa, please report "
        "it with the command line (HYDROPWA_DEBUG=1 prints the traceback)"
    )
    return 1


def exit_code(exc: BaseException) -> int:
    """The exit code of a command that raised ``exc``, after printing its one line.

    The one place that maps errors to what the user sees: the package's errors
    (:class:`~hydropwa.HydropwaError`) and ``OSError`` (read-only file system, disk full, a
    file where a folder is expected...) are one line ``error: ...`` and exit 2, as are
    running out of memory and a file nested too deeply to parse; a Ctrl-C is 130 (the caller
    prints :data:`INTERRUPTED`); click's exits and usage errors keep their codes; anything
    else is a bug in hydropwa: one line, exit 1 (``HYDROPWA_DEBUG=1`` adds the traceback).
    """
    if isinstance(exc, HydropwaError):
        error_line(str(exc))
        return 2
    if isinstance(exc, _EXITS):
        return int(getattr(exc, "exit_code", getattr(exc, "code", 0)) or 0)
    if isinstance(exc, (*_ABORTS, KeyboardInterrupt)):  # click turns Ctrl-C into Abort
        return INTERRUPTED_CODE
    if isinstance(exc, _USAGE):
        return _usage_error(exc)
    if isinstance(exc, OSError):
        error_line(os_error_message(exc))
        return 2
    if isinstance(exc, MemoryError):
        error_line(
            "out of memory; ask for less (shorter --duration, longer --sample-time, fewer cases)"
        )
        return 2
    if isinstance(exc, RecursionError):
        error_line(
            "an input file is nested too deeply to read; check that it is the file you meant"
        )
        return 2
    if isinstance(exc, SystemError) and interrupt_cause(exc) is not None:
        return INTERRUPTED_CODE  # a Ctrl-C reported by a compiled call (see interrupt_cause)
    return _internal_error(exc)


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:  # noqa: ARG001
    """``warnings.showwarning`` while a command runs: one ``warning: ...`` line on stderr."""
    print(f"warning: {message}", file=sys.stderr)


class CommandGroup(TyperGroup):
    """The group class of every ``hydropwa`` app: warnings as lines, errors through :func:`exit_code`."""

    def invoke(self, ctx: Any) -> Any:  # a click.Context of typer's vendored click
        with warnings.catch_warnings():  # restores the caller's showwarning afterwards
            warnings.showwarning = _show_warning
            try:
                return super().invoke(ctx)
            except _CLICK_FLOW:
                raise
            except Exception as exc:
                code = exit_code(exc)
                if code == INTERRUPTED_CODE:
                    raise KeyboardInterrupt from exc
                raise typer.Exit(code) from None


class Command(TyperCommand):
    """The command class of every ``hydropwa`` command: the checks every command shares.

    Before the command runs, every numeric option it was given is checked against its
    declared range (:func:`~hydropwa.cli._options.check_numbers`), and the lock of every
    output it names is taken (:func:`~hydropwa._io.target_lock`) and held until it ends, so
    two runs into one ``--out`` cannot both succeed. Errors go the one error path of the group.
    """

    def invoke(self, ctx: Any) -> Any:
        from .._io import target_lock  # deferred: loaded only when a command runs
        from ._options import check_numbers, output_paths

        check_numbers(ctx)
        with contextlib.ExitStack() as stack:
            for path in output_paths(ctx):
                stack.enter_context(target_lock(path, f"hydropwa {ctx.command_path}"))
            return super().invoke(ctx)


class _Typer(typer.Typer):
    """A typer app whose commands are :class:`Command` s."""

    def command(self, name: str | None = None, *, cls: Any = None, **kwargs: Any) -> Any:
        return super().command(name, cls=cls or Command, **kwargs)


def new_app(name: str | None = None, *, help: str | None = None, **kwargs: Any) -> typer.Typer:
    """A typer app of the ``hydropwa`` CLI (named: a command group; unnamed: merged commands)."""
    settings: dict[str, Any] = {
        "cls": CommandGroup,
        "no_args_is_help": True,
        "add_completion": False,
        "rich_markup_mode": None,  # help texts literally: "[grid]", "[s]" are not markup
        "pretty_exceptions_enable": False,
    }
    settings.update(kwargs)
    return _Typer(name=name, help=help, **settings)
