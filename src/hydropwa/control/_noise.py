"""Sensor noise levels measured from the standstill stretches of measured or simulated runs.

:func:`sensor_noise_from` gives the standard deviation of each measured channel (x, P_A,
P_B, and the spool position where the valve reports it) that a controller's estimator and
verification are designed for: the runs are cut into windows, the windows where the rod
stands still are kept, and in each the channel's scatter about its straight-line fit is its
noise (sensor noise plus the converter's quantization, step²/12). The median over the windows is robust against the few windows
that hold a pressure transient.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

import numpy as np

from ._controllers import ControlError

__all__ = ["NOISE_CHANNELS", "sensor_noise_from"]

#: Measured channels of a controller whose noise is estimated (SI: m, Pa, Pa; the spool position
#: the valve reports [1], where a run records it).
NOISE_CHANNELS = ("x", "p_a", "p_b", "spool")


def _runs(data: Any) -> list:
    """The runs of a Run, a Dataset or an iterable of runs."""
    if hasattr(data, "channels") and hasattr(data, "t"):
        return [data]
    if isinstance(data, Iterable) and not isinstance(data, str | bytes):
        runs = list(data)
        if all(hasattr(r, "channels") and hasattr(r, "t") for r in runs):
            return runs
    raise ControlError(
        f"sensor_noise_from needs a Run, a Dataset or a list of runs, not {type(data).__name__}; "
        "read a dataset folder with hydropwa.data.read_dataset"
    )


def _standstill_windows(t: np.ndarray, x: np.ndarray, n: int, max_velocity: float):
    """Index slices of the windows of n samples where x stands still.

    Both halves of the window must have a straight-line fit slower than ``max_velocity``
    (a window about a reversal has a small mean slope but two fast halves).
    """
    out = []
    h = n // 2
    for i in range(0, len(t) - n + 1, n):
        halves = (slice(i, i + h), slice(i + h, i + n))
        if all(abs(np.polyfit(t[s] - t[i], x[s], 1)[0]) <= max_velocity for s in halves):
            out.append(slice(i, i + n))
    return out


def sensor_noise_from(
    data: Any, *, window: float = 0.1, max_velocity: float = 1e-3, min_windows: int = 3
) -> dict[str, float]:
    """Standard deviation of the noise on x [m], P_A, P_B [Pa] and the spool [1] from the standstill stretches of ``data``.

    Parameters
    ----------
    data : Run, Dataset or iterable of Run
        Measured (or simulated) runs with ``t`` and ``x``; ``p_a``, ``p_b`` and ``spool`` (the
        spool position the valve reports, in units of the valve signal) where recorded.
    window : float
        Window length [s] (default 0.1 s, at least 10 samples).
    max_velocity : float
        A window is a standstill when the slopes of the straight lines fitted to x over each
        of its halves are at most this [m/s] (default 1 mm/s).
    min_windows : int
        Fewest standstill windows needed (default 3).

    Returns
    -------
    dict
        {channel: standard deviation} for the channels of :data:`NOISE_CHANNELS` that the
        runs record, SI units; the median over the standstill windows of the scatter about
        each window's straight-line fit (ddof 2), so a slow drift of the signal does not
        count as noise. Quantization of the converters is part of it (step²/12).

    Raises
    ------
    ControlError
        No run with x, or fewer than ``min_windows`` standstill windows.
    """
    if not (isinstance(window, int | float) and math.isfinite(window) and window > 0):
        raise ControlError(f"window {window!r} s must be a positive number")
    if not (isinstance(max_velocity, int | float) and max_velocity >= 0):
        raise ControlError(f"max_velocity {max_velocity!r} m/s must be a number >= 0")
    scatter: dict[str, list[float]] = {c: [] for c in NOISE_CHANNELS}
    with_x = 0
    for run in _runs(data):
        if "x" not in run.channels:
            continue
        with_x += 1
        t = np.asarray(run.t, dtype=float)
        n = max(int(round(window * float(run.fs))), 10)
        for s in _standstill_windows(t, np.asarray(run.channels["x"], float), n, max_velocity):
            tt = t[s] - t[s.start]
            for c in NOISE_CHANNELS:
                if c in run.channels:
                    y = np.asarray(run.channels[c][s], dtype=float)
                    res = y - np.polyval(np.polyfit(tt, y, 1), tt)
                    scatter[c].append(float(np.sqrt(np.sum(res**2) / (len(y) - 2))))
    if with_x == 0:
        raise ControlError(
            "sensor_noise_from: no run records the position x; give the noise levels"
        )
    if len(scatter["x"]) < min_windows:
        raise ControlError(
            f"sensor_noise_from: {len(scatter['x'])} standstill windows (|ẋ| <= {max_velocity:g} m/s "
            f"over {window:g} s) found, {min_windows} needed; give the noise levels instead "
            "(e.g. --sensor-noise 'x=20 um,p_a=0.1 bar,p_b=0.1 bar')"
        )
    return {c: float(np.median(v)) for c, v in scatter.items() if v}
