"""Built-in parameter presets.

``paper``
    Tables II, III and IV of the paper; K from the valve rating 40 L/min at
    70 bar (docs/errata.md E9); Stribeck parameters recovered from Table V by
    :func:`~hydropwa.params.recover_stribeck_from_table_v` (item 8); chamber
    dead volumes read as 0.7 L instead of the printed 0.7 m³ (item 2); supply
    100 bar (Sec. VII set value); ω0 scheduled on the command amplitude
    (Table II) with ζ = 0.7.
``symmetric``
    The paper rig with a double-rod cylinder (A_B = A_A): the reduced model is
    exact up to the valve dynamics here, useful for tests and teaching.
"""

from __future__ import annotations

from collections.abc import Callable

from .._errors import ParameterError
from ._paper import TABLE_II, TABLE_V_RMS_RESIDUAL, table_v_friction
from ._params import (
    Cylinder,
    DeadZone,
    Load,
    Oil,
    ServoValve,
    Supply,
    SystemParams,
    ValveFlow,
    flow_coefficient_from_rating,
)

__all__ = ["PRESET_NOTES", "PRESETS", "get_preset", "paper_params"]


def paper_params() -> SystemParams:
    """The paper's rig (Tables II–V), with the documented errata decisions."""
    return SystemParams(
        valve=ServoValve(
            omega0=628.3, zeta=0.7, omega0_table=tuple((a, w) for a, w, _ in TABLE_II)
        ),
        dead_zone=DeadZone(alpha=1.0, beta=0.1, creep_slope=0.04, continuous=False),
        flow=ValveFlow(K=flow_coefficient_from_rating(40e-3 / 60.0, 70e5), transition_pressure=1e5),
        cylinder=Cylinder(
            area_a=1.3e-3,
            area_b=0.76e-3,
            stroke=0.2,
            dead_volume_a=0.7e-3,
            dead_volume_b=0.7e-3,
            leakage=0.0,
        ),
        oil=Oil(bulk_modulus=1e9),
        friction=table_v_friction(),
        supply=Supply(pressure=100e5, tank_pressure=0.0),
        load=Load(mass=1.394, force=0.0),
        meta={
            "source": "preset 'paper': Tables II-V of the paper",
            "friction": f"recovered from Table V by least squares, RMS residual {TABLE_V_RMS_RESIDUAL:.2f} N",
            "dead_volumes": "Table III prints 0.7 m^3; read as 0.7 L (docs/errata.md E2)",
            "K": "40 L/min at 70 bar (docs/errata.md E9)",
        },
    )


def symmetric_params() -> SystemParams:
    """The paper rig with equal piston areas (double-rod cylinder, A_A = A_B = Ā)."""
    p = paper_params()
    a = p.cylinder.mean_area
    return p.replace(**{"cylinder.area_a": a, "cylinder.area_b": a}).replace(
        meta={**p.meta, "source": "preset 'symmetric': paper rig with A_A = A_B = mean area"}
    )


#: The presets' ``meta`` notes → the dotted fields (a prefix) each is about: a file with
#: ``base`` that gives such a field does not inherit the note (its K is not "40 L/min at
#: 70 bar" any more).
PRESET_NOTES: dict[str, str] = {
    "friction": "friction.",
    "dead_volumes": "cylinder.dead_volume_",
    "K": "flow.K",
}

PRESETS: dict[str, Callable[[], SystemParams]] = {
    "paper": paper_params,
    "symmetric": symmetric_params,
}


def get_preset(name: str) -> SystemParams:
    """Return a built-in preset by name (``paper``, ``symmetric``)."""
    try:
        make = PRESETS[name]
    except KeyError:
        raise ParameterError(
            f"unknown preset {name!r}; choose one of {', '.join(PRESETS)}"
        ) from None
    return make().with_origin(lambda _: f"preset {name!r}")
