"""Validation of measured runs: time base, missing values, clipping, unit plausibility.

Nothing is repaired silently: :func:`check_run` only reports, :func:`validate_run`
raises on errors and repairs only what its flags ask for.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping

import numpy as np

from hydropwa._channels import CHANNEL, FLOOR_CHANNELS, RANGED_CHANNELS
from hydropwa._errors import DataError
from hydropwa._signal import mask_runs, stuck_at_rails

from ._run import Run

__all__ = [
    "Issue",
    "Plausible",
    "PLAUSIBLE_RANGES",
    "ValidationReport",
    "check_run",
    "screen_runs",
    "validate_run",
    "COMMAND_CHANNELS",
    "converter_limits",
    "unusable",
]

#: Channels that are commanded, not measured: not checked for clipping (a saturated
#: command is legitimate).
COMMAND_CHANNELS = frozenset({"u", "x_ref"})


@dataclasses.dataclass(frozen=True)
class Plausible:
    """Plausible range of a canonical channel in SI units.

    Parameters
    ----------
    lo, hi : float
        Smallest and largest plausible sample [SI unit of the channel].
    min_peak : float
        Smallest plausible peak ``max |value|`` when the channel is not all zero
        [SI unit]; catches bar declared as Pa.
    high_hint, low_hint : str
        Likely cause when ``hi`` is exceeded / the peak is below ``min_peak``.
    """

    lo: float
    hi: float
    min_peak: float = 0.0
    high_hint: str = "check the unit declared for this channel"
    low_hint: str = "check the unit declared for this channel"


#: Plausibility ranges per canonical channel, SI units (see ``docs/architecture_data.md``), from
#: the channel table (:data:`hydropwa._channels.CHANNELS`).
PLAUSIBLE_RANGES: dict[str, Plausible] = {
    c.name: Plausible(c.lo, c.hi, c.min_peak, c.high_hint, c.low_hint)
    for c in (CHANNEL[name] for name in RANGED_CHANNELS)
}


@dataclasses.dataclass(frozen=True)
class Issue:
    """One finding of a check.

    Attributes
    ----------
    severity : str
        ``"error"`` (validation fails), ``"warning"``, or ``"note"`` (a physical fact about
        the signal that needs no repair, e.g. a chamber cavitating below a gauge sensor's
        0 bar: ``hydropwa data check`` prints it and still passes).
    code : str
        Stable identifier, e.g. ``"time_duplicate"``, ``"nonfinite"``, ``"clipped"``.
    run : str
        Run name.
    channel : str or None
        Channel name.
    sample : int or None
        Index of the first offending sample.
    time : float or None
        Time of that sample [s].
    message : str
        What is wrong.
    hint : str
        How to fix it.
    """

    severity: str
    code: str
    run: str
    channel: str | None
    sample: int | None
    time: float | None
    message: str
    hint: str

    def __str__(self) -> str:
        where = f"run {self.run!r}"
        if self.channel is not None:
            where += f", channel {self.channel!r}"
        if self.sample is not None:
            where += f", sample {self.sample}"
            if self.time is not None and np.isfinite(self.time):
                where += f" (t = {self.time:.6g} s)"
        return f"{where}: {self.message}; hint: {self.hint}"


@dataclasses.dataclass(frozen=True)
class ValidationReport:
    """Result of :func:`validate_run`.

    Attributes
    ----------
    run : Run
        The run after the requested repairs (the input run when none was asked for).
    issues : list[Issue]
        Remaining findings (warnings only when validation passed).
    repairs : list[str]
        Repairs applied, one sentence each.
    """

    run: Run
    issues: list[Issue]
    repairs: list[str]

    @property
    def ok(self) -> bool:
        """True when no error remains."""
        return not any(i.severity == "error" for i in self.issues)


def _issue(
    run: Run, code: str, channel, sample, message: str, hint: str, severity: str = "error"
) -> Issue:
    t = None
    if sample is not None:
        sample = int(sample)
        t = float(run.t[sample]) if 0 <= sample < run.n_samples else None
    return Issue(severity, code, run.name, channel, sample, t, message, hint)


# ---------------------------------------------------------------------- checks
def _check_time(run: Run, dt_rtol: float, gap_factor: float, fs_rtol: float) -> list[Issue]:
    t = run.t
    out: list[Issue] = []
    if run.n_samples < 2:
        return [
            _issue(
                run,
                "too_short",
                "t",
                None,
                f"only {run.n_samples} sample(s)",
                "a run needs at least two samples",
            )
        ]
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        out.append(
            _issue(
                run,
                "time_not_finite",
                "t",
                bad[0],
                f"time stamp is NaN/inf ({bad.size} such samples)",
                "drop these samples explicitly (validate_run(..., drop_duplicates=True) "
                "also drops non-finite time stamps)",
            )
        )
        return out
    dt = np.diff(t)
    for code, mask, what in (
        ("time_duplicate", dt == 0, "repeats the previous time stamp"),
        ("time_decreasing", dt < 0, "time goes backwards"),
    ):
        idx = np.flatnonzero(mask)
        if idx.size:
            i = idx[0] + 1
            out.append(
                _issue(
                    run,
                    code,
                    "t",
                    i,
                    f"{what} (t[{i - 1}] = {t[i - 1]:.9g} s, t[{i}] = {t[i]:.9g} s; "
                    f"{idx.size} such samples)",
                    "drop duplicated samples with validate_run(..., drop_duplicates=True)"
                    if code == "time_duplicate"
                    else "the file interleaves or concatenates logs; split it or sort by time",
                )
            )
    if out:
        return out
    return _check_steps(run, dt, dt_rtol, gap_factor, fs_rtol)


def _check_steps(
    run: Run, dt: np.ndarray, dt_rtol: float, gap_factor: float, fs_rtol: float
) -> list[Issue]:
    """Gaps, non-uniform steps and a declared fs the steps contradict (time increasing)."""
    out: list[Issue] = []
    step = float(np.median(dt))
    gaps = np.flatnonzero(dt > gap_factor * step)
    if gaps.size:
        i = gaps[0] + 1
        out.append(
            _issue(
                run,
                "time_gap",
                "t",
                i,
                f"gap in time: t jumps {dt[i - 1]:.6g} s from sample {i - 1} "
                f"(median step {step:.6g} s; {gaps.size} gaps)",
                "samples are missing; split the run with select(), or interpolate across "
                "with validate_run(..., resample=True) if that is acceptable",
            )
        )
    jitter = np.flatnonzero((np.abs(dt - step) > dt_rtol * step) & (dt <= gap_factor * step))
    if jitter.size:
        i = jitter[0] + 1
        out.append(
            _issue(
                run,
                "time_nonuniform",
                "t",
                i,
                f"non-uniform sampling: step {dt[i - 1]:.6g} s vs median {step:.6g} s "
                f"(tolerance {dt_rtol:.0%}; {jitter.size} such steps)",
                "resample explicitly with validate_run(..., resample=True) or Run.resample(fs)",
            )
        )
    if run.fs is not None and np.isfinite(run.fs) and abs(run.fs * step - 1.0) > fs_rtol:
        out.append(
            _issue(
                run,
                "fs_mismatch",
                "t",
                None,
                f"declared fs = {run.fs:.6g} Hz but the median step gives {1 / step:.6g} Hz",
                "fix fs in the file metadata or channel map",
                severity="warning",
            )
        )
    return out


def _check_finite(run: Run, channel: str) -> list[Issue]:
    v = run.channels[channel]
    bad = np.flatnonzero(~np.isfinite(v))
    if not bad.size:
        return []
    return [
        _issue(
            run,
            "nonfinite",
            channel,
            bad[0],
            f"{bad.size} NaN/inf value(s) (missing samples), first here",
            "interpolate them explicitly with validate_run(..., interpolate_gaps=True) "
            "or cut the run with select()",
        )
    ]


def _check_clipping(
    run: Run, channel: str, min_samples: int, floor_known: bool = False
) -> list[Issue]:
    out = []
    for side, level, starts, lengths in stuck_at_rails(run.channels[channel], min_samples):
        if side == "minimum" and floor_known:
            continue  # the converter-limit check found a physical floor there
        out.append(
            _issue(
                run,
                "clipped",
                channel,
                starts[0],
                f"stuck at its {side} {level:.6g} {run.units[channel]} for "
                f"{int(lengths[0])} samples ({lengths.size} such stretches)",
                "the sensor or ADC saturated; re-measure with a larger range or "
                "exclude the stretch with select()",
            )
        )
    return out


def _check_range(run: Run, channel: str, rng: Plausible) -> list[Issue]:
    v = run.channels[channel]
    fin = np.isfinite(v)
    if not fin.any():
        return []
    unit = run.units[channel]
    out = []
    outside = np.flatnonzero(fin & ((v > rng.hi) | (v < rng.lo)))
    if outside.size:
        i = outside[0]
        hint = (
            rng.high_hint
            if v[i] > rng.hi
            else ("check the sensor offset and sign, and the declared unit")
        )
        out.append(
            _issue(
                run,
                "implausible_magnitude",
                channel,
                i,
                f"value {v[i]:.6g} {unit} outside the plausible range "
                f"[{rng.lo:.6g}, {rng.hi:.6g}] {unit} ({outside.size} samples)",
                hint,
            )
        )
    peak = float(np.max(np.abs(v[fin])))
    if 0.0 < peak < rng.min_peak:
        i = int(np.flatnonzero(fin & (np.abs(v) == peak))[0])
        out.append(
            _issue(
                run,
                "implausible_magnitude",
                channel,
                i,
                f"peak |value| {peak:.6g} {unit} is below {rng.min_peak:.6g} {unit}, "
                "far below any working value",
                rng.low_hint,
            )
        )
    return out


def check_run(
    run: Run,
    *,
    dt_rtol: float = 0.01,
    gap_factor: float = 1.5,
    fs_rtol: float = 0.01,
    clip_min_samples: int = 10,
    ranges: Mapping[str, Plausible] | None = None,
    no_clip_check: Iterable[str] = COMMAND_CHANNELS,
    stuck_min_samples: int = 100,
    spike_factor: float = 30.0,
    limits: Mapping[str, tuple[float, float]] | None = None,
    measured: bool | None = None,
) -> list[Issue]:
    """Check a run and return every finding; never raises for bad data.

    Parameters
    ----------
    run : Run
        The run to check.
    dt_rtol : float
        Allowed relative deviation of a time step from the median step [1].
    gap_factor : float
        A step longer than ``gap_factor`` median steps is a gap (missing samples) [1].
    fs_rtol : float
        Allowed relative mismatch between the declared ``fs`` and the median step [1].
    clip_min_samples : int
        Samples in a row at the channel's extreme that count as clipping.
    ranges : dict[str, Plausible], optional
        Plausible ranges per channel; default :data:`PLAUSIBLE_RANGES`.
    no_clip_check : iterable of str
        Channels not checked for clipping, dropouts and spikes (commanded signals).
    stuck_min_samples : int
        Identical samples in a row, anywhere in the range, that count as a dropout (a
        channel stuck at its last value) when the channel otherwise changes every sample.
    spike_factor : float
        A sample is a spike when it leaves the mean of its two neighbours, which agree with
        each other, by more than this many robust noise scales of the channel.
    limits : dict[str, (float, float)], optional
        Lowest and highest value each channel's converter can record [SI unit]; default
        ``run.meta["converter_limits"]`` (the virtual rig writes them). A channel at one of
        them for ``clip_min_samples`` or more, the whole run included, is clipped.
    measured : bool, optional
        Whether the run comes from sensors. The sensor-fault checks (clipping, dropouts,
        spikes) look for what sensors and converters do to a signal; a simulation's
        noise-free channels have exact plateaus and kinks that these heuristics mistake for
        faults, so they are skipped for ``meta["source"] == "simulation"`` (the default
        ``None`` reads that key). Time base, NaN and plausibility are always checked.

    Returns
    -------
    list[Issue]
        Findings ordered by channel; empty for a clean run.
    """
    ranges = PLAUSIBLE_RANGES if ranges is None else ranges
    skip = set(no_clip_check)
    if measured is None:
        measured = run.meta.get("source") != "simulation"
    if limits is None:
        limits = run.meta.get("converter_limits") or {}
    issues = _check_time(run, dt_rtol, gap_factor, fs_rtol)
    for ch in run.channels:
        if ch == "t":
            continue
        issues += _check_finite(run, ch)
        floor = False
        if ch in limits and ch not in skip:
            found = _check_at_limit(run, ch, limits[ch], clip_min_samples)
            floor = any(i.code == "pressure_floor" for i in found)
            issues += found
        if ch not in skip and measured:
            issues += _check_clipping(run, ch, clip_min_samples, floor)
            issues += _check_stuck(run, ch, stuck_min_samples)
            issues += _check_spikes(run, ch, spike_factor)
        if ch in ranges:
            issues += _check_range(run, ch, ranges[ch])
    return _unique(issues)


def _unique(issues: list[Issue]) -> list[Issue]:
    """One clipping finding per channel (the limit check and the plateau check may both see it)."""
    seen: set[tuple[str, str | None]] = set()
    out = []
    for i in issues:
        key = (i.code, i.channel)
        if i.code == "clipped" and key in seen:
            continue
        seen.add(key)
        out.append(i)
    return out


#: Chamber (and line) pressures: at a converter floor near ambient they meet a physical floor.
PRESSURE_CHANNELS = FLOOR_CHANNELS
#: Absolute vacuum as a gauge pressure [Pa]: no liquid's pressure goes below it.
VACUUM_GAUGE = -1.01325e5
#: A converter whose lowest value is at most this [Pa, gauge] starts near ambient (a gauge
#: sensor, 0 bar): a chamber held at it is below ambient, i.e. between it and vacuum.
_FLOOR_NEAR_AMBIENT = 1e5


def unusable(issue: Issue) -> bool:
    """Whether a finding makes the samples it names unusable for a computation reading them:
    every error, and a chamber at a gauge sensor's floor (its pressure is unknown there, up to
    1 bar under the reading), which ``data check`` reports as a note."""
    return issue.severity == "error" or issue.code == "pressure_floor"


def _physical_floor(run: Run, channel: str, level: float, start: int, n: int) -> Issue:
    """A chamber at a gauge sensor's 0 bar: cavitation near the physical floor, not clipping."""
    lost = level - VACUUM_GAUGE
    return _issue(
        run,
        "pressure_floor",
        channel,
        start,
        f"sits at the converter's lowest value {level:.6g} {run.units[channel]} for {n} samples: "
        f"the chamber is below ambient there (cavitating; no liquid goes below vacuum, "
        f"{VACUUM_GAUGE:.6g} Pa), a physical floor at most {lost:.4g} Pa under the reading, "
        "not a clipped converter",
        "nothing to repair (identification and evaluation leave out what reads it there); a "
        "compound (vacuum) pressure sensor, e.g. −1…250 bar, records the sub-ambient part",
        severity="note",
    )


def _check_at_limit(run: Run, channel: str, limit, min_samples: int) -> list[Issue]:
    """Samples at the converter's lowest or highest code, the whole run included.

    A chamber pressure at the lowest value of a converter that starts near ambient
    (≤ 1 bar gauge) is below ambient, above vacuum: cavitation, reported as a ``note``
    (``"pressure_floor"``); any other channel or side, or a whole run there, is clipping.
    """
    v = run.channels[channel]
    try:
        lo, hi = (float(x) for x in limit)
    except (TypeError, ValueError):
        return []
    tol = 1e-6 * max(abs(hi - lo), 1e-300)  # below half a 16-bit code, above CSV rounding
    out = []
    for level, side in ((hi, "highest"), (lo, "lowest")):
        at = np.abs(v - level) <= tol
        starts, lengths = mask_runs(at)
        if lengths.size == 0 or lengths.max() < min_samples:
            continue
        k = int(np.argmax(lengths))
        whole = int(lengths[k]) == v.size
        if (
            channel in PRESSURE_CHANNELS
            and side == "lowest"
            and level <= _FLOOR_NEAR_AMBIENT
            and not whole
        ):
            out.append(_physical_floor(run, channel, level, int(starts[k]), int(lengths[k])))
            continue
        out.append(
            _issue(
                run,
                "clipped",
                channel,
                starts[k],
                (
                    f"sits at the converter's {side} value {level:.6g} {run.units[channel]} for the whole run"
                    if whole
                    else f"sits at the converter's {side} value {level:.6g} {run.units[channel]} for "
                    f"{int(lengths[k])} samples"
                ),
                "the sensor's range does not cover the signal; use a sensor with a larger range "
                "(the rig: [sensors] in the campaign) or exclude the stretch with select()",
            )
        )
    return out


def _check_stuck(run: Run, channel: str, min_samples: int) -> list[Issue]:
    """A dropout: the channel repeats one value for ``min_samples`` while it is otherwise live."""
    v = run.channels[channel]
    if v.size < 4 * min_samples:
        return []
    same = np.concatenate(([False], np.diff(v) == 0))
    starts, lengths = mask_runs(same)
    long = lengths >= min_samples
    if not long.any():
        return []
    plateau = np.zeros(v.shape, dtype=bool)
    for s0, n in zip(starts[long], lengths[long], strict=True):
        plateau[s0 - 1 : s0 + n] = True
    rest = np.diff(v[~plateau])
    if rest.size == 0 or np.mean(rest == 0) > 0.5:  # quantised, slowly moving: flat is normal
        return []
    fin = v[np.isfinite(v)]
    k = int(np.argmax(lengths * long))
    level = v[starts[k]]
    if level in (fin.max(), fin.min()):
        return []  # at a rail: reported as clipping
    return [
        _issue(
            run,
            "stuck",
            channel,
            starts[k] - 1,
            f"repeats the value {level:.6g} {run.units[channel]} for {int(lengths[k]) + 1} samples "
            "while it changes every sample elsewhere (a sensor dropout)",
            "exclude the stretch with select() or re-measure",
        )
    ]


def _check_spikes(run: Run, channel: str, factor: float) -> list[Issue]:
    """Isolated samples far from both neighbours, which agree with each other."""
    v = run.channels[channel]
    if v.size < 16:
        return []
    d = v[1:-1] - 0.5 * (v[:-2] + v[2:])
    ok = np.isfinite(d)
    if ok.sum() < 16:
        return []
    med = np.median(d[ok])
    scale = 1.4826 * float(np.median(np.abs(d[ok] - med)))
    if scale == 0.0:
        # the spread scaled by the largest deviation first: values near 1e154 would overflow
        # the sum of squares (a fuzzed file; such a channel also fails its plausible range)
        big = float(np.max(np.abs(d[ok] - med)))
        scale = big * float(np.std((d[ok] - med) / big)) if big > 0.0 else 0.0
    if not scale > 0.0 or not math.isfinite(scale):
        return []
    spread = np.abs(v[2:] - v[:-2])
    hit = ok & (np.abs(d - med) > factor * scale) & (spread < np.abs(d) / 3.0)
    idx = np.flatnonzero(hit) + 1
    if idx.size == 0:
        return []
    i = int(idx[0])
    return [
        _issue(
            run,
            "spike",
            channel,
            i,
            f"has {idx.size} isolated spike(s), the first {v[i]:.6g} {run.units[channel]} between "
            f"{v[i - 1]:.6g} and {v[i + 1]:.6g}",
            "remove them (e.g. a 3-sample median filter) or exclude the stretch with select()",
        )
    ]


# ---------------------------------------------------------------------- repairs
def _drop_duplicates(run: Run) -> tuple[Run, str | None]:
    t = run.t
    keep = np.isfinite(t)
    keep[1:] &= np.diff(t) != 0
    if keep.all():
        return run, None
    run2 = run.replace(channels={k: v[keep] for k, v in run.channels.items()})
    return run2, f"dropped {int((~keep).sum())} samples with repeated or non-finite time stamps"


def _interpolate_gaps(run: Run) -> tuple[Run, str | None]:
    chans, n_fixed = {}, 0
    t = run.t
    for k, v in run.channels.items():
        bad = ~np.isfinite(v)
        if k == "t" or not bad.any() or bad.all():
            chans[k] = v
            continue
        good = np.flatnonzero(~bad)
        inner = bad & (np.arange(v.size) > good[0]) & (np.arange(v.size) < good[-1])
        w = np.array(v)
        w[inner] = np.interp(t[inner], t[~bad], v[~bad])
        chans[k], n_fixed = w, n_fixed + int(inner.sum())
    if not n_fixed:
        return run, None
    return run.replace(channels=chans), f"linearly interpolated {n_fixed} NaN/inf samples"


def validate_run(
    run: Run,
    *,
    resample: bool = False,
    fs: float | None = None,
    interpolate_gaps: bool = False,
    drop_duplicates: bool = False,
    raise_on_error: bool = True,
    **check_options,
) -> ValidationReport:
    """Validate a run, apply only the repairs asked for, and raise on remaining errors.

    Parameters
    ----------
    run : Run
        The run to validate.
    resample : bool
        Resample onto a uniform grid at ``fs`` (linear interpolation) when the time base
        has jitter or gaps.
    fs : float, optional
        Target rate for ``resample`` [Hz]; default ``run.fs``.
    interpolate_gaps : bool
        Linearly interpolate NaN/inf samples that lie between finite ones.
    drop_duplicates : bool
        Drop samples whose time stamp repeats the previous one or is not finite.
    raise_on_error : bool
        Raise :class:`DataError` when errors remain (default) instead of returning them.
    **check_options
        Passed to :func:`check_run` (``dt_rtol``, ``clip_min_samples``, ``ranges``, ...).

    Returns
    -------
    ValidationReport
        The (repaired) run, remaining issues and the repairs applied.

    Raises
    ------
    DataError
        With the first error's message (run, channel, sample, hint) when errors remain.
    """
    repairs: list[str] = []
    if drop_duplicates:
        run, note = _drop_duplicates(run)
        repairs += [note] if note else []
    if interpolate_gaps:
        run, note = _interpolate_gaps(run)
        repairs += [note] if note else []
    if resample:
        codes = {i.code for i in check_run(run, **check_options)}
        if codes & {"time_gap", "time_nonuniform"} or (fs is not None and fs != run.fs):
            run = run.resample(fs)
            repairs.append(f"resampled to a uniform grid at {run.fs:.6g} Hz")
    issues = check_run(run, **check_options)
    errors = [i for i in issues if i.severity == "error"]
    if errors and raise_on_error:
        more = (
            f" [{len(errors) - 1} more error(s); run `hydropwa data check` to list all]"
            if len(errors) > 1
            else ""
        )
        raise DataError(f"{errors[0]}{more}")
    return ValidationReport(run=run, issues=issues, repairs=repairs)


def screen_runs(runs, **check_options) -> tuple[list[Run], list[tuple[str, str]]]:
    """Split runs into sound ones and those left out, never silently.

    Parameters
    ----------
    runs : Dataset or iterable of Run
        A dataset (anything with ``names`` and ``dataset[name]``) is read run by run; a
        run whose file cannot be read is left out, not raised.
    **check_options
        Passed to :func:`check_run`.

    Returns
    -------
    sound : list of Run
        Runs that were read and have no error-severity finding of :func:`check_run`.
    rejected : list of (str, str)
        (run name, one-line reason) for each run left out: ``"cannot be read: ..."`` or
        ``"bad data: ..."`` with the first error's channel, sample and time.
    """
    sound, rejected = [], []
    if hasattr(runs, "names"):
        dataset, runs = runs, []
        if "limits" not in check_options:
            sensors = (getattr(dataset, "meta", None) or {}).get("rig", {}).get("sensors", {})
            lim = converter_limits(sensors)
            if lim:
                check_options = {**check_options, "limits": lim}
        for name in dataset.names:
            try:
                runs.append(dataset[name])
            except DataError as exc:
                rejected.append((name, f"cannot be read: {exc}"))
    for run in runs:
        errors = [i for i in check_run(run, **check_options) if unusable(i)]
        if errors:
            more = f" (+{len(errors) - 1} more)" if len(errors) > 1 else ""
            rejected.append((run.name, f"bad data: {errors[0]}{more}"))
        else:
            sound.append(run)
    return sound, rejected


def converter_limits(sensors: Mapping | None) -> dict[str, tuple[float, float]]:
    """Converter limits per channel from a rig's sensor description (``range``, ``quantization_step``)."""
    out = {}
    for ch, d in (sensors or {}).items():
        try:
            lo, hi = (float(x) for x in d["range"])
            step = float(d["quantization_step"])
            bits = int(d.get("adc_bits", 16))
        except (KeyError, TypeError, ValueError):
            continue
        out[ch] = (lo, min(hi, lo + (2**bits - 1) * step))
    return out
