"""Converter limits, simulated runs and campaign folders in the validator (issue 18, items 2 and 8)."""

from __future__ import annotations

import numpy as np
import pytest

from hydropwa import simulate
from hydropwa.cli import main
from hydropwa.data import Run, check_run
from hydropwa.models import FullOrderModel, ReducedModel
from hydropwa.params import get_preset
from hydropwa.rig import Rig, SensorModel, measure, parse_campaign, run_campaign


def _pot_run(true_x: float, n: int = 2000) -> Run:
    """A position channel through the paper's pot (−25…225 mm) with the rod at ``true_x``."""
    pot = SensorModel("pot", "x", "m", (-0.025, 0.225), noise_std=5e-6)
    rng = np.random.default_rng(1)
    t = np.arange(n) / 2000.0
    x = pot.apply(np.full(n, true_x), rng)
    return Run(
        "r",
        {"t": t, "x": x, "u": np.full(n, 0.05)},
        fs=2000.0,
        meta={"converter_limits": {"x": list(pot.recorded_limits)}},
    )


def test_a_channel_at_the_converter_limit_for_the_whole_run_is_found():
    """A 500 mm rod read by a 250 mm pot: every sample is the top code (issue 18)."""
    run = _pot_run(0.4)
    assert np.ptp(run["x"]) == 0.0
    found = [i for i in check_run(run) if i.code == "clipped"]
    assert len(found) == 1 and found[0].severity == "error"
    assert "for the whole run" in found[0].message and "larger range" in found[0].hint
    # inside the range the same sensor gives no finding
    assert [i for i in check_run(_pot_run(0.1)) if i.severity == "error"] == []


@pytest.mark.parametrize("model", [FullOrderModel, ReducedModel])
@pytest.mark.parametrize("u", ["sine:amplitude=0.4,frequency=1", "step:time=0.1,after=0.5", "0.05"])
def test_the_packages_own_simulated_runs_pass_the_validator(model, u):
    run = simulate(model(get_preset("paper")), u, duration=2.0, fs=1000).to_run()
    assert [str(i) for i in check_run(run) if i.severity == "error"] == []


def test_the_rig_writes_its_converter_limits_with_each_run():
    rig = Rig.from_params("paper")
    res = simulate(FullOrderModel(rig.params), 0.0, duration=0.1, fs=rig.fs)
    run = measure(res, rig.sensors, np.random.default_rng(0))
    lo, hi = run.meta["converter_limits"]["x"]
    assert lo == pytest.approx(-0.025) and hi == pytest.approx(
        0.225, abs=rig.sensors["x"].quantization_step
    )


def test_data_check_accepts_a_campaign_folder(tmp_path, capsys):
    camp = parse_campaign(
        {
            "deadzone": {"inputs": [0.05, 0.2], "directions": ["extend"], "duration": 0.3},
            "sine": {"frequencies": [2.0], "amplitudes": [0.2], "periods": 1},
        }
    )
    run_campaign(Rig.from_params("paper"), camp, tmp_path / "c")
    assert main(["data", "check", str(tmp_path / "c")]) == 0
    assert "no issues" in capsys.readouterr().out


def test_simulate_then_identify_uses_every_simulated_run():
    """simulate → Run → identify: the package's own runs are not screened out (issue 18, item 8)."""
    from hydropwa.identification import identify

    p = get_preset("paper")
    runs = []
    for u in (0.03, 0.06, 0.09, 0.12, 0.15, 0.18, 0.21):
        for sign in (1, -1):
            x0 = 0.0 if sign > 0 else p.cylinder.stroke
            res = simulate(FullOrderModel(p), sign * u, duration=0.6, initial_position=x0, fs=1000)
            runs.append(
                res.to_run(f"dz_{sign * u:+.2f}", meta={"kind": "deadzone", "level": sign * u})
            )
    rep = identify(runs, ["deadzone"], params=p)
    assert rep.skipped == [] and len(rep.dead_zone.points_) == len(runs)
    assert abs(rep.params.dead_zone.beta - p.dead_zone.beta) < 0.005
