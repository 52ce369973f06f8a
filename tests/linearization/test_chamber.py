"""The chamber-level PWA model ``pwa-chamber``: an independent NumPy reference of the kernel's
assembly, guaranteed error bounds against dense grids, closed forms (steady speeds under load,
the hydraulic natural frequency), agreement with the full model, and the exports' round trips.

The NumPy reference below is written from Eqs. (5), (6), (9) and (10) with the cells evaluated
by :class:`~hydropwa.components.PiecewiseAffine` directly, not through the kernel's packed
layout or its helper functions.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.io import loadmat
from scipy.linalg import expm

from hydropwa import Sampled, get_preset, load_params, simulate
from hydropwa._errors import PwaError
from hydropwa.components import dead_zone
from hydropwa.linearization import (
    ChamberPwaModel,
    capacitance_cells,
    export_pwa,
    flow_cells,
    linearize,
    load_pwa,
    pwa_statespaces,
    save_pwa,
    save_pwa_mat,
)

INDUSTRIAL = Path(__file__).parents[1] / "machines" / "industrial.toml"


@pytest.fixture(scope="module")
def loaded():
    """Paper rig with the terms a copy of an assembly loses first: leakage, load damping, a
    2 kN load, a non-zero tank pressure and a wide laminar band."""
    return get_preset("paper").replace(
        **{
            "load.damping": 1e4,
            "cylinder.leakage": 2e-12,
            "load.force": 2000.0,
            "supply.tank_pressure": 2e5,
            "flow.transition_pressure": 1e5,
        }
    )


@pytest.fixture(scope="module")
def chamber(loaded):
    return linearize(loaded, form="chamber", scheduled=True)


@pytest.fixture(scope="module")
def industrial():
    return load_params(INDUSTRIAL)


def _root(dp, p_tr):
    a = abs(dp)
    if a >= p_tr:
        return math.copysign(math.sqrt(a), dp)
    s = dp / p_tr
    return math.sqrt(p_tr) * (1.25 * s - 0.25 * s**3)


def _reference_rhs(m: ChamberPwaModel, y, u, ps, fl):
    """Eqs. (3), (5), (6), (9), (10) with the model's cells, from the equations (NumPy)."""
    prm = m.params
    c, o = prm.cylinder, prm.oil
    nu, dnu, pa, pb, x, v = y[:6]
    z = float(m.dead_zone(nu))
    pt = prm.supply.tank_pressure
    K = prm.flow.K
    r = m.flow.pwa  # Q = z K √P_S r(ΔP/P_S)
    if z >= 0.0:
        qa = z * K * math.sqrt(ps) * float(r((ps - pa) / ps))
        qb = z * K * math.sqrt(ps) * float(r((pb - pt) / ps))
    else:
        qa = z * K * math.sqrt(ps) * float(r((pa - pt) / ps))
        qb = z * K * math.sqrt(ps) * float(r((ps - pb) / ps))
    xj = float(m.capacitance.centres[m.capacitance.cell(x)])
    va = c.dead_volume_a + c.area_a * xj
    vb = c.dead_volume_b + c.area_b * (c.stroke - xj)
    dpa = o.bulk_modulus / va * (qa - c.area_a * v + c.leakage * (pb - pa))
    dpb = o.bulk_modulus / vb * (-qb + c.area_b * v + c.leakage * (pa - pb))
    fr = float(m.friction.pwa(v))
    acc = (pa * c.area_a - pb * c.area_b - fr - fl - prm.load.damping * v) / prm.load.mass
    # ω0 of the Table II schedule at command amplitude 0, as every model's pack() (point
    # evaluations run at amplitude 0)
    w0, zeta = prm.valve.omega0_at(0.0), prm.valve.zeta
    ddnu = w0 * w0 * (u - nu) - 2.0 * zeta * w0 * dnu
    return np.array([dnu, ddnu, dpa, dpb, v, acc, 0.0, 0.0])


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    nu=st.floats(-1.3, 1.3),
    dnu=st.floats(-50.0, 50.0),
    pa=st.floats(0.5e5, 180e5),
    pb=st.floats(0.5e5, 180e5),
    x=st.floats(0.001, 0.199),
    v=st.floats(-0.5, 0.5),
    u=st.floats(-1.2, 1.2),
    ps=st.floats(60e5, 140e5),
    fl=st.floats(-3000.0, 3000.0),
)
def test_kernel_rhs_matches_numpy_reference(chamber, nu, dnu, pa, pb, x, v, u, ps, fl):
    """The compiled right-hand side equals the equations written out in NumPy (scheduled P_S),
    to rounding: 1e-9 of the largest term of each row."""
    y = np.array([nu, dnu, pa, pb, x, v, ps, pa])
    got = chamber.rhs(0.0, y, u, ps, fl)
    want = _reference_rhs(chamber, y, u, ps, fl)
    prm = chamber.params
    scale = np.array(
        [
            abs(dnu) + 1.0,
            prm.valve.omega0_at(0.0) ** 2 * 3.0 + 1.0,
            *(
                prm.oil.bulk_modulus / prm.cylinder.dead_volume_a * 1e-3,
                prm.oil.bulk_modulus / prm.cylinder.dead_volume_b * 1e-3,
            ),
            1.0,
            2e7 * prm.cylinder.area_a / prm.load.mass,
            1.0,
            1.0,
        ]
    )
    assert np.all(np.abs(got - want) <= 1e-9 * scale), (got, want)


def test_kernel_jacobian_is_exact_inside_a_cell(chamber):
    """∂f/∂y of the kernel equals central differences of its own right-hand side inside the
    cells (relative 1e-6), and ∂f/∂(u, P_S, F_L) likewise."""
    y = np.array([0.35, 3.0, 62e5, 31e5, 0.09, 0.05, 95e5, 62e5])
    f, J, G = chamber.point(y, 0.3, 95e5, 800.0)
    for j in range(8):
        h = 1e-6 * max(abs(y[j]), 1e-3 if j == 4 else 1.0)
        yp, ym = y.copy(), y.copy()
        yp[j] += h
        ym[j] -= h
        col = (chamber.rhs(0, yp, 0.3, 95e5, 800.0) - chamber.rhs(0, ym, 0.3, 95e5, 800.0)) / (
            2 * h
        )
        if j == 6:  # P_S is an input of this model, its state is inert
            assert np.all(J[:, j] == 0.0)
            continue
        assert np.allclose(J[:, j], col, rtol=1e-6, atol=1e-6 * np.abs(J).max()), j
    for k, (du, dps, dfl) in enumerate(((1e-6, 0, 0), (0, 10.0, 0), (0, 0, 1e-3))):
        d = (
            chamber.rhs(0, y, 0.3 + du, 95e5 + dps, 800.0 + dfl)
            - chamber.rhs(0, y, 0.3 - du, 95e5 - dps, 800.0 - dfl)
        ) / (2 * (du + dps + dfl))
        assert np.allclose(G[:, k], d, rtol=1e-6, atol=1e-9 * np.abs(G[:, k]).max()), k


@settings(max_examples=40, deadline=None)
@given(eps=st.floats(1e-4, 0.05), tol=st.floats(0.002, 0.05))
def test_flow_cell_bound_holds_on_a_dense_grid(eps, tol):
    """Every flow cell's guaranteed bound is at least its error on a dense grid of the cell
    (and meets the tolerance): the bound is computed, not sampled."""
    fc = flow_cells(eps, tol)
    e = fc.edges()
    assert np.all(fc.bounds <= tol)
    for i in range(fc.n_cells):
        q = np.linspace(e[i], e[i + 1], 401)
        err = np.abs(fc.pwa(q) - np.array([_root(v, eps) for v in q]))
        # the edges belong to both neighbours; the cells interpolate there (continuous)
        assert err.max() <= fc.bounds[i] + 1e-12
    # continuous, and exact at q = 0 (no flow without a pressure drop)
    assert np.allclose(fc.pwa.jumps(), 0.0, atol=1e-12)
    assert abs(fc.pwa(0.0)) < 1e-15


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    nu=st.floats(-1.2, 1.2),
    pa=st.floats(1e5, 150e5),
    pb=st.floats(1e5, 150e5),
    ps=st.floats(70e5, 120e5),
)
def test_model_flow_bound_covers_the_orifice_law(chamber, nu, pa, pb, ps):
    """|Q_PWA − Q of Eqs. (5)–(6)| ≤ the model's per-cell bound, at any state and scheduled P_S
    (the laminar band p_tr/P_S is fitted at the nominal P_S: the bound is widened by the
    root's change over the band, ≤ 0.1 √p_tr·|z|K)."""
    y = np.array([nu, 0.0, pa, pb, 0.1, 0.0, ps, pa])
    qa, qb = chamber.flows(y, ps)
    ra, rb = chamber.reference_flows(y, ps)
    dz = chamber.params.dead_zone
    z = float(dead_zone(nu, dz.alpha, dz.beta, dz.creep_slope, dz.outer_offset))
    ba, bb = chamber.flow_error_bound(chamber.cell_index(y, ps), z, ps)
    band = 0.1 * math.sqrt(chamber.params.flow.transition_pressure) * abs(z) * chamber.params.flow.K
    assert abs(qa - ra) <= ba + band + 1e-15
    assert abs(qb - rb) <= bb + band + 1e-15


def test_capacitance_bound_holds_on_a_dense_grid(industrial):
    """|V(x_j)/V(x) − 1| ≤ the cell's bound ≤ tolerance for both chambers, over the stroke."""
    cap = capacitance_cells(industrial, 0.01)
    c = industrial.cylinder
    x = np.linspace(0.0, c.stroke, 20001)
    xj = cap.centres[cap.cell(x)]
    ea = np.abs((c.dead_volume_a + c.area_a * xj) / (c.dead_volume_a + c.area_a * x) - 1)
    eb = np.abs(
        (c.dead_volume_b + c.area_b * (c.stroke - xj))
        / (c.dead_volume_b + c.area_b * (c.stroke - x))
        - 1
    )
    assert np.all(np.maximum(ea, eb) <= cap.bounds[cap.cell(x)] + 1e-12)
    assert cap.bounds.max() <= 0.01


def _closed_form_speed(prm, m, z, ps, fl, sign):
    """Steady rod speed of Eqs. (5), (6), (10) at opening z: Q_A = A_A v, Q_B = A_B v, forces
    balanced. Extension: v = zK √((P_S A_A − F_L − F_f)/(A_A³ + A_B³)); retraction:
    |v| = |z|K √((P_S A_B + F_L + F_f)/(A_A³ + A_B³)). F_f from the model's friction cells
    (fixed point), so the closed form tests the flows and the force balance."""
    c, K = prm.cylinder, prm.flow.K
    a3 = c.area_a**3 + c.area_b**3
    v = 0.1 * sign
    for _ in range(50):
        ff = float(m.friction.pwa(v))
        num = ps * c.area_a - fl - ff if sign > 0 else ps * c.area_b + fl + ff
        v = sign * abs(z) * K * math.sqrt(num / a3)
    return v


@pytest.mark.parametrize("u", [0.3, -0.3])
def test_steady_speed_under_load_against_closed_form(industrial, u):
    """Industrial axis (210 bar, 2 kN): the steady speed of pwa-chamber is within 1.5 % of the
    closed form (flow cells within 0.5 % of the full drop's flow; the edge drops here are
    20-80 % of P_S, where that is at most 1.2 % of the flow)."""
    prm = industrial.replace(**{"cylinder.leakage": 0.0})
    m = linearize(prm, form="chamber")
    x0 = 0.05 if u > 0 else 0.45
    r = simulate(m, u, duration=0.35, initial_position=x0)
    k = (r.t > 0.25) & (r.t < 0.35)
    v_sim = float(np.mean(r["v"][k]))
    dz = prm.dead_zone
    z = float(dead_zone(u, dz.alpha, dz.beta, dz.creep_slope, dz.outer_offset))
    v_cf = _closed_form_speed(prm, m, z, prm.supply.pressure, prm.load.force, 1 if u > 0 else -1)
    assert abs(v_sim - v_cf) <= 0.015 * abs(v_cf), (v_sim, v_cf)
    assert np.ptp(r["v"][k]) < 0.01 * abs(v_cf)  # steady


def test_natural_frequency_of_a_mid_stroke_cell(industrial):
    """The oscillating pair of the mid-stroke cell's A (valve closed, z = 0 in the overlap,
    sliding at 0.1 m/s) has |λ| = √(E/m·(A_A²/V_A + A_B²/V_B)) within 1 %, V_A, V_B at the
    cell's position (λ² + (k_w/m)λ + ω_h² = 0 on [P_A, P_B, ẋ], so |λ| = ω_h)."""
    prm = industrial
    m = linearize(prm, form="chamber")
    c = prm.cylinder
    j = int(m.capacitance.cell(0.5 * c.stroke))
    xj = float(m.capacitance.centres[j])
    y = m.initial_state(xj, load_force=prm.load.force)
    y[5] = 0.1  # sliding: the viscous friction cell (the stiction cell's slope overdamps)
    dyn = m.state_space(dict(zip(m.state_names, y, strict=True)) | {"u": 0.0})
    sub = dyn.A[np.ix_([2, 3, 4, 5], [2, 3, 4, 5])]  # P_A, P_B, x, v
    lam = np.linalg.eigvals(sub)
    w = np.max(np.abs(lam[np.abs(lam.imag) > 0]))
    va = c.dead_volume_a + c.area_a * xj
    vb = c.dead_volume_b + c.area_b * (c.stroke - xj)
    wh = math.sqrt(prm.oil.bulk_modulus / prm.load.mass * (c.area_a**2 / va + c.area_b**2 / vb))
    assert abs(w / wh - 1.0) < 0.01, (w, wh)


@pytest.mark.parametrize("machine", ["paper", "industrial"])
def test_agrees_with_the_full_model_on_a_sine_with_supply_pressure(machine, industrial):
    """A 40 %, 2 Hz sine with the full model's sagging P_S(t) scheduled into the cells: position
    fit ≥ 97 %, P_A and P_B ≥ 90 % (the issue's acceptance; measured 99.4/98.9/99.5 % on
    the paper rig and 98.2/99.3/99.6 % on the industrial axis)."""
    from hydropwa.rig._rig import machine_supply, paper_supply

    prm = get_preset("paper") if machine == "paper" else industrial
    sup = paper_supply(prm.supply.pressure) if machine == "paper" else machine_supply(prm)
    u = "sine:amplitude=0.4,frequency=2"
    x0 = 0.1 * prm.cylinder.stroke
    full = simulate("full", u, duration=1.5, params=prm.replace(supply=sup), initial_position=x0)
    m = linearize(prm, form="chamber", scheduled=True)
    y0 = m.state_from_measurement(
        {"x": x0, "v": 0.0, "p_a": full["p_a"][0], "p_b": full["p_b"][0], "p_s": full["p_s"][0]}
    )
    res = simulate(
        m, u, duration=1.5, supply_pressure=Sampled(full.t, full["p_s"]), initial_state=y0
    )

    def fit(a, b):
        return 100 * (1 - np.linalg.norm(a - b) / np.linalg.norm(b - b.mean()))

    assert fit(res["x"], full["x"]) >= 97.0
    assert fit(res["p_a"], full["p_a"]) >= 90.0
    assert fit(res["p_b"], full["p_b"]) >= 90.0


@pytest.fixture(scope="module")
def visited(chamber):
    run = simulate(chamber, "sine:amplitude=0.4,frequency=1", duration=1.0, initial_position=0.1)
    return chamber.visited_cells(run)


def test_every_exported_cell_is_the_vector_field_at_its_working_point(chamber, visited):
    """A y + B u + f of each exported cell equals the model's right-hand side at the cell's
    working point (relative 1e-9), in SI and in engineering units."""
    ps = chamber.supply_pressure
    for units, sc in (("si", None), ("engineering", None)):
        doc = export_pwa(chamber, cells=visited, units=units)
        assert len(doc["cells"]) == len(visited)
        names = doc["variable_order"]
        from hydropwa.linearization._export import _CHAMBER_UNITS

        sc = np.array([f for _u, f in _CHAMBER_UNITS[units]])
        for c in doc["cells"]:
            wp = c["working_point"]
            y = np.array([wp[n] for n in names[:-1]])
            u = wp["u"]
            lin = np.array(c["A"]) @ y + np.array(c["B"])[:, 0] * u + np.array(c["f"])
            f_si = chamber.rhs(0.0, y / sc[:-1], u / sc[-1], ps)
            want = f_si * sc[:-1]
            assert np.allclose(lin, want, rtol=1e-9, atol=1e-9 * np.abs(want).max()), c["index"]


@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(data=st.data())
def test_exported_bound_covers_the_error_in_its_box(chamber, visited, data):
    """Inside each exported box (pressures above the release pressure) the vector field's
    distance to A y + B u + f stays within the cell's error_bound, on Ṗ_A and Ṗ_B."""
    from hydropwa.linearization._export import chamber_regions

    ps = chamber.supply_pressure
    doc = export_pwa(chamber, cells=visited[:30])
    regions = chamber_regions(chamber, visited[:30], ps)
    i = data.draw(st.integers(0, len(regions) - 1))
    idx, lo, hi = regions[i]
    c = doc["cells"][i]
    frac = data.draw(st.lists(st.floats(0.0, 1.0), min_size=3, max_size=3))
    wp = c["working_point"]
    y = np.array([wp[n] for n in chamber.state_names])
    for k, f in zip((0, 2, 3), frac, strict=True):
        y[k] = lo[k] + f * (hi[k] - lo[k])
    y[0] = min(max(y[0], lo[0] + 1e-9), hi[0] - 1e-9)
    y[2:4] = np.maximum(y[2:4], chamber.params.oil.release_pressure)
    if tuple(chamber.cell_index(y, ps)) != tuple(idx):
        return  # a shared edge of the box that the kernel assigns to the neighbour
    lin = np.array(c["A"]) @ y + np.array(c["B"])[:, 0] * wp["u"] + np.array(c["f"])
    f = chamber.rhs(0.0, y, wp["u"], ps)
    assert max(abs(f[2] - lin[2]), abs(f[3] - lin[3])) <= c["error_bound"] * (1 + 1e-9) + 1e-6


def test_export_round_trips(chamber, visited, tmp_path):
    """JSON (the model back, equal), python-control per cell (A, B, f as the document), ZOH
    (A_d = exp(A·T)), MPT3 .mat (the same matrices and boxes)."""
    path = save_pwa(chamber, tmp_path / "c.json", cells=visited[:20])
    back = load_pwa(path)
    assert isinstance(back, ChamberPwaModel) and back == chamber
    y = np.array([0.3, 0.0, 60e5, 30e5, 0.1, 0.02, 100e5, 60e5])
    assert np.array_equal(back.rhs(0, y, 0.3, 90e5), chamber.rhs(0, y, 0.3, 90e5))
    doc = json.loads(path.read_text())
    ss = pwa_statespaces(chamber, cells=visited[:20])
    for c, s in zip(doc["cells"], ss, strict=True):
        assert np.allclose(s["sys"].A, c["A"])
        assert np.allclose(s["sys"].B[:, :1], c["B"])
        assert np.allclose(s["sys"].B[:, 1], c["f"])
    dt = 1e-3
    zoh = export_pwa(chamber, cells=visited[:5], sample_time=dt)
    cont = export_pwa(chamber, cells=visited[:5])
    for cd, cc in zip(zoh["cells"], cont["cells"], strict=True):
        assert np.allclose(cd["A"], expm(np.array(cc["A"]) * dt), rtol=1e-8, atol=1e-10)
    mat = save_pwa_mat(chamber, tmp_path / "c.mat", cells=visited[:20], units="engineering")
    d = loadmat(mat)
    eng = export_pwa(chamber, cells=visited[:20], units="engineering")
    for i, c in enumerate(eng["cells"]):
        assert np.allclose(d["A"][i, 0], c["A"])
        assert np.allclose(d["H"][i, 0], c["H"])
        assert np.allclose(d["h"][i, 0].ravel(), c["h"])
    assert d["cell_index"].shape == (20, 6)
    with pytest.raises(PwaError, match="cell combinations"):
        export_pwa(chamber)  # ~10^5 combinations: refused with the fix


def test_bad_input_says_what_to_do(loaded):
    with pytest.raises(PwaError, match="tolerance"):
        linearize(loaded, form="chamber", tolerances={"flow": -1.0})
    with pytest.raises(PwaError, match="unknown tolerance"):
        linearize(loaded, form="chamber", tolerances={"speed": 0.1})
    with pytest.raises(PwaError, match="chamber form"):
        linearize(loaded, tolerances={"flow": 0.01})
    with pytest.raises(PwaError, match="does not apply"):
        linearize(loaded, form="chamber", capacitance_position=0.1)
    m = linearize(loaded, form="chamber")
    with pytest.raises(Exception, match="fixed at P_S"):
        simulate(m, 0.1, duration=0.01, supply_pressure=80e5)


def test_evaluate_run_scores_the_chamber_model_per_cell():
    """evaluate_run(..., models=("full", "pwa-chamber")) on a run of the full model with the
    rig's pump: the chamber model's fits (measured x 98.8, P_A 98.9, P_B 99.6 %) and its cell
    coverage per set (fractions sum to 1, RMSE of P_A and P_B per cell)."""
    from hydropwa.evaluation import evaluate_run
    from hydropwa.rig._rig import paper_supply

    prm = get_preset("paper")
    full = simulate(
        "full",
        "sine:amplitude=0.4,frequency=2",
        duration=2.5,
        params=prm.replace(supply=paper_supply(prm.supply.pressure)),
        initial_position=0.02,
    )
    run = full.to_run("sine")
    res = evaluate_run(run, prm, models=("full", "pwa-chamber"))
    fit = res.metrics.set_index(["model", "channel"])["nrmse_fit"]
    assert fit["pwa-chamber", "x"] >= 97.0
    assert fit["pwa-chamber", "p_a"] >= 90.0 and fit["pwa-chamber", "p_b"] >= 90.0
    cm = res.cell_metrics[res.cell_metrics.model == "pwa-chamber"]
    assert set(cm["set"]) == {"g", "qa", "qb", "x", "w"}
    assert np.allclose(cm.groupby("set")["fraction"].sum(), 1.0)
    assert cm[["rmse_p_a", "rmse_p_b"]].notna().all().all()
