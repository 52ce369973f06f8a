"""Fit metrics of a model output against a measurement (Sec. VII of the paper).

Plain functions of arrays: the NRMSE fit in %, the RMSE, the peak error and the drift of
the rod position per period of a periodic input. Samples where either signal is not finite
are left out (a simulation that stopped early leaves NaN behind).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["nrmse_fit", "rmse", "peak_error", "drift_per_period", "channel_metrics"]


def _pair(y, y_hat) -> tuple[np.ndarray, np.ndarray]:
    y = np.asarray(y, dtype=float).ravel()
    y_hat = np.asarray(y_hat, dtype=float).ravel()
    if y.shape != y_hat.shape:
        raise ValueError(
            f"measurement ({y.size} samples) and model ({y_hat.size}) differ in length"
        )
    ok = np.isfinite(y) & np.isfinite(y_hat)
    return y[ok], y_hat[ok]


def nrmse_fit(y, y_hat) -> float:
    """Normalised root-mean-square fit [%]: 100·(1 − ‖y − ŷ‖ / ‖y − mean(y)‖).

    Parameters
    ----------
    y : array_like, shape (n,)
        Measurement [any unit].
    y_hat : array_like, shape (n,)
        Model output [same unit].

    Returns
    -------
    float
        100 for a perfect fit, 0 for a model no better than the measurement's mean,
        negative for a worse one; NaN when y is constant or no sample is finite.

    Notes
    -----
    The ``compare`` fit of system identification toolboxes (MATLAB ``goodnessOfFit``, NRMSE).
    """
    y, y_hat = _pair(y, y_hat)
    den = float(np.linalg.norm(y - y.mean())) if y.size else 0.0
    if den == 0.0:
        return math.nan
    return 100.0 * (1.0 - float(np.linalg.norm(y - y_hat)) / den)


def rmse(y, y_hat) -> float:
    """Root-mean-square error √(mean((y − ŷ)²)) [unit of y]; NaN without finite samples."""
    y, y_hat = _pair(y, y_hat)
    return float(np.sqrt(np.mean((y - y_hat) ** 2))) if y.size else math.nan


def peak_error(y, y_hat) -> float:
    """Largest absolute error max|y − ŷ| [unit of y]; NaN without finite samples."""
    y, y_hat = _pair(y, y_hat)
    return float(np.max(np.abs(y - y_hat))) if y.size else math.nan


def drift_per_period(t, x, period: float) -> float:
    """Mean change of the period average of ``x`` from one period to the next [unit of x].

    Parameters
    ----------
    t : array_like, shape (n,)
        Times [s], increasing.
    x : array_like, shape (n,)
        Signal, e.g. the rod position [m].
    period : float
        Period of the input [s].

    Returns
    -------
    float
        (mean over the last full period − mean over the first) / (number of periods − 1);
        NaN with fewer than two full periods.

    Notes
    -----
    Averaging over whole periods removes the periodic part exactly, so a ramp a·t plus any
    T-periodic signal gives a·T. The asymmetric cylinder of the paper drifts to +x under a
    zero-mean sine (Sec. VII), which this measures.
    """
    t = np.asarray(t, dtype=float).ravel()
    x = np.asarray(x, dtype=float).ravel()
    if not (period > 0) or t.size < 2:
        return math.nan
    n = int(math.floor((t[-1] - t[0]) / period + 1e-9))
    if n < 2:
        return math.nan
    means = []
    for k in (0, n - 1):
        sel = (t >= t[0] + k * period) & (t < t[0] + (k + 1) * period - 1e-12)
        vals = x[sel]
        vals = vals[np.isfinite(vals)]
        if vals.size == 0:
            return math.nan
        means.append(float(vals.mean()))
    return (means[1] - means[0]) / (n - 1)


def channel_metrics(y, y_hat) -> dict[str, float]:
    """NRMSE fit [%], RMSE and peak error [unit of y], and the fraction of finite model samples."""
    y_hat_arr = np.asarray(y_hat, dtype=float)
    return {
        "nrmse_fit": nrmse_fit(y, y_hat),
        "rmse": rmse(y, y_hat),
        "peak_error": peak_error(y, y_hat),
        "coverage": float(np.mean(np.isfinite(y_hat_arr))) if y_hat_arr.size else 0.0,
    }
