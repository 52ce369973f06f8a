"""Sensor chain of the virtual rig: sensor gain and offset, noise, clipping, 16-bit ADC.

The rig of the paper (Sec. V, Table I) samples every signal at 2 kHz with the 16-bit
converters of a Speedgoat IO183 (±10 V) and IO397 (±10.24 V) card. Each sensor is a
:class:`SensorModel`; :func:`measure` applies the chain to a simulated trajectory and
returns the :class:`~hydropwa.data.Run` the rig would have recorded.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np

from .._channels import CHANNEL, RECORDED_CHANNELS, channels_of
from .._errors import ParameterError
from ..data import Run

__all__ = ["SensorModel", "paper_sensors", "machine_sensors", "measure", "MEASURED_CHANNELS"]

#: Channels the rig records: the command it sends and what its sensors measure (the channel
#: table's rows with a sensor, :data:`hydropwa._channels.RECORDED_CHANNELS`, in its order).
MEASURED_CHANNELS = RECORDED_CHANNELS


@dataclass(frozen=True)
class SensorModel:
    """One sensor and its analogue-to-digital conversion.

    Attributes
    ----------
    name : str
        Part name (e.g. ``"Danfoss MBS 1250"``).
    channel : str
        Canonical channel the sensor measures (``p_a``, ``x``, ``f_l``, ...).
    unit : str
        SI unit of the measured quantity (``Pa``, ``m``, ``N``, ``1``).
    range : tuple of float
        Measurement range ``(lo, hi)`` [unit]; the output saturates outside it.
    adc_bits : int
        Converter resolution [bit] (16 on IO183 and IO397).
    adc_span : tuple of float
        Converter input span ``(lo, hi)`` [V] (±10 V on IO183, ±10.24 V on IO397).
    gain : float or None
        Sensor plus conditioning gain [V/unit]. ``None`` (default) scales ``range`` onto
        the full ``adc_span``, so one code is exactly ``(hi − lo) / 2**adc_bits``.
    noise_std : float
        Standard deviation of white measurement noise [unit], added before conversion.
    offset : float
        Zero error of the sensor [unit], added to the true value (calibration error).

    Notes
    -----
    The chain is ``y = Q(clip(x + offset + n, range))`` with ``n ~ N(0, noise_std²)``
    and ``Q`` a mid-tread quantizer of step :attr:`quantization_step` anchored at the
    voltage ``adc_span[0]``; the recorded value is converted back with the nominal gain,
    so an ``offset`` stays in the data as it would on the rig.
    """

    name: str
    channel: str
    unit: str
    range: tuple[float, float]
    adc_bits: int = 16
    adc_span: tuple[float, float] = (-10.0, 10.0)
    gain: float | None = None
    noise_std: float = 0.0
    offset: float = 0.0

    def __post_init__(self) -> None:
        lo, hi = (float(v) for v in self.range)
        vlo, vhi = (float(v) for v in self.adc_span)
        object.__setattr__(self, "range", (lo, hi))
        object.__setattr__(self, "adc_span", (vlo, vhi))
        where = f"sensor {self.channel!r} ({self.name})"
        if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
            raise ParameterError(f"{where}: range ({lo:g}, {hi:g}) {self.unit} needs lo < hi")
        if not (math.isfinite(vlo) and math.isfinite(vhi) and vhi > vlo):
            raise ParameterError(f"{where}: adc_span ({vlo:g}, {vhi:g}) V needs lo < hi")
        if not (isinstance(self.adc_bits, int) and 1 <= self.adc_bits <= 32):
            raise ParameterError(
                f"{where}: adc_bits = {self.adc_bits!r} must be an integer in 1..32"
            )
        if self.gain is not None and not (math.isfinite(self.gain) and self.gain > 0):
            raise ParameterError(f"{where}: gain = {self.gain!r} V/{self.unit} must be > 0")
        if not (math.isfinite(self.noise_std) and self.noise_std >= 0):
            raise ParameterError(
                f"{where}: noise_std = {self.noise_std!r} {self.unit} must be >= 0"
            )
        if not math.isfinite(self.offset):
            raise ParameterError(f"{where}: offset = {self.offset!r} {self.unit} must be finite")
        if self.gain is not None and self.gain * (hi - lo) > (vhi - vlo) * (1 + 1e-12):
            raise ParameterError(
                f"{where}: range × gain = {self.gain * (hi - lo):g} V exceeds the converter span "
                f"{vhi - vlo:g} V; lower the gain or use a converter with a larger span"
            )

    @property
    def volts_per_unit(self) -> float:
        """Effective gain [V/unit] (``gain``, or the span-filling gain when ``gain`` is None)."""
        if self.gain is None:
            return (self.adc_span[1] - self.adc_span[0]) / (self.range[1] - self.range[0])
        return float(self.gain)

    @property
    def full_scale(self) -> float:
        """Span of the measured quantity that the converter covers [unit]."""
        if self.gain is None:
            return self.range[1] - self.range[0]
        return (self.adc_span[1] - self.adc_span[0]) / self.gain

    @property
    def quantization_step(self) -> float:
        """One converter code in the measured quantity [unit]: ``full_scale / 2**adc_bits``."""
        return self.full_scale / 2**self.adc_bits

    @property
    def zero_level(self) -> float:
        """Measured value of the lowest converter code [unit] (the range's lower end).

        Unipolar sensors are wired so that their range starts at the converter's lowest
        code; with an explicit ``gain`` the codes above ``range[1]`` stay unused.
        """
        return self.range[0]

    @property
    def recorded_limits(self) -> tuple[float, float]:
        """Lowest and highest value the chain can record [unit] (range ends on the code grid)."""
        step = self.quantization_step
        top = self.zero_level + (2**self.adc_bits - 1) * step
        hi = self.zero_level + np.rint((min(self.range[1], top) - self.zero_level) / step) * step
        return (float(self.zero_level), float(hi))

    def apply(self, values: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Measure ``values`` [unit]: offset, noise, range clipping, quantization.

        Parameters
        ----------
        values : ndarray, shape (n,)
            True values [unit].
        rng : numpy.random.Generator
            Noise source.

        Returns
        -------
        ndarray, shape (n,)
            Recorded values [unit], multiples of :attr:`quantization_step` above
            :attr:`zero_level`.
        """
        y = np.asarray(values, dtype=float) + self.offset
        if self.noise_std > 0:
            y = y + rng.normal(0.0, self.noise_std, size=y.shape)
        lo, hi = self.range
        step = self.quantization_step
        top = self.zero_level + (2**self.adc_bits - 1) * step
        y = np.clip(y, lo, min(hi, top))
        codes = np.rint((y - self.zero_level) / step)
        codes = np.clip(codes, 0, 2**self.adc_bits - 1)
        return self.zero_level + codes * step

    def describe(self) -> dict[str, Any]:
        """Plain-dict description for metadata (SI units; ``quantization_step`` added)."""
        d = asdict(self)
        d["range"] = list(self.range)
        d["adc_span"] = list(self.adc_span)
        d["quantization_step"] = self.quantization_step
        return d


def paper_sensors() -> dict[str, SensorModel]:
    """Sensors of the paper's rig (Table I) with the defaults documented in the rig docs.

    Returns
    -------
    dict[str, SensorModel]
        By channel: ``p_a``, ``p_b``, ``p_s`` (Danfoss MBS 1250, 0–250 bar), ``x``
        (Celesco CLP-250, 0–250 mm), ``f_l`` (HBM S9M/50 kN, ±50 kN on the IO397's
        ±10.24 V), ``spool`` (valve's own ±10 V spool signal).
    """

    def pressure(channel: str) -> SensorModel:
        return SensorModel(
            "Danfoss MBS 1250 063G1229 (0-250 bar)",
            channel,
            "Pa",
            (0.0, 250e5),
            adc_span=(-10.0, 10.0),
            noise_std=0.05e5,
        )

    return {
        **{ch: pressure(ch) for ch in channels_of("pressure") if CHANNEL[ch].component is None},
        "x": SensorModel(
            "Celesco CLP-250 linear potentiometer",
            "x",
            "m",
            (-0.025, 0.225),
            adc_span=(-10.0, 10.0),
            noise_std=5e-6,
        ),
        "f_l": SensorModel(
            "HBM 1-S9M/50kN-1 with amplifier",
            "f_l",
            "N",
            (-50e3, 50e3),
            adc_span=(-10.24, 10.24),
            noise_std=5.0,
        ),
        "spool": SensorModel(
            "Moog D633 spool position output (±10 V)",
            "spool",
            "1",
            (-1.0, 1.0),
            adc_span=(-10.0, 10.0),
            noise_std=1e-3,
        ),
    }


#: Standard measurement ranges of catalogue parts, from which a machine's sensors are chosen.
PRESSURE_RANGES_BAR = (10, 16, 25, 40, 60, 100, 160, 250, 400, 600, 1000, 1600)
FORCE_RANGES_KN = (0.5, 1, 2, 5, 10, 20, 50, 100, 200, 500, 1000, 2000, 5000)
#: Noise of each sensor as a fraction of its full scale (the paper rig's defaults:
#: 0.05 bar of 250 bar, 5 µm of 250 mm, 5 N of 100 kN).
NOISE_FRACTION = {"pressure": 2e-4, "x": 2e-5, "f_l": 5e-5}
#: Position sensor travel beyond each end of the stroke, as a fraction of the stroke
#: (the paper rig: 25 mm each side of 200 mm, so the end stops stay on the converter).
POSITION_MARGIN = 0.125


def _standard(need: float, choices) -> float:
    for c in choices:
        if c >= need:
            return float(c)
    return float(need)


def machine_sensors(params, supply=None) -> dict[str, SensorModel]:
    """Sensors sized for a machine: ranges cover its stroke, pressures and forces with margin.

    Parameters
    ----------
    params : SystemParams
        The machine (stroke, areas, supply pressure).
    supply : Supply, optional
        The rig's supply unit (its relief pressure bounds the pressures); default ``params.supply``.

    Returns
    -------
    dict[str, SensorModel]
        ``x``: −m·l … (1 + m)·l with m = 12.5 % of the stroke l; ``p_a``, ``p_b``, ``p_s``: the
        smallest catalogue range (``PRESSURE_RANGES_BAR``) at or above 1.1 × the larger of the
        relief pressure and the rod-side intensification P_S·A_A/A_B (a closed valve on a moving
        single-rod cylinder); ``f_l``: ± the smallest catalogue range at or above 1.5 × relief ×
        A_A; ``spool``: ±1. Noise is the paper rig's fraction of full scale
        (``NOISE_FRACTION``), so for the paper's rig this equals :func:`paper_sensors`.
    """
    supply = params.supply if supply is None else supply
    cyl = params.cylinder
    peak_p = max(supply.relief_pressure, supply.pressure * cyl.area_a / cyl.area_b)
    p_hi = 1e5 * _standard(1.1 * peak_p / 1e5, PRESSURE_RANGES_BAR)
    f_hi = 1e3 * _standard(1.5 * supply.relief_pressure * cyl.area_a / 1e3, FORCE_RANGES_KN)
    margin = POSITION_MARGIN * cyl.stroke
    x_lo, x_hi = -margin, cyl.stroke + margin
    out = paper_sensors()

    def sized(ch: str, name: str, rng: tuple[float, float], noise: float) -> SensorModel:
        # the paper's part where it fits the machine (same range), a generic one otherwise
        same = np.allclose(out[ch].range, rng, rtol=1e-12, atol=0.0)
        return replace(
            out[ch],
            name=out[ch].name if same else name,
            range=rng,
            noise_std=out[ch].noise_std if same else noise,
        )

    for ch in channels_of("pressure"):
        if not params.carries(CHANNEL[ch].component):
            continue  # a transmitter only on a part the machine has (a hose line)
        out.setdefault(ch, replace(out["p_a"], channel=ch))  # the paper's part, on this line
        out[ch] = sized(
            ch,
            f"pressure transmitter 0-{p_hi / 1e5:g} bar",
            (0.0, p_hi),
            NOISE_FRACTION["pressure"] * p_hi,
        )
    out["x"] = sized(
        "x",
        f"position sensor, {1e3 * (x_hi - x_lo):g} mm travel",
        (x_lo, x_hi),
        NOISE_FRACTION["x"] * (x_hi - x_lo),
    )
    out["f_l"] = sized(
        "f_l",
        f"load cell ±{f_hi / 1e3:g} kN with amplifier",
        (-f_hi, f_hi),
        NOISE_FRACTION["f_l"] * 2 * f_hi,
    )
    return out


def measure(
    result,
    sensors: Mapping[str, SensorModel],
    rng: np.random.Generator,
    *,
    name: str = "run",
    meta: Mapping[str, Any] | None = None,
    fs: float | None = None,
):
    """Apply the sensor chain to a simulated trajectory.

    Parameters
    ----------
    result : SimulationResult
        Full-model simulation sampled at the rig rate.
    sensors : dict[str, SensorModel]
        Sensor per channel; channels without a sensor are not recorded, except the
        command ``u``, which the rig records as sent, nor those the model does not simulate
        (the line pressures of a machine without hose lines).
    rng : numpy.random.Generator
        Noise source (one per run, see :func:`hydropwa.rig.run_seed`).
    name : str
        Run name.
    meta : dict, optional
        Run metadata.
    fs : float, optional
        Nominal sampling rate [Hz].

    Returns
    -------
    hydropwa.data.Run
        Channels ``t``, ``u`` and one per sensor, in SI units.
    """
    channels = {
        "t": np.asarray(result.channels["t"], dtype=float),
        "u": np.asarray(result.channels["u"], dtype=float),
    }
    simulated = result.channels
    for ch in MEASURED_CHANNELS:
        if ch in sensors and ch in simulated:
            channels[ch] = sensors[ch].apply(simulated[ch], rng)
    for ch, sensor in sensors.items():
        if ch not in channels and ch in simulated:
            channels[ch] = sensor.apply(simulated[ch], rng)
    units = {ch: sensors[ch].unit for ch in channels if ch in sensors}
    meta = dict(meta or {})
    meta["converter_limits"] = {
        ch: list(sensors[ch].recorded_limits) for ch in channels if ch in sensors
    }
    return Run(name=name, channels=channels, units=units, fs=fs, meta=meta)
