"""Servo-valve frequency response and its second-order model, Eq. (1), Sec. VI-A, Table II.

Stepped-sine runs give one FRF point per frequency from a linear least-squares
sinusoid fit over the last ``n_periods`` full periods of command and spool
position; broadband runs (chirp, noise) give an H1 estimate with coherence.
The model G(s) = ω0²/(s² + 2ζω0 s + ω0²) is fitted to each amplitude's FRF by
complex least squares on the log ratio log(G/H) (equal weight to relative
magnitude error and phase error in radians).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import ClassVar

import numpy as np
from scipy import signal
from scipy.optimize import least_squares

from .._errors import IdentificationError
from ..params import ServoValve, SystemParams, parse_quantity
from ._common import (
    FitResult,
    OptimizerStatus,
    ParameterEstimate,
    SkippedRun,
    as_runs,
    channels_of,
    correlation,
    covariance_from_jacobian,
    estimate,
    not_fitted,
    require_usable,
    sandwich_covariance,
    signal_value,
    skip,
    t_quantile,
    within_physical_bounds,
)

__all__ = [
    "SineFit",
    "FrequencyResponse",
    "SecondOrderFit",
    "fit_sinusoid",
    "stepped_sine_point",
    "estimate_frf_h1",
    "second_order_response",
    "fit_second_order",
    "ValveFrfIdentifier",
]

_BROADBAND = {"chirp", "noise", "broadband", "multisine", "prbs", "sweep"}


@dataclasses.dataclass(frozen=True)
class SineFit:
    """Least-squares sinusoid y ≈ A sin(2πft + φ) + c (+ d·t) over a window.

    Attributes
    ----------
    frequency : float
        The known frequency f [Hz].
    amplitude : float
        A [unit of y].
    phase : float
        φ [rad].
    offset : float
        c [unit of y] (value of the fitted line at the window start).
    trend : float
        d [unit of y / s] (0 when no trend was fitted).
    rms_residual : float
        RMS of the fit residual [unit of y].
    window : tuple of float
        (t0, t1) [s] of the samples used.
    """

    frequency: float
    amplitude: float
    phase: float
    offset: float
    trend: float
    rms_residual: float
    window: tuple[float, float]

    @property
    def phasor(self) -> complex:
        """Complex amplitude A·e^{jφ} (of the sine, not the cosine)."""
        return complex(self.amplitude * np.cos(self.phase), self.amplitude * np.sin(self.phase))


def fit_sinusoid(t, y, frequency: float, n_periods: int = 4, trend: bool = True) -> SineFit:
    """Fit a sinusoid of known frequency to the last ``n_periods`` full periods of a signal.

    Parameters
    ----------
    t : array_like, shape (N,)
        Time [s], increasing.
    y : array_like, shape (N,)
        Signal [any unit].
    frequency : float
        Known frequency f [Hz].
    n_periods : int
        Number of full periods fitted, counted back from the end of the run so
        that the start-up transient is left out (the paper fits 4).
    trend : bool
        Also fit a linear trend (drift of the spool offset, slow position drift).

    Returns
    -------
    SineFit

    Raises
    ------
    IdentificationError
        If the run is shorter than ``n_periods`` periods or has fewer than 8
        samples per period.

    Notes
    -----
    Linear least squares on the regressors sin(2πft), cos(2πft), 1 (and t):
    y = a sin + b cos + c + d t gives A = √(a² + b²), φ = atan2(b, a).
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    f = float(frequency)
    if not (np.isfinite(f) and f > 0):
        raise IdentificationError(f"sine frequency {frequency!r} Hz must be positive")
    span = n_periods / f
    if t.size < 2 or t[-1] - t[0] < span * (1.0 - 1e-9):
        have = (t[-1] - t[0]) * f if t.size > 1 else 0.0
        raise IdentificationError(
            f"run holds {have:.2f} periods of {f:g} Hz, need {n_periods} full periods"
        )
    t1 = t[-1]
    keep = t >= t1 - span - 0.5 * np.median(np.diff(t))
    tw, yw = t[keep], y[keep]
    if tw.size < 8 * n_periods:
        raise IdentificationError(
            f"{tw.size / n_periods:.1f} samples per period at {f:g} Hz; need at least 8 (sample faster)"
        )
    w = 2.0 * np.pi * f
    tau = tw - tw[0]
    cols = [np.sin(w * tw), np.cos(w * tw), np.ones_like(tw)]
    if trend:
        cols.append(tau)
    X = np.column_stack(cols)
    coef, *_ = np.linalg.lstsq(X, yw, rcond=None)
    r = yw - X @ coef
    a, b, c = coef[:3]
    return SineFit(
        f,
        float(np.hypot(a, b)),
        float(np.arctan2(b, a)),
        float(c),
        float(coef[3]) if trend else 0.0,
        float(np.sqrt(np.mean(r**2))),
        (float(tw[0]), float(tw[-1])),
    )


def stepped_sine_point(t, u, y, frequency: float, n_periods: int = 4, trend: bool = True):
    """One FRF point H(j2πf) = Y/U from sinusoid fits to command and response.

    Parameters
    ----------
    t, u, y : array_like, shape (N,)
        Time [s], command [1] and response (spool position [1]).
    frequency : float
        Excitation frequency f [Hz].
    n_periods : int
        See :func:`fit_sinusoid`.
    trend : bool
        See :func:`fit_sinusoid`.

    Returns
    -------
    H : complex
        Ratio of the response phasor to the command phasor [1].
    fit_u, fit_y : SineFit
        The two sinusoid fits.
    """
    fu = fit_sinusoid(t, u, frequency, n_periods, trend)
    fy = fit_sinusoid(t, y, frequency, n_periods, trend)
    if fu.amplitude <= 0 or fu.amplitude < 10 * fu.rms_residual * 1e-3:
        raise IdentificationError(f"command holds no sine at {frequency:g} Hz")
    return fy.phasor / fu.phasor, fu, fy


def _relative_std(fit: SineFit, fs: float) -> float:
    """Standard error of log(phasor) per component [1]: σ_coef/A with σ_coef = rms·√(2/N)."""
    n = max((fit.window[1] - fit.window[0]) * fs, 8.0)
    return float(fit.rms_residual * np.sqrt(2.0 / n) / max(fit.amplitude, 1e-300))


@dataclasses.dataclass(frozen=True)
class FrequencyResponse:
    """A measured frequency response of the valve at one command amplitude.

    Attributes
    ----------
    frequency : ndarray, shape (K,)
        Frequencies [Hz], increasing.
    response : ndarray of complex, shape (K,)
        H(j2πf) [1] (spool position over command).
    coherence : ndarray, shape (K,) or None
        Magnitude-squared coherence [1] (H1 estimates only).
    amplitude : float
        Command amplitude |u| [1] the FRF belongs to.
    runs : tuple of str
        Names of the runs it came from.
    std : ndarray, shape (K,) or None
        Relative standard error of each point [1] (stepped sines: from the sinusoid fits'
        residuals, see :func:`stepped_sine_point`).
    independent_bins : bool
        H1 bins are uncorrelated (whole-period rectangular segments of a periodic excitation);
        otherwise neighbouring Hann-window bins share 1.5 bins of noise bandwidth.
    """

    frequency: np.ndarray
    response: np.ndarray
    coherence: np.ndarray | None = None
    amplitude: float = float("nan")
    runs: tuple[str, ...] = ()
    std: np.ndarray | None = None
    independent_bins: bool = False

    @property
    def omega(self) -> np.ndarray:
        """Angular frequencies ω = 2πf [rad/s]."""
        return 2.0 * np.pi * np.asarray(self.frequency)

    @property
    def magnitude_db(self) -> np.ndarray:
        """20·log10|H| [dB]."""
        return 20.0 * np.log10(np.abs(self.response))

    @property
    def phase_deg(self) -> np.ndarray:
        """Unwrapped phase of H [deg]."""
        return np.degrees(np.unwrap(np.angle(self.response)))

    def to_frd(self, name: str | None = None):
        """The measured response as a python-control frequency response (``control.frd``).

        Parameters
        ----------
        name : str, optional
            System name (default: ``valve_<amplitude in %>pct``; python-control forbids dots).

        Returns
        -------
        control.FrequencyResponseData
            H(jω) at ω = 2πf [rad/s], input ``u`` (command [1]), output ``spool`` [1];
            usable with ``control.bode_plot``, ``control.nyquist_plot`` and in
            interconnections with models.
        """
        import control  # deferred: python-control loads only here

        label = name or (
            f"valve_{round(100 * self.amplitude)}pct" if np.isfinite(self.amplitude) else "valve"
        )
        label = label.replace(".", "p")
        return control.frd(
            np.asarray(self.response, dtype=complex),
            self.omega,
            name=label,
            inputs="u",
            outputs="spool",
        )

    def __repr__(self) -> str:
        f = np.asarray(self.frequency)
        span = f"{f[0]:g}–{f[-1]:g} Hz" if f.size else "empty"
        return f"FrequencyResponse(amplitude={self.amplitude:g}, {f.size} points, {span})"


def estimate_frf_h1(
    t,
    u,
    y,
    nperseg: int | None = None,
    f_max: float | None = None,
    amplitude: float | None = None,
    name: str = "",
    f_min: float | None = None,
    period: float | None = None,
) -> FrequencyResponse:
    """H1 estimate H = S_uy/S_uu with coherence from a broadband run (chirp, noise).

    Parameters
    ----------
    t, u, y : array_like, shape (N,)
        Uniformly sampled time [s], command [1], response [1].
    nperseg : int, optional
        Welch segment length [samples]; default N/8 (at least 64).
    f_max : float, optional
        Highest frequency kept [Hz] (default: Nyquist). Give the excited band's upper
        end: bins the command does not excite hold noise over noise (+100 dB, any phase).
    amplitude : float, optional
        Command amplitude [1] the FRF is filed under (default: peak |u − mean u|).
    f_min : float, optional
        Lowest frequency kept [Hz] (the excited band's lower end).
    period : float, optional
        Period [s] of a periodic excitation (multisine). Segments are then whole periods with a
        rectangular window and no overlap, so every bin is one excited line, free of leakage,
        and bins are independent (a Hann window on segments that cut the period smears the
        lines into each other: ζ biased by 1.5σ on the small axis).

    Returns
    -------
    FrequencyResponse
        Without the DC bin; coherence γ² = |S_uy|²/(S_uu S_yy).
    """
    t = np.asarray(t, dtype=float)
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    fs = 1.0 / float(np.median(np.diff(t)))
    n = u.size
    if n < 256:
        raise IdentificationError(
            f"broadband run has {n} samples; need at least 256 for an H1 estimate"
        )
    if period is not None and period * fs >= 16 and n >= 2 * period * fs:
        nper = int(round(period * fs))
        kw = dict(window="boxcar", noverlap=0, detrend="constant")
        u = u[n - (n // nper) * nper :]  # whole periods, the start-up transient dropped first
        y = y[n - (n // nper) * nper :]
        if n // nper > 2:  # leave the first period out: the valve's transient
            u, y = u[nper:], y[nper:]
    else:
        nper = int(nperseg or max(64, n // 8))
        nper = min(nper, n)
        kw = dict(detrend="linear")
    f, s_uy = signal.csd(u, y, fs=fs, nperseg=nper, **kw)
    _, s_uu = signal.welch(u, fs=fs, nperseg=nper, **kw)
    _, s_yy = signal.welch(y, fs=fs, nperseg=nper, **kw)
    keep = (f > 0) & (s_uu > 0)
    if f_max is not None:
        keep &= f <= f_max
    if f_min is not None:
        keep &= f >= f_min
    h = s_uy[keep] / s_uu[keep]
    coh = np.abs(s_uy[keep]) ** 2 / (s_uu[keep] * s_yy[keep])
    amp = float(amplitude) if amplitude is not None else float(np.max(np.abs(u - np.mean(u))))
    return FrequencyResponse(
        f[keep],
        h,
        coh,
        amp,
        (name,) if name else (),
        independent_bins=period is not None and kw.get("window") == "boxcar",
    )


def second_order_response(omega, omega0: float, zeta: float) -> np.ndarray:
    """G(jω) = ω0²/((jω)² + 2ζω0 jω + ω0²) of Eq. (1) [1]; ``omega`` in rad/s."""
    s = 1j * np.asarray(omega, dtype=float)
    return omega0**2 / (s * s + 2.0 * zeta * omega0 * s + omega0**2)


@dataclasses.dataclass(frozen=True)
class SecondOrderFit(FitResult):
    """Second-order model (1) fitted to one FRF (one row of Table II).

    Attributes
    ----------
    omega0 : ParameterEstimate
        Natural frequency ω0 [rad/s].
    zeta : ParameterEstimate
        Damping ratio ζ [1].
    correlation : float
        Correlation of the ω0 and ζ estimates [1].
    rms_log_error : float
        RMS of the complex log error |log(G/H)| [1] (≈ relative error).
    n_points : int
        Number of FRF points used.
    amplitude : float
        Command amplitude |u| [1].
    status : OptimizerStatus
        How the best start's ``least_squares`` run ended; ``nfev`` counts the residual
        evaluations of all starts.
    """

    omega0: ParameterEstimate
    zeta: ParameterEstimate
    correlation: float
    rms_log_error: float
    n_points: int
    amplitude: float = float("nan")
    status: OptimizerStatus = dataclasses.field(
        default_factory=lambda: OptimizerStatus.closed_form("given")
    )

    def _estimates(self) -> dict[str, ParameterEstimate]:
        return {"omega0": self.omega0, "zeta": self.zeta}

    def response(self, omega) -> np.ndarray:
        """Model response G(jω) [1] at ``omega`` [rad/s]."""
        return second_order_response(omega, self.omega0.value, self.zeta.value)


def fit_second_order(
    frf: FrequencyResponse,
    min_coherence: float = 0.8,
    level: float = 0.95,
    f_max: float | None = None,
    f_min: float | None = None,
) -> SecondOrderFit:
    """Fit ω0 and ζ of Eq. (1) to a measured FRF by complex least squares.

    Parameters
    ----------
    frf : FrequencyResponse
        Measured FRF (points with coherence below ``min_coherence`` are dropped).
    min_coherence : float
        Smallest coherence [1] of an H1 point that is used.
    level : float
        Confidence level of the intervals [1].
    f_max, f_min : float, optional
        Band used [Hz] (the excited band of a broadband run).

    Returns
    -------
    SecondOrderFit

    Notes
    -----
    Residuals are Re and Im of log(G(jω)/H(jω)): the relative magnitude error and
    the phase error in rad. For an H1 estimate each bin is weighted by
    √(γ²/(1 − γ²)) (the inverse of the relative standard error of H1, which is
    ∝ √((1 − γ²)/γ²)), capped at γ² = 0.999; stepped-sine points weigh equally. Starts
    on a grid of ω0 over the measured band and ζ ∈ {0.3, 0.7, 1.5}; the best optimum is
    kept. Intervals are ±t·std with the sandwich covariance of the weighted residuals
    (:func:`sandwich_covariance`; for H1 the variance is also multiplied by the Hann
    window's equivalent noise bandwidth, 1.5 bins, since neighbouring bins are correlated).
    """
    w = frf.omega
    h = np.asarray(frf.response)
    f_hz = np.asarray(frf.frequency)
    keep = np.isfinite(h) & (np.abs(h) > 0)
    if frf.coherence is not None:
        keep &= np.asarray(frf.coherence) >= min_coherence
    if f_max is not None:
        keep &= f_hz <= f_max
    if f_min is not None:
        keep &= f_hz >= f_min
    w, h = w[keep], h[keep]
    if w.size < 3:
        raise IdentificationError(
            f"FRF at amplitude {frf.amplitude:g} has {w.size} usable points; need at least 3 for ω0 and ζ"
        )
    known = frf.std is not None and frf.coherence is None
    if known:
        sd_pts = np.asarray(frf.std, dtype=float)[keep]
        known = bool(np.all(np.isfinite(sd_pts) & (sd_pts > 0)))
    if frf.coherence is not None:
        g2 = np.clip(np.asarray(frf.coherence)[keep], 1e-6, 0.999)
        wt = np.sqrt(g2 / (1.0 - g2))
        wt = wt / np.mean(wt)
        bin_factor = 1.0 if frf.independent_bins else 1.5
    elif known:
        wt = 1.0 / sd_pts
        bin_factor = 1.0
    else:
        wt = np.ones(w.size)
        bin_factor = 1.0
    wt2 = np.concatenate([wt, wt])

    def resid(theta):
        r = np.log(second_order_response(w, theta[0], theta[1]) / h)
        return wt2 * np.concatenate([r.real, r.imag])

    best = None
    nfev = 0
    for w0 in np.geomspace(max(w.min(), 1.0), w.max() * 4.0, 6):
        for z0 in (0.3, 0.7, 1.5):
            res = least_squares(
                resid, [w0, z0], bounds=([1e-3, 1e-3], [1e7, 20.0]), x_scale=[w0, 0.3], method="trf"
            )
            nfev += int(res.nfev)
            if best is None or res.cost < best.cost:
                best = res
    assert best is not None
    if known:
        # each point's noise is known from its sinusoid fits: (JᵀWJ)⁻¹, widened by the lack of
        # fit χ²/dof when the points scatter more than their noise (model error); a variance
        # estimated from 7-8 points alone is itself too uncertain (issue 18: 2-4σ misses)
        dof = max(best.fun.size - 2, 1)
        chi2 = float(best.fun @ best.fun) / dof
        cov = covariance_from_jacobian(best.jac, best.fun) * max(1.0, chi2) / max(chi2, 1e-300)
        q = t_quantile(level, 10**6) if chi2 <= 1.0 else t_quantile(level, w.size - 2)
    else:
        cov = bin_factor * sandwich_covariance(best.jac, best.fun)
        q = t_quantile(level, w.size - 2)
    sd = np.sqrt(np.diag(cov))
    re, im = (resid(best.x) / wt2).reshape(2, -1)
    rms = float(np.sqrt(np.mean(re**2 + im**2)))
    return SecondOrderFit(
        omega0=within_physical_bounds("omega0", estimate(best.x[0], sd[0], q, "rad/s", level)),
        zeta=within_physical_bounds("zeta", estimate(best.x[1], sd[1], q, "1", level)),
        correlation=float(correlation(cov)[0, 1]),
        rms_log_error=rms,
        n_points=int(w.size),
        amplitude=float(frf.amplitude),
        status=OptimizerStatus(bool(best.success), str(best.message), nfev, None),
    )


def _estimate_frequency(t: np.ndarray, u: np.ndarray) -> float:
    """Dominant frequency [Hz] of a sine command: FFT peak refined by parabolic interpolation."""
    n = u.size
    fs = 1.0 / float(np.median(np.diff(t)))
    nfft = 1 << int(np.ceil(np.log2(8 * n)))
    spec = np.abs(np.fft.rfft((u - np.mean(u)) * np.hanning(n), nfft))
    k = int(np.argmax(spec[1:])) + 1
    if 1 <= k < spec.size - 1:
        a, b, c = np.log(spec[k - 1 : k + 2] + 1e-300)
        k = k + 0.5 * (a - c) / (a - 2 * b + c)
    return float(k * fs / nfft)


class ValveFrfIdentifier:
    """Identify the servo valve's ω0 and ζ per command amplitude (Sec. VI-A, Fig. 5, Table II).

    Parameters
    ----------
    n_periods : int
        Full periods per stepped-sine run used for the sinusoid fit, counted from the end.
    trend : bool
        Fit a linear trend together with the sinusoid.
    min_coherence : float
        Smallest coherence [1] of an H1 (broadband) point that is used in the fit.
    nperseg : int, optional
        Welch segment length [samples] for broadband runs.
    f_max : float, optional
        Highest frequency [Hz] used in the model fit.
    level : float
        Confidence level [1] of the intervals.
    amplitude_decimals : int
        Command amplitudes are grouped after rounding to this many decimals.
    band : (float, float), optional
        Frequency band [Hz] used for every FRF (``--band`` of ``hydropwa identify``);
        default: a broadband run's own excited band (meta ``band`` or ``f0``/``f1``), all
        stepped-sine points.

    Attributes
    ----------
    frf_ : dict[float, FrequencyResponse]
        Measured FRF per command amplitude [1].
    fits_ : dict[float, SecondOrderFit]
        Model (1) fitted per amplitude.
    valve_ : ServoValve
        ω0 of the amplitude nearest the middle as ``omega0``, the amplitude schedule in
        ``omega0_table`` (when more than one amplitude), and the inverse-variance weighted ζ.
    omega0_ : ParameterEstimate
        ω0 [rad/s] of the amplitude nearest 25 % (``valve_.omega0``).
    zeta_ : ParameterEstimate
        The pooled ζ [1].
    status_ : OptimizerStatus
        All per-amplitude fits together: converged when each did, ``nfev`` summed
        (each fit's own in ``fits_[a].status``).
    skipped_ : list[SkippedRun]
        Runs (or segments) left out, with the reason.

    Notes
    -----
    A run is a stepped-sine run when its metadata give a ``frequency`` [Hz] (or
    ``segments``, a list of ``{"t0", "t1", "frequency"}``) and a broadband run when
    its ``type`` (or experiment) is chirp/noise/multisine. Without either, the
    frequency is estimated from the command's spectrum.
    """

    #: The experiment kind this estimator reads and the parameter field it sets.
    part: ClassVar[str] = "frf"
    field: ClassVar[str] = "valve"

    def __init__(
        self,
        *,
        n_periods: int = 4,
        trend: bool = True,
        min_coherence: float = 0.8,
        nperseg: int | None = None,
        f_max: float | None = None,
        level: float = 0.95,
        amplitude_decimals: int = 3,
        band: tuple[float, float] | None = None,
    ) -> None:
        self.n_periods = n_periods
        self.trend = trend
        self.min_coherence = min_coherence
        self.nperseg = nperseg
        self.f_max = f_max
        self.level = level
        self.amplitude_decimals = amplitude_decimals
        self.band = band

    def _band(self, run) -> tuple[float | None, float | None]:
        """Excited band [Hz] of a broadband run: ``band`` if given, else the run's ``band``/``f0``–``f1``."""
        if self.band is not None:
            return float(self.band[0]), float(self.band[1])
        b = signal_value(run, "band")
        if isinstance(b, list | tuple) and len(b) == 2:
            return float(b[0]), float(b[1])
        f0, f1 = signal_value(run, "f0"), signal_value(run, "f1")
        if f0 is not None and f1 is not None:
            lo, hi = sorted((float(f0), float(f1)))
            return lo, hi
        return None, self.f_max

    # ---------------------------------------------------------------- per run
    def _segments(self, run, t):
        segs = signal_value(run, "segments")
        if isinstance(segs, list) and segs:
            return [(float(s["t0"]), float(s["t1"]), float(s["frequency"])) for s in segs]
        f = signal_value(run, "frequency", "freq", "f")
        return [(t[0], t[-1], None if f is None else float(f))]

    def _broadband(self, run) -> bool:
        kinds = {
            str(signal_value(run, k, default="")).lower()
            for k in ("type", "signal_type", "excitation")
        }
        exp = str((run.meta or {}).get("experiment", (run.meta or {}).get("kind", ""))).lower()
        return bool(kinds & _BROADBAND) or exp in _BROADBAND

    def _amplitude(self, run, measured: float) -> float:
        """Command amplitude [1] from the metadata, checked against the measured command.

        A value above full opening that is 100× the measured amplitude (within 20 %) was
        written in percent (``amplitude = 10`` for 10 %) and is read so; a string with a unit
        (``"10 %"``) is converted; any other value above 1.5 is an error with a hint.
        """

        a = signal_value(run, "amplitude", "opening", default=None)
        if a is None:
            return round(measured, self.amplitude_decimals)
        a = abs(parse_quantity(a, "", f"run {run.name!r} meta amplitude"))
        if a > 1.5:
            if measured > 0 and abs(a / 100.0 - measured) <= 0.2 * measured:
                a = a / 100.0
            else:
                raise IdentificationError(
                    f"meta amplitude {a:g} is {100 * a:g} % of full opening but the command's amplitude is "
                    f"{measured:.3g}; write it as a fraction ({a / 100:g}) or with a unit ('{a:g} %')"
                )
        return round(a, self.amplitude_decimals)

    def fit(self, data) -> ValveFrfIdentifier:
        """Estimate the FRFs from ``data`` (Dataset, runs, or a folder) and fit model (1).

        Returns
        -------
        ValveFrfIdentifier
            ``self``, with ``frf_``, ``fits_``, ``valve_``, ``zeta_`` and ``skipped_`` set.

        Raises
        ------
        IdentificationError
            If no amplitude has enough usable FRF points.
        """
        runs = as_runs(data, "frf")
        skipped: list[SkippedRun] = []
        points: dict[float, list[tuple[float, complex, str, float]]] = {}
        broadband: dict[float, list[FrequencyResponse]] = {}
        for run in runs:
            ch = channels_of(run, ("t", "u", "spool"), skipped)
            if ch is None:
                continue
            t, u, y = ch["t"], ch["u"], ch["spool"]
            if self._broadband(run):
                frf = self._broadband_frf(run, t, u, y, skipped)
                if frf is not None:
                    broadband.setdefault(frf.amplitude, []).append(frf)
                continue
            self._stepped_points(run, t, u, y, skipped, points)
        frfs = self._frfs(points, broadband)
        fits: dict[float, SecondOrderFit] = {}
        for amp in sorted(frfs):
            try:
                lo, hi = self.band if self.band is not None else (None, self.f_max)
                fits[amp] = fit_second_order(frfs[amp], self.min_coherence, self.level, hi, lo)
            except IdentificationError as exc:
                skip(skipped, ",".join(frfs[amp].runs) or f"amplitude {amp:g}", str(exc))
        require_usable(list(fits), skipped, "valve FRF identification")
        self.frf_ = dict(sorted(frfs.items()))
        self.fits_ = fits
        self.skipped_ = skipped
        self.zeta_ = _pooled([f.zeta for f in fits.values()], self.level, "1")
        amps = sorted(fits)
        mid = min(amps, key=lambda a: abs(a - 0.25))
        table = (
            tuple((a, fits[a].omega0.value) for a in amps if 0 < a <= 1.5) if len(amps) > 1 else ()
        )
        self.omega0_ = fits[mid].omega0
        self.valve_ = ServoValve(
            omega0=fits[mid].omega0.value, zeta=self.zeta_.value, omega0_table=table
        )
        sts = [f.status for f in fits.values()]
        failed = [f"{a:g}" for a, f in fits.items() if not f.status.success]
        self.status_ = OptimizerStatus(
            not failed,
            f"{len(sts)} amplitude fit(s)"
            + (f"; not converged at amplitude(s) {', '.join(failed)}" if failed else " converged"),
            sum(st.nfev for st in sts),
            None,
        )
        return self

    def _broadband_frf(self, run, t, u, y, skipped: list[SkippedRun]) -> FrequencyResponse | None:
        """The H1 estimate of one broadband run at its amplitude (None: skipped, and why)."""
        f_lo, f_hi = self._band(run)
        kinds = {str(signal_value(run, k, default="")).lower() for k in ("excitation", "type")}
        try:
            period = signal_value(run, "period") if "multisine" in kinds else None
            frf = estimate_frf_h1(
                t,
                u,
                y,
                self.nperseg,
                f_hi,
                None,
                run.name,
                f_lo,
                None if period is None else float(period),
            )
            amp = self._amplitude(run, frf.amplitude)
        except IdentificationError as exc:
            skip(skipped, run.name, str(exc))
            return None
        return dataclasses.replace(frf, amplitude=amp)

    def _stepped_points(self, run, t, u, y, skipped: list[SkippedRun], points: dict) -> None:
        """Add one point (f, H, label, relative std) per stepped-sine segment of ``run``."""
        segments = self._segments(run, t)
        for t0, t1, f in segments:
            sel = (t >= t0) & (t <= t1)
            label = run.name if f is None or len(segments) == 1 else f"{run.name}@{f:g}Hz"
            try:
                freq = f if f is not None else _estimate_frequency(t[sel], u[sel])
                h, fu, fy = stepped_sine_point(
                    t[sel], u[sel], y[sel], freq, self.n_periods, self.trend
                )
                amp = self._amplitude(run, fu.amplitude)
            except IdentificationError as exc:
                skip(skipped, label, str(exc))
                continue
            fs = 1.0 / float(np.median(np.diff(t)))
            sd = float(np.hypot(_relative_std(fy, fs), _relative_std(fu, fs)))
            points.setdefault(amp, []).append((freq, h, label, sd))

    def _frfs(self, points: dict, broadband: dict) -> dict[float, FrequencyResponse]:
        """One FRF per amplitude: the stepped-sine points, then the broadband estimates."""
        frfs: dict[float, FrequencyResponse] = {}
        for amp, pts in points.items():
            pts.sort()
            frfs[amp] = FrequencyResponse(
                np.array([p[0] for p in pts]),
                np.array([p[1] for p in pts]),
                None,
                amp,
                tuple(p[2] for p in pts),
                np.array([p[3] for p in pts]),
            )
        for amp, lst in broadband.items():
            if amp in frfs:  # stepped sine wins; keep the broadband one under its own key
                amp = amp + 10.0 ** -(self.amplitude_decimals + 1)
            frfs[amp] = lst[0] if len(lst) == 1 else _merge(lst, amp)
        return frfs

    def apply(self, params: SystemParams) -> SystemParams:
        """``params`` with the fitted servo valve (ω0, its amplitude schedule, ζ) in place."""
        if not hasattr(self, "valve_"):
            raise not_fitted("ValveFrfIdentifier")
        return dataclasses.replace(params, valve=self.valve_)

    def provenance(self) -> str:
        """One line on how the valve was found (``[meta.identification]`` of a parameter file)."""
        if not hasattr(self, "fits_"):
            raise not_fitted("ValveFrfIdentifier")
        return (
            f"Sec. VI-A: {sum(f.n_points for f in self.fits_.values())} FRF points at "
            f"amplitudes {', '.join(f'{a:g}' for a in self.fits_)}; 2nd-order fit, "
            f"zeta pooled (inverse-variance); optimiser: {self.status_}"
        )

    def uncertainty(self) -> dict:
        """Per-amplitude ω0 and ζ estimates as a plain dict (for the ``[uncertainty]`` table)."""
        out: dict = {"zeta": self.zeta_.to_dict()}
        for a, f in self.fits_.items():
            out[f"omega0_at_{a:g}"] = f.omega0.to_dict()
            out[f"zeta_at_{a:g}"] = f.zeta.to_dict()
        out["optimizer"] = dataclasses.asdict(self.status_)
        return out


def _merge(lst: list[FrequencyResponse], amp: float) -> FrequencyResponse:
    f = np.concatenate([x.frequency for x in lst])
    order = np.argsort(f)
    coh = [x.coherence if x.coherence is not None else np.ones(x.frequency.size) for x in lst]
    return FrequencyResponse(
        f[order],
        np.concatenate([x.response for x in lst])[order],
        np.concatenate(coh)[order],
        amp,
        tuple(n for x in lst for n in x.runs),
    )


def _pooled(ests: list[ParameterEstimate], level: float, unit: str) -> ParameterEstimate:
    """Inverse-variance weighted mean of several estimates of one quantity."""
    v = np.array([e.value for e in ests])
    s = np.array([e.std for e in ests])
    if len(ests) == 1 or not np.all(np.isfinite(s) & (s > 0)):
        m = float(np.mean(v))
        sd = float(np.std(v, ddof=1) / np.sqrt(v.size)) if v.size > 1 else float(s[0])
    else:
        wts = 1.0 / s**2
        m = float(np.sum(wts * v) / np.sum(wts))
        sd = float(np.sqrt(1.0 / np.sum(wts)))
        # Birge ratio: estimates that disagree by more than their errors (ζ is not exactly
        # the same at every amplitude, or an error is too small) widen the pooled interval
        birge = float(np.sum(wts * (v - m) ** 2) / (v.size - 1))
        sd *= float(np.sqrt(max(1.0, birge)))
    return estimate(m, sd, t_quantile(level, 1000), unit, level)


def frf_from_mapping(frf: Mapping[float, FrequencyResponse]) -> dict[float, FrequencyResponse]:
    """Copy of a mapping amplitude → FRF, sorted by amplitude (helper for plots)."""
    return dict(sorted(frf.items()))
