"""The campaign sized from the machine: the paper's experiments scaled to any axis.

The paper's campaign (``campaigns/paper.toml``) is written for its 200 mm rig: a 90 % FRF
sine at 2 Hz, the 60 % evaluation sine at 1 Hz, friction inputs from 5 % and dead-zone inputs
up to 20 % fit that rig's stroke, valve and 10 % dead band. :func:`size_campaign` derives the
same experiments from a machine's own parameters (stroke, areas, supply pressure, valve flow,
ω0, dead band, friction), so a 700 mm axis with a 40 Hz valve or a 3 % overlapped spool gets
amplitudes, frequencies and input levels it can play. The rules are declared once, in
:class:`SizingRules`; the built-in campaign name ``"machine"`` means "sized by these rules"
in ``hydropwa rig run`` and ``hydropwa rig plan`` (:func:`campaign_for`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._errors import ParameterError
from ..components import load_flow
from ..params import SystemParams
from ._campaign import (
    Campaign,
    DeadZoneExperiment,
    Experiment,
    FrfExperiment,
    FrfSweep,
    FrictionExperiment,
    LoadRuns,
    SineExperiment,
    load_campaign,
)

__all__ = ["SIZED", "SizingRules", "campaign_for", "no_load_velocity", "size_campaign"]

#: The campaign name that means "sized from the machine" (:func:`campaign_for`).
SIZED = "machine"


@dataclass(frozen=True)
class SizingRules:
    """How each experiment is scaled to a machine (applied by :func:`size_campaign`).

    Attributes
    ----------
    frf_openings : tuple of float
        FRF sine amplitudes [1] (the paper's 10, 25 and 90 %).
    frf_top : tuple of float
        Highest FRF frequency of each opening as a multiple of the nominal ω0/2π [1] (the
        paper: 100, 100, 50 Hz for its ~100 Hz valve).
    frf_points : int
        Frequencies per opening (geometric grid).
    frf_travel : float
        Largest rod amplitude of an FRF run [1] (fraction of the stroke) from the start at
        mid-stroke: sets the lowest frequency of each opening.
    deadzone_span : tuple of float
        Dead-zone inputs from ``span[0]·β`` to ``span[1]·β`` (the paper: 1 %-20 % for β = 10 %).
    deadzone_points : int
        Number of dead-zone inputs.
    friction_start, friction_width : float
        Friction inputs from ``start·β + 1 %`` to that plus ``width`` [1] (outside the band:
        the friction fit needs the rod moving steadily).
    friction_points : int
        Number of friction inputs.
    counter_load : float
        Counter force as a fraction of P_S·A_A [1] (the paper: 1.5 kN ≈ 0.115·P_S·A_A).
    counter_damping_ratio : float
        Counter-cylinder damping as a multiple of the Stribeck curve's steepest negative slope
        (F_s − F_c)/χ [1] (the paper: 1e4 N·s/m = 5/3 · 60 N/10 mm/s): keeps the slow runs free
        of stick-slip.
    sine_frequencies : tuple of float
        Evaluation sine frequencies [Hz] (the paper's 1, 2, 3 Hz).
    sine_openings : tuple of float
        Evaluation sine amplitudes above the band [1]: β + these (the paper: 20/40/60 %).
    sine_travel : float
        Largest rod amplitude of the lowest-frequency sine [1] (fraction of the stroke).
    load_levels : tuple of float
        Load-pressure levels of the load runs [1] (fractions of the direction's range). The
        paper's 0.05 is a load that pulls the rod along: 1.6-1.8 m/s on its 1.4 kg rig, beyond
        a real cylinder's seals, and its 1 ms step from 0.95 to 0.5 kicks it to 1.7 m/s; these
        levels keep the aiding load moderate and the step small (0.21 m/s; 0.17 m/s on the
        50/20 × 700 mm axis).
    """

    frf_openings: tuple[float, ...] = (0.10, 0.25, 0.90)
    frf_top: tuple[float, ...] = (1.0, 1.0, 0.5)
    frf_points: int = 14
    frf_travel: float = 0.3
    deadzone_span: tuple[float, float] = (0.1, 2.0)
    deadzone_points: int = 20
    friction_start: float = 1.2
    friction_width: float = 0.4
    friction_points: int = 16
    counter_load: float = 0.1
    counter_damping_ratio: float = 5.0 / 3.0
    sine_frequencies: tuple[float, ...] = (1.0, 2.0, 3.0)
    sine_openings: tuple[float, ...] = (0.1, 0.3, 0.5)
    sine_travel: float = 0.25
    load_levels: tuple[float, ...] = (0.2, 0.9, 0.85, 0.3)


def no_load_velocity(params: SystemParams, opening: float) -> float:
    """Steady extension speed [m/s] at a valve opening z [1] against the machine's static load.

    Q_A = z K √Δp of Eq. (12) for a single-rod cylinder (:func:`hydropwa.components.load_flow`)
    at the load pressure P_L = F_0/A_A, divided by A_A.
    """
    cyl, sup = params.cylinder, params.supply
    alpha = cyl.area_b / cyl.area_a
    p_l = params.load.force / cyl.area_a
    q = load_flow(
        float(opening),
        p_l,
        sup.pressure,
        params.flow.K,
        params.flow.transition_pressure,
        alpha,
        sup.tank_pressure,
    )
    return float(q) / cyl.area_a


def _round(x: float, digits: int = 3) -> float:
    return float(f"{x:.{digits}g}")


def _frf(params: SystemParams, rules: SizingRules) -> FrfExperiment:
    f0 = params.valve.omega0 / (2 * math.pi)
    beta = params.dead_zone.beta
    travel = rules.frf_travel * params.cylinder.stroke
    sweeps = []
    for opening, top in zip(rules.frf_openings, rules.frf_top, strict=True):
        v = no_load_velocity(params, max(opening - beta, 0.0) or opening)
        f_lo = max(2.0, v / (2 * math.pi * travel))  # sine amplitude v/(2πf) within the travel
        f_hi = max(top * f0, 2 * f_lo)
        grid = np.geomspace(f_lo, f_hi, rules.frf_points)
        sweeps.append(FrfSweep(opening, tuple(_round(f) for f in grid)))
    return FrfExperiment(sweeps=tuple(sweeps), margin_periods=1)


def _deadzone(params: SystemParams, rules: SizingRules) -> DeadZoneExperiment:
    beta = max(params.dead_zone.beta, 0.01)  # a zero-lap valve: probe around 1 %
    lo, hi = (s * beta for s in rules.deadzone_span)
    inputs = np.linspace(max(lo, 0.002), min(hi, 0.95), rules.deadzone_points)
    return DeadZoneExperiment(inputs=tuple(_round(u) for u in inputs), duration=3.0)


def _friction(params: SystemParams, rules: SizingRules) -> FrictionExperiment:
    beta = params.dead_zone.beta
    fr = params.friction
    lo = rules.friction_start * beta + 0.01
    inputs = np.linspace(lo, min(lo + rules.friction_width, 0.95), rules.friction_points)
    cyl = params.cylinder
    force = rules.counter_load * params.supply.pressure * cyl.area_a
    slope = max(fr.static - fr.coulomb, 0.0) / max(fr.stribeck_velocity, 1e-6)
    return FrictionExperiment(
        inputs=tuple(_round(u) for u in inputs),
        counter_force=_round(force, 2),
        counter_damping=_round(max(rules.counter_damping_ratio * slope, 1e3), 2),
        duration=3.0,
    )


def _sine(params: SystemParams, rules: SizingRules) -> SineExperiment:
    beta = params.dead_zone.beta
    travel = rules.sine_travel * params.cylinder.stroke
    f_min = min(rules.sine_frequencies)
    # the largest opening whose amplitude v(z)/(2πf) at the lowest frequency fits the travel
    v_full = no_load_velocity(params, 1.0)
    z_max = min(1.0, 2 * math.pi * f_min * travel / max(v_full, 1e-9))
    top = max(rules.sine_openings)
    amplitudes = [beta + o * min(1.0, max(z_max - beta, 0.05) / top) for o in rules.sine_openings]
    return SineExperiment(
        frequencies=rules.sine_frequencies,
        amplitudes=tuple(_round(min(a, 1.0)) for a in amplitudes),
        load=LoadRuns(inputs=(_round(beta + 0.1),), levels=rules.load_levels),
    )


def size_campaign(
    params: SystemParams, rules: SizingRules | None = None, *, seed: int = 20240501
) -> Campaign:
    """The paper's four experiments sized to a machine (rules: :class:`SizingRules`).

    Parameters
    ----------
    params : SystemParams
        The machine: stroke [m], areas [m²], supply pressure [Pa], valve flow coefficient and
        ω0 [rad/s], dead band β [1], friction (F_c, F_s [N], χ [m/s]).
    rules : SizingRules, optional
        The scaling rules (default: those that give the paper's campaign on the paper's rig).
    seed : int
        Campaign seed.

    Returns
    -------
    Campaign
        ``name = "machine"``: FRF sweeps from the lowest frequency whose rod amplitude fits
        ``frf_travel`` of the stroke up to a multiple of the machine's ω0; dead-zone inputs
        around its own β; friction inputs outside its band against a counter force scaled to
        P_S·A_A, damped against its Stribeck slope; evaluation sines whose rod amplitude fits
        ``sine_travel`` of the stroke, and load runs through its load-pressure range.
    """
    rules = rules or SizingRules()
    if not 0.0 <= params.dead_zone.beta < 0.5:
        raise ParameterError(
            f"dead_zone.beta = {params.dead_zone.beta:g} leaves no valve range to size a campaign "
            "in; give a dead band below 50 %"
        )
    experiments: dict[str, Experiment] = {
        "frf": _frf(params, rules),
        "deadzone": _deadzone(params, rules),
        "friction": _friction(params, rules),
        "sine": _sine(params, rules),
    }
    return Campaign(
        name=SIZED,
        seed=seed,
        experiments=experiments,
        description=(
            f"the paper's experiments sized to a {1e3 * params.cylinder.stroke:g} mm axis "
            f"({params.valve.omega0 / (2 * math.pi):.3g} Hz valve, "
            f"{100 * params.dead_zone.beta:.3g} % dead band)"
        ),
        source=f"{SIZED} (hydropwa.rig.size_campaign)",
    )


def campaign_for(name_or_path: str, params: SystemParams) -> Campaign:
    """The campaign ``name_or_path`` names: ``"machine"`` is sized from ``params``
    (:func:`size_campaign`); any other name or file is :func:`load_campaign`'s."""
    if name_or_path == SIZED:
        return size_campaign(params)
    return load_campaign(name_or_path)
