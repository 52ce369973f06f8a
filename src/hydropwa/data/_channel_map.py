"""Channel maps: which logged variable or column becomes which channel, and how.

A channel map is a TOML file::

    [map]
    name = "emps"                  # optional
    description = "EMPS benchmark"  # optional
    fs = 1000.0                     # optional nominal rate [Hz]; makes 't' optional
    keep_unmapped = false           # copy unmapped 1-D variables of length N as-is

    [meta]                          # merged into every run's metadata
    rig = "EMPS"

    [channels.x]
    source = "qm"                   # variable, column name or struct path
    unit = "m"                      # unit of gain * raw + offset (default: SI of the channel)

    [channels.f_m]
    source = "vir"
    unit = "N"
    gain = "@gtau"                  # a number, or "@var": a scalar variable of the file
    offset = 0.0

    [channels.p_a]
    source = "data"                 # a matrix logged with one signal per column
    column = 2                      # 1-based column (MATLAB convention)
    unit = "bar"
    gain = 25.0                     # bar/V for a 0-10 V sensor spanning 0-250 bar

Struct paths reach into dSPACE/Simulink exports: ``"rec.X.Data"``, ``"rec.Y(3).Data"``
(1-based element) or ``"rec.Y{p_A}.Data"`` (the element whose ``Name`` is ``p_A``).
A channel's value is ``gain * raw + offset`` in ``unit``, then converted to SI.
"""

from __future__ import annotations

import dataclasses
import os
import re
import tomllib
from collections.abc import Mapping
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from hydropwa._errors import DataError
from hydropwa._io import read_text

from ._run import Run
from ._units import CANONICAL_UNITS

__all__ = ["ChannelMap", "ChannelSpec", "builtin_channel_map", "resolve_channel_map"]

_TOKEN = re.compile(r"^(?P<name>[A-Za-z_][\w]*)(?:\((?P<index>\d+)\)|\{(?P<label>[^{}]+)\})?$")
_SPEC_KEYS = {"source", "column", "unit", "gain", "offset"}


@dataclasses.dataclass(frozen=True)
class ChannelSpec:
    """How to obtain one channel from a raw file.

    Parameters
    ----------
    channel : str
        Channel name in the run (``"p_a"``).
    source : str
        Variable, column name or struct path in the file.
    column : int, optional
        1-based column when ``source`` is a matrix with one signal per column.
    unit : str, optional
        Unit of ``gain * raw + offset``; defaults to the channel's SI unit.
    gain : float or str
        Gain [unit per raw unit, e.g. bar/V], or ``"@name"`` for a scalar in the file.
    offset : float or str
        Offset [unit], or ``"@name"``.
    """

    channel: str
    source: str
    column: int | None = None
    unit: str | None = None
    gain: float | str = 1.0
    offset: float | str = 0.0


@dataclasses.dataclass(frozen=True)
class ChannelMap:
    """A set of :class:`ChannelSpec` plus metadata for the runs it produces.

    Parameters
    ----------
    channels : dict[str, ChannelSpec]
        Spec per channel name.
    meta : dict
        Metadata merged into each run; the map wins over metadata found in the file.
    name : str
        Name of the map (recorded in run metadata as ``channel_map``).
    fs : float, optional
        Nominal sampling rate [Hz]; when ``t`` is not mapped, ``t = k / fs``.
    keep_unmapped : bool
        Also copy unmapped 1-D numeric variables of length N (unit ``"1"``).
    """

    channels: dict[str, ChannelSpec]
    meta: dict[str, Any] = dataclasses.field(default_factory=dict)
    name: str = ""
    fs: float | None = None
    keep_unmapped: bool = False

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any], origin: str = "channel map") -> ChannelMap:
        """Build a map from the parsed TOML document (see the module docstring)."""
        if not isinstance(doc, Mapping):
            raise DataError(
                f"{origin}: expected a table with [channels.<name>] entries, got "
                f"{type(doc).__name__}; hint: see the channel-map format in the docs"
            )
        head = doc.get("map", {})
        if not isinstance(head, Mapping):
            raise DataError(f"{origin}: [map] must be a table, got {type(head).__name__}")
        chans = doc.get("channels")
        if not isinstance(chans, Mapping) or not chans:
            raise DataError(
                f"{origin}: no [channels.<name>] tables; hint: add e.g. "
                '[channels.x] with source = "qm" and unit = "m"'
            )
        specs = {}
        for ch, body in chans.items():
            if isinstance(body, str):
                body = {"source": body}
            if not isinstance(body, Mapping):
                raise DataError(
                    f"{origin}, channel {ch!r}: expected a table or a source name, got "
                    f'{type(body).__name__}; hint: write [channels.{ch}] with source = "..."'
                )
            unknown = sorted(map(str, set(body) - _SPEC_KEYS))
            if unknown or "source" not in body:
                raise DataError(
                    f"{origin}, channel {ch!r}: keys {unknown} unknown or 'source' "
                    f"missing; hint: allowed keys are {sorted(_SPEC_KEYS)}"
                )
            column = body.get("column")
            if column is not None and (
                not isinstance(column, int) or isinstance(column, bool) or column < 1
            ):
                raise DataError(
                    f"{origin}, channel {ch!r}: column = {column!r}; "
                    "hint: columns are 1-based integers"
                )
            unit = body.get("unit")
            if unit is not None and not isinstance(unit, str):
                raise DataError(
                    f'{origin}, channel {ch!r}: unit = {unit!r}; hint: give the unit as a string, e.g. "bar"'
                )
            for what in ("gain", "offset"):
                _check_factor(body.get(what, 0.0), f"{origin}, channel {ch!r}", what)
            specs[ch] = ChannelSpec(
                channel=str(ch),
                source=str(body["source"]),
                column=column,
                unit=unit,
                gain=body.get("gain", 1.0),
                offset=body.get("offset", 0.0),
            )
        fs = head.get("fs")
        if fs is not None:
            if (
                isinstance(fs, bool)
                or not isinstance(fs, int | float)
                or not (np.isfinite(fs) and fs > 0)
            ):
                raise DataError(
                    f"{origin}: [map] fs = {fs!r}; hint: give the sampling rate in Hz, > 0"
                )
        keep = head.get("keep_unmapped", False)
        if not isinstance(keep, bool):
            raise DataError(
                f"{origin}: [map] keep_unmapped = {keep!r}; hint: write true or false (no quotes)"
            )
        meta = doc.get("meta", {})
        if not isinstance(meta, Mapping):
            raise DataError(f"{origin}: [meta] must be a table, got {type(meta).__name__}")
        return cls(
            channels=specs,
            meta=dict(meta),
            name=str(head.get("name", "")),
            fs=None if fs is None else float(fs),
            keep_unmapped=keep,
        )

    @classmethod
    def from_toml(cls, path) -> ChannelMap:
        """Read a channel map from a TOML file."""
        path = Path(path)
        try:
            doc = tomllib.loads(read_text(path, "channel map", DataError))
        except OSError as exc:
            raise DataError(
                f"channel map {str(path)!r}: cannot be read ({exc.strerror}); hint: check the path"
            ) from exc
        except tomllib.TOMLDecodeError as exc:
            raise DataError(
                f"channel map {str(path)!r}: invalid TOML ({exc}); "
                "hint: fix the syntax at the position given"
            ) from exc
        except UnicodeDecodeError as exc:
            raise DataError(
                f"channel map {str(path)!r}: byte {exc.start} is not UTF-8 text; hint: give the "
                "map's TOML file (saved as UTF-8)"
            ) from None
        except RecursionError:
            raise DataError(
                f"channel map {str(path)!r}: nested too deeply to be a channel map"
            ) from None
        return cls.from_dict(doc, origin=f"channel map {str(path)!r}")

    # ------------------------------------------------------------------ apply
    def apply(
        self, raw: Mapping[str, Any], name: str, meta: Mapping | None = None, where: str = ""
    ) -> Run:
        """Build a run from raw variables.

        Parameters
        ----------
        raw : dict[str, Any]
            Variables of the file (arrays, scalars, nested dicts/lists for structs).
        name : str
            Run name.
        meta : dict, optional
            Metadata from the file, merged under the map's ``meta``.
        where : str
            Description of the file for error messages.

        Returns
        -------
        Run
            Channels in SI units.
        """
        where = where or f"run {name!r}"
        arrays: dict[str, np.ndarray] = {}
        units: dict[str, str] = {}
        for ch, spec in self.channels.items():
            here = f"{where}, channel {ch!r} (source {spec.source!r})"
            values = _column(_lookup(raw, spec.source, here), spec.column, here)
            gain = _scalar(raw, spec.gain, here, "gain")
            offset = _scalar(raw, spec.offset, here, "offset")
            arrays[ch] = values * gain + offset if (gain != 1.0 or offset != 0.0) else values
            unit = spec.unit if spec.unit is not None else CANONICAL_UNITS.get(ch)
            if unit is None:
                raise DataError(f'{here}: no unit; hint: add unit = "..." to [channels.{ch}]')
            units[ch] = unit
        if "t" not in arrays:
            n = len(next(iter(arrays.values())))
            if self.fs is None:
                raise DataError(
                    f"{where}: the channel map maps no 't' and gives no fs; "
                    "hint: add [channels.t] or fs = <Hz> under [map]"
                )
            arrays["t"], units["t"] = np.arange(n) / self.fs, "s"
        if self.keep_unmapped:
            n = len(arrays["t"])
            used = {s.source for s in self.channels.values()}
            for key, val in raw.items():
                arr = np.asarray(val) if not isinstance(val, dict | list | str) else None
                if (
                    key not in used
                    and key not in arrays
                    and not key.startswith("_")
                    and arr is not None
                    and arr.dtype.kind in "biuf"
                    and arr.size == n
                    and max(arr.shape, default=0) == n
                ):
                    arrays[key], units[key] = arr.reshape(-1).astype(float), "1"
        merged = dict(meta or {})
        merged.update(self.meta)
        if self.name:
            merged.setdefault("channel_map", self.name)
        return Run.from_arrays(name, arrays, units, fs=self.fs, meta=merged)


def _lookup(raw: Mapping[str, Any], path: str, where: str):
    node: Any = raw
    for token in path.split("."):
        m = _TOKEN.match(token.strip())
        if m is None:
            raise DataError(
                f"{where}: cannot parse path element {token!r}; "
                "hint: use name, name(3) or name{Label}"
            )
        key = m.group("name")
        if not isinstance(node, Mapping) or key not in node:
            have = (
                sorted(k for k in node if not str(k).startswith("__"))
                if isinstance(node, Mapping)
                else []
            )
            raise DataError(
                f"{where}: variable {key!r} not found (have {have}); "
                "hint: fix 'source' in the channel map"
            )
        node = node[key]
        if m.group("index") is not None or m.group("label") is not None:
            items = list(node) if isinstance(node, list | np.ndarray) else [node]
            if m.group("index") is not None:
                i = int(m.group("index"))
                if not 1 <= i <= len(items):
                    raise DataError(
                        f"{where}: index {i} out of range 1..{len(items)} for {key!r}; "
                        "hint: indices are 1-based"
                    )
                node = items[i - 1]
            else:
                label = m.group("label")
                hits = [
                    it
                    for it in items
                    if isinstance(it, Mapping)
                    and str(it.get("Name", it.get("name", ""))).strip() == label
                ]
                if len(hits) != 1:
                    raise DataError(
                        f"{where}: {len(hits)} elements of {key!r} are named {label!r}; "
                        "hint: use a 1-based index instead, e.g. Y(2)"
                    )
                node = hits[0]
    return node


def _column(node, column: int | None, where: str) -> np.ndarray:
    if np.iscomplexobj(node):
        raise DataError(
            f"{where}: the values are complex; a measured signal is real; hint: store the real "
            "part or the magnitude explicitly"
        )
    try:
        arr = np.asarray(node, dtype=float)
    except (TypeError, ValueError) as exc:
        raise DataError(f"{where}: not a numeric array; hint: point 'source' at a signal") from exc
    if arr.ndim == 2 and column is None and 1 in arr.shape:
        return arr.reshape(-1)
    if arr.ndim == 1 and column is None:
        return arr
    if arr.ndim == 2 and column is not None:
        # Real-time targets log either (N, M) or (M, N); signals run along the long axis.
        mat = arr if arr.shape[0] >= arr.shape[1] else arr.T
        if not 1 <= column <= mat.shape[1]:
            raise DataError(
                f"{where}: column {column} out of range 1..{mat.shape[1]}; "
                "hint: columns are 1-based"
            )
        return mat[:, column - 1].copy()
    raise DataError(
        f"{where}: has shape {arr.shape}; hint: "
        + (
            "give column = <1-based index> for a matrix"
            if arr.ndim == 2
            else "point 'source' at a vector signal"
        )
    )


def _check_factor(value, where: str, what: str) -> None:
    """A gain or offset is a finite number or an ``"@variable"`` reference."""
    if isinstance(value, str) and value.startswith("@"):
        return
    if isinstance(value, bool) or not isinstance(value, int | float) or not np.isfinite(value):
        raise DataError(
            f"{where}: {what} = {value!r:.60}; hint: give a finite number or '@variable'"
        )


def _scalar(raw: Mapping[str, Any], value: float | str, where: str, what: str) -> float:
    if not isinstance(value, str):
        _check_factor(value, where, what)
    if isinstance(value, str):
        if not value.startswith("@"):
            raise DataError(f"{where}: {what} = {value!r}; hint: give a number or '@variable'")
        try:
            node = _lookup(raw, value[1:], f"{where}, {what} {value!r}")
            if np.iscomplexobj(node):
                raise TypeError("complex")
            arr = np.asarray(node, dtype=float)
        except (TypeError, ValueError):
            raise DataError(
                f"{where}: {what} {value!r} is not numeric; hint: reference a 1x1 numeric variable"
            ) from None
        if arr.size != 1:
            raise DataError(
                f"{where}: {what} {value!r} has {arr.size} values, expected one scalar; "
                "hint: reference a 1x1 variable"
            )
        return float(arr.reshape(-1)[0])
    return float(value)


def builtin_channel_map(name: str) -> ChannelMap:
    """Return a channel map shipped with the package (``"emps"``).

    Parameters
    ----------
    name : str
        Stem of a TOML file in ``hydropwa/data/channel_maps``.
    """
    res = resources.files("hydropwa.data").joinpath("channel_maps").joinpath(f"{name}.toml")
    if not res.is_file():
        raise DataError(f"no built-in channel map {name!r}; hint: the package ships 'emps'")
    return ChannelMap.from_dict(
        tomllib.loads(res.read_text(encoding="utf-8")), origin=f"built-in channel map {name!r}"
    )


def resolve_channel_map(channel_map: ChannelMap | str | os.PathLike | None) -> ChannelMap | None:
    """Accept a map, a TOML path, or the name of a built-in map (``"emps"``)."""
    if channel_map is None or isinstance(channel_map, ChannelMap):
        return channel_map
    path = Path(channel_map)
    if not path.exists() and not path.suffix and path.name == str(channel_map):
        return builtin_channel_map(str(channel_map))
    return ChannelMap.from_toml(path)
