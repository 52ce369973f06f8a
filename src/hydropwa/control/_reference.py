"""Position references: motion profiles (trapezoidal, S-curve), step sequences, specs and files.

Every reference is a :class:`~hydropwa.simulation.Signal` (it also works as an
open-loop input) with an analytic ``rate`` for the velocity feed-forward. The
closed loop samples the reference and its rate at the controller's sample instants
only, so nothing here runs per integration step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._errors import HydropwaError, SignalError
from ..data import read_run
from ..params import parse_quantity
from ..simulation import Sampled, Signal, as_signal
from ._controllers import ControlError

__all__ = [
    "MotionProfile",
    "MoveSequence",
    "StepSequence",
    "parse_reference",
    "as_reference",
    "random_reference",
    "parse_random",
]

_SAMPLED = 5  # kind of a sampled signal in the packed layout (simulation._signals)


def _check(obj, name: str, unit: str, *, gt: float | None = None, ge: float | None = None) -> float:
    v = getattr(obj, name)
    try:
        v = float(v)
    except (TypeError, ValueError):
        raise ControlError(
            f"{type(obj).__name__}.{name} = {v!r} must be a number in {unit}"
        ) from None
    if not math.isfinite(v) or (gt is not None and not v > gt) or (ge is not None and not v >= ge):
        bound = f" > {gt:g}" if gt is not None else (f" >= {ge:g}" if ge is not None else "")
        raise ControlError(f"{type(obj).__name__}.{name} = {v:g} {unit} must be finite{bound}")
    object.__setattr__(obj, name, v)
    return v


@dataclass(frozen=True)
class MotionProfile(Signal):
    """Point-to-point move with limited velocity and acceleration (and jerk: S-curve).

    A trapezoidal velocity profile from ``start_position`` to ``end_position`` [m],
    starting at ``start_time`` [s], with |ẋ| ≤ ``max_velocity`` [m/s] and
    |ẍ| ≤ ``max_acceleration`` [m/s²] (triangular if the move is too short to reach
    the velocity). With ``jerk_time`` T_j > 0 [s] the position is the trapezoid's
    moving average over T_j: an S-curve whose acceleration ramps in T_j (jerk
    a_max/T_j) and which ends T_j later.
    """

    start_position: float = 0.05
    end_position: float = 0.15
    start_time: float = 0.0
    max_velocity: float = 0.1
    max_acceleration: float = 1.0
    jerk_time: float = 0.0
    _kind = _SAMPLED

    def __post_init__(self) -> None:
        _check(self, "start_position", "m")
        _check(self, "end_position", "m")
        _check(self, "start_time", "s", ge=0.0)
        _check(self, "max_velocity", "m/s", gt=0.0)
        _check(self, "max_acceleration", "m/s²", gt=0.0)
        _check(self, "jerk_time", "s", ge=0.0)

    # trapezoid: t_a acceleration time, t_c cruise time, v_p peak velocity
    def _phases(self) -> tuple[float, float, float, float]:
        d = abs(self.end_position - self.start_position)
        a, v = self.max_acceleration, self.max_velocity
        if d * a < v * v:  # triangular
            vp = math.sqrt(d * a)
            return vp / a, 0.0, vp, d
        return v / a, (d - v * v / a) / v, v, d

    @property
    def duration(self) -> float:
        """Time [s] from ``start_time`` to the end of the move."""
        ta, tc, _vp, _d = self._phases()
        return 2.0 * ta + tc + self.jerk_time

    def _trap(self, tau, order: int):
        """Trapezoid position (order 0), velocity (1), acceleration (2) or its time integral (-1) at τ = t − start."""
        ta, tc, vp, d = self._phases()
        a = vp / ta if ta > 0 else 0.0
        s = 1.0 if self.end_position >= self.start_position else -1.0
        x0 = self.start_position
        tau = np.asarray(tau, dtype=float)
        t1, t2, t3 = ta, ta + tc, 2.0 * ta + tc
        # position pieces and their antiderivatives (continuous, starting at 0 for τ <= 0)
        tq = np.clip(tau, 0.0, t1)
        tcr = np.clip(tau - t1, 0.0, tc)
        td = np.clip(tau - t2, 0.0, ta)
        if order == 2:
            acc = np.where(tau < t1, a, np.where(tau < t2, 0.0, -a))
            return s * np.where((tau < 0.0) | (tau >= t3), 0.0, acc)
        if order == 1:
            v = np.where(tau < t1, a * tq, np.where(tau < t2, vp, vp - a * td))
            v = np.where((tau <= 0.0) | (tau >= t3), 0.0, v)
            return s * v
        pos = 0.5 * a * tq**2 + vp * tcr + vp * td - 0.5 * a * td**2
        if order == 0:
            return x0 + s * pos
        # ∫_0^τ pos: piecewise cubic
        p1 = 0.5 * a * t1**2
        p2 = p1 + vp * tc
        i = a * tq**3 / 6.0
        i = i + p1 * tcr + 0.5 * vp * tcr**2
        i = i + p2 * td + 0.5 * vp * td**2 - a * td**3 / 6.0
        i = i + d * np.clip(tau - t3, 0.0, None)
        return x0 * tau + s * i

    def __call__(self, t):
        tau = np.asarray(t, dtype=float) - self.start_time
        tj = self.jerk_time
        if tj > 0.0:
            out = (self._trap(tau, -1) - self._trap(tau - tj, -1)) / tj
        else:
            out = self._trap(tau, 0)
        return out if np.ndim(t) else float(out)

    def rate(self, t):
        """Velocity [m/s] of the profile (analytic)."""
        tau = np.asarray(t, dtype=float) - self.start_time
        tj = self.jerk_time
        if tj > 0.0:
            out = (self._trap(tau, 0) - self._trap(tau - tj, 0)) / tj
        else:
            out = self._trap(tau, 1)
        return out if np.ndim(t) else float(out)

    def acceleration(self, t):
        """Acceleration [m/s²] of the profile (analytic; right-continuous at the corners)."""
        tau = np.asarray(t, dtype=float) - self.start_time
        tj = self.jerk_time
        if tj > 0.0:
            out = (self._trap(tau, 1) - self._trap(tau - tj, 1)) / tj
        else:
            out = self._trap(tau, 2)
        return out if np.ndim(t) else float(out)

    def pack(self):
        """As a sampled signal at 10 kHz over the move (for use as an open-loop input)."""
        t1 = self.start_time + self.duration
        n = max(3, int(math.ceil((t1 - self.start_time) * 1e4)) + 1)
        ts = np.linspace(self.start_time, t1, n)
        return _SAMPLED, np.zeros(8), ts, np.asarray(self(ts), dtype=float)

    def peak(self, duration: float) -> float:
        return max(abs(self.start_position), abs(self.end_position))


@dataclass(frozen=True)
class MoveSequence(Signal):
    """Point-to-point moves one after the other: each :class:`MotionProfile` starts where the last ended."""

    moves: tuple = ()
    _kind = _SAMPLED

    def __post_init__(self) -> None:
        moves = tuple(self.moves)
        if not moves or not all(isinstance(m, MotionProfile) for m in moves):
            raise ControlError("MoveSequence needs one or more MotionProfile moves")
        for a, b in zip(moves[:-1], moves[1:], strict=True):
            if b.start_time < a.start_time + a.duration - 1e-12:
                raise ControlError(
                    f"move at {b.start_time:g} s starts before the previous one ends "
                    f"({a.start_time + a.duration:g} s)"
                )
            if abs(b.start_position - a.end_position) > 1e-12:
                raise ControlError(
                    f"move at {b.start_time:g} s starts at {b.start_position:g} m, "
                    f"not where the previous one ended ({a.end_position:g} m)"
                )
        object.__setattr__(self, "moves", moves)

    def __call__(self, t):
        out = self.moves[0].start_position + sum(
            np.asarray(m(t)) - m.start_position for m in self.moves
        )
        return out if np.ndim(t) else float(out)

    def rate(self, t):
        """Velocity [m/s] (analytic)."""
        out = sum(np.asarray(m.rate(t)) for m in self.moves)
        return out if np.ndim(t) else float(out)

    def acceleration(self, t):
        """Acceleration [m/s²] (analytic)."""
        out = sum(np.asarray(m.acceleration(t)) for m in self.moves)
        return out if np.ndim(t) else float(out)

    def pack(self):
        last = self.moves[-1]
        t1 = last.start_time + last.duration
        ts = np.linspace(0.0, t1, max(3, int(math.ceil(t1 * 1e4)) + 1))
        return _SAMPLED, np.zeros(8), ts, np.asarray(self(ts), dtype=float)

    def peak(self, duration: float) -> float:
        return max(m.peak(duration) for m in self.moves)


@dataclass(frozen=True)
class StepSequence(Signal):
    """Piecewise-constant positions [m]: ``positions[i]`` from ``times[i]`` [s] on (``positions[0]`` before).

    With ``smoothing`` τ > 0 [s] every step passes through the critically damped
    second-order filter 1/(τs + 1)², so the reference carries a velocity and an
    acceleration for the feed-forward: a step Δ at t_i gives
    r = Δ(1 − (1 + θ)e^{−θ}), ṙ = Δ θ e^{−θ}/τ, r̈ = Δ(1 − θ)e^{−θ}/τ², θ = (t − t_i)/τ
    (peak velocity Δ/(eτ) at θ = 1; 99 % of the step after 6.6 τ). Default 0: plain steps,
    no feed-forward.
    """

    times: np.ndarray = field(default_factory=lambda: np.zeros(1))
    positions: np.ndarray = field(default_factory=lambda: np.zeros(1))
    smoothing: float = 0.0
    _kind = _SAMPLED

    def __post_init__(self) -> None:
        t = np.ascontiguousarray(self.times, dtype=float).ravel()
        x = np.ascontiguousarray(self.positions, dtype=float).ravel()
        if (
            t.size != x.size
            or t.size < 1
            or not np.all(np.isfinite(t))
            or not np.all(np.isfinite(x))
        ):
            raise ControlError("StepSequence needs equally many finite times [s] and positions [m]")
        if np.any(np.diff(t) <= 0):
            raise ControlError("StepSequence times must be strictly increasing")
        object.__setattr__(self, "times", t)
        object.__setattr__(self, "positions", x)
        _check(self, "smoothing", "s", ge=0.0)

    def _filtered(self, t, order: int):
        """Sum over the steps of the filtered step's position (0), velocity (1) or acceleration (2)."""
        tt = np.asarray(t, dtype=float)
        tau = self.smoothing
        out = np.full(np.shape(tt), self.positions[0] if order == 0 else 0.0)
        for k in range(1, self.times.size):
            d = self.positions[k] - self.positions[k - 1]
            th = np.clip((tt - self.times[k]) / tau, 0.0, None)
            ex = np.exp(-th)
            if order == 0:
                out = out + d * (1.0 - (1.0 + th) * ex)
            elif order == 1:
                out = out + d * th * ex / tau
            else:
                out = out + np.where(tt >= self.times[k], d * (1.0 - th) * ex / tau**2, 0.0)
        return out if np.ndim(t) else float(out)

    def __call__(self, t):
        if self.smoothing > 0.0:
            return self._filtered(t, 0)
        tt = np.asarray(t, dtype=float)
        i = np.clip(np.searchsorted(self.times, tt, side="right") - 1, 0, self.times.size - 1)
        out = self.positions[i]
        return out if np.ndim(t) else float(out)

    def rate(self, t):
        """Velocity [m/s]: zero for plain steps, the filter's with ``smoothing``."""
        if self.smoothing > 0.0:
            return self._filtered(t, 1)
        return np.zeros(np.shape(t)) if np.ndim(t) else 0.0

    def acceleration(self, t):
        """Acceleration [m/s²]: zero for plain steps, the filter's with ``smoothing``."""
        if self.smoothing > 0.0:
            return self._filtered(t, 2)
        return np.zeros(np.shape(t)) if np.ndim(t) else 0.0

    def pack(self):
        if self.smoothing > 0.0:
            t1 = self.times[-1] + 10.0 * self.smoothing
            grid = np.linspace(
                self.times[0], t1, max(3, int(math.ceil((t1 - self.times[0]) * 1e4)) + 1)
            )
            return _SAMPLED, np.zeros(8), grid, np.asarray(self(grid), dtype=float)
        ts = [self.times[0]]
        vs = [self.positions[0]]
        for k in range(1, self.times.size):
            d = 1e-9 * max(1.0, abs(self.times[k]))
            ts += [self.times[k] - d, self.times[k]]
            vs += [self.positions[k - 1], self.positions[k]]
        return _SAMPLED, np.zeros(8), np.array(ts), np.array(vs)

    def peak(self, duration: float) -> float:
        return float(np.max(np.abs(self.positions)))

    def __eq__(self, other):
        return (
            isinstance(other, StepSequence)
            and np.array_equal(self.times, other.times)
            and np.array_equal(self.positions, other.positions)
            and self.smoothing == other.smoothing
        )

    __hash__ = None  # type: ignore[assignment]


_PROFILE_KEYS = {
    "from": ("start_position", "m"),
    "to": ("end_position", "m"),
    "start": ("start_time", "s"),
    "v": ("max_velocity", "m/s"),
    "a": ("max_acceleration", "m/s^2"),
    "jerk_time": ("jerk_time", "s"),
}


def parse_reference(spec: str) -> Signal:
    """Reference position from a spec string.

    ``trapezoid:from=50 mm,to=150 mm,v=0.1,a=2,start=0.1`` and
    ``scurve:...,jerk_time=20 ms`` (:class:`MotionProfile`);
    ``steps:0 s=50 mm,0.5 s=150 mm,1 s=50 mm`` (:class:`StepSequence`; ``,smooth=20 ms``
    passes the steps through the critically damped filter of time constant 20 ms, giving
    the feed-forward a velocity and an acceleration);
    ``random:rms=2 mm,f0=1,f1=10,duration=2,offset=0.1,seed=1`` (:func:`random_reference`);
    ``file:PATH`` or ``file:PATH#channel`` (a measured or planned run, channel ``x``
    by default, linearly interpolated); any signal spec of
    :func:`~hydropwa.simulation.parse_signal` in metres (``"step:time=0.1,before=50 mm,after=60 mm"``,
    ``"sine:amplitude=20 mm,frequency=1,offset=0.1"``) or a bare position.
    """
    text = spec.strip()
    kind, _, rest = text.partition(":")
    kind = kind.strip().lower()
    try:
        if kind in ("trapezoid", "scurve"):
            kw: dict[str, float] = {}
            for item in (p for p in rest.split(",") if p.strip()):
                key, eq, val = item.partition("=")
                key = key.strip()
                if not eq or key not in _PROFILE_KEYS:
                    raise ControlError(
                        f"reference: {item.strip()!r} in {spec!r}; give key=value with key one of {', '.join(_PROFILE_KEYS)}"
                    )
                name, unit = _PROFILE_KEYS[key]
                kw[name] = parse_quantity(val.strip(), unit, f"reference {key}")
            if kind == "scurve" and "jerk_time" not in kw:
                raise ControlError(
                    "reference: an scurve needs jerk_time=... (e.g. jerk_time=20 ms)"
                )
            return MotionProfile(**kw)
        if kind == "steps":
            times, pos = [], []
            smooth = 0.0
            for item in (p for p in rest.split(",") if p.strip()):
                key, eq, val = item.partition("=")
                if key.strip() == "smooth" and eq:
                    smooth = parse_quantity(val.strip(), "s", "reference smooth")
                    continue
                if not eq:
                    raise ControlError(
                        f"reference: {item.strip()!r} in {spec!r} must read 'time=position'"
                    )
                times.append(parse_quantity(key.strip(), "s", "reference step time"))
                pos.append(parse_quantity(val.strip(), "m", "reference step position"))
            return StepSequence(np.array(times), np.array(pos), smoothing=smooth)
        if kind == "random":
            return parse_random(text, "m", "reference")
        if kind == "file":
            path, _, channel = rest.partition("#")
            return _from_file(Path(path.strip()), channel.strip() or "x")
        return as_signal(text, "m", "reference")
    except ControlError:
        raise
    except HydropwaError as exc:
        raise ControlError(str(exc)) from None


def random_reference(
    rms: float,
    f0: float,
    f1: float,
    duration: float,
    offset: float = 0.0,
    seed: int = 0,
    sample_time: float = 2e-4,
) -> Sampled:
    """A band-limited random reference: offset + a multisine of RMS ``rms`` from f0 to f1 (Hz).

    Every harmonic of 1/``duration`` in the band gets the same amplitude and a phase drawn
    uniformly from ``numpy.random.default_rng(seed)``; the sum is scaled to the exact RMS over
    one period [0, ``duration``) and sampled every ``sample_time`` [s] (linearly interpolated,
    held after ``duration``). It is periodic in ``duration``, so its spectrum is flat in the band
    and zero outside (no leakage over a whole period); the value at t = 0 is offset + the sum's,
    not offset. Same seed, same signal.
    """
    if not (0.0 <= f0 < f1) or not duration > 0 or not rms > 0:
        raise ControlError(
            f"random reference: need 0 <= f0 < f1, duration > 0 and rms > 0 "
            f"(got f0={f0:g}, f1={f1:g}, duration={duration:g}, rms={rms:g})"
        )
    df = 1.0 / duration
    k = np.arange(max(1, math.ceil(f0 / df - 1e-9)), math.floor(f1 / df + 1e-9) + 1)
    if k.size == 0:
        raise ControlError(
            f"random reference: no harmonic of 1/duration = {df:g} Hz lies in [{f0:g}, {f1:g}] Hz; "
            "give a longer duration or a wider band"
        )
    phase = np.random.default_rng(int(seed)).uniform(0.0, 2.0 * np.pi, k.size)
    n = max(2, math.ceil(duration / sample_time))
    t = np.arange(n + 1) * (duration / n)
    s = np.sin(2.0 * np.pi * df * np.outer(t, k) + phase).sum(axis=1)
    s *= rms / np.sqrt(np.mean(s[:-1] ** 2))
    return Sampled(t, offset + s)


_RANDOM_KEYS = {"rms": None, "f0": "Hz", "f1": "Hz", "duration": "s", "offset": None, "seed": ""}


def parse_random(spec: str, unit: str = "m", name: str = "reference") -> Sampled:
    """``random:rms=...,f0=...,f1=...,duration=...[,offset=...][,seed=...]`` (rms and offset in
    ``unit``) as :func:`random_reference`."""
    kw: dict[str, float] = {}
    for item in (p for p in spec.partition(":")[2].split(",") if p.strip()):
        key, eq, val = item.partition("=")
        key = key.strip()
        if not eq or key not in _RANDOM_KEYS:
            raise ControlError(
                f"{name}: {item.strip()!r} in {spec!r}; give key=value with key one of {', '.join(_RANDOM_KEYS)}"
            )
        kw[key] = parse_quantity(val.strip(), _RANDOM_KEYS[key] or unit, f"{name} {key}")
    missing = [k for k in ("rms", "f0", "f1", "duration") if k not in kw]
    if missing:
        raise ControlError(
            f"{name}: a random reference needs {', '.join(missing)} "
            "(e.g. 'random:rms=1 kN,f0=1,f1=10,duration=2,offset=5 kN,seed=1')"
        )
    if "seed" in kw and kw["seed"] != int(kw["seed"]):
        raise ControlError(f"{name}: seed must be a whole number (got {kw['seed']:g})")
    return random_reference(
        kw["rms"], kw["f0"], kw["f1"], kw["duration"], kw.get("offset", 0.0), int(kw.get("seed", 0))
    )


def _from_file(path: Path, channel: str) -> Sampled:
    if not path.is_file():
        raise ControlError(f"reference file {path} does not exist")
    run = read_run(path, validate=False)
    if not run.has(channel):
        raise ControlError(
            f"reference file {path} has no channel {channel!r}; write file:PATH#channel"
        )
    unit = run.units.get(channel, "m")
    if unit not in ("m", ""):
        raise ControlError(
            f"reference channel {channel!r} of {path} is in {unit}, not a position in m"
        )
    return Sampled(run.t, run[channel])


def as_reference(value) -> Signal:
    """A reference from a Signal, a number [m], a spec string or (t, positions) samples."""
    if isinstance(value, str):
        return parse_reference(value)
    try:
        return as_signal(value, "m", "reference")
    except SignalError as exc:
        raise ControlError(str(exc)) from None
