"""Exact derivatives: the component slopes and the reduced/PWA Jacobians against differences.

The solver uses exact ∂f/∂y for the reduced and PWA models (``jac_reduced``, ``jac_pwa``),
built from the slope functions of :mod:`hydropwa.components`. Each is checked against a
central difference of the function it differentiates at random points (hypothesis).
Tolerance: 1e-5 relative to the larger of the two values plus a small absolute floor;
a central difference with step h·|x| has truncation error O(h²)·f''' and rounding
O(ε/h), both below 1e-6 of the slope for the steps chosen. Points whose difference
stencil straddles a kink are skipped: end-stop contact, PWA cell boundaries, and the
laminar-band edge ±p_tr (C¹, but the jump of the second derivative spoils a straddling
difference; the slope there is checked in closed form).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from hydropwa.components import (
    end_stop_force,
    end_stop_force_slope,
    load_flow,
    load_flow_slope,
    signed_sqrt,
    signed_sqrt_slope,
    stribeck_friction,
    stribeck_friction_slope,
)
from hydropwa.linearization import linearize
from hydropwa.models import as_model
from hydropwa.params import get_preset
from hydropwa.simulation import _kernel as K
from hydropwa.simulation import simulate
from hydropwa.simulation._simulate import _KERNEL_KIND as KIND

P_TR = 1e5
FRICTION = (21.15, 174.77, 1158.4, 0.01567, 0.7305, 1324.68)  # the paper preset's Stribeck law


def _close(exact, numeric, rel=1e-5, floor=0.0):
    assert abs(exact - numeric) <= rel * max(abs(exact), abs(numeric)) + floor, (exact, numeric)


def _central(f, x, h):
    return (f(x + h) - f(x - h)) / (2.0 * h)


@settings(max_examples=200, deadline=None)
@given(dp=st.floats(-3e7, 3e7))
def test_signed_sqrt_slope(dp):
    h = 1e-4 * max(abs(dp), P_TR)
    # C¹ but not C² at ±p_tr: a stencil across the edge errs by O(h·Δf'') (found 2.2e-5 relative)
    assume(abs(abs(dp) - P_TR) > 2 * h)
    num = _central(lambda d: signed_sqrt(d, P_TR), dp, h)
    _close(signed_sqrt_slope(dp, P_TR), num, rel=2e-5)  # O(h²) from the 1/√ curvature


def test_signed_sqrt_slope_closed_forms():
    assert signed_sqrt_slope(0.0, P_TR) == pytest.approx(1.25 / np.sqrt(P_TR), rel=1e-15)
    assert signed_sqrt_slope(P_TR, P_TR) == pytest.approx(0.5 / np.sqrt(P_TR), rel=1e-15)
    assert signed_sqrt_slope(P_TR * (1 - 1e-12), P_TR) == pytest.approx(
        0.5 / np.sqrt(P_TR), rel=1e-9
    )
    assert signed_sqrt_slope(-4e6, P_TR) == pytest.approx(0.25e-3, rel=1e-15)


@settings(max_examples=200, deadline=None)
@given(
    z=st.floats(-1.0, 1.0),
    pl=st.floats(-1.2e7, 1.2e7),
    near=st.one_of(st.none(), st.floats(-4 * P_TR, 4 * P_TR)),
    ps=st.floats(2e6, 2.5e7),
)
def test_load_flow_slope(z, pl, near, ps):
    K_ = 2.5e-7
    if near is not None:  # put the metering-edge drop ½(P_S ∓ P_L) in or near the laminar band
        pl = (ps - 2 * near) if z >= 0 else (2 * near - ps)
    h = 1e-4 * max(abs(pl), P_TR)
    drop = 0.5 * (ps - pl) if z >= 0 else 0.5 * (ps + pl)
    assume(
        abs(abs(drop) - P_TR) > h
    )  # not across the laminar-band edge (see test_signed_sqrt_slope)
    num = _central(lambda x: load_flow(z, x, ps, K_, P_TR), pl, h)
    _close(load_flow_slope(z, pl, ps, K_, P_TR), num, rel=1e-4, floor=1e-20)
    assert load_flow_slope(z, pl, ps, K_, P_TR) <= 0.0  # flow falls as the load pressure rises


@settings(max_examples=300, deadline=None)
@given(v=st.one_of(st.floats(-0.5, 0.5), st.floats(-1e-5, 1e-5), st.just(0.0)))
def test_stribeck_friction_slope(v):
    slope = stribeck_friction_slope(v, *FRICTION)
    # the Stribeck term's curvature grows like |v|^(δ-2) near 0, so the step shrinks with |v|
    h = 1e-4 * max(abs(v), 1e-6)
    num = _central(lambda x: float(stribeck_friction(x, *FRICTION)), v, h)
    _close(slope, num, rel=1e-4, floor=1e-3)


def test_stribeck_slope_at_rest_is_gamma_times_static_plus_viscous():
    fc, fs, sigma, chi, delta, gamma = FRICTION
    slope = stribeck_friction_slope(0.0, *FRICTION)
    assert slope == pytest.approx(gamma * fs + sigma, rel=1e-14)


@settings(max_examples=200, deadline=None)
@given(
    x=st.one_of(st.floats(-1e-3, 0.0), st.floats(0.2, 0.201), st.floats(0.0, 0.2)),
    v=st.floats(-0.5, 0.5),
)
def test_end_stop_force_slope(x, v):
    stroke, k, c = 0.2, 1e8, 2e4
    hx, hv = 1e-9, 1e-6
    fx = lambda a: end_stop_force(a, v, stroke, k, c)  # noqa: E731
    fv = lambda b: end_stop_force(x, b, stroke, k, c)  # noqa: E731
    # skip stencils across the contact kink (force crossing zero or x crossing a stop)
    assume(
        len({fx(x - hx) > 0, fx(x) > 0, fx(x + hx) > 0}) == 1
        and len({fx(x - hx) < 0, fx(x) < 0, fx(x + hx) < 0}) == 1
    )
    assume(len({fv(v - hv) != 0, fv(v) != 0, fv(v + hv) != 0}) == 1)
    assume(min(abs(x), abs(x - stroke)) > 2 * hx)
    kx, kv = end_stop_force_slope(x, v, stroke, k, c)
    _close(kx, _central(fx, x, hx), rel=1e-5, floor=1e-3)
    _close(kv, _central(fv, v, hv), rel=1e-5, floor=1e-6)


@pytest.fixture(scope="module")
def packed():
    prm = get_preset("paper")
    return {
        K.REDUCED: as_model("reduced", prm).pack(command_amplitude=0.4),
        K.PWA: linearize(prm).pack(command_amplitude=0.4),
    }


def _fd_jacobian(kind, y, u, ps, p):
    n = 3
    J = np.empty((n, n))
    f_p, f_m = np.empty(n), np.empty(n)
    for j in range(n):
        h = 1e-7 * max(abs(y[j]), (1e5, 1e-3, 1e-3)[j])
        yp, ym = y.copy(), y.copy()
        yp[j] += h
        ym[j] -= h
        K.rhs_at(kind, yp, u, ps, 0.0, p, f_p)
        K.rhs_at(kind, ym, u, ps, 0.0, p, f_m)
        J[:, j] = (f_p - f_m) / (2 * h)
    return J


@settings(max_examples=150, deadline=None)
@given(
    kind=st.sampled_from([K.REDUCED, K.PWA]),
    pl=st.floats(-9e6, 9e6),
    v=st.one_of(st.floats(-0.3, 0.3), st.floats(-1e-3, 1e-3)),
    x=st.floats(-1e-4, 0.2001),
    u=st.floats(-1.0, 1.0),
)
def test_model_jacobian_matches_differences(packed, kind, pl, v, x, u):
    p = packed[kind]
    ps = 1e7
    y = np.array([pl, v, x])
    if kind == K.PWA:  # a difference across a cell boundary is not the cell's slope
        cells = {
            K.pwa_cells(
                pl + s * 1e-7 * max(abs(pl), 1e5), v + r * 1e-7 * max(abs(v), 1e-3), u, ps, p
            )[:4]
            for s in (-1, 0, 1)
            for r in (-1, 0, 1)
        }
        assume(len(cells) == 1)
    assume(min(abs(x), abs(x - 0.2)) > 1e-9)  # end-stop contact kink
    J = np.empty((3, 3))
    (K.jac_reduced if kind == K.REDUCED else K.jac_pwa)(y, u, ps, 0.0, p, J)
    num = _fd_jacobian(kind, y, u, ps, p)
    scale = np.abs(J).max(axis=1, keepdims=True)  # row-wise: rows differ by 10 orders of magnitude
    assert np.all(np.abs(J - num) <= 1e-4 * scale + 1e-12), (J, num)


@pytest.mark.parametrize("name", ["reduced", "pwa"])
def test_exact_and_difference_jacobians_give_the_same_motion(name):
    """The Jacobian only steers the Rosenbrock-W steps; both runs land within the solver tolerance."""
    prm = get_preset("paper")
    model = linearize(prm) if name == "pwa" else as_model(name, prm)
    res = simulate(model, "sine:amplitude=0.4,frequency=1", duration=2.0)
    p = model.pack(command_amplitude=0.4)
    from hydropwa.simulation import as_signal, pack_signals

    sg = pack_signals(
        [
            as_signal("sine:amplitude=0.4,frequency=1", "", "u"),
            as_signal(prm.supply.pressure, "Pa", "p_s"),
            as_signal(0.0, "N", "f_l"),
        ]
    )
    run = K.SolverRun(
        model.initial_state(), res.t, p, sg, 1e-3, model.state_scale(), 1e-5, 0.01, 1_000_000
    )
    Y, n_done, status, *_ = K.integrate(KIND[model.name], run, K.ROS34PW2, True, True, False)
    assert status == K.OK and n_done == len(res.t)
    # both within the benchmark's 0.1 mm of the truth, so within 0.2 mm of each other
    assert np.max(np.abs(Y[:, 2] - res["x"])) < 0.2e-3


# --- ∂f/∂t: input rates and the models' exact time derivatives ---------------------------


def test_dead_zone_slope_matches_differences_in_every_cell():
    from hydropwa.components import dead_zone, dead_zone_slope

    alpha, beta, creep, outer = 0.8, 0.05, 0.1, 0.045
    for nu in (-0.95, -0.5, -0.03, 0.0, 0.02, 0.3, 0.9):  # saturated, open, band, ..., saturated
        h = 1e-7
        num = (
            dead_zone(nu + h, alpha, beta, creep, outer)
            - dead_zone(nu - h, alpha, beta, creep, outer)
        ) / (2 * h)
        assert dead_zone_slope(nu, alpha, beta, creep, outer) == pytest.approx(
            num, rel=1e-9, abs=1e-12
        )


@settings(max_examples=200, deadline=None)
@given(z=st.floats(-1.0, 1.0), pl=st.floats(-1.2e7, 1.2e7), ps=st.floats(2e6, 2.5e7))
def test_load_flow_input_slopes(z, pl, ps):
    from hydropwa.components import load_flow_input_slopes

    K_ = 2.5e-7
    drop = 0.5 * (ps - pl) if z >= 0 else 0.5 * (ps + pl)
    hp = 1e-4 * max(abs(ps), P_TR)
    assume(abs(abs(drop) - P_TR) > hp)  # not across the laminar-band edge
    dq_dz, dq_dps = load_flow_input_slopes(z, pl, ps, K_, P_TR)
    hz = 1e-6
    assume(z - hz >= 0 or z + hz < 0)  # the branch (sign of z) does not change in the stencil
    _close(dq_dz, _central(lambda a: load_flow(a, pl, ps, K_, P_TR), z, hz), rel=1e-6, floor=1e-18)
    _close(dq_dps, _central(lambda b: load_flow(z, pl, b, K_, P_TR), ps, hp), rel=1e-4, floor=1e-20)


_SIGNALS = [
    "sine:amplitude=0.4,frequency=1.3,phase=0.2,offset=0.1,start=0.2",
    "chirp:amplitude=0.2,f0=1,f1=20,duration=2,offset=0.05,start=0.1",
    "ramp:t0=0.3,t1=1.1,v0=-0.2,v1=0.5",
    "step:time=0.5,before=0.1,after=0.3",
    "constant:0.25",
]


@pytest.mark.parametrize("spec", _SIGNALS + ["sampled"])
def test_signal_rates_match_differences(spec):
    """eval_signal_rate is the right derivative of eval_signal for every signal kind.

    Central differences (h = 1e-6 s) at times whose stencil holds no kink; tolerance
    1e-6 relative plus 1e-9 (truncation h²·|f'''| ≤ 1e-12·(2π·20)³·0.2 ≈ 4e-7·rate).
    """
    from hydropwa.simulation import Sampled, as_signal
    from hydropwa.simulation._signals import eval_packed, eval_signal_rate

    if spec == "sampled":
        ts = np.cumsum(np.r_[0.0, np.random.default_rng(1).uniform(0.01, 0.1, 40)])
        sig = Sampled(ts, np.sin(3 * ts))
    else:
        sig = as_signal(spec, "", "u")
    sg = pack_signals_one(sig)
    h = 1e-6
    kinks = {0.1, 0.2, 0.3, 0.5, 1.1, 2.1}
    if spec == "sampled":
        kinks |= set(sig.t)
    t = np.linspace(-0.5, 3.0, 701)
    t = t[[min(abs(tk - k) for k in kinks) > 3 * h for tk in t]]
    num = (eval_packed(sg, 0, t + h) - eval_packed(sg, 0, t - h)) / (2 * h)
    rate = np.array([eval_signal_rate(sg, 0, tk) for tk in t])
    assert np.all(np.abs(rate - num) <= 1e-6 * np.abs(num) + 1e-9), np.max(np.abs(rate - num))
    if spec.startswith("step"):  # the jump is not a rate: zero on both sides and at the jump
        assert eval_signal_rate(sg, 0, 0.5) == 0.0
    if spec.startswith("ramp"):  # right derivative at the corners
        assert eval_signal_rate(sg, 0, 0.3) == pytest.approx(0.875, rel=1e-14)
        assert eval_signal_rate(sg, 0, 1.1) == 0.0


def pack_signals_one(sig):
    from hydropwa.simulation import pack_signals

    return pack_signals([sig])


@settings(max_examples=150, deadline=None)
@given(
    kind=st.sampled_from([K.REDUCED, K.PWA]),
    pl=st.floats(-9e6, 9e6),
    v=st.floats(-0.3, 0.3),
    u=st.floats(-1.0, 1.0),
    ps=st.floats(5e6, 1.5e7),
    rates=st.tuples(st.floats(-5.0, 5.0), st.floats(-1e8, 1e8), st.floats(-1e5, 1e5)),
)
def test_model_time_derivative_matches_differences(
    packed, pwa_scheduled, kind, pl, v, u, ps, rates
):
    """dfdt_reduced / dfdt_pwa equal Σ ∂f/∂input · rate over the inputs u, P_S, F_L.

    Each partial ∂f/∂input by a central difference of rhs_at with a step of 1e-7 of the
    input's scale (1, |P_S|, 1e4 N); the sum weighted by the rates is compared row-wise to
    1e-4 of Σ|∂f/∂input · rate| plus the differences' rounding (PWA both with fixed and
    with P_S-scheduled cells).
    Stencils across a kink are skipped: the dead-zone corners, z = 0, the laminar band's
    edges and PWA cell boundaries.
    """
    p = pwa_scheduled if kind == K.PWA and rates[1] > 0 else packed[kind]
    y = np.array([pl, v, 0.1])
    x0 = np.array([u, ps, 0.0])
    steps = 1e-7 * np.array([1.0, ps, 1e4])
    for i in range(2):  # the stencil stays inside the cells and on one side of every kink
        lo, hi = x0.copy(), x0.copy()
        lo[i] -= steps[i]
        hi[i] += steps[i]
        for a, b in ((lo, hi),):
            za, zb = K._opening(a[0], p), K._opening(b[0], p)
            assume((za >= 0) == (zb >= 0))
            if kind == K.PWA:
                assume(
                    K.pwa_cells(pl, v, a[0], a[1], p)[:4] == K.pwa_cells(pl, v, b[0], b[1], p)[:4]
                )
    alpha, beta, outer = p[K.I_ALPHA], p[K.I_BETA], p[K.I_OUTER]
    for corner in (beta, alpha + outer):
        assume(abs(abs(u) - corner) > 2 * steps[0])
    drop = 0.5 * (ps - pl) if K._opening(u, p) >= 0 else 0.5 * (ps + pl)
    assume(abs(abs(drop) - p[K.I_PTR]) > steps[1])
    num = np.zeros(3)
    weight = np.zeros(3)
    f_p, f_m = np.empty(3), np.empty(3)
    for i in range(3):
        hi, lo = x0.copy(), x0.copy()
        hi[i] += steps[i]
        lo[i] -= steps[i]
        K.rhs_at(kind, y, hi[0], hi[1], hi[2], p, f_p)
        K.rhs_at(kind, y, lo[0], lo[1], lo[2], p, f_m)
        part = (f_p - f_m) / (2 * steps[i]) * rates[i]
        num += part
        # the partial, plus the difference's rounding (~ten ulp of f over the step)
        weight += np.abs(part) + 1e-11 * np.maximum(np.abs(f_p), np.abs(f_m)) / steps[i] * abs(
            rates[i]
        )
    got = np.empty(3)
    (K.dfdt_reduced if kind == K.REDUCED else K.dfdt_pwa)(y, u, ps, 0.0, *rates, p, got)
    assert np.all(np.abs(got - num) <= 1e-4 * weight + 1e-9), (got, num)


@pytest.fixture(scope="module")
def pwa_scheduled():
    """PWA cells scheduled on the measured P_S(t) (∂f/∂P_S ≠ 0)."""
    prm = get_preset("paper")
    p = linearize(prm).pack(command_amplitude=0.4)
    p[K.I_SCHED] = 1.0
    return p


# --- the full model's exact Jacobian ----------------------------------------------------------


@pytest.fixture(scope="module")
def full_packed():
    """The paper rig's full model, with its supply an input and with the pump as a state.

    With worn seals (piston leakage and each chamber's external leakage, 5e-12 m³/(s·Pa), about
    0.3 L/min at 10 bar), so their columns are checked too: they are ~1e-3 of a pressure
    row's largest entry, ten times the tolerance.
    """
    worn = {f"cylinder.{k}": 5e-12 for k in ("leakage", "external_leakage_a", "external_leakage_b")}
    prm = get_preset("paper").replace(**worn)
    p = as_model("full", prm).pack(command_amplitude=0.4)
    pumped = p.copy()
    pumped[K.I_PUMP] = 1.0
    for slot, value in ((K.I_VLINE, 1e-3), (K.I_DROOP, 5e5), (K.I_QMAX, 1e-3), (K.I_PSET, 1e7)):
        pumped[slot] = pumped[slot] if pumped[slot] > 0 else value
    return {False: p, True: pumped}


def _full_state(nu, dnu, pa, pb, x, v, ps):
    y = np.zeros(len(K.Y_FULL))
    y[[K.Y_NU, K.Y_DNU, K.Y_PA, K.Y_PB, K.Y_X, K.Y_V, K.Y_PS]] = nu, dnu, pa, pb, x, v, ps
    return y


def _full_kinks(y, h, p, ps):
    """True if a difference stencil of half-width h around y straddles a kink of rhs_full."""
    prm_ptr, pt = p[K.I_PTR], p[K.I_PT]
    nu, pa, pb, x = y[K.Y_NU], y[K.Y_PA], y[K.Y_PB], y[K.Y_X]
    zs = {K._opening(nu + s * h[K.Y_NU], p) >= 0 for s in (-1, 0, 1)}
    corners = (p[K.I_BETA], p[K.I_ALPHA] + p[K.I_OUTER])
    near_corner = any(abs(abs(nu) - c) < 2 * h[K.Y_NU] for c in corners)
    drops = (ps - pa, pb - pt, pa - pt, ps - pb)
    near_band = any(abs(abs(d) - prm_ptr) < 2 * max(h[K.Y_PA], h[K.Y_PS]) for d in drops)
    near_release = any(
        abs(q - p[K.I_PREL]) < 2 * h[K.Y_PA] or abs(q - p[K.I_PVAP]) < 2 * h[K.Y_PA]
        for q in (pa, pb)
    )
    near_stop = min(abs(x), abs(x - p[K.I_STROKE])) < 2 * h[K.Y_X]
    pump_edges = (p[K.I_PSET], p[K.I_PSET] - p[K.I_DROOP], p[K.I_PRELIEF])
    near_pump = p[K.I_PUMP] > 0.5 and any(abs(y[K.Y_PS] - e) < 2 * h[K.Y_PS] for e in pump_edges)
    return len(zs) > 1 or near_corner or near_band or near_release or near_stop or near_pump


@settings(max_examples=300, deadline=None)
@given(
    pump=st.booleans(),
    nu=st.one_of(st.floats(-1.2, 1.2), st.floats(-0.05, 0.05)),
    dnu=st.floats(-50.0, 50.0),
    pa=st.one_of(st.floats(1e5, 1.1e7), st.floats(-0.9e5, 2e5)),
    pb=st.one_of(st.floats(1e5, 1.1e7), st.floats(-0.9e5, 2e5)),
    x=st.floats(-1e-4, 0.2001),
    v=st.one_of(st.floats(-0.3, 0.3), st.floats(-1e-3, 1e-3)),
    ps=st.floats(8e6, 1.1e7),
)
def test_full_jacobian_matches_differences(full_packed, pump, nu, dnu, pa, pb, x, v, ps):
    """jac_full equals a central difference of rhs_full, column by column (pump on and off).

    The states cover the cavitation range of the chambers (down to −0.9 bar gauge), the dead
    band, the end stops, the laminar band of the metering edges and the pump's droop band;
    stencils across one of those kinks are skipped (see the module docstring; the pump's clip at
    P_S = p_set was found by hypothesis). Row-wise tolerance 1e-4 of the row's largest
    entry: the rows differ by ten orders of magnitude (Pa/s against m/s²).
    """
    p = full_packed[pump]
    y = _full_state(nu, dnu, pa, pb, x, v, ps)
    scale = as_model("full", get_preset("paper")).state_scale()
    h = 1e-7 * np.maximum(np.abs(y), scale)
    assume(not _full_kinks(y, h, p, ps))
    u, ps_in, fl = 0.3, ps, 150.0
    n = y.size
    J = np.empty((n, n))
    assert K.jac_full(y, u, ps_in, fl, p, J)
    num = np.empty((n, n))
    fp, fm = np.empty(n), np.empty(n)
    for j in range(n):
        yp, ym = y.copy(), y.copy()
        yp[j] += h[j]
        ym[j] -= h[j]
        K.rhs_full(yp, u, ps_in, fl, p, fp)
        K.rhs_full(ym, u, ps_in, fl, p, fm)
        num[:, j] = (fp - fm) / (2 * h[j])
    row_scale = np.abs(J).max(axis=1, keepdims=True) + 1e-300
    assert np.all(np.abs(J - num) <= 1e-4 * row_scale + 1e-9), (J - num) / row_scale


def test_full_jacobian_with_an_accumulator_is_left_to_differences():
    """The accumulator's gas law has no exact slope: jac_full says so and leaves J alone."""
    from hydropwa.params import Accumulator

    prm = get_preset("paper").replace(accumulator=Accumulator(gas_volume=0.5e-3))
    p = as_model("full", prm).pack()
    J = np.full((len(K.Y_FULL),) * 2, 7.0)
    assert not K.jac_full(np.zeros(len(K.Y_FULL)), 0.0, 1e7, 0.0, p, J)
    assert np.all(J == 7.0)


@settings(max_examples=150, deadline=None)
@given(
    nu=st.floats(-1.0, 1.0),
    pa=st.floats(1e5, 9e6),
    pb=st.floats(1e5, 9e6),
    ps=st.floats(8e6, 1.1e7),
    rates=st.tuples(st.floats(-5.0, 5.0), st.floats(-1e8, 1e8), st.floats(-1e5, 1e5)),
)
def test_full_time_derivative_matches_differences(full_packed, nu, pa, pb, ps, rates):
    """dfdt_full equals Σ ∂f/∂input · rate over u, P_S (an input here) and F_L.

    Partials by central differences of rhs_full with steps of 1e-7 of each input's scale;
    compared row-wise to 1e-4 of Σ|∂f/∂input · rate| plus the differences' rounding
    (4ε|f|/h per input, times its rate). Stencils across the laminar band's edges are skipped
    (z does not move with u or P_S).
    """
    p = full_packed[False]
    y = _full_state(nu, 3.0, pa, pb, 0.1, 0.05, 0.0)
    h = 1e-7 * np.array([1.0, ps, 1e4])
    h_states = np.full(y.size, 1e-12)  # the states stay put; P_S moves the edges' drops
    h_states[[K.Y_PA, K.Y_PS]] = h[1]
    assume(not _full_kinks(y, h_states, p, ps))
    x0 = np.array([0.3, ps, 100.0])
    n = y.size
    parts = np.empty((3, n))
    rounding = np.zeros(n)  # ε·|f|/h of each difference, weighted by its rate
    fp, fm = np.empty(n), np.empty(n)
    for i in range(3):
        hi, lo = x0.copy(), x0.copy()
        hi[i] += h[i]
        lo[i] -= h[i]
        K.rhs_full(y, hi[0], hi[1], hi[2], p, fp)
        K.rhs_full(y, lo[0], lo[1], lo[2], p, fm)
        parts[i] = (fp - fm) / (2 * h[i])
        rounding += abs(rates[i]) * 4e-16 * np.maximum(np.abs(fp), np.abs(fm)) / h[i]
    want = np.asarray(rates) @ parts
    got = np.empty(n)
    K.dfdt_full(y, *x0, *rates, p, got)
    bound = 1e-4 * (np.abs(np.asarray(rates)[:, None] * parts).sum(axis=0)) + rounding + 1e-9
    assert np.all(np.abs(got - want) <= bound), (got, want)
