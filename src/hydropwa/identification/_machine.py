"""The machine a dataset was measured on: no command identifies on a machine it guessed.

Identification needs the machine's geometry (areas, stroke, mass) and every value it does
not identify. They come from, in this order:

1. the caller (``params=`` / ``--params``), checked against what the data record;
2. the data: a campaign folder's ``true_params.toml`` (``hydropwa rig run`` writes it), the
   ``machine`` entry of a dataset's manifest (a parameter table, or the name of a parameter
   TOML file next to the manifest; ``hydropwa data convert --params`` writes it), or the
   ``true_params`` a simulated dataset records;
3. nowhere: :class:`~hydropwa.ParameterError` with one line saying how to give it.

There is no default machine: the paper's cylinder is used only when named.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from .._display import channel_unit
from .._errors import DataError, ParameterError
from ..params import SystemParams, load_params, params_from_dict

__all__ = ["MACHINE_FILE", "machine_for", "recorded_machine", "check_same_machine"]

#: The parameter file of a campaign folder (written by ``hydropwa rig run``).
MACHINE_FILE = "true_params.toml"

#: Relative tolerance on the geometry that must agree between the data and ``params``.
_GEOMETRY_RTOL = 0.01
_GEOMETRY = (
    ("cylinder.area_a", "piston area A_A", *channel_unit("m**2")),
    ("cylinder.area_b", "annulus area A_B", *channel_unit("m**2")),
    ("cylinder.stroke", "stroke", *channel_unit("m")),
)

HOW = (
    "give the machine's parameters with --params FILE (Python: params=load_params(FILE) or "
    "params=get_preset('paper')), or record them with the data (`hydropwa data convert "
    "--params FILE`)"
)


def _from_entry(entry: Any, folder: Path, where: str) -> SystemParams:
    """A manifest's ``machine``/``true_params`` entry: a parameter table or a file name."""
    if isinstance(entry, Mapping):
        return params_from_dict(dict(entry), source=where, check_bare=False)
    if isinstance(entry, str):
        from ..data import contained_path  # deferred: hydropwa.data loads pint

        try:
            path = contained_path(folder, entry, "machine file")
        except DataError as exc:
            raise ParameterError(f"{where}: {exc}") from None
        if not path.is_file():
            raise ParameterError(f"{where}: machine file {entry!r} not found in {str(folder)!r}")
        return load_params(path)
    raise ParameterError(
        f"{where} must be a parameter table or the name of a parameter file, "
        f"got {type(entry).__name__}"
    )


def _machine_file(folder: Path) -> SystemParams:
    """The campaign's ``true_params.toml`` in ``folder``; refused if a link leads out of it."""
    from ..data import contained_path  # deferred: hydropwa.data loads pint

    return load_params(contained_path(folder, MACHINE_FILE, "machine file"))


def _from_meta(meta: Any, folder: Path, where: str) -> SystemParams | None:
    if not isinstance(meta, Mapping):
        return None
    for key in ("machine", "true_params"):
        if meta.get(key) is not None:
            return _from_entry(meta[key], folder, f"{where} {key}")
    return None


def _agree(found: list[tuple[SystemParams, str]]) -> tuple[SystemParams, str] | None:
    if not found:
        return None
    first, src = found[0]
    for other, osrc in found[1:]:
        if other != first:
            raise ParameterError(
                f"{src} and {osrc} record different machines; "
                "give the one to use with --params FILE"
            )
    return first, src


def recorded_machine(data: Any) -> tuple[SystemParams, str] | None:
    """The machine the data record, and where it was found; ``None`` when they record none.

    Parameters
    ----------
    data : path-like, Dataset, or list of Run
        A campaign folder (``true_params.toml``, or datasets in sub-folders), a dataset folder
        (its manifest's ``machine`` or ``true_params`` entry, else the parent folder's
        ``true_params.toml``), a :class:`~hydropwa.data.Dataset`, or runs (their
        ``meta["true_params"]``/``meta["machine"]``).

    Raises
    ------
    ParameterError
        When the data record two different machines, or an entry that is not a parameter set.
    """
    from ..data import MANIFEST, Dataset  # deferred: hydropwa.data loads pint

    if isinstance(data, Dataset):
        root = Path(data.root)
        got = _from_meta(data.meta, root, f"{str(root / MANIFEST)!r}")
        return (got, str(root / MANIFEST)) if got is not None else None
    if not isinstance(data, str | os.PathLike):
        if not isinstance(data, list | tuple):
            return None  # an iterator is not consumed here
        found = []
        for run in data:
            got = _from_meta(getattr(run, "meta", None), Path.cwd(), f"run {run.name!r}")
            if got is not None:
                found.append((got, f"run {run.name!r}"))
        return _agree(found)
    root = Path(data)
    if not root.is_dir():
        return None
    if (root / MACHINE_FILE).is_file():
        return _machine_file(root), str(root / MACHINE_FILE)
    if (root / MANIFEST).is_file():
        folders = [root]
    else:
        folders = sorted(p for p in root.iterdir() if (p / MANIFEST).is_file())
    found = []
    for folder in folders:
        ds = Dataset(folder, validate=False)
        got = _from_meta(ds.meta, folder, f"{str(folder / MANIFEST)!r}")
        if got is not None:
            found.append((got, str(folder / MANIFEST)))
    if not found and (root / MANIFEST).is_file() and (root.parent / MACHINE_FILE).is_file():
        return _machine_file(root.parent), str(root.parent / MACHINE_FILE)
    return _agree(found)


def check_same_machine(
    params: SystemParams,
    recorded: SystemParams,
    source: str,
    holder: str = "the data's machine",
    fix: str = "give the parameters of the machine the data were measured on",
) -> None:
    """Refuse ``params`` whose geometry is not the recorded machine's (1 % on areas and stroke).

    Values that identification estimates (friction, valve, dead zone) may differ: ``params``
    is then the starting point; the geometry is what the data were measured on. ``holder``
    and ``fix`` word the error for other records of a machine (a PWA document).
    """
    for name, what, unit, scale in _GEOMETRY:
        comp, field = name.split(".")
        a = getattr(getattr(params, comp), field)
        b = getattr(getattr(recorded, comp), field)
        if abs(a - b) > _GEOMETRY_RTOL * abs(b):
            raise ParameterError(
                f"the parameters give {what} {a * scale:.4g} {unit}, {holder} "
                f"({source}) {b * scale:.4g} {unit}; {fix}"
            )


def machine_for(data: Any, params: SystemParams | None = None) -> SystemParams:
    """The machine to identify with: ``params`` checked against the data, else the data's.

    Parameters
    ----------
    data : path-like, Dataset, or list of Run
        See :func:`recorded_machine`.
    params : SystemParams, optional
        The caller's parameters (the starting values of what is identified).

    Returns
    -------
    SystemParams

    Raises
    ------
    ParameterError
        Without ``params`` when the data record no machine (one line saying how to give it),
        or when ``params``' areas or stroke differ from the recorded machine's by more than 1 %.
    """
    rec = recorded_machine(data)
    if params is None:
        if rec is None:
            where = (
                f"{str(data)!r} records"
                if isinstance(data, str | os.PathLike)
                else ("the runs record")
            )
            raise ParameterError(f"{where} no machine; {HOW}")
        machine, src = rec
        return machine.replace(meta={**machine.meta, "source": f"{src} (the data's machine)"})
    if rec is not None:
        check_same_machine(params, rec[0], rec[1])
    return params
