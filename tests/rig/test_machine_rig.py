"""The rig sized from the machine's parameters (issue 18, item 1)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hydropwa import ParameterError
from hydropwa.params import get_preset, load_params
from hydropwa.rig import (
    Rig,
    counter_force_signal,
    execute,
    machine_sensors,
    machine_supply,
    paper_sensors,
    paper_supply,
    parse_campaign,
    plan,
    run_seed,
)

MACHINES = Path(__file__).parent.parent / "machines"


@pytest.fixture(scope="module")
def industrial():
    return load_params(MACHINES / "industrial.toml")


def test_paper_rig_is_unchanged_by_the_sizing_rules():
    """The rules reproduce the paper's sensors and pump for the paper's machine."""
    p = get_preset("paper")
    assert machine_supply(p) == paper_supply(p.supply.pressure)
    assert machine_sensors(p, paper_supply()) == paper_sensors()
    assert Rig.from_params("paper").sensors == paper_sensors()


def test_sensors_and_supply_cover_the_industrial_axis(industrial):
    rig = Rig(params=industrial)
    x = rig.sensors["x"]
    stroke = industrial.cylinder.stroke
    assert x.range[0] < 0.0 and x.range[1] > stroke  # the stops lie inside the travel
    assert rig.supply.relief_pressure > industrial.supply.pressure == 210e5
    # a closed valve on an extending rod intensifies P_B up to P_S·A_A/A_B (312 bar here)
    ratio = industrial.cylinder.area_a / industrial.cylinder.area_b
    for ch in ("p_a", "p_b", "p_s"):
        assert rig.sensors[ch].range[1] >= max(rig.supply.relief_pressure, 210e5 * ratio)
    # the load cell covers the largest hydraulic force with margin, at the paper's relative noise
    assert rig.sensors["f_l"].range[1] >= rig.supply.relief_pressure * industrial.cylinder.area_a
    assert rig.sensors["f_l"].noise_std / rig.sensors["f_l"].full_scale == pytest.approx(
        5.0 / 100e3
    )
    # the pump can feed the valve at full opening (K·√P_S per edge)
    assert rig.supply.pump_flow >= 2.5 * industrial.flow.K * np.sqrt(210e5)


def test_paper_sensors_on_a_long_stroke_is_an_error_that_says_what_to_change(industrial):
    with pytest.raises(
        ParameterError, match=r"\[sensors\.x\] range = \[\"-62\.5 mm\", \"562\.5 mm\"\]"
    ):
        Rig(params=industrial, sensors=paper_sensors())


def test_relief_below_the_supply_is_an_error_that_says_what_to_change(industrial):
    with pytest.raises(
        ParameterError, match=r"relief pressure 120 bar.*relief_pressure = \"231 bar\""
    ):
        Rig(
            params=industrial,
            supply=paper_supply(100e5).__class__(
                pressure=210e5, model="pump", relief_pressure=120e5
            ),
        )


def test_campaign_sensors_and_supply_override_the_sized_ones(industrial):
    camp = parse_campaign(
        {
            "sensors": {
                "pressure": {"range": ["0 bar", "600 bar"], "noise_std": "0.1 bar"},
                "x": {"range": ["-0.1 m", "0.7 m"]},
            },
            "supply": {"relief_pressure": "260 bar", "pump_flow": "250 L/min"},
            "deadzone": {"inputs": [0.05]},
        }
    )
    rig = Rig(params=industrial).with_overrides(camp.sensors, camp.supply)
    assert rig.sensors["p_b"].range == (0.0, 600e5) and rig.sensors[
        "p_a"
    ].noise_std == pytest.approx(0.1e5)
    assert rig.sensors["x"].range == (-0.1, 0.7)
    assert rig.supply.relief_pressure == pytest.approx(260e5)
    assert rig.supply.pump_flow == pytest.approx(250e-3 / 60)
    assert rig.params.supply == rig.supply
    with pytest.raises(ParameterError, match=r"\[sensors\]\.bogus: unknown sensor"):
        parse_campaign({"sensors": {"bogus": {"noise_std": 1}}, "deadzone": {"inputs": [0.05]}})
    # an override that cannot work is caught by the same cross-check
    small_p = parse_campaign(
        {"sensors": {"p_a": {"range": ["0 bar", "100 bar"]}}, "deadzone": {"inputs": [0.05]}}
    )
    with pytest.raises(ParameterError, match=r"sensor 'p_a'.*below the relief"):
        Rig(params=industrial).with_overrides(small_p.sensors, small_p.supply)


def test_counter_force_adds_to_the_static_load(industrial):
    """Friction runs load the rod with F_0 + F(t) (+ c·ẋ), not F(t) alone."""
    rng = np.random.default_rng(0)
    settings = {
        "force": 1000.0,
        "ramp": 0.1,
        "ripple": 0.0,
        "ripple_frequency": 7.0,
        "noise": 0.0,
        "rate": 500.0,
    }
    sig = counter_force_signal(settings, 1.0, rng, static=2000.0)
    assert sig(0.0) == pytest.approx(2000.0) and sig(0.5) == pytest.approx(3000.0)
    # end to end: the force sensor of a slow extending friction run reads F_0 + F + c·ẋ
    rig = Rig(params=industrial)
    camp = parse_campaign(
        {
            "friction": {
                "inputs": [0.2],
                "directions": ["extend"],
                "counter_force": "1 kN",
                "duration": "1.2 s",
                "force_noise": "0 N",
                "ripple": 0.0,
            }
        }
    )
    spec = plan(camp["friction"], rig)[0]
    run = execute(rig, spec, run_seed(1, "friction", spec.name))
    t, x, f = run["t"], run["x"], run["f_l"]
    late = t > 0.9
    v = np.polyfit(t[late], x[late], 1)[0]
    expected = 2000.0 + 1000.0 + camp["friction"].counter_damping * v
    assert np.median(f[late]) == pytest.approx(
        expected, abs=3 * rig.sensors["f_l"].quantization_step + 5.0
    )


def test_rig_cli_says_what_it_sized(tmp_path, capsys):
    from hydropwa.cli import main

    camp = tmp_path / "c.toml"
    camp.write_text(
        '[deadzone]\ninputs = ["10 %"]\ndirections = ["extend"]\nduration = "0.2 s"\n'
        '[supply]\nrelief_pressure = "250 bar"\n'
    )
    assert (
        main(
            [
                "rig",
                "run",
                "deadzone",
                "--params",
                str(MACHINES / "industrial.toml"),
                "--campaign",
                str(camp),
                "--out",
                str(tmp_path / "o"),
                "--quiet",
            ]
        )
        == 0
    )
    assert (
        main(
            [
                "rig",
                "run",
                "deadzone",
                "--params",
                str(MACHINES / "industrial.toml"),
                "--campaign",
                str(camp),
                "--out",
                str(tmp_path / "p"),
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "position -62.5…562.5 mm, pressures 0–400 bar, load cell ±200 kN" in out
    assert "relief 250 bar" in out


def test_a_sine_run_ends_before_the_stop_on_a_short_fast_axis():
    """Paper campaign's 1 Hz, 60 % sine on the 100 mm axis reaches the stop within 3 s, where a
    chamber empties below the 0 bar end of its converter (the run was lost); it now ends once the
    rod comes within 2 % of the stroke of a stop (after one period at least) and passes."""
    from hydropwa.data import check_run

    small = load_params(MACHINES / "small.toml")
    rig = Rig(params=small)
    camp = parse_campaign({"sine": {"frequencies": ["1 Hz"], "amplitudes": ["60 %"]}})
    spec = plan(camp["sine"], rig)[0]
    run = execute(rig, spec, run_seed(1, "sine", spec.name))
    assert run.meta["stopped_early"] and run["t"][-1] == pytest.approx(1.0)  # one period at least
    assert [str(i) for i in check_run(run) if i.severity == "error"] == []
