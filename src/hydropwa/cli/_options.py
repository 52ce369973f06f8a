"""The option vocabulary shared by the ``hydropwa`` commands.

``--params PRESET|FILE`` (short ``-p``) names the parameter set on every command that takes
one, and :func:`resolve_params` is the one function that reads it: a preset name
(``paper``, ``symmetric``), a parameter TOML file, or a JSON file (a parameter document as
``SystemParams.to_dict`` writes it, or a PWA JSON export, whose parameters are used).
``--base-params`` is the old name used by ``identify``: hidden, still accepted, with one
``warning:`` line (:func:`params_source`).
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Annotated

import typer

from .._errors import ParameterError
from ..params import PRESETS, SystemParams, get_preset, load_params, params_from_dict

__all__ = [
    "BaseParamsAlias",
    "MACHINE_PARAMS_HELP",
    "MachineParamsOption",
    "DEFAULT_PRESET",
    "PARAMS_HELP",
    "PARAMS_METAVAR",
    "PRESET_NAMES",
    "ParamsOption",
    "params_source",
    "resolve_params",
]

#: Default when ``--params`` is not given.
DEFAULT_PRESET = "paper"

#: The presets, as help texts and errors list them.
PRESET_NAMES = ", ".join(PRESETS)
#: How help texts show the value of ``--params``.
PARAMS_METAVAR = "PRESET|FILE"
PARAMS_HELP = (
    f"Parameter set: a preset ({PRESET_NAMES}) or a TOML/JSON parameter file "
    f"(default: {DEFAULT_PRESET})."
)


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
        data = json.loads(path.read_text(encoding="utf-8"))
    except UnicodeDecodeError:
        raise ParameterError(f"{path}: not a text file; expected a JSON parameter file") from None
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
        JSON file; ``None`` gives the ``paper`` preset. A file of that name wins over a preset.
    option : str
        The option or argument named in error messages.

    Raises
    ------
    ParameterError
        One line naming ``source`` and the presets, when it is neither; or the file's error.
    """
    if source is None:
        return get_preset(DEFAULT_PRESET)
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
