"""Frozen, validated parameter objects, one per component, SI units inside.

Every field's docstring names its unit. Construction validates each field and
raises :class:`~hydropwa.ParameterError` naming the field, the value and the
unit. Units are converted only at the boundaries (TOML, CLI, data files).
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, ClassVar

import numpy as np

from .._display import engineering, html_table
from .._errors import ParameterError

__all__ = [
    "ServoValve",
    "DeadZone",
    "ValveFlow",
    "Cylinder",
    "Oil",
    "Friction",
    "Supply",
    "Load",
    "Accumulator",
    "Lines",
    "SystemParams",
    "flow_coefficient_from_rating",
]


def _check(
    obj: Any,
    name: str,
    unit: str,
    *,
    gt: float | None = None,
    ge: float | None = None,
    le: float | None = None,
    lt: float | None = None,
) -> None:
    """Validate one float field of a parameter object (finite, within bounds)."""
    label = f"{type(obj).__name__}.{name}"
    value = getattr(obj, name)
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(
            f"{label} = {value!r} is not a number (expected a value in {unit})"
        ) from None
    if not math.isfinite(v):
        raise ParameterError(f"{label} = {v} {unit} is not finite; give a finite value in {unit}")
    for bound, ok, word in (
        (gt, lambda b: v > b, "greater than"),
        (ge, lambda b: v >= b, "at least"),
        (le, lambda b: v <= b, "at most"),
        (lt, lambda b: v < b, "less than"),
    ):
        if bound is not None and not ok(bound):
            # enough digits that value and bound never print alike when they differ
            vs, bs = f"{v:g}", f"{bound:g}"
            if vs == bs and v != bound:
                vs, bs = f"{v:.15g}", f"{bound:.15g}"
            raise ParameterError(f"{label} = {vs} {unit} must be {word} {bs} {unit}")
    object.__setattr__(obj, name, v)


@dataclass(frozen=True, slots=True)
class ServoValve:
    """Closed-loop spool dynamics of the servo valve, Eq. (1)/(3) and Table II.

    Attributes
    ----------
    omega0 : float
        Natural frequency ω0 [rad/s] used when ``omega0_table`` is empty.
    zeta : float
        Damping ratio ζ [1].
    omega0_table : tuple of (float, float)
        Optional amplitude schedule ((|u| [1], ω0 [rad/s]), ...), sorted by
        amplitude (Table II). When given, ω0 is interpolated linearly at the
        amplitude of the command signal (peak |u| of the run), clamped at the
        ends.
    command_voltage : float
        Command voltage [V] that opens the valve fully (u = 1): the servo amplifier's full
        scale. 0 (default): commands are fractions [1]. Where it is set, a replayed command
        file (``simulate --input-file``) holds ``u`` in volts, read by :meth:`command_from_volts`.
    null_voltage : float
        Command voltage [V] at which the spool is centred (the valve's null bias).
    """

    #: SI unit of each field (a pint expression; None: not a quantity).
    UNITS: ClassVar[dict[str, str | None]] = {
        "omega0": "rad/s",
        "zeta": "",
        "omega0_table": None,
        "command_voltage": "V",
        "null_voltage": "V",
    }

    omega0: float = 628.3
    zeta: float = 0.7
    omega0_table: tuple[tuple[float, float], ...] = ()
    command_voltage: float = 0.0
    null_voltage: float = 0.0

    def __post_init__(self) -> None:
        _check(self, "omega0", "rad/s", gt=0.0)
        _check(self, "zeta", "1", gt=0.0, le=10.0)
        _check(self, "command_voltage", "V", ge=0.0, le=100.0)
        _check(self, "null_voltage", "V", ge=-100.0, le=100.0)
        if self.null_voltage != 0.0 and abs(self.null_voltage) >= self.command_voltage:
            raise ParameterError(
                f"ServoValve.null_voltage = {self.null_voltage:g} V needs a larger "
                f"ServoValve.command_voltage (now {self.command_voltage:g} V): the null bias "
                "lies inside the command range; set command_voltage to the full-scale voltage"
            )
        try:
            table = tuple((float(a), float(w)) for a, w in self.omega0_table)
        except (TypeError, ValueError):
            raise ParameterError(
                f"ServoValve.omega0_table = {self.omega0_table!r:.80} must be a sequence of "
                "(amplitude [1], omega0 [rad/s]) pairs"
            ) from None
        for a, w in table:
            if not (0.0 < a <= 1.5) or not (w > 0.0 and math.isfinite(w)):
                raise ParameterError(
                    f"ServoValve.omega0_table entry ({a:g}, {w:g}) needs 0 < amplitude <= 1.5 [1] "
                    "and omega0 > 0 [rad/s]"
                )
        if any(table[i + 1][0] <= table[i][0] for i in range(len(table) - 1)):
            raise ParameterError(
                "ServoValve.omega0_table amplitudes [1] must be strictly increasing"
            )
        object.__setattr__(self, "omega0_table", table)

    def command_from_volts(self, volts: np.ndarray) -> np.ndarray:
        """Valve command u [1] from a command in volts: (V − null_voltage)/command_voltage.

        Raises
        ------
        ParameterError
            If ``command_voltage`` is 0 (the machine takes fractional commands).
        """
        if self.command_voltage <= 0.0:
            raise ParameterError(
                "ServoValve.command_voltage is 0: the machine takes commands as fractions [1]; "
                "set [valve] command_voltage (the full-scale voltage [V]) to read volts"
            )
        return (np.asarray(volts, dtype=float) - self.null_voltage) / self.command_voltage

    def omega0_at(self, amplitude: float) -> float:
        """ω0 [rad/s] for a command amplitude |u| [1] (Table II schedule or constant)."""
        if not self.omega0_table:
            return self.omega0
        amps = [a for a, _ in self.omega0_table]
        ws = [w for _, w in self.omega0_table]
        a = abs(float(amplitude))
        if a <= amps[0]:
            return ws[0]
        if a >= amps[-1]:
            return ws[-1]
        for i in range(len(amps) - 1):
            if amps[i] <= a <= amps[i + 1]:
                s = (a - amps[i]) / (amps[i + 1] - amps[i])
                return ws[i] + s * (ws[i + 1] - ws[i])
        return ws[-1]  # pragma: no cover


@dataclass(frozen=True, slots=True)
class DeadZone:
    """Spool overlap (dead band) and saturation, Eq. (2)/(4) and Table IV.

    Attributes
    ----------
    alpha : float
        Saturation α [1]: the largest orifice opening z.
    beta : float
        Dead-band half width β [1] (fraction of full spool travel).
    creep_slope : float
        Slope k_g [1] inside the dead band (Table IV cell III, Sec. VI-B creep).
    continuous : bool
        If False (default, as Table IV prints it), z = u − β·sign(u) outside the
        band, which leaves a jump of ``creep_slope·beta`` at |u| = β. If True,
        the outer cells are shifted so that z is continuous.
    """

    #: SI unit of each field (a pint expression; None: not a quantity).
    UNITS: ClassVar[dict[str, str | None]] = {
        "alpha": "",
        "beta": "",
        "creep_slope": "",
        "continuous": None,
    }

    alpha: float = 1.0
    beta: float = 0.1
    creep_slope: float = 0.04
    continuous: bool = False

    def __post_init__(self) -> None:
        _check(self, "alpha", "1", gt=0.0, le=2.0)
        _check(self, "beta", "1", ge=0.0, lt=1.0)
        _check(self, "creep_slope", "1", ge=0.0, lt=1.0)
        # bool("false") is True: accept only real booleans (and numpy bools), never strings.
        if not isinstance(self.continuous, bool | np.bool_):
            raise ParameterError(
                f"DeadZone.continuous = {self.continuous!r} must be true or false (a boolean)"
            )
        object.__setattr__(self, "continuous", bool(self.continuous))

    @property
    def outer_offset(self) -> float:
        """Offset [1] of the outer linear cells: β, or β(1 − creep) if continuous."""
        return self.beta * (1.0 - self.creep_slope) if self.continuous else self.beta

    @property
    def saturation_input(self) -> float:
        """Command |u| [1] at which the opening saturates at α."""
        return self.alpha + self.outer_offset


def flow_coefficient_from_rating(
    nominal_flow: float, nominal_pressure_drop: float, per: str = "land"
) -> float:
    """Valve flow coefficient K from a datasheet rating, Eq. (8).

    Parameters
    ----------
    nominal_flow : float
        Rated flow Q_n [m³/s] at full opening.
    nominal_pressure_drop : float
        Pressure drop p_n [Pa] at which Q_n is rated.
    per : {"land", "valve"}
        What ``nominal_pressure_drop`` is across. ``"land"`` (default): one metering
        edge, the drop K multiplies in Eqs. (5)–(6). ``"valve"``: both edges in series
        (P→A and B→T), as most datasheets state it ("60 L/min at 70 bar valve
        pressure drop" = 35 bar per land), so each edge sees p_n/2.

    Returns
    -------
    float
        K = Q_n / √p_land [m³/(s·√Pa)], with p_land = p_n (``per="land"``) or
        p_n/2 (``per="valve"``).

    Notes
    -----
    K is per metering edge: Q_A = z·K·√(P_S − P_A) (Eq. (5)). The paper's
    K = 0.252e-6 m³/(s·√Pa) is 40 L/min over √(70 bar) taken per land (docs/errata.md E9);
    the same rating read per valve gives √2 more flow per edge.
    """
    if per not in ("land", "valve"):
        raise ParameterError(f"valve rating per = {per!r} must be 'land' or 'valve'")
    if not (nominal_flow > 0 and math.isfinite(nominal_flow)):
        raise ParameterError(f"nominal flow {nominal_flow!r} m³/s must be positive and finite")
    if not (nominal_pressure_drop > 0 and math.isfinite(nominal_pressure_drop)):
        raise ParameterError(
            f"nominal pressure drop {nominal_pressure_drop!r} Pa must be positive and finite"
        )
    per_land = nominal_pressure_drop if per == "land" else 0.5 * nominal_pressure_drop
    return nominal_flow / math.sqrt(per_land)


@dataclass(frozen=True, slots=True)
class ValveFlow:
    """Turbulent orifice flow of the valve, Eqs. (5)–(8).

    Attributes
    ----------
    K : float
        Flow coefficient K [m³/(s·√Pa)] per metering edge at full opening.
    transition_pressure : float
        Pressure drop p_tr [Pa] below which the square root is replaced by a
        cubic laminar law with the same value and slope at p_tr (docs/errata.md E3).
    """

    #: SI unit of each field (a pint expression; None: not a quantity).
    UNITS: ClassVar[dict[str, str | None]] = {
        "K": "m**3/s/Pa**0.5",
        "transition_pressure": "Pa",
    }
    K: float = flow_coefficient_from_rating(40e-3 / 60.0, 70e5)
    transition_pressure: float = 1e5

    def __post_init__(self) -> None:
        _check(self, "K", "m³/(s·√Pa)", gt=0.0, lt=1e-2)
        _check(self, "transition_pressure", "Pa", gt=0.0, le=1e7)


@dataclass(frozen=True, slots=True)
class Cylinder:
    """Single-rod cylinder, its chambers and end stops, Eqs. (9)–(10) and Table III.

    Attributes
    ----------
    area_a : float
        Piston-side area A_A [m²].
    area_b : float
        Rod-side (annulus) area A_B [m²].
    stroke : float
        Stroke l [m]; the rod moves in 0 <= x <= l.
    dead_volume_a : float
        Oil volume V_A [m³] between valve and chamber A at x = 0.
    dead_volume_b : float
        Oil volume V_B [m³] between valve and chamber B at x = l.
    leakage : float
        Internal leakage coefficient C_L [m³/(s·Pa)] across the piston.
    end_stop_stiffness : float
        Contact stiffness [N/m] of the end stops (penalty force outside 0..l).
    end_stop_damping : float
        Contact damping [N·s/m] of the end stops (acts only while in contact).
    external_leakage_a, external_leakage_b : float
        External leakage coefficients C_eA, C_eB [m³/(s·Pa)] of chamber A and B to the
        ambient (worn rod or port seals), Q_e = C_e·P (0: tight, as in the paper).
    """

    #: SI unit of each field (a pint expression; None: not a quantity).
    UNITS: ClassVar[dict[str, str | None]] = {
        "area_a": "m**2",
        "area_b": "m**2",
        "stroke": "m",
        "dead_volume_a": "m**3",
        "dead_volume_b": "m**3",
        "leakage": "m**3/s/Pa",
        "end_stop_stiffness": "N/m",
        "end_stop_damping": "N*s/m",
        "external_leakage_a": "m**3/s/Pa",
        "external_leakage_b": "m**3/s/Pa",
    }

    area_a: float = 1.3e-3
    area_b: float = 0.76e-3
    stroke: float = 0.2
    dead_volume_a: float = 0.7e-3
    dead_volume_b: float = 0.7e-3
    leakage: float = 0.0
    end_stop_stiffness: float = 1e8
    end_stop_damping: float = 2e4
    external_leakage_a: float = 0.0
    external_leakage_b: float = 0.0

    @staticmethod
    def areas_from_diameters(bore: float, rod: float) -> dict[str, float]:
        """``{"area_a": πD²/4, "area_b": π(D² − d²)/4}`` for bore D and rod diameter d [m].

        Raises
        ------
        ParameterError
            Unless 0 < d < D and both are finite.
        """
        if not (math.isfinite(bore) and math.isfinite(rod) and 0.0 < rod < bore):
            raise ParameterError(
                f"cylinder bore {bore * 1e3:g} mm and rod {rod * 1e3:g} mm: need "
                "0 < rod < bore (diameters, e.g. bore 63 mm, rod 36 mm)"
            )
        return {"area_a": math.pi * bore**2 / 4.0, "area_b": math.pi * (bore**2 - rod**2) / 4.0}

    @classmethod
    def from_diameters(cls, bore: float, rod: float, stroke: float, **fields: float) -> Cylinder:
        """A cylinder by bore D, rod diameter d and stroke l [m], as a catalogue gives it.

        A_A = πD²/4 and A_B = π(D² − d²)/4 (Eq. (9)'s areas); ``fields`` sets the rest
        (dead volumes, leakage, end stops). TOML: ``bore = "63 mm"``, ``rod = "36 mm"``.
        """
        return cls(**cls.areas_from_diameters(bore, rod), stroke=stroke, **fields)

    def __post_init__(self) -> None:
        _check(self, "area_a", "m²", gt=0.0, lt=1.0)
        _check(self, "area_b", "m²", gt=0.0, lt=1.0)
        _check(self, "stroke", "m", gt=0.0, le=20.0)
        _check(self, "dead_volume_a", "m³", gt=0.0)
        _check(self, "dead_volume_b", "m³", gt=0.0)
        _check(self, "leakage", "m³/(s·Pa)", ge=0.0, lt=1e-6)
        _check(self, "end_stop_stiffness", "N/m", gt=0.0)
        _check(self, "end_stop_damping", "N·s/m", ge=0.0)
        _check(self, "external_leakage_a", "m³/(s·Pa)", ge=0.0, lt=1e-6)
        _check(self, "external_leakage_b", "m³/(s·Pa)", ge=0.0, lt=1e-6)
        if self.area_b > self.area_a * (1.0 + 1e-9):
            raise ParameterError(
                f"Cylinder.area_b = {self.area_b:g} m² exceeds Cylinder.area_a = {self.area_a:g} m²; "
                "A is the piston side and B the rod-side annulus (A_B = A_A − rod area): "
                "are the two areas swapped?"
            )
        swept = self.area_a * self.stroke
        for name in ("dead_volume_a", "dead_volume_b"):
            v = getattr(self, name)
            if v > 100.0 * swept:
                warnings.warn(
                    f"Cylinder.{name} = {v:g} m³ is {v / swept:.0f}× the cylinder volume "
                    f"({swept:.3g} m³); did you mean {v:g} L = {v * 1e-3:g} m³? (docs/errata.md E2)",
                    UserWarning,
                    stacklevel=3,
                )

    @property
    def mean_area(self) -> float:
        """Averaged piston area Ā = (A_A + A_B)/2 [m²], Eq. (14)."""
        return 0.5 * (self.area_a + self.area_b)

    @property
    def total_volume(self) -> float:
        """Total actuator volume V_t = V_A + V_B [m³], Eq. (14)."""
        return self.dead_volume_a + self.dead_volume_b


@dataclass(frozen=True, slots=True)
class Oil:
    """Hydraulic oil, Eq. (9).

    Attributes
    ----------
    bulk_modulus : float
        Effective bulk modulus E [Pa].
    density : float
        Density ρ [kg/m³] (informational; K already contains it, Eq. (7)).
    vapour_pressure : float
        Gauge pressure [Pa] (relative to the tank, about −1 bar = absolute zero)
        that a chamber can approach but never cross.
    release_pressure : float
        Gauge pressure [Pa] below which dissolved air makes the oil compliant:
        between ``vapour_pressure`` and ``release_pressure`` the effective bulk
        modulus falls linearly to 0.1 % of E, so pressures stay physical.
    """

    #: SI unit of each field (a pint expression; None: not a quantity).
    UNITS: ClassVar[dict[str, str | None]] = {
        "bulk_modulus": "Pa",
        "density": "kg/m**3",
        "vapour_pressure": "Pa",
        "release_pressure": "Pa",
    }

    bulk_modulus: float = 1e9
    density: float = 870.0
    vapour_pressure: float = -0.95e5
    release_pressure: float = 0.0

    def __post_init__(self) -> None:
        _check(self, "bulk_modulus", "Pa", gt=1e5, lt=1e11)
        _check(self, "density", "kg/m³", gt=100.0, lt=3000.0)
        _check(self, "vapour_pressure", "Pa", ge=-1.01325e5, le=0.0)
        _check(self, "release_pressure", "Pa", le=1e6)
        if self.release_pressure <= self.vapour_pressure:
            raise ParameterError(
                f"Oil.release_pressure = {self.release_pressure:g} Pa must be above "
                f"Oil.vapour_pressure = {self.vapour_pressure:g} Pa"
            )


@dataclass(frozen=True, slots=True)
class Friction:
    """Stribeck friction with a tanh sign, Eq. (11).

    Attributes
    ----------
    coulomb : float
        Coulomb friction F_c [N].
    static : float
        Static (stiction) friction F_s [N], F_s >= F_c.
    viscous : float
        Viscous coefficient σ [N·s/m].
    stribeck_velocity : float
        Stribeck velocity χ [m/s].
    shape : float
        Stribeck exponent δ [1].
    smoothness : float
        tanh slope γ [s/m] of the zero crossing.
    """

    #: SI unit of each field (a pint expression; None: not a quantity).
    UNITS: ClassVar[dict[str, str | None]] = {
        "coulomb": "N",
        "static": "N",
        "viscous": "N*s/m",
        "stribeck_velocity": "m/s",
        "shape": "",
        "smoothness": "s/m",
    }

    coulomb: float = 90.0
    static: float = 150.0
    viscous: float = 1100.0
    stribeck_velocity: float = 0.01
    shape: float = 1.0
    smoothness: float = 1e4

    def __post_init__(self) -> None:
        _check(self, "coulomb", "N", ge=0.0)
        _check(self, "static", "N", ge=0.0)
        _check(self, "viscous", "N·s/m", ge=0.0)
        _check(self, "stribeck_velocity", "m/s", gt=0.0)
        _check(self, "shape", "1", gt=0.0, le=10.0)
        _check(self, "smoothness", "s/m", gt=0.0, le=1e8)
        if self.static < self.coulomb:
            raise ParameterError(
                f"Friction.static = {self.static:g} N must be at least Friction.coulomb = "
                f"{self.coulomb:g} N (Eq. (11) needs F_s >= F_c)"
            )

    @classmethod
    def none(cls) -> Friction:
        """Friction switched off (all forces zero)."""
        return cls(coulomb=0.0, static=0.0, viscous=0.0)


@dataclass(frozen=True, slots=True)
class Supply:
    """Supply and tank pressures, and an optional pump model (Fig. 9).

    Attributes
    ----------
    pressure : float
        Supply pressure P_S [Pa] (set value; the default input of every model).
    tank_pressure : float
        Tank pressure P_T [Pa].
    model : str
        ``"ideal"``: P_S is an input signal. ``"pump"``: P_S is a state fed by a
        pressure-compensated pump into the line volume and drawn by the valve,
        so it sags with flow (the virtual rig uses this).
    pump_flow : float
        Maximum pump flow [m³/s] (pump model).
    compensator_droop : float
        Pressure below the set value [Pa] at which the compensator delivers
        the full pump flow (pump model); the steady sag is droop·Q/Q_max.
    line_volume : float
        Oil volume [m³] of the supply line between pump and valve (pump model).
    relief_pressure : float
        Relief valve cracking pressure [Pa] (pump model).
    relief_gain : float
        Relief valve flow gain [m³/(s·Pa)] above the cracking pressure.
    """

    #: SI unit of each field (a pint expression; None: not a quantity).
    UNITS: ClassVar[dict[str, str | None]] = {
        "pressure": "Pa",
        "tank_pressure": "Pa",
        "model": None,
        "pump_flow": "m**3/s",
        "compensator_droop": "Pa",
        "line_volume": "m**3",
        "relief_pressure": "Pa",
        "relief_gain": "m**3/s/Pa",
    }

    pressure: float = 100e5
    tank_pressure: float = 0.0
    model: str = "ideal"
    pump_flow: float = 120e-3 / 60.0
    compensator_droop: float = 15e5
    line_volume: float = 1.0e-3
    relief_pressure: float = 120e5
    relief_gain: float = 1e-9

    def __post_init__(self) -> None:
        _check(self, "pressure", "Pa", gt=0.0, le=1e9)
        _check(self, "tank_pressure", "Pa", ge=-1.01325e5, le=1e8)
        if self.model not in ("ideal", "pump"):
            raise ParameterError(f"Supply.model = {self.model!r} must be 'ideal' or 'pump'")
        _check(self, "pump_flow", "m³/s", gt=0.0)
        _check(self, "compensator_droop", "Pa", gt=0.0)
        _check(self, "line_volume", "m³", gt=0.0)
        _check(self, "relief_pressure", "Pa", gt=0.0)
        _check(self, "relief_gain", "m³/(s·Pa)", gt=0.0)
        if self.pressure <= self.tank_pressure:
            raise ParameterError(
                f"Supply.pressure = {self.pressure:g} Pa must exceed Supply.tank_pressure = "
                f"{self.tank_pressure:g} Pa"
            )


@dataclass(frozen=True, slots=True)
class Load:
    """Moving mass and external load, Eq. (10).

    Attributes
    ----------
    mass : float
        Total moving mass m [kg].
    force : float
        Constant external load force F_L [N] (positive opposes extension);
        a time signal given to ``simulate`` overrides it.
    damping : float
        Viscous damping c [N·s/m] of an attached load, e.g. the pressure-controlled
        counter cylinder of the rig: the load is F_L(t) + c·ẋ and the force sensor
        (channel ``f_l``) measures that sum. 0 for a free rod.
    specimen_stiffness : float
        Stiffness k [N/m] of a specimen, tool or spring the rod meets
        (:func:`~hydropwa.components.specimen_force`); 0 (default): none. A rigid wall is a
        stiff one (about the end stops' stiffness).
    specimen_damping : float
        Damping c [N·s/m] of that specimen (acts only in contact).
    contact_position : float
        Rod position x_c [m] at which the rod meets the specimen; it pushes back only while
        x > x_c. At or below the stroke start (x_c ≤ 0) the spring is attached: it acts at
        every position and pulls as well as pushes.
    preload : float
        Specimen force F_0 [N] at the contact position (≥ 0 for a contact; an attached
        spring may have F_0 < 0, which puts its rest position x_c − F_0/k inside the stroke).
    """

    #: SI unit of each field (a pint expression; None: not a quantity).
    UNITS: ClassVar[dict[str, str | None]] = {
        "mass": "kg",
        "force": "N",
        "damping": "N*s/m",
        "specimen_stiffness": "N/m",
        "specimen_damping": "N*s/m",
        "contact_position": "m",
        "preload": "N",
    }

    mass: float = 1.394
    force: float = 0.0
    damping: float = 0.0
    specimen_stiffness: float = 0.0
    specimen_damping: float = 0.0
    contact_position: float = 0.0
    preload: float = 0.0

    def __post_init__(self) -> None:
        _check(self, "mass", "kg", gt=0.0)
        _check(self, "force", "N")
        _check(self, "damping", "N·s/m", ge=0.0)
        # above 1e12 N/m the contact's period (√(m/k) ≈ 1 µs at 1 kg) is far below any step
        _check(self, "specimen_stiffness", "N/m", ge=0.0, le=1e12)
        _check(self, "specimen_damping", "N·s/m", ge=0.0)
        _check(self, "contact_position", "m", gt=-10.0, lt=10.0)
        _check(self, "preload", "N")
        if self.contact_position > 0.0 and self.preload < 0.0:
            raise ParameterError(
                f"Load.preload = {self.preload:g} N is negative for a contact at "
                f"Load.contact_position = {self.contact_position:g} m: a contact only pushes; "
                "give a preload >= 0, or contact_position <= 0 for an attached spring"
            )


@dataclass(frozen=True, slots=True)
class Accumulator:
    """Gas accumulator on port A, connected by a hose (not in the paper).

    A hydro-pneumatic (bladder or piston) accumulator on the A line adds compliance to
    chamber A: users with long hoses or an accumulator for shock damping see a lower
    hydraulic natural frequency. Its pressure P_acc is a state of the full-order model,
    fed by laminar flow through the hose (:func:`~hydropwa.components.hose_flow`) and
    stored by the gas (:func:`~hydropwa.components.accumulator_pressure_rate`). The
    reduced and PWA models do not include it. ``gas_volume = 0`` (default): no accumulator.

    Attributes
    ----------
    gas_volume : float
        Gas volume V_0 at the precharge [m³] (nominal size; 0: none).
    precharge_pressure : float
        Gas precharge P_0 [Pa] (gauge), typically 60–90 % of the lowest working pressure.
    polytropic_index : float
        n [1] of P V^n = const: 1.0 isothermal, 1.4 adiabatic (fast cycles).
    hose_length : float
        Length of the hose between port A and the accumulator [m].
    hose_diameter : float
        Inner diameter of the hose [m].
    viscosity : float
        Dynamic viscosity μ of the oil [Pa·s] (ISO VG 46 at 40 °C: about 0.04).
    """

    #: A parameter file may leave the section out (no accumulator).
    OPTIONAL: ClassVar[bool] = True
    #: SI unit of each field (a pint expression; None: not a quantity).
    UNITS: ClassVar[dict[str, str | None]] = {
        "gas_volume": "m**3",
        "precharge_pressure": "Pa",
        "polytropic_index": "",
        "hose_length": "m",
        "hose_diameter": "m",
        "viscosity": "Pa*s",
    }

    gas_volume: float = 0.0
    precharge_pressure: float = 50e5
    polytropic_index: float = 1.4
    hose_length: float = 2.0
    hose_diameter: float = 0.01
    viscosity: float = 0.04

    def __post_init__(self) -> None:
        _check(self, "gas_volume", "m³", ge=0.0, le=1.0)
        _check(self, "precharge_pressure", "Pa", gt=0.0, le=1e8)
        _check(self, "polytropic_index", "1", ge=1.0, le=1.67)
        _check(self, "hose_length", "m", gt=0.0, le=100.0)
        _check(self, "hose_diameter", "m", gt=1e-4, le=0.2)
        _check(self, "viscosity", "Pa·s", gt=1e-4, le=10.0)

    @property
    def hose_volume(self) -> float:
        """Oil volume of the hose π d² L / 4 [m³]."""
        return math.pi * self.hose_diameter**2 * self.hose_length / 4.0


@dataclass(frozen=True, slots=True)
class Lines:
    """Hose lines between the valve's ports and the chambers (not in the paper).

    Each line is a volume with its own pressure P_line (a state of the ``full-lines`` model):
    the valve's metering edges see the line pressure, and the line feeds its chamber through a
    resistance, laminar (Q = G ΔP) or an orifice (laminar below the valve's transition
    pressure P_tr with the same conductance G at small drops,
    :func:`~hydropwa.components.line_flow`). The oil in the line is stiffened by the oil's
    bulk modulus and softened by the hose wall's in series
    (:func:`~hydropwa.components.series_bulk_modulus`). A line of zero volume is no line: that
    port connects straight to its chamber (the default: no lines).

    Attributes
    ----------
    volume_a, volume_b : float
        Oil volume of the line on port A / B [m³] (0: no line).
    conductance_a, conductance_b : float
        Conductance G of the resistance between line and chamber [m³/(s·Pa)]; needed (> 0)
        where the line has a volume.
    bulk_modulus : float
        Bulk modulus of the hose wall [Pa], in series with the oil's; 0: a rigid line.
    orifice : bool
        The resistance is an orifice (square-root law above P_tr) instead of laminar.
    """

    #: A parameter file may leave the section out (no lines).
    OPTIONAL: ClassVar[bool] = True
    #: SI unit of each field (a pint expression; None: not a quantity).
    UNITS: ClassVar[dict[str, str | None]] = {
        "volume_a": "m**3",
        "volume_b": "m**3",
        "conductance_a": "m**3/s/Pa",
        "conductance_b": "m**3/s/Pa",
        "bulk_modulus": "Pa",
        "orifice": None,
    }

    volume_a: float = 0.0
    volume_b: float = 0.0
    conductance_a: float = 0.0
    conductance_b: float = 0.0
    bulk_modulus: float = 0.0
    orifice: bool = False

    def __post_init__(self) -> None:
        for side in ("a", "b"):
            _check(self, f"volume_{side}", "m³", ge=0.0, le=1.0)
            _check(self, f"conductance_{side}", "m³/(s·Pa)", ge=0.0, le=1e-3)
            if (
                getattr(self, f"volume_{side}") > 0.0
                and getattr(self, f"conductance_{side}") <= 0.0
            ):
                raise ParameterError(
                    f"Lines.conductance_{side} = 0 m³/(s·Pa) with a line volume on port "
                    f"{side.upper()}: give the conductance of the line's resistance (a 10 mm "
                    "hose of 1 m with oil of 0.04 Pa·s: about 6e-9 m³/(s·Pa)), or volume 0 "
                    "for no line"
                )
        _check(self, "bulk_modulus", "Pa", ge=0.0, le=1e12)
        if not isinstance(self.orifice, bool):
            raise ParameterError(f"Lines.orifice = {self.orifice!r} must be true or false")

    @property
    def present(self) -> bool:
        """Whether either port has a line (a volume above zero)."""
        return self.volume_a > 0.0 or self.volume_b > 0.0


@dataclass(frozen=True, slots=True)
class SystemParams:
    """All parameters of one valve-controlled cylinder (the three models share it).

    Attributes
    ----------
    valve : ServoValve
    dead_zone : DeadZone
    flow : ValveFlow
    cylinder : Cylinder
    oil : Oil
    friction : Friction
    supply : Supply
    load : Load
    accumulator : Accumulator
        Optional gas accumulator on port A (none by default).
    lines : Lines
        Optional hose lines between the valve's ports and the chambers (none by default).
    meta : dict
        Free-form notes (not used by the physics).
    origin : mapping
        Where each value was read from, as recorded by the loader: dotted field name
        (``"valve.omega0"``) → (source, value at loading). Empty for a set built in Python.
        Read it through :attr:`provenance`, which also notices values changed since.
    """

    valve: ServoValve = field(default_factory=ServoValve)
    dead_zone: DeadZone = field(default_factory=DeadZone)
    flow: ValveFlow = field(default_factory=ValveFlow)
    cylinder: Cylinder = field(default_factory=Cylinder)
    oil: Oil = field(default_factory=Oil)
    friction: Friction = field(default_factory=Friction)
    supply: Supply = field(default_factory=Supply)
    load: Load = field(default_factory=Load)
    accumulator: Accumulator = field(default_factory=Accumulator)
    lines: Lines = field(default_factory=Lines)
    meta: dict = field(default_factory=dict, compare=False, hash=False)
    origin: Mapping[str, tuple[str, Any]] = field(
        default_factory=dict, compare=False, hash=False, repr=False
    )

    def __post_init__(self) -> None:
        for name, cls in COMPONENT_TYPES.items():
            if not isinstance(getattr(self, name), cls):
                raise ParameterError(
                    f"SystemParams.{name} must be a {cls.__name__}, got {type(getattr(self, name)).__name__}"
                )

    def carries(self, component: str | None) -> bool:
        """Whether these parameters hold the optional part ``component`` (a field name whose
        group has a ``present`` property, ``"lines"``); ``None`` (a part every machine has) is
        always carried. What :attr:`hydropwa._layout.ModelKind.component` and
        :attr:`hydropwa._channels.Channel.component` name."""
        if component is None:
            return True
        group: Any = getattr(self, component, None)
        if not hasattr(group, "present"):
            raise ParameterError(
                f"{component!r} is not an optional part of SystemParams; the optional parts are "
                + ", ".join(n for n in COMPONENT_TYPES if hasattr(COMPONENT_TYPES[n], "present"))
            )
        return bool(group.present)

    @property
    def provenance(self) -> Mapping[str, str]:
        """Where every value came from: dotted field name → source, read-only.

        Sources are those the loader recorded (``"file"``, ``"base 'paper'"``,
        ``"preset 'paper'"``, ``"default"``, or a base table dropped by a rule of
        :data:`hydropwa.params.SUPERSEDES`); ``"changed after loading"`` for a value that
        differs from the one loaded (e.g. after :meth:`replace`), ``"given"`` for one the
        loader did not record (a set built in Python).

        Examples
        --------
        >>> from hydropwa.params import params_from_dict
        >>> p = params_from_dict({"base": "paper", "load": {"mass": "250 kg"}})
        >>> p.provenance["load.mass"], p.provenance["oil.bulk_modulus"]
        ('file', "base 'paper'")
        """
        out: dict[str, str] = {}
        for comp in COMPONENT_TYPES:
            part = getattr(self, comp)
            for fld in dataclasses.fields(part):
                name = f"{comp}.{fld.name}"
                record = self.origin.get(name)
                if record is None:
                    out[name] = "given"
                else:
                    out[name] = record[0] if record[1] == getattr(part, fld.name) else CHANGED
        return MappingProxyType(out)

    def with_origin(self, source: Callable[[str], str]) -> SystemParams:
        """A copy whose :attr:`origin` records ``source(dotted name)`` for every field."""
        origin = {
            f"{comp}.{fld.name}": (
                source(f"{comp}.{fld.name}"),
                getattr(getattr(self, comp), fld.name),
            )
            for comp in COMPONENT_TYPES
            for fld in dataclasses.fields(getattr(self, comp))
        }
        return dataclasses.replace(self, origin=origin)

    def _headline(self) -> list[tuple[str, str]]:
        """Headline quantities in engineering units, for the reprs."""

        return [
            ("supply pressure P_S", engineering(self.supply.pressure, "Pa")),
            ("flow coefficient K", f"{self.flow.K:.4g} m³/(s·√Pa)"),
            (
                "areas A_A / A_B",
                f"{self.cylinder.area_a * 1e4:.4g} / {self.cylinder.area_b * 1e4:.4g} cm²",
            ),
            ("stroke", engineering(self.cylinder.stroke, "m")),
            ("mass", f"{self.load.mass:.4g} kg"),
            ("bulk modulus E", f"{self.oil.bulk_modulus / 1e9:.4g} GPa"),
            ("valve ω0 / ζ", f"{self.valve.omega0:.4g} rad/s / {self.valve.zeta:.3g}"),
        ]

    def __repr__(self) -> str:
        src = self.meta.get("source") if isinstance(self.meta, dict) else None
        head = ", ".join(
            f"{k.split(' ')[-1]}={v}" for k, v in self._headline()[:5] if " / " not in v
        )
        return f"SystemParams({f'{src!r}, ' if src else ''}{head})"

    def _repr_html_(self) -> str:
        """Headline values, then every field of every component (SI) in a collapsible block."""

        rows = []
        provenance = self.provenance
        for comp in COMPONENT_TYPES:
            part = getattr(self, comp)
            units = _field_units().get(comp, {})
            for fld in dataclasses.fields(part):
                unit = units.get(fld.name) or ""
                value = getattr(part, fld.name)
                text = f"{value:.6g}" if isinstance(value, float) else str(value)
                unit_text = unit.replace("**", "^")
                rows.append((comp, fld.name, text, unit_text, provenance[f"{comp}.{fld.name}"]))
        src = self.meta.get("source", "") if isinstance(self.meta, dict) else ""
        top = html_table(f"SystemParams {src}".strip(), ("quantity", "value"), self._headline())
        full = html_table("", ("component", "field", "value", "unit (SI)", "from"), rows)
        return f"{top}<details><summary>all parameters</summary>{full}</details>"

    def replace(self, **changes: Any) -> SystemParams:
        """Return a copy with components or dotted fields replaced.

        Examples
        --------
        >>> p = SystemParams().replace(**{"supply.pressure": 95e5, "load.mass": 2.0})
        """
        groups: dict[str, dict[str, Any]] = {}
        top: dict[str, Any] = {}
        for key, value in changes.items():
            if "." in key:
                comp, fld = key.split(".", 1)
                groups.setdefault(comp, {})[fld] = value
            else:
                top[key] = value
        for comp, fields in groups.items():
            base = top.get(comp, getattr(self, comp, None))
            if base is None or not dataclasses.is_dataclass(base):
                raise ParameterError(f"unknown parameter group {comp!r}")
            names = {f.name for f in dataclasses.fields(base)}
            for f in fields:
                if f not in names:
                    raise ParameterError(
                        f"unknown parameter {comp}.{f}; known: {', '.join(sorted(names))}"
                    )
            top[comp] = dataclasses.replace(base, **fields)  # type: ignore[type-var]
        return dataclasses.replace(self, **top)

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """Nested plain dict in SI units (component → field → value)."""
        out: dict[str, dict[str, Any]] = {}
        for name in COMPONENT_TYPES:
            comp = getattr(self, name)
            out[name] = {}
            for cf in dataclasses.fields(comp):
                val = getattr(comp, cf.name)
                if isinstance(val, tuple):
                    val = [list(x) for x in val]
                out[name][cf.name] = val
        return out


#: Component name in :class:`SystemParams` (and TOML table name) → its parameter class,
#: derived from the dataclass fields so the two cannot disagree.
COMPONENT_TYPES: dict[str, Any] = {
    f.name: f.default_factory
    for f in dataclasses.fields(SystemParams)
    if f.name not in ("meta", "origin")
}

#: :attr:`SystemParams.provenance` of a value that differs from the one loaded.
CHANGED = "changed after loading"


def _field_units() -> dict:
    from ._toml import (
        FIELD_UNITS,  # _toml imports this module  # deferred: cycle: _toml imports this module
    )

    return FIELD_UNITS
