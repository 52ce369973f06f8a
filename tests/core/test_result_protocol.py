"""One result protocol (issue 33 item 3): every result class has ``status`` (a Status with
``name``, ``success`` and a fix-it ``message``), ``success``, ``message``, ``summary()``,
``to_pandas()``, ``plot(ax=)`` and ``_repr_html_()``; the views carry units; ``to_pandas``
holds the result's own numbers; plotting reads results through declared protocols.

The fits are made from small synthetic problems with a known answer (a hinge dead zone, a
Stribeck curve, a second-order FRF), so the tables are checked against the truth as well as
against the objects they come from.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure

from hydropwa import (
    FullOrderModel,
    IdentificationError,
    ReducedModel,
    Result,
    ResultStatus,
    Status,
    simulate,
)
from hydropwa.components import stribeck_friction
from hydropwa.control import (
    ControlDesign,
    PIController,
    TrackingMetrics,
    Verification,
    VerificationCriteria,
    design_pi,
    tracking_metrics,
)
from hydropwa.data import Run
from hydropwa.evaluation import EvaluationResult, evaluate_run
from hydropwa.identification import (
    DeadZoneFit,
    FrequencyResponse,
    GreyBoxFit,
    IdentificationReport,
    OptimizerStatus,
    ParameterEstimate,
    SecondOrderFit,
    SkippedRun,
    StribeckFit,
    fit_dead_zone,
    fit_second_order,
    fit_stribeck,
    identify,
    second_order_response,
)
from hydropwa.identification.greybox.result import (
    FitStatus,
    Identifiability,
    Profile,
    RunFit,
    StageResult,
    StartRecord,
)
from hydropwa.linearization import linearize
from hydropwa.plotting._shapes import EvaluationShape, TracedFit
from hydropwa.simulation import SimulationResult, SolverStatus

BETA, GAIN, CREEP = 0.05, 0.4, 0.02  # hinge dead zone: edge [1], gain [m/s], creep slope [1]
OMEGA0, ZETA = 2 * np.pi * 100.0, 0.7  # valve, Eq. (1)


def _dead_zone() -> DeadZoneFit:
    u = np.concatenate([np.linspace(0.01, 0.3, 15), -np.linspace(0.01, 0.3, 15)])
    edge = np.sign(u) * np.maximum(np.abs(u) - BETA, 0.0)
    v = GAIN * (edge + CREEP * u) + 1e-5 * np.random.default_rng(0).standard_normal(u.size)
    return fit_dead_zone(u, v, drift=False)


def _stribeck(paper) -> StribeckFit:
    v = np.concatenate([np.geomspace(1e-3, 0.2, 15), -np.geomspace(1e-3, 0.2, 15)])
    fr = paper.friction
    f = np.array(
        [
            stribeck_friction(
                x, fr.coulomb, fr.static, fr.viscous, fr.stribeck_velocity, fr.shape, fr.smoothness
            )
            for x in v
        ]
    )
    f += 2.0 * np.random.default_rng(1).standard_normal(v.size)
    return fit_stribeck(v, f, n_starts=4)


def _second_order() -> SecondOrderFit:
    f = np.geomspace(5.0, 300.0, 25)
    h = second_order_response(2 * np.pi * f, OMEGA0, ZETA)
    return fit_second_order(FrequencyResponse(f, h, np.ones(f.size), 0.1, ("frf",)))


def _greybox(paper) -> GreyBoxFit:
    est = {"coulomb": ParameterEstimate(300.0, 10.0, (280.0, 320.0), "N")}
    t = np.linspace(0.0, 1.0, 50)
    run = RunFit(
        "r1",
        "single",
        "forced",
        [(0.0, 1.0)],
        [],
        {"x": 1e-5},
        {"x": 2e-5},
        {"x": 40.0},
        t,
        {"x": 0.1 * t},
        {"x": 0.1 * t + 1e-5},
    )
    start = StartRecord(
        start={"coulomb": 250.0}, value={"coulomb": 300.0}, cost=1.0, status=FitStatus.FTOL,
        nfev=12, njev=3,
    )  # fmt: skip
    return GreyBoxFit(
        params_=paper,
        free=("coulomb",),
        estimates_=est,
        covariance_=np.eye(1) * 100.0,
        correlation_=np.eye(1),
        inflation_=np.ones(1),
        cost=1.0,
        initial_cost=4.0,
        runs_=[run],
        profiles_={
            "coulomb": Profile(
                "coulomb",
                np.array([280.0, 300.0, 320.0]),
                np.array([4.0, 0.0, 4.0]),
                (280.0, 320.0),
            )
        },
        identifiability_=Identifiability(1.0, [], [], [], []),
        starts_=[start],
        stages_=[StageResult("full", FitStatus.FTOL, 1.0, 12, 3)],
        model="full",
    )


def _step(paper):
    """A 2 mm step of a P loop (kp = 300) on the reduced model: it stops 0.061 mm short."""
    return simulate(
        "reduced", params=paper, duration=0.3, controller=PIController(kp=300.0),
        initial_position=0.1, reference="step:time=0.01,before=0.1,after=0.102",
    )  # fmt: skip


def _tracking(paper) -> TrackingMetrics:
    # a settling band of 0.2 mm (10 % of the step) holds the 0.061 mm offset
    return tracking_metrics(_step(paper), 0.01, band=2e-4)


def _verification(paper) -> Verification:
    """A verdict as verify_controller writes it: one hold over its limit."""
    worst = {"hold_peak_to_peak_mm": 0.15, "hold_mean_error_mm": 0.01, "following_error_mm": 0.4,
             "saturation_percent": 2.0, "sign_changes_per_s": 3.0, "limit_cycles": 0.0}  # fmt: skip
    failures = ["hold_1, draw 2: hold 0.150 mm peak to peak > 0.1 mm"]
    crit = dataclasses.asdict(VerificationCriteria())
    runs = [{"task": "hold_1", "draw": 2, "hold_pp": 1.5e-4}]
    return Verification(False, worst, failures, runs, {"criteria": crit, "draws": 3, "tasks": 1})


def _evaluation(paper) -> EvaluationResult:
    sim = simulate(FullOrderModel(paper), "sine:amplitude=0.5,frequency=3", duration=1.0, rtol=1e-6)
    return evaluate_run(sim.to_run("sine"), paper, models=("reduced",))


def _report(paper) -> IdentificationReport:
    """identify() on constant-command runs of the hinge dead zone (the rod ramps at v(u))."""
    fs, runs = 500.0, []
    for k, lv in enumerate(
        np.concatenate([np.linspace(0.02, 0.3, 12), -np.linspace(0.02, 0.3, 12)])
    ):
        t = np.arange(0.0, 1.0, 1.0 / fs)
        v = GAIN * (np.sign(lv) * max(abs(lv) - BETA, 0.0) + CREEP * lv)
        x = np.clip((0.0 if lv > 0 else 0.2) + v * t, 0.0, 0.2)
        x = x + 2e-5 * np.random.default_rng(k).standard_normal(t.size)
        meta = {"experiment": "deadzone", "signal": {"type": "constant", "level": float(lv)}}
        runs.append(
            Run(f"deadzone_{k:03d}", {"t": t, "x": x, "u": np.full(t.size, lv)}, fs=fs, meta=meta)
        )
    return identify(runs, parts=("deadzone",), params=paper)


MAKERS = {
    "SimulationResult": lambda p: simulate(ReducedModel(p), 0.2, duration=0.05),
    "DeadZoneFit": lambda p: _dead_zone(),
    "StribeckFit": _stribeck,
    "SecondOrderFit": lambda p: _second_order(),
    "IdentificationReport": _report,
    "GreyBoxFit": _greybox,
    "ControlDesign": lambda p: design_pi(linearize(p)),
    "EvaluationResult": _evaluation,
    "TrackingMetrics": _tracking,
    "Verification": _verification,
}
CLASSES = {
    "SimulationResult": SimulationResult,
    "DeadZoneFit": DeadZoneFit,
    "StribeckFit": StribeckFit,
    "SecondOrderFit": SecondOrderFit,
    "IdentificationReport": IdentificationReport,
    "GreyBoxFit": GreyBoxFit,
    "ControlDesign": ControlDesign,
    "EvaluationResult": EvaluationResult,
    "TrackingMetrics": TrackingMetrics,
    "Verification": Verification,
}


@pytest.fixture(scope="module")
def results(paper):
    return {}, paper


def _make(results, name):
    cache, paper = results
    if name not in cache:
        cache[name] = MAKERS[name](paper)
    return cache[name]


@pytest.mark.parametrize("name", list(MAKERS))
def test_every_result_satisfies_the_protocol(results, name):
    res = _make(results, name)
    assert type(res) is CLASSES[name]
    assert isinstance(res, Result)
    assert isinstance(res.status, Status)
    # status is one thing: an upper-case code, success and a message, agreeing with success
    assert res.status.name.isupper() and res.success is bool(res.status.success)
    assert res.status.message and res.status.message in res.message
    assert res.status.name in res.summary()
    assert "<table>" in res._repr_html_()
    df = res.to_pandas()
    assert isinstance(df, pd.DataFrame) and len(df) > 0
    fig = res.plot()
    assert isinstance(fig, Figure) and fig.axes


@pytest.mark.parametrize("name", ["DeadZoneFit", "StribeckFit", "SecondOrderFit", "GreyBoxFit"])
def test_to_pandas_holds_the_estimates_with_units(results, name):
    res = _make(results, name)
    ests = res.estimates_ if name == "GreyBoxFit" else res._estimates()
    df = res.to_pandas()
    assert list(df.index) == list(ests)
    for key, e in ests.items():
        row = df.loc[key]
        assert (row["value"], row["std"], row["ci_low"], row["ci_high"]) == (e.value, e.std, *e.ci)
        assert row["unit"] == e.unit
    # round trip: the table rebuilds the estimates exactly
    back = {
        k: ParameterEstimate(r["value"], r["std"], (r["ci_low"], r["ci_high"]), r["unit"], e.level)
        for (k, r), e in zip(df.iterrows(), ests.values(), strict=True)
    }
    assert back == ests


def test_fits_recover_the_truth_and_show_it_in_engineering_units(results):
    dz = _make(results, "DeadZoneFit")
    assert dz.success and dz.status.name == "SUCCESS"
    assert dz.to_pandas().loc["beta", "value"] == pytest.approx(BETA, abs=2e-3)
    # β [1] is shown in % in both views (5 %), not as 0.05
    assert f"beta: {100 * dz.beta.value:.4g} %" in dz.summary()
    assert f"gain_pos: {1e3 * dz.gain_pos.value:.4g} mm/s" in dz.summary()
    assert "<td style='text-align:left'>%</td>" in dz._repr_html_()
    so = _make(results, "SecondOrderFit")
    assert so.to_pandas().loc["omega0", "value"] == pytest.approx(OMEGA0, rel=1e-6)
    assert "rad/s" in so.summary()


def test_a_fit_that_did_not_converge_says_what_to_do(results):
    dz = _make(results, "DeadZoneFit")
    bad = dataclasses.replace(dz, status=OptimizerStatus(False, "maximum evaluations", 100))
    assert not bad.success and bad.status.name == "NOT_CONVERGED"
    assert bad.message.startswith("maximum evaluations; ") and "more evaluations" in bad.message
    assert "NOT_CONVERGED" in bad.summary()


def test_simulation_result_summary_carries_units_and_status(results):
    sim = _make(results, "SimulationResult")
    assert sim.status is SolverStatus.SUCCESS
    text = sim.summary()
    assert "SUCCESS" in text and " mm" in text and " bar" in text
    x = sim.to_pandas()["x"].to_numpy()
    assert f"x: {np.min(x) * 1e3:.4g} … {np.max(x) * 1e3:.4g} mm" in text


def test_report_and_design_status_follow_their_parts(results, paper):
    rep = _make(results, "IdentificationReport")
    assert rep.dead_zone is not None and rep.status is ResultStatus.SUCCESS and rep.success
    table = rep.to_pandas().set_index("parameter")
    assert table.loc["beta", "value"] == pytest.approx(BETA, abs=2e-3)
    assert (
        table.loc["beta", "value"] == rep.params.meta["uncertainty"]["dead_zone"]["beta"]["value"]
    )
    skipped = dataclasses.replace(rep, skipped=[SkippedRun("deadzone_003", "clipped")])
    assert skipped.status is ResultStatus.PARTIAL and "deadzone_003" in skipped.message
    design = _make(results, "ControlDesign")
    assert design.status is ResultStatus.SUCCESS and design.to_pandas() is design.table
    broken = dataclasses.replace(design, warnings=["cell 3 is not stable"])
    assert broken.status is ResultStatus.CHECK_FAILED
    assert broken.message.startswith("cell 3 is not stable; ") and "re-tune" in broken.message


def test_greybox_status_follows_its_deciding_stages(results):
    """The fit's status, success and message are derived from its stages: a sliding stage that
    did not converge fails the fit although the full stage converged (they used to disagree)."""
    fit = _make(results, "GreyBoxFit")
    assert fit.status is FitStatus.FTOL and fit.success and fit.nfev == 12 and fit.njev == 3
    assert fit.optimizer_.success and fit.optimizer_.nfev == 12 and fit.optimizer_.nit is None
    stalled = StageResult("sliding", FitStatus.MAX_EVALUATIONS, 0.5, 40, 8)
    bad = dataclasses.replace(fit, stages_=[*fit.stages_, stalled])
    assert bad.status is FitStatus.MAX_EVALUATIONS and not bad.success
    assert bad.success is bad.status.success is bad.optimizer_.success is False
    assert bad.message.startswith("the sliding stage did not converge; ")
    assert "raise max_nfev" in bad.message and bad.nfev == 12  # still the full stage's counts
    # locating and coarse stages lead the way; their outcome does not decide the fit
    lost = dataclasses.replace(
        fit, stages_=[StageResult("locate", FitStatus(0), 9.0, 5, 1), *fit.stages_]
    )
    assert lost.success and lost.status is FitStatus.FTOL
    with pytest.raises(IdentificationError, match="exactly one 'full' stage"):
        dataclasses.replace(fit, stages_=[stalled])
    with pytest.raises(TypeError):
        GreyBoxFit(fit.params_, fit.free)  # keyword-only
    with pytest.raises(dataclasses.FrozenInstanceError):
        fit.cost = 0.0


def test_tracking_and_verification_say_how_they_ended(results):
    m = _make(results, "TrackingMetrics")
    # in the 0.2 mm band the step settles within the window: every metric computed
    assert m.status is ResultStatus.SUCCESS and m.success and 0 < m.settling_time < 0.29
    assert m.to_pandas().loc["rise_time", "value"] == m.rise_time
    # the default band, 2 % of the step (0.04 mm), is narrower than the loop's 0.061 mm offset
    assert abs(m.steady_state_error) > 0.02 * m.step
    short = tracking_metrics(_step(results[1]), 0.01)
    assert math.isnan(short.settling_time) and short.rise_time == m.rise_time
    assert short.status is ResultStatus.NOT_SETTLED and not short.success
    assert short.message.startswith("settling_time: the rod was outside the band")
    assert "lengthen the window" in short.message and "NOT_SETTLED" in short.summary()
    # no step: the step metrics are NaN by definition, not a failure
    hold = dataclasses.replace(m, step=0.0, rise_time=float("nan"), settling_time=float("nan"))
    assert hold.success
    v = _make(results, "Verification")
    assert v.status is ResultStatus.CHECK_FAILED and not v.success and not v.passed
    assert v.message.startswith("hold_1, draw 2: hold 0.150 mm") and "re-tune" in v.message
    assert v.to_pandas().loc["hold_peak_to_peak_mm", "value"] == 0.15
    assert v.to_pandas().loc["saturation_percent", "unit"] == "%"
    crashed = dataclasses.replace(v, runs=[{"task": "hold_1", "draw": 0, "failed": True}])
    assert crashed.status is ResultStatus.FAILED
    ok = dataclasses.replace(v, passed=True, failures=[])
    assert ok.status is ResultStatus.SUCCESS and ok.success and "PASS (SUCCESS)" in ok.summary()


def test_evaluation_status_names_a_failed_model(results):
    ev = _make(results, "EvaluationResult")
    assert ev.success and ev.to_pandas() is ev.metrics
    assert ev.summary().count("fit") >= 1 and "bar" in ev.summary()
    sim = ev.simulations["reduced"]
    stopped = dataclasses.replace(
        sim,
        stats=dataclasses.replace(sim.stats, status=SolverStatus.MAX_STEPS),
        message="stopped at t = 0.5 s",
    )
    failed = dataclasses.replace(ev, simulations={"reduced": stopped})
    assert (
        failed.status is ResultStatus.FAILED and "reduced: stopped at t = 0.5 s" in failed.message
    )


def test_plotting_reads_results_through_declared_shapes(results):
    assert isinstance(_make(results, "GreyBoxFit"), TracedFit)
    assert isinstance(_make(results, "EvaluationResult"), EvaluationShape)
    from hydropwa.plotting import plot_evaluation, plot_greybox_fit

    with pytest.raises(
        TypeError, match="plot_greybox_fit: a dict has no runs_, profiles_, estimates_"
    ):
        plot_greybox_fit({})
    with pytest.raises(TypeError, match="plot_evaluation: a SimulationResult has no run, measured"):
        plot_evaluation(_make(results, "SimulationResult"))


def test_status_enum_messages_are_distinct_and_only_success_succeeds():
    assert [s.success for s in ResultStatus] == [True, False, False, False, False, False]
    assert len({s.message for s in ResultStatus}) == len(ResultStatus)
    for enum_type in (ResultStatus, SolverStatus, FitStatus):
        assert all(isinstance(s, Status) for s in enum_type)


def test_every_status_enum_says_what_happened_for_every_member():
    """The package's status enums share one base: every member has a message and a verdict."""
    from hydropwa._result import ResultStatus, StatusEnum, status_messages
    from hydropwa.identification.greybox.result import FitStatus
    from hydropwa.simulation import SolverStatus

    for cls in (ResultStatus, SolverStatus, FitStatus):
        assert issubclass(cls, StatusEnum)
        for member in cls:
            assert isinstance(member.message, str) and len(member.message) > 10, member
    assert [m.success for m in SolverStatus] == [m.name == "SUCCESS" for m in SolverStatus]
    assert [m.success for m in FitStatus] == [int(m) > 0 for m in FitStatus]  # scipy's rule

    class Half(StatusEnum):
        SUCCESS = 0
        BROKEN = 1

    with pytest.raises(TypeError, match="no message for BROKEN"):
        status_messages(Half, {Half.SUCCESS: "fine"})
