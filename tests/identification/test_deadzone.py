"""Dead band, creep slope and gain (Sec. VI-B, Fig. 6, Table IV)."""

from __future__ import annotations

import numpy as np
import pytest
from ident_support import constant_input_runs, hinge_velocity

from hydropwa import IdentificationError
from hydropwa.identification import (
    DeadZoneIdentifier,
    RigGeometry,
    dead_zone_velocity,
    fit_dead_zone,
    velocity_from_position,
)

LEVELS = np.concatenate([np.arange(0.01, 0.2001, 0.005), -np.arange(0.01, 0.2001, 0.005)])


@pytest.mark.parametrize(
    "beta,gain,creep_kg,seed", [(0.10, 0.5, 0.04, 1), (0.08, 0.3, 0.02, 2), (0.123, 0.8, 0.06, 3)]
)
def test_beta_within_half_a_percent_from_noisy_points(beta, gain, creep_kg, seed):
    """2 % multiplicative + 0.1 mm/s additive velocity noise; β within 0.005 of full opening."""
    rng = np.random.default_rng(seed)
    v = hinge_velocity(LEVELS, beta, gain, creep_kg * gain)
    v = v * (1 + 0.02 * rng.standard_normal(v.size)) + 1e-4 * rng.standard_normal(v.size)
    fit = fit_dead_zone(LEVELS, v)
    assert abs(fit.beta.value - beta) < 0.005
    assert fit.gain_pos.value == pytest.approx(gain, rel=0.05)
    assert fit.creep_slope.value == pytest.approx(creep_kg, abs=0.01)
    assert fit.beta.ci[0] < fit.beta.value < fit.beta.ci[1]
    dz = fit.dead_zone()
    assert dz.beta == pytest.approx(fit.beta.value)


def test_asymmetric_band_and_continuous_variant():
    u = LEVELS
    v = dead_zone_velocity(u, 0.5, 0.45, 0.11, 0.09, 0.02, continuous=True)
    fit = fit_dead_zone(u, v, continuous=True)
    assert fit.beta_pos.value == pytest.approx(0.11, abs=1e-3)
    assert fit.beta_neg.value == pytest.approx(0.09, abs=1e-3)
    assert fit.beta.value == pytest.approx(0.10, abs=1e-3)
    assert fit.gain_neg.value == pytest.approx(0.45, rel=1e-3)


def _leaky_points(seed, c_l, noise=2e-5):
    """Hinge points plus the leakage velocity −C_L·r of a load pressure that changes per run.

    r = (P_A − P_B)/A_in [Pa/m²] between −40 and −10 bar over 20/30 cm² (as the industrial
    axis's retracting and extending runs), growing with the opening.
    """
    rng = np.random.default_rng(seed)
    u = LEVELS
    dp = -(10e5 + 30e5 * np.abs(u) / 0.2) * np.where(u >= 0, 1.0, 1.4)
    r = dp / np.where(u >= 0, 31e-4, 21e-4)
    v = dead_zone_velocity(u, 0.5, 0.45, 0.05, 0.05, 0.0) - c_l * r
    return u, v + noise * rng.standard_normal(u.size), r


def test_leakage_regressor_recovers_the_leakage_and_the_band():
    """v = hinge(u) − C_L·r is linear in C_L for each split: C_L, β± and the intervals are exact
    up to the 0.02 mm/s noise. Without the regressor the same points shift β by over 0.005."""
    c_l = 4e-12
    hits = 0
    for seed in range(1, 21):
        u, v, r = _leaky_points(seed, c_l)
        fit = fit_dead_zone(u, v, leakage_regressor=r)
        assert fit.leakage is not None
        assert fit.leakage.value == pytest.approx(c_l, rel=0.05)
        assert fit.beta_pos.value == pytest.approx(0.05, abs=1e-3)
        assert fit.beta_neg.value == pytest.approx(0.05, abs=1e-3)
        hits += fit.leakage.ci[0] <= c_l <= fit.leakage.ci[1]
    assert hits >= 16  # 95 % intervals: fewer than 16 of 20 has probability < 2 %
    blind = fit_dead_zone(u, v, drift=False)
    assert abs(blind.beta_neg.value - 0.05) > 0.005


def test_leakage_is_never_negative():
    """Without leakage in the data the estimate sits at its bound 0 with an interval [0, hi]."""
    u, v, r = _leaky_points(1, 0.0)
    fit = fit_dead_zone(u, v + 0.5e-12 * r, leakage_regressor=r)  # would fit C_L = −0.5e-12
    assert fit.leakage.value == 0.0
    assert fit.leakage.ci[0] == 0.0 < fit.leakage.ci[1]
    assert fit.beta.value == pytest.approx(0.05, abs=2e-3)
    with pytest.raises(IdentificationError, match="one finite value per point"):
        fit_dead_zone(u, v, leakage_regressor=r[:-1])


def test_velocity_from_position_drops_the_end_stop():
    t = np.arange(0.0, 2.0, 1 / 2000)
    x = np.clip(0.15 * t, 0.0, 0.2)  # reaches the stop at 1.33 s
    est = velocity_from_position(t, x, direction=1.0, stroke=0.2, stop_margin=1e-3)
    assert est.hit_stop
    assert est.velocity == pytest.approx(0.15, rel=1e-6)
    assert est.window[1] < 0.2 / 0.15


def test_identifier_on_runs():
    beta, gain = 0.1, 0.5
    runs = constant_input_runs(
        LEVELS, lambda u: hinge_velocity(u, beta, gain, 0.04 * gain), duration=1.0
    )
    ident = DeadZoneIdentifier(geometry=RigGeometry(stroke=0.2)).fit(runs)
    assert ident.skipped_ == []
    assert abs(ident.dead_zone_.beta - beta) < 0.005
    assert ident.dead_zone_.creep_slope == pytest.approx(0.04, abs=0.005)
    assert len(ident.points_) == LEVELS.size


def test_undetermined_creep_is_an_infinite_interval_never_nan():
    """One command per direction inside the band cannot fix the creep slope and the band edge
    apart: their std is infinite (the data do not determine them), not NaN from inf − inf."""
    u = np.array([0.05, 0.12, 0.14, 0.16, 0.18, 0.2])
    u = np.concatenate([u, -u])
    rng = np.random.default_rng(1)
    v = hinge_velocity(u, 0.1, 0.5, 0.02)
    v = v * (1 + 0.02 * rng.standard_normal(v.size)) + 1e-4 * rng.standard_normal(v.size)
    fit = fit_dead_zone(u, v)
    for est in (fit.beta, fit.creep_slope, fit.creep_velocity_slope):
        assert not np.isnan(est.std) and not np.isnan(est.ci).any()
    assert fit.creep_slope.std == np.inf
    assert fit.gain_pos.value == pytest.approx(0.5, rel=0.05)  # the opening's gain still is


def test_combination_std_of_a_delta_method_combination():
    """sqrt(gᵀCg) on the used parameters; an undetermined one makes it inf, an unused one not."""
    from hydropwa.identification._common import combination_std

    cov = np.array([[4.0, 1.0, np.nan], [1.0, 9.0, np.nan], [np.nan, np.nan, np.inf]])
    assert combination_std(cov, np.array([0.5, 0.5, 0.0])) == pytest.approx(
        0.5 * np.sqrt(4 + 9 + 2)
    )
    assert combination_std(cov, np.array([1.0, 0.0, 1.0])) == np.inf
    assert combination_std(np.array([[1.0, -1.0], [-1.0, 1.0]]), np.array([1.0, 1.0])) == 0.0
