"""Stribeck friction from constant-input runs against a counter force (Sec. VI-C, Fig. 8).

Per run: the steady part (moving-window velocity and net force inside a band
around their medians, away from both end stops) gives averaged P_A, P_B, F_L and
the friction force of Eq. (10) at steady state,

    f = P_A A_A − P_B A_B − F_L,

and the velocity from a least-squares line through the position. The points
(ẋ, f) are fitted with Eq. (11),

    f(ẋ) = tanh(γẋ)·(F_c + (F_s − F_c)·exp(−|ẋ/χ|^δ)) + σẋ,

by bounded nonlinear least squares in (F_c, F_s − F_c, σ, log10 χ, δ, log10 γ)
with a robust loss and many starts. For fixed (χ, δ, γ) the model is linear in
(F_c, F_s, σ), which gives each start its linear part exactly.
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

import numpy as np
from scipy.optimize import least_squares

from .._errors import IdentificationError, ParameterError
from ..components import net_piston_force, stribeck_friction
from ..params import Friction, SystemParams
from ._common import (
    OptimizerStatus,
    ParameterEstimate,
    RigGeometry,
    SkippedRun,
    as_runs,
    channels_of,
    correlation,
    not_fitted,
    require_usable,
    resolve_geometry,
    sandwich_covariance,
    skip,
    t_quantile,
)
from ._deadzone import command_level

__all__ = [
    "FrictionPoint",
    "steady_window",
    "friction_point",
    "friction_samples",
    "StribeckFit",
    "BreakawayRun",
    "breakaway_peaks",
    "curve_maximum",
    "fit_stribeck",
    "StribeckIdentifier",
    "SteadyStateAverage",
    "InstantaneousBins",
    "BreakawayConstrained",
    "FrictionMethod",
    "STRIBECK_NAMES",
]

# 8th-order central stencils of d/dt and d²/dt² (multiply by 1/dt, 1/dt²).
_D1 = np.array([1 / 280, -4 / 105, 1 / 5, -4 / 5, 0.0, 4 / 5, -1 / 5, 4 / 105, -1 / 280])
_D2 = np.array([-1 / 560, 8 / 315, -1 / 5, 8 / 5, -205 / 72, 8 / 5, -1 / 5, 8 / 315, -1 / 560])

#: Friction field names in the order of the fit vector.
STRIBECK_NAMES = ("coulomb", "static", "viscous", "stribeck_velocity", "shape", "smoothness")
_UNITS = {
    "coulomb": "N",
    "static": "N",
    "viscous": "N·s/m",
    "stribeck_velocity": "m/s",
    "shape": "1",
    "smoothness": "s/m",
}


def _default_bounds(vmin: float) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of θ for data whose slowest speed is ``vmin`` [m/s] (see :func:`fit_stribeck`)."""
    lb = np.array([0.0, 0.0, 0.0, np.log10(vmin / 10.0), 0.5, np.log10(3.0 / vmin)])
    ub = np.array([1e5, 1e5, 1e7, 0.0, 5.0, 7.0])
    lb[5] = min(lb[5], 6.0)
    return lb, ub


def _moving_slope(t: np.ndarray, x: np.ndarray, half: int) -> np.ndarray:
    """Central secant slope over ±``half`` samples (NaN near the ends)."""
    out = np.full(x.shape, np.nan)
    if x.size > 2 * half:
        out[half:-half] = (x[2 * half :] - x[: -2 * half]) / (t[2 * half :] - t[: -2 * half])
    return out


def _moving_mean(y: np.ndarray, half: int) -> np.ndarray:
    out = np.full(y.shape, np.nan)
    if y.size > 2 * half:
        c = np.concatenate(([0.0], np.cumsum(y)))
        w = 2 * half + 1
        out[half:-half] = (c[w:] - c[:-w]) / w
    return out


def _longest_true(mask: np.ndarray) -> tuple[int, int]:
    """(start, stop) of the longest run of True (stop exclusive); (0, 0) if none."""
    m = np.concatenate(([False], mask, [False])).astype(np.int8)
    d = np.diff(m)
    starts, stops = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
    if starts.size == 0:
        return 0, 0
    k = int(np.argmax(stops - starts))
    return int(starts[k]), int(stops[k])


def _adaptive_window(
    t: np.ndarray, x: np.ndarray, window: float, band: float, abs_band: float
) -> float:
    """Lengthen the window so that position noise moves the secant velocity by < 1/3 of the band.

    The noise σ_x is estimated from sample-to-sample differences; a secant over a
    window T has velocity noise √2·σ_x/T.
    """
    d = np.diff(x)
    sigma_x = 1.4826 * float(np.median(np.abs(d - np.median(d)))) / np.sqrt(2.0)
    n = t.size
    v_rough = abs(float(np.median(x[n // 2 :]) - np.median(x[: n // 2]))) / max(
        0.5 * (t[-1] - t[0]), 1e-12
    )
    need = 3.0 * np.sqrt(2.0) * sigma_x / max(band * v_rough, abs_band)
    return float(min(max(window, need), max(window, (t[-1] - t[0]) / 4.0)))


def steady_window(
    t,
    x,
    net_force=None,
    stroke: float | None = None,
    stop_margin: float = 2e-3,
    window: float = 0.1,
    band: float = 0.15,
    abs_band: float = 5e-4,
    force_band: float = 0.25,
    force_abs_band: float = 20.0,
    min_duration: float = 0.2,
) -> slice:
    """The longest steady stretch of a constant-input run.

    Parameters
    ----------
    t, x : array_like, shape (N,)
        Time [s] and rod position [m].
    net_force : array_like, shape (N,), optional
        P_A A_A − P_B A_B − F_L [N]; when given it must be steady too.
    stroke : float, optional
        Stroke [m]; samples within ``stop_margin`` of 0 or ``stroke`` are not steady.
    stop_margin : float
        Distance [m] from an end stop treated as contact.
    window : float
        Shortest length [s] of the moving window for velocity and force; longer where
        position noise would otherwise put the window velocity outside the band
        (slow runs), at most a quarter of the run.
    band, abs_band : float
        Velocity band: |v_w − median| ≤ max(band·|median|, abs_band) [1], [m/s].
    force_band, force_abs_band : float
        Force band, likewise [1], [N].
    min_duration : float
        Shortest acceptable steady stretch [s].

    Returns
    -------
    slice
        Sample indices of the steady stretch.

    Raises
    ------
    IdentificationError
        If no steady stretch of ``min_duration`` exists.
    """
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    dt = float(np.median(np.diff(t)))
    window = _adaptive_window(t, x, window, band, abs_band)
    half = max(1, int(round(0.5 * window / dt)))
    vw = _moving_slope(t, x, half)
    ok = np.isfinite(vw)
    if stroke is not None:
        ok &= (x > stop_margin) & (x < stroke - stop_margin)
    if not ok.any():
        raise IdentificationError("no steady state: the rod never moves away from the end stops")
    med = float(np.median(vw[ok]))
    steady = ok & (np.abs(vw - med) <= max(band * abs(med), abs_band))
    if net_force is not None:
        fw = _moving_mean(np.asarray(net_force, dtype=float), half)
        fmed = float(np.median(fw[steady])) if steady.any() else float(np.nanmedian(fw))
        steady &= np.abs(fw - fmed) <= max(force_band * abs(fmed), force_abs_band)
    i0, i1 = _longest_true(steady)
    dur = float(t[i1 - 1] - t[i0]) if i1 > i0 else 0.0
    if dur < min_duration:
        raise IdentificationError(
            f"no steady state: longest steady stretch {dur:.3g} s, need {min_duration:g} s "
            "(velocity or force keeps changing, or the run hits the end stop)"
        )
    return slice(i0, i1)


@dataclasses.dataclass(frozen=True)
class FrictionPoint:
    """One steady-state friction measurement.

    Attributes
    ----------
    velocity, velocity_std : float
        ẋ [m/s] from the position slope, and its standard error.
    force, force_std : float
        f [N] of Eq. (10) at steady state, and the standard deviation of the
        window mean (from the sample spread over √(number of windows)).
    p_a, p_b, f_l : float
        Mean chamber pressures [Pa] and load force [N] over the steady part.
    window : tuple of float
        (t0, t1) [s] of the steady part.
    rms_position_residual : float
        Deviation of the position from the line [m] (Sec. VI-C, Fig. 7).
    force_fluctuation : float
        Standard deviation [N] of the net force over the steady part; far above the
        sensor noise it reveals a limit cycle, whose averaged force is not the static
        friction at the mean speed.
    """

    velocity: float
    velocity_std: float
    force: float
    force_std: float
    p_a: float
    p_b: float
    f_l: float
    window: tuple[float, float]
    rms_position_residual: float
    force_fluctuation: float = float("nan")


def friction_point(
    t, x, p_a, p_b, f_l, area_a: float, area_b: float, stroke: float | None = None, **window_kw
) -> FrictionPoint:
    """Steady-state friction force and velocity of one run, Eq. (10).

    Parameters
    ----------
    t, x, p_a, p_b, f_l : array_like, shape (N,)
        Time [s], position [m], chamber pressures [Pa], load force [N].
    area_a, area_b : float
        Piston areas A_A, A_B [m²].
    stroke : float, optional
        Stroke [m] for end-stop exclusion.
    **window_kw
        Passed to :func:`steady_window`.

    Returns
    -------
    FrictionPoint
    """
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    net = net_piston_force(p_a, p_b, f_l, area_a, area_b)
    sl = steady_window(t, x, net, stroke, **window_kw)
    ts, xs = t[sl], x[sl]
    tc = ts - ts.mean()
    slope = float(tc @ (xs - xs.mean())) / float(tc @ tc)
    r = xs - xs.mean() - slope * tc
    vstd = float(np.sqrt(float(r @ r) / max(ts.size - 2, 1) / float(tc @ tc)))
    n_blocks = max(1, int((ts[-1] - ts[0]) / window_kw.get("window", 0.1)))
    return FrictionPoint(
        velocity=slope,
        velocity_std=vstd,
        force=float(np.mean(net[sl])),
        force_std=float(np.std(net[sl]) / np.sqrt(n_blocks)),
        p_a=float(np.mean(np.asarray(p_a)[sl])),
        p_b=float(np.mean(np.asarray(p_b)[sl])),
        f_l=float(np.mean(np.asarray(f_l)[sl])),
        window=(float(ts[0]), float(ts[-1])),
        rms_position_residual=float(np.sqrt(np.mean(r**2))),
        force_fluctuation=float(np.std(net[sl])),
    )


def _consistent_kernels(
    dt: float, cutoff: float, taps: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Zero-phase low-pass h and its exact-in-band derivatives h', h'' (convolution kernels).

    h is a Kaiser-windowed FIR (β = 6, unit DC gain); h' = h ∗ D1, h'' = h ∗ D2 with 8th-order
    central stencils, so that within the pass band H'(ω) = jω·H(ω) and H''(ω) = −ω²·H(ω)
    to < 0.1 % up to 300 Hz at 2 kHz. This keeps m·ẍ consistent with the smoothed forces;
    Savitzky–Golay derivative filters are not (at 200 Hz, window 11, order 3 their ẍ gain is
    0.40 against 0.69 for the smoothing), which turns the inertia term into a spurious loop.
    """
    from scipy.signal import firwin  # deferred: scipy submodule, loaded only when fitting

    taps = int(taps) | 1
    h = firwin(taps, cutoff, fs=1.0 / dt, window=("kaiser", 6.0))
    h = h / h.sum()
    return np.pad(h, 4), np.convolve(h, _D1[::-1]) / dt, np.convolve(h, _D2[::-1]) / dt**2


def friction_samples(
    t,
    x,
    p_a,
    p_b,
    f_l,
    area_a: float,
    area_b: float,
    mass: float,
    u=None,
    stroke: float | None = None,
    stop_margin: float = 2e-3,
    settle: float = 0.15,
    cutoff: float = 300.0,
    taps: int = 41,
    min_speed: float = 3e-3,
    guard: float = 0.0,
    decimate: int = 1,
) -> tuple[np.ndarray, np.ndarray]:
    """Per-sample friction force of Eq. (10) with inertia, f = P_A A_A − P_B A_B − F_L − m·ẍ.

    Parameters
    ----------
    t, x, p_a, p_b, f_l : array_like, shape (N,)
        Time [s], position [m], chamber pressures [Pa], load force [N].
    area_a, area_b, mass : float
        Piston areas [m²] and moving mass [kg].
    u : array_like, optional
        Command [1]; samples before its last change + ``settle`` are left out.
    stroke, stop_margin : float, optional
        Samples within ``stop_margin`` [m] of an end stop are left out.
    settle : float
        Time [s] after the last command change that is left out.
    cutoff, taps : float, int
        Pass band [Hz] and length of the zero-phase FIR applied alike to position (with
        its consistent first and second derivative) and to the net force, so all
        channels share one delay-free response.
    min_speed : float
        Samples with |ẋ| below max(min_speed, 3·velocity noise) [m/s] are left out (the
        tanh/stiction band, where the force is set by the dynamics, not by the curve).
    guard : float
        Also leave out samples within ``guard`` [s] of a slow sample (filter smear of a
        stick→slip corner).
    decimate : int
        Keep every ``decimate``-th sample.

    Returns
    -------
    v, f : ndarray
        Velocity [m/s] and friction force [N] of the kept samples; samples moving
        against the run's main direction (filter ringing at stick-slip corners) are dropped.
    """
    t, x, dt, h, h1, v, a, nf = _filtered_motion(t, x, p_a, p_b, f_l, area_a, area_b, cutoff, taps)
    f = nf - mass * a
    ok = _usable_samples(t, x, u, h.size, settle, stroke, stop_margin)
    d4 = np.diff(x, 4)
    sigma_x = 1.4826 * float(np.median(np.abs(d4 - np.median(d4)))) / np.sqrt(70.0)
    vmin = max(min_speed, 3.0 * sigma_x * float(np.sqrt(np.sum(h1**2))))
    slow = np.abs(v) < vmin
    if guard > 0:
        n = int(round(guard / dt))
        slow = np.convolve(slow.astype(float), np.ones(2 * n + 1), mode="same") > 0.5
    ok &= ~slow
    if ok.any():
        ok &= np.sign(v) == np.sign(np.median(v[ok]))
    if not ok.any():
        raise IdentificationError(
            f"no moving samples: |ẋ| stays below {1e3 * vmin:.3g} mm/s away from the stops"
        )
    return v[ok][:: max(int(decimate), 1)], f[ok][:: max(int(decimate), 1)]


@dataclasses.dataclass(frozen=True)
class BreakawayRun:
    """Net-force peaks of the stick-slip cycles of one constant-input run.

    Attributes
    ----------
    direction : float
        +1 (extending) or −1 (retracting).
    mean_speed : float
        |ẋ| averaged over the used part [m/s] (position secant); sets the loading rate.
    peaks : ndarray
        Per-cycle peak of the filtered net force P_A A_A − P_B A_B − F_L [N], as a magnitude,
        parabolically interpolated between samples.
    """

    direction: float
    mean_speed: float
    peaks: np.ndarray

    @property
    def force(self) -> float:
        """Median per-cycle peak [N]."""
        return float(np.median(self.peaks))


def breakaway_peaks(
    t,
    x,
    p_a,
    p_b,
    f_l,
    area_a: float,
    area_b: float,
    u=None,
    stroke: float | None = None,
    stop_margin: float = 2e-3,
    settle: float = 0.15,
    cutoff: float = 300.0,
    taps: int = 41,
    min_slip: float = 5e-3,
    min_gap: float = 2e-3,
) -> BreakawayRun:
    """Per-cycle peaks of the net force in a stick-slip run (the break-away force).

    A cycle runs from one slip (local maximum of the filtered |ẋ| above ``min_slip``) to
    the next, with a stick in between (|ẋ| below 30 % of both slip peaks). Its peak is the
    maximum of the filtered net force P_A A_A − P_B A_B − F_L between the two slips.

    Parameters
    ----------
    t, x, p_a, p_b, f_l : array_like, shape (N,)
        Time [s], position [m], chamber pressures [Pa], load force [N].
    area_a, area_b : float
        Piston areas [m²].
    u : array_like, optional
        Command [1]; samples before its last change + ``settle`` are left out.
    stroke, stop_margin : float, optional
        Samples within ``stop_margin`` [m] of an end stop are left out.
    settle : float
        Time [s] after the last command change that is left out.
    cutoff, taps : float, int
        Zero-phase FIR as in :func:`friction_samples`.
    min_slip : float
        Smallest slip speed [m/s] (at least 3× the filtered velocity noise).
    min_gap : float
        Shortest time between two slips [s].

    Returns
    -------
    BreakawayRun
        ``peaks`` is empty if the run does not stick-slip.

    Notes
    -----
    The peak equals the break-away force, the maximum of Eq. (11), only when the net force
    rises slowly (slowest runs): the rod accelerates after break-away while the valve keeps
    feeding oil, so the net force overshoots by m·ẍ, by ≈ 20–40 % at 15–40 mm/s on the
    virtual rig. :class:`StribeckIdentifier` therefore uses the slowest stick-slip runs only.
    """
    t, x, dt, h, h1, v, _, nf = _filtered_motion(t, x, p_a, p_b, f_l, area_a, area_b, cutoff, taps)
    ok = _usable_samples(t, x, u, h.size, settle, stroke, stop_margin)
    if ok.sum() < 10:
        raise IdentificationError("no samples away from the stops after the command settled")
    idx = np.flatnonzero(ok)
    i0, i1 = int(idx[0]), int(idx[-1])
    mean_v = float((x[i1] - x[i0]) / max(t[i1] - t[i0], dt))
    s = 1.0 if mean_v >= 0 else -1.0
    d4 = np.diff(x, 4)
    sigma_x = 1.4826 * float(np.median(np.abs(d4 - np.median(d4)))) / np.sqrt(70.0)
    vslip = max(min_slip, 3.0 * sigma_x * float(np.sqrt(np.sum(h1**2))))
    sv = np.where(ok, s * v, -np.inf)
    y = s * nf
    from scipy.signal import find_peaks  # deferred: scipy submodule, loaded only when fitting

    pk, _ = find_peaks(
        np.where(ok, sv, -1.0), height=vslip, distance=max(1, int(round(min_gap / dt)))
    )
    peaks = []
    for a, b in zip(pk[:-1], pk[1:], strict=True):
        if not ok[a : b + 1].all() or float(np.min(sv[a:b])) > 0.3 * min(sv[a], sv[b]):
            continue
        k = a + int(np.argmax(y[a : b + 1]))
        if k <= a or k >= b:
            continue
        y0, y1, y2 = y[k - 1], y[k], y[k + 1]
        den = y0 - 2.0 * y1 + y2
        peaks.append(y1 - 0.125 * (y0 - y2) ** 2 / den if den < 0 else y1)
    return BreakawayRun(s, abs(mean_v), np.asarray(peaks, dtype=float))


def curve_maximum(friction: Friction, v_max: float = 1.0) -> tuple[float, float]:
    """Largest friction force of Eq. (11) over 0 < ẋ ≤ ``v_max`` and where it lies.

    Returns
    -------
    f_max, v_at : float
        The maximum [N] (the break-away force of the curve; below F_s by the tanh rounding,
        e.g. 0.83·F_s for the paper's set) and its velocity [m/s]. The first local maximum
        (the Stribeck peak) is returned when σ·ẋ makes the curve rise again at high speed.
    """
    return _curve_max(_theta_of(friction), v_max)


def _curve_max(th: np.ndarray, v_max: float = 1.0) -> tuple[float, float]:
    from scipy.optimize import (
        minimize_scalar,  # deferred: scipy submodule, loaded only when fitting
    )

    vg = np.logspace(-7, np.log10(v_max), 400)
    fg = _eval(vg, th)
    # first local maximum (Stribeck peak), else the global one
    loc = np.flatnonzero((fg[1:-1] >= fg[:-2]) & (fg[1:-1] >= fg[2:])) + 1
    k = int(loc[0]) if loc.size else int(np.argmax(fg))
    lo, hi = np.log(vg[max(k - 1, 0)]), np.log(vg[min(k + 1, vg.size - 1)])
    res = minimize_scalar(
        lambda z: -float(_eval(np.array([np.exp(z)]), th)[0]),
        bounds=(lo, hi),
        method="bounded",
        options={"xatol": 1e-6},
    )
    z = float(res.x) if -res.fun >= fg[k] else float(np.log(vg[k]))
    return float(_eval(np.array([np.exp(z)]), th)[0]), float(np.exp(z))


def _velocity_bins(
    v: np.ndarray, f: np.ndarray, rel: float, width: float, min_count: int
) -> np.ndarray:
    """(median v, median f) per velocity bin of width max(rel·|v|, width), per direction; shape (K, 3) with count."""
    out = []
    for s in (1.0, -1.0):
        sel = np.sign(v) == s
        if not sel.any():
            continue
        vs, fs = s * v[sel], f[sel]
        edges = [float(vs.min())]
        while edges[-1] <= vs.max():
            edges.append(edges[-1] + max(rel * edges[-1], width))
        idx = np.digitize(vs, edges)
        for k in np.unique(idx):
            m = idx == k
            if m.sum() >= min_count:
                out.append((s * float(np.median(vs[m])), float(np.median(fs[m])), int(m.sum())))
    return np.array(out, dtype=float).reshape(-1, 3)


@dataclasses.dataclass(frozen=True)
class StribeckFit:
    """Eq. (11) fitted to velocity–force points.

    Attributes
    ----------
    friction : Friction
        The fitted curve as parameters (PWA code turns it into 7 cells).
    estimates : dict[str, ParameterEstimate]
        Per Friction field; χ and γ intervals come from the log10 scale (asymmetric).
    correlation : ndarray, shape (p, p)
        Correlation of the free fit parameters, in ``free`` order (log10 for χ, γ;
        F_s − F_c for the static entry).
    free : tuple of str
        Names of the free parameters.
    weak : tuple of str
        Parameters the data barely determine (CI wider than ±50 %, a factor 2 on
        the log scale, or at a bound).
    unidentified : tuple of str
        Parameters the data do not determine: the estimate sits at a bound of the fit with
        a confidence interval wider than half its value, or the interval covers the whole
        bounded range. Not written as values (:meth:`StribeckIdentifier.apply` keeps the
        given parameters' value) and reported as not identified.
    velocity, force, residuals : ndarray
        Data [m/s], [N] and residuals f_data − f_model [N].
    rms_residual : float
        RMS residual [N].
    loss : str
        Loss function used.
    n_starts : int
        Number of starting points tried.
    status : OptimizerStatus
        How the final (robust) ``least_squares`` run ended; ``nfev`` counts the residual
        evaluations of every start and stage.
    """

    friction: Friction
    estimates: dict[str, ParameterEstimate]
    correlation: np.ndarray
    free: tuple[str, ...]
    weak: tuple[str, ...]
    velocity: np.ndarray
    force: np.ndarray
    residuals: np.ndarray
    rms_residual: float
    loss: str
    n_starts: int
    status: OptimizerStatus
    unidentified: tuple[str, ...] = ()

    def force_at(self, v) -> np.ndarray:
        """Fitted friction force [N] at velocity ``v`` [m/s]."""
        return _eval(np.asarray(v, dtype=float), _theta_of(self.friction))


def _theta_of(fr: Friction) -> np.ndarray:
    return np.array(
        [
            fr.coulomb,
            fr.static - fr.coulomb,
            fr.viscous,
            np.log10(fr.stribeck_velocity),
            fr.shape,
            np.log10(fr.smoothness),
        ]
    )


def _eval(v: np.ndarray, th: np.ndarray) -> np.ndarray:
    fc, dfs, sigma, lchi, delta, lgam = th
    return stribeck_friction(v, fc, fc + dfs, sigma, 10.0**lchi, delta, 10.0**lgam)


def _jac_theta(v: np.ndarray, th: np.ndarray) -> np.ndarray:
    """Analytic Jacobian of Eq. (11) in θ = (F_c, F_s − F_c, σ, log10 χ, δ, log10 γ), shape (K, 6)."""
    fc, dfs, _, lchi, delta, lgam = th
    chi, gam = 10.0**lchi, 10.0**lgam
    sgn = np.tanh(gam * v)
    ratio = np.abs(v) / chi
    with np.errstate(divide="ignore"):
        logr = np.where(ratio > 0, np.log(np.where(ratio > 0, ratio, 1.0)), 0.0)
    a = ratio**delta
    e = np.exp(-a)
    ln10 = np.log(10.0)
    return np.column_stack(
        [
            sgn,
            sgn * e,
            v,
            sgn * dfs * e * delta * a * ln10,
            -sgn * dfs * e * a * logr,
            (fc + dfs * e) * v * (1.0 - sgn**2) * gam * ln10,
        ]
    )


def _linear_part(
    v: np.ndarray, f: np.ndarray, lchi: float, delta: float, lgam: float
) -> np.ndarray:
    """(F_c, F_s − F_c, σ) ≥ 0 by linear least squares for fixed χ, δ, γ."""
    s = np.tanh(10.0**lgam * v)
    e = np.exp(-(np.abs(v / 10.0**lchi) ** delta))
    X = np.column_stack([s * (1.0 - e), s * e, v])
    coef, *_ = np.linalg.lstsq(X, f, rcond=None)
    fc, fs, sigma = np.clip(coef, 0.0, None)
    return np.array([fc, max(fs - fc, 0.0), sigma])


def fit_stribeck(
    v,
    f,
    fixed: dict[str, float] | None = None,
    loss: str = "soft_l1",
    f_scale: float | None = None,
    n_starts: int = 24,
    level: float = 0.95,
    seed: int = 0,
    bounds: dict[str, tuple[float, float]] | None = None,
    breakaway: tuple[float, float] | None = None,
) -> StribeckFit:
    """Fit the Stribeck curve, Eq. (11), to velocity–force points (Fig. 8).

    Unless γ is fixed or bounded by the caller, the fit is done twice: with γ ≥ 3/v_min
    (the zero crossing sharper than the slowest point: tanh(γ·v_min) > 0.995) and with
    γ ≥ 0.3/v_min (the slowest points may lie on the tanh corner). The wider family is
    taken only when it lowers the sum of squared residuals significantly (F-test at 95 %
    for one extra degree of freedom): with creeping runs at ~1 mm/s the data do show the
    corner, and forcing tanh ≈ 1 there biased F_s by −13 … −16 % on the virtual rig; with
    all points at several mm/s the wide family only trades γ against F_s and is rejected.
    See :func:`_fit_stribeck_bounded` for the parameters.
    """
    kw: dict[str, Any] = dict(
        fixed=fixed,
        loss=loss,
        f_scale=f_scale,
        n_starts=n_starts,
        level=level,
        seed=seed,
        breakaway=breakaway,
    )
    if "smoothness" in (fixed or {}) or "smoothness" in (bounds or {}):
        return _fit_stribeck_bounded(v, f, bounds=bounds, **kw)
    va = np.abs(np.asarray(v, dtype=float))
    vmin = max(float(np.min(va[va != 0])) if np.any(va != 0) else 1e-6, 1e-6)
    strict = _fit_stribeck_bounded(
        v, f, bounds={**(bounds or {}), "smoothness": (3.0 / vmin, 1e7)}, **kw
    )
    wide = _fit_stribeck_bounded(
        v, f, bounds={**(bounds or {}), "smoothness": (0.3 / vmin, 1e7)}, **kw
    )
    ssr_s = float(np.sum(strict.residuals**2))
    ssr_w = float(np.sum(wide.residuals**2))
    dof = max(strict.velocity.size - len(wide.free), 1)
    chosen = wide if ssr_s - ssr_w > 3.84 * ssr_w / dof else strict
    total = strict.status.nfev + wide.status.nfev
    chosen = dataclasses.replace(chosen, status=dataclasses.replace(chosen.status, nfev=total))
    if "smoothness" in chosen.weak:
        chosen = _profile_smoothness(v, f, chosen, 0.3 / vmin, dof, kw)
    return chosen


def _profile_smoothness(v, f, best: StribeckFit, g_low: float, dof: int, kw: dict) -> StribeckFit:
    """Widen the intervals by the γ the data cannot pin (a profile over γ).

    With every point at |ẋ| ≫ 1/γ the tanh is saturated at the optimum, γ's Jacobian column
    vanishes, and the covariance of the other parameters is the one *at that γ*, as if γ were
    known. But a slow (creeping) point sits on the tanh corner for smaller γ, and there F_s, χ,
    δ trade against γ: on the paper rig (issue 18, seed 20 of the coverage study) one point at
    1.5 mm/s gave F_s = 161.0 ± 0.7 N at γ = 3·10⁴ (truth 174.8 N: 19σ), while γ = 1325 (the
    truth) fits nearly as well (ΔSSR/s² = 3.2 < 3.84) with F_s = 172.2 N. So the fit is
    repeated with γ held on a grid from its lower bound to the optimum, and each parameter's
    interval becomes the envelope of the intervals of every γ whose fit is not significantly
    worse (ΔSSR/s² ≤ χ²₁(95 %) = 3.84); std = half-width / q.
    """
    g_best = best.friction.smoothness
    if not g_best > g_low * 1.01:
        return best
    ssr0 = float(np.sum(best.residuals**2))
    s2 = ssr0 / max(dof, 1)
    kw = {**kw, "fixed": {**(kw.get("fixed") or {})}, "n_starts": max(4, kw["n_starts"] // 3)}
    est = dict(best.estimates)
    nfev = best.status.nfev
    used = 0
    q = t_quantile(next(iter(est.values())).level if est else 0.95, dof)

    def trial(g: float) -> StribeckFit | None:
        nonlocal nfev
        kw["fixed"]["smoothness"] = float(g)
        fit = _fit_stribeck_bounded(v, f, **kw)
        nfev += fit.status.nfev
        return None if float(np.sum(fit.residuals**2)) - ssr0 > 3.84 * s2 else fit

    # a coarse grid from the bound up, then bisection (log γ) to the smallest γ that fits:
    # the trade-off is monotone there, so the edge of the region holds the widest intervals
    grid = np.geomspace(g_low, g_best, 7)[:-1]
    fits = [(g, trial(g)) for g in grid]
    accepted = [fit for _, fit in fits if fit is not None]
    rejected = [g for g, fit in fits if fit is None]
    if accepted and rejected:
        lo_g = max(rejected)
        hi_g = min(g for g, fit in fits if fit is not None and g > lo_g)
        for _ in range(6):  # to within (γ ratio of a grid step)^(1/64), ≈ 1.5 %
            mid = float(np.sqrt(lo_g * hi_g))
            fit = trial(mid)
            if fit is None:
                lo_g = mid
            else:
                hi_g = mid
                accepted.append(fit)
    for fit in accepted:
        used += 1
        for name, e in fit.estimates.items():
            if name not in est or name == "smoothness":
                continue
            old = est[name]
            lo, hi = min(old.ci[0], e.ci[0]), max(old.ci[1], e.ci[1])
            if (lo, hi) == old.ci:
                continue
            if name == "stribeck_velocity":  # log-scale interval: keep its geometric form
                std = max(old.std, old.value * np.log(hi / lo) / 2 / q)
            else:
                std = max(old.std, 0.5 * (hi - lo) / q)
            est[name] = ParameterEstimate(old.value, float(std), (lo, hi), old.unit, old.level)
    status = dataclasses.replace(
        best.status,
        nfev=nfev,
        message=best.status.message + f" (γ profiled: {used} lower γ fit as well)",
    )
    return dataclasses.replace(best, estimates=est, status=status)


def _fit_stribeck_bounded(  # noqa: C901 (to be split, issue 33)
    v,
    f,
    fixed: dict[str, float] | None = None,
    loss: str = "soft_l1",
    f_scale: float | None = None,
    n_starts: int = 24,
    level: float = 0.95,
    seed: int = 0,
    bounds: dict[str, tuple[float, float]] | None = None,
    breakaway: tuple[float, float] | None = None,
) -> StribeckFit:
    """Fit the Stribeck curve, Eq. (11), within given bounds (the work of :func:`fit_stribeck`).

    Parameters
    ----------
    v : array_like, shape (K,)
        Steady velocities [m/s], both directions.
    f : array_like, shape (K,)
        Friction forces [N] from Eq. (10).
    fixed : dict, optional
        Friction fields held fixed, e.g. ``{"shape": 1.0}`` (SI values).
    loss : str
        ``least_squares`` loss (``"soft_l1"`` keeps a stray point from dragging the curve).
    f_scale : float, optional
        Residual scale [N] of the robust loss; default 1.4826·MAD of a first linear-loss fit.
    n_starts : int
        Number of starting points over (log χ, δ, log γ); a grid plus random draws.
    level : float
        Confidence level [1].
    seed : int
        Seed of the random starts.
    bounds : dict, optional
        (low, high) per Friction field in SI units, replacing the defaults below.
    breakaway : (float, float), optional
        Measured break-away force F_b [N] and its standard error: adds the residual
        (max_{ẋ>0} f(ẋ) − F_b)/std, scaled like a point of the fit's robust residual scale
        (its gradient is ∂f/∂θ at the maximising ẋ, by the envelope theorem). The maximum
        lies below F_s by the tanh rounding, so γ should be fixed when this is used.

    Returns
    -------
    StribeckFit

    Raises
    ------
    IdentificationError
        With fewer points than free parameters + 2, or points in one direction only.

    Notes
    -----
    Fit vector θ = (F_c, F_s − F_c, σ, log10 χ, δ, log10 γ). Default bounds, with
    v_min the slowest measured |ẋ|: F_c, F_s − F_c ∈ [0, 1e5] N, σ ∈ [0, 1e7] N·s/m,
    χ ∈ [v_min/10, 1] m/s, δ ∈ [0.5, 5], γ ∈ [3/v_min, 1e7] s/m. The last three
    encode what constant-input data can say: a Stribeck decay finished well below the
    slowest run, or a tanh transition wider than the slowest speed, trade off
    against F_s without limit (F_s → ∞ with χ → 0 fits as well), so such optima are
    excluded rather than reported as estimates. Covariance from
    the Jacobian at the optimum; intervals on θ are mapped to Friction fields
    (χ, γ: 10^(θ ± q·sd)). With |ẋ| ≥ a few mm/s and γ large, tanh(γẋ) = 1 for all
    data: γ is then not identifiable and is reported so (``weak``).
    """
    v = np.asarray(v, dtype=float)
    f = np.asarray(f, dtype=float)
    fixed = dict(fixed or {})
    unknown = set(fixed) - set(STRIBECK_NAMES)
    if unknown:
        raise IdentificationError(
            f"cannot fix {sorted(unknown)}; Friction fields are {', '.join(STRIBECK_NAMES)}"
        )
    fixed_th = {}
    for key, val in fixed.items():
        i = STRIBECK_NAMES.index(key)
        fixed_th[i] = np.log10(val) if key in ("stribeck_velocity", "smoothness") else float(val)
    if "static" in fixed:
        fixed_th[1] = float(fixed["static"]) - float(fixed.get("coulomb", 0.0))
    free_idx = [i for i in range(6) if i not in fixed_th]
    if v.size < len(free_idx) + 2:
        raise IdentificationError(
            f"Stribeck fit needs at least {len(free_idx) + 2} points, have {v.size}"
        )
    if not (np.any(v > 0) and np.any(v < 0)):
        raise IdentificationError("Stribeck fit needs points in both directions of motion")

    def full(p):
        th = np.empty(6)
        th[free_idx] = p
        for i, val in fixed_th.items():
            th[i] = val
        return th

    fscale = max(float(np.max(np.abs(f))), 1.0)

    def resid(p):
        return (_eval(v, full(p)) - f) / fscale

    def jac(p):
        return _jac_theta(v, full(p))[:, free_idx] / fscale

    vmin = max(float(np.min(np.abs(v[v != 0]))), 1e-6)
    lb_all, ub_all = _default_bounds(vmin)
    for key, (lo, hi) in (bounds or {}).items():
        if key not in STRIBECK_NAMES:
            raise IdentificationError(
                f"no bound for {key!r}; Friction fields are {', '.join(STRIBECK_NAMES)}"
            )
        i = STRIBECK_NAMES.index(key)
        tr = np.log10 if i in (3, 5) else float
        lb_all[i], ub_all[i] = tr(lo), tr(hi)
    lb, ub = lb_all[free_idx], ub_all[free_idx]
    for i in free_idx:
        if not lb_all[i] < ub_all[i]:
            raise IdentificationError(f"empty bounds for {STRIBECK_NAMES[i]}")
    rng = np.random.default_rng(seed)
    lo_s, hi_s = lb_all[3:], ub_all[3:]
    grid = [
        (lc, d, lg)
        for lc in np.linspace(
            max(np.log10(vmin / 3), lo_s[0]), np.log10(max(np.max(np.abs(v)), vmin)), 4
        )
        for d in (0.7, 1.5)
        for lg in (lo_s[2] + 0.3, lo_s[2] + 2.0)
    ]
    while len(grid) < n_starts:
        grid.append(tuple(rng.uniform(lo_s, hi_s)))
    grid = [tuple(np.clip(g, lo_s + 1e-6, hi_s - 1e-6)) for g in grid]
    xs = np.array([0.1, 0.1, 0.1, 0.3, 0.3, 0.5])[free_idx]

    def x_scale(p: np.ndarray) -> np.ndarray:
        # forces and σ scale with their start, log10 χ, δ, log10 γ with O(0.3); every stage
        # needs it: without it the robust refits ran out of evaluations (600) before converging
        return np.where(np.isin(free_idx, [0, 1, 2]), np.maximum(np.abs(p), fscale * 0.05), xs)

    results = []
    for lc, d, lg in grid[: max(n_starts, 1)]:
        th0 = np.empty(6)
        th0[3:] = (lc, d, lg)
        for i, val in fixed_th.items():
            th0[i] = val
        th0[:3] = _linear_part(v, f, th0[3], th0[4], th0[5])
        for i, val in fixed_th.items():
            th0[i] = val
        p0 = np.clip(th0[free_idx], lb + 1e-9, ub - 1e-9)
        results.append(
            least_squares(resid, p0, jac=jac, bounds=(lb, ub), x_scale=x_scale(p0), method="trf")
        )
    best = min(results, key=lambda r: r.cost)
    nfev = sum(int(r.nfev) for r in results)
    scale_n = (
        f_scale / fscale if f_scale else max(1.4826 * float(np.median(np.abs(best.fun))), 1e-6)
    )
    if breakaway is not None:
        f_b, sd_b = float(breakaway[0]), max(float(breakaway[1]), 1e-9)
        w_b = scale_n / sd_b  # one point's weight at the robust residual scale
        vcap = float(np.max(np.abs(v)))
        resid_p, jac_p = resid, jac

        def resid(p):  # noqa: F811 - the constrained objective replaces the plain one
            return np.append(resid_p(p), w_b * (_curve_max(full(p), vcap)[0] - f_b))

        def jac(p):  # noqa: F811
            th_ = full(p)
            row = _jac_theta(np.array([_curve_max(th_, vcap)[1]]), th_)[:, free_idx]
            return np.vstack([jac_p(p), w_b * row])

        ranked = sorted(results, key=lambda r: r.cost)[:4]
        results = [
            least_squares(resid, r.x, jac=jac, bounds=(lb, ub), x_scale=x_scale(r.x), method="trf")
            for r in ranked
        ]
        best = min(results, key=lambda r: r.cost)
        nfev += sum(int(r.nfev) for r in results)
    if loss != "linear":
        ranked = sorted(results, key=lambda r: r.cost)[:4]
        robust = [
            least_squares(
                resid,
                r.x,
                jac=jac,
                bounds=(lb, ub),
                x_scale=x_scale(r.x),
                loss=loss,
                f_scale=scale_n,
                method="trf",
            )
            for r in ranked
        ]
        best = min(robust, key=lambda r: r.cost)
        nfev += sum(int(r.nfev) for r in robust)
    th = full(best.x)
    r = best.fun[: v.size] * fscale
    # run-level robust (sandwich) covariance: one point per run, and the points differ in
    # quality (slow runs creep, fast ones do not), which s²(JᵀJ)⁻¹ ignores (issue 18)
    cov = (
        sandwich_covariance(best.jac * fscale, best.fun * fscale)
        if best.jac.size
        else np.zeros((0, 0))
    )
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    q = t_quantile(level, v.size - len(free_idx))
    est: dict[str, ParameterEstimate] = {}
    weak = []
    unidentified = []
    names_free = []
    for k, i in enumerate(free_idx):
        names_free.append(STRIBECK_NAMES[i])
        at_bound = th[i] <= lb_all[i] + 1e-6 * (1 + abs(lb_all[i])) or th[i] >= ub_all[i] - 1e-6 * (
            1 + abs(ub_all[i])
        )
        if i in (3, 5):
            with np.errstate(over="ignore"):  # an undetermined log-scale CI reaches inf
                lo, hi = 10.0 ** (th[i] - q * sd[k]), 10.0 ** (th[i] + q * sd[k])
            val = 10.0 ** th[i]
            std = val * np.log(10.0) * sd[k]
            is_weak = sd[k] * q > np.log10(2.0) or at_bound
        elif i == 1:  # static = F_c + ΔF: propagate with the F_c covariance when F_c is free
            val = th[0] + th[1]
            var = sd[k] ** 2
            if 0 in free_idx:
                j = free_idx.index(0)
                var += cov[j, j] + 2 * cov[j, k]
            std = float(np.sqrt(max(var, 0.0))) if np.isfinite(var) else float("inf")
            lo, hi = val - q * std, val + q * std
            is_weak = q * std > 0.5 * abs(val)
        else:
            val, std = th[i], sd[k]
            lo, hi = val - q * std, val + q * std
            is_weak = q * std > 0.5 * abs(val) or (at_bound and i != 0)
        name = STRIBECK_NAMES[i]
        est[name] = ParameterEstimate(
            float(val), float(std), (float(lo), float(hi)), _UNITS[name], level
        )
        if is_weak:
            weak.append(name)
        # not identified: at (or, on the scale of its interval, next to) a bound of the fit
        # with an interval wider than half the value, or an interval covering the bounded
        # range (e.g. F_c = 9.6e-11 N, CI ±1209 N); then no value is written
        lo_b, hi_b = (
            (10.0 ** lb_all[i], 10.0 ** ub_all[i]) if i in (3, 5) else (lb_all[i], ub_all[i])
        )
        if i == 1:  # the bound is on F_s − F_c; at it F_s = F_c
            lo_b, hi_b = lo_b + th[0], hi_b + th[0]
        half = 0.5 * (hi - lo)
        near = at_bound or min(val - lo_b, hi_b - val) < 0.01 * half
        if (near and half > 0.5 * abs(val)) or (lo <= lo_b and hi >= hi_b):
            unidentified.append(name)
    friction = Friction(
        coulomb=float(th[0]),
        static=float(th[0] + th[1]),
        viscous=float(th[2]),
        stribeck_velocity=float(10.0 ** th[3]),
        shape=float(th[4]),
        smoothness=float(10.0 ** th[5]),
    )
    return StribeckFit(
        friction,
        est,
        correlation(cov),
        tuple(names_free),
        tuple(weak),
        v,
        f,
        f - _eval(v, th),
        float(np.sqrt(np.mean(r**2))),
        loss,
        len(results),
        OptimizerStatus(bool(best.success), str(best.message), nfev, None),
        tuple(unidentified),
    )


@dataclasses.dataclass(frozen=True)
class SteadyStateAverage:
    """Friction points by the paper's method: one point per run from its steady part (Sec. VI-C).

    Steady-part means of P_A, P_B, F_L give f of Eq. (10), the position slope gives ẋ
    (:func:`friction_point`).

    Attributes
    ----------
    window : float
        Moving window [s] of the steady-state detection.
    band : float
        Relative velocity band of the steady part [1].
    abs_band : float
        Absolute velocity band [m/s] (for slow runs).
    force_band, force_abs_band : float
        Relative [1] and absolute [N] band of the net force.
    min_duration : float
        Shortest steady stretch [s] a run must have.
    oscillation_factor : float
        A run whose net-force std exceeds this multiple of the quietest runs' is marked
        ``oscillating`` (kept in the fit, reported in ``notes_``) [1].
    """

    name: ClassVar[str] = "average"
    window: float = 0.1
    band: float = 0.15
    abs_band: float = 5e-4
    force_band: float = 0.25
    force_abs_band: float = 20.0
    min_duration: float = 0.2
    oscillation_factor: float = 3.0

    def __post_init__(self) -> None:
        _positive(self, "window", "band", "abs_band", "force_band", "force_abs_band")
        _positive(self, "min_duration", "oscillation_factor")


@dataclasses.dataclass(frozen=True)
class InstantaneousBins:
    """Friction points per velocity bin of per-sample forces (needs the moving mass).

    Per sample f = P_A A_A − P_B A_B − F_L − m·ẍ (:func:`friction_samples`) over the moving
    part of each run, reduced to per-run velocity-bin medians (``points_`` has one row per
    bin), so oscillating runs contribute their whole velocity range.

    Attributes
    ----------
    cutoff : float
        Low-pass cutoff [Hz] of velocity, acceleration and force.
    taps : int
        Filter length [samples].
    min_speed : float
        Slowest |ẋ| [m/s] of a sample that is used.
    guard : float
        Time [s] dropped after each command change.
    bin_rel, bin_width : float
        Bin width max(bin_rel·|v|, bin_width) [1], [m/s].
    bin_min_count : int
        Fewest samples in a bin that is used.
    """

    name: ClassVar[str] = "instantaneous"
    cutoff: float = 300.0
    taps: int = 41
    min_speed: float = 3e-3
    guard: float = 0.0
    bin_rel: float = 0.1
    bin_width: float = 1e-3
    bin_min_count: int = 5

    def __post_init__(self) -> None:
        _positive(self, "cutoff", "taps", "min_speed", "bin_rel", "bin_width", "bin_min_count")


@dataclasses.dataclass(frozen=True)
class BreakawayConstrained:
    """Friction points of ``points`` plus "maximum of Eq. (11) = break-away force F_b".

    F_b is the median per-cycle net-force peak of the slowest stick-slip runs per direction
    (mean speed ≤ ``speed_ratio`` × the slowest one's; faster runs overshoot), the mean of
    both directions, with a standard error that includes the direction difference
    (:func:`breakaway_peaks`, ``fit_stribeck(breakaway=...)``). Constant-input data do not
    identify γ and the curve's maximum lies below F_s by the tanh rounding, so γ is held at
    ``smoothness`` (or at the ``params``' γ) unless ``fixed`` says otherwise.

    Attributes
    ----------
    points : SteadyStateAverage or InstantaneousBins
        How the (ẋ, f) points are made (default: per-sample bins).
    speed_ratio : float
        Runs used for F_b: mean speed ≤ this × the slowest stick-slip run's, per direction [1].
    min_cycles : int
        Fewest stick-slip cycles for a run to count [1].
    min_slip : float
        Smallest slip speed [m/s] that marks a stick-slip cycle.
    cutoff : float
        Low-pass cutoff [Hz] of the peak detection.
    taps : int
        Filter length [samples] of the peak detection.
    smoothness : float, optional
        γ [s/m] held in the fit; default the ``params``' ``friction.smoothness``.
    """

    name: ClassVar[str] = "breakaway"
    points: SteadyStateAverage | InstantaneousBins = dataclasses.field(
        default_factory=InstantaneousBins
    )
    speed_ratio: float = 2.0
    min_cycles: int = 10
    min_slip: float = 5e-3
    cutoff: float = 300.0
    taps: int = 41
    smoothness: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.points, SteadyStateAverage | InstantaneousBins):
            raise ParameterError(
                f"BreakawayConstrained.points = {self.points!r}; give SteadyStateAverage() or "
                "InstantaneousBins()"
            )
        _positive(self, "speed_ratio", "min_cycles", "min_slip", "cutoff", "taps")
        if self.smoothness is not None:
            _positive(self, "smoothness")


#: The point strategies of :class:`StribeckIdentifier`.
FrictionMethod = SteadyStateAverage | InstantaneousBins | BreakawayConstrained


def _positive(obj: Any, *names: str) -> None:
    for name in names:
        val = getattr(obj, name)
        if not (isinstance(val, int | float) and np.isfinite(val) and val > 0):
            raise ParameterError(f"{type(obj).__name__}.{name} = {val!r} must be a positive number")


class StribeckIdentifier:
    """Identify the Stribeck friction curve from constant-input runs (Sec. VI-C, Eqs. (10)–(11)).

    Parameters
    ----------
    params : SystemParams, optional
        Gives the areas A_A, A_B [m²], the stroke [m] and the moving mass [kg] (and γ for
        :class:`BreakawayConstrained`). Either this or ``geometry`` is required: there is
        no default rig.
    geometry : RigGeometry, optional
        The same without a full parameter set (``mass`` only for :class:`InstantaneousBins`).
    method : SteadyStateAverage, InstantaneousBins or BreakawayConstrained
        How runs become (ẋ, f) points; default the paper's steady-state average.
    fixed : dict, optional
        Friction fields held fixed in the fit (SI values), e.g. ``{"shape": 1.0}``.
    loss : str
        Robust ``least_squares`` loss of the fit.
    n_starts : int
        Starting points of the fit.
    level : float
        Confidence level [1].
    stop_margin : float
        Distance [m] from an end stop treated as contact.

    Attributes
    ----------
    points_ : pandas.DataFrame
        One row per used run (``SteadyStateAverage``: ``run``, ``u`` [1], ``v`` [m/s],
        ``v_std``, ``f`` [N], ``f_std``, ``p_a``, ``p_b`` [Pa], ``f_l`` [N], ``t0``, ``t1`` [s],
        ``force_fluctuation`` [N], ``oscillating``) or per velocity bin (``InstantaneousBins``).
    fit_ : StribeckFit
        The fit, with its intervals and the optimiser's ``status``.
    friction_ : Friction
        The fitted curve as parameters.
    coulomb_, static_, viscous_, stribeck_velocity_, shape_, smoothness_ : ParameterEstimate
        The fitted Eq. (11) parameters with their intervals (a fixed one with std 0).
    status_ : OptimizerStatus
        How the optimiser ended (``fit_.status``).
    notes_ : list[str]
        Caveats found in the data (oscillating runs), and the break-away estimate.
    breakaway_ : ParameterEstimate or None
        Break-away force F_b [N] with its CI (:class:`BreakawayConstrained`), else None.
    breakaway_runs_ : pandas.DataFrame or None
        Per stick-slip run: ``run``, ``direction``, ``mean_speed`` [m/s], ``n_cycles``,
        ``peak`` (median) and ``peak_std`` [N], ``used``.
    skipped_ : list[SkippedRun]
    """

    #: The experiment kind this estimator reads and the parameter field it sets.
    part: ClassVar[str] = "friction"
    field: ClassVar[str] = "friction"

    def __init__(
        self,
        params: SystemParams | None = None,
        *,
        geometry: RigGeometry | None = None,
        method: FrictionMethod | None = None,
        fixed: dict[str, float] | None = None,
        loss: str = "soft_l1",
        n_starts: int = 24,
        level: float = 0.95,
        stop_margin: float = 2e-3,
    ) -> None:
        method = SteadyStateAverage() if method is None else method
        if not isinstance(method, SteadyStateAverage | InstantaneousBins | BreakawayConstrained):
            raise ParameterError(
                f"StribeckIdentifier method={method!r}; give SteadyStateAverage(), "
                "InstantaneousBins() or BreakawayConstrained()"
            )
        points = method.points if isinstance(method, BreakawayConstrained) else method
        needs = ("stroke", "area_a", "area_b") + (
            ("mass",) if isinstance(points, InstantaneousBins) else ()
        )
        self.geometry = resolve_geometry("StribeckIdentifier", params, geometry, needs)
        self.params = params
        self.method = method
        self.fixed = dict(fixed or {})
        self.loss = loss
        self.n_starts = n_starts
        self.level = level
        self.stop_margin = stop_margin
        if isinstance(method, BreakawayConstrained) and "smoothness" not in self.fixed:
            if method.smoothness is None and params is None:
                raise ParameterError(
                    "BreakawayConstrained holds γ fixed: give BreakawayConstrained(smoothness=...) "
                    "[s/m], fixed={'smoothness': ...} or params=SystemParams"
                )

    def fit(self, data) -> StribeckIdentifier:
        """Reduce each run to a friction point and fit Eq. (11).

        Returns
        -------
        StribeckIdentifier
            ``self`` with ``points_``, ``fit_``, ``friction_`` and ``skipped_`` set.

        Raises
        ------
        IdentificationError
            If too few runs are usable.
        """
        import pandas as pd  # deferred: pandas loads only for tables

        geo = self.geometry
        assert geo.area_a is not None and geo.area_b is not None
        runs = as_runs(data, "friction")
        skipped: list[SkippedRun] = []
        self.breakaway_: ParameterEstimate | None = None
        self.breakaway_runs_: Any = None
        points = self._points
        if isinstance(points, InstantaneousBins):
            return self._fit_instantaneous(runs, points, skipped)
        rows = []
        kw = dict(
            stop_margin=self.stop_margin,
            window=points.window,
            band=points.band,
            abs_band=points.abs_band,
            force_band=points.force_band,
            force_abs_band=points.force_abs_band,
            min_duration=points.min_duration,
        )
        for run in runs:
            ch = channels_of(run, ("t", "x", "p_a", "p_b", "f_l"), skipped)
            if ch is None:
                continue
            try:
                pt = friction_point(
                    ch["t"],
                    ch["x"],
                    ch["p_a"],
                    ch["p_b"],
                    ch["f_l"],
                    geo.area_a,
                    geo.area_b,
                    geo.stroke,
                    **kw,
                )
            except IdentificationError as exc:
                skip(skipped, run.name, str(exc))
                continue
            lv = command_level(run)
            rows.append(
                {
                    "run": run.name,
                    "u": float("nan") if lv is None else lv,
                    "v": pt.velocity,
                    "v_std": pt.velocity_std,
                    "f": pt.force,
                    "f_std": pt.force_std,
                    "p_a": pt.p_a,
                    "p_b": pt.p_b,
                    "f_l": pt.f_l,
                    "t0": pt.window[0],
                    "t1": pt.window[1],
                    "rms_position_residual": pt.rms_position_residual,
                    "force_fluctuation": pt.force_fluctuation,
                }
            )
        n_free = 6 - len(self.fixed or {})
        require_usable(rows, skipped, "Stribeck identification", minimum=n_free + 2)
        pts = pd.DataFrame(rows).sort_values("v", ignore_index=True)
        # runs whose force fluctuates far above the quietest runs (sensor noise) oscillate
        floor = float(
            np.median(np.sort(pts["force_fluctuation"].to_numpy())[: max(3, len(pts) // 4)])
        )
        pts["oscillating"] = pts["force_fluctuation"] > points.oscillation_factor * floor
        self.points_ = pts
        self.notes_: list[str] = []
        if pts["oscillating"].any():
            osc = pts[pts["oscillating"]]
            self.notes_.append(
                f"{len(osc)} run(s) oscillate (net-force std > {points.oscillation_factor:g}× the quietest runs' "
                f"{floor:.3g} N), at |v| up to {1e3 * osc['v'].abs().max():.3g} mm/s: their mean force is not "
                "the static friction there, so F_s, χ and δ that rest on them may be biased beyond their CI"
            )
        self._final_fit(pts, runs)
        self.skipped_ = skipped
        return self

    @property
    def _points(self) -> SteadyStateAverage | InstantaneousBins:
        m = self.method
        return m.points if isinstance(m, BreakawayConstrained) else m

    def _fit_instantaneous(
        self, runs, opts: InstantaneousBins, skipped: list[SkippedRun]
    ) -> StribeckIdentifier:
        import pandas as pd  # deferred: pandas loads only for tables

        geo = self.geometry
        assert geo.area_a is not None and geo.area_b is not None and geo.mass is not None
        rows = []
        for run in runs:
            ch = channels_of(run, ("t", "x", "p_a", "p_b", "f_l"), skipped)
            if ch is None:
                continue
            u = run["u"] if "u" in run.channels else None
            try:
                v, f = friction_samples(
                    ch["t"],
                    ch["x"],
                    ch["p_a"],
                    ch["p_b"],
                    ch["f_l"],
                    geo.area_a,
                    geo.area_b,
                    geo.mass,
                    u=u,
                    stroke=geo.stroke,
                    stop_margin=self.stop_margin,
                    cutoff=opts.cutoff,
                    taps=opts.taps,
                    min_speed=opts.min_speed,
                    guard=opts.guard,
                )
            except IdentificationError as exc:
                skip(skipped, run.name, str(exc))
                continue
            bins = _velocity_bins(v, f, opts.bin_rel, opts.bin_width, opts.bin_min_count)
            if bins.size == 0:
                skip(skipped, run.name, "no velocity bin with enough moving samples")
                continue
            lv = command_level(run)
            spread = float(np.percentile(np.abs(v), 95) - np.percentile(np.abs(v), 5))
            for bv, bf, n in bins:
                rows.append(
                    {
                        "run": run.name,
                        "u": float("nan") if lv is None else lv,
                        "v": bv,
                        "f": bf,
                        "n_samples": int(n),
                        "v_spread": spread,
                    }
                )
        n_free = 6 - len(self.fixed or {})
        require_usable(rows, skipped, "Stribeck identification", minimum=n_free + 2)
        pts = pd.DataFrame(rows).sort_values("v", ignore_index=True)
        # a run whose velocity swings over more than half its median speed + 10 mm/s oscillates
        med = pts.groupby("run")["v"].transform(lambda s: float(np.median(np.abs(s))))
        pts["oscillating"] = pts["v_spread"] > 0.5 * med + 0.01
        self.points_ = pts
        self.notes_ = []
        osc = pts.loc[pts["oscillating"], "run"].unique()
        if osc.size:
            self.notes_.append(
                f"{osc.size} run(s) oscillate (stick-slip); their samples are used per velocity bin, but the "
                "speeds crossed within a sample or two (the low-speed Stribeck peak) are not resolved at "
                "this sampling rate, so F_s, χ and δ rest on an extrapolation"
            )
        self._final_fit(pts, runs)
        self.skipped_ = skipped
        return self

    def _final_fit(self, pts, runs) -> None:
        fixed = dict(self.fixed)
        constraint = None
        m = self.method
        if isinstance(m, BreakawayConstrained):
            constraint = self._breakaway(runs, m)
            if constraint is not None and "smoothness" not in fixed:
                if m.smoothness is not None:
                    gamma, src = m.smoothness, "BreakawayConstrained.smoothness"
                else:
                    assert self.params is not None  # checked in __init__
                    gamma, src = self.params.friction.smoothness, "the given params"
                fixed["smoothness"] = gamma
                self.notes_.append(
                    f"γ held at {gamma:.4g} s/m ({src}): constant-input data do not "
                    "identify it, and it sets how far the curve's maximum (the break-away force) lies below F_s"
                )
        self.fit_ = fit_stribeck(
            pts["v"].to_numpy(),
            pts["f"].to_numpy(),
            fixed,
            self.loss,
            None,
            self.n_starts,
            self.level,
            breakaway=constraint,
        )
        if constraint is not None:
            fm, vm = curve_maximum(self.fit_.friction, float(np.max(np.abs(pts["v"]))))
            self.notes_.append(
                f"fitted curve maximum {fm:.4g} N at {1e3 * vm:.3g} mm/s (F_s = "
                f"{self.fit_.friction.static:.4g} N)"
            )
        self.friction_ = self.fit_.friction
        self.status_ = self.fit_.status
        for name in STRIBECK_NAMES:
            val = getattr(self.friction_, name)
            est = self.fit_.estimates.get(
                name, ParameterEstimate(val, 0.0, (val, val), _UNITS[name], self.level)
            )
            setattr(self, name + "_", est)

    def _breakaway(self, runs, opts: BreakawayConstrained) -> tuple[float, float] | None:
        """F_b and its standard error from the slowest stick-slip runs (sets ``breakaway_``)."""
        import pandas as pd  # deferred: pandas loads only for tables

        geo = self.geometry
        assert geo.area_a is not None and geo.area_b is not None
        rows, peaks = [], {}
        for run in runs:
            if not all(c in run.channels for c in ("t", "x", "p_a", "p_b", "f_l")):
                continue
            try:
                br = breakaway_peaks(
                    run["t"],
                    run["x"],
                    run["p_a"],
                    run["p_b"],
                    run["f_l"],
                    geo.area_a,
                    geo.area_b,
                    u=run["u"] if "u" in run.channels else None,
                    stroke=geo.stroke,
                    stop_margin=self.stop_margin,
                    cutoff=opts.cutoff,
                    taps=opts.taps,
                    min_slip=opts.min_slip,
                )
            except IdentificationError:
                continue
            if br.peaks.size < opts.min_cycles:
                continue
            pk = br.peaks
            sem = 1.2533 * 1.4826 * float(np.median(np.abs(pk - np.median(pk)))) / np.sqrt(pk.size)
            rows.append(
                {
                    "run": run.name,
                    "direction": br.direction,
                    "mean_speed": br.mean_speed,
                    "n_cycles": int(pk.size),
                    "peak": br.force,
                    "peak_std": sem,
                }
            )
            peaks[run.name] = pk
        if not rows:
            self.notes_.append(
                "breakaway: no stick-slip run with enough cycles; F_s rests on the points alone"
            )
            return None
        tab = pd.DataFrame(rows)
        tab["used"] = False
        per_dir = []
        for d in (1.0, -1.0):
            sel = tab["direction"] == d
            if not sel.any():
                continue
            vmin = float(tab.loc[sel, "mean_speed"].min())
            use = sel & (tab["mean_speed"] <= opts.speed_ratio * vmin)
            tab.loc[use, "used"] = True
            pooled = np.concatenate([peaks[n] for n in tab.loc[use, "run"]])
            val = float(np.median(pooled))
            sem = 1.2533 * 1.4826 * float(np.median(np.abs(pooled - val))) / np.sqrt(pooled.size)
            meds = tab.loc[use, "peak"].to_numpy()
            if meds.size > 1:
                sem = max(sem, float(np.std(meds, ddof=1)) / np.sqrt(meds.size))
            per_dir.append((d, val, sem, int(use.sum())))
        vals = np.array([p[1] for p in per_dir])
        sems = np.array([p[2] for p in per_dir])
        f_b = float(np.mean(vals))
        sd = float(np.sqrt(np.sum(sems**2)) / vals.size)
        if vals.size == 2:
            sd = float(np.hypot(sd, 0.5 * (vals[0] - vals[1])))
        q = t_quantile(self.level, max(int(tab["used"].sum()) - 1, 1))
        self.breakaway_ = ParameterEstimate(f_b, sd, (f_b - q * sd, f_b + q * sd), "N", self.level)
        self.breakaway_runs_ = tab
        txt = ", ".join(
            f"{'+' if d > 0 else '−'}: {val:.4g} ± {s_:.2g} N ({n} run(s))"
            for d, val, s_, n in per_dir
        )
        self.notes_.append(
            f"break-away force F_b = {f_b:.4g} N, {100 * self.level:g} % CI [{f_b - q * sd:.4g}, {f_b + q * sd:.4g}] "
            f"(median stick-slip net-force peak of the slowest stick-slip runs; {txt}); fitted as the curve's maximum"
        )
        return f_b, sd

    def uncertainty(self) -> dict:
        """Per-field estimates and the weakly identified names (``[uncertainty]`` table)."""
        out: dict[str, Any] = {k: e.to_dict() for k, e in self.fit_.estimates.items()}
        out["weakly_identified"] = list(self.fit_.weak)
        out["not_identified"] = list(self.fit_.unidentified)
        out["notes"] = list(self.notes_)
        out["rms_residual_N"] = self.fit_.rms_residual
        out["method"] = self.method.name
        out["optimizer"] = dataclasses.asdict(self.fit_.status)
        return out

    def apply(self, params: SystemParams) -> SystemParams:
        """``params`` with the fitted friction curve in place of its ``friction``."""
        if not hasattr(self, "friction_"):
            raise not_fitted("StribeckIdentifier")
        keep = self.fit_.unidentified
        if not keep:
            return dataclasses.replace(params, friction=self.friction_)
        # a value the data do not determine is not written: the given parameters' stays
        fitted = {
            f.name: getattr(self.friction_, f.name)
            for f in dataclasses.fields(Friction)
            if f.name not in keep
        }
        try:
            friction = dataclasses.replace(params.friction, **fitted)
        except ParameterError as exc:
            raise IdentificationError(
                f"friction: {', '.join(keep)} not identified by the data, and the given "
                f"value(s) do not fit the identified ones ({exc}); give runs that determine "
                "them (slower and faster steady speeds) or fix them with StribeckIdentifier("
                "fixed=...)"
            ) from None
        return dataclasses.replace(params, friction=friction)

    def provenance(self) -> str:
        """One line on how the curve was found (``[meta.identification]`` of a parameter file)."""
        if not hasattr(self, "fit_"):
            raise not_fitted("StribeckIdentifier")
        points = self._points
        kind = (
            "steady-state" if isinstance(points, SteadyStateAverage) else "per-sample velocity-bin"
        )
        brk = self.breakaway_
        return (
            f"Sec. VI-C: {len(self.points_)} {kind} points (method {self.method.name}), Eq. (10) "
            f"with areas from the given geometry; Eq. (11) by bounded {self.loss} least squares"
            + (
                f", constrained to the stick-slip break-away force {brk.value:.4g} N as its "
                "maximum with γ held"
                if brk is not None
                else ""
            )
            + (f"; weakly identified: {', '.join(self.fit_.weak)}" if self.fit_.weak else "")
            + (
                f"; not identified (given value kept): {', '.join(self.fit_.unidentified)}"
                if self.fit_.unidentified
                else ""
            )
            + f"; optimiser: {self.fit_.status}"
        )


def _usable_samples(t, x, u, edge, settle, stroke, stop_margin) -> np.ndarray:
    """Mask of samples clear of the filter edges, settled after the last command change
    (by ``settle`` [s]) and at least ``stop_margin`` [m] away from both end stops."""
    ok = np.ones(x.size, dtype=bool)
    ok[:edge] = False
    ok[-edge:] = False
    if u is not None:
        u = np.asarray(u, dtype=float)
        uf = float(np.median(u[u.size // 2 :]))
        changed = np.flatnonzero(np.abs(u - uf) > 1e-6 * max(abs(uf), 1e-9))
        t_on = t[min(changed[-1] + 1, t.size - 1)] if changed.size else t[0]
        ok &= t >= t_on + settle
    if stroke is not None:
        ok &= (x > stop_margin) & (x < stroke - stop_margin)
    return ok


def _filtered_motion(t, x, p_a, p_b, f_l, area_a, area_b, cutoff, taps):
    """Velocity, acceleration and net force (Eq. (10)) through one consistent low-pass.

    Returns ``(t, x, dt, h, h1, v, a, net)``: the sample step [s], the smoothing kernel
    (its length sets the edge samples to drop) and the first-derivative kernel, then the
    filtered velocity [m/s], acceleration [m/s²] and net force [N].
    """
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    dt = float(np.median(np.diff(t)))
    h, h1, h2 = _consistent_kernels(dt, min(cutoff, 0.45 / dt), taps)
    if x.size <= 2 * h.size:
        raise IdentificationError(f"run too short for the {h.size}-tap filter ({x.size} samples)")
    net = net_piston_force(p_a, p_b, f_l, area_a, area_b)
    return (
        t,
        x,
        dt,
        h,
        h1,
        np.convolve(x, h1, mode="same"),
        np.convolve(x, h2, mode="same"),
        np.convolve(net, h, mode="same"),
    )
