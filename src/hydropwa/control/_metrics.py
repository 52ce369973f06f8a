"""Tracking metrics of a closed-loop run and the comparison of one controller on the three models."""

from __future__ import annotations

import dataclasses
import html
import math
import warnings
from typing import Any, ClassVar

import numpy as np

from .._layout import FULL_KIND, PWA_KIND, REDUCED_KIND, build_model
from .._result import DerivedResult, ResultStatus
from ..simulation import DEFAULT_RTOL, simulate
from ._controllers import ControlError
from ._reference import as_reference

__all__ = ["TrackingMetrics", "tracking_metrics", "METRIC_UNITS", "compare_models"]

#: Display (engineering) unit of every metric: :meth:`TrackingMetrics.display`, the tables of
#: :func:`compare_models` and the report.
METRIC_UNITS = {
    "step": "mm",
    "rise_time": "ms",
    "overshoot": "%",
    "settling_time": "ms",
    "steady_state_error": "mm",
    "iae": "mm·s",
    "max_following_error": "mm",
    "saturation": "%",
    "cell_switches": "1",
    "chattering": "1/s",
}


#: SI unit of every field of :class:`TrackingMetrics`, and its factor to the display unit.
_SI = {
    "step": ("m", 1e3),
    "rise_time": ("s", 1e3),
    "overshoot": ("1", 100.0),
    "settling_time": ("s", 1e3),
    "steady_state_error": ("m", 1e3),
    "iae": ("m·s", 1e3),
    "max_following_error": ("m", 1e3),
    "saturation": ("1", 100.0),
    "cell_switches": ("1", 1.0),
    "chattering": ("1/s", 1.0),
}


@dataclasses.dataclass(frozen=True)
class TrackingMetrics(DerivedResult):
    """Tracking metrics of a closed-loop run over a window, in SI units.

    Attributes
    ----------
    step : float
        Reference change over the window [m].
    rise_time : float
        10 → 90 % of the step [s]; NaN without a step.
    overshoot : float
        Beyond the final reference, as a fraction of the step [1].
    settling_time : float
        From the window's start until |e| stays within the band [s].
    steady_state_error : float
        Mean r − x over the last 10 % of the window [m].
    iae : float
        ∫|e| dt [m·s].
    max_following_error : float
        max |e| [m].
    saturation : float
        Share of the samples with the command at a limit [1].
    cell_switches : int
        Changes of the gain row plus the PWA model's own cell changes.
    chattering : float
        Sign changes of the applied command per second [1/s] (beyond ±1 % of its range).
    window : (float, float)
        Start and end t0, t1 of the window [s].

    Notes
    -----
    The result protocol (:class:`hydropwa._result.Result`): ``status`` is
    ``ResultStatus.NOT_SETTLED`` where the reference steps but the rise or settling time is
    NaN (the rod did not reach 90 % of the step, or was outside the band at the window's
    end), else ``SUCCESS``; ``success``, ``message``, ``summary()``, ``to_pandas()`` and
    ``plot()`` (:func:`hydropwa.plotting.plot_metrics`) follow.
    :meth:`display` gives the values in engineering units (:data:`METRIC_UNITS`: mm, ms, %).
    Indexing (``m["overshoot"]``), ``keys()``, ``items()`` and ``values()`` are the former
    dict in those units: deprecated, with a ``DeprecationWarning``.
    """

    step: float
    rise_time: float
    overshoot: float
    settling_time: float
    steady_state_error: float
    iae: float
    max_following_error: float
    saturation: float
    cell_switches: int
    chattering: float
    window: tuple[float, float] = (math.nan, math.nan)

    #: SI unit of each metric.
    UNITS: ClassVar[dict[str, str]] = {k: u for k, (u, _) in _SI.items()}

    def display(self) -> dict[str, float]:
        """The metrics in engineering units (:data:`METRIC_UNITS`: mm, ms, %, 1/s)."""
        return {k: float(getattr(self, k)) * f for k, (_, f) in _SI.items()}

    def display_units(self) -> dict[str, str]:
        """The engineering unit of each metric (:data:`METRIC_UNITS`)."""
        return dict(METRIC_UNITS)

    def _status_details(self) -> list[str]:
        if self.step == 0 or not math.isfinite(self.step):
            return []  # no step: the step metrics do not apply
        out = []
        if math.isnan(self.rise_time):
            out.append("rise_time: the rod did not reach 90 % of the step in the window")
        if math.isnan(self.settling_time):
            out.append("settling_time: the rod was outside the band at the window's end")
        return out

    @property
    def status(self) -> ResultStatus:
        """``NOT_SETTLED`` where a step metric that applies is NaN, else ``SUCCESS``."""
        return ResultStatus.NOT_SETTLED if self._status_details() else ResultStatus.SUCCESS

    def plot(self, *, ax: Any = None) -> Any:
        """The metrics as bars in engineering units (:func:`hydropwa.plotting.plot_metrics`)."""
        from ..plotting import plot_metrics  # deferred: matplotlib loads only when plotting

        t0, t1 = self.window
        return plot_metrics(self, title=f"tracking metrics, {t0:g}…{t1:g} s", ax=ax)

    def to_pandas(self):
        """One row per metric: SI value and unit, display value and unit."""
        import pandas as pd  # deferred: pandas costs ~0.3 s at import

        shown = self.display()
        return pd.DataFrame(
            {
                "value": [float(getattr(self, k)) for k in _SI],
                "unit": [u for u, _ in _SI.values()],
                "display": list(shown.values()),
                "display unit": [METRIC_UNITS[k] for k in _SI],
            },
            index=pd.Index(list(_SI), name="metric"),
        )

    def summary(self) -> str:
        """The status, then one line per metric in engineering units."""
        lines = [f"TrackingMetrics ({self._status_line()})"]
        lines += [f"{k:<20} {v:>10.4g} {METRIC_UNITS[k]}" for k, v in self.display().items()]
        return "\n".join(lines)

    def __repr__(self) -> str:
        t0, t1 = self.window
        d = self.display()
        return (
            f"TrackingMetrics(window {t0:g}…{t1:g} s: max error {d['max_following_error']:.3g} mm, "
            f"steady-state error {d['steady_state_error']:.3g} mm, overshoot "
            f"{d['overshoot']:.3g} %, rise {d['rise_time']:.4g} ms, saturation {d['saturation']:.3g} %)"
        )

    def _repr_html_(self) -> str:
        rows = "".join(
            f"<tr><td>{k}</td><td>{v:.4g}</td><td>{METRIC_UNITS[k]}</td></tr>"
            for k, v in self.display().items()
        )
        note = html.escape(self._status_line())
        return (
            "<div><table><thead><tr><th>metric</th><th>value</th><th>unit</th></tr></thead>"
            f"<tbody>{rows}</tbody></table><div style='font-size:smaller'>{note}</div></div>"
        )

    # --- the former dict (engineering units), deprecated ------------------------------------
    def _old(self) -> dict[str, float]:
        warnings.warn(
            "tracking metrics are a TrackingMetrics object in SI units; read attributes "
            "(m.overshoot [1], m.rise_time [s]) or m.display() for the former dict in mm, ms, %",
            DeprecationWarning,
            stacklevel=3,
        )
        return self.display()

    def __getitem__(self, key: str) -> float:
        return self._old()[key]

    def keys(self):
        return self._old().keys()

    def items(self):
        return self._old().items()

    def values(self):
        return self._old().values()


def tracking_metrics(
    result, t0: float | None = None, t1: float | None = None, band: float | None = None
) -> TrackingMetrics:
    """Tracking metrics of a closed-loop result over the window from t0 to t1 (seconds).

    Parameters
    ----------
    result : SimulationResult
        From ``simulate(..., controller=..., reference=...)``.
    t0, t1 : float, optional
        Window [s]; default the whole run. For a step, start the window at the step: the
        move is measured from the output sample before t0.
    band : float, optional
        Settling band [m]; default 2 % of the step, at least 0.05 mm.

    Returns
    -------
    TrackingMetrics
        In SI units (``display()``: mm, ms, %): ``step`` (reference change over the
        window), ``rise_time`` (10 → 90 % of the step), ``overshoot`` (beyond the final
        reference, fraction of the step), ``settling_time`` (from t0 until |e| stays within
        the band), ``steady_state_error`` (mean r − x over the last 10 % of the window),
        ``iae`` (∫|e| dt), ``max_following_error`` (max |e|), ``saturation`` (share of
        samples with the command at a limit), ``cell_switches`` (changes of the gain
        row, plus the PWA model's own cell changes), ``chattering`` (sign changes of the
        applied command per second, counted between commands beyond ±1 % of the
        command range). Step metrics are NaN when the reference does not
        change over the window.
    """
    ctl = getattr(result, "control", None)
    if not ctl:
        raise ControlError(
            "tracking metrics need a closed-loop result (simulate(..., controller=..., reference=...))"
        )
    t = result.t
    a = float(t[0]) if t0 is None else float(t0)
    b = float(t[-1]) if t1 is None else float(t1)
    m = (t >= a - 1e-12) & (t <= b + 1e-12)
    if np.count_nonzero(m) < 3:
        raise ControlError(f"window [{a:g}, {b:g}] s holds fewer than 3 output samples")
    tt, x, r = t[m], result["x"][m], result["reference"][m]
    e = r - x
    # the move starts from the sample before the window (a step at t0 is in the window)
    i0 = max(int(np.argmax(m)) - 1, 0)
    r_a, r_b = float(result["reference"][i0]), float(r[-1])
    x_a = float(result["x"][i0])
    step = r_b - r_a
    out: dict[str, float] = {"step": step}
    nan = math.nan
    if abs(step) > 0:
        prog = (x - x_a) / step  # 0 → 1 along the move
        i10 = np.flatnonzero(prog >= 0.1)
        i90 = np.flatnonzero(prog >= 0.9)
        out["rise_time"] = float(tt[i90[0]] - tt[i10[0]]) if i10.size and i90.size else nan
        out["overshoot"] = max(0.0, float(np.max((x - r_b) * np.sign(step)))) / abs(step)
        bw = band if band is not None else max(0.02 * abs(step), 5e-5)
        outside = np.flatnonzero(np.abs(x - r_b) > bw)
        if outside.size == 0:
            out["settling_time"] = 0.0
        elif outside[-1] == tt.size - 1:
            out["settling_time"] = nan
        else:
            out["settling_time"] = float(tt[outside[-1] + 1] - a)
    else:
        out["rise_time"] = out["overshoot"] = out["settling_time"] = nan
    tail = tt >= b - 0.1 * (b - a)
    out["steady_state_error"] = float(np.mean(e[tail]))
    out["iae"] = float(np.sum(0.5 * (np.abs(e[1:]) + np.abs(e[:-1])) * np.diff(tt)))
    out["max_following_error"] = float(np.max(np.abs(e)))
    ts = ctl["t"]
    ms = (ts >= a - 1e-12) & (ts <= b + 1e-12)
    u = ctl["u"][ms]
    lo, hi = ctl["u_limits"]
    tol = 1e-9 * max(1.0, abs(lo), abs(hi))
    out["saturation"] = float(np.mean((u <= lo + tol) | (u >= hi - tol))) if u.size else nan
    rows = ctl["row"][ms]
    switches = int(np.count_nonzero(np.diff(rows) != 0))
    for key in ("cell_g", "cell_o", "cell_n", "cell_w"):
        if key in result.channels:
            switches += int(np.count_nonzero(np.diff(result.channels[key][m]) != 0))
    # a sign change counts between commands beyond ±1 % of the range (hysteresis): the
    # sub-percent dither of a held position is not chattering
    thr = 0.01 * max(abs(lo), abs(hi))
    sg = np.sign(u[np.abs(u) > thr])
    out["chattering"] = float(np.count_nonzero(np.diff(sg) != 0)) / max(b - a, 1e-12)
    return TrackingMetrics(**out, cell_switches=switches, window=(a, b))


def compare_models(
    controller,
    reference,
    *,
    params=None,
    pwa=None,
    duration: float,
    initial_position: float | None = None,
    load_force=None,
    models=(FULL_KIND.name, REDUCED_KIND.name, PWA_KIND.name),
    window: tuple[float, float] | None = None,
    rtol: float | None = None,
    x0: float | None = None,
    sensor_noise=None,
    seed: int | None = None,
) -> tuple[dict[str, Any], Any]:
    """Run one controller on several models and tabulate the tracking metrics.

    Parameters
    ----------
    controller : PIController or StateFeedbackController
    reference : reference position (see :func:`~hydropwa.control.as_reference`)
    params : SystemParams, optional
        Parameters of the full and reduced models (default: those of ``pwa``).
    pwa : PwaModel, optional
        PWA model (default: ``linearize(params)``).
    duration : float
        [s].
    initial_position : float, optional
        Initial rod position [m] (default: the reference at t = 0).
    load_force : optional
        F_L(t) [N] for every model.
    models : tuple of str
    window : (float, float), optional
        Window of the metrics [s] (default the whole run).
    rtol : float, optional
        Relative tolerance of the integration.
    x0 : float, optional
        Deprecated alias of ``initial_position``.
    sensor_noise : mapping, optional
        Noise on the controller's sensors (standard deviations, SI: ``x``, ``p_a``, ``p_b``,
        ``spool``), as :func:`~hydropwa.simulation.simulate` takes it.
    seed : int, optional
        Seed of the noise: every model gets the same draws.

    Returns
    -------
    results : dict of SimulationResult
    table : pandas.DataFrame
        One row per model, columns :data:`METRIC_UNITS` in those display units (mm, ms, %;
        units in ``attrs['units']``).
    """
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    if x0 is not None:
        warnings.warn(
            "compare_models(x0=...) is deprecated; use initial_position=...",
            DeprecationWarning,
            stacklevel=2,
        )
        initial_position = x0 if initial_position is None else initial_position
    if params is None and pwa is None:
        raise ControlError("compare_models needs params or a PWA model")
    if params is None:
        params = pwa.params
    ref = as_reference(reference)
    start = float(ref(0.0)) if initial_position is None else float(initial_position)
    results: dict[str, Any] = {}
    given = {} if pwa is None else {pwa.name: pwa}  # a PWA model given stands for its kind
    for name in models:
        mdl = given[name] if name in given else build_model(name, params)
        results[name] = simulate(
            mdl,
            duration=duration,
            params=params,
            controller=controller,
            reference=ref,
            initial_position=start,
            load_force=load_force,
            rtol=DEFAULT_RTOL if rtol is None else rtol,
            sensor_noise=sensor_noise,
            seed=seed,
        )
    w = window or (None, None)
    table = pd.DataFrame(
        {name: tracking_metrics(res, *w).display() for name, res in results.items()}
    ).T
    table.index.name = "model"
    table.attrs["units"] = dict(METRIC_UNITS)
    return results, table
