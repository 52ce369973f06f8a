"""The quiet band of the command (schema 2, ``DeadZoneInverse.quiet_band``): the default answer of
``control design`` to sensor noise (issue 34)."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from paper_cases import NOISE, TRAPEZOID, paper_trapezoid

from hydropwa.control import (
    QUIET_FACTOR,
    as_reference,
    command_noise,
    design_controller,
    design_state_feedback,
    load_controller,
    quiet_band_for,
    save_controller,
    tracking_metrics,
)
from hydropwa.linearization import linearize
from hydropwa.params import load_params
from hydropwa.simulation import _controller as C


@pytest.fixture(scope="module")
def industrial():
    return load_params(Path(__file__).resolve().parents[1] / "machines" / "industrial.toml")


@settings(max_examples=200, deadline=None)
@given(
    c=st.floats(-1.0, 1.0),
    d=st.floats(-0.05, 0.05),
    q=st.floats(1e-4, 0.05),
    ex=st.floats(-0.5, 0.5),
)
def test_quiet_band_is_the_stated_continuous_odd_map(c, d, q, ex):
    """Opening 0 inside ±q, c beyond ±2q, the line 2(|c| − q) between; odd, Lipschitz 2 (no
    jump of the flow), and the integral held only inside the band with |k_x e| < 8q."""
    o, held = C.quiet_band(c, q, ex)
    if abs(c) <= q:
        assert o == 0.0
        assert held == (abs(ex) < C.QUIET_HOLD * q)
    else:
        assert not held
        assert math.copysign(1.0, o) == math.copysign(1.0, c)
        assert o == (c if abs(c) >= 2 * q else pytest.approx(2 * (c - math.copysign(q, c))))
    assert C.quiet_band(-c, q, ex)[0] == -o
    assert abs(C.quiet_band(c + d, q, ex)[0] - o) <= 2.0 * abs(d) + 1e-15


def test_command_noise_is_the_observers_output_noise_through_the_gains(paper_pwa):
    """The closed form (discrete Lyapunov equation of the observer's error) against a Monte
    Carlo run of the observer equations of docs/controller_target.md on white position and
    pressure noise, x at rest: 400 000 samples, so the sample std is within 0.5 % (1/√(2N)
    is 0.11 %, and the samples are correlated over about 1/L_x ≈ 7 samples); bound 2 %."""
    ctrl = design_state_feedback(paper_pwa, delay=True, position_noise=NOISE["x"]).controller
    alpha = paper_pwa.params.cylinder.area_b / paper_pwa.params.cylinder.area_a
    sig = command_noise(ctrl, NOISE, alpha)
    rng = np.random.default_rng(3)
    n, ts = 400_000, ctrl.sample_time
    lx, lv = ctrl.position_observer
    xm = rng.normal(0.0, NOISE["x"], n)
    pl = rng.normal(0.0, NOISE["p_a"], n) - alpha * rng.normal(0.0, NOISE["p_b"], n)
    xh, vh = np.empty(n), np.empty(n)
    xk, vk = xm[0], 0.0
    for k in range(n):  # x̂⁻ = x̂ + T v̂, v̂⁻ = v̂ (r̈ = 0); update with the innovation
        xp = xk + ts * vk
        inn = xm[k] - xp
        xk, vk = xp + lx * inn, vk + lv * inn
        xh[k], vh[k] = xk, vk
    for i in (0, len(ctrl.rows) // 2, len(ctrl.rows) - 1):
        r = ctrl.rows[i]
        c = r.k_x * xh[1000:] + r.k_v * vh[1000:] + r.k_pl * pl[1000:]
        assert float(np.std(c)) == pytest.approx(sig[i], rel=0.02), r.label
    # without the observer: the raw position through k_x
    plain = design_state_feedback(paper_pwa, delay=True).controller
    r = plain.rows[0]
    assert command_noise(plain, NOISE, alpha)[0] == pytest.approx(
        math.hypot(r.k_x * NOISE["x"], r.k_pl * math.hypot(NOISE["p_a"], alpha * NOISE["p_b"]))
    )


def test_default_design_sizes_the_band_from_the_noise_and_writes_it(paper_pwa, tmp_path):
    """``design_controller`` adds the observer and q = 2.0 σ_c (0.0083 on the paper rig); exact
    sensors or ``quiet=False`` add neither; the file keeps q and the law packs it."""
    d = design_controller(paper_pwa, verify=False, delay=True)
    q = d.controller.dead_zone_inverse.quiet_band
    alpha = paper_pwa.params.cylinder.area_b / paper_pwa.params.cylinder.area_a
    assert q == pytest.approx(quiet_band_for(d.controller, NOISE, alpha))
    assert q == pytest.approx(QUIET_FACTOR * 0.00416, rel=0.05)
    assert d.controller.position_observer is not None and d.info["quiet_band"] == q
    for kw in ({"quiet": False}, {"sensor_noise": {}}):
        other = design_controller(paper_pwa, verify=False, delay=True, **kw).controller
        assert other.dead_zone_inverse.quiet_band == 0.0 and other.position_observer is None
    p = tmp_path / "c.toml"
    save_controller(d.controller, p)
    back = load_controller(p)
    assert back.dead_zone_inverse.quiet_band == q
    ctl = back.pack()
    e0 = C.C_ROWS + C.ROW * len(back.rows)
    assert ctl[e0 + C.X_DZQ] == q
    # the gains go through "<value> <unit>" strings of 10 digits
    np.testing.assert_allclose(ctl, d.controller.pack(), rtol=1e-9, atol=0)


def _noisy_trapezoid(paper, ctrl):
    """:func:`paper_trapezoid` with the sensor noise, seed 1 (0.9 s)."""
    return paper_trapezoid(paper, ctrl, sensor_noise=NOISE, seed=1)


def test_default_design_is_quiet_at_the_paper_rigs_hold_under_noise(paper, paper_pwa):
    """Issue 34's paper-rig numbers, full model, 20 µm / 0.1 bar, one sample of delay, hold over
    the last 0.2 s of 0.9 s after the 50 → 150 mm trapezoid (seed 1; benchmarks/control.py):
    measured 35 sign changes/s (960 without the band), hold 0.027 mm (0.062), peak error
    0.060 mm (0.064) with the band at rest (everywhere: 35/s, 0.026, 0.060 mm); with the
    pre-opening (the default now) 10/s, 0.011 mm, 0.044 mm. Bounds: the issue's 100/s; 0.035 mm
    for the hold (the issue's 0.03 is met on this seed, not on all: 0.011-0.035 mm over seeds
    1-10, see docs/control.md); 0.062 mm for the error (exact sensors: 0.058 without the band,
    0.068 mm with it everywhere, 0.059 at rest, 0.042 with the pre-opening)."""
    out = {}
    for name, quiet in (("plain", False), ("quiet", True)):
        ctrl = design_controller(paper_pwa, verify=False, delay=True, quiet=quiet).controller
        res = _noisy_trapezoid(paper, ctrl)
        hold = tracking_metrics(res, t0=0.7).display()
        pp = float(np.ptp(res["x"][res.t >= 0.7])) * 1e3
        out[name] = (hold["chattering"], pp, tracking_metrics(res).display()["max_following_error"])
    assert out["plain"][0] > 500.0, out  # the noise problem is there without the band
    assert out["quiet"][0] <= 100.0, out
    assert out["quiet"][1] <= 0.035, out
    assert out["quiet"][2] <= 0.062, out


def test_inside_the_band_the_valve_gets_the_middle_of_its_dead_zone(paper, paper_pwa):
    """In closed loop (full model, noise, one sample of delay) every command c inside ±q at
    rest (after the trapezoid's end at 0.64 s and its 3 ms look-ahead; the default's
    ``quiet_at_rest``) is applied one sample later as u = 0, while the reference moves the
    band does not act (u ≠ 0 for c ≠ 0), and q = 0 in the file gives back the plain law. (The
    default's pressure vent, off here, opens the valve inside the band where the low-passed
    pressure share is beyond 0.8 q: tests/control/test_pressure_vent.py.)"""
    d = design_controller(paper_pwa, verify=False, delay=True)
    q = d.controller.dead_zone_inverse.quiet_band
    band = dataclasses.replace(
        d.controller,
        dead_zone_inverse=dataclasses.replace(d.controller.dead_zone_inverse, pressure_vent=0.0),
    )
    off = dataclasses.replace(
        d.controller,
        dead_zone_inverse=dataclasses.replace(band.dead_zone_inverse, quiet_band=0.0),
    )
    runs = {}
    for name, ctrl in (("off", off), ("on", band)):
        runs[name] = _noisy_trapezoid(paper, ctrl).control
    on = runs["on"]
    assert d.controller.dead_zone_inverse.quiet_at_rest == 1.0
    c, t = on["command"][:-1], on["t"][:-1]
    inside = np.flatnonzero((np.abs(c) <= q) & (t > 0.641))
    assert inside.size > 100  # the hold after the move
    assert np.all(on["u"][inside + 1] == 0.0)
    moving = np.flatnonzero((np.abs(c) > 0.0) & (t > 0.1) & (t < 0.6))
    assert moving.size > 900 and np.all(on["u"][moving + 1] != 0.0)
    off_in = np.flatnonzero(np.abs(runs["off"]["command"][:-1]) <= q)
    assert np.count_nonzero(runs["off"]["u"][off_in + 1]) > 0.9 * off_in.size
    e0 = C.C_ROWS + C.ROW * len(off.rows)
    assert off.pack()[e0 + C.X_DZQ] == 0.0


def test_the_observer_is_made_faster_where_it_limit_cycles_the_corner_plant(industrial):
    """Heavy axis: the 1 m/s² observer limit-cycles on the draws' softest, heaviest corner (11-17 mm
    measured), so the default design takes 10 m/s²; that one holds the corner's steps at 8 % of
    the maximum force within 0.1 mm (0.001 mm measured) with exact sensors."""
    from hydropwa.control import task_set, verify_controller
    from hydropwa.control._verify import corner_parameters

    d = design_controller(linearize(industrial), verify=False, delay=True)
    assert d.info["observer_acceleration_noise"] == 10.0
    assert d.controller.design["observer_acceleration_noise"] == 10.0
    tasks = [t for t in task_set(industrial, load_fraction=0.08) if t.name.startswith("steps")]
    v = verify_controller(
        d.controller, corner_parameters(industrial), draws=1, tasks=tasks, sensor_noise={}
    )
    assert v.metrics["limit_cycles"] == 0 and v.metrics["hold_peak_to_peak_mm"] <= 0.1, v.metrics


def test_cli_quiet_band_is_on_by_default_and_can_be_turned_off(tmp_path, capsys):
    """`control design` writes the quiet band and the observer; --no-quiet-band neither; asking
    for it where it cannot act is one line, exit 2, nothing written."""
    from hydropwa.cli import main

    on, off, pi = tmp_path / "on.toml", tmp_path / "off.toml", tmp_path / "pi.toml"
    base = ["control", "design", "-p", "paper", "--no-verify", "--out"]
    assert main([*base, str(on)]) == 0
    assert main([*base, str(off), "--no-quiet-band"]) == 0
    a, b = load_controller(on), load_controller(off)
    assert a.dead_zone_inverse.quiet_band == pytest.approx(2.0 * 0.00416, rel=0.05)
    assert a.position_observer is not None
    assert b.dead_zone_inverse.quiet_band == 0.0 and b.position_observer is None
    # the pre-opening comes with the band: 2 x the 3 ms look-ahead on the paper rig
    assert a.dead_zone_inverse.pre_open == pytest.approx(2.0 * a.feedforward.lead)
    assert b.dead_zone_inverse.pre_open == 0.0
    capsys.readouterr()
    assert main([*base, str(pi), "--method", "pi", "--quiet-band"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --quiet-band needs") and err.count("\n") == 1
    assert not pi.exists()


def test_quiet_at_rest_round_trips_and_packs(paper_pwa, tmp_path):
    """``quiet_at_rest`` (schema 2): the default writes ``quiet_at_rest = 1`` and reads it back,
    packs 1 at X_DZQR; a file without it reads 0 (the band everywhere, as before); any value but
    0 or 1 is refused with one line."""
    ctrl = design_controller(paper_pwa, verify=False, delay=True).controller
    p = tmp_path / "c.toml"
    save_controller(ctrl, p)
    text = p.read_text()
    assert "quiet_at_rest = 1" in text
    assert load_controller(p).dead_zone_inverse.quiet_at_rest == 1.0
    e0 = C.C_ROWS + C.ROW * len(ctrl.rows)
    assert ctrl.pack()[e0 + C.X_DZQR] == 1.0
    old = tmp_path / "old.toml"
    old.write_text("\n".join(ln for ln in text.splitlines() if "quiet_at_rest" not in ln) + "\n")
    back = load_controller(old)
    assert back.dead_zone_inverse.quiet_at_rest == 0.0
    assert back.pack()[e0 + C.X_DZQR] == 0.0
    with pytest.raises(Exception, match="quiet_at_rest = 0.5 must be 0 or 1"):
        dataclasses.replace(ctrl.dead_zone_inverse, quiet_at_rest=0.5)


def test_the_band_at_rest_frees_the_trapezoids_start_from_static_friction(paper, paper_pwa):
    """The paper trapezoid's peak error is at the start corner (5.5 ms in: the rod sticks in static
    friction, F_s = 175 N, while the reference accelerates). With exact sensors, full model, one
    sample of delay, measured: band everywhere 0.068 mm at t = 0.1055 s, band only at rest (the
    default without the pre-opening) 0.059 mm at the same corner (docs/control.md). Bounds: the
    issue's 0.06 mm, and at least 0.005 mm better than the band everywhere (the measured gap is
    0.009)."""
    ctrl = _without_pre_open(design_controller(paper_pwa, verify=False, delay=True).controller)
    always = dataclasses.replace(
        ctrl, dead_zone_inverse=dataclasses.replace(ctrl.dead_zone_inverse, quiet_at_rest=0.0)
    )
    peak = {}
    for name, c in (("rest", ctrl), ("always", always)):
        res = paper_trapezoid(paper, c, 0.3)
        e = np.abs(res["reference"] - res["x"])
        i = int(np.argmax(e))
        peak[name] = (float(e[i]) * 1e3, float(res.t[i]))
    assert 0.1 < peak["always"][1] < 0.11 and 0.1 < peak["rest"][1] < 0.11, peak
    assert peak["rest"][0] <= 0.060, peak
    assert peak["always"][0] - peak["rest"][0] >= 0.005, peak


def _without_pre_open(ctrl):
    return dataclasses.replace(
        ctrl, dead_zone_inverse=dataclasses.replace(ctrl.dead_zone_inverse, pre_open=0.0)
    )


@settings(max_examples=200, deadline=None)
@given(
    c=st.floats(-1.0, 1.0),
    w=st.floats(0.0, 0.05),
    now=st.sampled_from([0.0, 0.1, -0.1]),
    ahead=st.sampled_from([0.0, 0.2, -0.2]),
)
def test_pre_open_asks_at_least_the_blend_width_toward_the_coming_move(c, w, now, ahead):
    """The opening is max(c, z_w) before an extension, min(c, −z_w) before a retraction, and c
    wherever the reference moves now or stays at rest τ_o ahead; odd in (c, ṙ_o)."""
    o = C.pre_open(c, w, now, ahead)
    if now != 0.0 or ahead == 0.0:
        assert o == c
    elif ahead > 0.0:
        assert o == max(c, w)
    else:
        assert o == min(c, -w)
    assert C.pre_open(-c, w, -now, -ahead) == -o


def test_pre_open_round_trips_and_packs(paper_pwa, tmp_path):
    """``pre_open`` (schema 2): ``control design``'s default is 2 × the feed-forward's look-ahead
    (6 ms on the paper rig), written in ms and read back to the bit of the file; it packs at
    X_DZPO and the loop samples ṙ(t_k + τ_o) into RC_DRPO; a file without it reads 0 (today's law,
    the channel stays 0); a negative value is one line."""
    from hydropwa.control import PRE_OPEN_FACTOR
    from hydropwa.simulation._simulate import _closed_loop_setup

    ctrl = design_controller(paper_pwa, verify=False, delay=True).controller
    dz = ctrl.dead_zone_inverse
    assert dz.pre_open == pytest.approx(PRE_OPEN_FACTOR * ctrl.feedforward.lead, rel=1e-12)
    assert 5e-3 < dz.pre_open < 7e-3
    p = tmp_path / "c.toml"
    save_controller(ctrl, p)
    text = p.read_text()
    assert "pre_open = " in text
    back = load_controller(p)
    assert back.dead_zone_inverse.pre_open == pytest.approx(dz.pre_open, rel=1e-9)
    e0 = C.C_ROWS + C.ROW * len(ctrl.rows)
    assert back.pack()[e0 + C.X_DZPO] == pytest.approx(dz.pre_open, rel=1e-9)
    tk = 5e-4 * np.arange(400)
    _ctl, sig, _r, rch = _closed_loop_setup(ctrl, as_reference(TRAPEZOID), tk)
    np.testing.assert_array_equal(rch[C.RC_DRPO], sig.rate(tk + dz.pre_open))
    # ṙ_o leads ṙ: nonzero from 0.1 s − τ_o on, ṙ itself from 0.1 s on
    first = tk[np.flatnonzero(rch[C.RC_DRPO])[0]]
    assert 0.1 - dz.pre_open - 1e-9 < first <= 0.1 - dz.pre_open + 5e-4
    old = tmp_path / "old.toml"
    old.write_text("\n".join(ln for ln in text.splitlines() if "pre_open" not in ln) + "\n")
    prev = load_controller(old)
    assert prev.dead_zone_inverse.pre_open == 0.0 and prev.pack()[e0 + C.X_DZPO] == 0.0
    assert not np.any(_closed_loop_setup(prev, as_reference(TRAPEZOID), tk)[3][C.RC_DRPO])
    with pytest.raises(Exception, match=r"pre_open = -0.001 s must be >= 0"):
        dataclasses.replace(dz, pre_open=-1e-3)


def test_pre_open_spends_the_dead_zone_crossing_before_the_trapezoid_starts(paper, paper_pwa):
    """Paper rig trapezoid, full model, exact sensors, one sample of delay: without the
    pre-opening the spool crosses the dead zone ~4 ms without flow after the reference starts and
    the peak error, 0.059 mm, is at the start corner (t = 0.105 s); with it (the default, 6 ms)
    measured 0.042 mm at t = 0.111 s, the start corner's worst 0.042 mm (docs/control.md). Bounds:
    0.05 mm with it (the issue's target is 0.06), and at least 0.01 mm better than without (the
    measured gap is 0.017); before 0.1 s the valve is already at the dead zone's edge
    (u = z_w + β_o, the pre-opening) and the rod has not moved 1 µm ahead of the reference."""
    ctrl = design_controller(paper_pwa, verify=False, delay=True).controller
    peak, runs = {}, {}
    for name, c in (("pre", ctrl), ("none", _without_pre_open(ctrl))):
        res = paper_trapezoid(paper, c, 0.2)
        e = np.abs(res["reference"] - res["x"])
        corner = (res.t >= 0.1) & (res.t <= 0.14)  # the acceleration phase (40 ms)
        peak[name] = float(np.max(e[corner])) * 1e3
        runs[name] = res
    assert peak["pre"] <= 0.05, peak
    assert peak["none"] - peak["pre"] >= 0.01, peak
    dz = ctrl.dead_zone_inverse
    ctl = runs["pre"].control
    before = (ctl["t"] > 0.1 - dz.pre_open + 2 * ctrl.sample_time) & (ctl["t"] < 0.1)
    assert np.all(ctl["u"][before] >= dz.width + dz.offset - 1e-12)
    res = runs["pre"]
    still = res.t < 0.1
    assert np.max(np.abs(res["x"][still] - 0.05)) < 1e-6
