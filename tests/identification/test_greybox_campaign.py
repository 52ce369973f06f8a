"""The joint fit of a whole campaign (greybox/campaign.py, issue 36): its pieces.

``free="all"`` names every group the campaign's experiments inform; a free ω0 moves the whole
Table II schedule (the model reads the schedule); the selection by experiment gives every
experiment its share of the budget; the start is ``identify all``'s, a given parameter set of
the same machine, or the machine's own; the CLI's ``--start auto`` picks between them.
"""

from __future__ import annotations

import dataclasses
import types
from pathlib import Path

import numpy as np
import pytest

from hydropwa._errors import IdentificationError
from hydropwa.cli._identify import _joint_start
from hydropwa.identification.greybox import JOINT_GROUPS, PARAMETER_GROUPS, expand_free
from hydropwa.identification.greybox.campaign import (
    CAMPAIGN_CHANNELS,
    _start,
    campaign_options,
)
from hydropwa.identification.greybox.objective import OutputErrorObjective
from hydropwa.identification.greybox.selection import Selection, _spread
from hydropwa.models import FullOrderModel
from hydropwa.params import get_preset, load_params

MACHINES = Path(__file__).parent.parent / "machines"


def test_all_is_every_joint_group_once():
    p = get_preset("paper")
    got = expand_free("all", p)
    want = [n for g in JOINT_GROUPS for n in PARAMETER_GROUPS[g]]
    assert list(got) == want and len(set(got)) == len(got)
    for n in ("valve.omega0", "valve.zeta", "dead_zone.beta", "flow.K", "oil.bulk_modulus"):
        assert n in got
    assert "cylinder.leakage" in got and "friction.static" in got


def test_a_free_omega0_scales_the_whole_schedule():
    """The industrial axis has a Table II schedule (60/45/25 Hz): the model reads it, so the
    fit's ω0 must move it; ω0 +10 % gives +10 % at every opening, and ζ alone leaves it."""
    p = load_params(MACHINES / "industrial.toml")
    assert p.valve.omega0_table
    obj = OutputErrorObjective(
        FullOrderModel(p), [], ("valve.omega0", "valve.zeta"), (), 1e-5, 1, {}
    )
    q = obj.params_at(np.array([1.1 * p.valve.omega0, p.valve.zeta]))
    for a in (0.05, 0.1, 0.2, 0.5, 0.9, 1.0):
        assert q.valve.omega0_at(a) == pytest.approx(1.1 * p.valve.omega0_at(a), rel=1e-12)
    same = obj.params_at(np.array([p.valve.omega0, 0.9 * p.valve.zeta]))
    assert np.allclose(same.valve.omega0_table, p.valve.omega0_table, rtol=1e-12)


def _fake_run(speed):
    seg = types.SimpleNamespace(i0=0, i1=10)
    return types.SimpleNamespace(speed=np.full(10, speed), segments=[seg])


def test_the_selection_by_experiment_keeps_every_experiment():
    """Twenty friction runs at spread speeds and four FRF runs at zero speed, budget for six:
    without groups the speeds decide and the FRF runs (all at zero) get at most one place;
    by experiment each gets three, spread over its speeds (both ends kept)."""
    runs = [_fake_run(0.01 * k) for k in range(1, 21)] + [_fake_run(0.0) for _ in range(4)]
    groups = ["friction"] * 20 + ["frf"] * 4
    plain = _spread(runs, 6, None)
    assert len([k for k in plain if k >= 20]) <= 1
    by = _spread(runs, 6, groups)
    assert len([k for k in by if k >= 20]) == 3
    fr = sorted(k for k in by if k < 20)
    assert len(fr) == 3 and fr[0] == 0 and fr[-1] == 19
    # at least two per experiment even when the budget is smaller
    assert len([k for k in _spread(runs, 2, groups) if k >= 20]) == 2


def test_the_campaign_options_fill_only_what_is_open():
    opts = campaign_options()
    assert opts.channels == CAMPAIGN_CHANNELS
    assert opts.selection.by_experiment and opts.selection.method == "events"
    mine = campaign_options(channels=("x",), selection=Selection(budget=3.0))
    assert mine.channels == ("x",)
    assert mine.selection.budget == 3.0 and mine.selection.by_experiment


def test_the_start_must_be_the_data_machine():
    paper = get_preset("paper")
    other = load_params(MACHINES / "industrial.toml")
    with pytest.raises(IdentificationError, match="cylinder.area_a"):
        _start(None, paper, other)
    tweaked = paper.replace(**{"flow.K": 0.9 * paper.flow.K})
    assert _start(None, paper, tweaked)[0] is tweaked
    assert _start(None, paper, "params")[0] is paper
    with pytest.raises(IdentificationError, match="choose 'identify'"):
        _start(None, paper, "best")


def test_the_start_rule():
    """``auto``: the ordinary fit unless ``--free all``; then identify all first, unless the
    parameters are those identify all wrote (their meta.identification: the library's rule)."""
    from hydropwa.identification.greybox.campaign import auto_start

    p = get_preset("paper")
    identified = dataclasses.replace(p, meta={**p.meta, "identification": {"identified": ["frf"]}})
    assert _joint_start("auto", "friction") is None
    assert _joint_start("auto", "flow.K, all") == "auto"
    assert _joint_start("identify", "flow.K") == "identify"
    assert _joint_start("params", "flow.K") == "params"
    assert auto_start(p) == "identify"
    assert auto_start(identified) is identified
    with pytest.raises(IdentificationError, match="choose auto, identify or params"):
        _joint_start("first", "all")
