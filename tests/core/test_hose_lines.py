"""Hose lines between valve and chambers (the ``full-lines`` kind, issue 47 item 6).

- Lines of zero volume are no lines: the right-hand side, the exact Jacobian and ∂f/∂t equal
  the full model's bit for bit at every state (with a constant supply and with the pump
  supply), and so the trajectories agree to the solver's rounding (module doc of
  ``test_lines_of_zero_volume_step_as_the_full_model``).
- With lines, the trajectory follows an independent NumPy/SciPy assembly of the line equations
  (``_reference_rhs`` below: continuity on each line with the series modulus, the laminar or
  orifice resistance, the chambers fed through the lines), integrated by ``solve_ivp`` (Radau)
  at rtol 1e-10.
- Physics: with the valve closed a line and its chamber equalise (no flow at steady state: equal
  pressures), and the oil leaving the line is the oil the chamber stores (mass conservation).
- A rig campaign on the Project Chrono actuator (``tests/machines/chrono.toml``) records the line
  pressures; the dataset is read back and the grey-box data take them as fitted channels and
  initial states.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from hydropwa import simulate
from hydropwa._layout import build_model
from hydropwa.components import dead_zone, orifice_flows, stribeck_friction
from hydropwa.data import check_run, read_dataset
from hydropwa.evaluation import evaluate_run
from hydropwa.identification.greybox.data import Shooting, prepare_run
from hydropwa.models import FullLinesModel, FullOrderModel, machine_model
from hydropwa.params import Lines, get_preset, load_params
from hydropwa.rig import Rig, load_campaign, machine_supply, run_campaign

MACHINES = Path(__file__).parent.parent / "machines"
#: The paper's rig with a constant ω0 (no amplitude schedule: the reference needs one value).
PAPER = get_preset("paper").replace(**{"valve.omega0_table": ()})
#: Hoses of 10 mm: 0.4 m on A, 1 m on B (laminar conductances of ISO VG 46), a 0.15 GPa wall.
HOSES = Lines(
    volume_a=3.14e-5, volume_b=7.85e-5, conductance_a=1.5e-8, conductance_b=6e-9, bulk_modulus=1.5e8
)


def _sine(t):
    return 0.3 * np.sin(2 * np.pi * 5.0 * t)


def _supplied(pump):
    return PAPER.replace(supply=machine_supply(PAPER)) if pump else PAPER


@pytest.mark.parametrize("pump", [False, True], ids=["constant-supply", "pump"])
def test_lines_of_zero_volume_are_the_full_model(pump):
    """Without lines the kind's compiled physics is the full model's: ẏ, ∂f/∂y and ∂f/∂t over
    300 random states (spool, pressures from cavitation to above supply, velocity, position
    across the stroke) with random inputs, each entry within 1e-9 of its peak over the states
    (the issue's bound; measured: equal, or 1 ulp apart where the two compiled functions round
    a product differently), and the line states' rates and rows exactly 0."""
    from hydropwa.simulation._rhs_full import dfdt_full, jac_full, rhs_full
    from hydropwa.simulation._rhs_lines import dfdt_lines, jac_lines, rhs_lines

    params = _supplied(pump)
    full, lines = FullOrderModel(params), FullLinesModel(params)
    pf, pl = full.pack(), lines.pack()
    nf, nl = len(full.state_names), len(lines.state_names)
    names = full.state_names
    rng = np.random.default_rng(47)
    stroke, ps = params.cylinder.stroke, params.supply.pressure
    got: dict[str, list] = {k: [] for k in ("rhs", "jac", "dfdt")}
    want: dict[str, list] = {k: [] for k in ("rhs", "jac", "dfdt")}
    for _ in range(300):
        yf = full.initial_state(rng.uniform(0.0, stroke))
        yf[names.index("spool")] = rng.uniform(-1.0, 1.0)
        yf[names.index("spool_rate")] = rng.normal(0.0, 50.0)
        yf[names.index("p_a")] = rng.uniform(-0.5e5, 1.3 * ps)
        yf[names.index("p_b")] = rng.uniform(-0.5e5, 1.3 * ps)
        yf[names.index("v")] = rng.normal(0.0, 0.05)
        if pump:
            yf[names.index("p_s")] = rng.uniform(0.5 * ps, 1.1 * ps)
        yl = np.concatenate([yf, yf[[names.index("p_a"), names.index("p_b")]]])
        assert yl.size == nl
        u, ps_in, fl = rng.uniform(-1, 1), rng.uniform(0.5 * ps, ps), rng.normal(0.0, 100.0)
        df, dl = np.zeros(nf), np.zeros(nl)
        rhs_full(yf, u, ps_in, fl, pf, df)
        rhs_lines(yl, u, ps_in, fl, pl, dl)
        Jf, Jl = np.zeros((nf, nf)), np.zeros((nl, nl))
        assert jac_full(yf, u, ps_in, fl, pf, Jf) == jac_lines(yl, u, ps_in, fl, pl, Jl)
        rates = rng.normal(0.0, 1.0, 3) * (10.0, 1e6, 1e3)
        tf, tl = np.zeros(nf), np.zeros(nl)
        dfdt_full(yf, u, ps_in, fl, *rates, pf, tf)
        dfdt_lines(yl, u, ps_in, fl, *rates, pl, tl)
        np.testing.assert_array_equal(dl[nf:], 0.0)
        np.testing.assert_array_equal(Jl[nf:], 0.0)
        np.testing.assert_array_equal(Jl[:nf, nf:], 0.0)
        for key, a, b in (("rhs", dl[:nf], df), ("jac", Jl[:nf, :nf], Jf), ("dfdt", tl[:nf], tf)):
            got[key].append(a)
            want[key].append(b)
    for key in got:
        a, b = np.array(got[key]), np.array(want[key])
        peak = np.max(np.abs(b), axis=0)
        assert np.all(np.abs(a - b) <= 1e-9 * peak), key


@pytest.mark.parametrize("pump", [False, True], ids=["constant-supply", "pump"])
def test_lines_of_zero_volume_step_as_the_full_model(pump):
    """Simulated without lines the kind is as accurate as the full model, and converges to it.

    The physics is the full model's bit for bit (the test above), but the step loop is compiled
    once per kind with FMA contraction, so the two kernels' roundings differ (from the first
    sample, 1e-25 m/s here; bit-equal runs on one build, 728 against 729 steps on CI's), and the
    stick-slip at each reversal of the 5 Hz sine magnifies that to the solver's own error. So
    against a reference at rtol 1e-8, each channel's error of the line kind at the default rtol
    stays within 3× the full model's (measured ≤ 2.25×, both ≈ rtol-level: 1e-5 of the
    position's peak, 3 % of the velocity's at the stick-slip), and at rtol 1e-7 the two agree
    within 1e-3 of each channel's peak (measured 9.5e-5).
    """
    params = _supplied(pump)
    t = np.arange(0.0, 0.3, 1 / 2000)
    ref = simulate(FullOrderModel(params), (t, _sine(t)), timepts=t, rtol=1e-8)
    full = simulate(FullOrderModel(params), (t, _sine(t)), timepts=t)
    lines = simulate(FullLinesModel(params), (t, _sine(t)), timepts=t)
    assert abs(lines.stats.steps - full.stats.steps) <= 0.02 * full.stats.steps
    for ch, y in ref.channels.items():
        e_full = np.max(np.abs(full.channels[ch] - y))
        e_lines = np.max(np.abs(lines.channels[ch] - y))
        assert e_lines <= 3.0 * e_full + 1e-12 * np.max(np.abs(y)), (ch, e_lines, e_full)
    np.testing.assert_array_equal(lines.channels["p_line_a"], lines.channels["p_a"])
    np.testing.assert_array_equal(lines.channels["p_line_b"], lines.channels["p_b"])
    assert lines.units["p_line_a"] == "Pa"
    fine = simulate(FullOrderModel(params), (t, _sine(t)), timepts=t, rtol=1e-7)
    fine_lines = simulate(FullLinesModel(params), (t, _sine(t)), timepts=t, rtol=1e-7)
    for ch, y in fine.channels.items():
        atol = 1e-3 * np.max(np.abs(y))
        np.testing.assert_allclose(fine_lines.channels[ch], y, rtol=0, atol=atol, err_msg=ch)


def _reference_rhs(p, lines, omega0, u_of_t):
    """The full-lines model written again in NumPy: y = [ν, ν̇, P_A, P_B, x, ẋ, P_lA, P_lB].

    Constant supply, no leakage, pressures above the release pressure (E constant; the caller
    checks it), no end-stop contact (mid-stroke). Valve edges, dead zone and friction are the
    components' (tested on their own); the line and chamber equations are written here.
    """
    v, c, o, fr, s, fl = p.valve, p.cylinder, p.oil, p.friction, p.supply, p.flow
    d = p.dead_zone
    e_line = 1.0 / (1.0 / o.bulk_modulus + 1.0 / lines.bulk_modulus)

    def flow(dp, g):
        if not lines.orifice:
            return g * dp
        ptr = fl.transition_pressure
        if abs(dp) >= ptr:  # turbulent: G·P_tr/1.25 · √(|ΔP|/P_tr)
            return np.sign(dp) * g * ptr / 1.25 * np.sqrt(abs(dp) / ptr)
        r = dp / ptr  # laminar band: the odd cubic through the same value and slope at P_tr
        return g * ptr / 1.25 * (1.25 * r - 0.25 * r**3)

    def rhs(t, y):
        nu, dnu, pa, pb, x, xd, pla, plb = y
        z = dead_zone(nu, d.alpha, d.beta, d.creep_slope, d.outer_offset)
        qa, qb = orifice_flows(
            z, pla, plb, s.pressure, s.tank_pressure, fl.K, fl.transition_pressure
        )
        qla = flow(pla - pa, lines.conductance_a)  # line A → chamber A
        qlb = flow(pb - plb, lines.conductance_b)  # chamber B → line B
        force = pa * c.area_a - pb * c.area_b
        f_fr = stribeck_friction(
            xd, fr.coulomb, fr.static, fr.viscous, fr.stribeck_velocity, fr.shape, fr.smoothness
        )
        return [
            dnu,
            omega0**2 * (u_of_t(t) - nu) - 2 * v.zeta * omega0 * dnu,
            o.bulk_modulus / (c.dead_volume_a + c.area_a * x) * (qla - c.area_a * xd),
            o.bulk_modulus / (c.dead_volume_b + c.area_b * (c.stroke - x)) * (c.area_b * xd - qlb),
            xd,
            (force - f_fr - p.load.force - p.load.damping * xd) / p.load.mass,
            e_line / lines.volume_a * (qa - qla),
            e_line / lines.volume_b * (qlb - qb),
        ]

    return rhs


#: Orifices whose drop passes the transition pressure (1 bar) in the sine below.
ORIFICES = Lines(
    volume_a=3.14e-5,
    volume_b=7.85e-5,
    conductance_a=4e-10,
    conductance_b=4e-10,
    bulk_modulus=1.5e8,
    orifice=True,
)


@pytest.mark.parametrize("lines", [HOSES, ORIFICES], ids=["laminar", "orifice"])
def test_line_pressures_follow_a_numpy_reference(lines):
    params = PAPER.replace(lines=lines)
    model = FullLinesModel(params)
    t = np.linspace(0.0, 0.08, 161)
    res = simulate(model, (t, _sine(t)), timepts=t, rtol=1e-9, hmax=1e-4)
    y0 = model.initial_state()
    keep = [i for i, n in enumerate(model.state_names) if n not in ("p_s", "p_acc")]
    ref = solve_ivp(
        # the command as simulate takes samples: linear between them
        _reference_rhs(params, lines, params.valve.omega0, lambda x: np.interp(x, t, _sine(t))),
        (0.0, t[-1]),
        y0[keep],
        method="Radau",
        t_eval=t,
        rtol=1e-10,
        atol=1e-10 * model.state_scale()[keep],
    )
    assert ref.success
    ch = res.channels
    assert min(ch["p_a"].min(), ch["p_b"].min(), ch["p_line_a"].min(), ch["p_line_b"].min()) > 0.0
    drop = np.abs(ch["p_line_a"] - ch["p_a"]).max()
    assert drop > 5e3  # the lines matter here (measured: 0.09 bar across line A, laminar)
    for name, row in (("p_line_a", 6), ("p_line_b", 7), ("p_a", 2), ("p_b", 3), ("x", 4)):
        span = np.ptp(ref.y[row])
        # the package's rtol 1e-9 against the reference's 1e-10: 1e-5 of the swing covers both
        np.testing.assert_allclose(ch[name], ref.y[row], rtol=0, atol=1e-5 * span, err_msg=name)


def test_a_closed_valve_equalises_line_and_chamber_and_keeps_the_oil():
    """No valve flow (u = 0, ν = 0: z = 0): the line's oil goes to its chamber only.

    Steady state without flow: P_line = P_chamber. Conservation: the oil volume V_l/E_l·ΔP_l
    the line gives up equals the chamber's ∫ V_A(x)/E dP_A + A_A Δx (Eq. (9) integrated).
    """
    params = PAPER.replace(lines=HOSES)
    model = FullLinesModel(params)
    rest = model.initial_state()
    names = model.state_names
    pa, pb = rest[names.index("p_a")], rest[names.index("p_b")]
    y0 = model.state_from_measurement(
        {"x": 0.1, "p_a": pa, "p_b": pb, "p_line_a": pa + 10e5, "p_line_b": pb - 5e5}
    )
    t = np.linspace(0.0, 1.0, 2001)
    ch = simulate(model, 0.0, timepts=t, initial_state=y0, rtol=1e-9).channels
    for line, chamber, step in (("p_line_a", "p_a", 10e5), ("p_line_b", "p_b", 5e5)):
        # the line drop carries the flow of the rod's creep, which dies out (friction):
        # measured 1.4e-3 / 4.1e-3 Pa after 1 s, 10 / 31 Pa after 5 ms
        assert abs(ch[line][-1] - ch[chamber][-1]) < 1e-6 * step, line
        assert abs(ch[line][-1] - ch[chamber][-1]) < 1e-3 * abs(ch[line][10] - ch[chamber][10])
    t = np.linspace(0.0, 2e-3, 4001)  # the equalisation itself (line time constant ~15 µs)
    ch = simulate(model, 0.0, timepts=t, initial_state=y0, rtol=1e-9, hmax=2e-6).channels
    c, e = params.cylinder, params.oil.bulk_modulus
    e_line = 1.0 / (1.0 / e + 1.0 / HOSES.bulk_modulus)
    given = HOSES.volume_a / e_line * (ch["p_line_a"][0] - ch["p_line_a"][-1])
    vol_a = c.dead_volume_a + c.area_a * ch["x"]
    stored = np.trapezoid(vol_a / e, ch["p_a"]) + c.area_a * (ch["x"][-1] - ch["x"][0])
    # trapezoid over 4001 samples of a smooth equalisation: 1e-4 of the volume moved
    assert stored == pytest.approx(given, rel=1e-4)


_CAMPAIGN = """
[campaign]
name = "lines"
seed = 47

[deadzone]
inputs = { start = "5 %", stop = "10 %", step = "5 %" }
duration = "0.3 s"
"""


def test_a_rig_with_line_sensors_records_them_and_the_data_take_them(tmp_path):
    chrono = load_params(MACHINES / "chrono.toml")
    assert chrono.lines.present and isinstance(machine_model(chrono), FullLinesModel)
    assert isinstance(build_model("full-lines", chrono), FullLinesModel)
    camp = tmp_path / "campaign.toml"
    camp.write_text(_CAMPAIGN)
    run_campaign(Rig(params=chrono), load_campaign(camp), tmp_path / "out")
    ds = read_dataset(tmp_path / "out" / "deadzone")
    assert ds.names
    run = ds[ds.names[0]]
    for ch in ("p_line_a", "p_line_b"):
        assert ch in run.channels and run.units[ch] == "Pa"
        assert np.ptp(run.channels[ch]) > 0.0
    assert not [i for i in check_run(run) if i.channel in ("p_line_a", "p_line_b")]
    model = FullLinesModel(chrono)
    rd = prepare_run(run, model, ("x", "p_a", "p_line_a"), Shooting(segment=0.1), [])
    assert rd is not None and "p_line_a" in rd.y
    first = {c: float(run.channels[c][0]) for c in ("x", "p_a", "p_b", "p_line_a", "p_line_b")}
    y0 = model.state_from_measurement(first)
    assert y0[model.state_names.index("p_line_b")] == first["p_line_b"]
    # the evaluation starts full-lines from the measured line pressures; on data of a machine
    # with hoses it fits the chamber pressures better than the full model without them
    # (measured on a 2 Hz sine of this machine: 0.03 against 1.7 bar RMS)
    ev = evaluate_run(run, chrono, models=("full", "full-lines"))
    assert "p_line_a" in ev.simulations["full-lines"].channels
    rmse = ev.metrics.set_index(["model", "channel"])["rmse"]
    assert rmse["full-lines", "p_a"] < rmse["full", "p_a"]


@pytest.mark.parametrize("pump", [False, True], ids=["constant-supply", "pump"])
@pytest.mark.parametrize("lines", [HOSES, ORIFICES, Lines(volume_b=7.85e-5, conductance_b=6e-9)])
@pytest.mark.parametrize("spool", [0.3, -0.2])
def test_exact_jacobian_with_lines_matches_differences(lines, pump, spool):
    """``jac_lines`` against central differences of ``rhs_lines`` (the solver's ∂f/∂y).

    Steps of 1e-6 of each state's scale: truncation O(h²) and rounding O(ε/h) both below 1e-6 of
    the entries; the orifice points sit outside its laminar band's edge (no kink in a stencil).
    """
    from hydropwa.simulation._rhs_lines import jac_lines, rhs_lines

    params = PAPER.replace(lines=lines)
    if pump:
        params = params.replace(supply=machine_supply(params))
    model = FullLinesModel(params)
    p = model.pack()
    y = model.initial_state(0.08)
    names = model.state_names
    y[names.index("spool")] = spool
    y[names.index("v")] = 0.01
    y[names.index("p_line_a")] = y[names.index("p_a")] + 3e5
    y[names.index("p_line_b")] = y[names.index("p_b")] - 2e5
    n = y.size
    J = np.zeros((n, n))
    assert jac_lines(y, spool, 100e5, 0.0, p, J)
    scale = model.state_scale()
    num = np.zeros((n, n))
    for j in range(n):
        h = 1e-6 * max(abs(y[j]), scale[j])
        f1, f0 = np.zeros(n), np.zeros(n)
        yp, ym = y.copy(), y.copy()
        yp[j] += h
        ym[j] -= h
        rhs_lines(yp, spool, 100e5, 0.0, p, f1)
        rhs_lines(ym, spool, 100e5, 0.0, p, f0)
        num[:, j] = (f1 - f0) / (2 * h)
    # 1e-5 of each row's largest entry: the rows span 1e-3 (spool) to 1e12 (pressures) per unit
    tol = 1e-5 * np.max(np.abs(num), axis=1, keepdims=True) + 1e-12
    assert np.all(np.abs(J - num) <= tol), np.argwhere(np.abs(J - num) > tol)
