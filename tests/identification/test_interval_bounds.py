"""Intervals stay where a parameter has a meaning (issue 49, item 4): an interval that would
reach below a physical bound (a Coulomb force below 0 N) is cut there and says so."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hydropwa.components._physics import stribeck_friction
from hydropwa.identification import ParameterEstimate, fit_stribeck
from hydropwa.identification._common import PHYSICAL_BOUNDS, within_physical_bounds


def test_within_cuts_an_interval_at_its_bounds_and_names_the_cut_ends():
    e = ParameterEstimate(2.0, 3.0, (2.0 - 5.88, 2.0 + 5.88), "N")
    cut = within_physical_bounds("friction.coulomb", e)
    assert cut.ci == (0.0, pytest.approx(7.88)) and cut.clipped == "low"
    assert (cut.value, cut.std) == (e.value, e.std)  # the estimate itself is not moved
    assert cut.to_dict()["clipped"] == "low" and "clipped" not in e.to_dict()
    assert "clipped at its physical bound (low)" in str(cut)
    assert within_physical_bounds("coulomb", cut) == cut  # cutting twice changes nothing
    offset = ParameterEstimate(0.5, 0.4, (-0.3, 1.3), "1")
    assert within_physical_bounds("beta", offset).ci == (0.0, 1.0)
    assert within_physical_bounds("beta", offset).clipped == "low, high"
    inside = ParameterEstimate(40.0, 1.0, (38.0, 42.0), "N")
    assert within_physical_bounds("static", inside) is inside
    drift = ParameterEstimate(-1e-4, 1e-4, (-3e-4, 1e-4), "m/s")  # a signed quantity: no bound
    assert (
        "drift_pos" not in PHYSICAL_BOUNDS and within_physical_bounds("drift_pos", drift) is drift
    )
    assert PHYSICAL_BOUNDS["coulomb"] == (0.0, math.inf)


def test_a_small_coulomb_force_in_noise_has_an_interval_that_stops_at_zero():
    """A Stribeck curve with F_c = 1 N under 15 N of force noise (30 points, 2 … 200 mm/s
    both ways): the symmetric interval F_c ± q·std reaches below 0 N (checked from the
    reported value and std with q ≥ 1.96); the fit's interval stops at 0 and is flagged, its
    upper end is the symmetric one's."""
    rng = np.random.default_rng(4)
    speed = np.geomspace(2e-3, 0.2, 15)
    v = np.concatenate([speed, -speed])
    truth = dict(f_c=1.0, f_s=60.0, sigma=300.0, chi=0.01, delta=1.0, gamma=1e4)
    f = stribeck_friction(v, **truth) + rng.normal(0.0, 15.0, v.size)
    fit = fit_stribeck(v, f, fixed={"shape": 1.0, "smoothness": 1e4}, n_starts=8)
    fc = fit.estimates["coulomb"]
    assert fc.value - 1.96 * fc.std < 0.0, fc  # the symmetric interval would cross 0 N
    assert fc.ci[0] == 0.0 and fc.clipped == "low"
    assert fc.ci[1] > fc.value + 1.96 * fc.std
    for name, e in fit.estimates.items():
        lo, hi = PHYSICAL_BOUNDS[name]
        assert lo <= e.ci[0] <= e.ci[1] <= hi, (name, e)
