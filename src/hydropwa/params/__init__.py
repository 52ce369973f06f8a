"""Parameters: frozen, validated component objects in SI, TOML files, presets."""

from . import _params
from ._paper import (
    TABLE_II,
    TABLE_IV,
    TABLE_V,
    TABLE_V_AS_PRINTED,
    StribeckRecovery,
    recover_stribeck_from_table_v,
    table_v_friction,
    table_v_pwa,
)
from ._params import *  # noqa: F403  (the component classes, _params.__all__)
from ._presets import PRESET_NOTES, PRESETS, get_preset, paper_params
from ._toml import (
    FIELD_UNITS,
    PLAUSIBLE,
    SUPERSEDES,
    load_params,
    params_from_dict,
    params_to_toml,
    parse_quantity,
    save_params,
)

__all__ = [
    *_params.__all__,
    "FIELD_UNITS",
    "PLAUSIBLE",
    "PRESET_NOTES",
    "PRESETS",
    "SUPERSEDES",
    "StribeckRecovery",
    "TABLE_II",
    "TABLE_IV",
    "TABLE_V",
    "TABLE_V_AS_PRINTED",
    "get_preset",
    "load_params",
    "paper_params",
    "params_from_dict",
    "params_to_toml",
    "parse_quantity",
    "recover_stribeck_from_table_v",
    "save_params",
    "table_v_friction",
    "table_v_pwa",
]
