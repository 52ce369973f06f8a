"""Campaign definitions: the paper's experiments as data (TOML → frozen dataclasses).

A campaign file has a ``[campaign]`` table and one table per experiment
(``[frf]``, ``[deadzone]``, ``[friction]``, ``[sine]``); see ``campaigns/paper.toml``
and ``docs/architecture_rig.md``. Numbers are SI (fractions for valve openings and
stroke positions); strings with units (``"10 %"``, ``"2 Hz"``, ``"1.5 kN"``) are
converted here, at the boundary.
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from .._channels import CHANNEL, channels_of
from .._errors import ParameterError
from .._io import read_text
from ..params import parse_quantity
from ._faults import Fault, parse_faults

__all__ = [
    "EXPERIMENTS",
    "BroadbandSweep",
    "Campaign",
    "DeadZoneExperiment",
    "Experiment",
    "FrfExperiment",
    "FrfSweep",
    "FrictionExperiment",
    "LoadRuns",
    "SineExperiment",
    "builtin_campaigns",
    "load_campaign",
    "parse_campaign",
]

#: Experiment names, in the order a campaign runs them.
EXPERIMENTS = ("frf", "deadzone", "friction", "sine")
_DIRECTIONS = {"extend": 1, "retract": -1}


# --------------------------------------------------------------------- readers
class _Table:
    """A TOML table with typed getters whose errors name the full key."""

    def __init__(self, data: Any, where: str) -> None:
        if not isinstance(data, Mapping):
            raise ParameterError(f"{where} must be a table, got {type(data).__name__}")
        self.data = dict(data)
        self.where = where
        self.used: set[str] = set()

    def key(self, k: str) -> str:
        return f"{self.where}.{k}"

    def raw(self, k: str, default: Any = ...) -> Any:
        self.used.add(k)
        if k not in self.data:
            if default is ...:
                raise ParameterError(f"{self.key(k)} is missing")
            return default
        return self.data[k]

    def quantity(
        self, k: str, unit: str, default: Any = ..., *, gt=None, ge=None, le=None
    ) -> float:
        v = self.raw(k, default)
        return _check(parse_quantity(v, unit, self.key(k)), self.key(k), unit, gt, ge, le)

    def integer(self, k: str, default: Any = ..., *, ge: int = 0) -> int:
        v = self.raw(k, default)
        if isinstance(v, bool) or not isinstance(v, int) or v < ge:
            raise ParameterError(f"{self.key(k)} = {v!r} must be an integer >= {ge}")
        return v

    def text(self, k: str, default: Any = ...) -> str:
        v = self.raw(k, default)
        if not isinstance(v, str):
            raise ParameterError(f"{self.key(k)} = {v!r} must be a string")
        return v

    def values(
        self, k: str, unit: str, default: Any = ..., *, gt=None, ge=None, le=None
    ) -> tuple[float, ...]:
        """A list of quantities, or a range table ``{start, stop, step}`` (stop included)."""
        v = self.raw(k, default)
        where = self.key(k)
        if isinstance(v, Mapping):
            rng = _Table(v, where)
            start = rng.quantity("start", unit)
            stop = rng.quantity("stop", unit)
            step = rng.quantity("step", unit, gt=0.0)
            rng.finish()
            n = math.floor((stop - start) / step + 1e-9) + 1
            if n < 1:
                raise ParameterError(f"{where}: stop {stop:g} lies below start {start:g}")
            vals = [round(start + i * step, 12) for i in range(n)]
        elif isinstance(v, list):
            vals = [parse_quantity(x, unit, f"{where}[{i}]") for i, x in enumerate(v)]
        else:
            raise ParameterError(f"{where} = {v!r} must be a list or a table {{start, stop, step}}")
        if not vals:
            raise ParameterError(f"{where} is empty")
        return tuple(_check(x, f"{where}[{i}]", unit, gt, ge, le) for i, x in enumerate(vals))

    def directions(self, k: str) -> tuple[int, ...]:
        v = self.raw(k, ["extend", "retract"])
        if (
            not isinstance(v, list)
            or not v
            or any(d not in _DIRECTIONS for d in v)
            or len(set(v)) != len(v)
        ):
            raise ParameterError(
                f"{self.key(k)} = {v!r} must list 'extend' and/or 'retract' once each"
            )
        return tuple(_DIRECTIONS[d] for d in v)

    def finish(self) -> None:
        extra = sorted(set(self.data) - self.used)
        if extra:
            raise ParameterError(f"{self.where}: unknown key(s) {', '.join(extra)}")


def _check(x: float, where: str, unit: str, gt=None, ge=None, le=None) -> float:
    u = f" {unit}" if unit else ""
    if not math.isfinite(x):
        raise ParameterError(f"{where} = {x!r} must be finite")
    if gt is not None and not x > gt:
        raise ParameterError(f"{where} = {x:g}{u} must be > {gt:g}{u}")
    if ge is not None and not x >= ge:
        raise ParameterError(f"{where} = {x:g}{u} must be >= {ge:g}{u}")
    if le is not None and not x <= le:
        raise ParameterError(f"{where} = {x:g}{u} must be <= {le:g}{u}")
    return x


# --------------------------------------------------------------------- experiments
@dataclass(frozen=True)
class FrfSweep:
    """Stepped sines at one valve opening.

    Attributes
    ----------
    opening : float
        Sine amplitude [1] (fraction of full opening, 0.1 = 10 %).
    frequencies : tuple of float
        Sine frequencies [Hz].
    """

    opening: float
    frequencies: tuple[float, ...]


@dataclass(frozen=True)
class BroadbandSweep:
    """One broadband valve run (chirp or multisine) at one opening, for an H1 estimate.

    Attributes
    ----------
    opening : float
        Peak command [1] (fraction of full opening).
    f0, f1 : float
        Excited band [Hz]; the identification fits only inside it.
    duration : float
        Length of the excitation [s].
    signal : str
        ``"chirp"`` (linear sweep f0 → f1) or ``"multisine"`` (Schroeder-phased sines on a
        1/``period`` grid in the band, repeated).
    period : float
        Period of the multisine [s] (its frequency resolution is 1/period).
    """

    opening: float
    f0: float
    f1: float
    duration: float = 4.0
    signal: str = "chirp"
    period: float = 0.5


@dataclass(frozen=True)
class FrfExperiment:
    """Valve FRF by stepped sines, Sec. VI-A: spool position measured.

    Attributes
    ----------
    sweeps : tuple of FrfSweep
        One per opening (10, 25, 90 % in the paper).
    settle : float
        Time before the evaluated periods [s].
    periods : int
        Periods evaluated by the sine fit (4 in the paper).
    margin_periods : int
        Extra periods recorded after them.
    start_position : float
        Initial rod position [1] (fraction of the stroke).
    broadband : tuple of BroadbandSweep
        Broadband runs (``[[frf.broadband]]``), H1-estimated over their band.
    """

    name = "frf"
    sweeps: tuple[FrfSweep, ...]
    settle: float = 0.05
    periods: int = 4
    margin_periods: int = 2
    start_position: float = 0.5
    broadband: tuple[BroadbandSweep, ...] = ()


@dataclass(frozen=True)
class DeadZoneExperiment:
    """Constant inputs around the dead band, Sec. VI-B (start retracted for u > 0, extended for u < 0).

    Attributes
    ----------
    inputs : tuple of float
        Input magnitudes [1] (1 % to 20 % in 0.5 % steps in the paper).
    directions : tuple of int
        +1 (extend from fully retracted) and/or −1 (retract from fully extended).
    duration : float
        Longest run [s]; long enough to see the creep inside the band.
    stop_at : float
        A run ends when the rod has travelled this fraction of the stroke [1], before the end stop.
    min_duration : float
        A run lasts at least this long [s] even if the stroke is used sooner.
    """

    name = "deadzone"
    inputs: tuple[float, ...]
    directions: tuple[int, ...] = (1, -1)
    duration: float = 4.0
    stop_at: float = 0.9
    min_duration: float = 0.2


@dataclass(frozen=True)
class FrictionExperiment:
    """Constant inputs against a counter force of the second cylinder, Sec. VI-C.

    Attributes
    ----------
    inputs : tuple of float
        Input magnitudes [1] (5 % to 50 % in 1 % steps in the paper).
    directions : tuple of int
        +1 and/or −1 (as for the dead-zone runs).
    counter_force : float
        Force opposing the motion [N] once ramped up.
    force_ramp : float
        Duration of the smooth (raised-cosine) ramp-up of the counter force [s].
    valve_delay : float
        Time at which the valve opens [s] (after the ramp).
    ripple : float
        Amplitude of the force-control ripple [1] (fraction of ``counter_force``).
    ripple_frequency : float
        Frequency of the ripple [Hz].
    force_noise : float
        Standard deviation of the force-control noise [N].
    force_rate : float
        Rate at which the counter-force signal is sampled [Hz] (noise bandwidth fs/2).
    counter_damping : float
        Viscous damping [N·s/m] of the coupled, pressure-controlled counter cylinder: its
        displaced oil passes its own control valve, so it loads the rod with c·ẋ on top of
        the set force (``Load.damping``). The force sensor sits between the rods and
        measures both, so Eq. (10) still isolates the friction. It also stops the
        stick-slip that the Stribeck curve's negative slope causes below ~45 mm/s
        against a nearly closed valve (measured: none down to 10 mm/s from 5e3 N·s/m).
    duration, stop_at, min_duration : float
        As in :class:`DeadZoneExperiment` [s], [1], [s] (``min_duration`` counted from ``valve_delay``).
    """

    name = "friction"
    inputs: tuple[float, ...]
    directions: tuple[int, ...] = (1, -1)
    counter_force: float = 1500.0
    force_ramp: float = 0.3
    valve_delay: float = 0.4
    ripple: float = 0.01
    ripple_frequency: float = 7.0
    force_noise: float = 5.0
    force_rate: float = 500.0
    counter_damping: float = 1.0e4
    duration: float = 4.0
    stop_at: float = 0.9
    min_duration: float = 0.2


@dataclass(frozen=True)
class LoadRuns:
    """Evaluation runs under a counter force that steps and ramps through the load-pressure range.

    Each run opens the valve to one opening in one direction (after ``valve_delay``) and the
    second cylinder's force walks the load pressure P_L = F_L/A_A through ``levels``: fractions
    of the range of P_L at which the valve meters steadily in that direction with both chambers
    between tank and supply pressure (:func:`hydropwa.evaluation.load_pressure_range`). The
    transitions between levels alternate: ramp, step, ramp, ... The force is scaled to the
    machine (its areas, supply and tank pressure), so one campaign serves every machine.

    Attributes
    ----------
    inputs : tuple of float
        Valve openings [1] (fractions of full opening; outside the dead band).
    directions : tuple of int
        +1 (extend, from near the retracted end) and/or −1 (retract, from near the extended end).
    levels : tuple of float
        Load-pressure levels [1], fractions of the direction's range (0: its lower end, 1: its
        upper end).
    ramp : float
        Duration of each ramp between levels [s].
    hold : float
        Time at each level [s].
    force_ramp : float
        Raised-cosine ramp from the machine's static load to the first level [s].
    valve_delay : float
        Time at which the valve opens [s] (after ``force_ramp``).
    start_margin : float
        The rod starts this fraction of the stroke [1] from the end it leaves.
    stop_margin : float
        A run ends once the rod comes within this fraction of the stroke [1] of an end stop.
    """

    inputs: tuple[float, ...]
    directions: tuple[int, ...] = (1, -1)
    levels: tuple[float, ...] = (0.05, 0.95, 0.5, 0.05)
    ramp: float = 1.0
    hold: float = 0.2
    force_ramp: float = 0.2
    valve_delay: float = 0.3
    start_margin: float = 0.1
    stop_margin: float = 0.05


@dataclass(frozen=True)
class SineExperiment:
    """Evaluation runs, Sec. VII: sines f × amplitude, sagging supply pressure recorded.

    Attributes
    ----------
    frequencies : tuple of float
        Sine frequencies [Hz] (1, 2, 3 in the paper).
    amplitudes : tuple of float
        Sine amplitudes [1] (0.2, 0.4, 0.6).
    periods : int
        Periods per run.
    start_position : float
        Initial rod position [1] (fraction of the stroke). The asymmetric cylinder
        drifts to +x, so runs start low in the stroke.
    stop_margin : float
        A run ends (after at least one period) once the rod comes within this fraction of
        the stroke of an end stop [1]: on a short fast axis a large slow sine reaches the
        stop, where a chamber empties below the pressure converter's range.
    load : LoadRuns or None
        ``[sine.load]``: runs under a stepped and ramped counter force that cover the load
        pressure range in both flow directions (the pressure cells of the PWA models).
    """

    name = "sine"
    frequencies: tuple[float, ...]
    amplitudes: tuple[float, ...]
    periods: int = 5
    start_position: float = 0.1
    stop_margin: float = 0.02
    load: LoadRuns | None = None


Experiment = FrfExperiment | DeadZoneExperiment | FrictionExperiment | SineExperiment


@dataclass(frozen=True)
class Campaign:
    """A set of experiments with one seed.

    Attributes
    ----------
    name : str
        Campaign name.
    seed : int
        Campaign seed; each run's noise seed derives from it and the run name.
    experiments : dict[str, Experiment]
        By name (``frf``, ``deadzone``, ``friction``, ``sine``), in run order.
    description : str
    source : str
        File the campaign came from.
    sensors : dict
        ``[sensors]`` overrides: per channel (``x``, ``p_a``, ``p_b``, ``p_s``, ``f_l``,
        ``spool``; ``pressure`` for all three pressures) the :class:`SensorModel` fields to
        replace, in SI. Empty: the rig sizes its sensors from the machine.
    supply : dict
        ``[supply]`` overrides of the rig's pump unit (``pump_flow``, ``compensator_droop``,
        ``line_volume``, ``relief_pressure``, ``relief_gain``), SI.
    faults : tuple of Fault
        ``[[faults]]`` injected into every experiment (:func:`~hydropwa.rig.parse_faults`).
    """

    name: str
    seed: int
    experiments: dict[str, Experiment] = field(default_factory=dict)
    description: str = ""
    source: str = ""
    sensors: dict[str, dict[str, Any]] = field(default_factory=dict)
    supply: dict[str, float] = field(default_factory=dict)
    faults: tuple[Fault, ...] = ()

    def __getitem__(self, name: str) -> Experiment:
        try:
            return self.experiments[name]
        except KeyError:
            raise ParameterError(
                f"campaign {self.name!r} has no experiment {name!r}; it has {', '.join(self.experiments) or 'none'}"
            ) from None


# --------------------------------------------------------------------- parsing
def _broadband(t: _Table) -> tuple[BroadbandSweep, ...]:
    items = t.raw("broadband", [])
    if not isinstance(items, list):
        raise ParameterError(f"{t.key('broadband')} must be an array of tables [[frf.broadband]]")
    out = []
    for i, b in enumerate(items):
        bt = _Table(b, f"{t.key('broadband')}[{i}]")
        sig = bt.text("signal", "chirp")
        if sig not in ("chirp", "multisine"):
            raise ParameterError(f"{bt.key('signal')} = {sig!r} must be 'chirp' or 'multisine'")
        bb = BroadbandSweep(
            opening=bt.quantity("opening", "", gt=0.0, le=1.0),
            f0=bt.quantity("f0", "Hz", gt=0.0),
            f1=bt.quantity("f1", "Hz", gt=0.0),
            duration=bt.quantity("duration", "s", 4.0, gt=0.0),
            signal=sig,
            period=bt.quantity("period", "s", 0.5, gt=0.0),
        )
        bt.finish()
        if bb.f1 <= bb.f0:
            raise ParameterError(f"{bt.key('f1')} = {bb.f1:g} Hz must exceed f0 = {bb.f0:g} Hz")
        if bb.signal == "multisine" and bb.f0 < 1.0 / bb.period:
            raise ParameterError(
                f"{bt.key('f0')} = {bb.f0:g} Hz lies below the multisine's resolution 1/period = "
                f"{1 / bb.period:g} Hz; lengthen period or raise f0"
            )
        out.append(bb)
    return tuple(out)


def _frf(t: _Table) -> FrfExperiment:
    sweeps = t.raw("sweep", [])
    broadband = _broadband(t)
    if not isinstance(sweeps, list) or not (sweeps or broadband):
        raise ParameterError(
            f"{t.key('sweep')} must be a non-empty array of tables [[frf.sweep]] (or give [[frf.broadband]])"
        )
    out = []
    for i, s in enumerate(sweeps):
        st = _Table(s, f"{t.key('sweep')}[{i}]")
        out.append(
            FrfSweep(
                st.quantity("opening", "", gt=0.0, le=1.0), st.values("frequencies", "Hz", gt=0.0)
            )
        )
        st.finish()
    return FrfExperiment(
        sweeps=tuple(out),
        settle=t.quantity("settle", "s", 0.05, ge=0.0),
        periods=t.integer("periods", 4, ge=1),
        margin_periods=t.integer("margin_periods", 2, ge=0),
        start_position=t.quantity("start_position", "", 0.5, ge=0.0, le=1.0),
        broadband=broadband,
    )


def _deadzone(t: _Table) -> DeadZoneExperiment:
    return DeadZoneExperiment(
        inputs=t.values("inputs", "", gt=0.0, le=1.0),
        directions=t.directions("directions"),
        duration=t.quantity("duration", "s", 4.0, gt=0.0),
        stop_at=t.quantity("stop_at", "", 0.9, gt=0.0, le=1.0),
        min_duration=t.quantity("min_duration", "s", 0.2, ge=0.0),
    )


def _friction(t: _Table) -> FrictionExperiment:
    exp = FrictionExperiment(
        inputs=t.values("inputs", "", gt=0.0, le=1.0),
        directions=t.directions("directions"),
        counter_force=t.quantity("counter_force", "N", 1500.0, ge=0.0),
        force_ramp=t.quantity("force_ramp", "s", 0.3, gt=0.0),
        valve_delay=t.quantity("valve_delay", "s", 0.4, ge=0.0),
        ripple=t.quantity("ripple", "", 0.01, ge=0.0, le=1.0),
        ripple_frequency=t.quantity("ripple_frequency", "Hz", 7.0, ge=0.0),
        force_noise=t.quantity("force_noise", "N", 5.0, ge=0.0),
        force_rate=t.quantity("force_rate", "Hz", 500.0, gt=0.0),
        counter_damping=t.quantity("counter_damping", "N*s/m", 1.0e4, ge=0.0),
        duration=t.quantity("duration", "s", 4.0, gt=0.0),
        stop_at=t.quantity("stop_at", "", 0.9, gt=0.0, le=1.0),
        min_duration=t.quantity("min_duration", "s", 0.2, ge=0.0),
    )
    if exp.valve_delay >= exp.duration:
        raise ParameterError(
            f"{t.key('valve_delay')} = {exp.valve_delay:g} s must be shorter than duration"
        )
    return exp


def _load_runs(t: _Table) -> LoadRuns | None:
    if "load" not in t.data:
        return None
    lt = _Table(t.raw("load"), t.key("load"))
    runs = LoadRuns(
        inputs=lt.values("inputs", "", gt=0.0, le=1.0),
        directions=lt.directions("directions"),
        levels=lt.values("levels", "", ge=0.0, le=1.0) if "levels" in lt.data else LoadRuns.levels,
        ramp=lt.quantity("ramp", "s", 1.0, gt=0.0),
        hold=lt.quantity("hold", "s", 0.2, gt=0.0),
        force_ramp=lt.quantity("force_ramp", "s", 0.2, gt=0.0),
        valve_delay=lt.quantity("valve_delay", "s", 0.3, ge=0.0),
        start_margin=lt.quantity("start_margin", "", 0.1, ge=0.0, le=0.5),
        stop_margin=lt.quantity("stop_margin", "", 0.05, ge=0.0, le=0.4),
    )
    lt.finish()
    if len(runs.levels) < 2:
        raise ParameterError(f"{lt.key('levels')} needs at least two levels to walk between")
    if runs.valve_delay < runs.force_ramp:
        raise ParameterError(
            f"{lt.key('valve_delay')} = {runs.valve_delay:g} s must not be shorter than "
            f"force_ramp = {runs.force_ramp:g} s (the valve opens once the first level is reached)"
        )
    return runs


def _sine(t: _Table) -> SineExperiment:
    return SineExperiment(
        frequencies=t.values("frequencies", "Hz", gt=0.0),
        amplitudes=t.values("amplitudes", "", gt=0.0, le=1.0),
        periods=t.integer("periods", 5, ge=1),
        start_position=t.quantity("start_position", "", 0.1, ge=0.0, le=1.0),
        stop_margin=t.quantity("stop_margin", "", 0.02, ge=0.0, le=0.4),
        load=_load_runs(t),
    )


#: ``[sensors]`` tables: one per channel a sensor measures (the channel table's), and
#: ``pressure`` for every pressure transmitter at once; the unit its quantities are read in.
_SENSOR_UNITS = {
    **{
        c: "" if CHANNEL[c].unit == "1" else CHANNEL[c].unit
        for c in channels_of("spool", "position", "pressure", "force")
    },
    "pressure": "Pa",
}
_SUPPLY_FIELDS = {
    "pump_flow": "m**3/s",
    "compensator_droop": "Pa",
    "line_volume": "m**3",
    "relief_pressure": "Pa",
    "relief_gain": "m**3/s/Pa",
}


def _sensors(t: _Table) -> dict[str, dict[str, Any]]:
    """``[sensors]``: per channel, SensorModel fields (range, noise_std, offset, gain, adc_bits, adc_span, name)."""
    out: dict[str, dict[str, Any]] = {}
    for ch in list(t.data):
        if ch not in _SENSOR_UNITS:
            raise ParameterError(f"{t.key(ch)}: unknown sensor; known: {', '.join(_SENSOR_UNITS)}")
        unit = _SENSOR_UNITS[ch]
        st = _Table(t.raw(ch), t.key(ch))
        over: dict[str, Any] = {}
        if "range" in st.data:
            r = st.raw("range")
            if not isinstance(r, list) or len(r) != 2:
                raise ParameterError(
                    f'{st.key("range")} = {r!r} must be [low, high], e.g. ["0 bar", "400 bar"]'
                )
            over["range"] = tuple(
                parse_quantity(v, unit, f"{st.key('range')}[{i}]") for i, v in enumerate(r)
            )
        if "noise_std" in st.data:
            over["noise_std"] = st.quantity("noise_std", unit, ge=0.0)
        if "offset" in st.data:
            over["offset"] = st.quantity("offset", unit)
        if "gain" in st.data:
            over["gain"] = st.quantity("gain", f"V/({unit})" if unit else "V", gt=0.0)
        if "adc_bits" in st.data:
            over["adc_bits"] = st.integer("adc_bits", ge=1)
        if "adc_span" in st.data:
            sp = st.raw("adc_span")
            if not isinstance(sp, list) or len(sp) != 2:
                raise ParameterError(f"{st.key('adc_span')} = {sp!r} must be [low, high] in V")
            over["adc_span"] = tuple(
                parse_quantity(v, "V", f"{st.key('adc_span')}[{i}]") for i, v in enumerate(sp)
            )
        if "name" in st.data:
            over["name"] = st.text("name")
        st.finish()
        for c in channels_of("pressure") if ch == "pressure" else (ch,):
            out.setdefault(c, {}).update(over)
        t.used.add(ch)
    return out


def _supply(t: _Table) -> dict[str, float]:
    """``[supply]``: overrides of the rig's pump unit (SI or strings with units)."""
    out = {k: t.quantity(k, u, gt=0.0) for k, u in _SUPPLY_FIELDS.items() if k in t.data}
    t.finish()
    return out


_PARSERS: dict[str, Callable[[_Table], Experiment]] = {
    "frf": _frf,
    "deadzone": _deadzone,
    "friction": _friction,
    "sine": _sine,
}


def parse_campaign(data: Mapping[str, Any], source: str = "<dict>") -> Campaign:
    """Build a :class:`Campaign` from a parsed TOML document.

    Raises
    ------
    ParameterError
        Naming the file and the key of any missing, unknown or invalid entry.
    """
    top = _Table(data, source)
    head = _Table(top.raw("campaign", {}), f"{source}: [campaign]")
    name = head.text("name", Path(source).stem)
    seed = head.integer("seed", 0, ge=0)
    description = head.text("description", "")
    head.finish()
    experiments: dict[str, Experiment] = {}
    for exp_name in EXPERIMENTS:
        if exp_name in data:
            t = _Table(top.raw(exp_name), f"{source}: [{exp_name}]")
            experiments[exp_name] = _PARSERS[exp_name](t)
            t.finish()
    sensors = _sensors(_Table(top.raw("sensors", {}), f"{source}: [sensors]"))
    supply = _supply(_Table(top.raw("supply", {}), f"{source}: [supply]"))
    faults = parse_faults(top.raw("faults", []), source)
    extra = sorted(set(data) - top.used - set(EXPERIMENTS) - {"limits"})  # [limits]: rig plan's
    if extra:
        raise ParameterError(
            f"{source}: unknown table(s) {', '.join(extra)}; known: campaign, sensors, supply, "
            f"faults, limits, "
            f"{', '.join(EXPERIMENTS)}"
        )
    if not experiments:
        raise ParameterError(f"{source}: no experiment tables; add one of {', '.join(EXPERIMENTS)}")
    return Campaign(
        name=name,
        seed=seed,
        experiments=experiments,
        description=description,
        source=source,
        sensors=sensors,
        supply=supply,
        faults=faults,
    )


def builtin_campaigns() -> list[str]:
    """Names of the campaigns shipped with the package (``paper``, ...)."""
    folder = resources.files("hydropwa.rig") / "campaigns"
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))


def load_campaign(name_or_path: str | os.PathLike = "paper") -> Campaign:
    """Load a campaign by built-in name (``"paper"``) or from a TOML file.

    Raises
    ------
    ParameterError
        If the file is missing or invalid (the message names the key).
    """
    p = Path(name_or_path)
    if isinstance(name_or_path, str) and not p.exists() and name_or_path in builtin_campaigns():
        text = (resources.files("hydropwa.rig") / "campaigns" / f"{name_or_path}.toml").read_text(
            encoding="utf-8"
        )
        source = f"{name_or_path}.toml"
    elif p.is_file():
        text = read_text(p, "campaign file", ParameterError)
        source = str(p)
    else:
        raise ParameterError(
            f"campaign {str(name_or_path)!r} not found; give a TOML file or a built-in name "
            f"({', '.join(builtin_campaigns())})"
        )
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ParameterError(f"{source}: invalid TOML ({exc})") from None
    except RecursionError:
        raise ParameterError(f"{source}: nested too deeply to be a campaign") from None
    return parse_campaign(data, source)
