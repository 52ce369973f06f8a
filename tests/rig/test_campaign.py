"""Campaign files: the paper campaign, ranges, and errors that name the key."""

from __future__ import annotations

import numpy as np
import pytest

from hydropwa import ParameterError
from hydropwa.rig import builtin_campaigns, load_campaign, parse_campaign, plan


def test_paper_campaign_has_the_papers_settings(rig):
    c = load_campaign("paper")
    assert "paper" in builtin_campaigns()
    frf = c["frf"]
    assert [s.opening for s in frf.sweeps] == [0.1, 0.25, 0.9]
    assert [len(s.frequencies) for s in frf.sweeps] == [50, 50, 25]
    assert frf.sweeps[0].frequencies[:2] == (2.0, 4.0) and frf.sweeps[2].frequencies[-1] == 50.0
    dz = c["deadzone"]
    assert dz.inputs[0] == 0.01 and dz.inputs[-1] == 0.2 and len(dz.inputs) == 39
    fr = c["friction"]
    assert fr.inputs[0] == 0.05 and fr.inputs[-1] == 0.5 and len(fr.inputs) == 46
    assert 1000.0 <= fr.counter_force <= 2000.0
    sine = c["sine"]
    assert sine.frequencies == (1.0, 2.0, 3.0) and sine.amplitudes == (0.2, 0.4, 0.6)
    counts = {name: len(plan(exp, rig)) for name, exp in c.experiments.items()}
    assert counts == {"frf": 125, "deadzone": 78, "friction": 92, "sine": 11}


def test_run_names_are_unique(rig):
    c = load_campaign("paper")
    for exp in c.experiments.values():
        names = [s.name for s in plan(exp, rig)]
        assert len(set(names)) == len(names)


def test_load_by_path(small_campaign_file):
    c = load_campaign(small_campaign_file)
    assert c.name == "small" and c.seed == 7
    assert set(c.experiments) == {"frf", "deadzone", "friction", "sine"}


@pytest.mark.parametrize(
    ("doc", "key"),
    [
        ({"deadzone": {}}, r"\[deadzone\]\.inputs is missing"),
        ({"deadzone": {"inputs": ["5 %"], "duration": "-1 s"}}, r"\[deadzone\]\.duration"),
        ({"deadzone": {"inputs": ["5 %"], "speed": 1}}, r"unknown key\(s\) speed"),
        ({"sine": {"frequencies": ["1 bar"], "amplitudes": [0.2]}}, r"\[sine\]\.frequencies\[0\]"),
        ({"frf": {"sweep": [{"opening": 2.0, "frequencies": [2.0]}]}}, r"sweep\[0\]\.opening"),
        ({"friction": {"inputs": {"start": 0.1, "stop": 0.05, "step": 0.01}}}, "stop"),
        ({"deadzone": {"inputs": [0.05], "directions": ["up"]}}, "directions"),
        ({"stribeck": {}}, "unknown table"),
        ({"campaign": {"seed": -1}}, r"\[campaign\]\.seed"),
        (
            {"sine": {"frequencies": [1], "amplitudes": [0.2], "load": {}}},
            r"load\.inputs is missing",
        ),
        (
            {
                "sine": {
                    "frequencies": [1],
                    "amplitudes": [0.2],
                    "load": {"inputs": [0.2], "levels": [0.5]},
                }
            },
            "at least two levels",
        ),
        (
            {
                "sine": {
                    "frequencies": [1],
                    "amplitudes": [0.2],
                    "load": {"inputs": [0.2], "levels": [0, 1.5]},
                }
            },
            r"levels\[1\]",
        ),
        (
            {
                "sine": {
                    "frequencies": [1],
                    "amplitudes": [0.2],
                    "load": {"inputs": [0.2], "valve_delay": "0.1 s"},
                }
            },
            "force_ramp",
        ),
        (
            {
                "sine": {
                    "frequencies": [1],
                    "amplitudes": [0.2],
                    "load": {"inputs": [0.2], "push": 1},
                }
            },
            "unknown key",
        ),
    ],
)
def test_errors_name_the_key(doc, key):
    with pytest.raises(ParameterError, match=key):
        parse_campaign(doc, "bad.toml")


def test_missing_campaign_lists_builtins():
    with pytest.raises(ParameterError, match="paper"):
        load_campaign("no-such-campaign")


def test_load_profile_walks_the_load_pressure_range(rig):
    """[sine.load]: F_L starts at the machine's static load, reaches A_A·P_L at each level of the
    direction's range (components.load_pressure_range) and joins the levels by ramp, step, ramp."""
    from hydropwa.components import load_pressure_range
    from hydropwa.rig import load_profile

    exp = load_campaign("paper")["sine"].load
    prm = rig.params
    cyl, sup = prm.cylinder, prm.supply
    for d in (1, -1):
        t, f = (np.asarray(v) for v in load_profile(exp, prm, d))
        assert np.all(np.diff(t) > 0) and f[0] == pytest.approx(prm.load.force)
        lo, hi = load_pressure_range(d, sup.pressure, cyl.area_b / cyl.area_a, sup.tank_pressure)
        want = [cyl.area_a * (lo + lev * (hi - lo)) for lev in exp.levels]
        held = f[np.r_[np.diff(f) == 0, False]]  # the start of each hold
        assert np.allclose(held, want)
        gaps = np.diff(t)[np.diff(f) != 0][1:]  # the transitions after the ramp-up
        trans = gaps[-(len(exp.levels) - 1) :]
        assert np.allclose(trans, [exp.ramp, 1e-3, exp.ramp][: len(trans)])
