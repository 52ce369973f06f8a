"""Parameters: frozen, validated component objects in SI, TOML files, presets."""

from ._paper import (
    TABLE_II,
    TABLE_IV,
    TABLE_V,
    TABLE_V_AS_PRINTED,
    StribeckRecovery,
    recover_stribeck_from_table_v,
    table_v_pwa,
)
from ._params import (
    Cylinder,
    DeadZone,
    Friction,
    Load,
    Oil,
    ServoValve,
    Supply,
    SystemParams,
    ValveFlow,
    flow_coefficient_from_rating,
)
from ._presets import PRESETS, get_preset, paper_params
from ._toml import (
    FIELD_UNITS,
    load_params,
    params_from_dict,
    params_to_toml,
    parse_quantity,
    save_params,
)

__all__ = [
    "Cylinder",
    "DeadZone",
    "FIELD_UNITS",
    "Friction",
    "Load",
    "Oil",
    "PRESETS",
    "ServoValve",
    "StribeckRecovery",
    "Supply",
    "SystemParams",
    "TABLE_II",
    "TABLE_IV",
    "TABLE_V",
    "TABLE_V_AS_PRINTED",
    "ValveFlow",
    "flow_coefficient_from_rating",
    "get_preset",
    "load_params",
    "paper_params",
    "params_from_dict",
    "params_to_toml",
    "parse_quantity",
    "recover_stribeck_from_table_v",
    "save_params",
    "table_v_pwa",
]
