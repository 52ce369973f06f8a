"""Force control (issue 52): the law's force output, its C in lockstep, the fatigue rig vs the PI.

The force law is the position law with the reference and the error in the cylinder force
(``output_stage``) and the flow feed-forward of the force rate through a compliance
(``feedforward_rate``); its C comes from the same numba source (``emit_unit``).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from c_support import GCC, compile_shared, reference_channels, replay_c, replay_package

from hydropwa.control import PIController, export_c
from hydropwa.control._design_force import design_force, design_force_pi, hydraulic_stiffness
from hydropwa.params import get_preset
from hydropwa.simulation import _controller as C
from hydropwa.simulation import simulate
from hydropwa.simulation._signals import Sine

#: the lockstep bar (the issue's), relative to max(|u|, 5e-2) as in test_target_c.py (numba's
#: fused multiply-adds against the C's rounded products: ulps of terms of order 0.1-1)
RTOL, FLOOR = 1e-12, 5e-2
#: the fatigue rig's specimen [N/m] at a contact 0.1 m out, mean force and amplitude [N]
K_SPEC, X_C, F_MEAN, F_AMP = 1e7, 0.1, 5000.0, 2000.0
NOISE = {"x": 20e-6, "p_a": 0.1e5, "p_b": 0.1e5}


@pytest.fixture(scope="module")
def rig():
    return get_preset("paper").replace(
        **{"load.specimen_stiffness": K_SPEC, "load.contact_position": X_C}
    )


@pytest.fixture(scope="module")
def designs(rig):
    return design_force(rig), design_force_pi(rig)


def test_the_force_output_is_the_cylinder_force_and_a_position_law_is_unchanged():
    """output_stage: F = A_A·P_L (asymmetric P_L = P_A − α P_B, so F = A_A P_A − A_B P_B),
    Ā·P_L in the mean-area form, P_L itself for a pressure output; x for a position law
    (whose description and file carry no output key)."""
    a_a, a_b = 1.3e-3, 0.76e-3
    p_a, p_b = 70e5, 30e5
    pl = C.load_pressure(p_a, p_b, a_a, a_b, 0.0)
    for output, expect in (("force", a_a * p_a - a_b * p_b), ("pressure", pl)):
        ctl = PIController(kp=1e-4, output=output).pack()
        got = C.output_stage(ctl, ctl.shape[0], 0.123, pl, (a_a, a_b))
        assert got == pytest.approx(expect, rel=1e-14)
    pos = PIController(kp=100.0)
    assert C.output_stage(pos.pack(), pos.pack().shape[0], 0.123, pl, (a_a, a_b)) == 0.123
    assert "output" not in pos.describe()


def test_the_feedforward_compliance_is_the_specimen_and_the_oil_columns(rig, designs):
    """1/k_s + 1/k_h with k_h = β(A_A²/V_A + A_B²/V_B) for the law, 1/k_s for the baseline."""
    law, pi = (d.controller for d in designs)
    c = rig.cylinder
    k_h = hydraulic_stiffness(rig, X_C + 6500.0 / K_SPEC)
    va, vb = c.dead_volume_a + c.area_a * 0.10065, c.dead_volume_b + c.area_b * (c.stroke - 0.10065)
    assert k_h == pytest.approx(1e9 * (c.area_a**2 / va + c.area_b**2 / vb), rel=1e-3)
    assert pi.feedforward_compliance == pytest.approx(1.0 / K_SPEC, rel=1e-12)
    assert law.feedforward_compliance == pytest.approx(1.0 / K_SPEC + 1.0 / k_h, rel=1e-3)
    assert law.feedforward.lead > 0.0 and pi.feedforward.lead == 0.0


@pytest.mark.skipif(GCC is None, reason="gcc is not installed")
def test_force_law_c_matches_the_compiled_law_in_lockstep(rig, designs, tmp_path):
    """The generated C and the numba law on one noisy force sequence, law and baseline: command
    and c within 1e-12 (relative, floor 5e-2), the same gain row at every sample."""
    rng = np.random.default_rng(52)
    ts = 5e-4
    tk = ts * np.arange(2000)
    ref = Sine(amplitude=F_AMP, frequency=5.0, offset=F_MEAN)
    a_a, a_b = rig.cylinder.area_a, rig.cylinder.area_b
    force = F_MEAN + 0.9 * F_AMP * np.sin(2 * np.pi * 5.0 * (tk - 0.004))
    pl = force / a_a + rng.normal(0.0, 0.15e5, tk.size)
    x = X_C + force / K_SPEC + rng.normal(0.0, 20e-6, tk.size)
    v = np.gradient(force / K_SPEC, ts) + rng.normal(0.0, 5e-3, tk.size)
    switched = 0
    for name, design in zip(("law", "pi"), designs, strict=True):
        ctrl = design.controller
        out = tmp_path / name
        export_c(ctrl, out)
        lib = compile_shared(out, out / "libctrl.so")
        r, rch = reference_channels(ctrl, ref, tk)
        pkg = replay_package(ctrl.pack(), x, v, pl, r, rch, a_a, a_b)
        c = replay_c(lib, x, v, pl, r, rch)
        for key in ("u", "c"):
            err = np.abs(c[key] - pkg[key]) / np.maximum(np.abs(pkg[key]), FLOOR)
            assert np.max(err) <= RTOL, (name, key, float(np.max(err)))
        np.testing.assert_array_equal(c["row"], pkg["row"], err_msg=name)
        assert np.count_nonzero(rch[C.RC_DRFF]) > 1000  # the feed-forward acts
        switched += int(np.count_nonzero(np.diff(pkg["row"])))
    assert switched > 10  # the law's rows switch (force cells, flow direction)


def _rms_error(rig, ctrl, hz: float) -> float:
    ref = Sine(amplitude=F_AMP, frequency=hz, offset=F_MEAN)
    res = simulate(
        "full",
        params=rig,
        controller=ctrl,
        reference=ref,
        duration=0.6,
        initial_position=X_C + F_MEAN / K_SPEC,
        sensor_noise=NOISE,
        seed=1,
    )
    assert res.success, res.message
    keep = res["t"] > 0.2
    assert min(res["p_a"].min(), res["p_b"].min()) > 1e5  # no chamber below 1 bar
    return float(np.sqrt(np.mean(res["force_error"][keep] ** 2)))


def test_fatigue_rig_the_law_halves_the_pi_baselines_error_at_10_hz(rig, designs):
    """Paper rig on a 1e7 N/m specimen, 5 ± 2 kN at 10 Hz, 20 µm / 0.1 bar noise, the design's
    one sample of delay, full model: RMS force error of the law at most half the PI's.
    Measured (2026-12-02): 31.6 N against 440 N (1 s runs); the bound is the issue's ½."""
    law, pi = (d.controller for d in designs)
    e_law, e_pi = _rms_error(rig, law, 10.0), _rms_error(rig, pi, 10.0)
    assert e_law <= 0.5 * e_pi, (e_law, e_pi)


def test_a_force_controller_file_is_schema_3_and_a_position_file_stays_schema_2(designs, tmp_path):
    """Schema 3 (output, feed-forward compliance, gains per kN) round-trips the packed law to
    the file's 10 digits and validates against its JSON Schema; a position controller still writes schema 2
    without the new keys."""
    jsonschema = pytest.importorskip("jsonschema")
    import json

    from hydropwa.control import controller_schema, load_controller, save_controller
    from hydropwa.control._io import controller_to_dict

    for d in designs:
        doc = controller_to_dict(d.controller)
        assert doc["schema"] == "hydropwa.controller/3" and doc["output"] == "force"
        jsonschema.Draft202012Validator(controller_schema(3)).validate(json.loads(json.dumps(doc)))
        path = save_controller(d.controller, tmp_path / f"{d.info['method']}.toml")
        # the gains are written as '0.1124174861 1/kN' (10 significant digits, _io._q): 1e-9
        np.testing.assert_allclose(load_controller(path).pack(), d.controller.pack(), rtol=1e-9)
    pos = controller_to_dict(PIController(kp=100.0, ki=10.0))
    assert pos["schema"] == "hydropwa.controller/2"
    assert "output" not in pos and "feedforward_compliance" not in pos


def test_the_transfer_integral_makes_the_first_command_the_old_laws(rig, designs):
    """transfer_integral: with it the force law's first opening is exactly the old law's
    (the command is affine in the integral), and the delay applies the old command first."""
    from hydropwa.control import transfer_integral

    law = designs[0].controller
    y = np.zeros(8)
    y[2], y[3], y[4], y[6], y[7] = 60e5, 40e5, X_C + 4e3 / K_SPEC, 100e5, 60e5
    a_a, a_b = rig.cylinder.area_a, rig.cylinder.area_b
    u0, c0 = 0.31, 0.19
    rates = (4e5, 4e5, 0.0)
    i0 = transfer_integral(law, y, 4e3, rates, (a_a, a_b), u0, c0)
    ctl = dataclasses.replace(law, transfer=(i0, u0, c0)).pack()
    cst, log, rch = np.zeros(C.N_CST), np.zeros((C.N_LOG, 1)), np.zeros((C.N_RCH, 1))
    rch[C.RC_DR, 0], rch[C.RC_DRFF, 0] = rates[:2]
    sg = np.zeros(32)
    C.controller_sample(0, 0, 0.0, y, a_a, a_b, ctl, cst, np.array([4e3]), rch, sg, log)
    assert log[C.L_C, 0] == pytest.approx(c0, abs=1e-12)
    assert log[C.L_U, 0] == u0  # the pending command: the old law's


def test_press_cycle_on_the_heavy_axis_transfers_without_a_bump():
    """Heavy axis, 5e7 N/m part, 100 mm approach at 0.1 m/s (position PI), 20 kN in 50 ms held
    0.5 s, release, retract; full model, 20 µm / 0.1 bar noise, one sample of delay. Measured
    (2026-12-02): overshoot 0.12 %, hold mean error −0.069 %, largest hold error 0.92 %, the
    command step at both transfers 0 (the new law's first own command is the old law's last: the
    integral is chosen on the run's own reference channels and noise, ``law_inputs``), the
    largest step over the next 10 samples 0.29 % / 0.46 %, lowest chamber 41 bar. Bounds: the
    issue's 5 %, 1 % (mean and largest), 2 % at each transfer and 1 bar; the transfer steps
    themselves to 1e-9 of full opening (the dead-zone inverse's round trip of the opening)."""
    from pathlib import Path

    from hydropwa import load_params
    from hydropwa.control import design_pi, press_cycle
    from hydropwa.linearization import linearize

    prm = load_params(Path(__file__).parents[1] / "machines" / "industrial.toml").replace(
        **{"load.specimen_stiffness": 5e7, "load.contact_position": 0.3, "load.force": 0.0}
    )
    position = design_pi(linearize(prm), delay=True, flow_feedforward=True).controller
    m = press_cycle(prm, position, design_force(prm).controller, sensor_noise=NOISE).metrics
    assert m["overshoot"] <= 0.05
    assert abs(m["hold_mean_error"]) <= 0.01 * 20e3
    assert m["hold_error"] <= 0.01 * 20e3
    assert m["jump_contact"] <= 1e-9
    assert m["jump_release"] <= 1e-9
    assert m["step_after_contact"] <= 0.02
    assert m["step_after_release"] <= 0.02
    assert m["p_min"] >= 1e5


def test_cli_refuses_an_unknown_output_in_one_line(tmp_path):
    """``control design --output torque``: one line naming the choices, exit code 2, no file."""
    from typer.testing import CliRunner

    from hydropwa.cli import app

    out = tmp_path / "f.toml"
    res = CliRunner().invoke(
        app, ["control", "design", "-p", "paper", "--output", "torque", "-o", str(out)]
    )
    assert res.exit_code == 2
    assert "--output 'torque' must be position, force or pressure" in res.output
    assert not out.exists()


def test_the_random_reference_is_band_limited_with_the_asked_rms():
    """random_reference: over one period its RMS is the asked one (to rounding), its spectrum
    (the FFT of one period, an exact multiple of the harmonics' spacing: no leakage) has no line
    outside [f0, f1] above 1e-9 of the largest, the same seed gives the same signal and another
    seed another; the spec reads in the unit given; a bad spec is one line."""
    from hydropwa.control import ControlError, parse_random, random_reference

    sig = random_reference(1500.0, 1.0, 10.0, 2.0, offset=5000.0, seed=1, sample_time=1e-3)
    v = sig.values[:-1] - 5000.0  # one period, the end sample repeats the first
    assert np.sqrt(np.mean(v**2)) == pytest.approx(1500.0, rel=1e-12)
    spec = np.abs(np.fft.rfft(v))
    f = np.fft.rfftfreq(v.size, 1e-3)
    inside = (f >= 1.0 - 1e-9) & (f <= 10.0 + 1e-9)
    assert np.count_nonzero(spec[inside] > 1e-6 * spec.max()) == 19  # 1, 1.5, ..., 10 Hz
    assert spec[~inside].max() < 1e-9 * spec.max()
    assert np.array_equal(
        sig.values, random_reference(1500.0, 1.0, 10.0, 2.0, 5000.0, 1, 1e-3).values
    )
    assert not np.allclose(
        v, random_reference(1500.0, 1.0, 10.0, 2.0, 5000.0, 2, 1e-3).values[:-1] - 5000.0
    )
    got = parse_random("random:rms=1.5 kN,f0=1,f1=10,duration=2 s,offset=5 kN,seed=1", "N")
    assert np.sqrt(np.mean((got.values[:-1] - 5000.0) ** 2)) == pytest.approx(1500.0, rel=1e-12)
    for bad, says in (
        ("random:rms=1 kN,f0=1,f1=10", "needs duration"),
        ("random:rms=1 kN,f0=10,f1=1,duration=2", "f0 < f1"),
        ("random:rms=1 kN,f0=1,f1=10,duration=2,band=3", "key one of"),
        ("random:rms=1 kN,f0=1.1,f1=1.2,duration=2", "no harmonic"),
    ):
        with pytest.raises(ControlError, match=says) as exc:
            parse_random(bad, "N")
        assert "\n" not in str(exc.value)


def test_cli_simulates_a_force_controller_on_a_random_reference(rig, designs, tmp_path):
    """``control simulate --reference random:...`` with a force controller: the run's
    force_reference is random_reference's (the same spec through the API), and a spec without
    its duration is one line, exit code 2."""
    from typer.testing import CliRunner

    from hydropwa.cli import app
    from hydropwa.control import random_reference, save_controller

    ctl = tmp_path / "f.toml"
    save_controller(designs[0].controller, ctl, machine_parameters=rig)
    run = tmp_path / "run.csv"
    spec = "random:rms=1 kN,f0=1,f1=10,duration=0.2,offset=5 kN,seed=3"
    args = ["control", "simulate", "-c", str(ctl), "--duration", "0.2", "-o", str(run)]
    res = CliRunner().invoke(app, [*args, "--reference", spec])
    assert res.exit_code == 0, res.output
    from hydropwa.data import read_run

    got = read_run(run, validate=False)
    want = random_reference(1000.0, 1.0, 10.0, 0.2, offset=5000.0, seed=3)(got.t)
    # the CSV keeps about 12 significant digits; 1e-9 of 5 kN is far below any real mismatch
    np.testing.assert_allclose(got["force_reference"], want, rtol=1e-9, atol=1e-6)
    bad = CliRunner().invoke(app, [*args, "--force", "--reference", "random:rms=1 kN,f0=1,f1=10"])
    assert bad.exit_code == 2
    assert "needs duration" in bad.output and bad.output.strip().count("\n") == 0


@pytest.mark.skipif(GCC is None, reason="gcc is not installed")
def test_force_law_fmu_closes_the_loop_on_the_axis_fmu_as_simulate_does(rig, designs, tmp_path):
    """The force law's controller FMU and the axis FMU (full model with the 1e7 N/m specimen),
    stepped together by FMPy at the sample time — another tool's loop, no hydropwa simulate in
    it: 5 ± 2 kN at 5 Hz for 0.3 s from the specimen's contact at 5 kN, exact sensors. The
    cylinder force follows the package's closed loop (simulate, rtol 1e-8) within 5e-4 of the
    amplitude, 1 N (the axis FMU integrates with its own step sequence at rtol 1e-8, so the runs
    agree to the solvers' tolerances, not bit for bit; the bound is a hundred times the measured
    difference and a fiftieth of the loop's own tracking error, which it must reproduce).
    Measured (2026-12-02): 0.0097 N apart, the loop's largest tracking error 58 N."""
    pytest.importorskip("fmpy")
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    from hydropwa.control import export_fmu
    from hydropwa.simulation import export_axis_fmu, law_inputs

    law = designs[0].controller
    ts = law.sample_time
    duration = 0.3
    ref = Sine(amplitude=F_AMP, frequency=5.0, offset=F_MEAN)
    x0 = X_C + F_MEAN / K_SPEC
    n = int(np.floor(duration / ts + 1e-9)) + 1
    tk = ts * np.arange(n)
    res = simulate(
        "full",
        timepts=tk,
        params=rig,
        controller=law,
        reference=ref,
        initial_position=x0,
        rtol=1e-8,
    )
    assert res.success, res.message
    a_a, a_b = rig.cylinder.area_a, rig.cylinder.area_b
    r, rch = law_inputs(law, ref, duration)

    def slave(path, name):
        md = read_model_description(str(path))
        unz = extract(str(path))
        fmu = FMU2Slave(
            guid=md.guid,
            unzipDirectory=unz,
            modelIdentifier=md.coSimulation.modelIdentifier,
            instanceName=name,
        )
        return fmu, {v.name: v.valueReference for v in md.modelVariables}

    axis, va = slave(export_axis_fmu(rig, tmp_path / "axis.fmu", initial_position=x0), "axis")
    ctrl, vc = slave(export_fmu(law, tmp_path / "law.fmu"), "law")
    force = np.empty(n)
    inputs = ("x", "v", "p_l", "r", "r_rate", "r_rate_ff", "r_acc", "r_rate_pre")
    rows = (C.RC_DR, C.RC_DRFF, C.RC_DDR, C.RC_DRPO)
    try:
        for f in (axis, ctrl):
            f.instantiate()
            f.setupExperiment(startTime=0.0)
            f.enterInitializationMode()
            f.exitInitializationMode()
        axis.setReal([va["rtol"]], [1e-8])
        for k in range(n):
            x, v, p_a, p_b = axis.getReal([va[c] for c in ("x", "v", "p_a", "p_b")])
            force[k] = a_a * p_a - a_b * p_b
            if k == n - 1:
                break
            pl = (a_a * p_a - a_b * p_b) / a_a  # the asymmetric P_L the law was designed with
            vals = [x, v, pl, float(r[k]), *(float(rch[i, k]) for i in rows)]
            ctrl.setReal([vc[c] for c in inputs], vals)
            ctrl.doStep(currentCommunicationPoint=float(tk[k]), communicationStepSize=ts)
            (u,) = ctrl.getReal([vc["u"]])
            axis.setReal([va["u"]], [u])
            axis.doStep(currentCommunicationPoint=float(tk[k]), communicationStepSize=ts)
    finally:
        for f in (axis, ctrl):
            f.terminate()
            f.freeInstance()
    want = np.asarray(res["force"], dtype=float)
    err = float(np.max(np.abs(force - want)))
    track = float(np.max(np.abs(want[tk > 0.1] - ref(tk[tk > 0.1]))))
    assert err <= 5e-4 * F_AMP, f"FMU loop off by {err:.3g} N (loop's tracking error {track:.3g} N)"
    assert track > 10 * err  # the comparison resolves the loop's own error


def test_law_inputs_are_what_the_runs_law_reads(rig, designs):
    """law_inputs: the compiled law replayed sample by sample on the run's states at the sample
    instants and on law_inputs' reference and channels (look-ahead rates and the sensor-noise
    draws of the seed) gives the run's own commands and rows, to rounding (the run's law and
    the replay are the same compiled function on the same numbers; 1e-12 of full opening
    allows for the states at t_k being the output grid's, not the step loop's registers);
    another seed's channels do not."""
    from hydropwa.simulation import law_inputs

    law = designs[0].controller
    ts = law.sample_time
    duration = 0.1
    n = int(np.floor(duration / ts + 1e-9)) + 1
    tk = ts * np.arange(n)
    ref = Sine(amplitude=F_AMP, frequency=5.0, offset=F_MEAN)
    res = simulate(
        "full", timepts=tk, params=rig, controller=law, reference=ref,
        initial_position=X_C + F_MEAN / K_SPEC, sensor_noise=NOISE, seed=4, rtol=1e-8,
    )  # fmt: skip
    assert res.success, res.message
    a_a, a_b = rig.cylinder.area_a, rig.cylinder.area_b

    def replay(seed):
        r, rch = law_inputs(law, ref, duration, sensor_noise=NOISE, seed=seed)
        ctl, cst = law.pack(), np.zeros(C.N_CST)
        log, sg = np.zeros((C.N_LOG, n)), np.zeros(32)
        for k in range(n):
            y = np.ascontiguousarray(res.states[k], dtype=float)
            C.controller_sample(0, k, tk[k], y, a_a, a_b, ctl, cst, r, rch, sg, log)
        return log

    log = replay(4)
    run = res.control
    np.testing.assert_allclose(log[C.L_U], run["u"], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(log[C.L_ROW].astype(np.int64), run["row"])
    np.testing.assert_array_equal(log[C.L_R], run["reference"])
    assert np.max(np.abs(replay(5)[C.L_U] - run["u"])) > 1e-4  # the noise draws matter
