"""The one table of the canonical channels of a run: what each one is, its unit and its range.

Every layer that reads a run by channel name reads this table: the data layer's units and
plausibility checks (:mod:`hydropwa.data`), the models' initial state from a measurement
(``state_from_measurement``), the grey-box data (:mod:`hydropwa.identification.greybox`), the
evaluation's start and the virtual rig's sensors (:mod:`hydropwa.rig`). A new measured channel
(a line pressure ``p_line_a`` logged where the rig has a transmitter on the hose, say) is one row
here plus the physics of the state it initialises:

- its ``state`` names the model state it initialises (the models fill every state named by a
  row from the measurement; a model without that state ignores the channel);
- its ``sensor`` kind picks the rig's sensor for it (a ``pressure`` row gets a pressure
  transmitter sized for the machine) and which channels the rig records;
- its range and hints are the data layer's plausibility check.

This module is a leaf like :mod:`hydropwa._layout`: it imports only :mod:`hydropwa._errors`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from ._errors import ParameterError

__all__ = [
    "Channel",
    "CHANNELS",
    "CHANNEL",
    "SENSOR_KINDS",
    "RECORDED_CHANNELS",
    "RANGED_CHANNELS",
    "SCORED_CHANNELS",
    "FLOOR_CHANNELS",
    "CONVERTER_CHANNELS",
    "SENSED_STATE_CHANNELS",
    "STATE_CHANNELS",
    "START_REQUIRED",
    "channels_of",
    "measured_values",
]

_P_HIGH = "values above 1000 bar: check the declared unit (psi or kPa declared as Pa?)"
_P_LOW = "the values look like bar (or MPa); declare the unit as 'bar' or 'MPa', e.g. 'p_a [bar]'"
_FRACTION_HIGH = "the values look like percent; declare the unit as '%'"
_UNIT_HINT = "check the unit declared for this channel"

#: Sensor kinds of :attr:`Channel.sensor`: ``clock`` (the time base), ``command`` (what the rig
#: sends, not measured), ``spool``, ``position``, ``pressure`` and ``force`` (a sensor on the rig
#: measures it), and ``derived`` (computed from other channels: the velocity from x, the load
#: pressure, the opening; no sensor of its own).
SENSOR_KINDS: tuple[str, ...] = (
    "clock",
    "command",
    "spool",
    "position",
    "pressure",
    "force",
    "derived",
)


@dataclass(frozen=True)
class Channel:
    """One canonical channel of a run.

    Attributes
    ----------
    name : str
        Channel name in runs, files and results (``p_a``).
    unit : str
        SI unit of the channel inside the package (``Pa``).
    state : str or None
        Model state this channel initialises in ``state_from_measurement`` (its name in the
        layout's state tables, :mod:`hydropwa._layout`), or ``None``: an input or a derived
        quantity.
    sensor : str
        Sensor kind (:data:`SENSOR_KINDS`).
    lo, hi : float
        Smallest and largest plausible sample [unit].
    min_peak : float
        Smallest plausible peak ``max |value|`` when the channel is not all zero [unit]
        (catches bar declared as Pa); 0: no such check.
    floor : bool
        Whether the pressure can fall to the oil's vapour pressure in operation (a chamber
        or a line; not the supply): at a gauge sensor's 0 bar it meets a physical floor, not
        a clipping converter (``hydropwa.data``'s ``pressure_floor`` note).
    score : int
        Rank of the channel in the evaluation's tables of measured against simulated channels
        (:mod:`hydropwa.evaluation`); 0: not scored.
    high_hint : str
        Likely cause when ``hi`` is exceeded.
    description : str
        What it is, in the paper's terms.
    low_hint : str
        Likely cause when the peak is below ``min_peak``.
    component : str or None
        The optional part of the machine the channel exists with (``"lines"``:
        ``SystemParams.carries``): the rig fits a sensor for it only on a machine that carries
        the part. None: every machine has it.
    """

    name: str
    unit: str
    state: str | None
    sensor: str
    lo: float
    hi: float
    min_peak: float
    floor: bool
    score: int
    high_hint: str
    description: str
    low_hint: str = _UNIT_HINT
    component: str | None = None

    def __post_init__(self) -> None:
        if self.sensor not in SENSOR_KINDS:
            raise ParameterError(
                f"channel {self.name!r}: sensor kind {self.sensor!r} must be one of "
                f"{', '.join(SENSOR_KINDS)}"
            )
        if not self.lo < self.hi:
            raise ParameterError(f"channel {self.name!r}: range lo {self.lo} must be below hi")


_X_HIGH = "positions beyond 2 m look like mm; declare the unit as 'mm'"
_V_HIGH = "speeds beyond 5 m/s look like mm/s; declare 'mm/s'"
_F_HIGH = "forces beyond 10 MN: check the declared unit"
_INF = math.inf

#: The canonical channels. The rig's sensors sample them in this order (its noise streams
#: follow it) and it records the rows of sensor kind ``command`` to ``force``
#: (:data:`RECORDED_CHANNELS`) that its model simulates: the line pressures only on a machine
#: with hose lines (they come last, so a machine without lines draws the same noise).
# fmt: off
CHANNELS: tuple[Channel, ...] = (
    #       name     unit   state    sensor      lo     hi    peak  floor  score hint
    Channel("t",     "s",   None,    "clock",    0.0,   _INF, 0.0,  False, 0, _UNIT_HINT,
            "time"),
    Channel("u",     "1",   None,    "command",  -1.05, 1.05, 0.0,  False, 0, _FRACTION_HIGH,
            "valve command u, Eq. (1)"),
    Channel("spool", "1",   "spool", "spool",    -1.05, 1.05, 0.0,  False, 0, _FRACTION_HIGH,
            "spool position ν, Eq. (1)"),
    Channel("p_a",   "Pa",  "p_a",   "pressure", -1e5,  1e8,  1e3,  True,  2, _P_HIGH,
            "chamber A pressure P_A, Eq. (9)", _P_LOW),
    Channel("p_b",   "Pa",  "p_b",   "pressure", -1e5,  1e8,  1e3,  True,  3, _P_HIGH,
            "chamber B pressure P_B, Eq. (9)", _P_LOW),
    Channel("p_s",   "Pa",  "p_s",   "pressure", -1e5,  1e8,  1e3,  False, 0, _P_HIGH,
            "supply pressure P_S", _P_LOW),
    Channel("x",     "m",   "x",     "position", -0.05, 2.0,  0.0,  False, 1, _X_HIGH,
            "rod position x, Eq. (10)"),
    Channel("f_l",   "N",   None,    "force",    -1e7,  1e7,  0.0,  False, 0, _F_HIGH,
            "external load force F_L, Eq. (10)"),
    Channel("p_line_a", "Pa", "p_line_a", "pressure", -1e5, 1e8, 1e3, True, 0, _P_HIGH,
            "pressure in the hose line on valve port A (params.Lines)", _P_LOW,
            component="lines"),
    Channel("p_line_b", "Pa", "p_line_b", "pressure", -1e5, 1e8, 1e3, True, 0, _P_HIGH,
            "pressure in the hose line on valve port B (params.Lines)", _P_LOW,
            component="lines"),
    Channel("z",     "1",   None,    "derived",  -1.05, 1.05, 0.0,  False, 0, _FRACTION_HIGH,
            "valve opening after the dead zone, Eq. (4)"),
    Channel("p_l",   "Pa",  None,    "derived",  -1e8,  1e8,  1e3,  False, 4, _P_HIGH,
            "load pressure P_L = P_A − α P_B, Eq. (12)", _P_LOW),
    Channel("v",     "m/s", "v",     "derived",  -5.0,  5.0,  0.0,  False, 5, _V_HIGH,
            "rod velocity ẋ (estimated from x), Eq. (10)"),
)
# fmt: on
#: Each channel by name.
CHANNEL: dict[str, Channel] = {c.name: c for c in CHANNELS}
#: Channels the rig records: the command it sends and what its sensors measure.
RECORDED_CHANNELS: tuple[str, ...] = tuple(
    c.name for c in CHANNELS if c.sensor not in ("clock", "derived")
)
#: Channels checked against their plausible range (all but the time base).
RANGED_CHANNELS: tuple[str, ...] = tuple(c.name for c in CHANNELS if c.sensor != "clock")
#: Channels the evaluation scores (measured against simulated), in the order of its tables.
SCORED_CHANNELS: tuple[str, ...] = tuple(
    c.name for c in sorted((c for c in CHANNELS if c.score), key=lambda c: c.score)
)
#: Channels whose converter can clip (a sensor of position, pressure or force); the spool signal
#: and the command saturate legitimately at ±1.
CONVERTER_CHANNELS: tuple[str, ...] = tuple(
    c.name for c in CHANNELS if c.sensor in ("position", "pressure", "force")
)
#: State channels a sensor measures (the others, the velocity, are estimated from them).
SENSED_STATE_CHANNELS: tuple[str, ...] = tuple(
    c.name for c in CHANNELS if c.state is not None and c.sensor != "derived"
)
#: Pressures that meet the oil's physical floor (chambers, lines; :attr:`Channel.floor`).
FLOOR_CHANNELS: tuple[str, ...] = tuple(c.name for c in CHANNELS if c.floor)
#: Channels that initialise a model state (``state_from_measurement``).
STATE_CHANNELS: tuple[str, ...] = tuple(c.name for c in CHANNELS if c.state is not None)
#: Channels a measured initial state needs; the others default (v and ν at rest: 0, P_S: the
#: machine's supply pressure, a state without a channel: the layout's rest value).
START_REQUIRED: tuple[str, ...] = ("x", "p_a", "p_b")


def channels_of(*sensors: str) -> tuple[str, ...]:
    """Names of the channels of the given sensor kinds (:data:`SENSOR_KINDS`), in table order."""
    bad = [s for s in sensors if s not in SENSOR_KINDS]
    if bad:
        raise ParameterError(
            f"sensor kind(s) {', '.join(map(repr, bad))} must be among {', '.join(SENSOR_KINDS)}"
        )
    return tuple(c.name for c in CHANNELS if c.sensor in sensors)


def measured_values(
    measured: Mapping[str, float],
    states: tuple[str, ...],
    defaults: Mapping[str, float],
    positional: tuple[float, ...] = (),
) -> dict[str, float]:
    """Named state values of a model from a measurement by channel name.

    Parameters
    ----------
    measured : Mapping[str, float]
        Channel name → measured value [SI unit of the channel, :data:`CHANNELS`].
    states : tuple of str
        The model's state names; a channel whose state is not among them is ignored.
    defaults : Mapping[str, float]
        Channel name → value used where ``measured`` lacks the channel.
    positional : tuple of float
        Further positional arguments of the caller: the removed form
        ``(x, v, p_a, p_b, p_s, spool)``; any is an error saying how to call it now.

    Returns
    -------
    dict[str, float]
        State name → value, for every channel of :data:`STATE_CHANNELS` whose state is in
        ``states`` and that is measured or defaulted.

    Raises
    ------
    ParameterError
        ``measured`` is not a mapping, names an unknown or non-state channel, lacks one of
        :data:`START_REQUIRED`, or holds a value that is not finite.
    """
    if positional or not isinstance(measured, Mapping):
        got = "positional values" if positional else type(measured).__name__
        raise ParameterError(
            "state_from_measurement takes a mapping of channel name → value [SI], e.g. "
            "{'x': 0.1, 'v': 0.0, 'p_a': 40e5, 'p_b': 30e5, 'p_s': 100e5, 'spool': 0.0}; "
            f"got {got} (the positional form (x, v, p_a, p_b, p_s, spool) was removed)"
        )
    unknown = sorted(set(measured) - set(STATE_CHANNELS))
    if unknown:
        raise ParameterError(
            f"measured channel(s) {', '.join(unknown)} initialise no state; "
            f"give only {', '.join(STATE_CHANNELS)}"
        )
    missing = [c for c in START_REQUIRED if c not in measured]
    if missing:
        raise ParameterError(
            f"a measured initial state needs {', '.join(missing)}; give every one of "
            f"{', '.join(START_REQUIRED)} [SI]"
        )
    out: dict[str, float] = {}
    for name in STATE_CHANNELS:
        state = CHANNEL[name].state
        if state not in states or (name not in measured and name not in defaults):
            continue
        value = float(measured[name] if name in measured else defaults[name])
        if not math.isfinite(value):
            raise ParameterError(
                f"measured {name} = {value} [{CHANNEL[name].unit}] is not finite; "
                "give a finite value"
            )
        out[str(state)] = value
    return out
