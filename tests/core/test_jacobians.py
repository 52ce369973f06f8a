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
    assert signed_sqrt_slope(P_TR * (1 - 1e-12), P_TR) == pytest.approx(0.5 / np.sqrt(P_TR), rel=1e-9)
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
    assume(abs(abs(drop) - P_TR) > h)  # not across the laminar-band edge (see test_signed_sqrt_slope)
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
@given(x=st.one_of(st.floats(-1e-3, 0.0), st.floats(0.2, 0.201), st.floats(0.0, 0.2)), v=st.floats(-0.5, 0.5))
def test_end_stop_force_slope(x, v):
    stroke, k, c = 0.2, 1e8, 2e4
    hx, hv = 1e-9, 1e-6
    fx = lambda a: end_stop_force(a, v, stroke, k, c)  # noqa: E731
    fv = lambda b: end_stop_force(x, b, stroke, k, c)  # noqa: E731
    # skip stencils across the contact kink (force crossing zero or x crossing a stop)
    assume(len({fx(x - hx) > 0, fx(x) > 0, fx(x + hx) > 0}) == 1 and len({fx(x - hx) < 0, fx(x) < 0, fx(x + hx) < 0}) == 1)
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
        cells = {K.pwa_cells(pl + s * 1e-7 * max(abs(pl), 1e5), v + r * 1e-7 * max(abs(v), 1e-3), u, ps, p)[:4]
                 for s in (-1, 0, 1) for r in (-1, 0, 1)}
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

    sg = pack_signals([as_signal("sine:amplitude=0.4,frequency=1", "", "u"), as_signal(prm.supply.pressure, "Pa", "p_s"),
                       as_signal(0.0, "N", "f_l")])
    Y, n_done, status, *_ = K.integrate(model.kind, model.initial_state(), res.t, p, sg, 1e-3, model.state_scale(),
                                        1e-5, 0.01, 1_000_000, K.ROS34PW2, True, True, False)
    assert status == K.OK and n_done == len(res.t)
    # both within the benchmark's 0.1 mm of the truth, so within 0.2 mm of each other
    assert np.max(np.abs(Y[:, 2] - res["x"])) < 0.2e-3
