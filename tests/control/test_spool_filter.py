"""The measured spool position as the spool estimate's measurement (issue 34, item 1).

The valve-aware design's spool terms feed back ν̂, ν̂̇ of the discrete valve model (Eq. (1), ZOH
at T_s). With ``spool="measured"`` and a spool noise σ_ν > 0 the model's prediction is corrected
by the measured spool through a steady-state Kalman gain (``spool_filter_gain``); σ_ν = 0 (an
exact sensor) runs that filter's limit (1, Γ₂/Γ₁): the measured position itself and the model's
rate, corrected, which a target computes from what it measures. Checked here: the gain against
python-control and its exact-sensor limit, the law's update written out, the exact-sensor
reduction, the file round trip and JSON Schema, the generated C and the controller FMU in
lockstep on the full model's samples with a noisy spool, and the spool noise measured from a
simulated standstill.
"""

from __future__ import annotations

import ctypes
import dataclasses
import json
import warnings

import control
import jsonschema
import numpy as np
import pytest
from c_support import (
    GCC,
    Meas,
    Ref,
    State,
    compile_shared,
    package_load_pressure,
    reference_channels,
)
from hypothesis import given, settings
from hypothesis import strategies as st
from paper_cases import NOISE, TRAPEZOID, paper_trapezoid

from hydropwa._layout import Y_FULL
from hydropwa.control import (
    SPOOL_COMMAND_NOISE,
    ControlError,
    SpoolModel,
    as_reference,
    controller_schema,
    design_cell_estimator,
    design_controller,
    design_state_feedback,
    export_c,
    load_controller,
    save_controller,
    sensor_noise_from,
    spool_filter_gain,
    tracking_metrics,
)
from hydropwa.data import Run
from hydropwa.rig import SensorModel
from hydropwa.simulation import _controller as C
from hydropwa.simulation import simulate

SIGMA = 2e-3  # 0.2 % of the full opening


@pytest.fixture(scope="module")
def filtered(paper_pwa):
    """``control design --spool measured`` for 0.2 % spool noise (without the quiet band, whose
    position observer would loosen the C lockstep's bound)."""
    noise = NOISE | {"spool": SIGMA}
    d = design_controller(
        paper_pwa, verify=False, delay=True, quiet=False, spool="measured", sensor_noise=noise
    )
    return d.controller


def test_spool_gain_is_the_kalman_filter_of_python_control(paper):
    """L against ``control.dlqe`` (process noise Γ w on the opening, measured ν): python-control's
    predictor gain is Φ L of the same Riccati solution (1e-9); the filter's error dynamics
    (I − L H) Φ are stable, and the gain goes to [1, ·] for an exact sensor, to 0 for a useless one."""
    sm = SpoolModel.from_valve(paper.valve.omega0, paper.valve.zeta, 5e-4)
    phi = np.asarray(sm.phi).reshape(2, 2)
    gam = np.asarray(sm.gamma).reshape(2, 1)
    H = np.array([[1.0, 0.0]])
    for s_nu, s_c in ((SIGMA, 0.02), (1e-3, 0.005), (5e-3, 0.1)):
        L = np.array(spool_filter_gain(sm.phi, sm.gamma, s_nu, s_c)).reshape(2, 1)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            Lp, _P, _E = control.dlqe(phi, gam, H, np.array([[s_c**2]]), np.array([[s_nu**2]]))
        np.testing.assert_allclose(np.asarray(Lp), phi @ L, rtol=1e-9, atol=1e-12)
        assert np.max(np.abs(np.linalg.eigvals((np.eye(2) - L @ H) @ phi))) < 1.0
    assert spool_filter_gain(sm.phi, sm.gamma, 1e-9, 0.02)[0] > 1.0 - 1e-6
    # the exact-sensor limit in closed form: L -> (1, Γ₂/Γ₁) whatever σ_c (the Riccati solution
    # at σ_ν = 1e-9: 1e-8 relative), the second error pole at the model's zero, |z₀| < 1
    lim = sm.exact_gain
    for s_c in (0.005, 0.02, 0.1):
        got = spool_filter_gain(sm.phi, sm.gamma, 1e-9, s_c)
        np.testing.assert_allclose(got, lim, rtol=1e-8)
    L = np.array(lim).reshape(2, 1)
    z0 = np.linalg.eigvals((np.eye(2) - L @ H) @ phi)
    np.testing.assert_allclose(
        np.sort(np.abs(z0)), [0.0, abs(phi[1, 1] - phi[0, 1] * lim[1])], atol=1e-12
    )
    assert 0.5 < np.max(np.abs(z0)) < 1.0  # stable (paper valve: -0.863)
    assert spool_filter_gain(sm.phi, sm.gamma, 10.0, 0.02)[0] < 1e-4
    with pytest.raises(ControlError, match="positive spool noise"):
        spool_filter_gain(sm.phi, sm.gamma, 0.0, 0.02)


@settings(max_examples=40, deadline=None)
@given(
    nu=st.floats(-1.0, 1.0),
    noise=st.floats(-0.01, 0.01),
    prior=st.floats(-1.0, 1.0),
    dprior=st.floats(-50.0, 50.0),
    ln=st.floats(0.05, 1.0),
    ld=st.floats(0.0, 2000.0),
)
def test_the_law_corrects_the_prediction_by_the_measured_spool(nu, noise, prior, dprior, ln, ld):
    """The compiled law's spool_feedback written out (to 1e-14): ν_m = the inverse of the dead-zone
    inverse of the reported spool plus noise; ν̂ = ν̂⁻ + L_ν (ν_m − ν̂⁻), ν̂̇ = ν̂̇⁻ + L_ν̇ (ν_m − ν̂⁻),
    kept in the memory; the spool state's rate is never read (a target has only the position);
    estimated: the prediction; with the per-cell filter its ẑ₃, ẑ₄ whatever the mode (as the C)."""
    off, w = 0.05, 0.01
    n = C.C_ROWS + C.ROW
    ctl = np.zeros(n + C.N_EXT + C.XROW)
    ctl[C.C_DZINV], ctl[C.C_DZOFF], ctl[C.C_DZW], ctl[C.C_NROWS] = 1.0, off, w, 1.0
    e0 = n
    y = np.zeros(len(Y_FULL))
    y[Y_FULL["spool"]], y[Y_FULL["spool_rate"]] = nu, 3.0
    m = nu + noise
    nu_m = (m - off if m > 0 else m + off) if abs(m) >= w + off else m * (w / (w + off))
    ctl[e0 + C.X_SPOOL] = C.SPOOL_MEASURED
    ctl[e0 + C.X_SPLN], ctl[e0 + C.X_SPLD] = ln, ld
    cst = np.zeros(C.N_CST)
    cst[C.S_NU], cst[C.S_DNU] = prior, dprior
    got = C.spool_feedback(ctl, e0, cst, y[Y_FULL["spool"]] + noise, 1.0, False)
    want = (prior + ln * (nu_m - prior), dprior + ld * (nu_m - prior))
    assert got == pytest.approx(want, rel=1e-14, abs=1e-14)  # numba may fuse: a few ulps
    assert (cst[C.S_NU], cst[C.S_DNU]) == got
    # the law is given the measured position only (the state's rate never reaches it)
    cst[C.S_NU], cst[C.S_DNU] = prior, dprior
    assert C.spool_feedback(ctl, e0, cst, y[Y_FULL["spool"]] + noise, 1.0, False) == got
    ctl[e0 + C.X_SPOOL] = C.SPOOL_ESTIMATED
    cst = np.zeros(C.N_CST)
    cst[C.S_NU], cst[C.S_DNU] = prior, dprior
    assert C.spool_feedback(ctl, e0, cst, m, 1.0, False) == (prior, dprior)
    # the load-state models have no spool: the estimate, whatever the mode
    ctl[e0 + C.X_SPOOL] = C.SPOOL_MEASURED
    assert C.spool_feedback(ctl, e0, cst, m, 0.0, False) == (prior, dprior)
    cst[C.S_Z + 3], cst[C.S_Z + 4] = 0.25, -4.0  # the per-cell filter's spool states
    assert C.spool_feedback(ctl, e0, cst, m, 1.0, True) == (0.25, -4.0)
    assert (cst[C.S_NU], cst[C.S_DNU]) == (prior, dprior)


def test_an_exact_spool_sensor_reduces_to_the_raw_feedback(paper, paper_pwa, filtered):
    """σ_ν = 0: no filter gain in the model (nor the file), packed as the filter's exact-sensor
    limit (1, Γ₂/Γ₁) — the same law as a bare measured ``SpoolModel``; a filter for a nearly
    exact sensor (σ_ν = 1e-7) packs within 1e-6 of it and tracks the paper trapezoid (exact x,
    P_A, P_B) like it: peak error within 1 µm (the end of the move, in static friction, is not
    compared)."""
    raw = design_state_feedback(paper_pwa, delay=True, spool="measured").controller
    estimated = design_state_feedback(paper_pwa, delay=True).controller
    assert raw.spool_model.gain == (0.0, 0.0) and not raw.spool_model.filtered
    bare = dataclasses.replace(
        raw,
        spool_model=dataclasses.replace(
            SpoolModel.from_valve(paper.valve.omega0, paper.valve.zeta, 5e-4), measured=True
        ),
    )
    np.testing.assert_array_equal(raw.pack(), bare.pack())
    assert raw.spool_model.with_filter(0.0) == raw.spool_model
    e0 = C.C_ROWS + C.ROW * len(raw.rows)
    gam = raw.spool_model.gamma
    assert tuple(raw.pack()[e0 + C.X_SPLN : e0 + C.X_SPLD + 1]) == (1.0, gam[1] / gam[0])
    tiny = dataclasses.replace(raw, spool_model=raw.spool_model.with_filter(1e-7))
    np.testing.assert_allclose(tiny.spool_model.gain, raw.spool_model.exact_gain, rtol=1e-6)
    peak = {
        name: tracking_metrics(paper_trapezoid(paper, c, sensor_noise={}, seed=1)).display()[
            "max_following_error"
        ]
        for name, c in (("raw", raw), ("tiny", tiny), ("estimated", estimated))
    }
    assert peak["tiny"] == pytest.approx(peak["raw"], abs=1e-3)  # mm
    # and the measured spool is not the estimate's law (measured 0.0580 mm): the check resolves it
    assert abs(peak["estimated"] - peak["raw"]) > 3e-3
    # the filter for the 0.2 % sensor is a different law (L_ν ≈ 0.6), and the design says so
    assert 0.3 < filtered.spool_model.gain[0] < 0.9
    assert filtered.design["spool_noise"] == SIGMA


def test_the_filter_round_trips_through_the_file_and_its_schema(filtered, tmp_path):
    """The gain and its noise are written into ``spool_model`` (TOML and JSON), read back to the
    same packed law (1e-9, the file's digits; the gain exactly), and the written files validate against the shipped JSON Schema; a file
    without the gain reads as an exact sensor, the filter's limit (1, Γ₂/Γ₁)."""
    val = jsonschema.Draft202012Validator(controller_schema())
    for ext in ("toml", "json"):
        p = tmp_path / f"c.{ext}"
        save_controller(filtered, p)
        back = load_controller(p)
        a, b = filtered.pack(), back.pack()  # the file keeps 10 significant digits of a gain
        np.testing.assert_allclose(b[np.isfinite(a)], a[np.isfinite(a)], rtol=1e-9, atol=0)
        assert back.spool_model.gain == filtered.spool_model.gain  # written in full
        assert back.spool_model.noise == {"spool": SIGMA, "command": pytest.approx(0.02)}
    doc = json.loads((tmp_path / "c.json").read_text())
    val.validate(doc)
    assert doc["spool_model"]["gain"] == list(filtered.spool_model.gain)
    del doc["spool_model"]["gain"], doc["spool_model"]["noise"]
    (tmp_path / "old.json").write_text(json.dumps(doc))
    old = load_controller(tmp_path / "old.json")
    ctl = old.pack()
    e0 = C.C_ROWS + C.ROW * len(old.rows)
    assert ctl[e0 + C.X_SPOOL] == C.SPOOL_MEASURED and ctl[e0 + C.X_SPLN] == 1.0
    gam = old.spool_model.gamma
    assert ctl[e0 + C.X_SPLD] == gam[1] / gam[0]
    doc["spool_model"]["gain"] = [1.5, 0.0]  # L_ν beyond 1 is no filter
    val.validate(doc)
    (tmp_path / "bad.json").write_text(json.dumps(doc))
    with pytest.raises(ControlError, match="L_nu in"):
        load_controller(tmp_path / "bad.json")


@pytest.fixture(scope="module")
def exact_spool(paper_pwa):
    """``control design --spool measured`` for an exact spool sensor (σ_ν = 0: the filter's limit)."""
    d = design_controller(
        paper_pwa, verify=False, delay=True, quiet=False, spool="measured", sensor_noise=NOISE
    )
    assert d.controller.spool_model.measured and not d.controller.spool_model.filtered
    return d.controller


@pytest.fixture(scope="module")
def cell_filtered(paper_pwa):
    """The valve-aware design with the per-cell Kalman filter measuring the spool (y = [P_L, x, ν])."""
    d = design_state_feedback(paper_pwa, delay=True, spool="measured")
    est = design_cell_estimator(paper_pwa, d, NOISE | {"spool": SIGMA})
    sm = d.controller.spool_model.with_filter(SIGMA)
    return dataclasses.replace(d.controller, spool_model=sm, estimator=est)


def _lockstep_samples(paper, ctrl, tk):
    """The full model's closed-loop trapezoid sampled at t_k, with 20 µm / 0.1 bar / 0.2 % spool
    noise added to the samples (seeded), and the reference channels."""
    res = paper_trapezoid(paper, ctrl, timepts=tk, rtol=1e-6)  # (timepts sets the span)
    assert res.success
    r, rch = reference_channels(ctrl, as_reference(TRAPEZOID), tk)
    rng = np.random.default_rng(34)
    meas = {k: np.asarray(res[k], dtype=float) for k in ("x", "v", "p_a", "p_b", "spool")}
    for k, sd in (NOISE | {"spool": SIGMA}).items():
        meas[k] = meas[k] + rng.normal(0.0, sd, len(tk))
    return meas, r, rch


def _package_law(paper, ctrl, meas, r, rch):
    """The compiled law stepped on the samples: its commands and rows."""
    n, ts = len(r), ctrl.sample_time
    ctl = ctrl.pack()
    a_a, a_b = paper.cylinder.area_a, paper.cylinder.area_b
    cst, log = np.zeros(C.N_CST), np.zeros((C.N_LOG, n))
    sg, y = np.zeros(32), np.zeros(len(Y_FULL))
    y[Y_FULL["spool_rate"]] = np.nan  # the law reads no spool rate: a read would show
    for k in range(n):
        for key in ("x", "v", "p_a", "p_b", "spool"):
            y[Y_FULL[key]] = meas[key][k]
        C.controller_sample(0, k, k * ts, y, a_a, a_b, ctl, cst, r, rch, sg, log)
    return log[C.L_U], log[C.L_ROW].astype(int)


@pytest.fixture(scope="module")
def cell_exact(paper_pwa):
    """The per-cell Kalman filter for x, P_L only, on a design whose spool is measured by an exact
    sensor: the spool terms use the filter's ẑ₃, ẑ₄ (the spool is not read)."""
    d = design_state_feedback(paper_pwa, delay=True, spool="measured")
    return dataclasses.replace(d.controller, estimator=design_cell_estimator(paper_pwa, d, NOISE))


LOCKSTEP = ["spool filter", "exact spool sensor", "per-cell Kalman filter", "per-cell, exact spool"]


def _lockstep_controller(request, which):
    name = {
        "spool filter": "filtered",
        "exact spool sensor": "exact_spool",
        "per-cell Kalman filter": "cell_filtered",
        "per-cell, exact spool": "cell_exact",
    }[which]
    return request.getfixturevalue(name), (1.0 if which.startswith("per-cell") else 1e-2)


@pytest.mark.skipif(GCC is None, reason="gcc is not installed")
@pytest.mark.parametrize("which", LOCKSTEP)
def test_the_c_runs_the_measured_spool_in_lockstep(paper, request, which, tmp_path):
    """The full model's samples of a closed-loop trapezoid (x with 20 µm, P_A, P_B with 0.1 bar and
    the spool with 0.2 % noise) stepped through the package's law and the generated C
    (``m.spool``): the same command within 1e-12 relative at every sample (floor 1e-2 of the
    other lockstep cases; 1 with the per-cell filter, whose x̂ carries numba's fused multiply-adds,
    test_target_c.FLOOR_OBSERVER), the same rows. The exact-sensor mode too: the package reads
    only the measured position (the spool state's rate is NaN here), as the C does."""
    ctrl, floor = _lockstep_controller(request, which)
    ts = ctrl.sample_time
    n = int(0.9 / ts) + 1
    meas, r, rch = _lockstep_samples(paper, ctrl, ts * np.arange(n))
    u_p, rows_p = _package_law(paper, ctrl, meas, r, rch)
    a_a, a_b = paper.cylinder.area_a, paper.cylinder.area_b
    lib = compile_shared(export_c(ctrl, tmp_path / "c"), tmp_path / "libctrl.so")
    s, m, rf = State(), Meas(), Ref()
    lib.hydropwa_ctrl_init(ctypes.byref(s))
    u_c, rows_c = np.empty(n), np.empty(n, dtype=int)
    for k in range(n):
        m.x, m.v, m.spool = meas["x"][k], meas["v"][k], meas["spool"][k]
        m.p_l = lib.hydropwa_ctrl_load_pressure(meas["p_a"][k], meas["p_b"][k], a_a, a_b)
        rf.r, rf.r_rate, rf.r_rate_ff = r[k], rch[C.RC_DR, k], rch[C.RC_DRFF, k]
        rf.r_acc, rf.r_rate_pre = rch[C.RC_DDR, k], rch[C.RC_DRPO, k]
        u_c[k] = lib.hydropwa_ctrl_step(ctypes.byref(s), ctypes.byref(m), ctypes.byref(rf))
        rows_c[k] = s.row
    err = np.abs(u_c - u_p) / np.maximum(np.abs(u_p), floor)
    assert np.max(err) <= 1e-12, (which, float(np.max(err)))
    np.testing.assert_array_equal(rows_c, rows_p)
    assert len(set(rows_c.tolist())) > 3 and np.ptp(meas["spool"]) > 0.1  # the valve moves


@pytest.mark.skipif(GCC is None, reason="gcc is not installed")
@pytest.mark.parametrize(
    ("which", "version"),
    [("spool filter", "2.0"), ("exact spool sensor", "3.0"), ("per-cell Kalman filter", "2.0")],
)
def test_the_controller_fmu_reads_the_measured_spool(paper, request, which, version, tmp_path):
    """The controller FMU of a controller that measures the spool: the input ``spool`` appended as
    value reference 9 (x … r_rate_pre 0–7 and u 8 as before); built with the C compiler, no
    FMPy validation problem, and simulated in FMPy on the lockstep samples (noisy spool) it gives
    the compiled law's commands within 1e-12 (floors as the C lockstep; its output after
    doStep(t_k) is the command of t_k); with the spool input held at 0 the commands differ.
    FMI 2.0 and 3.0 (the same model code)."""
    fmpy = pytest.importorskip("fmpy")
    from fmpy.validation import validate_fmu

    from hydropwa.control import export_fmu

    ctrl, floor = _lockstep_controller(request, which)
    fmu = export_fmu(ctrl, tmp_path / "c.fmu", fmi_version=version)
    assert validate_fmu(str(fmu)) == []
    md = fmpy.read_model_description(str(fmu))
    vr = {v.name: (v.valueReference, v.causality) for v in md.modelVariables}
    if version == "3.0":  # FMI 3's independent variable takes the reference after the others
        assert vr.pop("time") == (10, "independent")
    names = ("x", "v", "p_l", "r", "r_rate", "r_rate_ff", "r_acc", "r_rate_pre")
    assert vr == {n: (i, "input") for i, n in enumerate(names)} | {
        "u": (8, "output"),
        "spool": (9, "input"),
    }
    ts = ctrl.sample_time
    n = int(0.9 / ts) + 1
    tk = ts * np.arange(n)
    meas, r, rch = _lockstep_samples(paper, ctrl, tk)
    u_p, _rows = _package_law(paper, ctrl, meas, r, rch)
    sig = np.zeros(n, dtype=[(k, np.float64) for k in ("time", *names, "spool")])
    sig["time"], sig["x"], sig["v"], sig["spool"] = tk, meas["x"], meas["v"], meas["spool"]
    a_a, a_b = paper.cylinder.area_a, paper.cylinder.area_b
    sig["p_l"] = package_load_pressure(ctrl.pack(), meas["p_a"], meas["p_b"], a_a, a_b)
    sig["r"], sig["r_rate"], sig["r_rate_ff"] = r, rch[C.RC_DR], rch[C.RC_DRFF]
    sig["r_acc"], sig["r_rate_pre"] = rch[C.RC_DDR], rch[C.RC_DRPO]
    run = {"start_time": 0.0, "stop_time": tk[-1], "step_size": ts, "output_interval": ts}
    out = fmpy.simulate_fmu(str(fmu), input=sig, output=["u"], **run)
    np.testing.assert_array_equal(out["time"], tk)
    want = u_p[:-1]
    err = np.abs(out["u"][1:] - want) / np.maximum(np.abs(want), floor)
    assert err.max() <= 1e-12, (which, float(err.max()))
    sig["spool"] = 0.0  # the input is read
    off = fmpy.simulate_fmu(str(fmu), input=sig, output=["u"], **run)
    assert np.max(np.abs(off["u"] - out["u"])) > 0.01


def test_the_cell_filter_measures_the_spool(paper, paper_pwa, cell_filtered, tmp_path):
    """y = [P_L, x, ν]: L (7 × 3) against ``control.dlqe`` with R = diag(σ_PL², σ_x², σ_ν²) and
    the command noise Γ w (python-control's predictor gain Φ L, 1e-7 as the 2-channel filter's
    test), the spool column not negligible (|L_νν| > 0.1); packed with the
    spool column after the filters' rows (e0+X_ESTNU = 1); written with ``measured`` naming the
    three columns, validated by the JSON Schema, read back to the same law (1e-9)."""
    from hydropwa.control._estimator import _EST_SCALE, N_EST, cell_estimator

    dyn = paper_pwa.state_space(cells=(3, 1, 0, 6))
    proc = {"acceleration": 0.3, "force_drift": 1.0, "pressure_drift": 2e3, "pressure": 1e5}
    ts, spl, sx = 5e-4, 1.2e4, 20e-6
    phi, gam, _aff, L, _init = cell_estimator(
        dyn.A.copy(), dyn.B.copy(), dyn.f.copy(), sample_time=ts, omega0=paper.valve.omega0,
        zeta=paper.valve.zeta, sigma_pl=spl, sigma_x=sx, process=proc, sigma_nu=SIGMA,
    )  # fmt: skip
    assert L.shape == (N_EST, 3)
    T, Ti = np.diag(_EST_SCALE), np.diag(1.0 / _EST_SCALE)
    H = np.zeros((3, N_EST))
    H[0, 0], H[1, 2], H[2, 3] = 1.0, 1.0, 1.0
    W = np.zeros((N_EST, 5))
    W[1, 0], W[5, 1], W[6, 2], W[0, 3] = ts * 0.3, 1.0, 2e3, 1e5
    W[:, 4] = gam * SPOOL_COMMAND_NOISE  # white noise on the opening the valve holds
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        Lp, _P, _E = control.dlqe(
            Ti @ phi @ T, Ti @ W, H @ T, np.eye(5), np.diag([spl**2, sx**2, SIGMA**2])
        )
    np.testing.assert_allclose(T @ np.asarray(Lp), phi @ L, rtol=1e-7, atol=1e-12)
    assert abs(L[3, 2]) > 0.1  # the measured spool corrects ν̂
    est = cell_filtered.estimator
    assert est.measured == ("p_l", "x", "spool") and est.noise["spool"] == SIGMA
    ctl = cell_filtered.pack()
    n = len(cell_filtered.rows)
    e0 = C.C_ROWS + C.ROW * n
    sb = e0 + C.N_EXT + (C.XROW + C.EROW) * n
    assert ctl[e0 + C.X_ESTNU] == 1.0 and ctl.shape[0] == sb + C.NZ * n
    g = np.asarray(est.gain).reshape(n, N_EST, 3)
    np.testing.assert_array_equal(ctl[sb:].reshape(n, N_EST), g[:, :, 2])
    p = tmp_path / "k.json"
    save_controller(cell_filtered, p)
    doc = json.loads(p.read_text())
    jsonschema.Draft202012Validator(controller_schema()).validate(doc)
    assert doc["estimator"]["measured"] == ["p_l", "x", "spool"]
    b = load_controller(p).pack()
    np.testing.assert_allclose(b[np.isfinite(ctl)], ctl[np.isfinite(ctl)], rtol=1e-9, atol=0)


def test_spool_noise_is_measured_at_a_simulated_standstill(paper):
    """A closed-valve second of the full model recorded through the rig's sensors (the valve's
    spool output: 0.1 % noise, 16 bits over ±1): ``sensor_noise_from`` gives the spool channel's
    noise with the quantisation, hypot(σ, q/√12), within 6 % (the bound of the other channels:
    20 windows of 200 samples); the CLI vocabulary reads ``spool=0.2 %``."""
    from hydropwa.cli._control import _sensor_noise

    fs = 2000.0
    t = np.arange(int(1.0 * fs)) / fs
    res = simulate("full", params=paper, timepts=t, u=0.0, initial_position=0.1)
    sens = {
        "x": SensorModel("position", "x", "m", (0.0, 0.2), noise_std=20e-6),
        "spool": SensorModel("spool", "spool", "1", (-1.0, 1.0), noise_std=1e-3),
    }
    rng = np.random.default_rng(3)
    run = Run(
        "hold", {"t": t} | {c: s.apply(np.asarray(res[c]), rng) for c, s in sens.items()}, fs=fs
    )
    got = sensor_noise_from(run)
    for c, s in sens.items():
        assert got[c] == pytest.approx(
            np.hypot(s.noise_std, s.quantization_step / np.sqrt(12)), rel=0.06
        )
    assert _sensor_noise("x=20 um,spool=0.2 %") == {
        "x": pytest.approx(20e-6),
        "spool": pytest.approx(2e-3),
    }


def test_cli_design_spool_measured_writes_the_filter(paper, tmp_path, capsys):
    """``control design --spool measured`` writes the filter for the spool noise given (and 0.1 %,
    the rig valve's, with the default noise); the default stays the estimate; a wrong value or
    the measured spool without the valve-aware LQR is one line, exit 2, nothing written."""
    from hydropwa.cli import main

    base = ["control", "design", "-p", "paper", "--no-verify", "--no-quiet-band", "--out"]
    noise = "x=20 um,p_a=0.1 bar,p_b=0.1 bar,spool=0.2 %"
    meas, dflt, est = tmp_path / "m.toml", tmp_path / "d.toml", tmp_path / "e.toml"
    assert main([*base, str(meas), "--spool", "measured", "--sensor-noise", noise]) == 0
    assert main([*base, str(dflt), "--spool", "measured"]) == 0
    assert main([*base, str(est)]) == 0
    sm = SpoolModel.from_valve(paper.valve.omega0, paper.valve.zeta, 5e-4)
    got = load_controller(meas).spool_model
    assert got.measured and got.gain == pytest.approx(spool_filter_gain(sm.phi, sm.gamma, 2e-3))
    assert load_controller(dflt).spool_model.gain == pytest.approx(
        spool_filter_gain(sm.phi, sm.gamma, 1e-3)
    )
    e = load_controller(est).spool_model
    assert not e.measured and e.gain == (0.0, 0.0)
    capsys.readouterr()
    bad = tmp_path / "bad.toml"
    for args in (["--spool", "sometimes"], ["--spool", "measured", "--method", "pi"]):
        assert main([*base, str(bad), *args]) == 2
        err = capsys.readouterr().err
        assert err.startswith("error: --spool") and err.count("\n") == 1
        assert not bad.exists()
