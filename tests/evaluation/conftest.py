"""Fixtures of the evaluation tests: a virtual-rig sine run and a small paper study."""

from __future__ import annotations

from pathlib import Path

import pytest

HERE = Path(__file__).parent
SMALL_CAMPAIGN = HERE / "small_campaign.toml"


@pytest.fixture(scope="session")
def sine_run():
    """One virtual-rig sine run (60 % opening, 3 Hz, 4 periods) with true parameters."""
    from hydropwa.rig import Rig, SineExperiment, execute, plan, run_seed

    rig = Rig.from_params("paper")
    exp = SineExperiment(frequencies=(3.0,), amplitudes=(0.6,), periods=4, start_position=0.1)
    spec = plan(exp, rig)[0]
    return execute(rig, spec, run_seed(1, "sine", spec.name)), rig.params


@pytest.fixture(scope="session")
def small_study(tmp_path_factory):
    """A small study on the virtual rig (the campaign in small_campaign.toml)."""
    from hydropwa.studies.paper import run_paper_study

    out = tmp_path_factory.mktemp("study") / "report"
    return run_paper_study(out, campaign=SMALL_CAMPAIGN, progress=False)
