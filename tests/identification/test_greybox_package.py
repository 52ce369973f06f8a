"""The grey-box package's parts: status enum, Jacobian strategies, options, campaign selection,
held-out validation, progress and the stages' outcomes (issue 36).

The fits here are one-parameter fits of short runs (seconds); the fitted numbers of the
package are checked against the former monolithic implementation in ``test_greybox*.py``,
whose tests pass unchanged.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from ident_support import noisy_run
from scipy import optimize

from hydropwa import OutputExistsError
from hydropwa._errors import IdentificationError
from hydropwa.identification import FitOptions, FitStatus, Selection, Shooting, fit_model
from hydropwa.identification.greybox.data import prepare_run
from hydropwa.identification.greybox.jacobian import FiniteDifferenceJacobian
from hydropwa.identification.greybox.selection import events
from hydropwa.identification.greybox.validation import normalized_fit, split_runs, validate
from hydropwa.models import FullOrderModel
from hydropwa.simulation import Sine, Step


def test_fit_status_is_scipys_status_with_fix_it_messages():
    """Every least_squares status maps to a member; success is status > 0 as scipy's."""
    fun = lambda x: np.array([x[0] - 1.0, 2.0 * (x[0] - 1.0)])  # noqa: E731
    res = optimize.least_squares(fun, [3.0])
    st = FitStatus.from_scipy(res)
    assert st == res.status and st.success == res.success
    starved = optimize.least_squares(lambda x: np.exp(x) - 2.0 + x**3, [5.0], max_nfev=1)
    assert FitStatus.from_scipy(starved) is FitStatus.MAX_EVALUATIONS
    assert not FitStatus.MAX_EVALUATIONS.success and "max_nfev" in FitStatus(0).message
    assert {int(s) for s in FitStatus} == {-1, 0, 1, 2, 3, 4}


class _Linear:
    """Residuals r = A θ + b: forward and central differences and Broyden are exact."""

    def __init__(self, A, b):
        self.A, self.b, self.calls = A, b, 0

    def fun(self, th):
        return self.A @ th + self.b

    def jac(self, th, step, r0=None, central=False):
        self.calls += 1
        cols = []
        for j in range(th.size):
            e = np.zeros(th.size)
            e[j] = step
            if central:
                cols.append((self.fun(th + e) - self.fun(th - e)) / (2 * step))
            else:
                cols.append((self.fun(th + e) - (r0 if r0 is not None else self.fun(th))) / step)
        return np.array(cols).T


def test_broyden_updates_between_refreshes_are_exact_on_a_linear_residual():
    """Broyden's rank-one update J + (Δr − JΔθ)Δθᵀ/|Δθ|² keeps the exact Jacobian of a linear
    map (Δr = AΔθ), so refresh=3 takes differences at calls 0 and 3 alone."""
    rng = np.random.default_rng(0)
    prob = _Linear(rng.normal(size=(5, 3)), rng.normal(size=5))
    jac = FiniteDifferenceJacobian(prob, 1e-3, "central", refresh=3)
    for _ in range(5):
        J = jac(rng.normal(size=3))
        np.testing.assert_allclose(J, prob.A, atol=1e-10)
    assert prob.calls == 2
    assert jac.central is not None and jac.central[1].shape == (5, 3)
    with pytest.raises(IdentificationError, match="central or forward"):
        FiniteDifferenceJacobian(prob, 1e-3, "backward")


def test_fit_options_keep_the_keyword_api_and_refuse_unknown_settings():
    opts = FitOptions.merged(FitOptions(loss="huber", starts=2), {"starts": 3})
    assert (opts.loss, opts.starts) == ("huber", 3)
    assert opts.optimizer.loss == "huber" and opts.optimizer.max_nfev == 40
    with pytest.raises(TypeError, match="strts"):
        FitOptions.merged(None, {"strts": 2})
    with pytest.raises(IdentificationError, match="level"):
        FitOptions(level=1.5)


def test_normalized_fit_and_the_held_out_split():
    """fit = 100(1 − ‖y − ŷ‖/‖y − ȳ‖): 100 for a perfect model, 0 for the mean, 90 for an
    error of a tenth of the spread; the split is deterministic and evenly spread."""
    y = np.sin(np.linspace(0, 6, 500))
    assert normalized_fit(y, y) == pytest.approx(100.0)
    assert normalized_fit(y, np.full_like(y, y.mean())) == pytest.approx(0.0, abs=1e-12)
    assert normalized_fit(y, y + 0.1 * (y - y.mean())) == pytest.approx(90.0)
    fit, held = split_runs(list(range(10)), 0.2)
    assert held == [2, 7] and len(fit) == 8
    assert split_runs([1, 2], 0.0) == ([1, 2], [])
    with pytest.raises(IdentificationError, match="validate"):
        split_runs([1, 2], 1.0)


@pytest.fixture(scope="module")
def step_run(truth):
    """A valve step from rest: the rod leaves standstill at 0.1 s (a motion event)."""
    return noisy_run(FullOrderModel(truth), Step(0.1, 0.0, 0.3), 0.6, 3, x0=0.02, name="step")


def test_events_find_the_command_step_and_the_motion_onset(truth, step_run):
    rd = prepare_run(step_run, FullOrderModel(truth), ("x", "p_a", "p_b"), Shooting(), [])
    cmd = events(rd, ("command",), 3e-3)
    assert len(cmd) == 1 and 0.095 - 1e-9 <= cmd[0] <= 0.1  # the 5 ms in which u steps
    moves = events(rd, ("motion",), 3e-3)
    assert len(moves) == 1 and 0.1 < moves[0] < 0.13  # the rod follows the spool within ms


def test_selection_keeps_the_segments_after_the_events_within_the_budget(truth, step_run):
    """Windows of 20 ms: the first after the step and a few steady ones; the budget decides
    the number of runs kept, the summary sentence says what was kept and why."""
    m = FullOrderModel(truth)
    rd = prepare_run(step_run, m, ("x", "p_a", "p_b"), Shooting("multiple", max_windows=None), [])
    runs = [dataclasses.replace(rd, name=f"r{k}") for k in range(4)]
    sel = Selection(method="events", budget=0.4, per_run=0.2, steady_per_run=0.06)
    out, note = sel.select(runs, ("valve.omega0",), 3e-3)
    kept = [r for r in out if r.segments]
    assert len(kept) == 2  # 0.4 s of budget, 0.2 s per run
    starts = [float(kept[0].t[s.i0]) for s in kept[0].segments]
    # the six windows that overlap the 100 ms after the step (0.08 … 0.18 s) and three steady
    # ones (0.06 s) spread over the rest: nine of the ten allowed (0.2 s)
    assert starts[:6] == pytest.approx([0.08, 0.1, 0.12, 0.14, 0.16, 0.18], abs=1e-9)
    assert len(starts) == 9 and min(starts[6:]) >= 0.2 - 1e-9
    assert "command steps" in note and "2 of 4 runs" in note
    assert sel.wanted(("friction.static", "oil.bulk_modulus")) == ("motion", "command", "load")
    assert not Selection().applies(45.0) and Selection().applies(61.0)
    with pytest.raises(IdentificationError, match="budget"):
        Selection(budget=0.0)


def test_validation_of_the_true_model_on_a_held_out_run_is_near_perfect(truth):
    """The true parameters simulate a held-out sine run from its measured start over 1 s:
    the position fit is limited by the 5 µm noise against a 10 mm spread (≥ 99.5 %)."""
    run = noisy_run(FullOrderModel(truth), Sine(amplitude=0.4, frequency=2.0), 1.0, 5)
    m = FullOrderModel(truth)
    got = validate([run], m, np.array([truth.flow.K]), ("flow.K",), ("x", "p_a", "p_b"),
                   {"x": 5e-6, "p_a": 5e3, "p_b": 5e3}, 1e-6, 1, 50.0)  # fmt: skip
    assert got is not None and got.seconds == pytest.approx(1.0, abs=0.02)
    assert got.mean["x"] > 99.5
    assert "held-out" in got.summary()


def test_fit_reports_progress_stages_validation_and_saves_only_with_overwrite(truth, tmp_path):
    """A one-parameter fit: progress events per stage (begin and end, in order), the stages'
    outcomes behind ``success``, the held-out run's fit % in the summary, and ``save``
    refusing an existing file unless ``overwrite``."""
    m = FullOrderModel(truth)
    runs = [
        noisy_run(m, Sine(amplitude=a, frequency=2.0), 1.0, k, name=f"s{k}")
        for k, a in enumerate((0.3, 0.4, 0.5))
    ]
    start = FullOrderModel(truth.replace(**{"flow.K": 1.1 * truth.flow.K}))
    seen = []
    fit = fit_model(start, runs, "flow.K", jobs=1, validate=0.34, progress=seen.append,
                    nuisance_draws=0, profile="none")  # fmt: skip
    assert fit.params_.flow.K == pytest.approx(truth.flow.K, rel=0.01)
    names = [(e.stage, e.event) for e in seen]
    assert names[0] == ("full", "begin") and ("full", "end") in names
    assert names[-1] == ("done", "end") and ("validation", "begin") in names
    assert all(e.elapsed >= 0 for e in seen)
    assert [s.name for s in fit.stages_] == ["full"] and fit.success == fit.stages_[0].success
    assert fit.status is FitStatus(fit.status) and fit.message == fit.status.message
    assert list(fit.validation_.runs) == ["s1"] and fit.validation_.mean["x"] > 99.0
    text = fit.summary_markdown()
    assert "held-out" in text and "Stages: full" in text
    path = fit.save(tmp_path / "fit.toml")
    with pytest.raises(OutputExistsError):
        fit.save(path)
    fit.save(path, overwrite=True)


def test_cli_validates_on_held_out_runs_and_reports_progress(truth, tmp_path):
    """``identify model --validate 0.5``: one of two runs held out, its fit % in the summary;
    the progress lines (one per finished stage) go to stderr unless ``--quiet``."""
    from typer.testing import CliRunner

    from hydropwa.cli import app
    from hydropwa.data import write_dataset
    from hydropwa.params import save_params

    m = FullOrderModel(truth)
    runs = [
        noisy_run(m, Sine(amplitude=a, frequency=2.0), 1.0, k, name=f"s{k}")
        for k, a in enumerate((0.3, 0.5))
    ]
    write_dataset(runs, tmp_path / "data")
    base = tmp_path / "base.toml"
    save_params(truth.replace(**{"flow.K": 1.1 * truth.flow.K}), base)
    args = ["identify", "model", str(tmp_path / "data"), "--free", "flow.K", "--jobs", "1"]
    args += ["--params", str(base), "--validate", "0.5", "--out", str(tmp_path / "f.toml")]
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 0, res.output
    text = (tmp_path / "f.md").read_text()
    assert "Validation on 1 held-out run(s)" in text and "| s1 |" in text
    assert "grey-box fit: [" in res.output and "full: cost" in res.output
    quiet = CliRunner().invoke(app, [*args[:-1], str(tmp_path / "g.toml"), "--quiet"])
    assert quiet.exit_code == 0 and "grey-box fit: [" not in quiet.output
