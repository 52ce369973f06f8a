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

import dataclasses
import json
import math
import os
from collections.abc import Iterator
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
    "NUMBER_RANGES",
    "OUTPUT_OPTIONS",
    "Range",
    "check_numbers",
    "output_paths",
    "params_source",
    "parse_sample_time",
    "resolve_params",
    "sample_time_option",
    "sample_time_source",
]

#: How help texts show the value of ``--sample-time``.
SAMPLE_TIME_METAVAR = "PERIOD|RATE"


def sample_time_option(help_text: str) -> Any:
    """The ``--sample-time`` option (a period or a rate, :func:`parse_sample_time`) with a
    command's own help text."""
    return typer.Option("--sample-time", metavar=SAMPLE_TIME_METAVAR, help=help_text)


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


#: The sampling interval [s] when none is given: 0.5 ms (2 kHz), the paper's rig. A number, so
#: that the default costs no unit parse (pint's import and registry are ~1 CPU-s of a command).
DEFAULT_SAMPLE_TIME = 5e-4


def parse_sample_time(text: str | None, option: str = "--sample-time") -> float:
    """A sampling interval [s] from a period (``"0.5 ms"``, a plain number in s) or a rate
    (``"2 kHz"``); :data:`DEFAULT_SAMPLE_TIME` when ``text`` is None (the option not given).

    Raises
    ------
    ParameterError
        One line when ``text`` is neither, or not positive.
    """
    if text is None:
        return DEFAULT_SAMPLE_TIME
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


# ----------------------------------------------------------------------------- ranges
@dataclasses.dataclass(frozen=True)
class Range:
    """The accepted values of a numeric option: ``low <= value <= high``, finite.

    Attributes
    ----------
    low, high : float
        The closed range, in SI units (``unit``).
    what : str
        What the number is, for the message (how to choose a good value).
    unit : str or None
        ``None``: the option is typed as a number (int/float). A unit (``"s"``, ``"m"``): the
        option is a quantity text (``'100 mm'``), read with ``parse_quantity``; ``"period"``:
        a sampling period or rate, read with :func:`parse_sample_time`.
    signal : bool
        The option also takes a signal spec (``kind:key=value,...``), checked where it is read.
    """

    low: float
    high: float
    what: str
    unit: str | None = None
    signal: bool = False

    def value(self, option: str, raw: Any) -> float | None:
        """``raw`` as a number [SI]; ParameterError (one line) when it is none or out of range.

        With ``signal``, a signal spec (``'sine:...'``) is left to the signal parser (None).
        """
        if self.signal and ":" in str(raw):
            return None
        if self.unit == "period":
            v = parse_sample_time(str(raw), option)
        elif self.unit is not None:
            v = parse_quantity(str(raw), self.unit, option)
        else:
            v = float(raw)
        if not (math.isfinite(v) and self.low <= v <= self.high):
            unit = "s" if self.unit == "period" else (self.unit or "")
            raise ParameterError(
                f"{option} {raw!r} is outside [{self.low:g}, {self.high:g}]{' ' + unit if unit else ''}"
                f": {self.what}"
            )
        return v


#: Every numeric option of the CLI (by its long name) and the values it accepts; checked for
#: every command before it runs (:func:`check_numbers`), so ``nan``, ``inf``, ``''``, a
#: negative count or an implausible tolerance is one line, exit 2. A test walks the commands:
#: an option typed as a number without a row here fails it. ``--supply-pressure`` has no row:
#: it gets the bounds of ``Supply.pressure`` where the machine is known (``_limits``).
NUMBER_RANGES: dict[str, Range] = {
    # the range simulate checks (simulation.RTOL_RANGE; a test keeps them equal)
    "--rtol": Range(
        1e-12,
        0.1,
        "the integrator's relative tolerance; 1e-3 keeps the position "
        "within 0.1 mm, 1e-6 is measurement grade",
    ),
    "--starts": Range(1, 1000, "the number of optimiser starts; 1 is one fit, 8-32 a multi-start"),
    "--delay-samples": Range(
        0, 20, "whole samples of delay between computation and valve; 0 or 1 on a real target"
    ),
    "--window": Range(1e-4, 60.0, "the multiple-shooting window [s]; 0.02 suits the paper's rig"),
    "--budget": Range(0.1, 86_400.0, "the seconds of data a selection keeps; default 6"),
    "--validate": Range(
        0.0, 0.8, "the share of the runs held out of the fit; 0.2 holds out one in five"
    ),
    "--draws": Range(1, 1000, "the parameter draws of the verification; default 4"),
    "--soundness-samples": Range(
        0, 100_000, "the (state, command) pairs of the certificate's one-step check; 0: off"
    ),
    "--seed": Range(0, 2**32 - 1, "a random seed, a non-negative integer below 2^32"),
    "--jobs": Range(1, 1024, "the number of workers"),
    "--dead-zone-hysteresis": Range(0.0, 0.5, "a share of the opening, e.g. 0.005"),
    "--false-alarm": Range(
        1e-12, 0.5, "the false-alarm probability per healthy run the thresholds allow, e.g. 1e-3"
    ),
    # positive and finite here; whether the samples fit in memory is _limits.check_samples
    "--duration": Range(1e-9, math.inf, "a positive, finite simulated time, e.g. '2 s'", "s"),
    "--x0": Range(0.0, 100.0, "an initial rod position on the stroke, e.g. '100 mm'", "m"),
    "--load-force": Range(
        -1e8, 1e8, "a load force, e.g. '500 N' (or a signal spec)", "N", signal=True
    ),
    "--sample-time": Range(
        1e-15, 3600.0, "a sampling period ('0.5 ms') or rate ('2 kHz')", "period"
    ),
}

#: The options and arguments that name what a command writes (files or folders): the CLI
#: holds the lock of each (``hydropwa._io.target_lock``) while the command runs. A test walks
#: the commands: a path option in neither this set nor ``INPUT_OPTIONS`` fails it.
OUTPUT_OPTIONS = frozenset(
    {
        "--out",
        "--figures",
        "--plot",
        "--table",
        "--summary",
        "--c",
        "--fmu",
        "--trajectories",
        "--tables",
        "--mat",
        "dst",
    }
)


def _option_values(ctx: Any) -> Iterator[tuple[str, Any]]:
    """(long option name or argument name, parsed value) of the given values of a command."""
    for prm in ctx.command.params:
        value = ctx.params.get(prm.name)
        if value is None or isinstance(value, bool):
            continue
        names = [o for o in prm.opts if o.startswith("--")] or list(prm.opts)
        yield names[0], value


def check_numbers(ctx: Any) -> None:
    """Check every numeric option a command was given against :data:`NUMBER_RANGES`."""
    for option, value in _option_values(ctx):
        rng = NUMBER_RANGES.get(option)
        if rng is not None and not isinstance(value, tuple | list):
            rng.value(option, value)


def output_paths(ctx: Any) -> list[Path]:
    """The outputs a command names (:data:`OUTPUT_OPTIONS`), each once."""
    seen: dict[Path, Path] = {}
    for option, value in _option_values(ctx):
        if option in OUTPUT_OPTIONS and isinstance(value, str | os.PathLike):
            seen.setdefault(Path(value).resolve(), Path(value))
    return list(seen.values())
