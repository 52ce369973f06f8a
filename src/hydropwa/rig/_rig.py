"""The virtual rig: the true system parameters, its supply unit, its sensors and its rate."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from .._channels import CHANNEL, channels_of
from .._errors import ParameterError
from ..params import Supply, SystemParams, load_params
from ._sensors import SensorModel, machine_sensors

__all__ = ["Rig", "paper_supply", "machine_supply"]

#: Catalogue pump sizes [L/min] from which a machine's pump is chosen.
PUMP_SIZES_LPM = (10, 16, 25, 40, 63, 80, 100, 120, 160, 200, 250, 315, 400, 500, 630, 800, 1000)


def machine_supply(params: SystemParams) -> Supply:
    """Supply unit sized for a machine: pump, compensator, line and relief from its parameters.

    Parameters
    ----------
    params : SystemParams
        The machine: supply set pressure P_S [Pa] and valve flow coefficient K.

    Returns
    -------
    Supply
        ``model="pump"``: pump flow the smallest catalogue size (``PUMP_SIZES_LPM``) at or above
        2.5 × the valve's largest flow K·√P_S per edge, compensator droop 15 % of P_S, line volume
        1 L per 120 L/min (at least 0.1 L), relief at P_S + max(20 bar, 10 % of P_S). For the
        paper's rig (K·√P_S = 48 L/min at 100 bar) this is :func:`paper_supply`.
    """
    ps = params.supply.pressure
    q_valve = params.flow.K * math.sqrt(ps) * 60e3  # L/min
    pump = next((q for q in PUMP_SIZES_LPM if q >= 2.5 * q_valve), 2.5 * q_valve)
    return Supply(
        pressure=ps,
        tank_pressure=params.supply.tank_pressure,
        model="pump",
        pump_flow=pump / 60e3,
        compensator_droop=0.15 * ps,
        line_volume=max(1.0e-3 * pump / 120.0, 1e-4),
        relief_pressure=ps + max(20e5, 0.1 * ps),
        relief_gain=1e-9,
    )


def paper_supply(pressure: float = 100e5) -> Supply:
    """Supply unit of the rig: a pressure-compensated pump whose pressure sags with flow (Fig. 9).

    Parameters
    ----------
    pressure : float
        Set pressure [Pa] (100 bar in Sec. VII).

    Returns
    -------
    Supply
        ``model="pump"`` with 120 L/min maximum flow (Sec. V), 15 bar compensator droop,
        1 L line volume and a relief valve at set + 20 bar.
    """
    return Supply(
        pressure=pressure,
        model="pump",
        pump_flow=120e-3 / 60.0,
        compensator_droop=15e5,
        line_volume=1.0e-3,
        relief_pressure=pressure + 20e5,
        relief_gain=1e-9,
    )


@dataclass(frozen=True)
class Rig:
    """Virtual test rig: the full-order model plus what surrounds it on the paper's rig.

    Attributes
    ----------
    params : SystemParams
        True parameters of the cylinder drive (required: there is no default machine;
        ``get_preset("paper")`` is the paper's rig). Their ``supply`` is replaced by ``supply``.
    sensors : dict[str, SensorModel] or None
        Sensor per recorded channel; ``None`` (default) sizes them for the machine
        (:func:`~hydropwa.rig.machine_sensors`: the paper's sensors on the paper's rig).
    fs : float
        Sampling rate [Hz] (2 kHz on the Speedgoat, Sec. V).
    supply : Supply or None
        Supply unit; ``None`` takes ``params.supply`` when it is a pump model, otherwise
        :func:`machine_supply` (the paper's pump on the paper's rig).
    rtol : float
        Relative tolerance of the simulation [1].

    Notes
    -----
    The rig records the command ``u`` as sent (the 16-bit DAC step of 3e-5 of full
    opening is below the valve's resolution and is not modelled) and every sensor channel
    through its :class:`SensorModel`. The load force F_L of the second cylinder is an
    input of the model; the end stops are part of the full-order model.
    """

    params: SystemParams  # the machine: required, there is no default machine (issue 37)
    sensors: Mapping[str, SensorModel] | None = None
    fs: float = 2000.0
    supply: Supply | None = None
    rtol: float = 1e-5

    def __post_init__(self) -> None:
        if not isinstance(self.params, SystemParams):
            raise ParameterError(
                f"the rig needs the machine's SystemParams, got {type(self.params).__name__}; "
                "use Rig.from_params('machine.toml') or Rig.from_params('paper')"
            )
        if not (math.isfinite(self.fs) and self.fs > 0):
            raise ParameterError(f"rig fs = {self.fs!r} Hz must be a positive number")
        if not (0 < self.rtol < 1):
            raise ParameterError(f"rig rtol = {self.rtol!r} must lie in (0, 1)")
        if self.supply is not None:
            supply = self.supply
        elif self.params.supply.model == "pump":
            supply = self.params.supply
        else:
            supply = machine_supply(self.params)
        object.__setattr__(self, "supply", supply)
        object.__setattr__(self, "params", self.params.replace(supply=supply))
        object.__setattr__(self, "_auto_sensors", self.sensors is None)
        sensors = machine_sensors(self.params, supply) if self.sensors is None else self.sensors
        for ch, s in sensors.items():
            if not isinstance(s, SensorModel) or s.channel != ch:
                raise ParameterError(
                    f"rig sensors[{ch!r}] must be a SensorModel for channel {ch!r}"
                )
        object.__setattr__(self, "sensors", dict(sensors))
        self._cross_check()

    @property
    def _sensors(self) -> Mapping[str, SensorModel]:
        """The sensors, always set by ``__post_init__`` (the field is None only as input)."""
        assert self.sensors is not None
        return self.sensors

    @property
    def _supply(self) -> Supply:
        """The supply, always set by ``__post_init__`` (the field is None only as input)."""
        assert self.supply is not None
        return self.supply

    def _cross_check(self) -> None:
        """Settings that cannot work together: relief below the set pressure, sensors too small."""
        sup = self.supply
        assert sup is not None
        if sup.relief_pressure <= sup.pressure:
            raise ParameterError(
                f"rig supply: relief pressure {sup.relief_pressure / 1e5:g} bar is not above the set "
                f"pressure {sup.pressure / 1e5:g} bar, so the pump could never reach it; set "
                f'[supply] relief_pressure = "{(sup.pressure + max(20e5, 0.1 * sup.pressure)) / 1e5:g} bar" '
                "in the campaign (or supply.relief_pressure in the parameter file)"
            )
        stroke = self.params.cylinder.stroke
        x = self._sensors.get("x")
        if x is not None and not (x.range[0] < 0.0 and x.range[1] > stroke):
            m = 0.125 * stroke
            raise ParameterError(
                f"rig sensor 'x' ({x.name}) reads {1e3 * x.range[0]:g}…{1e3 * x.range[1]:g} mm but the rod "
                f"moves 0…{1e3 * stroke:g} mm (and a little past both ends at the stops): runs would sit at the "
                f'converter\'s limit; set [sensors.x] range = ["{-1e3 * m:g} mm", "{1e3 * (stroke + m):g} mm"] '
                "in the campaign, or leave [sensors] out to size it from the stroke"
            )
        for ch in channels_of("pressure"):
            s = self._sensors.get(ch)
            if s is not None and s.range[1] < sup.relief_pressure:
                raise ParameterError(
                    f"rig sensor {ch!r} ({s.name}) reads up to {s.range[1] / 1e5:g} bar, below the relief "
                    f"pressure {sup.relief_pressure / 1e5:g} bar: pressures would clip at the converter; "
                    f'use a larger range ([sensors.{ch}] range = ["0 bar", '
                    f'"{1e-5 * machine_sensors(self.params, sup)[ch].range[1]:g} bar"]) or leave '
                    "[sensors] out to size it from the machine"
                )

    def with_overrides(
        self,
        sensors: Mapping[str, Mapping[str, Any]] | None = None,
        supply: Mapping[str, Any] | None = None,
    ) -> Rig:
        """This rig with sensor and supply settings replaced (a campaign's ``[sensors]``, ``[supply]``).

        Parameters
        ----------
        sensors : dict, optional
            Per channel, :class:`SensorModel` fields to replace (SI units).
        supply : dict, optional
            :class:`~hydropwa.params.Supply` fields to replace (SI units).

        Returns
        -------
        Rig
            Sensors that were sized from the machine are sized again for the new supply
            before the overrides apply; the result is cross-checked.
        """
        sup = dataclasses.replace(self._supply, **supply) if supply else self._supply
        params = self.params.replace(supply=sup)
        base = (
            machine_sensors(params, sup)
            if getattr(self, "_auto_sensors", False)
            else dict(self._sensors)
        )
        for ch, over in (sensors or {}).items():
            if ch not in base and not params.carries(
                CHANNEL[ch].component if ch in CHANNEL else None
            ):
                continue  # a transmitter of a part this machine lacks ([sensors.pressure], lines)
            if ch not in base:
                raise ParameterError(
                    f"[sensors.{ch}]: the rig has no sensor {ch!r}; known: {', '.join(base)}"
                )
            base[ch] = dataclasses.replace(base[ch], **over)
        return Rig(params=params, sensors=base, fs=self.fs, supply=sup, rtol=self.rtol)

    @classmethod
    def from_params(cls, params: SystemParams | str | None = None, **kwargs: Any) -> Rig:
        """Rig around parameters, a parameter file or a preset name (``"paper"``: the paper's
        rig); there is no default machine: ``None`` raises :class:`~hydropwa.ParameterError`."""
        if params is None:
            raise ParameterError(
                "the rig needs the machine: Rig.from_params('machine.toml') (your parameter "
                "file) or Rig.from_params('paper') (the paper's rig)"
            )
        if not isinstance(params, SystemParams):
            params = load_params(params)
        return cls(params=params, **kwargs)

    def describe(self) -> dict[str, Any]:
        """Plain-dict description for metadata (rate, supply, sensors; SI units)."""
        return {
            "fs": self.fs,
            "rtol": self.rtol,
            "supply": dataclasses.asdict(self.params.supply),
            "sensors": {ch: s.describe() for ch, s in self._sensors.items()},
        }
