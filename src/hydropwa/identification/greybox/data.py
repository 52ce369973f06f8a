"""Grey-box data: a run's fitted channels, noise levels, valid stretches and segments.

The shooting settings (:class:`Shooting`), the per-run preparation (validity, shooting method,
initial states from smoothed measurements, segments, filtered inputs) and the perturbation of
a run by its own initial-state and input errors (errors in variables).
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from scipy.signal import butter, savgol_coeffs, savgol_filter, sosfiltfilt

from ..._channels import (
    CONVERTER_CHANNELS,
    RECORDED_CHANNELS,
    SENSED_STATE_CHANNELS,
    START_REQUIRED,
    STATE_CHANNELS,
)
from ..._errors import IdentificationError
from .._common import IdentificationWarning, SkippedRun, skip

__all__ = ["Shooting", "noise_level", "prepare_run", "perturbed_run"]


# ----------------------------------------------------------------------------- settings
@dataclasses.dataclass(frozen=True)
class Shooting:
    """How each run is simulated during the fit.

    Attributes
    ----------
    method : {"auto", "single", "multiple"}
        ``auto`` chooses per run: multiple shooting when the run oscillates (stick-slip,
        see :func:`fit_model`), single shooting otherwise.
    window : float
        Multiple shooting window length [s] (20 ms: 3–4 stick-slip periods at 150–200 Hz).
    segment : float or None
        Single shooting restarts from the measured state every ``segment`` seconds (None:
        one simulation per valid stretch). The position integrates every velocity error,
        so over a 5 s sine run a 10 % error in K drifts the rod by centimetres (thousands
        of noise levels): the cost is then dominated by the drift and its valleys are
        curved. Half-second stretches keep the drift, and the fit, well-conditioned.
    max_windows : int or None
        At most this many windows per run, evenly spaced over its valid part (None: all).
        Windows of a steady oscillation repeat each other; 40 per run keep the fit fast.
    velocity_window : float
        Length [s] of the Savitzky–Golay filter (quadratic) that gives the initial
        velocity of each window from the measured position.
    oscillation_ratio : float
        ``auto`` calls a run oscillating when the robust spread (1.4826·median |·|) of its
        load pressure around a 10 ms moving mean exceeds this many times its noise level.
        Measured on the virtual rig: 1.0–1.3 on smooth runs, 2.4–2.8 on 20 % sines (brief
        stick at the reversals), 4.5–7.5 on stick-slip runs.
    """

    method: str = "auto"
    window: float = 0.02
    segment: float | None = 0.5
    max_windows: int | None = 40
    velocity_window: float = 0.004
    oscillation_ratio: float = 3.5

    def __post_init__(self) -> None:
        if self.method not in ("auto", "single", "multiple"):
            raise IdentificationError(
                f"Shooting.method = {self.method!r}; choose auto, single or multiple"
            )
        if not (math.isfinite(self.window) and 1e-3 <= self.window <= 10.0):
            raise IdentificationError(
                f"Shooting.window = {self.window!r} s must lie in [1 ms, 10 s]"
            )
        if self.segment is not None and not (self.segment >= self.window):
            raise IdentificationError(
                f"Shooting.segment = {self.segment!r} s must be >= the window or None"
            )
        if self.max_windows is not None and self.max_windows < 1:
            raise IdentificationError(
                f"Shooting.max_windows = {self.max_windows!r} must be >= 1 or None"
            )
        if not (self.velocity_window > 0):
            raise IdentificationError(
                f"Shooting.velocity_window = {self.velocity_window!r} s must be > 0"
            )


# ----------------------------------------------------------------------------- run preparation
@dataclasses.dataclass
class _Segment:
    i0: int
    i1: int  # exclusive
    y0: np.ndarray
    #: the smoothed measurements y0 was built from (x, v, p_a, p_b, p_s, spool, spool_rate)
    meas: dict[str, float]
    #: per channel, a factor on the segment's noise-scaled residuals, one for all or one per
    #: residual sample (None: 1); a steady stretch's mean stands for many samples (``greybox.steady``)
    weight: dict[str, Any] | None = None


@dataclasses.dataclass
class RunData:
    name: str
    t: np.ndarray
    u: np.ndarray
    p_s: np.ndarray | None
    f_l: np.ndarray | None
    y: dict[str, np.ndarray]
    sigma: dict[str, float]
    method: str
    reason: str
    segments: list[_Segment]
    excluded: list[tuple[float, float, str]]
    #: builds an initial state from measurements (the segment's ``meas``, perturbed)
    make_state: Callable[[dict[str, float]], np.ndarray]
    #: standard deviation of each smoothed initial measurement (its sensor noise through the
    #: Savitzky–Golay filter)
    meas_sd: dict[str, float]
    #: per driving input (p_s, f_l): its noise level [SI] and the low-pass it went through
    input_noise: dict[str, tuple[float, Any]]
    #: the smoothed measured velocity [m/s] (what the segment selection reads)
    speed: np.ndarray | None = None
    #: the load damping [N·s/m] the model applies for this run (the ``feedback`` taken out
    #: of its measured F_L); None: the model's own (a whole campaign: only the friction
    #: experiment's counter cylinder loads the rod with c·ẋ)
    damping: float | None = None


def noise_level(y: np.ndarray) -> float:
    """Standard deviation of white noise on a signal from its second differences (robust).

    σ = 1.4826·MAD(Δ²y)/√6: the second difference removes smooth motion, white noise
    of variance σ² gives Δ²y a variance 6σ², and the MAD ignores sharp events. Never
    below one quantization step/√12 (the smallest change in the record).
    """
    y = np.asarray(y, dtype=float)
    d2 = np.diff(y, 2)
    s = 1.4826 * float(np.median(np.abs(d2 - np.median(d2)))) / math.sqrt(6.0) if d2.size else 0.0
    steps = np.abs(np.diff(y))
    steps = steps[steps > 0]
    q = float(steps.min()) / math.sqrt(12.0) if steps.size else 0.0
    return max(s, q, 1e-300)


def _mask_runs(mask: np.ndarray) -> list[tuple[int, int]]:
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return list(
        zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist(), strict=True)
    )


def _clipped(v: np.ndarray, min_samples: int = 5) -> np.ndarray:
    """Samples stuck at the record's extreme for ``min_samples`` or more (a converter limit)."""
    out = np.zeros(v.size, bool)
    if v.size < 2 * min_samples or v.min() == v.max():
        return out
    for level in (v.max(), v.min()):
        for s, e in _mask_runs(v == level):
            if e - s >= min_samples:
                out[s:e] = True
    rest = np.diff(v[~out])
    if out.any() and rest.size and np.mean(rest == 0) > 0.5:  # quantised slow signal, not a rail
        return np.zeros(v.size, bool)
    return out


def _dilate(mask: np.ndarray, n: int) -> np.ndarray:
    if n <= 0 or not mask.any():
        return mask
    k = np.convolve(mask.astype(float), np.ones(2 * n + 1), mode="same")
    return k > 0.5


def _smoothed_velocity(t: np.ndarray, x: np.ndarray, window: float) -> np.ndarray:
    dt = float(np.median(np.diff(t)))
    n = max(5, int(round(window / dt)) | 1)
    if n >= x.size:
        return np.gradient(x, t)
    return savgol_filter(x, n, 2, deriv=1, delta=dt)


def _smoothed(t: np.ndarray, y: np.ndarray, window: float) -> np.ndarray:
    dt = float(np.median(np.diff(t)))
    n = max(5, int(round(window / dt)) | 1)
    return y if n >= y.size else savgol_filter(y, n, 2)


def _arrays(
    run: Any, channels: Sequence[str], skipped: list[SkippedRun]
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]] | None:
    """The run's usable channels and its fitted outputs (``p_l`` = p_a − p_b on request);
    None, with the reason in ``skipped``, for a run that cannot enter the fit."""
    ch = run.channels
    needed = ("t", "u", *START_REQUIRED)
    missing = [c for c in needed if c not in ch]
    if missing:
        why = f"missing channel(s) {', '.join(missing)} (grey-box fit needs {', '.join(needed)})"
        skip(skipped, run.name, why, 4)
        return None
    kept = {"t", *RECORDED_CHANNELS, *STATE_CHANNELS}
    arrays = {k: np.asarray(v, dtype=float) for k, v in ch.items() if k in kept}
    bad = [k for k, v in arrays.items() if not np.all(np.isfinite(v))]
    if bad:
        skip(skipped, run.name, f"channel(s) {', '.join(bad)} hold non-finite samples", 4)
        return None
    n = arrays["t"].size
    if n < 20:
        skip(skipped, run.name, f"only {n} samples", 4)
        return None
    y = {}
    for c in channels:
        if c == "p_l":
            y[c] = arrays["p_a"] - arrays["p_b"]
        elif c in arrays:
            y[c] = arrays[c]
    if not y:
        skip(skipped, run.name, f"none of the fitted channels {', '.join(channels)} is logged", 4)
        return None
    return arrays, y


def _departures(stop: np.ndarray, x: np.ndarray, stroke: float) -> np.ndarray:
    """``stop`` with each departure from an end stop given back from where the rod is 50 µm
    (or ten noise levels) away from it: leaving a stop has no contact transient, and the
    first millimetre is where the rod breaks away through the Stribeck peak."""
    near = max(5e-5, 10.0 * noise_level(x))
    small = (x < near) | (x > stroke - near)
    out = stop.copy()
    for s, e in _mask_runs(stop):
        inside = np.flatnonzero(small[s:e])
        if e < stop.size and inside.size:
            out[s + int(inside[-1]) + 1 : e] = False
    return out


def _validity(
    arrays: dict[str, np.ndarray], stroke: float, dt: float, departures: bool = False
) -> tuple[np.ndarray, list[tuple[float, float, str]]]:
    """Samples left out (converter limits and end-stop contact, widened by 10 ms: their
    transients) and the excluded stretches [s] with their reasons (``departures``: the rod
    leaving an end stop is kept from 50 µm away, see :func:`_departures`)."""
    t = arrays["t"]
    margin = max(5e-4, 1e-3 * stroke)
    excluded: list[tuple[float, float, str]] = []
    bad_mask = np.zeros(t.size, bool)
    widen = int(round(0.01 / dt))
    for c in CONVERTER_CHANNELS:
        if c in arrays:
            m = _clipped(arrays[c])
            if m.any():
                m = _dilate(m, widen)
                for s, e in _mask_runs(m):
                    excluded.append((float(t[s]), float(t[e - 1]), f"{c} at a converter limit"))
                bad_mask |= m
    x = arrays["x"]
    stop = (x < margin) | (x > stroke - margin)
    if stop.any():
        stop = _dilate(stop, widen)
        if departures:
            stop = _departures(stop, x, stroke)
        for s, e in _mask_runs(stop & ~bad_mask):
            excluded.append((float(t[s]), float(t[e - 1]), "rod at an end stop"))
        bad_mask |= stop
    return bad_mask, excluded


def oscillation_ratio(arrays: dict[str, np.ndarray], bad_mask: np.ndarray, dt: float) -> float:
    """Robust spread of the load pressure around its 10 ms moving mean over its noise level
    (median-based: brief events such as reversals of a sine or a step do not count, a
    sustained oscillation does)."""
    pl = arrays["p_a"] - arrays["p_b"]
    k = max(3, int(round(0.01 / dt)) | 1)
    hp = pl - np.convolve(pl, np.ones(k) / k, mode="same")
    good = ~bad_mask
    good[:k] = False
    good[-k:] = False
    if good.sum() <= 10:
        return 0.0
    return float(1.4826 * np.median(np.abs(hp[good])) / noise_level(pl))


def _method(ratio: float, shooting: Shooting, sliding_above: float | None) -> tuple[str, str]:
    if sliding_above is not None:
        return "single", f"sliding stretches (|v| > {1e3 * sliding_above:.3g} mm/s)"
    if shooting.method == "auto":
        method = "multiple" if ratio > shooting.oscillation_ratio else "single"
        return (
            method,
            f"auto: load-pressure fast content {ratio:.1f}× noise "
            f"(threshold {shooting.oscillation_ratio:g})",
        )
    return shooting.method, "forced"


#: Order of a segment's measured start: the bootstrap (:func:`perturbed_run`) draws its noise in
#: it, so a seeded fit repeats; channels not listed (a new one of the channel table) follow.
_DRAW_ORDER = ("x", "v", "p_a", "p_b", "p_s", "spool")


def _draw_rank(item: tuple[str, float]) -> int:
    name = item[0]
    return _DRAW_ORDER.index(name) if name in _DRAW_ORDER else len(_DRAW_ORDER)


@dataclasses.dataclass
class _MeasuredStates:
    """Initial states from smoothed measurements: a raw sample's noise would persist through
    the whole segment (a 5 µm position error stays a 5 µm offset)."""

    mdl: Any
    u: np.ndarray
    v_est: np.ndarray
    sm: dict[str, np.ndarray]
    spool_rate: np.ndarray | None

    @classmethod
    def from_run(
        cls, mdl: Any, t: np.ndarray, arrays: dict[str, np.ndarray], window: float
    ) -> _MeasuredStates:
        sm: dict[str, np.ndarray] = {
            c: _smoothed(t, arrays[c], window) for c in SENSED_STATE_CHANNELS if c in arrays
        }
        rate = _smoothed_velocity(t, arrays["spool"], window) if "spool" in arrays else None
        return cls(mdl, arrays["u"], _smoothed_velocity(t, arrays["x"], window), sm, rate)

    def make_state(self, m: dict[str, float]) -> np.ndarray:
        mdl = self.mdl
        measured = {c: m[c] for c in STATE_CHANNELS if c in m}
        y0 = np.asarray(mdl.state_from_measurement(measured), dtype=float)
        if "spool_rate" in m and "spool_rate" in mdl.state_names:
            y0[mdl.state_names.index("spool_rate")] = m["spool_rate"]
        return y0

    def measured_at(self, i: int) -> dict[str, float]:
        sm = self.sm
        m = {c: float(y[i]) for c, y in sm.items()}
        m["v"] = float(self.v_est[i])
        # unmeasured: the machine's supply pressure, the spool at its command
        m.setdefault("p_s", float(self.mdl.params.supply.pressure))
        m.setdefault("spool", float(self.u[i]))
        m = dict(sorted(m.items(), key=_draw_rank))
        if self.spool_rate is not None:
            m["spool_rate"] = float(self.spool_rate[i])
        return m

    def segment(self, a: int, b: int) -> _Segment:
        m = self.measured_at(a)
        return _Segment(a, b, self.make_state(m), m)


def _measurement_sd(arrays: dict[str, np.ndarray], window: float, dt: float) -> dict[str, float]:
    """The initial measurements' errors: each channel's noise through the quadratic
    Savitzky–Golay filter (value: √Σh₀², derivative: √Σh₁²; the two are uncorrelated)."""
    n_sg = max(5, int(round(window / dt)) | 1)
    g0 = math.sqrt(float(np.sum(savgol_coeffs(n_sg, 2) ** 2)))
    g1 = math.sqrt(float(np.sum(savgol_coeffs(n_sg, 2, deriv=1, delta=dt) ** 2)))
    meas_sd: dict[str, float] = {
        c: noise_level(arrays[c]) * g0 for c in SENSED_STATE_CHANNELS if c in arrays
    }
    meas_sd["v"] = noise_level(arrays["x"]) * g1
    if "spool" in arrays:
        meas_sd["spool_rate"] = noise_level(arrays["spool"]) * g1
    return meas_sd


def _segments(
    method: str,
    states: _MeasuredStates,
    valid: list[tuple[int, int]],
    bad_mask: np.ndarray,
    shooting: Shooting,
    dt: float,
    sliding_above: float | None,
) -> list[_Segment]:
    """The simulated segments: single-shooting stretches (cut every ``shooting.segment``),
    the sliding stretches, or multiple-shooting windows (at most ``max_windows``)."""
    n = bad_mask.size
    segments: list[_Segment] = []
    min_len = max(10, int(round(0.25 * shooting.window / dt)))
    if method == "single":
        stretches, shortest = valid, min_len
        if sliding_above is not None:
            # the sliding stretches, at least one window long, selected on the same smoothed
            # velocity as the initial states: each starts at the crossing (see the sliding
            # stage in docs/architecture_identification.md for the delayed and the separately
            # smoothed starts that were measured and not kept)
            stretches = _mask_runs((np.abs(states.v_est) > sliding_above) & ~bad_mask)
            shortest = max(min_len, int(round(shooting.window / dt)))
        step = e_max = max(min_len, int(round(shooting.segment / dt))) if shooting.segment else n
        for s, e in stretches:
            for a in range(s, e, step):
                b = min(a + e_max, e)
                if b - a >= shortest:
                    segments.append(states.segment(a, b))
        return segments
    w = max(4, int(round(shooting.window / dt)))
    starts = [s0 for s, e in valid for s0 in range(s, e - w, w)]
    if shooting.max_windows is not None and len(starts) > shooting.max_windows:
        pick = np.unique(
            np.round(np.linspace(0, len(starts) - 1, shooting.max_windows)).astype(int)
        )
        starts = [starts[i] for i in pick]
    return [states.segment(s0, s0 + w + 1) for s0 in starts]


def _filtered_inputs(
    arrays: dict[str, np.ndarray],
    dt: float,
    input_cutoff: float | None,
    feedback: float = 0.0,
    speed: np.ndarray | None = None,
) -> tuple[dict[str, np.ndarray], dict[str, tuple[float, Any]]]:
    """Measured inputs carry sensor noise that the simulation would integrate (errors in
    variables: 5 N of force noise becomes a random walk of the rod); a zero-phase low-pass
    keeps the supply sag and the counter-force ripple and drops the noise."""
    inputs: dict[str, np.ndarray] = {}
    input_noise: dict[str, tuple[float, Any]] = {}
    for c in ("p_s", "f_l"):
        if c in arrays:
            v = arrays[c]
            if c == "f_l" and feedback > 0 and speed is not None:
                # the load's c·ẋ goes back into the model (load.damping = c), driven by the
                # simulated velocity: as a measured input it would be an open loop
                v = v - feedback * speed
            sos = None
            if input_cutoff and input_cutoff < 0.45 / dt and v.size > 30:
                sos = butter(2, input_cutoff, fs=1.0 / dt, output="sos")
                v = sosfiltfilt(sos, v)
            inputs[c] = v
            input_noise[c] = (noise_level(arrays[c]), sos)
    return inputs, input_noise


def prepare_run(
    run: Any,
    mdl: Any,
    channels: Sequence[str],
    shooting: Shooting,
    skipped: list[SkippedRun],
    input_cutoff: float | None = 50.0,
    sliding_above: float | None = None,
    departures: bool = False,
    feedback: float = 0.0,
) -> RunData | None:
    """A run's data for the fit: fitted channels, noise levels, valid stretches, segments.

    ``sliding_above`` [m/s]: instead of the shooting's segments, single-shooting segments
    over the stretches where the smoothed measured speed exceeds it (each started from
    the measured state there; see the sliding stage of :func:`fit_model`). ``departures``:
    keep the rod's departures from an end stop (see :func:`_departures`). ``feedback``
    [N·s/m]: the load's velocity-proportional part c·ẋ taken out of the measured F_L (the
    model then applies it with ``load.damping = feedback``).
    """
    got = _arrays(run, channels, skipped)
    if got is None:
        return None
    arrays, y = got
    t = arrays["t"]
    dt = float(np.median(np.diff(t)))
    sigma = {c: noise_level(v) for c, v in y.items()}
    bad_mask, excluded = _validity(arrays, mdl.params.cylinder.stroke, dt, departures)
    method, reason = _method(oscillation_ratio(arrays, bad_mask, dt), shooting, sliding_above)
    states = _MeasuredStates.from_run(mdl, t, arrays, shooting.velocity_window)
    segments = _segments(
        method, states, _mask_runs(~bad_mask), bad_mask, shooting, dt, sliding_above
    )
    if not segments:
        skip(
            skipped,
            run.name,
            "no valid stretch long enough to simulate (end stops or converter limits everywhere)",
            4,
        )
        return None
    inputs, input_noise = _filtered_inputs(arrays, dt, input_cutoff, feedback, states.v_est)
    return RunData(
        run.name,
        t,
        arrays["u"],
        inputs.get("p_s"),
        inputs.get("f_l"),
        y,
        sigma,
        method,
        reason,
        segments,
        excluded,
        states.make_state,
        _measurement_sd(arrays, shooting.velocity_window, dt),
        input_noise,
        states.v_est,
        feedback if feedback > 0 else None,
    )


def prepare_again(run: Any, *args: Any, **kwargs: Any) -> RunData | None:
    """:func:`prepare_run` of a run the fit has prepared once already (other segments: the
    locating windows, the sliding stretches, a selection, a validation): a run with none of
    those is left out without a second warning (its first preparation warned)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentificationWarning)
        return prepare_run(run, *args, **kwargs)


def perturbed_run(rd: RunData, rng: np.random.Generator) -> RunData:
    """``rd`` with one draw of its initial-state and input errors added.

    Each segment's initial measurements move by their smoothed noise (``meas_sd``) and each
    driving input by white noise of its level through the same low-pass; the measured
    outputs stay. What the fit's estimate would be with these data instead is one draw
    of what the data's initial states and inputs (errors in variables) do to it.
    """
    segs = []
    for seg in rd.segments:
        # P_S from the parameters or the spool from the command (not logged) carry no noise
        m = {k: v + rng.normal(0.0, rd.meas_sd.get(k, 0.0)) for k, v in seg.meas.items()}
        segs.append(dataclasses.replace(seg, y0=rd.make_state(m), meas=m))
    extra = {}
    for c in ("p_s", "f_l"):
        arr = getattr(rd, c)
        if arr is None or c not in rd.input_noise:
            continue
        sd, sos = rd.input_noise[c]
        e = rng.normal(0.0, sd, arr.size)
        extra[c] = arr + (sosfiltfilt(sos, e) if sos is not None else e)
    return dataclasses.replace(rd, segments=segs, **extra)
