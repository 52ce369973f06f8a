"""Import of the EMPS benchmark measurements (real third-party data)."""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

from ._channel_map import ChannelMap
from ._formats import read_run
from ._run import Run

__all__ = ["load_emps", "builtin_channel_map"]


def builtin_channel_map(name: str) -> ChannelMap:
    """Return a channel map shipped with the package (``"emps"``).

    Parameters
    ----------
    name : str
        Stem of a TOML file in ``hydropwa/data/channel_maps``.
    """
    import tomllib

    from hydropwa._errors import DataError

    res = resources.files("hydropwa.data").joinpath("channel_maps").joinpath(f"{name}.toml")
    if not res.is_file():
        raise DataError(f"no built-in channel map {name!r}; hint: the package ships 'emps'")
    return ChannelMap.from_dict(tomllib.loads(res.read_text(encoding="utf-8")),
                                origin=f"built-in channel map {name!r}")


def load_emps(path: str | os.PathLike, name: str | None = None, *, validate: bool = True) -> Run:
    """Load ``DATA_EMPS.mat`` or ``DATA_EMPS_PULSES.mat`` through the built-in map.

    Parameters
    ----------
    path : path-like
        The benchmark ``.mat`` file.
    name : str, optional
        Run name (default: file stem).
    validate : bool
        Validate the run (raises :class:`~hydropwa._errors.DataError` on errors).

    Returns
    -------
    Run
        Channels ``t`` [s], ``x`` [m] (motor position ``qm`` on the load side),
        ``x_ref`` [m] (reference ``qg``), ``f_m`` [N] (motor force ``gtau * vir``)
        and, in the pulses file, ``pulses_N`` [1]; ``fs`` = 1000 Hz.
    """
    path = Path(path)
    run = read_run(path, builtin_channel_map("emps"), name=name or path.stem, validate=validate)
    return run
