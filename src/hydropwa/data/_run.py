"""The measurement run: named channels in SI units, a sampling rate and metadata."""

from __future__ import annotations

import copy
import dataclasses
import json
import re
from collections.abc import Mapping
from typing import Any

import numpy as np

from hydropwa._errors import DataError

from .._display import channel_rows, html_table
from ._units import CANONICAL_UNITS, normalize_unit, to_si

__all__ = ["Run", "parse_column_label", "format_column_label"]

_LABEL = re.compile(r"^\s*(?P<name>[^\[\]]+?)\s*(?:\[(?P<unit>[^\[\]]*)\])?\s*$")


def parse_column_label(label: str) -> tuple[str, str | None]:
    """Split a column label ``"p_a [bar]"`` into ``("p_a", "bar")``; no unit gives ``None``."""
    m = _LABEL.match(str(label))
    if m is None:
        raise DataError(
            f"column label {label!r} is malformed; hint: write it as 'name [unit]', e.g. 'p_a [bar]'"
        )
    unit = m.group("unit")
    return m.group("name"), (unit.strip() if unit is not None else None)


def format_column_label(name: str, unit: str) -> str:
    """Return the column label ``"name [unit]"`` used by the CSV format."""
    return f"{name} [{unit}]"


def _as_channel(name: str, run: str, values) -> np.ndarray:
    if np.iscomplexobj(values):
        raise DataError(
            f"run {run!r}, channel {name!r}: the values are complex; a measured signal is real; "
            "hint: store the real part or the magnitude explicitly"
        )
    try:
        arr = np.array(values, dtype=float)
    except (TypeError, ValueError) as exc:
        raise DataError(
            f"run {run!r}, channel {name!r}: values are not numeric ({exc}); "
            "hint: check the file for text in a numeric column"
        ) from exc
    if arr.ndim == 2 and 1 in arr.shape:
        arr = arr.reshape(-1)
    if arr.ndim != 1:
        raise DataError(
            f"run {run!r}, channel {name!r}: expected a 1-D signal, got shape {arr.shape}; "
            "hint: split a matrix into one channel per column with a channel map"
        )
    arr.setflags(write=False)
    return arr


def _check_json(meta: Mapping, run: str) -> dict:
    try:
        return json.loads(json.dumps(dict(meta), allow_nan=False))
    except (TypeError, ValueError) as exc:
        raise DataError(
            f"run {run!r}: metadata is not JSON-serialisable ({exc}); "
            "hint: keep metadata to str, finite numbers, bools, None, lists and dicts"
        ) from exc


@dataclasses.dataclass(frozen=True, eq=False)
class Run:
    """One measured or simulated experiment.

    Parameters
    ----------
    name : str
        Run name, unique inside a dataset (used as file stem).
    channels : dict[str, numpy.ndarray]
        Samples by channel name, each shape (N,), in SI units. ``t`` [s] is required.
        Canonical channels: ``t`` [s], ``u`` [1], ``spool`` [1], ``z`` [1], ``x`` [m],
        ``v`` [m/s], ``p_a``, ``p_b``, ``p_s``, ``p_l`` [Pa], ``f_l`` [N]; others allowed.
    units : dict[str, str]
        SI unit per channel. Canonical channels may be left out (their unit is fixed);
        giving them a non-SI unit is an error (convert with :meth:`from_pandas` or the
        readers, which convert at the boundary).
    fs : float, optional
        Nominal sampling rate [Hz]. Estimated from the median time step when omitted.
    meta : dict, optional
        JSON-serialisable metadata. Conventional keys: ``kind`` (experiment kind, e.g.
        ``"step"``, ``"stribeck"``), ``signal`` (commanded signal and its parameters),
        ``rig`` and ``sensors`` (descriptions), ``true_params`` (simulated runs), ``source``.

    Notes
    -----
    The arrays are stored read-only; methods return new runs. No validation of
    the samples happens here (see :func:`hydropwa.data.validate_run`).
    """

    name: str
    channels: dict[str, np.ndarray]
    units: dict[str, str] = dataclasses.field(default_factory=dict)
    fs: float | None = None
    meta: dict[str, Any] = dataclasses.field(default_factory=dict)

    def __post_init__(self) -> None:
        name = str(self.name)
        if not name or "/" in name or "\\" in name:
            raise DataError(
                f"run name {name!r} is invalid; hint: use a non-empty name without slashes"
            )
        if "t" not in self.channels:
            raise DataError(
                f"run {name!r}: has no time channel 't' (channels: {sorted(self.channels)}); "
                "hint: name the time column 't' or map it with a channel map"
            )
        chans = {str(k): _as_channel(str(k), name, v) for k, v in self.channels.items()}
        n = len(chans["t"])
        for k, v in chans.items():
            if len(v) != n:
                raise DataError(
                    f"run {name!r}, channel {k!r}: has {len(v)} samples but 't' has {n}; "
                    "hint: all channels of a run must share the time base"
                )
        units = self._check_units(name, chans, self.units)
        fs = self._nominal_fs(name, chans["t"], self.fs)
        object.__setattr__(self, "name", name)
        object.__setattr__(self, "channels", chans)
        object.__setattr__(self, "units", units)
        object.__setattr__(self, "fs", fs)
        object.__setattr__(self, "meta", _check_json(self.meta or {}, name))

    @staticmethod
    def _check_units(name: str, chans: Mapping, given: Mapping[str, str]) -> dict[str, str]:
        units: dict[str, str] = {}
        for k in chans:
            canon = CANONICAL_UNITS.get(k)
            unit = normalize_unit(given[k]) if k in given else canon
            if unit is None:
                raise DataError(
                    f"run {name!r}, channel {k!r}: no unit given; hint: pass units={{{k!r}: 'unit'}}"
                )
            if canon is not None and unit != canon:
                raise DataError(
                    f"run {name!r}, channel {k!r}: unit {unit!r} inside a Run, expected SI {canon!r}; "
                    "hint: build runs with Run.from_pandas or a reader, which convert units"
                )
            units[k] = unit
        extra = sorted(set(given) - set(chans))
        if extra:
            raise DataError(
                f"run {name!r}: units given for missing channels {extra}; hint: drop them"
            )
        return units

    @staticmethod
    def _nominal_fs(name: str, t: np.ndarray, fs: float | None) -> float:
        if fs is not None:
            try:
                fs = float(fs)
            except (TypeError, ValueError):
                raise DataError(
                    f"run {name!r}: sampling rate fs = {fs!r:.60} is not a number; "
                    "hint: give fs > 0 in Hz"
                ) from None
            if not np.isfinite(fs) or fs <= 0:
                raise DataError(
                    f"run {name!r}: sampling rate fs = {fs} Hz; hint: give fs > 0 in Hz"
                )
            return fs
        dt = np.diff(t)
        dt = dt[np.isfinite(dt) & (dt > 0)]
        # 12 significant digits: 1 / median(diff(arange(n) / 1000)) is 999.9999999999991.
        return float(f"{1.0 / np.median(dt):.12g}") if dt.size else float("nan")

    # ------------------------------------------------------------------ access
    @property
    def t(self) -> np.ndarray:
        """Time stamps [s], shape (N,)."""
        return self.channels["t"]

    @property
    def n_samples(self) -> int:
        """Number of samples N."""
        return len(self.t)

    @property
    def duration(self) -> float:
        """Time from first to last sample [s] (0 for fewer than two samples)."""
        return float(self.t[-1] - self.t[0]) if self.n_samples > 1 else 0.0

    @property
    def kind(self) -> str | None:
        """Experiment kind from ``meta["kind"]``, or ``None``."""
        kind = self.meta.get("kind")
        return None if kind is None else str(kind)

    def __getitem__(self, channel: str) -> np.ndarray:
        try:
            return self.channels[channel]
        except KeyError:
            raise DataError(
                f"run {self.name!r}: no channel {channel!r} (has {sorted(self.channels)}); "
                "hint: check the channel map or use Run.has() first"
            ) from None

    def __repr__(self) -> str:
        chans = ", ".join(k for k in self.channels if k != "t")
        fs = f" at {self.fs:g} Hz" if self.fs else ""
        return f"Run({self.name!r}, {self.n_samples} samples, {self.duration:.4g} s{fs}; {chans})"

    def _repr_html_(self) -> str:
        kind = f", kind {self.kind}" if self.kind else ""
        title = f"Run {self.name!r}: {self.n_samples} samples, {self.duration:.4g} s at {self.fs or 0:g} Hz{kind}"
        return html_table(
            title,
            ("channel", "unit", "min", "max"),
            channel_rows(self.channels, self.units),
            note="values in engineering units (SI inside)",
        )

    def has(self, channel: str) -> bool:
        """Whether the run holds ``channel``."""
        return channel in self.channels

    def replace(self, **changes) -> Run:
        """Return a copy with fields replaced (``channels``, ``units``, ``fs``, ``meta``, ``name``)."""
        fields: dict[str, Any] = {
            "name": self.name,
            "channels": dict(self.channels),
            "units": dict(self.units),
            "fs": self.fs,
            "meta": copy.deepcopy(self.meta),
        }
        fields.update(changes)
        return Run(**fields)

    # ------------------------------------------------------------------ pandas
    def to_pandas(self):
        """Return a :class:`pandas.DataFrame`, one column per channel (``t`` first).

        ``df.attrs`` holds ``name``, ``units``, ``fs`` [Hz] and ``meta``.
        """
        import pandas as pd  # deferred: pandas costs ~0.3 s at import

        df = pd.DataFrame({k: np.array(v) for k, v in self.channels.items()})
        df.attrs.update(
            name=self.name, units=dict(self.units), fs=self.fs, meta=copy.deepcopy(self.meta)
        )
        return df

    @classmethod
    def from_pandas(
        cls,
        df,
        units: Mapping[str, str] | None = None,
        name: str | None = None,
        meta: Mapping | None = None,
        fs: float | None = None,
    ) -> Run:
        """Build a run from a data frame, converting units to SI.

        Parameters
        ----------
        df : pandas.DataFrame
            One column per channel. Column labels may carry the unit, ``"p_a [bar]"``.
        units : dict[str, str], optional
            Unit per channel name (overrides labels and ``df.attrs["units"]``).
            Canonical channels default to their SI unit; extra channels need a unit.
        name : str, optional
            Run name (default ``df.attrs["name"]`` or ``"run"``).
        meta : dict, optional
            Metadata (default ``df.attrs["meta"]``).
        fs : float, optional
            Nominal sampling rate [Hz] (default ``df.attrs["fs"]``, else estimated).

        Returns
        -------
        Run
        """
        attrs = dict(getattr(df, "attrs", {}) or {})
        name = str(name if name is not None else attrs.get("name", "run"))
        declared = dict(attrs.get("units") or {})
        cols: dict[str, np.ndarray] = {}
        for label in df.columns:
            ch, unit = parse_column_label(str(label))
            if ch in cols:
                raise DataError(
                    f"run {name!r}: channel {ch!r} appears twice; hint: rename one column"
                )
            cols[ch] = df[label].to_numpy(dtype=float, copy=True)
            if unit is not None:
                declared[ch] = unit
        declared.update(units or {})
        return cls.from_arrays(
            name,
            cols,
            declared,
            fs=fs if fs is not None else attrs.get("fs"),
            meta=meta if meta is not None else attrs.get("meta") or {},
        )

    @classmethod
    def from_arrays(
        cls,
        name: str,
        channels: Mapping[str, np.ndarray],
        units: Mapping[str, str],
        fs: float | None = None,
        meta: Mapping | None = None,
    ) -> Run:
        """Build a run from arrays in declared (possibly non-SI) units; converts to SI.

        Parameters
        ----------
        name : str
            Run name.
        channels : dict[str, array_like]
            Samples per channel, shape (N,), in ``units``.
        units : dict[str, str]
            Declared unit per channel (e.g. ``"bar"``); canonical channels default to SI.
        fs : float, optional
            Nominal sampling rate [Hz].
        meta : dict, optional
            Metadata.
        """
        si_chans: dict[str, np.ndarray] = {}
        si_units: dict[str, str] = {}
        for ch, values in channels.items():
            unit = units.get(ch, CANONICAL_UNITS.get(ch))
            if unit is None:
                raise DataError(
                    f"run {name!r}, channel {ch!r}: no unit declared; "
                    f"hint: write the header as '{ch} [unit]' or give the unit in the channel map"
                )
            si_chans[ch], si_units[ch] = to_si(
                _as_channel(ch, name, values), unit, ch, f"run {name!r}, channel {ch!r}"
            )
        return cls(name=name, channels=si_chans, units=si_units, fs=fs, meta=dict(meta or {}))

    # ------------------------------------------------------------------ slicing
    def select(self, t0: float | None = None, t1: float | None = None) -> Run:
        """Return the samples with ``t0 <= t <= t1`` [s] (either bound may be ``None``)."""
        t = self.t
        keep = np.ones(t.shape, dtype=bool)
        if t0 is not None:
            keep &= t >= t0
        if t1 is not None:
            keep &= t <= t1
        if not keep.any():
            raise DataError(
                f"run {self.name!r}: no sample in [{t0}, {t1}] s (run spans "
                f"{t[0]:.6g} to {t[-1]:.6g} s); hint: pick a window inside the run"
            )
        return self.replace(channels={k: v[keep] for k, v in self.channels.items()})

    def resample(self, fs: float | None = None) -> Run:
        """Linearly interpolate every channel onto a uniform grid.

        Parameters
        ----------
        fs : float, optional
            New sampling rate [Hz]; defaults to the nominal ``self.fs``.

        Returns
        -------
        Run
            A run with ``t = t[0] + k / fs`` for ``k = 0 … floor(duration * fs)``.

        Raises
        ------
        DataError
            If time stamps are not strictly increasing or not finite.
        """
        nominal = self.fs if self.fs is not None else float("nan")
        fs = float(nominal if fs is None else fs)
        if not np.isfinite(fs) or fs <= 0:
            raise DataError(
                f"run {self.name!r}: cannot resample to fs = {fs} Hz; hint: give fs > 0"
            )
        t = self.t
        bad = np.flatnonzero(~np.isfinite(t))
        if bad.size:
            raise DataError(
                f"run {self.name!r}, channel 't', sample {bad[0]}: time stamp is not finite; "
                "hint: drop the sample (validate_run(..., drop_nonfinite_time=True)) before resampling"
            )
        dt = np.diff(t)
        bad = np.flatnonzero(dt <= 0)
        if bad.size:
            i = int(bad[0]) + 1
            raise DataError(
                f"run {self.name!r}, channel 't', sample {i} (t = {t[i]:.9g} s): time does not "
                "increase; hint: sort or drop duplicated samples before resampling "
                "(validate_run(..., drop_duplicates=True))"
            )
        n = int(np.floor(self.duration * fs * (1 + 1e-12))) + 1
        grid = t[0] + np.arange(n) / fs
        chans = {"t": grid}
        for k, v in self.channels.items():
            if k != "t":
                chans[k] = np.interp(grid, t, v)
        return self.replace(channels=chans, fs=fs)
