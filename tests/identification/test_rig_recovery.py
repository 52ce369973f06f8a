"""Parameter recovery on the virtual rig (hydropwa.rig): the paper's experiments, fewer runs, seeded.

The rig simulates the full-order model with the paper's sensors and supply; the
identification sees only its datasets. Tolerances are the measured errors plus
margin (see docs/architecture_identification.md for the numbers).
"""

from __future__ import annotations

import numpy as np
import pytest

import hydropwa.rig as rig  # noqa: E402  (an ImportError of the package must fail, not skip)
from hydropwa.components import stribeck_friction
from hydropwa.identification import identify
from hydropwa.params import TABLE_II, get_preset

CAMPAIGN = {
    "campaign": {"name": "ident-recovery", "seed": 11},
    "frf": {
        "settle": "0.05 s",
        "periods": 4,
        "margin_periods": 2,
        "start_position": "50 %",
        "sweep": [
            {"opening": "10 %", "frequencies": {"start": "4 Hz", "stop": "100 Hz", "step": "8 Hz"}},
            {"opening": "25 %", "frequencies": {"start": "4 Hz", "stop": "100 Hz", "step": "8 Hz"}},
            {"opening": "90 %", "frequencies": {"start": "4 Hz", "stop": "50 Hz", "step": "6 Hz"}},
        ],
    },
    "deadzone": {
        "inputs": {"start": "1 %", "stop": "20 %", "step": "1 %"},
        "directions": ["extend", "retract"],
        "duration": "4 s",
        "stop_at": "90 %",
        "min_duration": "0.2 s",
    },
    "friction": {
        "inputs": {"start": "11 %", "stop": "50 %", "step": "3 %"},
        "directions": ["extend", "retract"],
        "counter_force": "1.5 kN",
        "force_ramp": "0.3 s",
        "valve_delay": "0.4 s",
        "ripple": "1 %",
        "ripple_frequency": "7 Hz",
        "force_noise": "5 N",
        "force_rate": "500 Hz",
        "duration": "4 s",
        "stop_at": "90 %",
        "min_duration": "0.2 s",
    },
}


@pytest.fixture(scope="module")
def recovered(tmp_path_factory):
    out = tmp_path_factory.mktemp("rig")
    the_rig = rig.Rig.from_params("paper")
    rig.run_campaign(the_rig, rig.parse_campaign(CAMPAIGN), out, jobs=4)
    return identify(out, params=get_preset("paper")), the_rig.params


def test_valve_table_ii_recovered(recovered):
    rep, _ = recovered
    for amp, w0, zeta in TABLE_II:
        fit = rep.valve.fits_[amp]
        assert fit.omega0.value == pytest.approx(w0, rel=0.02)
        assert fit.zeta.value == pytest.approx(zeta, rel=0.02)


def test_dead_zone_recovered(recovered):
    rep, true = recovered
    assert abs(rep.params.dead_zone.beta - true.dead_zone.beta) < 0.005
    assert rep.params.dead_zone.creep_slope == pytest.approx(true.dead_zone.creep_slope, abs=0.01)


def test_friction_recovered_where_the_runs_are_steady(recovered):
    """σ within 10 %; the curve within 10 N for |ẋ| ≥ 40 mm/s.

    Below about 40 mm/s the rig's runs carry a small limit cycle (the Stribeck slope is
    negative there), so their averaged force is not the static curve; F_s and χ come out
    biased and are flagged (wide CI) rather than trusted. See the architecture notes.
    """
    rep, true = recovered
    fr, tf = rep.params.friction, true.friction
    assert fr.viscous == pytest.approx(tf.viscous, rel=0.10)
    v = np.concatenate([np.linspace(0.04, 0.18, 30), -np.linspace(0.04, 0.18, 30)])
    args_true = (tf.coulomb, tf.static, tf.viscous, tf.stribeck_velocity, tf.shape, tf.smoothness)
    args_fit = (fr.coulomb, fr.static, fr.viscous, fr.stribeck_velocity, fr.shape, fr.smoothness)
    assert np.max(np.abs(stribeck_friction(v, *args_fit) - stribeck_friction(v, *args_true))) < 10.0
    assert rep.skipped == []
