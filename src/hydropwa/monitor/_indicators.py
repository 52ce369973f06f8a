"""The health indicators and the machine parameters that are not watched but only known.

:data:`INDICATORS` is the one table of what the monitor estimates: each row names the
indicator, its SI unit and display unit, the fit and the entry of θ it reads, the machine
parameter it is the estimate of, the direction a fault moves it, the fault it names and the
healthy half-width assumed when the parameter file gives no interval for it.
:data:`NUISANCE` lists the parameters the fits hold at their identified values, with the
relative half-width assumed when the file has none; their intervals become the thresholds'
model-error allowance (:mod:`._thresholds`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, fields, is_dataclass
from typing import Any

from ..params import SystemParams

__all__ = ["INDICATORS", "NUISANCE", "Indicator", "draw_within", "parameter_intervals"]


@dataclass(frozen=True)
class Indicator:
    """One health indicator.

    Attributes
    ----------
    name : str
        Key in ``health.json``.
    unit, display_unit : str
        SI unit of the value, and the unit of the report (``display_scale`` × SI).
    display_scale : float
        Factor from SI to the display unit.
    fit : str
        ``"continuity"``, ``"friction"``, ``"spool"`` or ``"supply"`` (:mod:`._residuals`).
    column : int
        Entry of that fit's θ (``-1``: the sum of the friction fit's first two, F_s).
    parameter : str
        The machine parameter it estimates (dotted ``SystemParams`` field), or ``""`` for a
        quantity whose healthy value is zero (the valve null offset).
    direction : int
        +1: a fault raises it; −1: lowers it; 0: either.
    fault : str
        The fault it names when it alarms (a :data:`hydropwa.rig.FAULT_KINDS` name).
    healthy_halfwidth : float
        Healthy half-width assumed without an identified interval: a fraction of the value
        when ``relative``, else absolute (SI).
    relative : bool
    alarms : bool
        Whether it has a threshold. F_c, F_s and σ apart are estimates only: one run's speed
        range rarely separates them (``friction_scale`` carries the friction alarm).
    ratio_of : tuple of str
        For a ratio to the identified value (nominal 1): the parameters whose intervals
        bound it (``friction_scale``: F_c, F_s, σ, weighted by the run's speeds,
        :func:`~._residuals.friction_level_weights`).
    """

    name: str
    unit: str
    display_unit: str
    display_scale: float
    fit: str
    column: int
    parameter: str
    direction: int
    fault: str
    healthy_halfwidth: float
    relative: bool
    alarms: bool = True
    ratio_of: tuple[str, ...] = ()


#: L/min per m³/(s·Pa) at the 50 bar a leakage is quoted at.
_LPM_AT_50BAR = 50e5 * 6e4

#: What the monitor estimates (a new indicator is one row here and its column in a fit).
INDICATORS: tuple[Indicator, ...] = (
    Indicator(
        "internal_leakage",
        "m**3/s/Pa",
        "L/min @ 50 bar",
        _LPM_AT_50BAR,
        "continuity",
        1,
        "cylinder.leakage",
        +1,
        "internal_leakage",
        0.0,
        False,
    ),
    Indicator(
        "external_leakage_a",
        "m**3/s/Pa",
        "L/min @ 50 bar",
        _LPM_AT_50BAR,
        "continuity",
        2,
        "cylinder.external_leakage_a",
        +1,
        "external_leakage_a",
        0.0,
        False,
    ),
    Indicator(
        "external_leakage_b",
        "m**3/s/Pa",
        "L/min @ 50 bar",
        _LPM_AT_50BAR,
        "continuity",
        3,
        "cylinder.external_leakage_b",
        +1,
        "external_leakage_b",
        0.0,
        False,
    ),
    Indicator(
        "bulk_modulus",
        "Pa",
        "GPa",
        1e-9,
        "continuity",
        0,
        "oil.bulk_modulus",
        -1,
        "bulk_modulus",
        0.10,
        True,
    ),
    Indicator("valve_null", "1", "%", 100.0, "spool", 0, "", 0, "valve_null", 0.0, False),
    Indicator(
        "friction_scale",
        "1",
        "×",
        1.0,
        "friction_scale",
        0,
        "",
        +1,
        "friction",
        0.0,
        False,
        ratio_of=("friction.coulomb", "friction.static", "friction.viscous"),
    ),
    Indicator(
        "coulomb_friction",
        "N",
        "N",
        1.0,
        "friction",
        0,
        "friction.coulomb",
        +1,
        "friction",
        0.10,
        True,
        alarms=False,
    ),
    Indicator(
        "static_friction",
        "N",
        "N",
        1.0,
        "friction",
        -1,
        "friction.static",
        +1,
        "friction",
        0.10,
        True,
        alarms=False,
    ),
    Indicator(
        "viscous_friction",
        "N*s/m",
        "N·s/m",
        1.0,
        "friction",
        2,
        "friction.viscous",
        +1,
        "friction",
        0.10,
        True,
        alarms=False,
    ),
    Indicator(
        "supply_pressure",
        "Pa",
        "bar",
        1e-5,
        "supply",
        0,
        "supply.pressure",
        -1,
        "supply",
        0.01,
        True,
    ),
)

#: Held parameters and the relative half-width assumed when the file gives no interval.
NUISANCE: dict[str, float] = {
    "flow.K": 0.02,
    "flow.transition_pressure": 0.5,
    "dead_zone.beta": 0.05,
    "dead_zone.creep_slope": 0.2,
    "valve.omega0": 0.1,
    "valve.zeta": 0.1,
    "cylinder.dead_volume_a": 0.1,
    "cylinder.dead_volume_b": 0.1,
    "load.mass": 0.05,
    "friction.stribeck_velocity": 0.2,
    "friction.shape": 0.1,
    "supply.compensator_droop": 0.1,
    "supply.pump_flow": 0.05,
}


def value_of(params: SystemParams, path: str) -> float:
    """The float at a dotted ``component.field`` path of ``params``."""
    comp, fld = path.split(".")
    return float(getattr(getattr(params, comp), fld))


def _identified(params: SystemParams) -> dict[str, tuple[float, float]]:
    """Intervals [ci_low, ci_high] (SI) of the file's ``[uncertainty]`` tables, by dotted field."""
    out: dict[str, tuple[float, float]] = {}
    table = params.meta.get("uncertainty", {})
    if not isinstance(table, Mapping):
        return out
    for part, entries in table.items():
        comp = getattr(params, str(part), None)
        if not isinstance(entries, Mapping):
            continue
        for name, e in entries.items():
            if not (isinstance(e, Mapping) and "ci_low" in e and "ci_high" in e):
                continue
            path = str(name) if "." in str(name) else f"{part}.{name}"
            if "." not in str(name):
                known = {f.name for f in fields(comp)} if is_dataclass(comp) else set()
                if name not in known:
                    continue
            try:
                lo, hi = float(e["ci_low"]), float(e["ci_high"])
            except (TypeError, ValueError):
                continue
            out[path] = (min(lo, hi), max(lo, hi))
    return out


def parameter_intervals(
    params: SystemParams, overrides: Mapping[str, tuple[float, float]] | None = None
) -> dict[str, tuple[tuple[float, float], str]]:
    """Each watched and held parameter's healthy interval (SI) and where it came from.

    Sources, in order: ``overrides``, the file's ``[uncertainty]`` (identified), else the
    assumed half-width of :data:`INDICATORS` / :data:`NUISANCE` around the value.
    Returns ``{path: ((lo, hi), "given" | "identified" | "assumed")}``.
    """
    ident = _identified(params)
    out: dict[str, tuple[tuple[float, float], str]] = {}
    assumed: dict[str, tuple[float, bool]] = {p: (w, True) for p, w in NUISANCE.items()}
    for ind in INDICATORS:
        if ind.parameter:
            assumed[ind.parameter] = (ind.healthy_halfwidth, ind.relative)
    for path, (w, rel) in assumed.items():
        value = value_of(params, path)
        if overrides and path in overrides:
            lo, hi = overrides[path]
            out[path] = ((float(lo), float(hi)), "given")
        elif path in ident:
            lo, hi = ident[path]
            out[path] = ((min(lo, value), max(hi, value)), "identified")
        else:
            h = abs(value) * w if rel else w
            out[path] = ((value - h, value + h), "assumed")
    return out


def draw_within(
    params: SystemParams,
    intervals: Mapping[str, tuple[tuple[float, float], str]],
    rng: Any,
) -> SystemParams:
    """A healthy machine: each parameter of ``intervals`` drawn uniformly inside its interval.

    The population the thresholds are sized for (a healthy axis within its identified or
    assumed intervals), for checking them (benchmarks/monitor_study.py, the tests). The valve's
    ω0 amplitude table moves with ω0; F_s is kept at least F_c.
    """
    changes: dict[str, float] = {}
    for path, ((lo, hi), _src) in intervals.items():
        if hi > lo:
            changes[path] = float(rng.uniform(lo, hi))
    if "friction.static" in changes and "friction.coulomb" in changes:
        changes["friction.static"] = max(changes["friction.static"], changes["friction.coulomb"])
    w = changes.pop("valve.omega0", None)
    out = params.replace(**changes)
    if w is not None:
        v = out.valve
        table = tuple((a, x * w / v.omega0) for a, x in v.omega0_table)
        out = out.replace(valve=dataclasses.replace(v, omega0=w, omega0_table=table))
    return out


def describe_intervals(intervals: Mapping[str, tuple[tuple[float, float], str]]) -> dict[str, Any]:
    """Plain dict for the report: ``{path: {"low", "high", "source"}}`` (SI)."""
    return {p: {"low": lo, "high": hi, "source": src} for p, ((lo, hi), src) in intervals.items()}
