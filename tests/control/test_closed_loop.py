"""Closed loop: the compiled discrete controller against python-control's linear analysis,
the dead-zone inverse, convergence to the continuous design, anti-windup, and an LQR designed
on the PWA model positioning the full model."""

import math

import control
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from hydropwa.control import (
    DeadZoneInverse,
    PIController,
    StepSequence,
    design_state_feedback,
    tracking_metrics,
)
from hydropwa.linearization import linearize, reduced_rhs
from hydropwa.models import ReducedModel
from hydropwa.params import get_preset
from hydropwa.simulation import simulate

KP = 90.0  # [1/m]: loop gain k_p K_v ≈ 50 1/s, well below the hydraulic mode (~1450 rad/s)
TS = 5e-4


def _jacobian(prm, y0, u0, fl):
    """Central-difference A, B of the reduced model (Eqs. (12)-(15)) and its value f0 at (y0, u0)."""

    def f(y, u):
        return reduced_rhs(0.0, y, u, prm.supply.pressure, fl, prm, form="paper")

    A = np.zeros((3, 3))
    for j, sc in enumerate((1e5, 1e-3, 1e-3)):
        d = 1e-6 * max(abs(y0[j]), sc)
        e = np.zeros(3)
        e[j] = d
        A[:, j] = (f(y0 + e, u0) - f(y0 - e, u0)) / (2 * d)
    # one-sided in u: the flow gain differs for z > 0 (√(P_S − P_L)) and z < 0 (√(P_S + P_L)), and
    # the opening that holds the load against the leakage is positive
    B = ((f(y0, u0 + 1e-7) - f(y0, u0)) / 1e-7)[:, None]
    return A, B, f(y0, u0)


def test_p_loop_on_reduced_model_matches_python_control(linear_valve):
    """Small step under P control: time constant and the leakage's steady-state error as predicted.

    On the paper's mean-area reduced model (P_L = P_A − P_B, where the leakage term is C_L·P_L
    and the docstring's closed form z/k_p holds exactly).

    With leakage C_L and a load F_L, holding P_L0 = F_L/Ā needs the flow C_L·P_L0, so the
    valve stays open by z = C_L P_L0/K_q and the P loop keeps the error z/k_p (0.068 mm here).
    The linear analysis linearizes at (P_L0, 0, u = 0), where the leakage is the constant
    term f0 of the affine model; python-control's dcgain of the closed loop with f0 as its
    input gives the error, its dominant pole the time constant. Tolerances: 3 % (the flow
    gain changes with z by √ at second order; the time constant is fitted on 40-95 % of the
    response, where the hydraulic modes (-341 1/s) have decayed below 2 %).
    """
    prm = linear_valve.replace(**{"cylinder.leakage": 1e-12, "load.force": 3000.0})
    pl0 = prm.load.force / prm.cylinder.mean_area
    x_eq, step = 0.1, 1e-3
    A, B, f0 = _jacobian(prm, np.array([pl0, 0.0, x_eq]), 0.0, prm.load.force)
    C = np.array([[0.0, 0.0, 1.0]])
    # steady-state error: closed loop y' = (A - k_p B C) y + f0, e = -x (reference 0)
    e_lin = -float(control.ss(A - KP * B @ C, f0[:, None], C, 0).dcgain())
    cl = control.feedback(KP * control.sample_system(control.ss(A, B, C, 0), TS, "zoh"), 1)
    s = np.log(cl.poles().astype(complex)) / TS
    tau_lin = -1.0 / s.real[np.argmin(np.abs(s.real))]

    ctrl = PIController(kp=KP, sample_time=TS)
    r = simulate(
        ReducedModel(prm, "paper"),
        duration=0.45,
        fs=20000.0,
        controller=ctrl,
        initial_position=x_eq,
        rtol=1e-7,
        reference=f"step:time=0.2,before={x_eq},after={x_eq + step}",
        load_force=prm.load.force,
    )
    t, e = r.t, r["error"]
    e_ss_before = e[(t > 0.15) & (t < 0.2)].mean()
    e_ss_after = e[t > 0.4].mean()
    assert e_lin == pytest.approx(
        6.8e-5, rel=0.05
    )  # z/k_p of the docstring: the set-up is what we think
    assert e_ss_before == pytest.approx(e_lin, rel=0.03)
    assert e_ss_after == pytest.approx(e_lin, rel=0.03)
    # time constant: slope of ln(remaining error) on 40 %..95 % of the move
    x_rel = (r["x"] - r["x"][(t > 0.15) & (t < 0.2)].mean()) / step
    sel = (t > 0.2) & (x_rel > 0.4) & (x_rel < 0.95)
    tau_sim = -1.0 / np.polyfit(t[sel], np.log(1.0 - x_rel[sel]), 1)[0]
    assert tau_sim == pytest.approx(tau_lin, rel=0.03)


def test_dead_zone_inverse_removes_the_dead_band_error(paper):
    """A P loop stalls once k_p|e| falls into the dead band β; the inverse of Table IV closes the gap.

    Pure dead band (no creep, so nothing moves inside it) and viscous friction only. Without
    the inverse the rod stops with 0.5-1.05 of β/k_p (1.1 mm) left; with it the remaining band is
    the inverse's blend width z_w = 0.01 β, so |e| <= 1.05·z_w/k_p (25 times less).
    """
    prm = paper.replace(
        **{
            "dead_zone.creep_slope": 0.0,
            "friction.coulomb": 0.0,
            "friction.static": 0.0,
            "friction.viscous": 1000.0,
        }
    )
    band = prm.dead_zone.beta / KP
    ref = "step:time=0.01,before=0.1,after=0.105"
    plain = simulate(
        "reduced",
        params=prm,
        duration=0.6,
        controller=PIController(kp=KP),
        reference=ref,
        initial_position=0.1,
    )
    dzi = DeadZoneInverse.from_params(prm.dead_zone)
    inv = simulate(
        "reduced",
        params=prm,
        duration=0.6,
        controller=PIController(kp=KP, dead_zone_inverse=dzi),
        reference=ref,
        initial_position=0.1,
    )
    e_plain = tracking_metrics(plain, 0.01).steady_state_error
    e_inv = tracking_metrics(inv, 0.01).steady_state_error
    assert 0.5 * band < e_plain <= 1.05 * band
    assert abs(e_inv) <= 1.05 * dzi.width / KP
    assert dzi.width == pytest.approx(0.01 * prm.dead_zone.beta)


def test_dead_zone_inverse_is_the_inverse_outside_its_blend(paper):
    """dead_zone(DZ⁻¹(c)) = c for |c| >= z_w, for Table IV's cells (Eq. (2), discontinuous creep)."""
    from hydropwa.components import dead_zone

    dz = paper.dead_zone
    inv = DeadZoneInverse.from_params(dz)
    for c in np.concatenate((np.linspace(-0.9, -inv.width, 50), np.linspace(inv.width, 0.9, 50))):
        assert dead_zone(
            inv(c), dz.alpha, dz.beta, dz.creep_slope, dz.outer_offset
        ) == pytest.approx(c, abs=1e-12)
    # inside the blend the creep band gives unit small-signal gain (the default width's purpose)
    c = 0.5 * inv.width * dz.beta / (inv.width + dz.beta)
    assert dead_zone(inv(c), dz.alpha, dz.beta, dz.creep_slope, dz.outer_offset) == pytest.approx(
        c, rel=1e-9
    )


def _continuous_p_loop(prm, kp, r_of_t, x0, t_end):
    def f(t, y):
        return reduced_rhs(t, y, kp * (r_of_t(t) - y[2]), prm.supply.pressure, prm.load.force, prm)

    return solve_ivp(
        f,
        (0.0, t_end),
        [0.0, 0.0, x0],
        method="Radau",
        rtol=1e-9,
        atol=[1.0, 1e-9, 1e-11],
        dense_output=True,
        max_step=1e-3,
    )


def test_discrete_controller_converges_to_the_continuous_design(linear_valve):
    """The ZOH delays the command by T_s/2 on average, so the trajectory error falls like T_s.

    At 2 kHz (40 times the 8 Hz closed-loop bandwidth) the position differs from the
    continuous loop by ~1 % of the step; at 20 kHz ten times less (we require 5 times, the
    error's second-order part), and below 0.3 % of the step.
    """
    step, x0 = 2e-3, 0.1
    ref = f"step:time=0.01,before={x0},after={x0 + step}"
    sol = _continuous_p_loop(linear_valve, KP, lambda t: x0 + step * (t >= 0.01), x0, 0.2)
    errs = []
    for fs_ctl in (2000.0, 20000.0):
        r = simulate(
            "reduced",
            params=linear_valve,
            duration=0.2,
            fs=20000.0,
            rtol=1e-8,
            initial_position=x0,
            controller=PIController(kp=KP, sample_time=1.0 / fs_ctl),
            reference=ref,
        )
        errs.append(np.max(np.abs(r["x"] - sol.sol(r.t)[2])) / step)
    assert errs[0] < 0.03
    assert errs[1] < errs[0] / 5
    assert errs[1] < 3e-3


def test_anti_windup_bounds_the_overshoot_after_a_saturating_step(linear_valve):
    """A 100 mm step saturates the valve for ~0.15 s; the integral must not wind up meanwhile.

    The bound is the PI's own linear behaviour: a 2 mm step (no saturation) overshoots by 12 %
    (integral corner at a fifth of the crossover). With clamping or back-calculation the
    saturating step overshoots less than that (measured 1.3 % and 0 %); without anti-windup
    the integral stored while saturated overshoots by more than twice that (measured 50 %).
    """
    ki = KP * 10.0  # integral corner at 10 1/s, a fifth of the 50 1/s crossover
    out = {}
    for aw, step in (("clamp", 0.1), ("back-calculation", 0.1), ("none", 0.1), ("linear", 0.002)):
        c = PIController(
            kp=KP,
            ki=ki,
            anti_windup="none" if aw == "linear" else aw,
            tracking_gain=50.0 if aw == "back-calculation" else 0.0,
        )
        r = simulate(
            "reduced",
            params=linear_valve,
            duration=1.2,
            controller=c,
            initial_position=0.05,
            reference=f"step:time=0.01,before=0.05,after={0.05 + step}",
        )
        out[aw] = tracking_metrics(r, 0.01)
    assert out["linear"].saturation == 0.0 and out["clamp"].saturation > 0.05
    small = out["linear"].overshoot
    assert 0.05 < small < 0.20
    assert out["clamp"].overshoot < small
    assert out["back-calculation"].overshoot < small
    assert out["none"].overshoot > 2.0 * small


def test_one_sample_delay_shifts_the_applied_command(linear_valve):
    """With ``delay`` the command computed at t_k is applied from t_k+1 on (log and output channel)."""
    ref = "step:time=0.01,before=0.1,after=0.101"
    kw = dict(params=linear_valve, duration=0.02, reference=ref, initial_position=0.1)
    r = simulate("reduced", controller=PIController(kp=KP, delay=True), **kw)
    rec = r.control
    k = int(round(0.01 / TS))
    assert rec["u"][k] == 0.0 and rec["u"][k + 1] == pytest.approx(KP * 1e-3)
    # the output channel u holds the applied command over each interval (ZOH)
    t = r.t
    assert np.allclose(r["u"][(t > 0.0105 + 1e-9) & (t < 0.011 - 1e-9)], rec["u"][k + 1])


@pytest.fixture(scope="module")
def lqr(paper):
    return design_state_feedback(linearize(paper), delay=False)


@pytest.mark.parametrize("load", [0.0, 1500.0, -1500.0])
def test_lqr_designed_on_pwa_positions_the_full_model(paper, lqr, load):
    """Steps over the stroke (10 → 180 → 20 → 100 → 99 mm), both directions, no load and ±1.5 kN.

    The gains come from the PWA model only (70 cells); the full model adds the servo valve,
    both chambers and Stribeck friction. Over the last 100 ms of each 0.8 s hold the rod stays
    within 0.1 mm of the target, moves less than 0.1 mm peak to peak (the stated limit-cycle
    bound; stick-slip on the Stribeck branch is what remains: measured 0.01-0.065 mm) and its
    mean error is below 0.05 mm (measured ≤ 0.044 mm).
    """
    times = np.array([0.0, 0.05, 0.85, 1.65, 2.45])
    pos = np.array([0.01, 0.18, 0.02, 0.10, 0.099])
    r = simulate(
        "full",
        params=paper,
        duration=3.0,
        controller=lqr.controller,
        reference=StepSequence(times, pos),
        initial_position=0.01,
        load_force=load,
    )
    t, x = r.t, r["x"]
    for t_end, target in zip(np.append(times[2:], 3.0), pos[1:], strict=True):
        hold = (t > t_end - 0.1) & (t < t_end - 1e-9)
        # 0.06 mm: the friction cells from the machine (breakpoints="machine") leave the rod
        # crawling on a falling-slope cell a little longer than Table V's did (0.044 mm then)
        assert abs(x[hold].mean() - target) < 6e-5
        assert np.ptp(x[hold]) < 1e-4
        assert np.max(np.abs(x[hold] - target)) < 1e-4
    assert lqr.table["radius"].max() < 1.0  # every cell stable on the model it was designed on


def test_lqr_table_reports_cells_and_warnings(lqr):
    """70 cells (2 flow directions × 5 C_q cells × 7 friction cells); clipped friction cells are noted."""
    t = lqr.table
    assert len(t) == 70 and set(t["s"]) == {-1, 1}
    assert t["controllable"].all()
    # the valve-aware design (servo valve, ZOH in every cell): its poles include the valve's;
    # the hydraulic mode (~1400 rad/s) of the cells whose friction slope is clipped to zero
    # keeps a damping of 0.038 behind the 628 rad/s valve (measured), the others >= 0.3
    assert (t["bandwidth_hz"] > 1.0).all() and (t["damping_min"] > 0.03).all()
    assert (t.loc[~t["friction_clipped"], "damping_min"] > 0.3).all()
    assert (t["radius_valve"] < 1.0).all()  # stable with the servo valve: the design includes it
    # clipped: the friction cells whose slope lies outside [0, the outer (viscous) cells' slope],
    # in all 10 (s, o) combinations (Table V's breakpoints: cells III, IV, V)
    k = linearize(get_preset("paper")).friction.pwa.slopes
    k_max = max(k[0], k[-1])
    assert t["friction_clipped"].sum() == 10 * int(np.sum((k < 0) | (k > k_max)))
    assert (
        lqr.warnings == []
    )  # no cell unstable with the valve (12 were before the valve-aware design)
    assert math.isclose(lqr.controller.sample_time, 5e-4)
