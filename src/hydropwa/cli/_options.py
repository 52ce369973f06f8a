"""The option vocabulary shared by the ``hydropwa`` commands.

``--params PRESET|FILE`` (short ``-p``) names the parameter set on every command that takes
one, and :func:`resolve_params` is the one function that reads it: a preset name
(``paper``, ``symmetric``), a parameter TOML file, or a JSON file (a parameter document as
``SystemParams.to_dict`` writes it, or a PWA JSON export, whose parameters are used).
There is no default machine (issue 37): a command that needs one and is given none (no
``--params``, no machine recorded in its data or controller file) stops with one line saying
how to give it (:data:`NO_MACHINE`); the paper's rig is ``--params paper``.
``--base-params`` is the old name used by ``identify``: hidden, still accepted, with one
``warning:`` line (:func:`params_source`).

``--sample-time PERIOD|RATE`` is the one name for a sampling interval (the simulated output's,
a controller's, the discretised PWA cells'): a period (``0.5 ms``; a plain number is seconds)
or a rate (``2 kHz``), read by :func:`parse_sample_time`. ``--fs`` (``simulate``) and
``--rate`` (``control design``) are its old names: hidden, still accepted, with one
``warning:`` line (:func:`sample_time_source`). ``--jobs/-j`` defaults to all cores and
``--out/-o`` to a fixed name in the working folder on every command (nothing is overwritten
without ``--force``).
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Annotated, Any

import typer

from .._errors import ParameterError
from .._io import read_text
from ..params import (
    PRESETS,
    SystemParams,
    get_preset,
    load_params,
    params_from_dict,
    parse_quantity,
)

__all__ = [
    "BaseParamsAlias",
    "MACHINE_PARAMS_HELP",
    "MachineParamsOption",
    "PARAMS_HELP",
    "PARAMS_METAVAR",
    "PRESET_NAMES",
    "ParamsOption",
    "JOBS_HELP",
    "MACHINE_FIX",
    "NO_MACHINE",
    "SAMPLE_TIME_METAVAR",
    "params_source",
    "parse_sample_time",
    "resolve_params",
    "sample_time_source",
]

#: How help texts show the value of ``--sample-time``.
SAMPLE_TIME_METAVAR = "PERIOD|RATE"
#: The help ending of every ``--jobs/-j`` (default ``None``: all cores).
JOBS_HELP = "(default: all cores)"

#: How to give the machine, as the errors of a command without one say it.
MACHINE_FIX = "pass --params FILE (your machine's TOML) or --params paper for the paper's rig"
#: The one line of a command that needs a machine and is given none (exit 2).
NO_MACHINE = f"no machine given: {MACHINE_FIX}"

#: The presets, as help texts and errors list them.
PRESET_NAMES = ", ".join(PRESETS)
#: How help texts show the value of ``--params``.
PARAMS_METAVAR = "PRESET|FILE"
PARAMS_HELP = (
    f"The machine: a TOML/JSON parameter file or a preset ({PRESET_NAMES}); required, "
    "there is no default machine (the paper's rig: --params paper)."
)


def jobs_option(what: str) -> Any:
    """``--jobs/-j N`` (1 to 1024, default ``None``: all cores); ``what`` says what runs in parallel."""
    return typer.Option("--jobs", "-j", min=1, max=1024, help=f"{what} {JOBS_HELP}.")


def duration_option(help: str) -> Any:  # noqa: A002 - typer's own word
    """``--duration/-d TIME`` (a quantity with a time unit, or seconds)."""
    return typer.Option("--duration", "-d", metavar="TIME", help=help)


def params_option(help: str) -> Any:  # noqa: A002 - typer's own word
    """``--params/-p PRESET|FILE`` with a command's own help text."""
    return typer.Option("--params", "-p", metavar=PARAMS_METAVAR, help=help)


#: ``--params/-p PRESET|FILE``: the parameter set of every command that takes one.
ParamsOption = Annotated[
    str | None, typer.Option("--params", "-p", metavar=PARAMS_METAVAR, help=PARAMS_HELP)
]

MACHINE_PARAMS_HELP = (
    f"The machine's parameters: a TOML/JSON parameter file or a preset ({PRESET_NAMES}); "
    "default: the machine the data or the controller file record (a campaign's "
    "true_params.toml, a 'machine' entry); there is no default machine."
)

#: ``--params/-p PRESET|FILE`` of the commands that read measured data or a controller file:
#: no default preset (the machine comes from the data or the file, else exit 2).
MachineParamsOption = Annotated[
    str | None,
    typer.Option("--params", "-p", metavar=PARAMS_METAVAR, help=MACHINE_PARAMS_HELP),
]

#: ``--base-params``: the old name of ``--params`` in ``identify``; hidden, still accepted.
BaseParamsAlias = Annotated[
    str | None,
    typer.Option("--base-params", hidden=True, help="Deprecated name of --params."),
]


def params_source(params: str | None, base_params: str | None) -> str | None:
    """``--params``, or the deprecated ``--base-params`` with one ``warning:`` line on stderr."""
    if base_params is None:
        return params
    if params is not None:
        raise ParameterError(
            "give --params only; --base-params is its old name and names the same thing"
        )
    typer.echo(
        "warning: --base-params is deprecated and will be removed; use --params (same values)",
        err=True,
    )
    return base_params


def _read_json(path: Path) -> SystemParams:
    """Parameters from a JSON document: a parameter dict, or a PWA export's ``params``."""
    try:
        data = json.loads(read_text(path, "parameter file", ParameterError))
    except json.JSONDecodeError as exc:
        raise ParameterError(f"{path}: invalid JSON ({exc})") from None
    if isinstance(data, dict) and str(data.get("schema", "")).startswith("hydropwa.pwa"):
        # a PWA export holds the exact SI parameters it was built from (plausible or not)
        prm = data.get("params")
        if not isinstance(prm, dict):
            raise ParameterError(f"{path}: a PWA document without its 'params' table")
        return params_from_dict(prm, source=f"{path} (params)", check_bare=False)
    return params_from_dict(data, source=str(path))


def resolve_params(source: str | os.PathLike | None, option: str = "--params") -> SystemParams:
    """The parameter set a command line names: a preset, a TOML file or a JSON file.

    Parameters
    ----------
    source : str, path or None
        A preset name (:data:`hydropwa.params.PRESETS`), or the path of a parameter TOML or
        JSON file. A file of that name wins over a preset. ``None`` (nothing given) is an
        error: there is no default machine.
    option : str
        The option or argument named in error messages.

    Raises
    ------
    ParameterError
        One line naming ``source`` and the presets, when it is neither; or the file's error;
        :data:`NO_MACHINE` when ``source`` is None.
    """
    if source is None:
        raise ParameterError(NO_MACHINE)
    path = Path(source)
    if not path.is_file():
        if str(source) in PRESETS and not path.exists():
            return get_preset(str(source))
        what = "is a folder" if path.is_dir() else "not found (no such preset or file)"
        raise ParameterError(
            f"{option} {str(source)!r} {what}; give a preset ({PRESET_NAMES}) "
            "or a TOML/JSON parameter file"
        )
    try:
        if path.suffix.lower() == ".json":
            return _read_json(path)
        return load_params(path)
    except RecursionError:
        raise ParameterError(f"{source}: nested too deeply to be a parameter file") from None


def parse_sample_time(text: str, option: str = "--sample-time") -> float:
    """A sampling interval [s] from a period (``"0.5 ms"``, a plain number in s) or a rate
    (``"2 kHz"``).

    Raises
    ------
    ParameterError
        One line when ``text`` is neither, or not positive.
    """
    try:
        dt = parse_quantity(text, "s", option)
    except ParameterError:
        try:
            rate = parse_quantity(text, "Hz", option)
        except ParameterError:
            raise ParameterError(
                f"{option} {text!r} is neither a period nor a rate; give e.g. '0.5 ms' or '2 kHz'"
            ) from None
        dt = 1.0 / rate if rate > 0 else -1.0
    if not (math.isfinite(dt) and dt > 0):
        raise ParameterError(f"{option} {text!r} must be positive, e.g. '0.5 ms' or '2 kHz'")
    return dt


def sample_time_source(
    sample_time: str | None, old: str | None, old_name: str, old_unit: str
) -> str | None:
    """``--sample-time``, or its deprecated old name (``--fs``, ``--rate``) with one ``warning:``
    line on stderr; a plain number given to the old name keeps that name's unit (Hz)."""
    if old is None:
        return sample_time
    if sample_time is not None:
        raise ParameterError(
            f"give --sample-time only; {old_name} is its old name and names the same thing"
        )
    typer.echo(
        f"warning: {old_name} is deprecated and will be removed; use --sample-time "
        "(a period such as '0.5 ms' or a rate such as '2 kHz')",
        err=True,
    )
    try:
        return f"{float(old)!r} {old_unit}"
    except ValueError:
        return old
