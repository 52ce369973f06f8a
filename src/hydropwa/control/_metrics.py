"""Tracking metrics of a closed-loop run and the comparison of one controller on the three models."""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np

from ..linearization import linearize
from ..simulation import DEFAULT_RTOL, simulate
from ._controllers import ControlError
from ._reference import as_reference

__all__ = ["tracking_metrics", "METRIC_UNITS", "compare_models"]

#: Unit of every metric of :func:`tracking_metrics`.
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


def tracking_metrics(
    result, t0: float | None = None, t1: float | None = None, band: float | None = None
) -> dict[str, float]:
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
    dict
        In :data:`METRIC_UNITS` (engineering units): ``step`` (reference change over the
        window), ``rise_time`` (10 → 90 % of the step), ``overshoot`` (beyond the final
        reference, % of the step), ``settling_time`` (from t0 until |e| stays within
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
    out: dict[str, float] = {"step": step * 1e3}
    nan = math.nan
    if abs(step) > 0:
        prog = (x - x_a) / step  # 0 → 1 along the move
        i10 = np.flatnonzero(prog >= 0.1)
        i90 = np.flatnonzero(prog >= 0.9)
        out["rise_time"] = float(tt[i90[0]] - tt[i10[0]]) * 1e3 if i10.size and i90.size else nan
        out["overshoot"] = max(0.0, float(np.max((x - r_b) * np.sign(step)))) / abs(step) * 100.0
        bw = band if band is not None else max(0.02 * abs(step), 5e-5)
        outside = np.flatnonzero(np.abs(x - r_b) > bw)
        if outside.size == 0:
            out["settling_time"] = 0.0
        elif outside[-1] == tt.size - 1:
            out["settling_time"] = nan
        else:
            out["settling_time"] = float(tt[outside[-1] + 1] - a) * 1e3
    else:
        out["rise_time"] = out["overshoot"] = out["settling_time"] = nan
    tail = tt >= b - 0.1 * (b - a)
    out["steady_state_error"] = float(np.mean(e[tail])) * 1e3
    out["iae"] = float(np.sum(0.5 * (np.abs(e[1:]) + np.abs(e[:-1])) * np.diff(tt))) * 1e3
    out["max_following_error"] = float(np.max(np.abs(e))) * 1e3
    ts = ctl["t"]
    ms = (ts >= a - 1e-12) & (ts <= b + 1e-12)
    u = ctl["u"][ms]
    lo, hi = ctl["u_limits"]
    tol = 1e-9 * max(1.0, abs(lo), abs(hi))
    out["saturation"] = float(np.mean((u <= lo + tol) | (u >= hi - tol))) * 100.0 if u.size else nan
    rows = ctl["row"][ms]
    switches = int(np.count_nonzero(np.diff(rows) != 0))
    for key in ("cell_g", "cell_o", "cell_n", "cell_w"):
        if key in result.channels:
            switches += int(np.count_nonzero(np.diff(result.channels[key][m]) != 0))
    out["cell_switches"] = float(switches)
    # a sign change counts between commands beyond ±1 % of the range (hysteresis): the
    # sub-percent dither of a held position is not chattering
    thr = 0.01 * max(abs(lo), abs(hi))
    sg = np.sign(u[np.abs(u) > thr])
    out["chattering"] = float(np.count_nonzero(np.diff(sg) != 0)) / max(b - a, 1e-12)
    return out


def compare_models(
    controller,
    reference,
    *,
    params=None,
    pwa=None,
    duration: float,
    initial_position: float | None = None,
    load_force=None,
    models=("full", "reduced", "pwa"),
    window: tuple[float, float] | None = None,
    rtol: float | None = None,
    x0: float | None = None,
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

    Returns
    -------
    results : dict of SimulationResult
    table : pandas.DataFrame
        One row per model, columns :data:`METRIC_UNITS` (units in ``attrs['units']``).
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
    for name in models:
        if name == "pwa":
            if pwa is None:
                pwa = linearize(params)
            mdl: Any = pwa
        elif name == "pwa-chamber":
            mdl = linearize(params, form="chamber")
        else:
            mdl = name
        results[name] = simulate(
            mdl,
            duration=duration,
            params=params,
            controller=controller,
            reference=ref,
            initial_position=start,
            load_force=load_force,
            rtol=DEFAULT_RTOL if rtol is None else rtol,
        )
    w = window or (None, None)
    table = pd.DataFrame({name: tracking_metrics(res, *w) for name, res in results.items()}).T
    table.index.name = "model"
    table.attrs["units"] = dict(METRIC_UNITS)
    return results, table
