"""The shared signal helpers (hydropwa._signal): the robust noise level against white noise of
known σ on a trend its difference order removes, and the rail check against constructed
saturated and quantised records."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hydropwa._signal import mask_runs, robust_noise, stuck_at_rails


@settings(max_examples=25, deadline=None)
@given(
    order=st.integers(1, 4),
    sigma=st.floats(1e-6, 1e3),
    seed=st.integers(0, 2**31 - 1),
)
def test_robust_noise_recovers_sigma_under_a_trend_the_difference_removes(order, sigma, seed):
    rng = np.random.default_rng(seed)
    n = 20_000
    t = np.linspace(0.0, 1.0, n)
    trend = 1e3 * sigma * t ** (order - 1)  # degree order − 1: the order-th difference is 0
    est = robust_noise(trend + sigma * rng.standard_normal(n), order)
    # the MAD of n = 2·10⁴ correlated differences has a relative standard error below 2 %
    # (1.1/√n per independent sample, times the correlation of overlapping differences)
    assert est == pytest.approx(sigma, rel=0.08)


def test_robust_noise_ignores_sharp_events_and_short_records():
    y = 0.01 * np.random.default_rng(0).standard_normal(5000)
    y[::100] += 5.0  # 1 % spikes of 500 σ
    assert robust_noise(y, 2) == pytest.approx(0.01, rel=0.1)
    assert robust_noise(np.array([1.0]), 1) == 0.0
    # the normalisation is the variance of the k-th difference of white noise, C(2k, k) σ²
    assert [math.comb(2 * k, k) for k in range(1, 5)] == [2, 6, 20, 70]


def test_mask_runs():
    starts, lengths = mask_runs(np.array([0, 1, 1, 0, 1, 0, 0, 1, 1, 1], bool))
    assert starts.tolist() == [1, 4, 7] and lengths.tolist() == [2, 1, 3]


def test_stuck_at_rails_finds_a_saturated_converter_not_a_quantised_signal():
    t = np.linspace(0.0, 1.0, 1000)
    v = np.sin(2 * np.pi * 2 * t)
    clipped = np.minimum(v, 0.8)
    clipped[5] = np.nan  # ignored for the extremes
    (side, level, starts, lengths), *more = stuck_at_rails(clipped, 5)
    assert not more and side == "maximum" and level == 0.8
    at = clipped >= 0.8
    assert lengths.sum() == at.sum() and lengths.size == 2  # two sine crests
    assert starts.tolist() == mask_runs(at)[0].tolist()
    quantised = np.round(10 * t) / 10  # a slow ramp in 0.1 steps: flat everywhere
    assert quantised.max() == 1.0 and np.sum(quantised == 1.0) >= 5
    assert stuck_at_rails(quantised, 5) == []
    assert stuck_at_rails(np.ones(100), 5) == []
