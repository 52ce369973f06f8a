"""Input signals: constant, step, ramp, sine, chirp and sampled (measured) data.

A signal is a frozen object that evaluates in Python (``sig(t)``) and packs
into plain arrays that the compiled solver evaluates without calling Python
(:func:`eval_signal`). ``parse_signal`` reads the CLI spec language, e.g.
``"sine:amplitude=0.4,frequency=1"`` or ``"constant:95 bar"``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field, fields
from functools import lru_cache

import numpy as np
from numba import njit

from .. import _jitcache  # noqa: F401  (one cache stamp for all compiled modules)
from .._errors import ParameterError, SignalError
from .._layout import N_SIGNALS, SG, SG_DATA, SG_PARAMS, SIGNAL_PARAMS
from ..params import parse_quantity

__all__ = [
    "Signal",
    "Constant",
    "Step",
    "Ramp",
    "Sine",
    "Chirp",
    "Sampled",
    "as_signal",
    "parse_signal",
    "eval_signal",
    "eval_signal_rate",
    "pack_signals",
    "check_supply_signal",
]

#: numba options for allocation-free helpers that only touch arrays their caller owns: no
#: reference counting (numba's private ``_nrt`` option; dropped if this numba lacks it).
try:
    from numba.core.options import DefaultOptions

    NO_REFCOUNT: dict = {"_nrt": False} if hasattr(DefaultOptions, "_nrt") else {}
except ImportError:  # pragma: no cover - older/newer numba layouts
    NO_REFCOUNT = {}

_CONSTANT, _STEP, _RAMP, _SINE, _CHIRP, _SAMPLED = 0, 1, 2, 3, 4, 5
_TWO_PI = 2.0 * math.pi


# Layout of a packed signal vector ``sg``, declared in hydropwa._layout (SG, SG_PARAMS, SG_DATA):
# one float64 array for all input signals, so the solver's inner loop reads a single array
# (separate arrays cost ~30 ns per call in reference counting): per signal i its kind, the
# first index and count of its samples, SIGNAL_PARAMS parameters from SG_PARAMS; a sampled
# signal's times are sg[lo : lo + n] and its values sg[lo + n : lo + 2 n].
_PAR = SG_PARAMS
_DATA = SG_DATA
_SG_KIND, _SG_FIRST, _SG_COUNT = SG["kind"], SG["first"], SG["count"]


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def eval_signal(sg, i: int, t: float) -> float:
    """Value of packed signal ``i`` of ``sg`` at time ``t`` [s] (compiled; see :func:`pack_signals`)."""
    kind = sg[_SG_KIND + i]
    r = _PAR + SIGNAL_PARAMS * i
    if kind == _CONSTANT:
        return sg[r]
    if kind == _SINE:
        off, start = sg[r + 2], sg[r + 4]
        if t < start:
            return off
        return off + sg[r] * math.sin(_TWO_PI * sg[r + 1] * (t - start) + sg[r + 3])
    if kind == _STEP:
        return sg[r + 2] if t >= sg[r] else sg[r + 1]
    if kind == _RAMP:
        t0, t1, v0, v1 = sg[r], sg[r + 1], sg[r + 2], sg[r + 3]
        if t <= t0:
            return v0
        if t >= t1:
            return v1
        return v0 + (v1 - v0) * (t - t0) / (t1 - t0)
    if kind == _CHIRP:
        amp, f0, f1, dur, off, start = sg[r], sg[r + 1], sg[r + 2], sg[r + 3], sg[r + 4], sg[r + 5]
        tau = t - start
        if tau < 0.0 or tau > dur:
            return off
        return off + amp * math.sin(_TWO_PI * (f0 * tau + 0.5 * (f1 - f0) * tau * tau / dur))
    # sampled: linear interpolation (binary search), held at the ends
    lo = int(sg[_SG_FIRST + i])
    n = int(sg[_SG_COUNT + i])
    if t <= sg[lo]:
        return sg[lo + n]
    if t >= sg[lo + n - 1]:
        return sg[lo + 2 * n - 1]
    a = _sample_interval(sg, lo, n, t)
    w = (t - sg[a]) / (sg[a + 1] - sg[a])
    return sg[a + n] + w * (sg[a + 1 + n] - sg[a + n])


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def _sample_interval(sg, lo, n, t):
    """Index a of the sample interval sg[a] ≤ t < sg[a + 1] (binary search); needs sg[lo] ≤ t < sg[lo + n − 1]."""
    a, b = lo, lo + n - 1
    while b - a > 1:
        m = (a + b) >> 1
        if sg[m] <= t:
            a = m
        else:
            b = m
    return a


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def eval_signal_rate(sg, i: int, t: float) -> float:
    """Time derivative of packed signal ``i`` at ``t`` [unit/s] (compiled; see :func:`eval_signal`).

    The right derivative, as the solver steps forward: a ramp's slope on [t0, t1), a
    sampled signal's slope on the interval [t_k, t_k+1) holding t (0 before the first
    and from the last sample on), 0 for constants and steps (the jump itself is not a
    rate), the analytic derivative of a sine or chirp inside its active span.
    """
    kind = sg[_SG_KIND + i]
    r = _PAR + SIGNAL_PARAMS * i
    if kind == _CONSTANT or kind == _STEP:
        return 0.0
    if kind == _SINE:
        if t < sg[r + 4]:
            return 0.0
        w = _TWO_PI * sg[r + 1]
        return sg[r] * w * math.cos(w * (t - sg[r + 4]) + sg[r + 3])
    if kind == _RAMP:
        t0, t1 = sg[r], sg[r + 1]
        return (sg[r + 3] - sg[r + 2]) / (t1 - t0) if t0 <= t < t1 else 0.0
    if kind == _CHIRP:
        amp, f0, f1, dur, start = sg[r], sg[r + 1], sg[r + 2], sg[r + 3], sg[r + 5]
        tau = t - start
        if tau < 0.0 or tau >= dur:
            return 0.0
        th = _TWO_PI * (f0 * tau + 0.5 * (f1 - f0) * tau * tau / dur)
        return amp * math.cos(th) * _TWO_PI * (f0 + (f1 - f0) * tau / dur)
    lo = int(sg[_SG_FIRST + i])
    n = int(sg[_SG_COUNT + i])
    if t < sg[lo] or t >= sg[lo + n - 1]:
        return 0.0
    a = _sample_interval(sg, lo, n, t)
    return (sg[a + 1 + n] - sg[a + n]) / (sg[a + 1] - sg[a])


@njit(cache=True, nogil=True, error_model="numpy")
def eval_packed(sg, i, t):
    """Packed signal ``i`` of ``sg`` at every time of the array ``t`` [s]."""
    out = np.empty(t.shape[0])
    for k in range(t.shape[0]):
        out[k] = eval_signal(sg, i, t[k])
    return out


def pack_signals(signals) -> np.ndarray:
    """Pack up to three signals (u, P_S, F_L in the solver) into one float64 vector for :func:`eval_signal`."""
    signals = list(signals)
    if len(signals) > N_SIGNALS:
        raise SignalError(f"at most {N_SIGNALS} signals can be packed, got {len(signals)}")
    data = []
    head = np.zeros(_DATA)
    pos = _DATA
    for i, sig in enumerate(signals):
        kind, par, ts, vs = sig.pack()
        head[_SG_KIND + i] = kind
        head[_PAR + SIGNAL_PARAMS * i : _PAR + SIGNAL_PARAMS * (i + 1)] = par
        if kind == _SAMPLED:
            head[_SG_FIRST + i] = pos
            head[_SG_COUNT + i] = ts.size
            data += [ts, vs]
            pos += 2 * ts.size
    return np.ascontiguousarray(np.concatenate([head, *data]) if data else head)


_EMPTY = np.zeros(1)


@dataclass(frozen=True)
class Signal:
    """Base class of input signals (values in SI, or fractions for the valve command)."""

    _kind = -1

    def _par(self) -> list[float]:
        return [float(getattr(self, f.name)) for f in fields(self)]

    def pack(self) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
        """Return ``(kind, par[8], ts, vs)``, the pieces :func:`pack_signals` assembles."""
        par = np.zeros(8)
        vals = self._par()
        par[: len(vals)] = vals
        return self._kind, par, _EMPTY, _EMPTY

    def __call__(self, t):
        arr = np.atleast_1d(np.asarray(t, dtype=float))
        out = eval_packed(pack_signals([self]), 0, arr)
        return out if np.ndim(t) else float(out[0])

    def peak(self, duration: float) -> float:
        """Largest |value| over [0, duration] (used for the ω0 amplitude schedule)."""
        tt = np.linspace(0.0, max(duration, 1e-9), 4001)
        return float(np.max(np.abs(self(tt))))

    def describe(self) -> dict:
        """Plain-dict description (kind and parameters) for metadata."""
        d = {"kind": type(self).__name__.lower()}
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, np.ndarray):
                d[f.name] = f"array[{v.size}]"
            else:
                d[f.name] = v
        return d

    def _validate_finite(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, float | int) and not math.isfinite(v):
                raise SignalError(f"{type(self).__name__}.{f.name} = {v} is not finite")


@dataclass(frozen=True)
class Constant(Signal):
    """Constant value."""

    value: float = 0.0
    _kind = _CONSTANT

    def __post_init__(self):
        self._validate_finite()

    def peak(self, duration: float) -> float:
        return abs(self.value)

    def __call__(self, t):
        return np.full(np.shape(t), float(self.value)) if np.ndim(t) else float(self.value)


@dataclass(frozen=True)
class Step(Signal):
    """Step from ``before`` to ``after`` at ``time`` [s]."""

    time: float = 0.0
    before: float = 0.0
    after: float = 1.0
    _kind = _STEP

    def __post_init__(self):
        self._validate_finite()


@dataclass(frozen=True)
class Ramp(Signal):
    """Linear ramp from ``v0`` at ``t0`` [s] to ``v1`` at ``t1`` [s], held outside."""

    t0: float = 0.0
    t1: float = 1.0
    v0: float = 0.0
    v1: float = 1.0
    _kind = _RAMP

    def __post_init__(self):
        self._validate_finite()
        if not self.t1 > self.t0:
            raise SignalError(f"ramp needs t1 > t0, got t0={self.t0}, t1={self.t1}")


@dataclass(frozen=True)
class Sine(Signal):
    """offset + amplitude·sin(2π·frequency·(t − start) + phase) for t ≥ start [s]; offset before."""

    amplitude: float = 1.0
    frequency: float = 1.0
    offset: float = 0.0
    phase: float = 0.0
    start: float = 0.0
    _kind = _SINE

    def __post_init__(self):
        self._validate_finite()
        if self.frequency < 0:
            raise SignalError(f"sine frequency {self.frequency} Hz must be >= 0")

    def peak(self, duration: float) -> float:
        return abs(self.offset) + abs(self.amplitude)


@dataclass(frozen=True)
class Chirp(Signal):
    """Linear chirp from f0 to f1 [Hz] over ``duration`` [s] starting at ``start`` [s]."""

    amplitude: float = 1.0
    f0: float = 1.0
    f1: float = 10.0
    duration: float = 1.0
    offset: float = 0.0
    start: float = 0.0
    _kind = _CHIRP

    def __post_init__(self):
        self._validate_finite()
        if self.duration <= 0 or self.f0 < 0 or self.f1 < 0:
            raise SignalError("chirp needs duration > 0 s and frequencies f0, f1 >= 0 Hz")

    def peak(self, duration: float) -> float:
        return abs(self.offset) + abs(self.amplitude)


@dataclass(frozen=True)
class Sampled(Signal):
    """Measured samples (t [s], values), linearly interpolated, held at the ends."""

    t: np.ndarray = field(default_factory=lambda: np.zeros(2))
    values: np.ndarray = field(default_factory=lambda: np.zeros(2))
    _kind = _SAMPLED

    def __post_init__(self):
        t = np.ascontiguousarray(self.t, dtype=float).ravel()
        v = np.ascontiguousarray(self.values, dtype=float).ravel()
        if t.size != v.size or t.size < 1:
            raise SignalError(
                f"sampled signal needs equal, non-empty t and values (got {t.size} and {v.size})"
            )
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            raise SignalError(
                f"sampled signal has a non-finite value at sample {bad[0]} (t = {t[bad[0]]:g} s); "
                "repair the data (interpolate the gap) before simulating"
            )
        if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            i = int(np.flatnonzero(~(np.diff(t) > 0))[0]) + 1 if t.size > 1 else 0
            raise SignalError(
                f"sampled signal times must be finite and strictly increasing (sample {i})"
            )
        if t.size == 1:
            t = np.array([t[0], t[0] + 1.0])
            v = np.array([v[0], v[0]])
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "values", v)

    def pack(self):
        return self._kind, np.zeros(8), self.t, self.values

    def peak(self, duration: float) -> float:
        m = self.t <= self.t[0] + duration
        return float(np.max(np.abs(self.values[m]))) if np.any(m) else float(abs(self.values[0]))

    def __eq__(self, other):
        return (
            isinstance(other, Sampled)
            and np.array_equal(self.t, other.t)
            and np.array_equal(self.values, other.values)
        )

    __hash__ = None  # type: ignore[assignment]


def as_signal(value, unit: str = "", name: str = "signal") -> Signal:
    """Turn a number, a spec string, a (t, values) pair or a Signal into a Signal."""
    if isinstance(value, Signal):
        return value
    if isinstance(value, bool):
        raise SignalError(f"{name}: {value!r} is not a signal")
    if isinstance(value, int | float | np.floating | np.integer):
        return Constant(float(value))
    if isinstance(value, str):
        return _parse_cached(value, unit, name)
    if isinstance(value, tuple) and len(value) == 2:
        return Sampled(np.asarray(value[0]), np.asarray(value[1]))
    raise SignalError(
        f"{name}: cannot use {type(value).__name__} as a signal; give a number, a spec such as "
        "'sine:amplitude=0.4,frequency=1', a (t, values) pair or a Signal"
    )


_KINDS: dict[str, type[Signal]] = {
    "constant": Constant,
    "step": Step,
    "ramp": Ramp,
    "sine": Sine,
    "chirp": Chirp,
}
_FIRST = {
    "constant": "value",
    "step": "after",
    "ramp": "v1",
    "sine": "amplitude",
    "chirp": "amplitude",
}
#: Parameters that carry the signal's own unit; the rest are times/frequencies/angles.
_VALUED = {"value", "before", "after", "v0", "v1", "amplitude", "offset"}
_TIMED = {
    "time": "s",
    "t0": "s",
    "t1": "s",
    "start": "s",
    "duration": "s",
    "frequency": "Hz",
    "f0": "Hz",
    "f1": "Hz",
    "phase": "rad",
}


#: A bare number (no unit) for a signal of this unit is ambiguous beyond these magnitudes:
#: (largest plausible SI magnitude or None, smallest plausible nonzero SI magnitude or None,
#: the unit a user most likely meant).
_BARE_LIMITS: dict[str, tuple[float | None, float | None, str]] = {
    "": (1.5, None, "%"),
    "Pa": (None, 1e4, "bar"),
}


def _bare_checked(value: float, text: str, unit: str, where: str) -> float:
    """Reject a unitless number whose size says it was written in another unit.

    ``sine:amplitude=40`` reads as 40 (4000 % of full opening) and ``constant:95`` for a
    pressure as 95 Pa; both are almost certainly 40 % and 95 bar. A number with an
    explicit unit (``"40 %"``, ``"95 bar"``, ``"95 Pa"``) is taken as written.
    """
    try:
        float(text)
    except ValueError:
        return value  # it carries a unit
    hi, lo, hint = _BARE_LIMITS.get(unit, (None, None, ""))
    if hi is not None and abs(value) > hi:
        raise SignalError(
            f"{where} = {text} is {100 * value:g} % of full opening; write '{text} %' for percent "
            f"or a fraction such as {value / 100:g} (1 = fully open)"
        )
    if lo is not None and value != 0 and abs(value) < lo:
        raise SignalError(
            f"{where} = {text} reads as {text} Pa; did you mean '{text} {hint}'? "
            f"(write the unit, or give SI Pa such as {value * 1e5:g})"
        )
    return value


@lru_cache(maxsize=256)
def _parse_cached(spec: str, unit: str, name: str) -> Signal:
    """:func:`parse_signal`, remembered: specs parse to frozen signals, so repeats share one."""
    return parse_signal(spec, unit, name)


def parse_signal(spec: str, unit: str = "", name: str = "signal") -> Signal:
    """Parse a signal spec ``kind:key=value,...`` (values may carry units).

    Parameters
    ----------
    spec : str
        E.g. ``"sine:amplitude=0.4,frequency=1"``, ``"step:time=0.1,after=40 %"``,
        ``"constant:95 bar"``, ``"chirp:amplitude=0.1,f0=2,f1=100,duration=5"``,
        or a bare number ``"0.2"``.
    unit : str
        SI unit of the signal's values as a pint expression (``""`` for the valve
        command fraction, ``"Pa"`` for pressure, ``"N"`` for force).
    name : str
        Name used in error messages (e.g. ``"--input"``).
    """
    text = spec.strip()
    if ":" not in text:
        try:
            return Constant(_bare_checked(parse_quantity(text, unit, name), text, unit, name))
        except SignalError:
            raise
        except Exception as exc:
            if "wrong dimension" in str(exc):
                raise SignalError(str(exc)) from None
            raise SignalError(
                f"{name}: cannot read {spec!r}; write kind:key=value,... with kind one of "
                f"{', '.join(_KINDS)} (e.g. 'sine:amplitude=0.4,frequency=1')"
            ) from None
    kind, _, rest = text.partition(":")
    kind = kind.strip().lower()
    if kind not in _KINDS:
        raise SignalError(
            f"{name}: unknown signal kind {kind!r}; choose one of {', '.join(_KINDS)}"
        )
    cls = _KINDS[kind]
    allowed = [f.name for f in fields(cls)]
    kwargs: dict[str, float] = {}
    for i, item in enumerate(p for p in rest.split(",") if p.strip()):
        if "=" in item:
            key, _, val = item.partition("=")
            key = key.strip()
        elif i == 0:
            key, val = _FIRST[kind], item
        else:
            raise SignalError(f"{name}: {item.strip()!r} in {spec!r} needs the form key=value")
        if key not in allowed:
            raise SignalError(
                f"{name}: {kind} has no parameter {key!r}; known: {', '.join(allowed)}"
            )
        if key in kwargs:
            raise SignalError(f"{name}: {key!r} is given twice in {spec!r}; give it once")
        target = unit if key in _VALUED else _TIMED.get(key, "")
        try:
            value = parse_quantity(val.strip(), target, f"{name} {key}")
            if key in _VALUED:
                value = _bare_checked(value, val.strip(), unit, f"{name} {key}")
            kwargs[key] = value
        except SignalError:
            raise
        except Exception as exc:
            raise SignalError(f"{name}: {exc}") from None
    try:
        return cls(**kwargs)
    except SignalError as exc:
        raise SignalError(f"{name}: {exc}") from None


def check_supply_signal(sig: Signal, supply, duration: float, where: str = "supply_pressure"):
    """P_S (a signal over ``[0, duration]``) within the bounds of ``Supply.pressure``.

    The bounds a parameter file gets (above the tank pressure, at most 1e9 Pa), so that
    ``simulate(..., supply_pressure=0)`` or ``1e14`` is one error, not a silent run. A
    constant is checked once, other signals at 4001 points.

    Raises
    ------
    ParameterError
        Naming ``where``, the value and the bound.
    """
    if isinstance(sig, Constant):
        vals = np.array([float(sig(0.0))])
    else:
        vals = np.asarray(sig(np.linspace(0.0, float(duration), 4001)), dtype=float)
    if not np.all(np.isfinite(vals)):
        raise ParameterError(f"{where}: P_S is not finite everywhere; give a finite pressure")
    for v in (float(vals.min()), float(vals.max())):
        try:
            dataclasses.replace(supply, pressure=v)
        except ParameterError as exc:
            raise ParameterError(f"{where}: {exc}") from None
