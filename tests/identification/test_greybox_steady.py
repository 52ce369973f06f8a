"""The steady stretches of a campaign as their means (greybox/steady.py, issue 36).

A constant-input run against a constant load settles: its steady stretch's means are the
model's balance, known to their standard errors. The tests check the weighting's closed form
(the late half's squared weights sum to (σ/se)², so a mismatch δ costs (δ/se)²), that the
true parameters reproduce the means within a few standard errors, and that a 1 % error of
the flow coefficient or a 20 % error of the Coulomb friction (5 N of 1.5 kN) is seen.
"""

from __future__ import annotations

import numpy as np
import pytest
from ident_support import noisy_run

from hydropwa.identification.greybox.data import Shooting, prepare_run
from hydropwa.identification.greybox.objective import OutputErrorObjective
from hydropwa.identification.greybox.steady import steady_runs, steady_stretch
from hydropwa.models import FullOrderModel
from hydropwa.simulation import Sine, Step

CHANNELS = ("x", "p_a", "p_b")


@pytest.fixture(scope="module")
def steady(truth):
    """A valve step at 0.05 s against 1.5 kN, 1.6 s at about 0.1 m/s: the speed settles within
    ms, the chamber pressures' sum over tenths of a second."""
    m = FullOrderModel(truth)
    run = noisy_run(m, Step(0.05, 0.0, 0.3), 1.6, 11, x0=0.01, load=1500.0, name="step")
    rd = prepare_run(run, m, CHANNELS, Shooting(segment=0.1), [])
    sigma = {c: rd.sigma[c] for c in CHANNELS}
    return m, rd, sigma


def _cost(m, runs, sigma, values, names=("flow.K", "friction.coulomb")):
    obj = OutputErrorObjective(m, runs, names, CHANNELS, 1e-7, 1, sigma)
    r = obj.residual_vector(obj.simulate_all(np.asarray(values, dtype=float)))
    return float(r @ r)


def test_the_steady_stretch_starts_after_the_motion_and_is_weighted_by_its_standard_error(
    steady,
):
    m, rd, sigma = steady
    got = steady_stretch(rd, 3e-3, 0.1, 0.3)
    assert got is not None
    i0, i1 = got
    # after the sum pressure settled (the stretch halved from its start)
    assert rd.t[i0] > 0.15 and rd.t[i1 - 1] - rd.t[i0] >= 0.3
    (ps,), note = steady_runs([rd], CHANNELS, sigma, 3e-3, 0.1, 0.1)
    assert "steady stretches of 1 run" in note
    seg = ps.segments[0]
    assert set(seg.weight) == {"v", "p_a", "p_b"}  # the position by its speed
    for c in ("p_a", "p_b"):
        y = rd.y[c][i0:i1]
        assert ps.y[c][0] == pytest.approx(y.mean())
        se = sigma[c] / np.sqrt(np.sum(seg.weight[c] ** 2))
        # never below the white-noise standard error, and the first half weighs nothing
        assert se >= 0.999 * rd.sigma[c] / np.sqrt(y.size)
        assert np.all(seg.weight[c][: (seg.i1 - 2) // 2] == 0.0)
    slope = np.polyfit(rd.t[i0:i1], rd.y["x"][i0:i1], 1)[0]
    assert ps.y["v"][0] == pytest.approx(slope, rel=1e-9)


def test_the_true_parameters_reproduce_the_means_and_small_errors_are_seen(steady, truth):
    """Cost of the three weighted means (each ≈ χ²₁ at the truth): below 3 × 9 at the truth;
    K +1 % moves the speed by ~1 % (thousands of standard errors) and F_c +20 % the
    pressures' balance by 4 N."""
    m, rd, sigma = steady
    runs, _ = steady_runs([rd], CHANNELS, sigma, 3e-3, 0.1, 0.1)
    k, fc = truth.flow.K, truth.friction.coulomb
    at_truth = _cost(m, runs, sigma, [k, fc])
    assert at_truth < 27.0
    assert _cost(m, runs, sigma, [1.01 * k, fc]) > 100.0 * max(at_truth, 1.0)
    assert _cost(m, runs, sigma, [k, 1.2 * fc]) > at_truth + 9.0


def test_a_stretch_still_settling_or_a_sine_run_gives_none(truth, steady):
    m, rd, _sigma = steady
    # a run shorter than the shortest stretch: nothing
    assert steady_stretch(rd, 3e-3, 0.1, 1.6) is None
    run = noisy_run(m, Sine(amplitude=0.4, frequency=2.0), 1.0, 3, name="sine")
    sine = prepare_run(run, m, CHANNELS, Shooting(), [])
    assert steady_stretch(sine, 3e-3, 0.1, 0.3) is None
    assert steady_runs([sine], CHANNELS, _sigma, 3e-3, 0.1, 0.1) == ([], "")
