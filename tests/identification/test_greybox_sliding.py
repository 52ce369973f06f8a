"""The sliding stage of the grey-box fit (issue 19): stretches, refit, propagated covariance.

Runs are the full model's own sines with the rig's white sensor noise, so every number below
is checked against known truth; the benchmark-sized recovery over seeds is in
``test_greybox_sine.py`` (slow).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from ident_support import noisy_run as _measured

from hydropwa.identification import IdentificationWarning, Shooting, fit_model
from hydropwa.identification.greybox.data import _smoothed_velocity
from hydropwa.identification.greybox.data import prepare_run as _prepare_run
from hydropwa.identification.greybox.uncertainty import join_held as _join_held
from hydropwa.models import FullOrderModel
from hydropwa.simulation import Sine

FRICTION = ("friction.coulomb", "friction.static", "friction.viscous")


@pytest.fixture(scope="module")
def reversing_runs(truth):
    """Two 2 s sines whose reversals pass through the Stribeck dip (20 % and 40 % at 1–2 Hz)."""
    m = FullOrderModel(truth)
    return [
        _measured(m, Sine(amplitude=0.2, frequency=1.0), 2.0, 11, x0=0.03, name="s20"),
        _measured(m, Sine(amplitude=0.4, frequency=2.0), 2.0, 12, x0=0.03, name="s40"),
    ]


def test_sliding_stretches_stay_above_the_speed_and_start_where_it_is_crossed(
    truth, reversing_runs
):
    """Every stretch lies where the smoothed measured speed exceeds v_min, is at least one
    window long and starts at a crossing (or the run's start) from the measured state;
    together they hold every fast sample but those of stretches shorter than a window."""
    shooting = Shooting()
    v_min = 2.0 * truth.friction.stribeck_velocity
    for run in reversing_runs:
        rd = _prepare_run(
            run, FullOrderModel(truth), ("x", "p_a", "p_b"), shooting, [], sliding_above=v_min
        )
        assert rd is not None and rd.method == "single" and "sliding" in rd.reason
        t, x = rd.t, rd.y["x"]
        fast = np.abs(_smoothed_velocity(t, x, shooting.velocity_window)) > v_min
        covered = np.zeros(t.size, bool)
        dt = float(np.median(np.diff(t)))
        w = round(shooting.window / dt)
        for seg in rd.segments:
            assert fast[seg.i0 : seg.i1].all()
            assert seg.i1 - seg.i0 >= w
            # at a crossing, at a cut of a longer stretch, or at the run's start
            assert seg.i0 == 0 or covered[seg.i0 - 1] or not fast[seg.i0 - 1]
            # the initial state is the smoothed measurement there (position within 3 noise σ)
            assert seg.meas["x"] == pytest.approx(x[seg.i0], abs=3 * 5e-6)
            assert abs(seg.meas["v"]) > v_min
            covered[seg.i0 : seg.i1] = True
        # the sines reverse: a good part of each run is slower than v_min and left out
        assert 0.1 < 1.0 - covered.mean() < 0.9
        # fast samples left out belong to stretches shorter than a window
        missed = fast & ~covered
        if missed.any():
            edges = np.diff(np.concatenate(([0], missed.astype(int), [0])))
            lengths = np.flatnonzero(edges == -1) - np.flatnonzero(edges == 1)
            assert lengths.max() < w


@pytest.fixture(scope="module")
def friction_fit(truth, reversing_runs):
    start = truth.replace(
        **{
            "friction.coulomb": 1.25 * truth.friction.coulomb,
            "friction.static": 0.9 * truth.friction.static,
            "friction.viscous": 1.15 * truth.friction.viscous,
        }
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentificationWarning)
        return fit_model(
            FullOrderModel(start),
            reversing_runs,
            FRICTION,
            jobs=2,
            profile="none",
            nuisance_draws=8,
        )


def test_sliding_stage_refits_all_but_the_breakaway_parameters(truth, friction_fit):
    """F_c and σ come from the sliding stretches, F_s (breakaway) from the full data.

    Measured on these runs (seeds 11/12, 21/22, 31/32): F_c +6.5, +0.3, −2.7 % with the
    sliding stage, every interval holding the truth; without it +10.2, +17.4, +7.7 %, every
    interval missing it (eight seed pairs: −10.0 … +6.5 %, 16 of 16 intervals of F_c and σ
    inside). σ within 1 %, F_s +0.4 … +1.5 %. Bounds: F_c 10 % (the issue's
    figure), σ 3 % and F_s 5 % (the full fit's figures on the sine runs). F_s's interval is the
    full fit's and not judged here (on these short runs it missed the truth on two seeds of
    three, at +1.5 % and +0.6 %)."""
    fit = friction_fit
    sl = fit.sliding_
    assert sl.applied and sl.parameters == ("friction.coulomb", "friction.viscous")
    assert sl.held == ("friction.static",)
    assert sl.v_min == pytest.approx(2.0 * truth.friction.stribeck_velocity, rel=1e-12)
    assert sl.stretches >= 4 and sl.runs == ("s20", "s40")
    meta = fit.params_.meta["greybox"]["sliding"]
    assert meta["stretches"] == sl.stretches and meta["held"] == ["friction.static"]
    assert "runs" not in meta and sl.to_dict() == meta
    for n, tol in zip(FRICTION, (0.10, 0.05, 0.03), strict=True):
        comp, fld = n.split(".")
        true = getattr(getattr(truth, comp), fld)
        e = fit.estimates_[n]
        assert e.value == pytest.approx(true, rel=tol), n
        if n in sl.parameters:
            assert e.ci[0] <= true <= e.ci[1], n
    # the fitted parameter set holds the sliding stage's values; the tables say which stage
    assert fit.params_.friction.coulomb == fit.estimates_["friction.coulomb"].value
    stage = fit.to_pandas()["stage"]
    assert stage["friction.coulomb"] == "sliding" and stage["friction.static"] == "full"
    assert "Sliding stage: friction.coulomb, friction.viscous refitted" in fit.summary_markdown()


def test_held_parameters_uncertainty_is_propagated(friction_fit):
    """The fit's covariance is symmetric positive semi-definite, with |correlations| ≤ 1, and
    F_c and σ, which share the sliding force, strongly anti-correlated (measured −0.92 …
    −0.96). (The held F_s adds < 1 % to F_c's variance on these runs: the propagation itself
    is checked against sampling below.)"""
    c = friction_fit.covariance_
    assert np.allclose(c, c.T, rtol=0, atol=1e-12 * np.abs(c).max())
    assert np.linalg.eigvalsh(c).min() >= -1e-9 * np.abs(c).max()
    i_c = friction_fit.free.index("friction.coulomb")
    i_v = friction_fit.free.index("friction.viscous")
    assert friction_fit.correlation_[i_c, i_v] < -0.8
    assert np.all(np.abs(friction_fit.correlation_) <= 1.0 + 1e-9)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_join_held_is_the_covariance_of_the_linearised_refit(seed):
    """θ_f = θ̂_f + G·θ_b with θ̂_f ~ N(0, C_f) and θ_b ~ N(0, C_b) independent: the sample
    covariance of (θ_f, θ_b), laid out at the parameters' positions, matches
    ``_join_held`` (200 000 draws: entries within 2 % of the diagonal scale)."""
    rng = np.random.default_rng(seed)
    p, i_held = 5, sorted(rng.choice(5, size=2, replace=False).tolist())
    i_free = [i for i in range(p) if i not in i_held]
    a = rng.normal(size=(p, p))
    cov = a @ a.T  # the full fit's covariance: only its held block is used
    f = rng.normal(size=(len(i_free), len(i_free)))
    c_free = f @ f.T
    G = rng.normal(size=(len(i_free), len(i_held)))
    n = 200_000
    th_b = rng.multivariate_normal(np.zeros(len(i_held)), cov[np.ix_(i_held, i_held)], n)
    th_f = rng.multivariate_normal(np.zeros(len(i_free)), c_free, n) + th_b @ G.T
    draws = np.empty((n, p))
    draws[:, i_free], draws[:, i_held] = th_f, th_b
    got = _join_held(cov, c_free, G, i_free, i_held)
    scale = np.sqrt(np.outer(np.diag(got), np.diag(got)))
    assert np.all(np.abs(np.cov(draws, rowvar=False) - got) <= 0.02 * scale)


def test_sliding_stage_off_or_not_applicable(truth, reversing_runs):
    """``sliding=False`` leaves ``sliding_`` empty; runs fitted in windows only have no
    single-shot stretches, and the stage says why it did not apply."""
    start = truth.replace(**{"friction.coulomb": 1.2 * truth.friction.coulomb})
    quick = {"jobs": 2, "profile": "none", "nuisance_draws": 0, "scan_intervals": False}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentificationWarning)
        off = fit_model(
            FullOrderModel(start), reversing_runs[:1], "friction.coulomb", sliding=False, **quick
        )
        windows = fit_model(
            FullOrderModel(start),
            reversing_runs[:1],
            "friction.coulomb",
            shooting=Shooting(method="multiple", max_windows=10),
            **quick,
        )
    assert not off.sliding_.applied and off.sliding_.skipped == ""
    assert "sliding" not in off.params_.meta["greybox"]
    assert not windows.sliding_.applied and "too few" in windows.sliding_.skipped


def test_sliding_stage_on_an_industrial_axis():
    """A machine unlike the paper rig (63/36 mm × 500 mm, 250 kg, 210 bar; F_c 300 N, F_s
    500 N, v_s 20 mm/s): three seeds of two 2 s sines, friction started 10–25 % off.

    Measured over seeds 1–7: F_c −2.4 … +1.4 % with the sliding stage (−2.1 … +2.2 % without:
    here F_c is a large part of the sliding force and the full data place it as well), σ
    within 1.2 %, F_s within 0.5 %, 21 of 21 intervals holding the truth. Bounds: F_c 5 %,
    σ 3 %, F_s 2 % (about twice the largest measured), every interval."""
    from pathlib import Path

    from hydropwa.params import load_params

    truth = load_params(Path(__file__).parents[1] / "machines" / "industrial.toml").replace(
        **{"cylinder.leakage": 5e-13}
    )
    m = FullOrderModel(truth)
    start = truth.replace(
        **{
            "friction.coulomb": 1.25 * truth.friction.coulomb,
            "friction.static": 0.9 * truth.friction.static,
            "friction.viscous": 1.15 * truth.friction.viscous,
        }
    )
    for k in (1, 2, 3):
        runs = [
            _measured(m, Sine(amplitude=0.2, frequency=1.0), 2.0, 10 * k + 1, x0=0.25, ps=210e5),
            _measured(m, Sine(amplitude=0.4, frequency=1.5), 2.0, 10 * k + 2, x0=0.25, ps=210e5),
        ]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", IdentificationWarning)
            # a per-parameter x_scale reaches the sliding stage for its own parameters
            xs = np.ones(len(FRICTION)) if k == 1 else 1.0
            fit = fit_model(
                FullOrderModel(start),
                runs,
                FRICTION,
                jobs=2,
                profile="none",
                nuisance_draws=8,
                x_scale=xs,
            )
        assert fit.sliding_.parameters == ("friction.coulomb", "friction.viscous")
        assert fit.sliding_.v_min == pytest.approx(0.04)
        for n, tol in zip(FRICTION, (0.05, 0.02, 0.03), strict=True):
            true = getattr(truth.friction, n.split(".")[1])
            e = fit.estimates_[n]
            assert e.value == pytest.approx(true, rel=tol), (k, n)
            assert e.ci[0] <= true <= e.ci[1], (k, n)


def test_cli_sliding_switch(tmp_path, truth, reversing_runs):
    """``hydropwa identify model --free friction.coulomb`` runs the sliding stage and says so
    in its summary; ``--no-sliding`` leaves it out."""
    from typer.testing import CliRunner

    from hydropwa.cli import app
    from hydropwa.data import write_dataset
    from hydropwa.params import save_params

    data = tmp_path / "data"
    write_dataset(reversing_runs, data)
    base = tmp_path / "base.toml"
    save_params(truth.replace(**{"friction.coulomb": 1.2 * truth.friction.coulomb}), base)
    summaries = {}
    for flag in ("--sliding", "--no-sliding"):
        out = tmp_path / f"fit{flag}.toml"
        res = CliRunner().invoke(
            app,
            [
                "identify",
                "model",
                str(data),
                "--free",
                "friction.coulomb",
                "--params",
                str(base),
                "--jobs",
                "2",
                flag,
                "--out",
                str(out),
            ],
        )
        assert res.exit_code == 0, res.output
        summaries[flag] = out.with_suffix(".md").read_text()
    assert "Sliding stage: friction.coulomb refitted" in summaries["--sliding"]
    assert "Sliding stage" not in summaries["--no-sliding"]
