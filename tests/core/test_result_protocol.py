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

import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure

from hydropwa import FullOrderModel, ReducedModel, Result, ResultStatus, Status, simulate
from hydropwa.components import stribeck_friction
from hydropwa.control import ControlDesign, design_pi
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
from hydropwa.identification.greybox.result import FitStatus, Identifiability, Profile, RunFit
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
    return GreyBoxFit(
        paper,
        ("coulomb",),
        est,
        np.eye(1) * 100.0,
        np.eye(1),
        np.ones(1),
        True,
        FitStatus.FTOL,
        FitStatus.FTOL.message,
        12,
        3,
        1.0,
        4.0,
        [run],
        {
            "coulomb": Profile(
                "coulomb",
                np.array([280.0, 300.0, 320.0]),
                np.array([4.0, 0.0, 4.0]),
                (280.0, 320.0),
            )
        },
        Identifiability(1.0, [], [], [], []),
        [],
        "full",
        OptimizerStatus.closed_form(),
    )


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
    assert [s.success for s in ResultStatus] == [True, False, False, False, False]
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
