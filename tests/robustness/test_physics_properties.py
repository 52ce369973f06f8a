"""Property tests of the physics with random valid parameters and bounded inputs.

Every simulation is short (≤ 0.5 s simulated) and the example count follows the hypothesis
profile (``PHYSICS_EXAMPLES``: 8 in ``ci``, 150 in ``long``). Tolerances are stated (and
derived) next to each property; see ``docs/robustness.md``.
"""

from __future__ import annotations

import math

import numpy as np
from _fuzzutil import COUNTS
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from robust_support import PHYSICS_EXAMPLES

from hydropwa import FullOrderModel, ReducedModel, get_preset, simulate
from hydropwa.components import chamber_pressure_rates, orifice_flows, stribeck_friction
from hydropwa.linearization import linearize
from hydropwa.params import flow_coefficient_from_rating

PHYS = settings(
    max_examples=PHYSICS_EXAMPLES,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
)
BAR = 1e5


@st.composite
def system_params(draw, symmetric: bool = False):
    """Random parameters inside the documented ranges of each field (rig-sized cylinders)."""
    base = get_preset("paper")
    area_a = draw(st.floats(3e-4, 4e-3))
    area_b = area_a if symmetric else area_a * draw(st.floats(0.4, 1.0))
    stroke = draw(st.floats(0.05, 0.5))
    coulomb = draw(st.floats(0.0, 200.0))
    return base.replace(
        **{
            "supply.pressure": draw(st.floats(20 * BAR, 200 * BAR)),
            "flow.K": flow_coefficient_from_rating(draw(st.floats(5.0, 80.0)) / 6e4, 70 * BAR),
            "cylinder.area_a": area_a,
            "cylinder.area_b": area_b,
            "cylinder.stroke": stroke,
            # up to 50x the swept volume (Cylinder warns above 100x: "did you mean litres?")
            "cylinder.dead_volume_a": min(draw(st.floats(0.1e-3, 2e-3)), 50 * area_a * stroke),
            "cylinder.dead_volume_b": min(draw(st.floats(0.1e-3, 2e-3)), 50 * area_a * stroke),
            "cylinder.leakage": draw(st.sampled_from([0.0, 1e-13, 1e-12, 1e-11])),
            "oil.bulk_modulus": draw(st.floats(0.5e9, 2e9)),
            "friction.coulomb": coulomb,
            "friction.static": coulomb + draw(st.floats(0.0, 200.0)),
            "friction.viscous": draw(st.floats(0.0, 5000.0)),
            "friction.stribeck_velocity": draw(st.floats(1e-3, 0.05)),
            "friction.shape": draw(st.floats(0.5, 2.0)),
            "friction.smoothness": draw(st.floats(1e2, 1e5)),
            "load.mass": draw(st.floats(0.5, 50.0)),
        }
    )


command = st.one_of(
    st.builds(
        lambda a, f: f"sine:amplitude={a},frequency={f}", st.floats(-1.0, 1.0), st.floats(0.5, 10.0)
    ),
    st.builds(lambda a, t: f"step:time={t},after={a}", st.floats(-1.0, 1.0), st.floats(0.0, 0.2)),
    st.builds(lambda a: f"chirp:amplitude={a},f0=1,f1=30,duration=0.4", st.floats(0.05, 1.0)),
)


def _vmax(res) -> float:
    return float(np.max(np.abs(res["v"])))


# ----------------------------------------------------------------------- pressures
@PHYS
@given(params=system_params(), u=command, load=st.floats(-0.3, 0.3))
def test_pressures_stay_physical(params, u, load):
    """vapour pressure − 100 Pa ≤ P_A, P_B ≤ P_S·max(1, A_A/A_B) + ΔP_kin + p_tr.

    Upper bound: the supply pressure, raised by the area ratio on the rod side (intensification
    is physics, not a defect), by the water-hammer rise ΔP_kin = v_max·√(m·E/V_min) that a
    moving mass m can produce when it compresses the smallest chamber volume V_min (kinetic
    energy ½mv² into ½V·ΔP²/E), by the external load over the smaller area, and by the
    transition pressure p_tr of the regularised orifice root (docs/errata.md E3).
    Lower bound: while a chamber is emptied its effective bulk modulus falls to zero at the
    vapour pressure, and below it pulls the pressure back (cavitation, architecture decision 5),
    so only an integration step can overshoot p_vap. At rtol 1e-5 the solver's pressure
    tolerance there is rtol·(1 bar + |p|) ≈ 2 Pa per step; the allowance of 100 Pa is 50 of
    those (the worst overshoot over 2000 random examples was 3.6 Pa).
    """
    c, oil, sup = params.cylinder, params.oil, params.supply
    f_l = load * sup.pressure * min(c.area_a, c.area_b)
    # rtol 1e-5, not the default 1e-3: at 1e-3 an overshoot of ~0.015 bar at the onset of
    # cavitation is an integration error of the size that tolerance allows
    res = simulate(FullOrderModel(params), u, duration=0.3, fs=4000, load_force=f_l, rtol=1e-5)
    v_min = min(c.dead_volume_a, c.dead_volume_b)
    hammer = _vmax(res) * math.sqrt(params.load.mass * oil.bulk_modulus / v_min)
    ratio = max(1.0, c.area_a / c.area_b)
    high = (
        sup.pressure * ratio
        + hammer
        + abs(f_l) / min(c.area_a, c.area_b)
        + params.flow.transition_pressure
    )
    low = oil.vapour_pressure - 100.0
    for ch in ("p_a", "p_b"):
        assert np.all(np.isfinite(res[ch]))
        assert res[ch].min() >= low, f"{ch} min {res[ch].min():.6g} Pa below vapour pressure"
        assert res[ch].max() <= high, f"{ch} max {res[ch].max():.6g} Pa above bound {high:.6g}"


# ----------------------------------------------------------------------- friction
@settings(max_examples=PHYSICS_EXAMPLES * 25, deadline=None)
@given(params=system_params(), v=st.floats(-5.0, 5.0, allow_subnormal=True))
def test_friction_is_odd(params, v):
    """f(−ẋ) = −f(ẋ) to 1e-12 relative (tanh and |ẋ| are odd/even in IEEE arithmetic)."""
    fr = params.friction
    args = (fr.coulomb, fr.static, fr.viscous, fr.stribeck_velocity, fr.shape, fr.smoothness)
    fp, fm = stribeck_friction(v, *args), stribeck_friction(-v, *args)
    assert math.isfinite(fp)
    assert abs(fp + fm) <= 1e-12 * max(abs(fp), 1.0)
    assert fp * v >= 0.0  # dissipative: friction opposes motion


# ----------------------------------------------------------------------- stroke
@PHYS
@given(
    params=system_params(),
    amp=st.floats(0.3, 1.0),
    sign=st.sampled_from([-1.0, 1.0]),
    start=st.floats(0.02, 0.98),
)
def test_piston_stays_within_stroke(params, amp, sign, start):
    """−tol ≤ x ≤ l + tol with tol = F_hyd,max/k_stop + v_max·√(m/k_stop) + 1 µm.

    The end stop is a penalty spring k_stop: it yields F/k_stop under the largest hydraulic
    force F_hyd,max = max(P_A)·A_A + max(P_B)·A_B (pressures as simulated), and absorbs the
    impact ½mv² in a further v·√(m/k_stop).
    """
    c = params.cylinder
    res = simulate(
        FullOrderModel(params),
        f"constant:{sign * amp}",
        duration=0.5,
        fs=2000,
        initial_position=start * c.stroke,
    )
    f_hyd = max(res["p_a"].max(), 0.0) * c.area_a + max(res["p_b"].max(), 0.0) * c.area_b
    k = c.end_stop_stiffness
    tol = f_hyd / k + _vmax(res) * math.sqrt(params.load.mass / k) + 1e-6
    assert res["x"].min() >= -tol
    assert res["x"].max() <= c.stroke + tol


# ----------------------------------------------------------------------- oil volume balance
def _locked(params):
    # A very heavy piston does not move in 0.2 s: x changes by < F·t²/(2m) ≈ 1e-9 m.
    return params.replace(
        **{
            "load.mass": 1e9,
            "friction.coulomb": 0.0,
            "friction.static": 0.0,
            "friction.viscous": 0.0,
        }
    )


@PHYS
@given(
    params=system_params(),
    pa=st.floats(5 * BAR, 150 * BAR),
    pb=st.floats(5 * BAR, 150 * BAR),
    leak=st.floats(1e-12, 1e-10),
)
def test_closed_valve_leakage_conserves_oil(params, pa, pb, leak):
    """Closed valve (u = 0, spool at 0 so z = 0), locked piston, leakage only:
    V_A·P_A + V_B·P_B is conserved (E constant above the release pressure).

    The "locked" piston (m = 1e9 kg) still creeps by Δx ~ 1e-7 m under A_A·P_A − A_B·P_B, which
    changes V_A·P_A + V_B·P_B by E·(A_A − A_B)·Δx; the exact balance checked is therefore
    ∫(V_A dP_A + V_B dP_B) = −E·(A_A − A_B)·Δx (leakage leaves A and enters B: it cancels),
    to 1e-4 of (V_A + V_B)·(|P_A − P_B| + 1 bar): ten times the solver's rtol (fixed at 1e-5 here).
    """
    p = _locked(params).replace(**{"cylinder.leakage": leak})
    c, E = p.cylinder, p.oil.bulk_modulus
    x0 = 0.5 * c.stroke
    state = FullOrderModel(p).state_from_measurement({"x": x0, "v": 0.0, "p_a": pa, "p_b": pb})
    res = simulate(FullOrderModel(p), 0.0, duration=0.2, fs=2000, initial_state=state, rtol=1e-5)
    va = c.dead_volume_a + c.area_a * res["x"]
    vb = c.dead_volume_b + c.area_b * (c.stroke - res["x"])
    vdp = np.concatenate(
        (
            [0.0],
            np.cumsum(
                0.5 * (va[1:] + va[:-1]) * np.diff(res["p_a"])
                + 0.5 * (vb[1:] + vb[:-1]) * np.diff(res["p_b"])
            ),
        )
    )
    expected = -E * (c.area_a - c.area_b) * (res["x"] - res["x"][0])
    scale = (c.dead_volume_a + c.dead_volume_b) * (abs(pa - pb) + BAR)
    assert np.max(np.abs(vdp - expected)) <= 1e-4 * scale
    # and the pressures do move towards each other (leakage acts); the heavy piston still
    # creeps under A_A·P_A − A_B·P_B, which shifts both pressures by a few Pa
    if abs(pa - pb) > BAR:
        assert abs(res["p_a"][-1] - res["p_b"][-1]) < abs(pa - pb)


@PHYS
@given(params=system_params(), u=st.floats(-1.0, 1.0).filter(lambda a: abs(a) > 0.15))
def test_locked_piston_volume_balance(params, u):
    """Locked piston, open valve: (V_A/E)·ΔP_A = ∫(Q_A + Q_leak) dt and
    (V_B/E)·ΔP_B = −∫(Q_B + Q_leak) dt, Q_leak = C_L·(P_B − P_A).

    Flows are recomputed from the simulated z, P_A, P_B with ``components.orifice_flows`` and
    integrated with the trapezoidal rule at 20 kHz. Pressures are kept above the release
    pressure (E constant) by a start in the middle of the supply range and a short run.
    Tolerance 2 % of the largest term plus 1e-9 m³: the quadrature error of the trapezoid on
    a valve that opens within ~5 ms, plus the solver tolerance.
    """
    p = _locked(params)
    c, oil, sup = p.cylinder, p.oil, p.supply
    x0 = 0.5 * c.stroke
    ps = sup.pressure
    state = FullOrderModel(p).state_from_measurement(
        {"x": x0, "v": 0.0, "p_a": 0.5 * ps, "p_b": 0.5 * ps, "p_s": ps}
    )
    res = simulate(FullOrderModel(p), u, duration=0.02, fs=20000, initial_state=state)
    keep = (res["p_a"] > oil.release_pressure + 0.05 * ps) & (
        res["p_b"] > oil.release_pressure + 0.05 * ps
    )
    n = int(np.argmin(keep)) if not keep.all() else keep.size
    if n < 20:
        return
    t = res.t[:n]
    qa = np.empty(n)
    qb = np.empty(n)
    for i in range(n):
        qa[i], qb[i] = orifice_flows(
            res["z"][i],
            res["p_a"][i],
            res["p_b"][i],
            ps,
            sup.tank_pressure,
            p.flow.K,
            p.flow.transition_pressure,
        )
    va = c.dead_volume_a + c.area_a * res["x"][:n]
    vb = c.dead_volume_b + c.area_b * (c.stroke - res["x"][:n])
    lhs_a = va[-1] / oil.bulk_modulus * (res["p_a"][n - 1] - res["p_a"][0])
    lhs_b = vb[-1] / oil.bulk_modulus * (res["p_b"][n - 1] - res["p_b"][0])
    leak = c.leakage * (res["p_b"][:n] - res["p_a"][:n])  # internal leakage B -> A
    rhs_a = np.trapezoid(qa + leak, t)
    rhs_b = -np.trapezoid(qb + leak, t)
    scale = max(abs(lhs_a), abs(lhs_b), abs(rhs_a), abs(rhs_b))
    assert abs(lhs_a - rhs_a) <= 0.02 * scale + 1e-9
    assert abs(lhs_b - rhs_b) <= 0.02 * scale + 1e-9


@settings(max_examples=PHYSICS_EXAMPLES * 25, deadline=None)
@given(
    params=system_params(),
    qa=st.floats(-1e-3, 1e-3),
    qb=st.floats(-1e-3, 1e-3),
    pa=st.floats(0.0, 200 * BAR),
    pb=st.floats(0.0, 200 * BAR),
    frac=st.floats(0.0, 1.0),
)
def test_chamber_continuity_balance(params, qa, qb, pa, pb, frac):
    """Eq. (9) component: (V_A/E)·Ṗ_A + (V_B/E)·Ṗ_B = Q_A − Q_B − (A_A − A_B)·ẋ with v = 0
    reduces to Q_A − Q_B: the leakage term leaves one chamber and enters the other (1e-9 rel.)."""
    c, oil = params.cylinder, params.oil
    x = frac * c.stroke
    dpa, dpb = chamber_pressure_rates(
        qa,
        qb,
        x,
        0.0,
        pa,
        pb,
        c.area_a,
        c.area_b,
        c.stroke,
        c.dead_volume_a,
        c.dead_volume_b,
        c.leakage,
        oil.bulk_modulus,
        oil.vapour_pressure,
        oil.release_pressure,
    )
    va = c.dead_volume_a + c.area_a * x
    vb = c.dead_volume_b + c.area_b * (c.stroke - x)
    total = va / oil.bulk_modulus * dpa + vb / oil.bulk_modulus * dpb
    scale = abs(qa) + abs(qb) + c.leakage * abs(pa - pb)
    assert abs(total - (qa - qb)) <= 1e-9 * scale + 1e-18


# ----------------------------------------------------------------------- model agreement
@PHYS
@given(params=system_params(symmetric=True), amp=st.floats(0.25, 0.8), freq=st.floats(0.5, 2.0))
def test_reduced_and_pwa_track_full_model(params, amp, freq):
    """Symmetric cylinder, low-frequency sine (≤ 2 Hz), 0.5 s, away from the end stops.

    Bound on max|x_model − x_full|:
    reduced: 5 % of the travel + 2·v_max·(2ζ/ω0) + 0.2 mm. The reduced model drops the valve
    dynamics (a lag of 2ζ/ω0, so a position error ≈ v·lag, doubled for the start transient) and
    is otherwise exact for A_A = A_B up to the chamber-volume averaging (the 5 %).
    PWA: the reduced bound + 10 % of the travel: the C_q, C_qp and friction cells of the paper
    approximate the flow with an RMS error of ≈ 8 % (``PwaModel.cq.rms_error``) and the
    position integrates that flow error.
    """
    c = params.cylinder
    # keep the piston in the stroke: travel ≈ K·amp·√(P_S/2)/A / (2π f) must stay < l/2
    u = f"sine:amplitude={amp},frequency={freq}"
    full = simulate(FullOrderModel(params), u, duration=0.5, fs=1000)
    travel = float(np.ptp(full["x"]))
    if full["x"].min() < 0.02 * c.stroke or full["x"].max() > 0.98 * c.stroke:
        COUNTS["physics: model agreement"][0] += 1
        COUNTS["physics: model agreement"][2] += 1  # skipped: the stops act
        return  # the stops act: not the regime the reduced model claims
    COUNTS["physics: model agreement"][0] += 1
    COUNTS["physics: model agreement"][1] += 1  # compared
    lag = (
        2
        * params.valve.zeta
        / min(w for _, w in params.valve.omega0_table or ((0, params.valve.omega0),))
    )
    bound = 0.05 * travel + 2 * _vmax(full) * lag + 0.2e-3
    red = simulate(ReducedModel(params), u, duration=0.5, fs=1000)
    err_red = float(np.max(np.abs(red["x"] - full["x"])))
    assert err_red <= bound, f"reduced: {err_red:.3g} m > {bound:.3g} m"
    pwa = simulate(linearize(params), u, duration=0.5, fs=1000)
    err_pwa = float(np.max(np.abs(pwa["x"] - full["x"])))
    assert err_pwa <= bound + 0.10 * travel, f"pwa: {err_pwa:.3g} m > {bound + 0.10 * travel:.3g} m"
