"""Rig campaign → ``identify all`` on two machines unlike the paper's (issue 18, acceptance).

``tests/machines/industrial.toml``: 63/36 × 500 mm, 250 kg, 210 bar, a 60 L/min valve rated
across the whole valve with a 3 % overlap, 2 kN load, ω0 25–60 Hz. ``small.toml``: 25/16 ×
100 mm, 3 kg, 140 bar, 10 L/min, ω0 100–200 Hz, 200 N load. Both run the same small campaign
(``tests/machines/campaign.toml``, openings and positions as fractions); the rig sizes its
sensors and pump from each machine. Tolerances are those of the paper rig's recovery tests
(``test_rig_recovery.py``, ``test_rig_friction_sets.py``): ω0 and ζ 2 %, β ± 0.005, k_g ± 0.01,
F_c, F_s, σ 10 %.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

from hydropwa.data import check_run, read_dataset
from hydropwa.identification import IdentificationWarning, identify
from hydropwa.params import load_params
from hydropwa.rig import Rig, load_campaign, run_campaign

MACHINES = Path(__file__).parent.parent / "machines"

# two campaigns of ≈ 110 runs and two `identify all`: ≈ 25 s on an idle 2-core machine
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module", params=["industrial", "small"])
def identified(request, tmp_path_factory):
    true = load_params(MACHINES / f"{request.param}.toml")
    out = tmp_path_factory.mktemp(request.param)
    run_campaign(Rig(params=true), load_campaign(MACHINES / "campaign.toml"), out)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", IdentificationWarning)
        rep = identify(out, params=true)
    return true, rep, out, [str(w.message) for w in caught]


def test_no_run_is_lost_to_a_converter_limit(identified):
    true, rep, out, _ = identified
    assert not [s for s in rep.skipped if "converter" in s.reason or "clipped" in s.reason]
    for exp in ("frf", "deadzone", "friction"):
        ds = read_dataset(out / exp, validate=False)
        for name in ds.names:
            run = ds[name]
            assert not [
                i
                for i in check_run(run)
                if i.code == "clipped" and i.channel in ("x", "spool", "f_l")
            ]


def test_valve_recovered(identified):
    true, rep, _, _ = identified
    assert len(rep.valve.fits_) == 3
    for amp, fit in rep.valve.fits_.items():
        assert fit.omega0.value == pytest.approx(true.valve.omega0_at(amp), rel=0.02)
        assert fit.zeta.value == pytest.approx(true.valve.zeta, rel=0.02)
    assert rep.params.valve.zeta == pytest.approx(true.valve.zeta, rel=0.02)


def test_dead_zone_recovered(identified):
    true, rep, _, _ = identified
    assert abs(rep.params.dead_zone.beta - true.dead_zone.beta) < 0.005
    assert rep.params.dead_zone.creep_slope == pytest.approx(true.dead_zone.creep_slope, abs=0.01)


def test_friction_recovered(identified):
    true, rep, _, _ = identified
    got, want = rep.params.friction, true.friction
    for k in ("coulomb", "static", "viscous"):
        assert getattr(got, k) == pytest.approx(getattr(want, k), rel=0.10), k
