"""Friction points from measured runs: steady windows, (ẋ, f) points and samples, break-away peaks.

Eq. (10) at steady state, f = P_A A_A − P_B A_B − F_L, per run (:func:`friction_point`), per
sample (:func:`friction_samples`) and at break-away (:func:`breakaway_peaks`); the fit of
Eq. (11) to them is in :mod:`._friction_curve`, the estimator in :mod:`._friction`.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .._errors import IdentificationError
from .._signal import robust_noise
from ..components import net_piston_force

# 8th-order central stencils of d/dt and d²/dt² (multiply by 1/dt, 1/dt²).
_D1 = np.array([1 / 280, -4 / 105, 1 / 5, -4 / 5, 0.0, 4 / 5, -1 / 5, 4 / 105, -1 / 280])
_D2 = np.array([-1 / 560, 8 / 315, -1 / 5, 8 / 5, -205 / 72, 8 / 5, -1 / 5, 8 / 315, -1 / 560])


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
    sigma_x = robust_noise(x, 1)
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
    band : float
        Relative velocity band [1]: |v_w − median| ≤ max(band·|median|, abs_band).
    abs_band : float
        Absolute velocity band [m/s].
    force_band : float
        Relative force band [1], likewise.
    force_abs_band : float
        Absolute force band [N].
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
    stroke : float, optional
        Stroke [m]; with it, samples near an end stop are left out.
    stop_margin : float
        Samples within ``stop_margin`` [m] of an end stop are left out.
    settle : float
        Time [s] after the last command change that is left out.
    cutoff : float
        Pass band [Hz] of the zero-phase FIR (see ``taps``).
    taps : int
        Length of the zero-phase FIR applied alike to position (with
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
    sigma_x = robust_noise(x, 4)
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
    stroke : float, optional
        Stroke [m]; with it, samples near an end stop are left out.
    stop_margin : float
        Samples within ``stop_margin`` [m] of an end stop are left out.
    settle : float
        Time [s] after the last command change that is left out.
    cutoff : float
        Pass band [Hz] of the zero-phase FIR, as in :func:`friction_samples`.
    taps : int
        Length of that FIR, as in :func:`friction_samples`.
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
    sigma_x = robust_noise(x, 4)
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
