"""The solver's packed input vector: every signal kind, several sampled signals in one vector.

The kernel reads all three inputs (u, P_S, F_L) from one float64 vector (``pack_signals``),
with measured samples appended and found by binary search. These tests compare each packed
signal with an independent closed form or ``np.interp``; tolerance 1e-12 relative (the
same formula in a different order of operations), exact for constants and held ends.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hydropwa._errors import SignalError
from hydropwa.simulation import Chirp, Constant, Ramp, Sampled, Sine, Step, pack_signals
from hydropwa.simulation._signals import eval_packed

finite = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)


def _interp_held(t, ts, vs):
    return np.interp(t, ts, vs)  # np.interp holds the end values, as the kernel does


@st.composite
def sampled(draw):
    n = draw(st.integers(2, 60))
    dt = np.array(draw(st.lists(st.floats(1e-4, 1.0), min_size=n - 1, max_size=n - 1)))
    t0 = draw(st.floats(-5.0, 5.0))
    ts = t0 + np.concatenate([[0.0], np.cumsum(dt)])
    vs = np.array(draw(st.lists(finite, min_size=n, max_size=n)))
    return Sampled(ts, vs)


@settings(max_examples=60, deadline=None)
@given(
    a=sampled(), b=sampled(), amp=st.floats(-10, 10), freq=st.floats(0, 50), phase=st.floats(-3, 3)
)
def test_two_sampled_signals_and_a_sine_in_one_vector(a, b, amp, freq, phase):
    sine = Sine(amplitude=amp, frequency=freq, phase=phase, offset=0.5, start=0.1)
    sg = pack_signals([a, sine, b])
    lo = min(a.t[0], b.t[0]) - 1.0
    hi = max(a.t[-1], b.t[-1]) + 1.0
    t = np.concatenate([np.linspace(lo, hi, 501), a.t, b.t])  # also exactly on the samples
    for i, sig in ((0, a), (2, b)):
        got = eval_packed(sg, i, t)
        want = _interp_held(t, sig.t, sig.values)
        scale = np.max(np.abs(sig.values)) + 1.0
        assert np.max(np.abs(got - want)) <= 1e-12 * scale
    arg = 2 * math.pi * freq * (t - 0.1) + phase
    want = np.where(t < 0.1, 0.5, 0.5 + amp * np.sin(arg))
    # the same phase summed in another order differs by a few ulp of |arg| (up to ~1e4 rad
    # here: 50 Hz over 40 s), which sin passes on as an absolute error of |amp|·|arg|·eps
    atol = 1e-12 * (abs(amp) + 1) + 8 * abs(amp) * np.max(np.abs(arg)) * np.finfo(float).eps
    assert np.allclose(eval_packed(sg, 1, t), want, rtol=1e-12, atol=atol)


def test_every_kind_against_its_closed_form():
    t = np.linspace(-1.0, 4.0, 1001)
    sigs = [
        Constant(3.5),
        Step(time=1.0, before=-2.0, after=5.0),
        Ramp(t0=0.5, t1=2.5, v0=1.0, v1=-3.0),
    ]
    sg = pack_signals(sigs)
    assert np.all(eval_packed(sg, 0, t) == 3.5)
    assert np.array_equal(eval_packed(sg, 1, t), np.where(t >= 1.0, 5.0, -2.0))
    assert np.allclose(
        eval_packed(sg, 2, t), np.interp(t, [0.5, 2.5], [1.0, -3.0]), rtol=0, atol=1e-14
    )
    chirp = Chirp(amplitude=2.0, f0=1.0, f1=9.0, duration=2.0, offset=0.25, start=0.5)
    tau = t - 0.5
    want = np.where(
        (tau < 0) | (tau > 2.0),
        0.25,
        0.25 + 2.0 * np.sin(2 * math.pi * (tau + 0.5 * 8.0 * tau**2 / 2.0)),
    )
    assert np.allclose(eval_packed(pack_signals([chirp]), 0, t), want, rtol=0, atol=1e-12)
    # the Python call goes through the same packed evaluation
    tau1 = 1.3 - 0.5
    assert chirp(1.3) == pytest.approx(
        0.25 + 2.0 * math.sin(2 * math.pi * (tau1 + 2.0 * tau1**2)), abs=1e-12
    )


def test_sampled_signal_with_one_sample_is_held():
    s = Sampled(np.array([2.0]), np.array([7.0]))
    assert np.all(eval_packed(pack_signals([s]), 0, np.array([-1.0, 2.0, 50.0])) == 7.0)


def test_more_than_three_signals_is_refused():
    with pytest.raises(SignalError, match="at most 3"):
        pack_signals([Constant(0.0)] * 4)


@pytest.mark.parametrize("kind", ["full", "reduced"])
def test_simulate_packed_is_simulate_bit_for_bit(kind):
    """The grey-box fit's lean path (inputs packed once, no result object) runs the same
    kernel call and output pass as ``simulate``: identical channels, exactly, for measured
    inputs starting at t ≠ 0, a constant supply and a sampled load."""
    from hydropwa.models import FullOrderModel, ReducedModel
    from hydropwa.params import get_preset
    from hydropwa.simulation import simulate
    from hydropwa.simulation._simulate import PackedInputs, simulate_packed

    model = (FullOrderModel if kind == "full" else ReducedModel)(get_preset("paper"))
    ts = np.arange(0.1, 0.3, 5e-4)
    u = Sampled(ts, 0.3 * np.sin(2 * np.pi * 4.0 * ts))
    fl = Sampled(ts, 200.0 * np.cos(2 * np.pi * 3.0 * ts))
    t_out = ts[1:-1].copy()
    y0 = model.initial_state(0.05, supply_pressure=90e5, load_force=float(fl(t_out[0])))
    ref = simulate(
        model, u, timepts=t_out, supply_pressure=90e5, load_force=fl, initial_state=y0, rtol=1e-6
    )
    inputs = PackedInputs.from_signals(u, 90e5, fl, t_out)
    channels, n_done, status = simulate_packed(model, inputs, t_out, y0, rtol=1e-6)
    assert status == 0 and n_done == t_out.size
    for name, values in channels.items():
        np.testing.assert_array_equal(values, ref[name], err_msg=name)
