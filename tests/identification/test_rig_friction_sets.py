"""Stribeck recovery on virtual-rig friction campaigns for three true parameter sets, both methods.

Campaign: the paper's friction experiment (constant inputs 5–50 % both directions against
1.5 kN), every 2nd % step, default sensor noise, seeded. Most tests here use an UNDAMPED
counter force (``counter_damping = 0``) to document the stick-slip case; the last tests use
the rig's default damped counter cylinder (``Load.damping`` = 1e4 N·s/m), which removes the
stick-slip: F_c, F_s and σ then come out within 6 % for all three sets. Measured errors are in
docs/architecture_identification.md. σ is recovered within 10 % by both methods; F_s is not
(−30 … −45 %): the runs below ≈ 40–50 mm/s stick-slip at ≈ 200 Hz and cross 2–10 mm/s,
where the Stribeck peak lies, within one 2 kHz sample, so F_s is an extrapolation.

``BreakawayConstrained()`` adds the stick-slip break-away force (net-force peaks of the slowest
stick-slip runs) as the curve's maximum. That force is measured within 7 % of the true
curve maximum (asserted), but F_s still misses by ≈ 20 %: the maximum lies at ≈ 1.5 mm/s,
below F_s by tanh(γẋ)·exp(−(ẋ/χ)^δ), and δ (with F_c) is not pinned by the data above
10–20 mm/s, so the fit trades δ → 0.5 and F_c → 0 against F_s.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import hydropwa.rig as rig  # noqa: E402  (an ImportError of the package must fail, not skip)
from hydropwa.components import stribeck_friction
from hydropwa.identification import (
    BreakawayConstrained,
    InstantaneousBins,
    SteadyStateAverage,
    StribeckIdentifier,
    curve_maximum,
    friction_samples,
    load_runs,
)
from hydropwa.params import get_preset

SETS = {
    "paper": {},
    "B": {
        "friction.coulomb": 40.0,
        "friction.static": 120.0,
        "friction.viscous": 800.0,
        "friction.stribeck_velocity": 0.01,
    },
    "C": {
        "friction.coulomb": 60.0,
        "friction.static": 250.0,
        "friction.viscous": 1500.0,
        "friction.stribeck_velocity": 0.02,
        "friction.shape": 1.0,
        "friction.smoothness": 2000.0,
    },
}

CAMPAIGN = {
    "campaign": {"name": "friction-sets", "seed": 7},
    "friction": {
        "inputs": {"start": "5 %", "stop": "50 %", "step": "2 %"},
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
        "counter_damping": "0 N*s/m",
    },
}
"""An undamped counter force: the slow runs stick-slip (the tests below document that case)."""

DAMPED = {**CAMPAIGN, "friction": {**CAMPAIGN["friction"], "counter_damping": "1e4 N*s/m"}}
"""The rig's default: the coupled counter cylinder damps the rod (no stick-slip down to 10 mm/s)."""


@pytest.fixture(scope="module", params=sorted(SETS))
def campaign(request, tmp_path_factory):
    params = (
        get_preset("paper").replace(**SETS[request.param])
        if SETS[request.param]
        else get_preset("paper")
    )
    out = tmp_path_factory.mktemp(f"fr_{request.param}")
    rig.run_campaign(rig.Rig(params=params), rig.parse_campaign(CAMPAIGN), out, jobs=2)
    return request.param, params, load_runs(out, params=params)


_METHODS = {
    "average": SteadyStateAverage(),
    "instantaneous": InstantaneousBins(),
    "breakaway": BreakawayConstrained(),
}


def _fit(campaign, method):
    _, params, runs = campaign
    with (
        warnings.catch_warnings()
    ):  # slow creeping runs without a steady part are skipped (average)
        warnings.simplefilter("ignore")
        return StribeckIdentifier(params, method=_METHODS[method]).fit(runs)


@pytest.mark.parametrize("method", ["average", "instantaneous", "breakaway"])
def test_viscous_within_10_percent(campaign, method):
    _, params, _ = campaign
    ident = _fit(campaign, method)
    assert ident.friction_.viscous == pytest.approx(
        params.friction.viscous, rel=0.10 if method != "breakaway" else 0.15
    )
    v = np.concatenate([np.linspace(0.06, 0.18, 20), -np.linspace(0.06, 0.18, 20)])
    tf = params.friction
    true = stribeck_friction(
        v, tf.coulomb, tf.static, tf.viscous, tf.stribeck_velocity, tf.shape, tf.smoothness
    )
    assert np.max(np.abs(ident.fit_.force_at(v) - true)) < (10.0 if method != "breakaway" else 15.0)


def test_breakaway_force_is_the_curve_maximum(campaign):
    """Net-force peaks of the slowest stick-slip runs measure max f(ẋ) (not F_s) within 7 %."""
    _, params, _ = campaign
    ident = _fit(campaign, "breakaway")
    f_max, v_at = curve_maximum(params.friction, 0.2)
    assert 1e-3 < v_at < 3e-3  # the maximum lies in the tanh/Stribeck corner, 0.83-0.95 F_s
    assert ident.breakaway_.value == pytest.approx(f_max, rel=0.07)
    assert ident.breakaway_.value > f_max  # overshoot of the loading ramp plus noise: biased high
    used = ident.breakaway_runs_[ident.breakaway_runs_["used"]]
    assert set(used["direction"]) == {1.0, -1.0} and (used["mean_speed"] < 5e-3).all()
    fm, _ = curve_maximum(ident.friction_, 0.2)
    assert fm == pytest.approx(ident.breakaway_.value, rel=0.02)  # the constraint holds
    assert any("break-away force" in n for n in ident.notes_)


@pytest.mark.xfail(
    strict=True,
    reason="stick-slip below ~45 mm/s: the Stribeck peak is not sampled at 2 kHz "
    "(see module docstring); F_s comes out 30-45 % low, or ~+20 % with the "
    "break-away constraint (delta/F_c not pinned)",
)
@pytest.mark.parametrize("method", ["average", "instantaneous", "breakaway"])
def test_static_within_10_percent(campaign, method):
    _, params, _ = campaign
    assert _fit(campaign, method).friction_.static == pytest.approx(
        params.friction.static, rel=0.10
    )


def test_friction_samples_include_inertia():
    """Sinusoidal motion on a ramp: f = net − m·ẍ is the curve at every sample (no loop)."""
    p = get_preset("paper")
    c, m, fr = p.cylinder, 5.0, p.friction
    t = np.arange(0.0, 1.0, 1 / 2000.0)
    x = 0.02 + 0.05 * t + 4e-5 * np.sin(2 * np.pi * 80 * t)
    v = 0.05 + 4e-5 * 2 * np.pi * 80 * np.cos(2 * np.pi * 80 * t)
    a = -4e-5 * (2 * np.pi * 80) ** 2 * np.sin(2 * np.pi * 80 * t)
    f = stribeck_friction(
        v, fr.coulomb, fr.static, fr.viscous, fr.stribeck_velocity, fr.shape, fr.smoothness
    )
    p_b = np.full(t.size, 10e5)
    p_a = (f + m * a + 1500.0 + p_b * c.area_b) / c.area_a
    vs, fs = friction_samples(
        t, x, p_a, p_b, np.full(t.size, 1500.0), c.area_a, c.area_b, m, stroke=c.stroke
    )
    model = stribeck_friction(
        vs, fr.coulomb, fr.static, fr.viscous, fr.stribeck_velocity, fr.shape, fr.smoothness
    )
    assert vs.size > 1000
    assert np.max(np.abs(fs - model)) < 1.0  # m·ẍ amplitude is 51 N


@pytest.fixture(scope="module", params=sorted(SETS))
def damped_campaign(request, tmp_path_factory):
    params = (
        get_preset("paper").replace(**SETS[request.param])
        if SETS[request.param]
        else get_preset("paper")
    )
    out = tmp_path_factory.mktemp(f"frd_{request.param}")
    rig.run_campaign(rig.Rig(params=params), rig.parse_campaign(DAMPED), out, jobs=2)
    return request.param, params, load_runs(out, params=params)


# Measured with the damped counter cylinder, method="average" (identified vs true):
#   paper: F_c +5.3 %, F_s -2.7 %, σ -0.5 %, χ +3.1 %
#   B:     F_c +1.0 %, F_s -3.5 %, σ -0.3 %, χ +7.3 %
#   C:     F_c +0.7 %, F_s -0.7 %, σ -0.2 %, χ +0.6 %
# The creeping runs inside the dead band (5-9 %, ~1-2 mm/s) reach the Stribeck peak.
def test_damped_rig_recovers_friction(damped_campaign):
    _, params, _ = damped_campaign
    ident = _fit(damped_campaign, "average")
    f, t = ident.friction_, params.friction
    for name in ("coulomb", "static", "viscous"):
        assert getattr(f, name) == pytest.approx(getattr(t, name), rel=0.10), name


# Grey-box path (issue 19): the same undamped campaigns, fitted by multiple shooting (20 ms
# windows re-initialised from the measured pressures, position, spool and a smoothed velocity,
# chosen automatically: the slow runs stick-slip, so the whole friction experiment is fitted
# in windows). F_c, F_s, σ and χ free from 30-50 % off (δ, γ at the true values), 20 windows
# per run, 3 starts. Measured (one start): paper F_s +0.3 %, σ +8.5 %; B passes; C: F_s stalls
# at the start with one start, −0.8 % with three, σ +21 % (F_c −77 %: F_c, σ and χ trade
# against each other where the data only see the curve's sum).
@pytest.fixture(scope="module")
def greybox_fit(campaign):
    from hydropwa.identification import Shooting, fit_model
    from hydropwa.models import FullOrderModel

    name, params, runs = campaign
    tf = params.friction
    start = params.replace(
        **{
            "friction.coulomb": 1.3 * tf.coulomb,
            "friction.static": 0.7 * tf.static,
            "friction.viscous": 1.2 * tf.viscous,
            "friction.stribeck_velocity": 1.5 * tf.stribeck_velocity,
        }
    )
    free = "friction.coulomb,friction.static,friction.viscous,friction.stribeck_velocity"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = fit_model(
            FullOrderModel(start),
            runs,
            free,
            shooting=Shooting(max_windows=20),
            starts=3,
            jobs=2,
            profile="none",
        )
    return name, params, fit


@pytest.mark.slow
@pytest.mark.study
def test_greybox_static_within_10_percent(greybox_fit):
    _, params, fit = greybox_fit
    assert any(r.method == "multiple" for r in fit.runs_)  # the stick-slip runs were recognised
    assert fit.params_.friction.static == pytest.approx(params.friction.static, rel=0.10)


@pytest.mark.slow
@pytest.mark.study
def test_greybox_viscous_and_curve(greybox_fit):
    name, params, fit = greybox_fit
    if name == "C":
        pytest.xfail(
            "set C: σ +21 % (F_c, σ and χ trade against each other; the curve is off by 12 N at 180 mm/s)"
        )
    tf, f = params.friction, fit.params_.friction
    assert f.viscous == pytest.approx(tf.viscous, rel=0.10)
    v = np.concatenate([np.linspace(0.06, 0.18, 20), -np.linspace(0.06, 0.18, 20)])
    true = stribeck_friction(
        v, tf.coulomb, tf.static, tf.viscous, tf.stribeck_velocity, tf.shape, tf.smoothness
    )
    got = stribeck_friction(
        v, f.coulomb, f.static, f.viscous, f.stribeck_velocity, f.shape, f.smoothness
    )
    assert np.max(np.abs(got - true)) < 10.0
