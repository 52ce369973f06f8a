"""Shared fixtures of the rig tests: a small campaign and the paper rig."""

from __future__ import annotations

import pytest

from hydropwa.rig import Rig, load_campaign

SMALL_CAMPAIGN = """
[campaign]
name = "small"
seed = 7

[frf]
settle = "0.02 s"
periods = 4
margin_periods = 1

[[frf.sweep]]
opening = "25 %"
frequencies = ["20 Hz", "40 Hz"]

[deadzone]
inputs = ["5 %", "15 %"]
directions = ["extend", "retract"]
duration = "1 s"

[friction]
inputs = ["20 %"]
directions = ["extend"]
counter_force = "1.5 kN"
duration = "1.5 s"

[sine]
frequencies = ["3 Hz"]
amplitudes = ["20 %"]
periods = 2
"""


@pytest.fixture(scope="session")
def small_campaign_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("campaign") / "small.toml"
    path.write_text(SMALL_CAMPAIGN, encoding="utf-8")
    return path


@pytest.fixture(scope="session")
def small_campaign(small_campaign_file):
    return load_campaign(small_campaign_file)


@pytest.fixture(scope="session")
def rig():
    return Rig.from_params("paper")
