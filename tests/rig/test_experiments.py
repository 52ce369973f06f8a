"""Physics of the rig's experiments: supply sag, dead-zone creep, counter force, FRF runs."""

from __future__ import annotations

import numpy as np
import pytest

from hydropwa import FullOrderModel, Sine, simulate
from hydropwa.rig import (
    DeadZoneExperiment,
    FrictionExperiment,
    SineExperiment,
    execute,
    measure,
    plan,
    run_seed,
)


def _one(rig, exp, name=None):
    specs = plan(exp, rig)
    spec = specs[0] if name is None else next(s for s in specs if s.name == name)
    return execute(rig, spec, run_seed(1, spec.experiment, spec.name))


def test_supply_sags_with_flow(rig):
    """Sine at 60 %: P_S drops below the set value by about droop·Q/Q_max (Fig. 9)."""
    sup = rig.supply
    res = simulate(
        FullOrderModel(rig.params),
        Sine(amplitude=0.6, frequency=2.0),
        duration=2.0,
        initial_position=0.02,
    )
    c = res.channels
    v = c["v"]
    q = np.where(v > 0, rig.params.cylinder.area_a * v, -rig.params.cylinder.area_b * v)
    expected = sup.compensator_droop * q.max() / sup.pump_flow
    drop = sup.pressure - c["p_s"].min()
    assert expected > 1e5  # the sag is visible (> 1 bar)
    assert drop == pytest.approx(expected, rel=0.3)
    # and the rig records it
    run = measure(res, rig.sensors, np.random.default_rng(0))
    assert sup.pressure - run["p_s"].min() > 0.7 * expected


def test_sine_run_records_supply_and_stays_off_the_end_stops(rig):
    exp = SineExperiment(frequencies=(1.0,), amplitudes=(0.6,), periods=5, start_position=0.1)
    run = _one(rig, exp)
    assert {"t", "u", "spool", "p_a", "p_b", "p_s", "x", "f_l"} <= set(run.channels)
    assert run["p_s"].min() < rig.supply.pressure - 1e5
    stroke = rig.params.cylinder.stroke
    assert run["x"].min() > 0.0 and run["x"].max() < stroke
    assert run.meta["experiment"] == "sine" and run.meta["signal"]["frequency"] == 1.0
    assert run.fs == 2000.0


def test_deadzone_run_inside_the_band_only_creeps(rig):
    exp = DeadZoneExperiment(inputs=(0.05, 0.2), directions=(1,), duration=1.0)
    inside = _one(rig, exp, "deadzone_extend_u05")
    outside = _one(rig, exp, "deadzone_extend_u20")
    v_in = np.polyfit(inside.t, inside["x"], 1)[0]
    v_out = np.polyfit(outside.t[outside.t > 0.2], outside["x"][outside.t > 0.2], 1)[0]
    assert 0 < v_in < 5e-3  # creeps: below 5 mm/s, but moves
    assert v_out > 10 * v_in
    assert inside["x"][0] == pytest.approx(0.0, abs=1e-4)  # starts fully retracted
    assert inside.meta["level"] == 0.05


def test_fast_constant_run_stops_before_the_end_stop(rig):
    exp = DeadZoneExperiment(inputs=(0.5,), directions=(-1,), duration=4.0, stop_at=0.9)
    run = _one(rig, exp)
    stroke = rig.params.cylinder.stroke
    assert run.duration < 2.0
    assert run["x"][0] == pytest.approx(stroke, abs=1e-4)  # starts fully extended
    assert run["x"][-1] == pytest.approx(0.1 * stroke, abs=0.01 * stroke)
    assert run.meta["stopped_early"] is True


def test_friction_run_has_the_counter_force(rig):
    exp = FrictionExperiment(inputs=(0.2,), directions=(1,), counter_force=1500.0, duration=1.5)
    run = _one(rig, exp)
    f = run["f_l"]
    t = run.t
    assert abs(np.mean(f[t < 0.02])) < 50.0  # ramps up from zero
    m = t > exp.force_ramp + 0.05
    steady = f[m]
    # the sensor sees the set force plus the counter cylinder's damping c·ẋ (Load.damping)
    v = np.gradient(run["x"], t)
    expected = 1500.0 + exp.counter_damping * v[m]
    assert np.mean(steady) == pytest.approx(np.mean(expected), rel=0.01)
    late = f[t > exp.valve_delay + 0.5]  # rod at its steady speed: only ripple and noise vary
    assert 5.0 < np.std(late) < 50.0
    assert run.meta["counter_force"] == 1500.0
    assert np.all(run["p_a"] < 250e5) and np.all(run["p_b"] < 250e5)


def test_counter_force_opposes_retraction(rig):
    exp = FrictionExperiment(inputs=(0.2,), directions=(-1,), counter_force=1500.0, duration=1.0)
    run = _one(rig, exp)
    m = run.t > 0.5
    v = np.gradient(run["x"], run.t)[m]
    assert np.mean(run["f_l"][m]) == pytest.approx(
        np.mean(-1500.0 + exp.counter_damping * v), rel=0.01
    )
    assert np.mean(run["f_l"][m]) < -1500.0  # damping adds to the opposing force
    assert run["x"][-1] < run["x"][0]


def test_frf_run_has_settle_plus_periods(rig, small_campaign):
    exp = small_campaign["frf"]
    specs = plan(exp, rig)
    spec = specs[0]
    f = spec.meta["frequency"]
    assert spec.duration == pytest.approx(exp.settle + (exp.periods + exp.margin_periods) / f)
    run = execute(rig, spec, run_seed(0, "frf", spec.name))
    y = run["spool"][run.t > exp.settle]
    assert 0.5 * 0.25 < 0.5 * (y.max() - y.min()) < 1.2 * 0.25
    assert run.meta["amplitude"] == 0.25 and run.meta["experiment"] == "frf"


def test_run_seed_depends_on_seed_and_name():
    a = np.random.default_rng(run_seed(1, "frf", "a")).random()
    assert a == np.random.default_rng(run_seed(1, "frf", "a")).random()
    assert a != np.random.default_rng(run_seed(2, "frf", "a")).random()
    assert a != np.random.default_rng(run_seed(1, "frf", "b")).random()
