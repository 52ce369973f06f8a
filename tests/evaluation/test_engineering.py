"""The engineer's views: small-signal Bode, pole map, per-cell margins, error-bound map.

Each is checked against an independent number: the full model's own Jacobian, the design's
closed-loop poles, the unit circle at the margin's gain, the PWA vector field at sampled points.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from hydropwa.evaluation import cell_loops, error_bound_map, small_signal_bode


@pytest.fixture(scope="module")
def pwa(paper):
    from hydropwa.linearization import linearize

    return linearize(paper.replace(**{"supply.model": "ideal"}))


@pytest.fixture(scope="module")
def design(pwa):
    from hydropwa.control import design_state_feedback

    return design_state_feedback(pwa, delay=False)


@pytest.fixture(scope="module")
def loops(pwa, design):
    return cell_loops(pwa, design.controller)


@pytest.mark.parametrize("command", [0.3, -0.3])
def test_linearized_and_full_small_signal_agree_below_the_hydraulic_resonance(pwa, command):
    """Below half the hydraulic natural frequency the PWA cell + valve and the full model's
    Jacobian differ by the C_q cells' approximation of the orifice flow (minimax ~1 % of
    K√(P_S/2)) plus the load-pressure model's single P_L for two chambers: 3 % in magnitude
    and 3° in phase hold for both flow directions (measured 1.4 % / 1.3° extending,
    1.2 % / 2.7° retracting)."""
    bode = small_signal_bode(pwa, command=command)
    wp = bode.working_point
    assert wp["cell"][1] == np.sign(command)  # the working point is in the flow direction asked
    assert np.sign(wp["v"]) == np.sign(command)
    # the hydraulic natural frequency is the closed form's ω_h = √(4E Ā²/(V_t m)) of Eq. (14)
    prm = pwa.params
    c = prm.cylinder
    v_t = c.area_a * c.stroke / 2 + c.area_b * c.stroke / 2 + c.dead_volume_a + c.dead_volume_b
    a_bar = 0.5 * (c.area_a + c.area_b)
    wh = math.sqrt(4 * prm.oil.bulk_modulus * a_bar**2 / (v_t * prm.load.mass)) / (2 * math.pi)
    assert bode.natural_frequency == pytest.approx(wh, rel=0.15)
    mag, phase = bode.agreement(0.5)
    assert mag < 0.03 and phase < 3.0
    # above the valve's corner both roll off: the shape is compared, not only the static gain
    hi = bode.frequency > 2 * max(bode.natural_frequency, bode.valve_frequency)
    assert np.all(np.abs(bode.full[hi]) < 0.2 * abs(bode.full[0]))
    assert np.all(np.abs(bode.linearized[hi]) < 0.2 * abs(bode.linearized[0]))


def test_full_small_signal_is_the_steady_motion_and_its_jacobian(paper):
    """The working point is a steady motion (rates zero); the Jacobian matches central
    differences of the same compiled right-hand side; the static velocity gain matches the
    change of the steady velocity with the command."""
    from hydropwa.models import FullOrderModel
    from hydropwa.simulation import full_point_derivatives, full_small_signal

    prm = paper.replace(**{"supply.model": "ideal"})
    model = FullOrderModel(prm)
    ps, x = prm.supply.pressure, prm.cylinder.stroke / 2
    ss = full_small_signal(model, 0.3, x, ps)
    f, J, B = full_point_derivatives(model, ss.state, 0.3, ps, prm.load.force)
    assert np.all(np.abs(f[[2, 3]]) < 1e-6 * ps) and abs(f[5]) < 1e-6  # Ṗ_A, Ṗ_B, ẍ
    for j in (2, 3, 5):  # P_A, P_B, ẋ columns
        d = 1e-6 * max(abs(ss.state[j]), 1.0)
        yp, ym = ss.state.copy(), ss.state.copy()
        yp[j] += d
        ym[j] -= d
        fd = (
            full_point_derivatives(model, yp, 0.3, ps, prm.load.force)[0]
            - full_point_derivatives(model, ym, 0.3, ps, prm.load.force)[0]
        ) / (2 * d)
        np.testing.assert_allclose(J[:6, j], fd[:6], rtol=1e-5, atol=1e-9 * np.abs(J[:6, j]).max())
    # d v_ss / d u from two steady motions against the Jacobian's static gain without x
    du = 1e-4
    dv = (
        full_small_signal(model, 0.3 + du, x, ps).state[5]
        - full_small_signal(model, 0.3 - du, x, ps).state[5]
    ) / (2 * du)
    keep = [0, 1, 2, 3, 5]  # x frozen: the position only moves the volumes
    A, Bk = ss.A[np.ix_(keep, keep)], ss.B[keep]
    gain = -np.linalg.solve(A, Bk)[4, 0]
    assert gain == pytest.approx(dv, rel=1e-4)


def _design_poles(text: str) -> np.ndarray:
    return np.array([complex(p.strip().replace("+-", "-")) for p in text.split(";")])


def test_closed_loop_poles_are_the_designs(loops, design):
    """With the design's own (clipped) friction slopes the closed-loop poles of every cell are
    the design table's (printed rounded to 1/s)."""
    assert len(loops.table) == len(design.table)
    for _, row in design.table.iterrows():
        ours = np.sort_complex(loops.closed_loop[row["cell"]])
        theirs = np.sort_complex(_design_poles(row["poles"]))
        fast = np.abs(theirs) < 1e5
        np.testing.assert_allclose(ours[fast], theirs[fast], atol=1.0)
    t = loops.table.set_index("cell")
    assert (t["radius [1]"] < 1.0).all()
    np.testing.assert_allclose(t["radius [1]"], design.table.set_index("cell")["radius"], rtol=1e-9)
    # the falling Stribeck branch: cells whose exact open loop grows are the clipped ones
    grows = t["open_loop_max_real [1/s]"] > 1.0
    assert grows.any() and (t.loc[grows, "friction_clipped"]).all()


def test_margins_put_a_pole_on_the_unit_circle(pwa, design, loops):
    """At its gain margin k a cell's loop has a closed-loop pole z* on |z| = 1, and the loop's
    frequency response there is L(z*) = −1/k (the Nyquist curve through −1); 2 % inside the
    margin the loop is stable. At the phase margin's crossover |L| = 1 and ∠L = −180° + PM."""
    from hydropwa.evaluation._engineering import _design_plant, _loop

    t = loops.table
    rows = {r.label: r for r in design.controller.rows}
    ts = design.controller.sample_time
    finite = 0
    for _, rec in t.iterrows():
        key = (int(rec["g"]), int(rec["s"]), int(rec["o"]), int(rec["w"]))
        A, B, _ = _design_plant(pwa, key, design.info["load_force"], True, clip=True)
        Aa, Ba, K = _loop(A, B, rows[rec["cell"]], design.controller, pwa.params.valve)
        n = Aa.shape[0]

        def loop_at(z, Aa=Aa, Ba=Ba, K=K, n=n):
            return (K @ np.linalg.solve(z * np.eye(n) - Aa, Ba))[0, 0]

        for col, inside in (("gain_margin [dB]", 0.98), ("lower_gain_margin [dB]", 1.02)):
            if not math.isfinite(rec[col]):
                continue
            k = 10 ** (rec[col] / 20)
            lam = np.linalg.eigvals(Aa - k * Ba @ K)
            zs = lam[np.argmax(np.abs(lam))]
            assert abs(zs) == pytest.approx(1.0, abs=1e-6)
            assert loop_at(zs) == pytest.approx(-1.0 / k, rel=1e-3, abs=1e-6 / k)
            assert np.max(np.abs(np.linalg.eigvals(Aa - inside * k * Ba @ K))) < 1.0
            finite += 1
        L = loop_at(np.exp(2j * math.pi * rec["gain_crossover [Hz]"] * ts))
        assert abs(L) == pytest.approx(1.0, abs=2e-3)
        wrapped = (np.degrees(np.angle(L)) + 180.0 - rec["phase_margin [deg]"] + 180.0) % 360.0
        assert wrapped - 180.0 == pytest.approx(0.0, abs=0.2)
    assert finite >= len(t)  # the sampled loop's gain is limited in every cell (valve, ZOH)
    # python-control's stability_margins on the last cell's frequency response: same phase margin
    import control

    f = np.logspace(-2, math.log10(0.5 / ts), 300)
    resp = np.array([loop_at(np.exp(2j * math.pi * fi * ts)) for fi in f])
    _, pm, *_ = control.stability_margins(control.frd(resp, 2 * math.pi * f))
    assert pm == pytest.approx(rec["phase_margin [deg]"], abs=1.0)


def test_error_bound_map_bounds_the_vector_field(pwa):
    """At random points of each cell's box, |Ṗ_L(PWA) − the cell's affine row| stays within
    the map's bound (a guaranteed maximum, not a sample statistic)."""
    from hydropwa.linearization import export_pwa

    bounds = error_bound_map(pwa)
    cells = export_pwa(pwa)["cells"]
    assert len(bounds) == len(cells) and (bounds["error_bound"] > 0).all()
    rng = np.random.default_rng(3)
    ps, fl = pwa.supply_pressure, pwa.params.load.force
    worst = 0.0
    for i in rng.choice(len(cells), 25, replace=False):
        r, c = bounds.iloc[i], cells[i]
        A, B, f = np.asarray(c["A"]), np.asarray(c["B"]), np.asarray(c["f"])
        for _ in range(20):
            p = rng.uniform(r["p_l_lo"], r["p_l_hi"])
            v = rng.uniform(r["v_lo"], r["v_hi"])
            u = rng.uniform(r["u_lo"], r["u_hi"])
            x = pwa.params.cylinder.stroke / 2
            if pwa.cell_index(p, v, u, ps)[1:] != (
                int(r["s"]),
                int(r["o"]),
                int(r["n"]),
                int(r["w"]),
            ):
                continue  # on a shared edge
            exact = pwa.rhs(0.0, np.array([p, v, x]), u, ps, fl)[0]
            err = abs(exact - (A[0] @ np.array([p, v, x]) + B[0, 0] * u + f[0]))
            assert err <= r["error_bound"] * (1 + 1e-9)
            worst = max(worst, err / r["error_bound"])
    assert worst > 0.05  # the bound is not vacuous: samples reach a fair part of it


def test_views_draw_and_the_margins_need_gain_rows(pwa, loops):
    from hydropwa.evaluation import EngineeringError
    from hydropwa.plotting import plot_cell_margins, plot_error_bound_map, plot_pole_map

    for obj in (loops, small_signal_bode(pwa, command=0.3)):
        assert "\n" not in repr(obj) and len(repr(obj)) < 250, repr(obj)
        assert obj._repr_html_().startswith("<div>") and "<table>" in obj._repr_html_()
    assert re.search(r"CellLoops\(70 cells: closed-loop radius ≤ 0\.99", repr(loops))
    for fig in (
        plot_pole_map(loops),
        plot_cell_margins(loops),
        plot_error_bound_map(error_bound_map(pwa)),
    ):
        assert fig.axes
    open_only = cell_loops(pwa)
    assert not open_only.closed_loop and "gain_margin [dB]" not in open_only.table

    class PI:
        rows = ()

    with pytest.raises(EngineeringError, match="gain rows"):
        cell_loops(pwa, PI())
