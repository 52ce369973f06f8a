"""Grey-box recovery from the virtual rig's sine runs (issue 19), over seeds (slow).

Nine sine runs (1, 2, 3 Hz × 20, 40, 60 %) of 2 s from 2 cm, rig sensors and pump supply,
true leakage 2e-12 m³/(s·Pa). Free: bulk modulus, leakage, flow coefficient and viscous
friction, started 10–25 % away. Single shooting in 0.5 s segments (chosen automatically).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from hydropwa.identification import IdentificationWarning, fit_model
from hydropwa.models import FullOrderModel
from hydropwa.params import get_preset
from hydropwa.rig import Rig, RunSpec, execute, run_seed
from hydropwa.simulation import Sine

FREE = ("oil.bulk_modulus", "cylinder.leakage", "flow.K", "friction.viscous")
START = {"oil.bulk_modulus": 1.2, "cylinder.leakage": 0.75, "flow.K": 0.9, "friction.viscous": 1.2}
SEEDS = (1, 2, 3, 4, 5)


def _value(params, name):
    comp, fld = name.split(".")
    return getattr(getattr(params, comp), fld)


def _sine_runs(rig, seed):
    """The nine sine runs (1, 2, 3 Hz × 20, 40, 60 %) of 2 s from 2 cm, measured by ``rig``."""
    runs = []
    for f in (1.0, 2.0, 3.0):
        for a in (0.2, 0.4, 0.6):
            spec = RunSpec(
                name=f"sine_f{f:g}_a{round(100 * a)}",
                experiment="sine",
                command=Sine(amplitude=a, frequency=f),
                duration=2.0,
                start_position=0.02,
            )
            runs.append(execute(rig, spec, run_seed(seed, "sine", spec.name)))
    return runs


@pytest.fixture(scope="module")
def fits():
    truth = get_preset("paper").replace(**{"cylinder.leakage": 2e-12})
    rig = Rig(params=truth)
    start = truth.replace(**{n: START[n] * _value(truth, n) for n in FREE})
    out = []
    for seed in SEEDS:
        runs = _sine_runs(rig, seed)
        with warnings.catch_warnings():
            # a fit that stops short of its optimum (seed 4 or 5 on some machines, 1.1-1.5 std)
            # warns, lists it in identifiability_.unconverged and adds that step to the
            # variance: the tests below judge its estimates and intervals like the others'
            warnings.simplefilter("ignore", IdentificationWarning)
            out.append(fit_model(FullOrderModel(start), runs, FREE, jobs=2, profile="none"))
    return truth, out


@pytest.mark.slow
def test_sine_runs_recover_hydraulic_parameters(fits):
    """E, C_L, K within 1 % and σ within 3 %, converged.

    Measured with central differences: E +0.04 … +0.05 %, C_L within ±0.02 %, K +0.01 %,
    σ +0.5 … +0.7 % (the forward-difference Jacobian stalled in the K–σ valley at σ +10 … +12 %,
    E +0.2 %: see ``differences`` of ``fit_model``). The bounds are an order above the
    measured errors and below what a stall leaves."""
    truth, results = fits
    for fit in results:
        assert {r.method for r in fit.runs_} == {"single"}
        assert fit.optimizer_.success
        for n in FREE:
            tol = 0.03 if n == "friction.viscous" else 0.01
            assert fit.estimates_[n].value == pytest.approx(_value(truth, n), rel=tol), n


def _inside(fits) -> list[bool]:
    truth, results = fits
    return [
        fit.estimates_[n].ci[0] <= _value(truth, n) <= fit.estimates_[n].ci[1]
        for fit in results
        for n in FREE
    ]


@pytest.mark.slow
def test_truth_inside_95_percent_interval_for_90_percent(fits):
    """The issue's aim: at least 90 % of the 95 % intervals hold the truth.

    E, K and σ land above the truth on every seed (about +0.03 %, +0.01 %, +0.7 %): the
    segments start from smoothed noisy measurements and the model is driven by measured
    inputs, and those errors move the estimate by what no residual covariance shows. With
    their propagation (``nuisance_draws``, 16 draws) measured 20 of 20 inside over seeds 1–5,
    the largest |z| 1.84 (σ, seed 5); without it 16 of 20 (misses at 2.05–2.4 std)."""
    assert np.mean(_inside(fits)) >= 0.9


STICK_FREE = FREE + ("friction.coulomb", "friction.static")
STICK_START = {**START, "friction.coulomb": 1.3, "friction.static": 0.85}


@pytest.mark.slow
def test_coulomb_and_static_friction_found_from_sine_runs():
    """Six free parameters, F_c started +30 % and F_s −15 % away (the benchmark's fit, 2 s runs).

    The single-shooting cost is a narrow well in F_s on a plateau (a stick at a reversal shifts
    the phase of the rest of the segment): from this start the fit without the locating stage
    ended at F_c +48 %, F_s −20 % (benchmark, cost 3.2× that at the truth). The multiple-
    shooting locating stage finds the well; measured here F_c +2.4 %, F_s −0.3 %, σ −1.2 %, the
    hydraulic parameters within 0.1 %, after the full stage restarted from a lower difference
    point (+5.5 % without; −5.7 … +7.1 % when the fit's rtol was changed by 1–3 %: the stick
    events make the cost rough; the data's optimum at rtol 1e-7 is F_c +14.9 %, 2.9 std off).
    Benchmark, 5 s runs, seeds 1–2: F_c −5.2 … +2.2 %, F_s +0.1 … +0.2 %. Bounds: the issue's
    10 % for F_c and F_s, 3 % for σ and 1 % for the hydraulic parameters (as the test above);
    5 % for F_c from the sliding stage (measured −1.3, −3.0, −1.6 % over seeds 1–3).
    """
    truth = get_preset("paper").replace(**{"cylinder.leakage": 2e-12})
    runs = _sine_runs(Rig(params=truth), 1)
    start = truth.replace(**{n: STICK_START[n] * _value(truth, n) for n in STICK_FREE})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentificationWarning)
        fit = fit_model(FullOrderModel(start), runs, STICK_FREE, jobs=2, profile="none")
    assert fit.starts_[0].locate_evaluations > 0
    for n in STICK_FREE:
        tol = {"friction.coulomb": 0.10, "friction.static": 0.10, "friction.viscous": 0.03}.get(
            n, 0.01
        )
        assert fit.estimates_[n].value == pytest.approx(_value(truth, n), rel=tol), n
    # F_c and the hydraulic parameters come from the sliding stage (stretches above 2 v_s, F_s
    # held): on the full data F_c's cost is a flat floor under the stick events' runaway
    # (seeds 1–3 without the stage: F_c +2.4, +10.4, −6.8 %, intervals widened by the scan to
    # hold it); with it −1.3, −3.0, −1.6 %, inside intervals from −9.6 … +7.1 % to
    # −12.6 … +7.6 % of the truth
    assert fit.sliding_.held == ("friction.static",)
    assert "friction.coulomb" in fit.sliding_.parameters
    assert fit.estimates_["friction.coulomb"].value == pytest.approx(
        _value(truth, "friction.coulomb"), rel=0.05
    )
    lo, hi = fit.estimates_["friction.coulomb"].ci
    assert lo <= _value(truth, "friction.coulomb") <= hi
