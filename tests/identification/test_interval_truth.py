"""Intervals that hold the truth, and every miss flagged (issue 49, item 4).

* The Stribeck fit's intervals over a family of friction shapes (δ 0.5–2, χ 5–30 mm/s,
  F_s/F_c 1.5–8) on two machines (the paper rig and the heavy axis of
  ``tests/machines/industrial.toml``): steady friction points at the speeds a
  constant-input campaign reaches (two creeping ones, then up to the machine's top speed,
  both directions) with force noise, fitted by :func:`fit_stribeck`. Every parameter must be
  within 10 % of its truth or have its 95 % interval hold it (the issue's criterion), and the
  curve's band must hold the true curve over the speeds the data excite. A few shapes run
  by default; the whole family (3 × 3 × 3 shapes × 2 machines × seeds) under the ``study``
  marker, or ``python tests/identification/test_interval_truth.py [seeds]`` for its table.
* The grey-box profiles carry the weak directions into the others' intervals
  (:func:`~hydropwa.identification.greybox.profile.carry`).
* One rule (:func:`~hydropwa.identification.truth_in_interval`) flags a truth outside its
  interval in both tables of the paper report that show one.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from hydropwa.components import stribeck_friction
from hydropwa.identification import TRUTH_OUTSIDE, ParameterEstimate, truth_in_interval
from hydropwa.identification._friction_curve import STRIBECK_NAMES, fit_stribeck
from hydropwa.identification.greybox.profile import carry
from hydropwa.identification.greybox.result import Profile

#: (Coulomb force [N], viscous coefficient [N·s/m], smoothness [s/m], top speed [m/s]):
#: the paper rig's preset (its friction campaign reaches 1.7–190 mm/s) and the heavy axis
#: of tests/machines/industrial.toml (60 L/min into 31 cm²: about 0.3 m/s)
MACHINES = {"paper": (21.15, 1158.45, 1324.68, 0.19), "industrial": (300.0, 4000.0, 2000.0, 0.3)}
#: the speeds of a constant-input campaign as fractions of the top speed: two creeping runs,
#: then evenly spaced openings
SPEED_FRACTIONS = np.concatenate([[0.009, 0.02], np.linspace(0.03, 1.0, 14)])
#: the family of the issue: shape δ, Stribeck velocity χ [m/s], F_s/F_c
SHAPES = (0.5, 1.0, 2.0)
CHIS = (0.005, 0.011, 0.03)
RATIOS = (1.5, 3.0, 8.0)


def _campaign_points(machine: str, delta: float, chi: float, ratio: float, seed: int):
    """Steady friction points (velocity [m/s], force [N]) of one campaign and the truth."""
    f_c, sigma, gamma, v_top = MACHINES[machine]
    truth = {
        "coulomb": f_c,
        "static": ratio * f_c,
        "viscous": sigma,
        "stribeck_velocity": chi,
        "shape": delta,
        "smoothness": gamma,
    }
    v = np.concatenate([SPEED_FRACTIONS, -SPEED_FRACTIONS]) * v_top
    f = stribeck_friction(v, f_c, ratio * f_c, sigma, chi, delta, gamma)
    # force noise of a steady point: 0.5 % of the Coulomb force (the rig's damped campaign:
    # 0.17 N RMS residual at 21 N) plus the pressure sensors' share
    rng = np.random.default_rng(seed)
    f = f + rng.normal(0.0, 0.005 * f_c + 0.1, v.size)
    return v, f, truth


def _holds(e: ParameterEstimate, true: float) -> bool:
    """The issue's criterion: within 10 % of the truth or its interval holds it."""
    return abs(e.value - true) <= 0.1 * abs(true) or truth_in_interval(*e.ci, true) == "yes"


def _check(machine: str, delta: float, chi: float, ratio: float, seed: int, n_starts: int):
    """Per parameter whether it holds, and whether the band holds the true curve."""
    v, f, truth = _campaign_points(machine, delta, chi, ratio, seed)
    fit = fit_stribeck(v, f, n_starts=n_starts)
    held = {}
    for name in STRIBECK_NAMES:
        if name == "smoothness" or name in fit.unidentified:
            continue  # γ: constant speeds of mm/s saturate the tanh; a value not identified is not written
        held[name] = _holds(fit.estimates[name], truth[name])
    vb, lo, hi = fit.band
    tv = stribeck_friction(vb, *(truth[n] for n in STRIBECK_NAMES))
    band = bool(np.all((lo <= tv + 1e-9) & (tv <= hi + 1e-9)))
    return held, band, fit


#: the default suite's cases: two corners of the family, one per machine (the issue's own
#: shape is the stored campaign below; the whole family runs under ``study``)
FAST_CASES = [("paper", 0.5, 0.03, 8.0), ("industrial", 2.0, 0.005, 1.5)]

#: Steady friction points (velocity [m/s], force [N]) of a virtual-rig campaign of the
#: paper rig with the issue's curve (F_c 42 N, F_s 118 N, σ 1158 N·s/m, χ 11 mm/s, δ 1.6):
#: the paper's friction experiment at every 3rd % step, 2.5 s runs, an undamped counter
#: force (stick-slip below ≈ 20 mm/s), seed 5. Before the shape profile ``identify``
#: reported F_s = 73.4 N with the interval [49.5, 97.2] N, the truth outside, F_s not weak.
_ISSUE_V = [-0.14976469, -0.13873989, -0.12768591, -0.11659247, -0.10546985, -0.09431151,
            -0.08311958, -0.07189742, -0.06063883, -0.04934866, -0.03802684, -0.02666792,
            -0.01526368, -0.00386109, 0.00169614, 0.0052957, 0.02100277, 0.03666756,
            0.05226918, 0.0678213, 0.08332422, 0.09878221, 0.11418525, 0.12953937, 0.14484126,
            0.16009193, 0.1752896, 0.19043514, 0.20552963]  # fmt: skip
_ISSUE_F = [-215.6786, -202.9223, -190.0556, -177.2073, -164.0621, -151.6178, -138.2061,
            -125.3288, -112.3602, -99.2842, -86.0009, -74.5556, -83.1027, -77.8399, 89.9389,
            77.1903, 87.3702, 84.8048, 102.617, 120.651, 138.6167, 156.1339, 174.2736,
            192.0797, 210.0492, 227.5388, 245.3432, 262.7899, 280.421]  # fmt: skip


def test_the_issues_campaign_reports_f_s_honestly():
    """The stick-slip runs pin F_c and σ but not the curve below 20 mm/s: F_s's interval
    must hold 118 N and F_s be flagged weak; the curve's band holds the true curve."""
    truth = {"coulomb": 42.0, "static": 118.0, "viscous": 1158.45, "stribeck_velocity": 0.011}
    fit = fit_stribeck(np.array(_ISSUE_V), np.array(_ISSUE_F), n_starts=8)
    for name, t in truth.items():
        assert _holds(fit.estimates[name], t), f"{name}: {fit.estimates[name]} (true {t:g})"
    assert "static" in fit.weak
    vb, lo, hi = fit.band
    tv = stribeck_friction(vb, 42.0, 118.0, 1158.45, 0.011, 1.6, 1324.68)
    assert np.all((lo <= tv) & (tv <= hi))


@pytest.mark.parametrize(("machine", "delta", "chi", "ratio"), FAST_CASES)
def test_stribeck_intervals_hold_the_truth_over_shapes_and_machines(machine, delta, chi, ratio):
    held, band, fit = _check(machine, delta, chi, ratio, seed=1, n_starts=8)
    wrong = [
        f"{n}: {fit.estimates[n]} (true {t:.4g})"
        for n, ok in held.items()
        if not ok
        for t in [_campaign_points(machine, delta, chi, ratio, 1)[2][n]]
    ]
    assert not wrong, f"{machine} δ {delta} χ {chi} F_s/F_c {ratio:.3g}: " + "; ".join(wrong)
    assert band, "the curve's band misses the true curve over the excited speeds"


@pytest.mark.slow
@pytest.mark.study
def test_stribeck_interval_coverage_over_the_whole_family():
    """≥ 90 % of the parameters hold over the family (3 seeds), per machine."""
    for machine in MACHINES:
        got = _family(machine, seeds=(1, 2, 3))
        share = np.mean([ok for row in got for ok in row[0].values()])
        assert share >= 0.9, f"{machine}: {100 * share:.0f} % of the parameters hold"


def _family(machine: str, seeds=(1,), n_starts: int = 8):
    return [
        _check(machine, d, c, r, s, n_starts)[:2]
        for d, c, r, s in itertools.product(SHAPES, CHIS, RATIOS, seeds)
    ]


#: the rig study's friction campaign (the paper's experiment, every 3rd step, 2.5 s runs)
RIG_CAMPAIGN = {
    "friction": {
        "inputs": {"start": "5 %", "stop": "50 %", "step": "3 %"},
        "directions": ["extend", "retract"],
        "counter_force": "1.5 kN",
        "duration": "2.5 s",
    }
}


@pytest.mark.slow
@pytest.mark.study
def test_rig_friction_campaigns_over_the_family(tmp_path):
    """The whole chain on the virtual rig: friction campaigns of the paper rig and the heavy
    axis with shapes of the family's corners and the issue's, ``identify`` on each; ≥ 90 %
    of the parameters hold (within 10 % or inside the interval)."""
    hits = rig_family(tmp_path, seeds=(1,))
    share = np.mean([ok for row in hits.values() for ok in row.values()])
    assert share >= 0.9, f"{100 * share:.0f} % hold: {hits}"


#: the rig study's shapes: the family's corners and the issue's shape on both machines
RIG_CASES = [*FAST_CASES, ("paper", 1.6, 0.011, 118.0 / 42.0), ("industrial", 1.6, 0.011, 2.8)]


def rig_family(tmp, seeds=(1,), cases=RIG_CASES) -> dict[tuple, dict[str, bool]]:
    """Per (machine, δ, χ, F_s/F_c, seed) whether each identified friction value holds."""
    import dataclasses
    import warnings
    from pathlib import Path

    from hydropwa.identification import IdentificationWarning, identify
    from hydropwa.params import get_preset, load_params
    from hydropwa.rig import Rig, parse_campaign, run_campaign

    machines = Path(__file__).parent.parent / "machines"
    out: dict[tuple, dict[str, bool]] = {}
    for (machine, delta, chi, ratio), seed in itertools.product(cases, seeds):
        p = get_preset("paper") if machine == "paper" else load_params(machines / f"{machine}.toml")
        fr = dataclasses.replace(
            p.friction,
            static=ratio * p.friction.coulomb,
            stribeck_velocity=chi,
            shape=delta,
        )
        p = dataclasses.replace(p, friction=fr)
        where = Path(tmp) / f"{machine}_{delta}_{chi}_{ratio:.3g}_{seed}"
        camp = parse_campaign({"campaign": {"name": "family", "seed": seed}, **RIG_CAMPAIGN})
        run_campaign(Rig(params=p), camp, where, jobs=1)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", IdentificationWarning)
            fit = identify(where, parts=("friction",), params=p).friction.fit_
        out[(machine, delta, chi, ratio, seed)] = {
            n: _holds(fit.estimates[n], getattr(fr, n))
            for n in STRIBECK_NAMES[:5]
            if n not in fit.unidentified
        }
    return out


# ----------------------------------------------------------------------------- grey box
def test_a_profile_carries_its_weak_direction_into_the_others_intervals():
    """δ's profile stays below z² = 3.84 out to δ = 3 while F_s, refitted there, reaches
    140 N: F_s's interval must reach 140 N (not beyond: the point at 4.5 N above the
    threshold does not count); a parameter no profile moves keeps its interval."""
    est = {
        "friction.static": ParameterEstimate(100.7, 1.9, (96.95, 104.5), "N"),
        "friction.shape": ParameterEstimate(1.0, 0.5, (0.5, 2.0), "1"),
        "oil.bulk_modulus": ParameterEstimate(1e9, 1e7, (0.98e9, 1.02e9), "Pa"),
    }
    prof = Profile(
        "friction.shape",
        np.array([0.6, 1.0, 2.0, 3.0, 4.5]),
        np.array([1.0, 0.0, 1.2, 3.5, 4.5]),
        (0.6, 3.0),
        {
            "friction.static": np.array([90.0, 100.7, 120.0, 140.0, 170.0]),
            "oil.bulk_modulus": np.array([1e9, 1e9, 1e9, 1e9, 1e9]),
        },
    )
    got, widened = carry(est, {"friction.shape": prof}, 1.959963984540054**2)
    assert got["friction.static"].ci == (90.0, 140.0)
    assert widened == ["friction.static"]
    assert got["oil.bulk_modulus"] == est["oil.bulk_modulus"]
    # its standard error follows the interval: half-width in ln p over z
    half = 0.5 * math.log(140.0 / 90.0)
    assert got["friction.static"].std == pytest.approx(100.7 * half / 1.959963984540054)


# ----------------------------------------------------------------------------- reports
def test_one_rule_flags_a_truth_outside_in_both_report_tables(tmp_path):
    """The report's identification table and its grey-box table: the main job's E interval
    9.889e8 … 9.969e8 Pa against the rig's 1e9 Pa is flagged in both, by the same rule."""
    import pandas as pd

    from hydropwa.studies.paper._report import _greybox_section, _params_section

    assert truth_in_interval(9.889e8, 9.969e8, 1e9) == TRUTH_OUTSIDE
    assert truth_in_interval(9.889e8, 1.01e9, 1e9) == "yes"
    assert truth_in_interval(1.0, math.inf, 5.0) == "yes"  # open on one side
    assert truth_in_interval(1.0, 2.0, None) == truth_in_interval(1.0, 2.0, math.nan) == ""
    (tmp_path / "tables").mkdir()
    rows = [
        ("oil.bulk_modulus", 9.929e8, 9.889e8, 9.969e8, 1e9),
        ("flow.K", 1.5e-7, 1.4e-7, 1.6e-7, 1.55e-7),
    ]
    pd.DataFrame(
        [
            {
                "parameter": n,
                "value": v,
                "std": 1.0,
                "ci_low": lo,
                "ci_high": hi,
                "unit": "",
                "true": t,
            }
            for n, v, lo, hi, t in rows
        ]
    ).to_csv(tmp_path / "tables" / "greybox.csv", index=False)
    pd.DataFrame(
        [
            {
                "parameter": n, "unit": "", "identified": v, "std": 1.0, "ci_low": lo,
                "ci_high": hi, "true": t, "true_in_ci": truth_in_interval(lo, hi, t),
            }
            for n, v, lo, hi, t in rows
        ]
    ).to_csv(tmp_path / "tables" / "identified.csv", index=False)  # fmt: skip
    for html in (_greybox_section(tmp_path), _params_section(tmp_path)):
        assert html.count(TRUTH_OUTSIDE) == 1, html
        assert "1 true value(s) outside their interval" in html


if (
    __name__ == "__main__"
):  # the family's table: python tests/identification/test_interval_truth.py [seeds]
    import sys

    n = int(sys.argv[1]) if len(sys.argv) > 1 else 1
    for m in MACHINES:
        res = _family(m, seeds=tuple(range(1, n + 1)))
        per = {k: [row[0][k] for row in res if k in row[0]] for k in STRIBECK_NAMES[:5]}
        bands = [row[1] for row in res]
        print(
            m,
            " ".join(f"{k} {sum(v)}/{len(v)}" for k, v in per.items()),
            f"band {sum(bands)}/{len(bands)}",
            f"all {sum(sum(v) for v in per.values())}/{sum(len(v) for v in per.values())}",
            flush=True,
        )
