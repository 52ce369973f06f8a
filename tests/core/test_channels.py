"""The channel table (``hydropwa._channels``): every layer reads it, and a measurement by name
initialises each model's states as the equations say."""

from __future__ import annotations

import numpy as np
import pytest

from hydropwa import ParameterError, get_preset
from hydropwa._channels import (
    CHANNEL,
    CHANNELS,
    FLOOR_CHANNELS,
    RECORDED_CHANNELS,
    SCORED_CHANNELS,
    STATE_CHANNELS,
    channels_of,
)
from hydropwa._layout import FULL_STATES, MODEL_KINDS, Y_FULL
from hydropwa.data import CANONICAL_UNITS, PLAUSIBLE_RANGES
from hydropwa.evaluation import CHANNELS as EVALUATED
from hydropwa.linearization import linearize
from hydropwa.models import FullOrderModel, ReducedModel
from hydropwa.params import Lines
from hydropwa.rig import MEASURED_CHANNELS, machine_sensors, paper_sensors

MEASURED = {"x": 0.07, "v": -0.02, "p_a": 41e5, "p_b": 23e5, "p_s": 95e5, "spool": 0.25}


@pytest.fixture(scope="module")
def params():
    return get_preset("paper")


def test_every_state_channel_names_a_model_state():
    states = {n for row in MODEL_KINDS.values() for n, _u, _s in row.states}
    for c in CHANNELS:
        assert c.state is None or c.state in states, c.name


def test_the_layers_read_the_table():
    assert CANONICAL_UNITS == {c.name: c.unit for c in CHANNELS}
    assert set(PLAUSIBLE_RANGES) == set(CHANNEL) - {"t"}
    assert PLAUSIBLE_RANGES["p_a"].hi == CHANNEL["p_a"].hi
    assert (
        MEASURED_CHANNELS
        == RECORDED_CHANNELS
        == (
            *("u", "spool", "p_a", "p_b", "p_s", "x", "f_l"),
            *("p_line_a", "p_line_b"),  # recorded where the model simulates them (hose lines)
        )
    )
    assert EVALUATED == SCORED_CHANNELS == ("x", "p_a", "p_b", "p_l", "v")
    assert FLOOR_CHANNELS == ("p_a", "p_b", "p_line_a", "p_line_b")


def test_the_rig_has_a_sensor_for_every_measured_channel(params):
    """A machine's rig fits a sensor for every recorded channel of the parts that machine
    carries (the line pressures only with hose lines, Channel.component); the paper's rig has
    no lines."""
    sensed = set(RECORDED_CHANNELS) - set(channels_of("command"))
    hosed = params.replace(
        lines=Lines(volume_a=3e-5, volume_b=8e-5, conductance_a=1.5e-8, conductance_b=6e-9)
    )
    assert not params.lines.present
    lines = {c.name for c in CHANNELS if c.component == "lines"}
    assert lines == {"p_line_a", "p_line_b"}
    for sensors, expected in (
        (paper_sensors(), sensed - lines),
        (machine_sensors(params), sensed - lines),
        (machine_sensors(hosed), sensed),
    ):
        assert set(sensors) == expected
        for ch in set(channels_of("pressure")) & expected:
            assert sensors[ch].unit == CHANNEL[ch].unit == "Pa"


def test_full_model_state_from_a_measurement(params):
    y = FullOrderModel(params).state_from_measurement(MEASURED)
    expected = np.zeros(len(FULL_STATES))
    for name in STATE_CHANNELS:
        if name in Y_FULL:  # the line pressures initialise the full-lines model's states
            expected[Y_FULL[name]] = MEASURED[name]
    expected[Y_FULL["p_acc"]] = MEASURED["p_a"]  # the accumulator rests with chamber A
    np.testing.assert_array_equal(y, expected)


def test_unmeasured_channels_rest(params):
    y = FullOrderModel(params).state_from_measurement({"x": 0.1, "p_a": 30e5, "p_b": 20e5})
    assert y[Y_FULL["v"]] == y[Y_FULL["spool"]] == 0.0
    assert y[Y_FULL["p_s"]] == params.supply.pressure


def test_reduced_and_pwa_load_pressure_from_a_measurement(params):
    # P_L = P_A − α P_B with α = A_B/A_A (asymmetric) or 1 (the paper's mean-area form)
    alpha = params.cylinder.area_b / params.cylinder.area_a
    for model, a in ((ReducedModel(params), alpha), (ReducedModel(params, "paper"), 1.0)):
        y = model.state_from_measurement(MEASURED)
        np.testing.assert_allclose(
            y, [MEASURED["p_a"] - a * MEASURED["p_b"], MEASURED["v"], MEASURED["x"]], rtol=1e-15
        )
    pwa = linearize(params)
    np.testing.assert_array_equal(
        pwa.state_from_measurement(MEASURED), ReducedModel(params).state_from_measurement(MEASURED)
    )


def test_chamber_model_takes_its_supply_pressure_where_none_is_measured(params):
    m = linearize(params, form="chamber", supply_pressure=80e5)
    y = m.state_from_measurement({"x": 0.1, "p_a": 30e5, "p_b": 20e5})
    assert y[Y_FULL["p_s"]] == 80e5


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda m: m.state_from_measurement(0.1, 0.0, 30e5, 20e5, 100e5), "positional"),
        (lambda m: m.state_from_measurement((0.1, 0.0, 30e5, 20e5)), "takes a mapping"),
        (lambda m: m.state_from_measurement({**MEASURED, "p_l": 1e5}), "p_l initialise no"),
        (lambda m: m.state_from_measurement({"x": 0.1, "p_a": 3e6}), "needs p_b"),
        (lambda m: m.state_from_measurement({**MEASURED, "x": np.nan}), "x = nan"),
    ],
)
def test_bad_measurements_are_one_line_errors(params, call, match):
    for model in (FullOrderModel(params), ReducedModel(params)):
        with pytest.raises((ParameterError, TypeError), match=match) as err:
            call(model)
        assert "\n" not in str(err.value)
