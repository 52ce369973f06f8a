"""Coverage of the partition (issue 38, item 3): the load-pressure range per flow direction, the
campaign's load runs that walk through it, and the per-band and per-cell scores."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hydropwa.components import chamber_pressures_from_load, load_pressure_range
from hydropwa.data import check_run
from hydropwa.evaluation import (
    cell_coverage,
    coverage_study,
    evaluate_run,
    load_pressure_coverage,
)
from hydropwa.params import get_preset, load_params
from hydropwa.rig import Rig, execute, load_campaign, plan, run_seed

MACHINES = Path(__file__).parents[1] / "machines"


@settings(max_examples=200, deadline=None)
@given(
    alpha=st.floats(0.2, 1.0),
    p_s=st.floats(20e5, 400e5),
    p_t=st.floats(0.0, 5e5),
    d=st.sampled_from([1, -1]),
    s=st.floats(0.0, 1.0),
)
def test_range_is_where_both_chambers_lie_between_tank_and_supply(alpha, p_s, p_t, d, s):
    """Inside the range the steady chamber pressures (Eq. (13) generalised) lie in [P_T, P_S];
    at its ends the stall end has zero drop and the other end has one chamber at tank or supply;
    1 % beyond that end a chamber leaves [P_T, P_S]."""
    lo, hi = load_pressure_range(d, p_s, alpha, p_t)
    tol = 1e-9 * p_s
    p_a, p_b = chamber_pressures_from_load(float(d), lo + s * (hi - lo), p_s, alpha, p_t)
    assert p_t - tol <= p_a <= p_s + tol and p_t - tol <= p_b <= p_s + tol
    stall, far = (hi, lo) if d > 0 else (lo, hi)
    p_a, p_b = chamber_pressures_from_load(float(d), stall, p_s, alpha, p_t)
    assert (p_a, p_b) == pytest.approx((p_s, p_t) if d > 0 else (p_t, p_s), abs=tol)
    beyond = far + 0.01 * (far - stall)
    p_a, p_b = chamber_pressures_from_load(float(d), beyond, p_s, alpha, p_t)
    assert min(p_a, p_b) < p_t - tol or max(p_a, p_b) > p_s + tol


def test_range_closed_form_paper_form():
    """α = 1, P_T = 0: |P_L| ≤ P_S in both directions (Eq. (13)); α < 1: [−α³P_S, P_S] and
    [−αP_S, (1 − α + α³)P_S]."""
    assert load_pressure_range(1, 100e5) == pytest.approx((-100e5, 100e5))
    assert load_pressure_range(-1, 100e5) == pytest.approx((-100e5, 100e5))
    a = 0.5
    assert load_pressure_range(1, 100e5, a) == pytest.approx((-(a**3) * 100e5, 100e5))
    assert load_pressure_range(-1, 100e5, a) == pytest.approx((-a * 100e5, (1 - a + a**3) * 100e5))


def test_coverage_counts_bins_of_a_known_sweep(paper):
    """A synthetic sweep of P_L over the lower 60 % of the extension range (valve open) and
    the whole retraction range covers 60 % and 100 %; samples inside the dead band count for
    neither direction."""
    alpha = paper.cylinder.area_b / paper.cylinder.area_a
    p_s = paper.supply.pressure
    n = 4000
    lo, hi = load_pressure_range(1, p_s, alpha)
    ext = np.linspace(lo, lo + 0.6 * (hi - lo), n)
    lo_r, hi_r = load_pressure_range(-1, p_s, alpha)
    ret = np.linspace(lo_r, hi_r, n)
    u = np.r_[np.full(n, 0.3), np.full(n, -0.3), np.full(n, 0.5 * paper.dead_zone.beta)]
    p_l = np.r_[ext, ret, np.zeros(n)]
    run = {
        "u": u,
        "p_a": p_l + alpha * 10e5,
        "p_b": np.full(3 * n, 10e5),
        "p_s": np.full(3 * n, p_s),
    }
    cov = load_pressure_coverage([run], paper, bins=20).set_index("direction")
    assert cov.loc["extend", "covered"] == pytest.approx(0.6)
    assert cov.loc["retract", "covered"] == 1.0
    assert cov.loc["extend", "time_share"] == pytest.approx(1 / 3)
    assert cov.loc["extend", "low"] == pytest.approx(0.0, abs=1e-12)
    assert cov.loc["extend", "high"] == pytest.approx(0.6)


def test_cell_coverage_pools_rmse_by_samples():
    """Pooled RMSE over runs is √(Σ n·rmse²/Σ n); time share is per model and family."""
    df = pd.DataFrame(
        {
            "run": ["a", "b", "a"],
            "model": ["pwa"] * 3,
            "set": ["o"] * 3,
            "cell": [1, 1, 2],
            "samples": [100, 300, 100],
            "fraction": [0.5, 1.0, 0.5],
            "rmse_x": [1.0, 2.0, 3.0],
            "rmse_p_l": [0.0] * 3,
            "rmse_p_a": [0.0] * 3,
            "rmse_p_b": [0.0] * 3,
        }
    )
    out = cell_coverage(df).set_index("cell")
    assert out.loc[1, "rmse_x"] == pytest.approx(np.sqrt((100 * 1 + 300 * 4) / 400))
    assert out.loc[1, "runs"] == 2 and out.loc[2, "runs"] == 1
    assert out.loc[1, "time_share"] == pytest.approx(0.8)
    assert (out["cells_visited"] == 2).all()


def _load_runs(params):
    rig = Rig(params)
    specs = [s for s in plan(load_campaign("paper")["sine"], rig) if s.name.startswith("sine_load")]
    assert {s.meta["direction"] for s in specs} == {"extend", "retract"}
    return rig, [execute(rig, s, run_seed(1, "sine", s.name)) for s in specs]


@pytest.mark.parametrize(
    "machine", ["paper", "industrial"], ids=["paper rig", "heavy axis 63/36x500"]
)
def test_campaign_load_runs_cover_the_load_pressure_range(machine):
    """The paper campaign's [sine.load] runs, scaled to the machine, cover ≥ 80 % of the P_L
    range in both flow directions and pass the data check (inside the converters' ranges)."""
    params = (
        get_preset("paper") if machine == "paper" else load_params(MACHINES / "industrial.toml")
    )
    rig, runs = _load_runs(params)
    for run in runs:
        assert check_run(run) == [], run.name
    cov = load_pressure_coverage(runs, rig.params).set_index("direction")
    assert cov.loc["extend", "covered"] >= 0.8
    assert cov.loc["retract", "covered"] >= 0.8


def test_load_runs_score_every_model_per_band(paper):
    """On the load runs every model is scored in each band of both directions; the chamber
    model keeps P_A and P_B (fit ≥ 90 %) where the load-pressure models lose them, and the
    full model with the true parameters is the closest in every band."""
    rig, runs = _load_runs(paper)
    results = [evaluate_run(r, rig.params, models=("full", "pwa", "pwa-chamber")) for r in runs]
    for res in results:
        for ch in ("p_a", "p_b"):
            assert res.fit("pwa-chamber", ch) >= 90.0
            assert res.fit("pwa-chamber", ch) > res.fit("pwa", ch)
    cs = coverage_study(results, rig.params)
    assert cs.covered("extend") >= 0.8 and cs.covered("retract") >= 0.8
    bands = cs.bands.set_index(["model", "direction", "band"])
    assert len(bands) == 3 * 2 * 5
    full = bands.xs("full")["rmse_p_a"]
    assert (full <= bands.xs("pwa")["rmse_p_a"]).all()
    fams = set(cs.cells[cs.cells["model"] == "pwa-chamber"]["set"])
    assert {"g", "qa", "qb", "x", "w"} <= fams
    qa = cs.cells[(cs.cells["model"] == "pwa-chamber") & (cs.cells["set"] == "qa")]
    assert qa["cells_visited"].iloc[0] >= 5  # the metering cells beyond the no-load one
