"""Typed simulation results: status enum, success/message, SolverStats, the Model protocol,
python-control's vocabulary (timepts, initial_position) and the error class of bad input."""

from __future__ import annotations

import numpy as np
import pytest

from hydropwa import (
    FullOrderModel,
    Model,
    ParameterError,
    ReducedModel,
    SignalError,
    SimulationError,
    SolverStats,
    SolverStatus,
    simulate,
)
from hydropwa.control import PIController
from hydropwa.linearization import linearize
from hydropwa.models import as_model
from hydropwa.simulation import _kernel as K


def test_status_enum_names_the_kernel_codes_with_fix_it_messages():
    assert [int(s) for s in SolverStatus] == [K.OK, K.MAX_STEPS, K.STEP_COLLAPSE, K.NON_FINITE]
    assert SolverStatus.SUCCESS.success and not SolverStatus.MAX_STEPS.success
    assert "raise max_steps" in SolverStatus.MAX_STEPS.message
    assert "rtol" in SolverStatus.STEP_TOO_SMALL.message
    assert "NaN" in SolverStatus.NONFINITE.message
    assert len({s.message for s in SolverStatus}) == len(SolverStatus)


def test_successful_run_reports_success_and_typed_stats(paper):
    res = simulate(ReducedModel(paper), 0.2, duration=0.05)
    assert res.success and res.status is SolverStatus.SUCCESS
    assert res.message == SolverStatus.SUCCESS.message
    st = res.stats
    assert isinstance(st, SolverStats)
    # every accepted step evaluates the right-hand side at least once per stage
    assert st.steps > 0 and st.rhs_evaluations >= st.steps and st.rejected >= 0
    assert st.rtol == 1e-3 and st.solver == "ros34pw2" and st.wall_time > 0.0
    # readable as a mapping for existing callers; frozen
    assert st["steps"] == st.steps and dict(st)["status"] == 0 and "omega0" in st
    assert st.as_dict()["status"] == 0 and type(st.as_dict()["status"]) is int
    with pytest.raises(AttributeError):
        st.steps = 1  # type: ignore[misc]
    with pytest.raises(KeyError):
        st["message"]


def test_failed_run_without_raising_carries_status_and_message(paper):
    res = simulate(FullOrderModel(paper), 0.5, duration=0.5, max_steps=20, raise_on_failure=False)
    assert not res.success and res.status is SolverStatus.MAX_STEPS
    assert res.stats.steps <= 20 and res.t[-1] < 0.5
    assert "failed at t = " in res.message and SolverStatus.MAX_STEPS.message in res.message
    assert "status=MAX_STEPS" in repr(res)
    with pytest.raises(SimulationError, match="raise max_steps") as info:
        simulate(FullOrderModel(paper), 0.5, duration=0.5, max_steps=20)
    assert info.value.partial.status is SolverStatus.MAX_STEPS


def test_input_errors_raise_their_class(paper):
    with pytest.raises(ParameterError, match="unknown solver 'rk45'; choose"):
        simulate(ReducedModel(paper), 0.1, duration=0.01, solver="rk45")
    with pytest.raises(ParameterError, match="unknown model 'quadratic'"):
        simulate("quadratic", 0.1, duration=0.01)
    with pytest.raises(ParameterError, match=r"linearize\(params\)"):
        as_model("pwa", paper)
    with pytest.raises(SignalError, match="timepts must hold"):
        simulate(ReducedModel(paper), 0.1, timepts=[0.0])
    with pytest.raises(SignalError, match="as_reference"):
        simulate(
            ReducedModel(paper),
            duration=0.01,
            controller=PIController(kp=100.0),
            reference="trapezoid:from=50 mm,to=80 mm,v=0.2,a=5",
        )


def test_every_model_satisfies_the_protocol(paper):
    for model in (FullOrderModel(paper), ReducedModel(paper), linearize(paper)):
        assert isinstance(model, Model)
        y0 = model.initial_state(initial_position=0.07)
        assert y0.shape == (len(model.state_names),) and model.state_scale().shape == y0.shape
        assert y0[list(model.state_names).index("x")] == 0.07
        assert model.pack().dtype == np.float64
    assert not isinstance(paper, Model)


def test_timepts_and_initial_position_and_their_deprecated_aliases(paper):
    tp = np.linspace(0.0, 0.02, 11)
    new = simulate(ReducedModel(paper), 0.1, timepts=tp, initial_position=0.05)
    np.testing.assert_array_equal(new.t, tp)
    assert new["x"][0] == 0.05
    with pytest.warns(DeprecationWarning, match="timepts"):
        old_t = simulate(ReducedModel(paper), 0.1, t=tp, initial_position=0.05)
    with pytest.warns(DeprecationWarning, match="initial_position"):
        old_x = simulate(ReducedModel(paper), 0.1, timepts=tp, x0=0.05)
    for old in (old_t, old_x):  # the aliases change nothing else: bit-for-bit equal
        np.testing.assert_array_equal(old["x"], new["x"])
    with pytest.raises(SignalError, match="not both"), pytest.warns(DeprecationWarning):
        simulate(ReducedModel(paper), 0.1, timepts=tp, t=tp)


def test_channels_are_computed_on_first_read_and_equal_the_eager_pass(paper, monkeypatch):
    """``simulate``'s derived channels wait for the first read (a caller of ``states`` alone
    pays no output pass); then they are the compiled pass on the kernel's states, bit for
    bit, and survive a caller's later change of its ``timepts`` and a pickle round trip."""
    import pickle

    from hydropwa.simulation import _simulate

    calls = []
    outputs = K.outputs
    monkeypatch.setattr(K, "outputs", lambda *a: calls.append(1) or outputs(*a))
    t_out = np.linspace(0.0, 0.2, 401)
    res = simulate(FullOrderModel(paper), "sine:amplitude=0.4,frequency=5", timepts=t_out)
    assert isinstance(res.channels, _simulate.Channels)
    assert res.states.shape == (401, len(res.state_names)) and not calls
    t_out[:] = 0.0  # the caller's array: its later change must not reach the channels
    x = res["x"]
    assert len(calls) == 1
    np.testing.assert_array_equal(x, res.states[:, res.state_names.index("x")])
    assert res.t[-1] == 0.2 and list(res.channels)[0] == "t"
    # the eager pass: simulate_packed computes the same channels at once
    t2 = np.linspace(0.0, 0.2, 401)
    u = "sine:amplitude=0.4,frequency=5"
    inputs = _simulate.PackedInputs.from_signals(u, paper.supply.pressure, 0.0, t2)
    ch, n_done, status = _simulate.simulate_packed(FullOrderModel(paper), inputs, t2, res.states[0])
    assert status == 0 and n_done == 401 and len(calls) == 2
    for name, values in ch.items():
        np.testing.assert_array_equal(values, res[name], err_msg=name)
    res.channels["p_l"] = res["p_a"] - res["p_b"]  # a writer (evaluation) sees a plain mapping
    back = pickle.loads(pickle.dumps(res))
    assert type(back.channels) is dict and list(back.channels) == list(res.channels)
    for name, values in res.channels.items():
        np.testing.assert_array_equal(back.channels[name], values, err_msg=name)
    assert len(calls) == 2
