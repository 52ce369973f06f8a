"""PwaModel: state-space form against the reduced model, packing, export, errors."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.linalg import expm

from hydropwa._errors import PwaError
from hydropwa.linearization import (
    PAPER_WORKING_POINTS,
    PwaModel,
    linearize,
    load_pwa,
    pwa_rhs,
    reduced_rhs,
    save_pwa,
)
from hydropwa.params import get_preset

FRICTION_WP = [-0.1, -0.03, -0.005, 0.0, 0.005, 0.03, 0.1]


@pytest.fixture(scope="module")
def params():
    # a tiny laminar region so that the reduced model is the turbulent law at every working point
    return get_preset("paper").replace(**{"flow.transition_pressure": 10.0})


@pytest.fixture(scope="module", params=["asymmetric", "consistent"])
def tangent_model(params, request):
    return linearize(
        params,
        supply_pressure=93.8e5,
        breakpoints="tangent",
        form=request.param,
        working_points={"friction": FRICTION_WP},
    )


def _fd_jacobian(fun, y, u, h):
    f0 = fun(y, u)
    A = np.zeros((3, 3))
    for j in range(3):
        dy = np.zeros(3)
        dy[j] = h[j]
        A[:, j] = (fun(y + dy, u) - fun(y - dy, u)) / (2 * h[j])
    B = ((fun(y, u + 1e-7) - fun(y, u - 1e-7)) / 2e-7)[:, None]
    return A, B, f0 - A @ y - B[:, 0] * u


@pytest.mark.parametrize("g", [0, 1, 2, 3, 4])
def test_cell_dynamics_equal_fd_linearization_of_reduced_model(tangent_model, params, g):
    """A, B, f of each cell = FD linearization of the reduced model the PWA model is built on.

    Consistent form: Eqs. (12), (14), (15); asymmetric form: the single-rod model, whose PWA
    cells freeze the chamber capacitances at the working position (mid-stroke), so their
    ∂/∂x column is zero where the reduced model's is ∂c/∂x·(...): that column is left out.
    """
    m = tangent_model
    ps = m.supply_pressure
    rform = "asymmetric" if m.form == "asymmetric" else "paper"
    cols = [0, 1] if m.form == "asymmetric" else [0, 1, 2]
    for s in (1, -1):
        ulo, uhi = m._input_bounds(g, s)
        z = m.dead_zone(np.array(0.5 * (ulo + uhi)))
        if np.sign(z) not in (s, 0):
            continue
        for o in range(m.cq.n_cells):
            for w in range(m.friction.n_cells):
                dyn = m.state_space(cells=(g, s, o, w))
                pt = dyn.point
                y = np.array([pt["p_l"], pt["v"], pt["x"]])

                def fun(yy, uu):
                    return reduced_rhs(0.0, yy, uu, ps, None, params, end_stops=False, form=rform)

                # tiny step at v = 0: |v|^δ (δ < 1) in Eq. (11) spoils central differences there
                pe = m.edge_pressure(ps, s)[0]
                h = np.array(
                    [
                        1e-4 * pe * (1 - PAPER_WORKING_POINTS[o]),
                        1e-10 if pt["v"] == 0 else 1e-7,
                        1e-6,
                    ]
                )
                A, B, f = _fd_jacobian(fun, y, pt["u"], h)
                scale = np.abs(np.hstack((A, B))).max(axis=1) + 1e-30
                np.testing.assert_allclose(
                    dyn.A[:, cols] / scale[:, None], A[:, cols] / scale[:, None], atol=2e-5
                )
                np.testing.assert_allclose(dyn.B[:, 0] / scale, B[:, 0] / scale, atol=2e-5)
                rhs = m.rhs(0.0, y, pt["u"])
                np.testing.assert_allclose(
                    rhs, fun(y, pt["u"]), rtol=1e-9, atol=1e-6 * np.abs(rhs).max()
                )
                np.testing.assert_allclose(
                    dyn.A @ y + dyn.B[:, 0] * pt["u"] + dyn.f,
                    rhs,
                    rtol=1e-9,
                    atol=1e-6 * np.abs(rhs).max(),
                )


@pytest.mark.parametrize("form", ["asymmetric", "consistent", "paper"])
def test_matrices_of_eq_23_reproduce_rhs(params, form):
    m = linearize(params, form=form)
    rng = np.random.default_rng(1)
    for _ in range(50):
        y = np.array([rng.uniform(-80e5, 80e5), rng.uniform(-0.15, 0.15), 0.1])
        u = rng.uniform(-1.3, 1.3)
        A, b, f = m.matrices(y[0], y[1], u)
        rhs = pwa_rhs(0.0, y, u, None, None, m)
        np.testing.assert_allclose(A @ y[:2] + b * u + f, rhs[:2], rtol=1e-9, atol=1e-6)


def test_printed_eq_25_27_need_minus_sign_on_cqp(params):
    """(25)–(27) as printed, with k_n, d_n → −s·k_n, −s·d_n, equal the derived matrices.

    The closed forms are written here from the physical cells (Tables VI–IX), independently
    of the kernel that :meth:`PwaModel.matrices` reads.
    """
    m = linearize(params, form="paper")
    p_l, v, u = 30e5, 0.02, 0.6
    A, b, f = m.matrices(p_l, v, u)
    idx = m.cell_index(p_l, v, u)
    cells = m.cells_at(None, idx.s)
    o, n = int(cells["cq"].cell(p_l)), int(cells["cqp"].cell(p_l))
    k_o, d_o = cells["cq"].slopes[o], cells["cq"].offsets[o]
    k_n, d_n = cells["cqp"].slopes[n], cells["cqp"].offsets[n]
    k_g, d_g = m.dead_zone.slopes[idx.g], m.dead_zone.offsets[idx.g]
    cyl = params.cylinder
    kn, dn = -idx.s * k_n, -idx.s * d_n
    c4 = 4 * params.oil.bulk_modulus / cyl.total_volume
    A11 = c4 * d_g * (k_o + kn * p_l + dn - cyl.leakage / d_g)
    b1 = c4 * k_g * p_l * (k_o + d_o / p_l + kn * p_l + dn)
    assert A[0, 0] == pytest.approx(A11, rel=1e-8)
    assert b[0] == pytest.approx(b1, rel=1e-8)
    assert f[0] == pytest.approx(c4 * d_o * d_g, rel=1e-8)
    # the load damping is part of A₂₂ (it was lost in an earlier Python copy of the assembly)
    mass = params.load.mass
    assert A[1, 1] == pytest.approx(
        -(m.friction.pwa.slopes[idx.w] + params.load.damping) / mass, rel=1e-12
    )


def test_paper_form_double_counts_pressure(params):
    ps = 100e5
    cons = linearize(params, supply_pressure=ps, breakpoints="optimized", form="consistent")
    pap = linearize(
        params, supply_pressure=ps, form="paper", breakpoints={"cq": "optimized", "cqp": "paper"}
    )
    exact = params.flow.K * np.sqrt(0.25 * ps)
    assert cons.load_flow(0.5 * ps, 1.2) == pytest.approx(exact, rel=0.03)
    assert pap.load_flow(0.5 * ps, 1.2) / exact == pytest.approx(0.5, abs=0.03)


def test_scheduling_rescales_cells_exactly_asymmetric(params):
    m = linearize(params, scheduled=True)
    al = params.cylinder.area_b / params.cylinder.area_a
    for ps in (60e5, 95e5, 140e5):
        for s, pe in ((1, ps), (-1, al * ps)):  # tank at 0 bar
            cq = m.cells_at(ps, s)["cq"]
            p_hat = s * pe * np.array(PAPER_WORKING_POINTS)
            exact = params.flow.K * np.sqrt(pe * (1 - s * p_hat / pe) / (1 + al**3))
            np.testing.assert_allclose(cq(p_hat), exact, rtol=1e-12)
        y = np.array([0.3 * ps, 0.01, 0.1])
        q = m.load_flow(y[0], 0.8, ps)
        assert q == pytest.approx(
            0.7 * params.flow.K * np.sqrt((ps - y[0]) / (1 + al**3)), rel=1e-12
        )


def test_scheduling_rescales_cells_exactly(params):
    m = linearize(params, scheduled=True, form="consistent")
    for ps in (60e5, 95e5, 140e5):
        cq = m.cells_at(ps)["cq"]
        p_hat = ps * np.array(PAPER_WORKING_POINTS)
        exact = params.flow.K * np.sqrt(0.5 * (ps - p_hat))
        np.testing.assert_allclose(cq(p_hat), exact, rtol=1e-12)
        y = np.array([0.3 * ps, 0.01, 0.1])
        q = m.load_flow(y[0], 0.8, ps)
        assert q == pytest.approx(0.7 * params.flow.K * np.sqrt(0.5 * (ps - y[0])), rel=1e-12)
    # fixed P_S ignores the input
    f = linearize(params, supply_pressure=90e5)
    y = np.array([10e5, 0.0, 0.1])
    np.testing.assert_array_equal(
        pwa_rhs(0, y, 0.5, 140e5, None, f), pwa_rhs(0, y, 0.5, None, None, f)
    )


def test_pack_layout(params):
    from hydropwa._layout import I_CELLS, PWA_SLOT

    m = linearize(params, form="paper", scheduled=True, supply_pressure=85e5)
    p = m.pack()
    assert p[PWA_SLOT["sched"]] == 1.0 and p[PWA_SLOT["psfix"]] == 85e5
    assert p[PWA_SLOT["form"]] == 1.0
    ng, no, nn, nw = (int(p[PWA_SLOT[k]]) for k in ("ng", "no", "nn", "nw"))
    assert (ng, no, nn, nw) == (5, 5, 5, 7)
    assert p.size == I_CELLS + sum(3 * n - 1 for n in (ng, no, nn, nw))
    s = I_CELLS
    np.testing.assert_array_equal(p[s : s + ng - 1], m.dead_zone.breakpoints)
    np.testing.assert_array_equal(p[s + ng - 1 : s + 2 * ng - 1], m.dead_zone.slopes)
    s = I_CELLS + 3 * ng - 1
    np.testing.assert_array_equal(p[s + no - 1 : s + 2 * no - 1], m.cq.pwa.slopes)


def _reference_mean_area_pwa(y, u, ps, fl, m):
    """Ṗ_L, v̇, ẋ of the mean-area PWA forms written from the paper, not from the kernel.

    Eq. (16): z = k_g u + d_g in the dead-zone cell g of u. Eqs. (18), (20): C_q is the PWA
    cell o of √(1 − p̃), p̃ = sign(z)·P_L/P_S, scaled by K√(P_S/2). Eqs. (19), (21): C_qp is
    |z|·K/(4√(P_S/2)) times the PWA cell n of 1/√(1 − p̃) (paper form only). Eq. (17):
    Q_L = z C_q − C_qp P_L. Eq. (14): Ṗ_L = 4E/V_t (Q_L − Ā ẋ − C_L P_L), V_t = V_A + V_B.
    Eqs. (15), (22): m v̇ = Ā P_L − (k_w ẋ + d_w) − F_L − c ẋ (away from the end stops).
    Cells are looked up here with numpy's ``searchsorted`` on the model's public cell sets.
    """
    p_l, v, _x = y
    prm = m.params
    cyl, K = prm.cylinder, prm.flow.K
    dz = m.dead_zone
    g = int(np.searchsorted(dz.breakpoints, u, side="right"))
    z = dz.slopes[g] * u + dz.offsets[g]
    pn = (1.0 if z >= 0 else -1.0) * p_l / ps

    def cell(fit, arg):
        i = int(np.searchsorted(fit.pwa.breakpoints, arg, side="right"))
        return fit.pwa.slopes[i] * arg + fit.pwa.offsets[i]

    c_q = K * np.sqrt(ps / 2.0) * cell(m.cq, pn)
    q_l = z * c_q
    if m.form == "paper":
        q_l -= abs(z) * K / (4.0 * np.sqrt(ps / 2.0)) * cell(m.cqp, pn) * p_l
    area = 0.5 * (cyl.area_a + cyl.area_b)
    gain = 4.0 * prm.oil.bulk_modulus / (cyl.dead_volume_a + cyl.dead_volume_b)
    dp_l = gain * (q_l - area * v - cyl.leakage * p_l)
    friction = cell(m.friction, v)
    dv = (area * p_l - friction - fl - prm.load.damping * v) / prm.load.mass
    return np.array([dp_l, dv, v])


@pytest.mark.parametrize("form", ["consistent", "paper"])
def test_kernel_matches_reference_rhs(params, form):
    """The compiled PWA assembly of the mean-area forms equals the paper's Eqs. (14)–(22).

    The reference is written independently of the kernel (above); load damping and leakage
    are switched on so those terms are exercised. x stays 1 mm inside the stroke, where the
    end-stop force is zero. Tolerance 1e-9 relative: both sides evaluate the same closed
    form in double precision and differ only in the order of operations (dropping the
    leakage term alone, 1e-12 m³/(s·Pa), fails it).
    """
    prm = params.replace(**{"load.damping": 3e3, "cylinder.leakage": 1e-12})
    m = linearize(prm, form=form, scheduled=True)
    rng = np.random.default_rng(3)
    stroke = prm.cylinder.stroke
    for _ in range(200):
        y = np.array(
            [rng.uniform(-90e5, 90e5), rng.uniform(-0.15, 0.15), rng.uniform(1e-3, stroke - 1e-3)]
        )
        u, ps, fl = rng.uniform(-1.3, 1.3), rng.uniform(70e5, 120e5), rng.uniform(-500, 500)
        ref = _reference_mean_area_pwa(y, u, ps, fl, m)
        got = pwa_rhs(0.0, y, u, ps, fl, m)
        np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max())


def test_json_round_trip_identical(params, tmp_path):
    for m in (
        linearize(params),
        linearize(params, form="paper", scheduled=True, breakpoints="optimized"),
    ):
        back = PwaModel.from_json(m.to_json())
        assert back == m
        np.testing.assert_array_equal(back.pack(), m.pack())
        path = save_pwa(m, tmp_path / "pwa.json", overwrite=True)
        assert load_pwa(path) == m
        doc = json.loads(path.read_text())
        assert doc["time"] == "continuous" and len(doc["cells"]) > 0
        cell = doc["cells"][0]
        H, h = np.array(cell["H"]), np.array(cell["h"])
        wp = cell["working_point"]
        assert np.all(H @ np.array([wp["p_l"], wp["v"], wp["x"], wp["u"]]) <= h + 1e-9)


@pytest.mark.parametrize(
    "mutate, match",
    [
        (lambda d: d.update(schema="other/1"), "schema"),
        (lambda d: d.pop("params"), "params"),
        (lambda d: d["cell_sets"]["cq"].update(breakpoints=[0.9, 0.1, 0.2, 0.3]), "increasing"),
        (lambda d: d.update(form="magic"), "form"),
    ],
)
def test_json_schema_mismatch_raises(params, mutate, match):
    d = linearize(params).to_dict()
    mutate(d)
    with pytest.raises(PwaError, match=match):
        PwaModel.from_json(json.dumps(d))


def test_load_pwa_not_json(tmp_path):
    p = tmp_path / "x.json"
    p.write_text("{nope")
    with pytest.raises(PwaError, match="not valid JSON"):
        load_pwa(p)


def test_zoh_matches_expm_of_augmented_matrix(params):
    m = linearize(params)
    dyn = m.state_space({"p_l": 20e5, "v": 0.03, "u": 0.4})
    dt = 5e-4
    d = dyn.discretize(dt)
    M = np.zeros((5, 5))
    M[:3, :3], M[:3, 3], M[:3, 4] = dyn.A, dyn.B[:, 0], dyn.f
    E = expm(M * dt)
    np.testing.assert_allclose(d.A, E[:3, :3], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(d.B[:, 0], E[:3, 3], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(d.f, E[:3, 4], rtol=1e-9, atol=1e-12)
    sys, f = d.to_statespace()
    assert sys.dt == dt and np.allclose(f, d.f)


def test_discrete_export(params, tmp_path):
    m = linearize(params)
    path = save_pwa(m, tmp_path / "d.json", sample_time=1e-3)
    doc = json.loads(path.read_text())
    assert doc["time"] == "discrete" and doc["sample_time"] == 1e-3
    assert load_pwa(path) == m


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (
            {"supply_pressure": 50e5, "load_pressure_range": (-80e5, 80e5)},
            "below the load-pressure range",
        ),
        ({"supply_pressure": -1.0}, "supply pressure"),
        ({"cells": {"cq": 0}}, "positive integer"),
        ({"cells": {"valve": 3}}, "unknown cell set"),
        ({"breakpoints": {"cq": [0.5, 0.2, 0.7, 0.9]}}, "strictly increasing"),
        ({"breakpoints": {"cq": [0.2, 0.5, 0.7, 1.5]}}, "inside the fit interval"),
        ({"breakpoints": "best"}, "must be one of"),
        ({"form": "exact"}, "form"),
        ({"cells": {"cq": 4}}, "use breakpoints='optimized'"),
    ],
)
def test_bad_inputs(params, kwargs, match):
    with pytest.raises(PwaError, match=match):
        linearize(params, **kwargs)


def test_load_force_above_supply_raises(params):
    heavy = params.replace(**{"load.force": 2e4})
    with pytest.raises(PwaError, match="load pressure"):
        linearize(heavy, supply_pressure=50e5)


def test_control_statespace(params):
    sys, f = linearize(params).state_space({"p_l": 0.0, "v": 0.0, "u": 0.5}).to_statespace()
    assert sys.nstates == 3 and sys.ninputs == 1 and f.shape == (3,)


@pytest.mark.parametrize("supply_pressure", [1.0, 1e3])
def test_friction_cells_on_a_range_too_narrow_for_the_stribeck_pattern(params, supply_pressure):
    """At a supply of a few pascal the machine's velocity range (µm/s) is far below the
    Stribeck pattern's breakpoints (0.05χ … 3.5χ), which clip onto one another: the cells
    are then the plain 7-cell minimax fit over that range, a complete model (it packs), and
    they follow the friction law within the fit's own maximum error (grid of 2001 points;
    1e-9 N of slack for the roundoff of evaluating two forms of one affine piece)."""
    from hydropwa.linearization._cells import friction_function

    model = linearize(params, supply_pressure=supply_pressure)
    fit = model.friction
    assert fit is not None and fit.n_cells == 7
    assert model.pack().size > 0
    v = np.linspace(*fit.interval, 2001)
    err = np.abs(fit.pwa(v) - friction_function(params.friction)(v))
    assert err.max() <= fit.max_error + 1e-9
