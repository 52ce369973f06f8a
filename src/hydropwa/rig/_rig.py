"""The virtual rig: the true system parameters, its supply unit, its sensors and its rate."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from .._errors import ParameterError
from ..params import Supply, SystemParams, get_preset, load_params
from ._sensors import SensorModel, paper_sensors

__all__ = ["Rig", "paper_supply"]


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
        True parameters of the cylinder drive. Their ``supply`` is replaced by ``supply``.
    sensors : dict[str, SensorModel]
        Sensor per recorded channel (default :func:`~hydropwa.rig.paper_sensors`).
    fs : float
        Sampling rate [Hz] (2 kHz on the Speedgoat, Sec. V).
    supply : Supply or None
        Supply unit; ``None`` uses :func:`paper_supply` at ``params.supply.pressure``.
    rtol : float
        Relative tolerance of the simulation [1].

    Notes
    -----
    The rig records the command ``u`` as sent (the 16-bit DAC step of 3e-5 of full
    opening is below the valve's resolution and is not modelled) and every sensor channel
    through its :class:`SensorModel`. The load force F_L of the second cylinder is an
    input of the model; the end stops are part of the full-order model.
    """

    params: SystemParams = field(default_factory=lambda: get_preset("paper"))
    sensors: Mapping[str, SensorModel] = field(default_factory=paper_sensors)
    fs: float = 2000.0
    supply: Supply | None = None
    rtol: float = 1e-5

    def __post_init__(self) -> None:
        if not (math.isfinite(self.fs) and self.fs > 0):
            raise ParameterError(f"rig fs = {self.fs!r} Hz must be a positive number")
        if not (0 < self.rtol < 1):
            raise ParameterError(f"rig rtol = {self.rtol!r} must lie in (0, 1)")
        supply = (
            self.supply if self.supply is not None else paper_supply(self.params.supply.pressure)
        )
        object.__setattr__(self, "supply", supply)
        object.__setattr__(self, "params", self.params.replace(supply=supply))
        for ch, s in self.sensors.items():
            if not isinstance(s, SensorModel) or s.channel != ch:
                raise ParameterError(
                    f"rig sensors[{ch!r}] must be a SensorModel for channel {ch!r}"
                )
        object.__setattr__(self, "sensors", dict(self.sensors))

    @classmethod
    def from_params(cls, params: SystemParams | str | None = None, **kwargs: Any) -> Rig:
        """Rig around parameters, a parameter file or a preset name (default ``"paper"``)."""
        if params is None:
            params = get_preset("paper")
        elif not isinstance(params, SystemParams):
            params = load_params(params)
        return cls(params=params, **kwargs)

    def describe(self) -> dict[str, Any]:
        """Plain-dict description for metadata (rate, supply, sensors; SI units)."""
        return {
            "fs": self.fs,
            "rtol": self.rtol,
            "supply": dataclasses.asdict(self.params.supply),
            "sensors": {ch: s.describe() for ch, s in self.sensors.items()},
        }
