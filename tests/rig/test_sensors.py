"""Sensor chain: quantization step, noise, clipping, validation."""

from __future__ import annotations

import numpy as np
import pytest

from hydropwa import ParameterError
from hydropwa.rig import SensorModel, paper_sensors


@pytest.mark.parametrize("channel", sorted(paper_sensors()))
def test_quantization_step_is_range_over_2_to_16(channel):
    s = paper_sensors()[channel]
    lo, hi = s.range
    assert s.adc_bits == 16
    assert s.quantization_step == (hi - lo) / 2**16


def test_quantization_step_with_explicit_gain():
    # A 0-10 V pressure sensor on a ±10 V input uses half the codes: twice the step.
    s = SensorModel(
        "MBS 1250 0-10 V", "p_a", "Pa", (0.0, 250e5), adc_span=(-10.0, 10.0), gain=10.0 / 250e5
    )
    assert s.quantization_step == pytest.approx(2 * 250e5 / 2**16, rel=1e-12)
    assert s.quantization_step == pytest.approx(s.full_scale / 2**16, rel=0)


def test_measured_values_lie_on_the_converter_grid():
    s = paper_sensors()["p_a"]
    y = s.apply(np.linspace(1e5, 200e5, 1001), np.random.default_rng(1))
    codes = (y - s.zero_level) / s.quantization_step
    assert np.array_equal(codes, np.rint(codes))
    assert codes.min() >= 0 and codes.max() <= 2**16 - 1


def test_noise_std_matches_setting():
    s = SensorModel("test", "x", "m", (0.0, 0.25), noise_std=1e-3)
    y = s.apply(np.full(200_000, 0.1), np.random.default_rng(2))
    assert np.std(y) == pytest.approx(1e-3, rel=0.02)
    assert np.mean(y) == pytest.approx(0.1, abs=1e-5)


def test_noise_free_sensor_quantizes_only():
    s = SensorModel("test", "x", "m", (0.0, 0.25))
    x = np.linspace(0.01, 0.2, 500)
    y = s.apply(x, np.random.default_rng(0))
    assert np.max(np.abs(y - x)) <= 0.5 * s.quantization_step * (1 + 1e-9)


def test_offset_and_range_clipping():
    s = SensorModel("test", "f_l", "N", (-50e3, 50e3), adc_span=(-10.24, 10.24), offset=100.0)
    y = s.apply(np.array([-80e3, 0.0, 80e3]), np.random.default_rng(0))
    assert y[0] == -50e3
    assert y[1] == pytest.approx(100.0, abs=s.quantization_step)
    assert y[2] <= 50e3 and y[2] > 50e3 - 2 * s.quantization_step


@pytest.mark.parametrize(
    ("kwargs", "word"),
    [
        ({"range": (1.0, 0.0)}, "range"),
        ({"noise_std": -1.0}, "noise_std"),
        ({"adc_bits": 0}, "adc_bits"),
        ({"gain": 1000.0}, "exceeds"),
    ],
)
def test_invalid_sensor_names_the_field(kwargs, word):
    base = {"name": "t", "channel": "x", "unit": "m", "range": (0.0, 0.25)}
    with pytest.raises(ParameterError, match=word):
        SensorModel(**{**base, **kwargs})
