"""Metrics against hand-computed values."""

import math

import numpy as np
import pytest

from hydropwa.evaluation import drift_per_period, nrmse_fit, peak_error, rmse


def test_nrmse_of_a_known_pair():
    y = np.array([1.0, 2.0, 3.0, 4.0])  # mean 2.5, ‖y − ȳ‖ = √5
    y_hat = np.array([1.0, 2.0, 3.0, 5.0])  # ‖y − ŷ‖ = 1
    assert nrmse_fit(y, y_hat) == pytest.approx(100 * (1 - 1 / math.sqrt(5)))
    assert nrmse_fit(y, y) == 100.0
    assert nrmse_fit(y, np.full(4, 2.5)) == pytest.approx(0.0)


def test_rmse_and_peak_error():
    y = np.zeros(4)
    y_hat = np.array([1.0, -1.0, 1.0, -3.0])
    assert rmse(y, y_hat) == pytest.approx(math.sqrt(12 / 4))
    assert peak_error(y, y_hat) == 3.0


def test_non_finite_model_samples_are_left_out():
    y = np.array([1.0, 2.0, 3.0, 4.0])
    y_hat = np.array([1.0, 2.0, np.nan, 4.0])
    assert rmse(y, y_hat) == 0.0
    assert math.isnan(nrmse_fit(np.ones(3), np.ones(3)))  # constant measurement: undefined


def test_drift_per_period_of_a_ramp_plus_sine():
    t = np.arange(0, 5.0, 1e-3)  # five periods of 1 s
    x = 0.003 * t + 0.01 * np.sin(2 * np.pi * t)
    assert drift_per_period(t, x, 1.0) == pytest.approx(0.003, rel=1e-9)
    assert drift_per_period(t, 0.003 * t, 0.5) == pytest.approx(0.0015, rel=1e-9)
    assert math.isnan(drift_per_period(t[:1500], x[:1500], 1.0))  # fewer than two periods


def test_length_mismatch_is_an_error():
    with pytest.raises(ValueError, match="differ in length"):
        rmse([1.0, 2.0], [1.0])
