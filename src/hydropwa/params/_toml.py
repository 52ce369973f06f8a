"""TOML parameter files: the unit boundary of the parameter layer.

Values may be plain SI numbers or strings with units (``"100 bar"``,
``"40 L/min"``, ``"0.7 L"``, ``"10 %"``), parsed with pint here and nowhere else.
"""

from __future__ import annotations

import dataclasses
import math
import os
import tomllib
from collections.abc import Callable
from functools import lru_cache
from pathlib import Path
from typing import Any

import tomli_w

from .._errors import ParameterError
from .._io import atomic_write_text, read_text
from ._params import COMPONENT_TYPES, Cylinder, SystemParams, flow_coefficient_from_rating
from ._presets import PRESET_NOTES, PRESETS, get_preset

__all__ = [
    "load_params",
    "save_params",
    "params_to_toml",
    "params_from_dict",
    "parse_quantity",
    "FIELD_UNITS",
    "PLAUSIBLE",
    "SUPERSEDES",
]


#: SI unit of every numeric field, as a pint expression (None: not a quantity); declared next to
#: the fields, in each component class's ``UNITS``.
FIELD_UNITS: dict[str, dict[str, str | None]] = {
    name: dict(cls.UNITS) for name, cls in COMPONENT_TYPES.items()
}

_BAR = (("bar", 1e5), ("MPa", 1e6), ("psi", 6894.757))
_LITRE = (("L", 1e-3), ("cm³", 1e-6))
_MM = (("mm", 1e-3), ("cm", 1e-2))
_PER_BAR = (("L/min/bar", 1e-3 / 60 / 1e5),)
_PERCENT = (("%", 1e-2),)

#: Plausible SI magnitude of a bare (unitless) number per unit-bearing field, and the units a
#: user who wrote a number outside it most likely meant: (low, high, ((unit, SI factor), ...)).
#: A bare number whose magnitude is outside [low, high] is an error naming the likely unit
#: (zero reads alike in every unit and always passes); with a unit (``"100 bar"``) any value
#: the component accepts is taken as written. Every field of :data:`FIELD_UNITS` with a unit
#: has a row (tests/core/test_params_units.py checks it); the rows named ``a.b`` are keys
#: inside a field (the valve rating, the ω0 schedule's pairs) and the catalogue diameters.
PLAUSIBLE: dict[tuple[str, str], tuple[float, float, tuple[tuple[str, float], ...]]] = {
    # a bare ω0 is rad/s; a slow proportional valve has 10 Hz = 63 rad/s, so 40 is a frequency
    ("valve", "omega0"): (60.0, 2e4, (("Hz", 2.0 * math.pi),)),
    ("valve", "zeta"): (0.05, 5.0, _PERCENT),
    ("valve", "omega0_table.amplitude"): (1e-3, 1.5, _PERCENT),
    ("valve", "omega0_table.omega0"): (60.0, 2e4, (("Hz", 2.0 * math.pi),)),
    ("dead_zone", "alpha"): (0.0, 2.0, _PERCENT),
    ("dead_zone", "beta"): (0.0, 1.0, _PERCENT),
    ("dead_zone", "creep_slope"): (0.0, 1.0, _PERCENT),
    ("flow", "K"): (1e-10, 1e-4, (("L/min/bar**0.5", 1e-3 / 60 / math.sqrt(1e5)),)),
    ("flow", "rating.flow"): (1e-7, 1.0, (("L/min", 1e-3 / 60), ("L/s", 1e-3))),
    ("flow", "rating.pressure_drop"): (1e4, 1e8, _BAR),
    ("flow", "transition_pressure"): (1e2, 1e7, (("bar", 1e5),)),
    ("cylinder", "area_a"): (1e-6, 0.5, (("mm²", 1e-6), ("cm²", 1e-4))),
    ("cylinder", "area_b"): (1e-6, 0.5, (("mm²", 1e-6), ("cm²", 1e-4))),
    ("cylinder", "bore"): (1e-3, 2.0, _MM),
    ("cylinder", "rod"): (1e-3, 2.0, _MM),
    ("cylinder", "stroke"): (1e-3, 20.0, _MM),
    ("cylinder", "dead_volume_a"): (1e-9, 1.0, _LITRE),
    ("cylinder", "dead_volume_b"): (1e-9, 1.0, _LITRE),
    ("cylinder", "leakage"): (1e-18, 1e-7, _PER_BAR),
    ("cylinder", "end_stop_stiffness"): (1e4, 1e12, (("N/mm", 1e3), ("kN/mm", 1e6))),
    ("cylinder", "end_stop_damping"): (1.0, 1e9, (("kN*s/m", 1e3),)),
    ("oil", "bulk_modulus"): (1e7, 1e11, (("MPa", 1e6), ("GPa", 1e9), ("bar", 1e5))),
    ("oil", "density"): (300.0, 3000.0, (("g/cm³", 1e3),)),
    ("oil", "vapour_pressure"): (1e3, 1.01325e5, _BAR),
    ("oil", "release_pressure"): (1e2, 1e6, _BAR),
    ("friction", "coulomb"): (1e-3, 1e7, (("kN", 1e3),)),
    ("friction", "static"): (1e-3, 1e7, (("kN", 1e3),)),
    ("friction", "viscous"): (1e-3, 1e8, (("kN*s/m", 1e3),)),
    ("friction", "stribeck_velocity"): (1e-6, 1.0, (("mm/s", 1e-3),)),
    ("friction", "shape"): (0.05, 10.0, ()),
    ("friction", "smoothness"): (1.0, 1e8, (("s/mm", 1e3),)),
    ("supply", "pressure"): (1e5, 1e8, _BAR),
    ("supply", "tank_pressure"): (1e3, 1e8, _BAR),
    ("supply", "pump_flow"): (1e-6, 1.0, (("L/min", 1e-3 / 60), ("L/s", 1e-3))),
    ("supply", "compensator_droop"): (1e3, 1e8, _BAR[:2]),
    ("supply", "line_volume"): (1e-7, 1.0, _LITRE),
    ("supply", "relief_pressure"): (1e5, 1e8, _BAR),
    ("supply", "relief_gain"): (1e-16, 1e-4, _PER_BAR),
    ("load", "mass"): (1e-3, 1e6, (("t", 1e3),)),
    ("load", "force"): (1e-3, 1e8, (("kN", 1e3),)),
    ("load", "damping"): (1e-3, 1e9, (("kN*s/m", 1e3),)),
    ("accumulator", "gas_volume"): (1e-6, 1.0, _LITRE),
    ("accumulator", "precharge_pressure"): (1e4, 1e8, _BAR),
    ("accumulator", "polytropic_index"): (1.0, 1.67, ()),
    ("accumulator", "hose_length"): (1e-2, 100.0, _MM),
    ("accumulator", "hose_diameter"): (1e-4, 0.2, _MM),
    ("accumulator", "viscosity"): (1e-4, 10.0, (("mPa*s", 1e-3),)),
    ("lines", "volume_a"): (1e-9, 1.0, _LITRE),
    ("lines", "volume_b"): (1e-9, 1.0, _LITRE),
    ("lines", "conductance_a"): (1e-16, 1e-3, _PER_BAR),
    ("lines", "conductance_b"): (1e-16, 1e-3, _PER_BAR),
    ("lines", "bulk_modulus"): (1e6, 1e12, (("MPa", 1e6), ("GPa", 1e9))),
    # the valve's volt scale: ±10 V servo inputs, a null of millivolts (FASTER: 22 mV)
    ("valve", "command_voltage"): (0.1, 100.0, (("mV", 1e-3),)),
    ("valve", "null_voltage"): (1e-6, 10.0, (("mV", 1e-3),)),
    ("cylinder", "external_leakage_a"): (1e-18, 1e-7, _PER_BAR),
    ("cylinder", "external_leakage_b"): (1e-18, 1e-7, _PER_BAR),
    # a specimen: a rubber pad's 1e3 N/m to a steel block's 1e11 N/m
    ("load", "specimen_stiffness"): (1.0, 1e12, (("N/mm", 1e3), ("kN/mm", 1e6))),
    ("load", "specimen_damping"): (1e-3, 1e9, (("kN*s/m", 1e3),)),
    ("load", "contact_position"): (1e-5, 20.0, _MM),
    ("load", "preload"): (1e-3, 1e8, (("kN", 1e3),)),
}

#: Pint spellings of display units, for the example a hint writes.
_UNIT_TEXT = {"cm³": "cm**3", "mm²": "mm**2", "cm²": "cm**2", "g/cm³": "g/cm**3"}


def _bare_number(value: Any) -> float | None:
    """``value`` as a float if it is a bare number (or a numeric string), else None."""
    if isinstance(value, bool):
        return None
    if isinstance(value, str):
        try:
            value = float(value)
        except ValueError:
            return None  # it carries a unit
    if not isinstance(value, int | float) or not math.isfinite(value):
        return None
    return float(value)


def bare_is_plausible(comp: str, key: str, value: float) -> bool:
    """Whether the bare SI number ``value`` is plausible for ``comp.key`` (:data:`PLAUSIBLE`)."""
    lo, hi, _ = PLAUSIBLE[(comp, key)]
    return value == 0.0 or lo <= abs(value) <= hi


def _check_bare(comp: str, key: str, value: Any, unit: str, where: str) -> None:
    """Reject a bare number implausible for its field, naming the unit it was likely meant in."""
    number = _bare_number(value)
    if number is None or (comp, key) not in PLAUSIBLE or bare_is_plausible(comp, key, number):
        return  # a row for every field is checked by tests/core/test_params_inheritance.py
    lo, hi, candidates = PLAUSIBLE[(comp, key)]
    shown = _DISPLAY.get(unit, unit) or "1"
    guess = [u for u, f in candidates if lo <= abs(number) * f <= hi]
    name = key.rsplit(".", 1)[-1]
    hint = (
        f"; did you mean {number:g} {guess[0]}? write it with its unit, e.g. "
        f'{name} = "{number:g} {_UNIT_TEXT.get(guess[0], guess[0])}"'
        if guess
        else f'; write it with its unit, e.g. {name} = "{number:g} {shown}"'
    )
    raise ParameterError(
        f"{where} = {number:g} read as {number:g} {shown} is implausible for this field "
        f"(expected {lo:g} to {hi:g} {shown} as a bare SI number){hint}"
    )


#: Inheritance rules: a field a file gives → the fields of the base it supersedes. A file
#: with ``base = "paper"`` that gives ``[valve] omega0 = "40 Hz"`` and not ``omega0_table``
#: means a constant ω0, so the base's amplitude schedule (which would win, Table II) is
#: dropped — set to the field's default — and :attr:`SystemParams.provenance` says so. Every
#: other field is a single value: one given replaces the base's, one not given is inherited
#: and marked "base '<name>'". (``rating`` and ``bore``/``rod`` set K and both areas.)
SUPERSEDES: dict[str, tuple[str, ...]] = {
    "valve.omega0": ("valve.omega0_table",),
}


#: Units written next to SI numbers in saved files, for the human reader.
_DISPLAY = {
    "": "1",
    "m**3/s/Pa**0.5": "m³/(s·√Pa)",
    "m**2": "m²",
    "m**3": "m³",
    "m**3/s/Pa": "m³/(s·Pa)",
    "N*s/m": "N·s/m",
    "kg/m**3": "kg/m³",
    "m**3/s": "m³/s",
}


@lru_cache(maxsize=1)
def _ureg():
    import pint  # deferred: pint costs ~0.3 s at import

    ureg: Any = pint.UnitRegistry()
    ureg.define("percent_opening = 0.01 = pct")
    return ureg


def parse_quantity(value: Any, unit: str, where: str) -> float:
    """Convert a TOML value (number or string with unit) to a float in ``unit``.

    Parameters
    ----------
    value : float or str
        A plain number (taken as SI) or a string such as ``"100 bar"``.
    unit : str
        Target SI unit as a pint expression (``""`` for dimensionless).
    where : str
        Field name used in error messages.

    Returns
    -------
    float
        The value in SI units.
    """
    if isinstance(value, bool):
        raise ParameterError(
            f"{where} = {value!r} is a boolean; expected a number in {unit or '1'}"
        )
    if isinstance(value, int | float):
        return float(value)
    if not isinstance(value, str):
        raise ParameterError(f"{where} = {value!r} must be a number or a string with a unit")
    try:
        return float(value)
    except ValueError:
        pass
    import pint  # deferred: pint costs ~0.3 s at import

    ureg = _ureg()
    try:
        q = ureg.Quantity(value.strip().replace("%", " percent"))
        if isinstance(q, int | float):
            return float(q)
        if unit == "rad/s" and q.check("[frequency]") and "rad" not in str(q.units):
            # pint equates 1 Hz with 1 rad/s (radians are dimensionless); a frequency
            # in Hz given for an angular frequency means 2π rad per cycle.
            return float(2.0 * math.pi * q.to("Hz").magnitude)
        return float(q.to(unit or "dimensionless").magnitude)
    except pint.errors.DimensionalityError:
        raise ParameterError(
            f"{where} = {value!r} has the wrong dimension; expected a value convertible to "
            f"{_DISPLAY.get(unit, unit) or '1'}"
        ) from None
    except Exception:
        raise ParameterError(
            f"{where} = {value!r} cannot be read as a quantity; write e.g. '100 bar' or a plain SI number"
        ) from None


def params_from_dict(
    data: dict[str, Any], source: str = "<dict>", *, check_bare: bool = True
) -> SystemParams:
    """Build :class:`SystemParams` from a nested dict as read from TOML.

    Missing components and fields take the defaults of the dataclasses (or of the preset
    named by ``base``; :func:`load_params` requires every section of a file without
    ``base``). A field given supersedes the base's fields that :data:`SUPERSEDES` names
    (``omega0`` drops the base's ``omega0_table``); the result's
    :attr:`~SystemParams.provenance` marks each value "file", "base '<name>'", "default" or
    dropped, and the base's notes about fields the file gives are left out of ``meta``.
    The ``[flow]`` table may give
    ``rating = {flow = "60 L/min", pressure_drop = "70 bar", per = "valve"}`` instead of
    ``K`` (Eq. (8)): ``per = "valve"`` for a drop across the whole valve (both metering
    edges, the usual datasheet rating), ``per = "land"`` (default) across one edge.
    Bare numbers are SI, but one implausible for its field (:data:`PLAUSIBLE`:
    ``pressure = 100`` is 100 Pa, ``omega0 = 40`` is 6.4 Hz) is an error naming the likely
    unit — unless ``check_bare`` is False, for documents whose numbers are SI by their
    schema (a PWA JSON export holds the exact parameters it was built from, plausible or not).
    """
    if not isinstance(data, dict):
        raise ParameterError(
            f"{source}: a parameter document must be a table of sections, got {type(data).__name__}"
        )
    base = data.get("base")
    params = get_preset(str(base)) if base is not None else SystemParams()
    unknown = set(data) - set(COMPONENT_TYPES) - {"meta", "base", "uncertainty"}
    if unknown:
        raise ParameterError(
            f"{source}: unknown section(s) {', '.join(sorted(unknown))}; "
            f"known: {', '.join(COMPONENT_TYPES)}, meta, uncertainty"
        )
    changes: dict[str, Any] = {}
    given: set[str] = set()
    for comp in COMPONENT_TYPES:
        section = data.get(comp)
        if section is None:
            continue
        if not isinstance(section, dict):
            raise ParameterError(f"{source}: [{comp}] must be a table")
        kwargs = _section_fields(comp, section, source, check_bare)
        given |= {f"{comp}.{k}" for k in kwargs}
        dropped = _superseded(comp, kwargs)
        try:
            changes[comp] = dataclasses.replace(getattr(params, comp), **kwargs, **dropped)
        except ParameterError as exc:
            raise ParameterError(f"{source}: {exc}") from None
    meta = _inherited_notes(params.meta, given) if base is not None else {}
    if base is not None:
        meta["source"] = f"{source} (base {str(base)!r})"
    extra_meta = data.get("meta", {}) or {}
    if not isinstance(extra_meta, dict):
        raise ParameterError(f"{source}: [meta] must be a table, got {type(extra_meta).__name__}")
    meta.update(extra_meta)
    if "uncertainty" in data:
        meta["uncertainty"] = data["uncertainty"]
    result = dataclasses.replace(params, meta=meta, **changes)
    return result.with_origin(_origin_labels(params, given, base))


def _origin_labels(base_params: SystemParams, given: set[str], base: Any) -> Callable[[str], str]:
    """Dotted field name → where its value came from: the file, the base (or the class
    default, without ``base``), or dropped from the base by a :data:`SUPERSEDES` rule."""
    inherited = f"base {str(base)!r}" if base is not None else "default"
    drops = {t: f for f in sorted(given) for t in SUPERSEDES.get(f, ()) if t not in given}
    defaults = _defaults()

    def label(name: str) -> str:
        if name in given:
            return "file"
        comp, key = name.split(".", 1)
        was = getattr(getattr(base_params, comp), key)
        if name in drops and was != getattr(getattr(defaults, comp), key):
            return f"dropped from {inherited}: {drops[name]} given"
        return inherited

    return label


@lru_cache(maxsize=1)
def _defaults() -> SystemParams:
    """The class defaults of every field (frozen, so one instance serves)."""
    return SystemParams()


def _superseded(comp: str, kwargs: dict[str, Any]) -> dict[str, Any]:
    """The fields of ``comp`` that the given ``kwargs`` supersede (:data:`SUPERSEDES`), at
    their defaults."""
    defaults = getattr(_defaults(), comp)
    out: dict[str, Any] = {}
    for key in kwargs:
        for target in SUPERSEDES.get(f"{comp}.{key}", ()):
            t_comp, t_key = target.split(".", 1)
            if t_comp == comp and t_key not in kwargs:
                out[t_key] = getattr(defaults, t_key)
    return out


def _inherited_notes(meta: dict[str, Any], given: set[str]) -> dict[str, Any]:
    """The base's notes, less those about a field the file gives (:data:`PRESET_NOTES`)."""
    return {
        k: v
        for k, v in meta.items()
        if k != "source" and not any(f.startswith(PRESET_NOTES.get(k, "\0")) for f in given)
    }


def _section_fields(
    comp: str, section: dict[str, Any], source: str, check_bare: bool
) -> dict[str, Any]:
    """The fields of one section in SI (``K`` from a flow rating, areas from bore and rod)."""
    units = FIELD_UNITS[comp]
    kwargs: dict[str, Any] = {}
    for key, value in section.items():
        where = f"{source}: {comp}.{key}"
        if comp == "flow" and key == "rating":
            kwargs["K"] = _rated_flow_coefficient(value, where, check_bare)
            continue
        if comp == "cylinder" and key in ("bore", "rod"):
            # the cylinder as a catalogue names it: bore D and rod d (Eq. (9)'s areas)
            if check_bare:
                _check_bare(comp, key, value, "m", where)
            kwargs[f"_{key}"] = parse_quantity(value, "m", where)
            continue
        if key not in units:
            raise ParameterError(
                f"{where}: unknown field; known: {', '.join(units)}, or bore and rod"
            )
        unit = units[key]
        if key == "omega0_table":
            kwargs[key] = _omega0_table(value, where, check_bare)
        elif unit is None:
            kwargs[key] = value
        else:
            if check_bare:
                _check_bare(comp, key, value, unit, where)
            kwargs[key] = parse_quantity(value, unit, where)
    if "_bore" in kwargs or "_rod" in kwargs:
        kwargs.update(_areas_from_diameters(kwargs, source))
    return kwargs


def _omega0_table(value: Any, where: str, check_bare: bool) -> tuple[tuple[float, float], ...]:
    """[[amplitude, omega0], ...] with units → ((amplitude [1], ω0 [rad/s]), ...)."""
    try:
        pairs = [(a, w) for a, w in value]
    except (TypeError, ValueError):
        raise ParameterError(f"{where} must be a list of [amplitude, omega0] pairs") from None
    if check_bare:
        for a, w in pairs:
            _check_bare("valve", "omega0_table.amplitude", a, "", f"{where} amplitude")
            _check_bare("valve", "omega0_table.omega0", w, "rad/s", f"{where} omega0")
    return tuple(
        (parse_quantity(a, "", where), parse_quantity(w, "rad/s", where)) for a, w in pairs
    )


def _rated_flow_coefficient(value: Any, where: str, check_bare: bool = True) -> float:
    """K [m³/(s·√Pa)] from ``rating = {flow, pressure_drop, per}`` (Eq. (8))."""
    if not isinstance(value, dict) or {"flow", "pressure_drop"} - set(value):
        raise ParameterError(
            f'{where} must be a table such as {{flow = "60 L/min", pressure_drop = '
            f'"70 bar", per = "valve"}}'
        )
    extra = set(value) - {"flow", "pressure_drop", "per"}
    if extra:
        raise ParameterError(
            f"{where}: unknown key(s) {', '.join(sorted(extra))}; known: flow, pressure_drop, per"
        )
    per = value.get("per", "land")
    if per not in ("land", "valve"):
        raise ParameterError(
            f"{where}.per = {per!r} must be 'land' (drop across one metering edge) or "
            "'valve' (across the whole valve, P→A→B→T, as most datasheets rate it)"
        )
    if check_bare:
        _check_bare("flow", "rating.flow", value["flow"], "m**3/s", where + ".flow")
        _check_bare(
            "flow", "rating.pressure_drop", value["pressure_drop"], "Pa", where + ".pressure_drop"
        )
    qn = parse_quantity(value["flow"], "m**3/s", where + ".flow")
    pn = parse_quantity(value["pressure_drop"], "Pa", where + ".pressure_drop")
    return flow_coefficient_from_rating(qn, pn, per)


def _areas_from_diameters(kwargs: dict[str, Any], source: str) -> dict[str, float]:
    """``area_a``/``area_b`` from ``bore``/``rod`` (popped from ``kwargs``); both or neither."""
    bore, rod = kwargs.pop("_bore", None), kwargs.pop("_rod", None)
    if bore is None or rod is None:
        raise ParameterError(
            f"{source}: [cylinder] gives {'bore' if rod is None else 'rod'} without "
            f'{"rod" if rod is None else "bore"}; give both diameters, e.g. bore = "63 mm", '
            'rod = "36 mm"'
        )
    if "area_a" in kwargs or "area_b" in kwargs:
        raise ParameterError(
            f"{source}: [cylinder] gives both bore/rod and area_a/area_b; give one of the two"
        )
    return Cylinder.areas_from_diameters(bore, rod)


def load_params(path: str | os.PathLike) -> SystemParams:
    """Load a parameter TOML file (or a preset name such as ``"paper"``).

    Raises
    ------
    ParameterError
        If the file is missing, is not valid TOML, or holds invalid values.
    """
    if isinstance(path, str) and path in PRESETS and not Path(path).exists():
        return get_preset(path)
    p = Path(path)
    if not p.is_file():
        raise ParameterError(
            f"parameter file {str(p)!r} not found; give a TOML file or a preset ({', '.join(PRESETS)})"
        )
    try:
        data = tomllib.loads(read_text(p, "parameter file", ParameterError))
    except tomllib.TOMLDecodeError as exc:
        raise ParameterError(f"{p}: invalid TOML ({exc})") from None
    except RecursionError:  # tomllib recurses per nesting level ("a = [[[[...")
        raise ParameterError(f"{p}: nested too deeply to be a parameter file") from None
    if "base" not in data:
        # a component class with OPTIONAL = True (e.g. an accessory that defaults to absent)
        # may be left out of a complete file
        missing = [
            c
            for c, cls in COMPONENT_TYPES.items()
            if c not in data and not getattr(cls, "OPTIONAL", False)
        ]
        if missing:
            raise ParameterError(
                f"{p}: missing section(s) {', '.join(f'[{c}]' for c in missing)}; give them, or put "
                f'base = "paper" (a preset name) at the top to take the rest from it'
            )
        _check_machine_fields(data, p)
    return params_from_dict(data, source=str(p))


#: The fields that make a machine: a file without ``base`` states each (one of the names);
#: left out, the field's default (the paper rig's value) would be used in silence (issue 37).
MACHINE_FIELDS = (
    ("cylinder", ("area_a", "bore")),
    ("cylinder", ("area_b", "rod")),
    ("cylinder", ("stroke",)),
    ("load", ("mass",)),
    ("supply", ("pressure",)),
    ("flow", ("K", "rating")),
)


def _check_machine_fields(data: dict[str, Any], path: Path) -> None:
    """Refuse a file without ``base`` that leaves out a field of :data:`MACHINE_FIELDS`."""
    left = [
        f"{comp}.{names[0]}"
        for comp, names in MACHINE_FIELDS
        if isinstance(data.get(comp), dict) and not any(n in data[comp] for n in names)
    ]
    if left:
        raise ParameterError(
            f"{path}: {', '.join(left)} not given (the default would be the paper rig's); "
            f'give your machine\'s, or put base = "paper" at the top to take the rest from it'
        )


def _fmt(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        if math.isfinite(value) and value == int(value) and abs(value) < 1e15:
            return f"{value:.1f}"
        return repr(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        return tomli_w.dumps({"x": value}).split("=", 1)[1].strip()
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_fmt(v) for v in value) + "]"
    raise TypeError(f"cannot write {value!r} to TOML")


def params_to_toml(params: SystemParams, header: str = "") -> str:
    """Render parameters as a hand-editable TOML document (SI numbers, unit comments)."""
    lines = [
        '# hydropwa parameter file. Plain numbers are SI; strings with units ("100 bar") work too.'
    ]
    if header:
        lines += [f"# {h}" for h in header.splitlines()]
    for comp, cls in COMPONENT_TYPES.items():
        obj = getattr(params, comp)
        lines += ["", f"[{comp}]"]
        doc_units = FIELD_UNITS[comp]
        for f in dataclasses.fields(cls):
            val = getattr(obj, f.name)
            unit = doc_units[f.name]
            comment = f"  # {_DISPLAY.get(unit, unit)}" if unit is not None else ""
            if f.name == "omega0_table":
                comment = "  # [[|u| in 1, omega0 in rad/s], ...] (empty: constant omega0)"
                val = [
                    [
                        _si_value(comp, "omega0_table.amplitude", a, ""),
                        _si_value(comp, "omega0_table.omega0", w, "rad/s"),
                    ]
                    for a, w in val
                ]
            elif unit is not None:
                val = _si_value(comp, f.name, val, unit)
            lines.append(f"{f.name} = {_fmt(val)}{comment}")
    meta = {k: v for k, v in params.meta.items() if k != "uncertainty"}
    if meta:
        lines += ["", tomli_w.dumps({"meta": _plain(meta)}).strip()]
    if "uncertainty" in params.meta:
        lines += ["", tomli_w.dumps({"uncertainty": _plain(params.meta["uncertainty"])}).strip()]
    return "\n".join(lines) + "\n"


def _si_value(comp: str, key: str, value: Any, unit: str) -> Any:
    """``value`` as written to a file: the bare SI number, or, where a bare number would be
    refused as implausible (:data:`PLAUSIBLE`), a string with its SI unit, which reads back
    exactly."""
    if (
        not isinstance(value, float)
        or (comp, key) not in PLAUSIBLE
        or bare_is_plausible(comp, key, value)
    ):
        return value
    return f"{value!r} {unit or 'dimensionless'}"


def _plain(obj: Any) -> Any:
    """Make nested metadata TOML-serialisable (numpy scalars, tuples, None)."""
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items() if v is not None}
    if isinstance(obj, list | tuple):
        return [_plain(v) for v in obj if v is not None]
    if hasattr(obj, "item") and callable(obj.item):
        return obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return str(obj)
    return obj


def save_params(
    params: SystemParams, path: str | os.PathLike, header: str = "", *, overwrite: bool = False
) -> Path:
    """Write parameters to a TOML file atomically; :func:`load_params` reads it back exactly.

    An existing file raises :class:`~hydropwa.OutputExistsError` unless ``overwrite``.
    """
    return atomic_write_text(path, params_to_toml(params, header), overwrite=overwrite)
