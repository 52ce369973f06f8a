"""Component physics shared by the full, reduced and PWA models (see :mod:`._physics`)."""

from ._physics import (
    chamber_pressure_rates,
    dead_zone,
    effective_bulk_modulus,
    end_stop_force,
    load_flow,
    load_pressure_rate,
    net_piston_force,
    orifice_flows,
    piston_acceleration,
    pump_supply_rate,
    servo_valve_acceleration,
    signed_sqrt,
    stribeck_friction,
    supply_flow,
)
from ._pwa import PiecewiseAffine

__all__ = [
    "PiecewiseAffine",
    "chamber_pressure_rates",
    "dead_zone",
    "effective_bulk_modulus",
    "end_stop_force",
    "load_flow",
    "load_pressure_rate",
    "net_piston_force",
    "orifice_flows",
    "piston_acceleration",
    "pump_supply_rate",
    "servo_valve_acceleration",
    "signed_sqrt",
    "stribeck_friction",
    "supply_flow",
]
