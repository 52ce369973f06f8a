"""Sizing of the control law's bands at a hold from the sensors' noise: the quiet band q,
its opening delay n, the integral band e_I, and the measured constants of the pre-opening, the
integral's leak and the pressure vent (docs/control.md, "The quiet band").

Every function reads a designed :class:`~hydropwa.control.StateFeedbackController` and the
sensor noise; none designs gains (that is :mod:`._design`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from ._controllers import ControlError

__all__ = [
    "command_noise",
    "command_noise_correlation",
    "quiet_band_for",
    "quiet_open_for",
    "integral_band_for",
    "QUIET_FACTOR",
    "QUIET_OPEN_CORRELATION",
    "INTEGRAL_BAND_FACTOR",
    "INTEGRAL_LEAK",
    "PRE_OPEN_FACTOR",
    "PRESSURE_VENT_SAMPLES",
]


#: the quiet band in units of the command's noise at a hold (:func:`quiet_band_for`). Measured
#: on the paper rig (full model, 20 µm / 0.1 bar, one sample of delay, position observer,
#: last 0.2 s after the 50 → 150 mm trapezoid, noise seeds 1-5): 1.0σ 255 sign changes/s
#: (seed 1); 1.5σ 5-115/s, hold 0.022-0.055 mm; 2.0σ 0-25/s, 0.005-0.055 mm, error
#: 0.060-0.071 mm; 2.5σ 0-5/s but 0.068-0.072 mm. Heavy axis, ±5 kN holds over 200 draws,
#: noisy: 1.5σ 17 of 400 above 0.1 mm (52/s), 2.0σ 2 of 400 (8/s)
QUIET_FACTOR = 2.0


def _observer_error(controller, sx: float):
    """(A, P) of the position observer's error for white position noise ``sx`` [m]: its dynamics
    ε⁺ = A ε − L n, A = (I − L H) Φ, and the steady covariance P (discrete Lyapunov); None
    without the observer or the noise."""
    from scipy.linalg import solve_discrete_lyapunov  # deferred: scipy.linalg at import

    if controller.position_observer is None or sx <= 0.0:
        return None
    ts = controller.sample_time
    L = np.array([[controller.position_observer[0]], [controller.position_observer[1]]])
    A = (np.eye(2) - L @ np.array([[1.0, 0.0]])) @ np.array([[1.0, ts], [0.0, 1.0]])
    return A, solve_discrete_lyapunov(A, L @ L.T * sx**2)


def command_noise(controller, sensor_noise: Mapping[str, float], area_ratio: float) -> np.ndarray:
    """Standard deviation [1] of each gain row's command c that the sensor noise alone makes at a hold.

    c's noise is k_x ε_x + k_v ε_v + k_pl ε_PL: ε_PL the load-pressure noise of the chamber
    sensors (P_A − α P_B: σ² = σ_A² + α²σ_B²; the mean-area form scaled by A_A/Ā), and
    (ε_x, ε_v) the position observer's output noise for white position noise (the
    discrete Lyapunov equation of its error dynamics ε⁺ = (I − L H) Φ ε + L n), or (n, 0)
    without the observer (the design's velocity sensor; a velocity filter is not counted).
    """
    sx = float(sensor_noise.get("x", 0.0))
    sa, sb = float(sensor_noise.get("p_a", 0.0)), float(sensor_noise.get("p_b", 0.0))
    spl = math.hypot(sa, area_ratio * sb)
    if controller.load_pressure == "mean-area":
        spl *= 2.0 / (1.0 + area_ratio)
    obs = _observer_error(controller, sx)
    P = np.diag([sx**2, 0.0]) if obs is None else obs[1]
    out = []
    for r in controller.rows:
        g = np.array([r.k_x, r.k_v])
        out.append(math.sqrt(float(g @ P @ g) + (r.k_pl * spl) ** 2))
    return np.array(out)


#: the quiet band's opening delay n (:func:`quiet_open_for`) is the first lag at which the command
#: noise's autocorrelation at a hold falls below this. Measured on the paper rig's trapezoid hold
#: (full model, 20 µm / 0.1 bar, one sample of delay; noise seeds 1-40; the rule sized here gives
#: n = 12 there and n = 3 on the heavy axis), hold peak to peak over seeds 1-10 / 11-20 / 21-30 /
#: 31-40 and the most sign changes/s: n = 1 (none) ≤ 0.032 / 0.046 / 0.029 / 0.038 mm, 135/s;
#: n = 4 ≤ 0.025 / 0.032 mm, 35/s (seeds 1-20); n = 8 ≤ 0.017 / 0.017 / 0.026 / 0.016 mm, 35/s;
#: n = 12 ≤ 0.020 / 0.020 / 0.022 / 0.019 mm, 15/s. n = 12 on the heavy axis: a limit cycle in
#: the four-draw verification (+50 % force, 0.92 mm); its n = 3 passes (docs/control.md)
QUIET_OPEN_CORRELATION = 0.1


def command_noise_correlation(
    controller, sensor_noise: Mapping[str, float], area_ratio: float, lags: int
) -> np.ndarray:
    """Autocorrelation ρ(k) [1] of each gain row's command noise at a hold, lags k = 1 … ``lags``.

    The command noise (:func:`command_noise`) is the position observer's output error through
    g = [k_x, k_v], correlated by its error dynamics A = (I − L H) Φ, plus the white
    load-pressure noise through k_pl: ρ(k) = g Aᵏ P gᵀ / (g P gᵀ + k_pl² σ_PL²), P the
    observer's error covariance. Without the observer (or position noise) the noise is white:
    ρ = 0. Shape (rows, lags).
    """
    out = np.zeros((len(controller.rows), int(lags)))
    obs = _observer_error(controller, float(sensor_noise.get("x", 0.0)))
    if obs is None:
        return out
    A, P = obs
    var = command_noise(controller, sensor_noise, area_ratio) ** 2
    g = np.array([[r.k_x, r.k_v] for r in controller.rows])
    AkP = P
    for k in range(int(lags)):
        AkP = A @ AkP
        out[:, k] = np.einsum("ij,jk,ik->i", g, AkP, g) / var
    return out


def quiet_open_for(
    controller,
    sensor_noise: Mapping[str, float],
    area_ratio: float,
    correlation: float = QUIET_OPEN_CORRELATION,
) -> int:
    """Opening delay n [samples] of the quiet band: the first lag at which the command noise's autocorrelation falls below ``correlation``.

    The autocorrelation is :func:`command_noise_correlation`'s, the median over the rows whose
    box holds a hold (all rows if none does); n is at most 100. Beyond n samples the noise
    has all but forgotten where it was, so n consecutive samples beyond the quiet band are
    about as unlikely as n independent ones, while a position error beyond the band still
    opens the valve after n samples. Without the position observer the noise is white: n = 1,
    the band without a delay.
    """
    if not (math.isfinite(correlation) and 0.0 < correlation < 1.0):
        raise ControlError(f"quiet-open correlation {correlation!r} must be between 0 and 1")
    rho = command_noise_correlation(controller, sensor_noise, area_ratio, 100)
    hold = _hold_rows(controller) or list(range(len(controller.rows)))
    below = np.nonzero(np.median(rho[hold], axis=0) < correlation)[0]
    return int(below[0]) + 1 if below.size else 100


def quiet_band_for(
    controller, sensor_noise: Mapping[str, float], area_ratio: float, factor: float = QUIET_FACTOR
) -> float:
    """Quiet band q [1] for ``controller`` under ``sensor_noise``: ``factor`` times the command noise at a hold.

    The command noise (:func:`command_noise`) is the median over the rows whose box holds
    a hold (ẋ = 0 and c = 0; all rows if none does). With q the valve stays closed while
    the noise alone moves the command (:class:`~hydropwa.control.DeadZoneInverse`).
    """
    if not (math.isfinite(factor) and factor > 0):
        raise ControlError(f"quiet band factor {factor!r} must be a positive number")
    sig = command_noise(controller, sensor_noise, area_ratio)
    hold = _hold_rows(controller)
    return float(factor * np.median(sig[hold] if hold else sig))


def _hold_rows(controller) -> list[int]:
    """Indices of the gain rows whose box holds a hold (ẋ = 0 and c = 0)."""
    return [
        i
        for i, r in enumerate(controller.rows)
        if r.lower[1] <= 0.0 <= r.upper[1] and r.lower[3] <= 0.0 <= r.upper[3]
    ]


#: the integral band e_I in units of the quiet band's position width q/k_x
#: (:func:`integral_band_for`), and the integral's leak time constant [s] where the band parks
#: the valve. Measured with ``verify_controller`` (10 draws, exact / 20 µm + 0.1 bar sensors,
#: one sample of delay, leak 20 ms): paper rig factor 4: hold 0.100 mm and 80 sign changes/s
#: (exact); 5: 0.062 / 0.054 mm, mean hold error 0.021 / 0.013 mm; 8: the same; heavy axis
#: 5: 0.053 / 0.027 mm, mean 0.052 / 0.061 mm; 8: 0.071 / 0.031 mm. Leak 50 ms: paper rig
#: 0.075 / 0.052 mm, mean 0.023 / 0.021 mm; no leak: mean 0.079 / 0.054 mm (factor 6)
INTEGRAL_BAND_FACTOR = 5.0
INTEGRAL_LEAK = 0.02
#: the pre-opening's look-ahead τ_o in units of the feed-forward's look-ahead τ (the valve's
#: lag, 1.5 T_s + 2ζ/ω0): the spool needs about another τ to cross the dead zone. Measured on
#: the paper rig's trapezoid (τ = 3 ms; peak error, exact and seeds 1, 2, 5, 6, 7): τ_o = 3 ms
#: 0.059-0.067 mm, 4 ms 0.049-0.056 mm, 6 ms 0.037-0.044 mm (docs/control.md)
PRE_OPEN_FACTOR = 2.0
#: the pressure vent's low-pass T_p in samples (T_p = 40 T_s: 20 ms at 2 kHz): the pressure share's
#: sensor noise averaged over 2 T_p/T_s = 80 samples is about √80 ≈ 9 times smaller, well inside the
#: vent's dead band 0.8 q (``QUIET_VENT`` of the compiled law), while T_p stays below the creep's
#: time constant (~0.1 s) it is to cut short. Measured on the paper rig's trapezoid hold (exact and
#: noise seeds 1-10, dead band 0.6 q): 30 / 40 / 50 samples: hold ≤ 0.030 / 0.029 / 0.029 mm,
#: ≤ 95 / 85 / 95 sign changes/s; 80 samples with 0.7 q: 0.032 mm (docs/control.md)
PRESSURE_VENT_SAMPLES = 40.0


def integral_band_for(controller, quiet_band: float, factor: float = INTEGRAL_BAND_FACTOR) -> float:
    """Integral band e_I [m]: ``factor`` times the quiet band's width in position, q/k_x.

    k_x is the median over the rows whose box holds a hold (all rows if none does). Beyond
    e_I the integral does not run (:class:`~hydropwa.control.DeadZoneInverse`): the
    millimetre errors of a step's approach would wind it into an undershoot that static
    friction then holds while the integral unwinds.
    """
    if not (math.isfinite(factor) and factor > 0):
        raise ControlError(f"integral band factor {factor!r} must be a positive number")
    hold = _hold_rows(controller) or list(range(len(controller.rows)))
    kx = float(np.median([abs(controller.rows[i].k_x) for i in hold]))
    return float(factor * quiet_band / kx) if kx > 0.0 else 0.0
