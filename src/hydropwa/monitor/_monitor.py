"""Health of logged runs: indicators, thresholds with a stated false-alarm bound, alarms, faults.

:class:`HealthMonitor` (settings in ``__init__``, the machine in ``fit``, then ``check`` per
run or ``check_dataset``) evaluates the residual generator of :mod:`._residuals` on each run,
reads each indicator of :data:`~._indicators.INDICATORS` with its standard error, bounds what
the held parameters' intervals can move it (:func:`_held_bias`) and alarms when it leaves its
healthy interval by more than that bound and ``k`` standard errors. See docs/monitoring.md
for what the false-alarm bound guarantees and what is only measured.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from statistics import NormalDist
from typing import Any

import numpy as np

from .._errors import DataError, ParameterError
from .._result import DerivedResult, ResultStatus
from ..params import SystemParams
from ._indicators import (
    INDICATORS,
    NUISANCE,
    Indicator,
    describe_intervals,
    parameter_intervals,
    value_of,
)
from ._residuals import (
    LinearFit,
    Signals,
    continuity_fit,
    friction_fit,
    friction_level_weights,
    friction_scale_fit,
    prepare,
    sliding_speed,
    spool_fit,
    supply_fit,
)

__all__ = ["HealthMonitor", "HealthReport", "IndicatorValue", "RunHealth", "monitor"]

#: Channels a run must have.
REQUIRED = ("t", "u", "x", "p_a", "p_b")
#: Channels used when logged.
OPTIONAL = ("p_s", "f_l", "spool")


@dataclass(frozen=True)
class IndicatorValue:
    """One indicator of one run (SI).

    Attributes
    ----------
    name, unit : str
    value, std : float
        Estimate and its standard error (residual autocorrelation included); NaN if the run
        cannot give it (``available`` False).
    interval : (float, float)
        value ± k·std (k of the monitor's false-alarm probability).
    nominal : (float, float)
        The healthy interval of the parameter it estimates.
    bias : float
        Largest shift the held parameters' intervals can cause (to first order), plus the
        shift when the filter's window is doubled (:meth:`HealthMonitor._filter_bias`).
    threshold : (float or None, float or None)
        Alarm below the first / above the second (None: no alarm on that side).
    alarm : bool
    score : float
        Exceedance beyond the threshold in units of the threshold's margin (> 0 alarms).
    available : bool
    """

    name: str
    unit: str
    value: float
    std: float
    interval: tuple[float, float]
    nominal: tuple[float, float]
    bias: float
    threshold: tuple[float | None, float | None]
    alarm: bool
    score: float
    available: bool = True

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (NaN as None)."""

        def num(x: float | None) -> float | None:
            return None if x is None or not math.isfinite(x) else float(x)

        return {
            "value": num(self.value),
            "std": num(self.std),
            "interval": [num(self.interval[0]), num(self.interval[1])],
            "threshold": [num(self.threshold[0]), num(self.threshold[1])],
            "nominal": [num(self.nominal[0]), num(self.nominal[1])],
            "bias": num(self.bias),
            "unit": self.unit,
            "alarm": self.alarm,
            "score": num(self.score),
            "available": self.available,
        }


@dataclass(frozen=True)
class RunHealth(DerivedResult):
    """The health of one run: indicators, alarm and the faults named (most likely first).

    ``faults`` lists each fault kind whose indicator alarms, ordered by the largest
    exceedance score; ``faults[0]`` is the isolation.
    """

    run: str
    indicators: dict[str, IndicatorValue]
    alarm: bool
    faults: tuple[str, ...]
    rows: int
    notes: tuple[str, ...] = ()
    #: the speed [m/s] above which the friction rows were read (:func:`~._residuals.sliding_speed`)
    sliding_speed: float = float("nan")
    #: the optional channels the run logged (of ``p_s``, ``f_l``, ``spool``)
    logged: tuple[str, ...] = ()

    @property
    def status(self) -> ResultStatus:
        """SUCCESS, or PARTIAL when an indicator could not be estimated from this run."""
        if any(not iv.available for iv in self.indicators.values()):
            return ResultStatus.PARTIAL
        return ResultStatus.SUCCESS

    def _status_details(self) -> list[str]:
        return list(self.notes)

    def _summary_title(self) -> str:
        return f"RunHealth {self.run!r}: {'ALARM ' + ', '.join(self.faults) if self.alarm else 'healthy'}"

    def _summary_rows(self) -> list[tuple[str, Any, str]]:
        return [(n, iv.value, iv.unit) for n, iv in self.indicators.items() if iv.available]

    def to_dict(self) -> dict[str, Any]:
        """The ``health.json`` entry: ``run``, ``alarm``, ``faults``, ``indicators``."""
        return {
            "run": self.run,
            "alarm": self.alarm,
            "faults": list(self.faults),
            "rows": self.rows,
            "notes": list(self.notes),
            "indicators": {n: iv.to_dict() for n, iv in self.indicators.items()},
        }

    def to_pandas(self) -> Any:
        """One row per indicator (SI)."""
        import pandas as pd  # deferred: pandas costs ~0.3 s at import

        return pd.DataFrame([{"indicator": n, **iv.to_dict()} for n, iv in self.indicators.items()])

    def plot(self, *, ax: Any = None) -> Any:
        """Not drawn for one run; :meth:`HealthReport.write` draws the trends over runs."""
        raise NotImplementedError("plot the trends over runs with HealthReport.write(out)")


@dataclass(frozen=True)
class HealthReport(DerivedResult):
    """The health of every run of a dataset, in run order.

    Attributes
    ----------
    runs : tuple of RunHealth
    false_alarm : float
        The per-run false-alarm probability the thresholds are sized for.
    k : float
        Standard errors in each threshold.
    intervals : dict
        The healthy and held parameter intervals used, with their source.
    skipped : tuple of str
        Runs that could not be checked, each with why.
    """

    runs: tuple[RunHealth, ...]
    false_alarm: float
    k: float
    intervals: dict[str, Any]
    skipped: tuple[str, ...] = ()

    @property
    def status(self) -> ResultStatus:
        """SUCCESS, or PARTIAL when runs were skipped or an indicator was missing."""
        if self.skipped or any(not r.success for r in self.runs):
            return ResultStatus.PARTIAL
        return ResultStatus.SUCCESS

    def _status_details(self) -> list[str]:
        return [f"skipped {s}" for s in self.skipped]

    @property
    def alarms(self) -> list[str]:
        """Names of the runs that alarm."""
        return [r.run for r in self.runs if r.alarm]

    def _summary_rows(self) -> list[tuple[str, Any, str]]:
        return [
            ("runs checked", len(self.runs), ""),
            ("runs alarming", len(self.alarms), ""),
            ("false-alarm probability per run (design)", self.false_alarm, ""),
        ]

    def to_dict(self) -> dict[str, Any]:
        """The ``health.json`` document."""
        return {
            "false_alarm_per_run": self.false_alarm,
            "k": self.k,
            "intervals": self.intervals,
            "skipped": list(self.skipped),
            "runs": [r.to_dict() for r in self.runs],
        }

    def to_pandas(self) -> Any:
        """One row per run and indicator (SI values)."""
        import pandas as pd  # deferred: pandas costs ~0.3 s at import

        rows = [
            {"run": r.run, "alarm": r.alarm, "indicator": n, **iv.to_dict()}
            for r in self.runs
            for n, iv in r.indicators.items()
        ]
        return pd.DataFrame(rows)

    def plot(self, *, ax: Any = None) -> Any:
        """The trends are drawn as SVG in the HTML page (:meth:`write`)."""
        raise NotImplementedError("the trends are in the HTML page: HealthReport.write(out)")

    def write(self, out: Any, *, overwrite: bool = False) -> dict[str, Any]:
        """Write ``out/health.json`` and ``out/health.html`` (no-clobber unless ``overwrite``)."""
        from ._report import write_report  # deferred: the HTML writer, only when writing

        return write_report(self, out, overwrite=overwrite)


def _spool(sig: Signals, params: SystemParams, mask: np.ndarray) -> LinearFit | None:
    return spool_fit(sig, mask)


#: The fits of :mod:`._residuals`, by the name :data:`INDICATORS` uses.
FITS: dict[str, Callable[[Signals, SystemParams, np.ndarray], LinearFit | None]] = {
    "continuity": continuity_fit,
    "friction": friction_fit,
    "friction_scale": friction_scale_fit,
    "spool": _spool,
    "supply": supply_fit,
}
#: The valve null's fallback when the spool is not logged: the continuity fit's δ.
_NULL_FALLBACK = ("continuity", 4)


def _read(ind: Indicator, fits: Mapping[str, LinearFit | None]) -> tuple[float, float] | None:
    """(value, std) of an indicator from the fits, or None when its fit is not available."""
    fit, col = ind.fit, ind.column
    if fits.get(fit) is None and ind.name == "valve_null":
        fit, col = _NULL_FALLBACK
    f = fits.get(fit)
    if f is None:
        return None
    if col == -1:  # F_s = F_c + (F_s − F_c)
        g = np.array([1.0, 1.0, 0.0])
        return float(g @ f.theta), float(np.sqrt(max(g @ f.cov @ g, 0.0)))
    if ind.name == "bulk_modulus":  # E = 1/θ₀, standard error by the delta method
        b = float(f.theta[col])
        return 1.0 / b, float(f.std[col]) / (b * b)
    return float(f.theta[col]), float(f.std[col])


def _perturbed(params: SystemParams, path: str, value: float) -> SystemParams:
    """``params`` with one held parameter at ``value`` (ω0 scales its amplitude table too)."""
    if path == "valve.omega0" and params.valve.omega0_table:
        r = value / params.valve.omega0
        table = tuple((a, w * r) for a, w in params.valve.omega0_table)
        return params.replace(
            valve=dataclasses.replace(params.valve, omega0=value, omega0_table=table)
        )
    return params.replace(**{path: value})


class HealthMonitor:
    """Watch an identified axis: health indicators of logged runs with guarded thresholds.

    Parameters
    ----------
    false_alarm : float
        Probability [1] of a false alarm per healthy run that the thresholds are sized for
        (split over the indicators' threshold sides; Gaussian errors). Default 1e-3.
    intervals : mapping, optional
        ``{"component.field": (lo, hi)}`` (SI) overriding the healthy interval of a watched
        or held parameter; otherwise the file's ``[uncertainty]`` or the assumed half-widths.
    window : float
        Savitzky–Golay window [s] of the filter that smooths and differentiates the channels.
    stroke_margin : float
        Fraction of the stroke at each end where rows are not used (end stops).
    min_pressure : float
        Rows with a chamber below this gauge pressure [Pa] are not used (air release).

    Attributes
    ----------
    params_ : SystemParams
        The identified machine (after :meth:`fit`).
    intervals_ : dict
        ``{path: ((lo, hi), source)}`` used (after :meth:`fit`).
    k_ : float
        Standard errors in each threshold.
    """

    def __init__(
        self,
        false_alarm: float = 1e-3,
        intervals: Mapping[str, tuple[float, float]] | None = None,
        window: float = 0.01,
        stroke_margin: float = 0.02,
        min_pressure: float = 2e5,
    ) -> None:
        self.false_alarm = false_alarm
        self.intervals = intervals
        self.window = window
        self.stroke_margin = stroke_margin
        self.min_pressure = min_pressure

    def fit(self, params: SystemParams) -> HealthMonitor:
        """Take the identified machine and its intervals; returns ``self``."""
        if not isinstance(params, SystemParams):
            raise ParameterError(
                f"HealthMonitor.fit needs the identified SystemParams, got {type(params).__name__}; "
                "load them with hydropwa.params.load_params('identified.toml')"
            )
        if not (0.0 < self.false_alarm < 0.5):
            raise ParameterError(
                f"false_alarm = {self.false_alarm!r} must lie in (0, 0.5) (a probability per run, e.g. 1e-3)"
            )
        if not (1e-3 <= self.window <= 0.2):
            raise ParameterError(
                f"window = {self.window!r} s must lie in 1 ms … 200 ms (e.g. 0.01)"
            )
        self.params_ = params
        self.intervals_ = parameter_intervals(params, self.intervals)
        sides = sum((2 if ind.direction == 0 else 1) for ind in INDICATORS if ind.alarms)
        self.k_ = NormalDist().inv_cdf(1.0 - self.false_alarm / sides)
        return self

    def _signals(
        self, run: Any, params: SystemParams, window: float | None = None
    ) -> tuple[Signals, np.ndarray]:
        sig = prepare(run.channels, float(run.fs), params, window or self.window)
        c = params.cylinder
        m = self.stroke_margin * c.stroke
        mask = (sig.x > m) & (sig.x < c.stroke - m)
        mask &= (sig.p_a > self.min_pressure) & (sig.p_b > self.min_pressure)
        return sig, mask

    def _fits(
        self, run: Any, params: SystemParams, prepared: tuple[Signals, np.ndarray] | None = None
    ) -> dict[str, LinearFit | None]:
        sig, mask = self._signals(run, params) if prepared is None else prepared
        if int(mask.sum()) < 50:
            raise DataError(
                f"run {run.name!r}: only {int(mask.sum())} usable rows (rod within "
                f"{100 * self.stroke_margin:g} % of a stop or a chamber below "
                f"{self.min_pressure / 1e5:g} bar); give a longer run away from the stops"
            )
        return {name: fn(sig, params, mask) for name, fn in FITS.items()}

    def _held_bias(self, run: Any, prepared: tuple[Signals, np.ndarray]) -> dict[str, float]:
        """Per indicator: Σ over held parameters of half the change across the interval.

        The estimate moves with a held parameter's assumed value; to first order it moves
        by the same amount with the true value inside its interval, so this bounds what a
        healthy machine within its intervals can show (model error of the residual generator).
        """
        bias = {ind.name: 0.0 for ind in INDICATORS}
        for path, ((lo, hi), _src) in self.intervals_.items():
            if path not in NUISANCE or hi <= lo:
                continue
            # only the valve's ω0 and ζ change the filtered signals (the modelled spool)
            again = path.startswith("valve.")
            ends = [
                self._fits(run, q, None if again else prepared)
                for q in (_perturbed(self.params_, path, v) for v in (lo, hi))
            ]
            for ind in INDICATORS:
                a, b = _read(ind, ends[0]), _read(ind, ends[1])
                if a is not None and b is not None:
                    bias[ind.name] += 0.5 * abs(b[0] - a[0])
        return bias

    def _filter_bias(self, run: Any, fits: Mapping[str, LinearFit | None]) -> dict[str, float]:
        """Per indicator: the change of the estimate when the filter's window is doubled.

        The equations hold between filtered signals only for their linear terms: the
        Stribeck curve of a filtered speed, the metering flows of filtered pressures and the
        speed's noise in the regressors (errors in variables) bias the estimates by an amount
        the filter sets. Refitting with twice the window measures it on this run (measured,
        not bounded: docs/monitoring.md). The whole change, not a Richardson fraction of it:
        the error is not one power of the window but two effects of opposite sign (the noise
        in the regressors falls with w, the smoothing's error grows), so the estimate at w can
        lie further from the truth than from the estimate at 2w (the paper rig's 20 % sines:
        +2.5 … +4.5 % at 10 ms, −3 … 0 % at 20 ms; half the change left two of 333 healthy
        sines above the threshold). Runs too short for the wider window add nothing.
        """
        try:
            wide = self._fits(run, self.params_, self._signals(run, self.params_, 2 * self.window))
        except DataError:
            return {ind.name: 0.0 for ind in INDICATORS}
        out = {}
        for ind in INDICATORS:
            a, b = _read(ind, fits), _read(ind, wide)
            out[ind.name] = abs(b[0] - a[0]) if a is not None and b is not None else 0.0
        return out

    def check(self, run: Any) -> RunHealth:
        """The health of one run (a :class:`hydropwa.data.Run`)."""
        if not hasattr(self, "params_"):
            raise ParameterError("HealthMonitor is not fitted; call .fit(identified_params) first")
        missing = [c for c in REQUIRED if c not in run.channels]
        if missing:
            raise DataError(
                f"run {run.name!r} has no {', '.join(missing)}; the monitor needs "
                f"{', '.join(REQUIRED)} (p_s, f_l and spool when logged)"
            )
        prepared = self._signals(run, self.params_)
        fits = self._fits(run, self.params_, prepared)
        bias = self._held_bias(run, prepared)
        for name, b in self._filter_bias(run, fits).items():
            bias[name] += b
        level = friction_level_weights(prepared[0], self.params_, prepared[1])
        values = {ind.name: self._indicator(ind, fits, bias[ind.name], level) for ind in INDICATORS}
        faults: dict[str, float] = {}
        for ind in INDICATORS:
            iv = values[ind.name]
            if iv.alarm:
                faults[ind.fault] = max(faults.get(ind.fault, 0.0), iv.score)
        named = tuple(sorted(faults, key=lambda f: -faults[f]))
        notes = tuple(
            f"{n} not available from this run" for n, iv in values.items() if not iv.available
        )
        rows = fits["continuity"].rows if fits["continuity"] is not None else 0
        logged = tuple(c for c in OPTIONAL if c in run.channels)
        speed = sliding_speed(prepared[0], self.params_)
        return RunHealth(run.name, values, bool(named), named, rows, notes, speed, logged)

    def _indicator(
        self,
        ind: Indicator,
        fits: Mapping[str, LinearFit | None],
        bias: float,
        level: np.ndarray,
    ) -> IndicatorValue:
        lo, hi = self._healthy(ind, level)
        got = _read(ind, fits)
        if got is None:
            nan = float("nan")
            return IndicatorValue(
                ind.name,
                ind.unit,
                nan,
                nan,
                (nan, nan),
                (lo, hi),
                bias,
                (None, None),
                False,
                nan,
                False,
            )
        value, std = got
        margin = self.k_ * std + bias
        low = lo - margin if ind.direction <= 0 and ind.alarms else None
        high = hi + margin if ind.direction >= 0 and ind.alarms else None
        scores = [-math.inf]
        if high is not None:
            scores.append((value - high) / max(margin, 1e-300))
        if low is not None:
            scores.append((low - value) / max(margin, 1e-300))
        score = max(scores)
        return IndicatorValue(
            ind.name,
            ind.unit,
            value,
            std,
            (value - self.k_ * std, value + self.k_ * std),
            (lo, hi),
            bias,
            (low, high),
            bool(score > 0.0),
            score,
        )

    def _healthy(self, ind: Indicator, level: np.ndarray) -> tuple[float, float]:
        """The healthy interval (SI) of what an indicator estimates.

        A ratio to the identified curve (``ratio_of``: the friction level) spans
        Σ_j [lo_j, hi_j]·g_j over its parameters' intervals, g_j the run's weights
        (:func:`~._residuals.friction_level_weights`; exact, the curve is linear in them);
        without sliding rows (g NaN) the widest relative interval.
        """
        if ind.ratio_of and np.all(np.isfinite(level)):
            ends = [
                np.array(self.intervals_[p][0]) * g
                for p, g in zip(ind.ratio_of, level, strict=True)
            ]
            return float(sum(e.min() for e in ends)), float(sum(e.max() for e in ends))
        if ind.ratio_of:
            w = 0.0
            for path in ind.ratio_of:
                (lo, hi), _src = self.intervals_[path]
                v = value_of(self.params_, path)
                if v != 0.0:
                    w = max(w, (v - lo) / abs(v), (hi - v) / abs(v))
            return 1.0 - w, 1.0 + w
        if ind.parameter:
            return self.intervals_[ind.parameter][0]
        return 0.0, 0.0

    def check_dataset(self, runs: Iterable[Any]) -> HealthReport:
        """The health of every run (a :class:`hydropwa.data.Dataset` or runs), in order.

        A run that cannot be checked (too short, channels missing) is listed in ``skipped``.
        """
        out, skipped = [], []
        for run in runs:
            try:
                out.append(self.check(run))
            except DataError as exc:
                skipped.append(f"{run.name}: {exc}")
        return HealthReport(
            tuple(out),
            self.false_alarm,
            self.k_,
            describe_intervals(self.intervals_),
            tuple(skipped),
        )


def monitor(runs: Iterable[Any], params: SystemParams, **settings: Any) -> HealthReport:
    """The health of logged runs: ``HealthMonitor(**settings).fit(params).check_dataset(runs)``."""
    return HealthMonitor(**settings).fit(params).check_dataset(runs)
