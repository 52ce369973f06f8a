"""Unit handling at the data boundary.

Files declare units per channel; inside the package every channel is SI.
This module is the only place of the data layer that talks to pint.
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

import numpy as np

from hydropwa._channels import CHANNELS
from hydropwa._errors import DataError

if TYPE_CHECKING:
    import pint

__all__ = ["CANONICAL_UNITS", "si_unit_for", "to_si", "from_si", "convert_units", "normalize_unit"]

#: Canonical channel names and their SI units inside the package (the channel table,
#: :data:`hydropwa._channels.CHANNELS`).
CANONICAL_UNITS: dict[str, str] = {c.name: c.unit for c in CHANNELS}

# SI unit used for an extra (non-canonical) channel, chosen by dimensionality.
_PREFERRED_SI = (
    "1",
    "s",
    "m",
    "m/s",
    "m/s**2",
    "Pa",
    "N",
    "kg",
    "m**3/s",
    "m**3",
    "m**2",
    "V",
    "A",
    "W",
    "K",
    "N*s/m",
)

#: Units known to be valid without asking pint (a conversion between equal ones is the identity).
_KNOWN_SI = frozenset(CANONICAL_UNITS.values()) | frozenset(_PREFERRED_SI)

# Spellings that pint does not read, or reads differently from what engineers mean.
_ALIASES = {"": "1", "-": "1", "1": "1", "%": "percent", "lpm": "L/min", "l/min": "L/min"}


def _pint_errors():
    """pint's error classes (pint is imported by then: the registry was built)."""
    import pint  # deferred: see _registry

    return pint.errors


@functools.lru_cache(maxsize=1)
def _registry() -> pint.UnitRegistry:
    import pint  # deferred: pint costs ~0.3 s at import; SI channels never need it

    # pint's on-disk cache of its parsed definitions (in the user's cache folder) cuts the
    # registry's construction from ~0.15 s to ~0.05 s; without a writable folder, parse afresh
    try:
        return pint.UnitRegistry(cache_folder=":auto:")
    except Exception:  # pragma: no cover - pint's cache is an optimisation only
        return pint.UnitRegistry()


def normalize_unit(unit: str) -> str:
    """Return the spelling of ``unit`` used in files and ``Run.units`` (``"1"`` for none)."""
    text = str(unit).strip()
    return _ALIASES.get(text.lower(), text)


def _pint_unit(unit: str, where: str) -> pint.Unit:
    text = normalize_unit(unit)
    try:
        return _registry().Unit("dimensionless" if text == "1" else text)
    except Exception as exc:
        # pint's expression parser fails in many ways on arbitrary text (UndefinedUnitError,
        # DefinitionSyntaxError, tokenize.TokenError, ZeroDivisionError, RecursionError,
        # AssertionError, ...): every one of them means "not a unit".
        raise DataError(
            f"{where}: unknown unit {unit!r}; hint: use a unit pint understands, "
            "e.g. bar, Pa, MPa, psi, mm, m, mm/s, L/min, %, kN, N, V or 1"
        ) from exc


@functools.cache
def _preferred_by_dimension() -> dict[object, str]:
    return {_pint_unit(u, "SI table").dimensionality: u for u in _PREFERRED_SI}


def si_unit_for(channel: str, unit: str, where: str = "") -> str:
    """SI unit that ``channel`` carries inside the package.

    Parameters
    ----------
    channel : str
        Channel name; canonical channels have a fixed unit (:data:`CANONICAL_UNITS`).
    unit : str
        Unit declared in the file, used for extra channels to find the dimension.
    where : str
        Prefix for error messages (run and channel).

    Returns
    -------
    str
        The SI unit, e.g. ``"Pa"`` for ``"bar"``.
    """
    if channel in CANONICAL_UNITS:
        return CANONICAL_UNITS[channel]
    pu = _pint_unit(unit, where or f"channel {channel!r}")
    found = _preferred_by_dimension().get(pu.dimensionality)
    if found is not None:
        return found
    try:
        return f"{_registry().Quantity(1.0, pu).to_base_units().units:~}"
    except Exception as exc:  # OverflowError for 'bar**1e9', pint errors for odd units
        raise DataError(
            f"{where or f'channel {channel!r}'}: unit {unit!r} has no usable SI form ({exc}); "
            "hint: declare a physical unit such as bar, mm or K"
        ) from None


def convert_units(values, from_unit: str, to_unit: str, where: str = "") -> np.ndarray:
    """Convert ``values`` from ``from_unit`` to ``to_unit``.

    Parameters
    ----------
    values : array_like
        Values in ``from_unit``, any shape.
    from_unit, to_unit : str
        Units as pint reads them (``"%"``, ``"1"`` and ``"L/min"`` are accepted).
    where : str
        Prefix for error messages, e.g. ``"run 'r1', channel 'p_a'"``.

    Returns
    -------
    numpy.ndarray
        Values in ``to_unit`` as float64. Multiplicative units are scaled by one
        factor, so a factor of exactly one leaves the values bit for bit unchanged.

    Raises
    ------
    DataError
        If a unit is unknown or the dimensions differ.
    """
    where = where or "unit conversion"
    arr = np.asarray(values, dtype=float)
    if from_unit == to_unit and from_unit in _KNOWN_SI:
        return arr  # SI to the same SI unit: nothing to convert, and no pint to load
    src = _pint_unit(from_unit, where)
    dst = _pint_unit(to_unit, where)
    if src.dimensionality != dst.dimensionality:
        raise DataError(
            f"{where}: unit {from_unit!r} cannot be converted to {to_unit!r} "
            f"({src.dimensionality} vs {dst.dimensionality}); hint: declare the unit of the "
            "quantity this channel really holds"
        )
    if src == dst:
        return arr
    ureg = _registry()
    try:
        try:
            factor = float(ureg.Quantity(1.0, src).to(dst).magnitude)
            inverse = float(ureg.Quantity(1.0, dst).to(src).magnitude)
            zero = float(ureg.Quantity(0.0, src).to(dst).magnitude)
        except _pint_errors().OffsetUnitCalculusError:  # pragma: no cover - pint version dependent
            zero = float("nan")
        if zero == 0.0:
            if factor == 1.0:
                return arr
            # Scale by the factor that is >= 1 (exact for 1e3, 1e5, ...): 12.5 mm / 1000 is the
            # double nearest 0.0125 m, and SI -> bar -> SI round trips stay within one ulp.
            with np.errstate(over="ignore", under="ignore", invalid="ignore"):
                return arr * factor if abs(factor) >= 1.0 else arr / inverse
        return np.asarray(ureg.Quantity(arr, src).to(dst).magnitude, dtype=float)
    except (OverflowError, ZeroDivisionError, _pint_errors().PintError) as exc:
        raise DataError(
            f"{where}: cannot convert {from_unit!r} to {to_unit!r} ({exc}); "
            "hint: declare a physical unit such as bar, mm or K"
        ) from None


def to_si(values, unit: str, channel: str, where: str = "") -> tuple[np.ndarray, str]:
    """Convert one channel from its declared unit to the package's SI unit.

    Parameters
    ----------
    values : array_like
        Samples in ``unit``, shape (N,).
    unit : str
        Declared unit, e.g. ``"bar"``.
    channel : str
        Channel name (fixes the target unit of canonical channels).
    where : str
        Prefix for error messages.

    Returns
    -------
    values_si : numpy.ndarray
        Samples in SI, shape (N,).
    si_unit : str
        The SI unit.
    """
    where = where or f"channel {channel!r}"
    target = si_unit_for(channel, unit, where)
    return convert_units(values, unit, target, where), target


def from_si(values, channel: str, si_unit: str, unit: str, where: str = "") -> np.ndarray:
    """Convert a channel from its SI unit to ``unit`` for writing (inverse of :func:`to_si`)."""
    return convert_units(values, si_unit, unit, where or f"channel {channel!r}")
