"""The asymmetric (single-rod) reduced and PWA models: closed forms, agreement with the full
model, an independent NumPy reference of the assembly, exports and their error bounds.

The reference right-hand sides below are written from the chamber equations (9) and the
force balance (10) directly (Ṗ_L = Ṗ_A − α Ṗ_B at the quasi-steady chamber pressures),
not from the capacitance algebra the kernel uses, so they check the derivation too.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.io import loadmat

from hydropwa import FullOrderModel, ReducedModel, get_preset, simulate
from hydropwa._errors import PwaError, SignalError
from hydropwa.components import dead_zone, stribeck_friction
from hydropwa.linearization import (
    UNITS,
    export_pwa,
    linearize,
    machine_velocity_range,
    pwa_rhs,
    pwa_statespaces,
    reduced_rhs,
    save_pwa_mat,
)
from hydropwa.linearization._cells import friction_function


@pytest.fixture(scope="module")
def loaded():
    """Paper rig with the terms an earlier Python copy of the assembly lost or never tested:
    load damping (1e4 N·s/m), piston leakage, a 2 kN load and a non-zero tank pressure."""
    return get_preset("paper").replace(
        **{
            "load.damping": 1e4,
            "cylinder.leakage": 2e-12,
            "load.force": 2000.0,
            "supply.tank_pressure": 2e5,
            "flow.transition_pressure": 10.0,
        }
    )


def _root(dp, p_tr):
    a = abs(dp)
    if a >= p_tr:
        return math.copysign(math.sqrt(a), dp)
    s = dp / p_tr
    return math.sqrt(p_tr) * (1.25 * s - 0.25 * s**3)


def _chambers(q, z, p_l, ps, prm, x, v):
    """Ṗ_L from Eq. (9) for both chambers under Q_B = α Q_A, P_A and P_B from P_L."""
    c, E = prm.cylinder, prm.oil.bulk_modulus
    al, pt = c.area_b / c.area_a, prm.supply.tank_pressure
    if z >= 0:  # P_S − P_A = (P_B − P_T)/α², P_A − α P_B = P_L
        pa = (p_l + al * pt + al**3 * ps) / (1 + al**3)
        pb = pt + al**2 * (ps - pa)
    else:  # P_A − P_T = (P_S − P_B)/α²
        pa = (p_l + al * ps + al**3 * pt) / (1 + al**3)
        pb = ps - al**2 * (pa - pt)
    va = c.dead_volume_a + c.area_a * x
    vb = c.dead_volume_b + c.area_b * (c.stroke - x)
    leak = c.leakage * (pa - pb)
    dpa = E / va * (q - c.area_a * v - leak)
    dpb = E / vb * (-al * q + c.area_b * v + leak)
    return dpa - al * dpb, pa, pb


def _mechanics(pa, pb, friction, v, fl, prm):
    c = prm.cylinder
    return (c.area_a * pa - c.area_b * pb - friction - fl - prm.load.damping * v) / prm.load.mass


def reference_reduced(y, u, ps, fl, prm):
    p_l, v, x = y
    dz, c = prm.dead_zone, prm.cylinder
    z = float(dead_zone(u, dz.alpha, dz.beta, dz.creep_slope, dz.outer_offset))
    _, pa, pb = _chambers(0.0, z, p_l, ps, prm, x, v)
    drop = ps - pa if z >= 0 else pa - prm.supply.tank_pressure  # the metering edge into/out of A
    q = z * prm.flow.K * _root(drop, prm.flow.transition_pressure)
    dp, pa, pb = _chambers(q, z, p_l, ps, prm, x, v)
    fr = prm.friction
    ff = float(
        stribeck_friction(
            v, fr.coulomb, fr.static, fr.viscous, fr.stribeck_velocity, fr.shape, fr.smoothness
        )
    )
    assert math.isclose(c.area_a * pa - c.area_b * pb, c.area_a * p_l, rel_tol=1e-9, abs_tol=1e-6)
    return np.array([dp, _mechanics(pa, pb, ff, v, fl, prm), v])


def reference_pwa(y, u, ps, fl, m):
    p_l, v, x = y
    prm = m.params
    g = int(m.dead_zone.cell(u))
    z = m.dead_zone.slopes[g] * u + m.dead_zone.offsets[g]
    s = 1 if z >= 0 else -1
    cq = m.cells_at(ps, s)["cq"]
    q = z * float(cq(p_l))
    dp, pa, pb = _chambers(q, z, p_l, ps, prm, m.x_capacitance, v)
    ff = float(m.friction.pwa(v))
    return np.array([dp, _mechanics(pa, pb, ff, v, fl, prm), v])


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    pl=st.floats(-60e5, 60e5),
    v=st.floats(-0.3, 0.3),
    x=st.floats(0.01, 0.19),
    u=st.floats(-1.3, 1.3),
    ps=st.floats(60e5, 140e5),
    fl=st.floats(-3e3, 3e3),
)
def test_kernel_equals_independent_reference(loaded, pl, v, x, u, ps, fl):
    """The compiled assembly (reduced and PWA) equals the chamber-level NumPy reference."""
    y = np.array([pl, v, x])
    ref = reference_reduced(y, u, ps, fl, loaded)
    got = reduced_rhs(0.0, y, u, ps, fl, loaded)
    np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max() + 1e-9)
    m = _pwa(loaded)
    ref = reference_pwa(y, u, ps, fl, m)
    got = pwa_rhs(0.0, y, u, ps, fl, m)
    np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max() + 1e-9)


_PWA_CACHE: dict = {}


def _pwa(prm, **kw):
    key = (id(prm), tuple(sorted(kw.items())))
    if key not in _PWA_CACHE:
        _PWA_CACHE[key] = linearize(prm, supply_pressure=100e5, scheduled=True, **kw)
    return _PWA_CACHE[key]


def test_exported_cell_at_working_point_equals_kernel(loaded):
    """Every exported cell's A y + B u + f at its working point is the model's right-hand side
    (1e-9 relative), with load damping, leakage, load force and tank pressure non-zero."""
    m = linearize(loaded, supply_pressure=100e5)
    doc = export_pwa(m)
    assert len(doc["cells"]) > 50
    for c in doc["cells"]:
        wp = c["working_point"]
        y = np.array([wp["p_l"], wp["v"], wp["x"]])
        lhs = np.array(c["A"]) @ y + np.array(c["B"])[:, 0] * wp["u"] + np.array(c["f"])
        ref = reference_pwa(y, wp["u"], 100e5, loaded.load.force, m)
        np.testing.assert_allclose(lhs, ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max())
    # the load damping is in A₂₂ (the lost-damping defect: −32 1/s instead of about −7200 1/s)
    A = np.array(doc["cells"][0]["A"])
    k_w = m.friction.pwa.slopes[doc["cells"][0]["index"]["w"]]
    assert A[1, 1] == pytest.approx(-(k_w + 1e4) / loaded.load.mass, rel=1e-12)


def _no_friction(prm):
    return prm.replace(
        **{
            "friction.coulomb": 0.0,
            "friction.static": 0.0,
            "friction.viscous": 0.0,
            "cylinder.leakage": 0.0,
            "load.damping": 0.0,
            "load.force": 0.0,
            "flow.transition_pressure": 10.0,
        }
    )


@pytest.mark.parametrize("u", [0.3, 0.8])
def test_steady_speeds_equal_full_model_and_closed_form(u):
    """Without load, with viscous friction σ only, both models reach the closed-form speed
    v = ±|z| K √(Δp/(1 + α³))/A_A with A_A P_L = σ v, Δp = P_S − P_L (extension) or
    α P_S + P_L (retraction); σ → 0 gives v_ext/|v_ret| = 1/√α. (The viscous term damps the
    hydraulic mode, which with no friction at all rings for seconds.)"""
    from scipy.optimize import brentq

    sigma = 3000.0
    prm = _no_friction(get_preset("paper")).replace(**{"friction.viscous": sigma})
    c = prm.cylinder
    al, ps, Kv = c.area_b / c.area_a, prm.supply.pressure, prm.flow.K
    dz = prm.dead_zone
    speeds = {}
    for sign in (1, -1):
        z = abs(float(dead_zone(sign * u, dz.alpha, dz.beta, dz.creep_slope, dz.outer_offset)))

        def gap(v, sign=sign, z=z):
            p_l = sigma * v / c.area_a
            drop = ps - p_l if sign > 0 else al * ps + p_l
            return v - sign * z * Kv * math.sqrt(drop / (1 + al**3)) / c.area_a

        closed = brentq(gap, -2.0, 2.0)
        speeds[("closed", sign)] = closed
        for model in (FullOrderModel(prm), ReducedModel(prm)):
            res = simulate(
                model,
                f"step:time=0,after={sign * u}",
                duration=0.25,
                rtol=1e-6,
                initial_position=0.1 - sign * 0.06,
            )
            v = float(np.mean(res["v"][-50:]))
            # 0.3 %: the full model keeps its valve and chamber dynamics; the rest has decayed
            assert v == pytest.approx(closed, rel=3e-3), (model.name, sign)
            speeds[(model.name, sign)] = v
    closed_ratio = speeds[("closed", 1)] / -speeds[("closed", -1)]
    assert closed_ratio > 1.25  # the single-rod asymmetry (1/√α = 1.31 without friction), not ~1
    for name in ("full", "reduced"):
        assert speeds[(name, 1)] / -speeds[(name, -1)] == pytest.approx(closed_ratio, rel=5e-3)


def test_chamber_pressures_match_full_model_in_steady_motion():
    """P_A, P_B recovered in closed form equal the full model's in steady motion (no leakage)."""
    prm = _no_friction(get_preset("paper")).replace(
        **{"friction.viscous": 3000.0, "load.force": 1500.0}
    )
    for u in (0.4, -0.4):
        out = {}
        for model in (FullOrderModel(prm), ReducedModel(prm)):
            res = simulate(
                model,
                f"step:time=0,after={u}",
                duration=0.25,
                rtol=1e-6,
                initial_position=0.1 - 0.15 * u,
            )
            pa, pb = np.mean(res["p_a"][-40:]), np.mean(res["p_b"][-40:])
            out[model.name] = (pa, pb, pa - prm.cylinder.area_b / prm.cylinder.area_a * pb)
            if model.name == "reduced":  # its load pressure channel is its state P_A − α P_B
                assert np.mean(res["p_l"][-40:]) == pytest.approx(out["reduced"][2], rel=1e-9)
        # 0.1 bar of 24–30 bar: what is left of the full model's settling after 0.25 s (0.3 % in speed)
        np.testing.assert_allclose(out["reduced"], out["full"], atol=0.1e5)


def test_drift_per_period_matches_full_model_fast_valve():
    """A zero-mean sine makes the single-rod axis drift; the asymmetric reduced model drifts by the
    full model's amount per period (within 5 %) when the valve is fast (ω0 = 5000 rad/s), the
    paper's mean-area model does not."""
    prm = get_preset("paper").replace(**{"valve.omega0": 5000.0, "valve.omega0_table": ()})
    drift = {}
    for model in (FullOrderModel(prm), ReducedModel(prm), ReducedModel(prm, "paper")):
        res = simulate(
            model, "sine:amplitude=0.4,frequency=2", duration=2.0, initial_position=0.06, fs=1000
        )
        x = res["x"][::500]  # start of each period
        drift[(model.name, getattr(model, "form", ""))] = np.diff(x[1:]).mean()
    full = drift[("full", "")]
    assert abs(full) > 1e-3  # millimetres per period: a real effect
    assert drift[("reduced", "asymmetric")] == pytest.approx(full, rel=0.05)
    assert abs(drift[("reduced", "paper")]) < 0.1 * abs(full)


@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(k=st.integers(0, 10_000), form=st.sampled_from(["asymmetric", "consistent", "paper"]))
def test_error_bound_never_below_dense_sampling(loaded, k, form):
    """The reported bound of each cell is at least the largest error on a dense grid of the cell."""
    m = _bound_model(form)
    regions = m.regions()
    idx, lo, hi = regions[k % len(regions)]
    wp = m.working_point((idx.g, idx.s, idx.o, idx.w))
    wp["p_l"] = float(np.clip(wp["p_l"], lo[0], hi[0]))
    wp["v"] = float(np.clip(wp["v"], lo[1], hi[1]))
    dyn = m.state_space(wp)
    bound = m.error_bound(idx, dyn)
    worst = 0.0
    for P in np.linspace(lo[0], hi[0], 21):
        for u in np.linspace(lo[3], hi[3], 11):
            for v in (lo[1], hi[1]):
                y = np.array([P, v, m.x_capacitance])
                c = m.cell_index(P, v, u)
                if (c.g, c.s, c.o) != (idx.g, idx.s, idx.o) or (form == "paper" and c.n != idx.n):
                    continue  # a point on a cell's upper edge belongs to the next cell
                e = abs(m.rhs(0.0, y, u)[0] - (dyn.A @ y + dyn.B[:, 0] * u + dyn.f)[0])
                worst = max(worst, e)
    assert bound >= worst * (1 - 1e-9)


_BOUND_MODELS: dict = {}


def _bound_model(form):
    if form not in _BOUND_MODELS:
        _BOUND_MODELS[form] = linearize(get_preset("paper"), form=form)
    return _BOUND_MODELS[form]


def test_refinement_meets_the_tolerance():
    m = linearize(get_preset("paper"))
    coarse = export_pwa(m)
    tol = 0.05 * coarse["max_error_bound"]
    fine = export_pwa(m, refine_tol=tol)
    assert fine["max_error_bound"] <= tol < coarse["max_error_bound"]
    assert len(fine["cells"]) > len(coarse["cells"])


def test_engineering_units_are_a_similarity_transform(tmp_path):
    m = linearize(get_preset("paper"))
    si, eng = export_pwa(m), export_pwa(m, units="engineering")
    assert [s["unit"] for s in eng["state"]] == ["bar", "mm/s", "mm"] and eng["input"][0][
        "unit"
    ] == "%"
    sc = np.array([f for _u, f in UNITS["engineering"]])
    T = np.diag(sc[:3])
    for a, b in zip(si["cells"][:20], eng["cells"][:20], strict=True):
        np.testing.assert_allclose(
            np.array(b["A"]), T @ np.array(a["A"]) @ np.linalg.inv(T), rtol=1e-12, atol=1e-12
        )
        np.testing.assert_allclose(np.array(b["B"]), T @ np.array(a["B"]) / sc[3], rtol=1e-12)
        np.testing.assert_allclose(np.array(b["f"]), T @ np.array(a["f"]), rtol=1e-12, atol=1e-12)
        assert b["error_bound"] == pytest.approx(a["error_bound"] * 1e-5, rel=1e-12)

    # better conditioned: the largest/smallest non-zero entry ratio shrinks by orders of magnitude
    def spread(A):
        a = np.abs(np.array(A))[np.abs(np.array(A)) > 0]
        return a.max() / a.min()

    assert spread(eng["cells"][5]["A"]) < 1e-3 * spread(si["cells"][5]["A"])
    assert json.loads(json.dumps(eng))["variable_order"] == ["p_l", "v", "x", "u"]


def test_statespaces_and_mpt3_mat_round_trip(tmp_path):
    m = linearize(get_preset("paper"))
    doc = export_pwa(m, sample_time=1e-3)
    systems = pwa_statespaces(m, sample_time=1e-3)
    assert len(systems) == len(doc["cells"])
    s0 = systems[7]
    np.testing.assert_allclose(s0["sys"].B[:, 1], doc["cells"][7]["f"], rtol=1e-12)
    assert s0["sys"].dt == pytest.approx(1e-3)
    path = save_pwa_mat(m, tmp_path / "pwa.mat", sample_time=1e-3)
    d = loadmat(path)
    assert d["A"].shape == (len(doc["cells"]), 1)
    for i in (0, 7, len(doc["cells"]) - 1):
        np.testing.assert_allclose(d["A"][i, 0], doc["cells"][i]["A"], rtol=1e-12)
        np.testing.assert_allclose(d["H"][i, 0], doc["cells"][i]["H"], rtol=1e-12)
        np.testing.assert_allclose(d["h"][i, 0].ravel(), doc["cells"][i]["h"], rtol=1e-12)
    assert d["Ts"].item() == pytest.approx(1e-3)
    with pytest.raises(PwaError, match="exists"):
        save_pwa_mat(m, path)


def test_unscheduled_pwa_refuses_a_supply_pressure_it_would_ignore():
    prm = get_preset("paper")
    fixed = linearize(prm, supply_pressure=100e5)
    with pytest.raises(SignalError, match="scheduled=True"):
        simulate(fixed, "sine:amplitude=0.3,frequency=2", duration=0.2, supply_pressure=80e5)
    simulate(
        fixed, "sine:amplitude=0.3,frequency=2", duration=0.2, supply_pressure=100e5
    )  # the same: fine
    sched = linearize(prm, supply_pressure=100e5, scheduled=True)
    res = simulate(sched, "sine:amplitude=0.3,frequency=2", duration=0.2, supply_pressure=80e5)
    assert np.all(res["p_s"] == 80e5)


def test_cli_pwa_follows_the_supply_pressure(tmp_path):
    from typer.testing import CliRunner

    from hydropwa.cli import app

    out = tmp_path / "run.parquet"
    r = CliRunner().invoke(
        app,
        [
            "simulate",
            "--params",
            "paper",
            "--model",
            "pwa",
            "--supply-pressure",
            "80 bar",
            "--duration",
            "0.2",
            "--out",
            str(out),
        ],
    )
    assert r.exit_code == 0, r.output
    assert np.allclose(pd.read_parquet(out)["p_s"], 80e5)


def industrial_axis():
    """63/36 × 500 mm, 250 kg, 210 bar, 60 L/min at 35 bar per land, small overlap, 2 kN load."""
    from hydropwa.params import flow_coefficient_from_rating

    a_a = math.pi / 4 * 0.063**2
    a_b = a_a - math.pi / 4 * 0.036**2
    return get_preset("paper").replace(
        **{
            "cylinder.area_a": a_a,
            "cylinder.area_b": a_b,
            "cylinder.stroke": 0.5,
            "cylinder.dead_volume_a": 0.4e-3,
            "cylinder.dead_volume_b": 0.4e-3,
            "load.mass": 250.0,
            "load.force": 2000.0,
            "supply.pressure": 210e5,
            "supply.relief_pressure": 230e5,
            "flow.K": flow_coefficient_from_rating(60 / 60000, 70e5),
            "friction.coulomb": 300.0,
            "friction.static": 500.0,
            "friction.viscous": 2000.0,
            "friction.stribeck_velocity": 0.02,
        }
    )


def test_friction_cells_from_the_machine():
    """On an industrial axis reaching ~0.5 m/s the cells derived from the machine follow the
    Stribeck curve over its whole velocity range; Table V's breakpoints and ±0.2 m/s do not."""
    prm = industrial_axis()
    lo, hi = machine_velocity_range(prm)
    assert 0.3 < -lo < hi < 1.5
    f = friction_function(prm.friction)
    v = np.concatenate(
        (np.linspace(lo, hi, 4001), np.geomspace(1e-6, 0.05, 400), -np.geomspace(1e-6, 0.05, 400))
    )
    err = {}
    for mode in ("machine", "paper"):
        m = linearize(prm, breakpoints=mode)
        err[mode] = np.max(np.abs(m.friction.pwa(v) - f(v)))
    assert err["machine"] < 0.5 * err["paper"]
    assert err["machine"] < 0.1 * prm.friction.static


def test_default_friction_range_covers_the_machine_on_a_shared_grid():
    """The default friction interval holds the machine's range, at most 5 % wider, and nearby
    supply pressures land on the same grid point, so their friction cells are computed once."""
    prm = industrial_axis()
    for ps in (150e5, 151e5, 210e5):
        lo, hi = machine_velocity_range(prm, ps)
        w_lo, w_hi = linearize(prm, supply_pressure=ps).friction.interval
        assert w_lo <= lo < 0 < hi <= w_hi
        assert -w_lo <= 1.05 * -lo and w_hi <= 1.05 * hi  # one grid step: 10^(1/48) = 1.0491
    a = linearize(prm, supply_pressure=150e5).friction
    b = linearize(prm, supply_pressure=150.5e5).friction  # speeds 0.17 % apart
    assert a is b  # the cached cells of the same grid interval
