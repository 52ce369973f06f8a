"""Import of the EMPS benchmark measurements (real third-party data)."""

from __future__ import annotations

import os
from pathlib import Path

from ._channel_map import builtin_channel_map
from ._formats import read_run
from ._run import Run

__all__ = ["load_emps"]


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
