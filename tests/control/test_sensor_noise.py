"""Sensor noise levels from standstill stretches (:func:`hydropwa.control.sensor_noise_from`)."""

from __future__ import annotations

import numpy as np
import pytest

from hydropwa.control import ControlError, sensor_noise_from
from hydropwa.data import Run
from hydropwa.rig import SensorModel

FS = 2000.0
SX, SP = 20e-6, 0.1e5  # the levels: 20 µm, 0.1 bar


def _sensors():
    return {
        "x": SensorModel("position", "x", "m", (0.0, 0.2), noise_std=SX),
        "p_a": SensorModel("pressure A", "p_a", "Pa", (0.0, 250e5), noise_std=SP),
        "p_b": SensorModel("pressure B", "p_b", "Pa", (0.0, 250e5), noise_std=SP),
    }


def _trajectory():
    """Hold 1 s at 50 mm (with a 20 bar pressure jump at 0.5 s), move at 0.1 m/s, hold 1 s with a slow drift."""
    t = np.arange(int(3.0 * FS)) / FS
    x = np.where(t < 1.0, 0.05, np.where(t < 2.0, 0.05 + 0.1 * (t - 1.0), 0.15))
    x = x + np.where(t >= 2.0, 0.5e-3 * (t - 2.0), 0.0)  # 0.5 mm/s creep: a standstill
    p_a = np.where(t < 0.5, 60e5, 80e5) - 10e5 * (t > 1.0) * (t < 2.0)
    p_b = 40e5 + 5e5 * np.sin(2 * np.pi * 0.2 * t)  # slow, near-linear over 0.1 s
    return t, {"x": x, "p_a": p_a, "p_b": p_b}


def _measured(seed=0):
    t, true = _trajectory()
    rng = np.random.default_rng(seed)
    sens = _sensors()
    chans = {"t": t, **{c: sens[c].apply(v, rng) for c, v in true.items()}}
    return Run("hold-move-hold", chans, fs=FS), sens


def test_noise_levels_of_the_rig_sensors_are_recovered():
    """Each channel's standard deviation is the sensor's noise with the 16-bit quantization (step²/12).

    20 standstill windows of 200 samples: a window's sample std scatters by 1/√(2·198) = 5 %,
    the median of 20 by about 1.25·5 %/√20 = 1.4 %; the bound 6 % is four of those.
    The pressure jump and the slow sine are in the standstill windows too: the median and the
    per-window straight-line fit keep them out.
    """
    run, sens = _measured()
    got = sensor_noise_from(run)
    assert set(got) == {"x", "p_a", "p_b"}
    for c, s in sens.items():
        expected = np.hypot(s.noise_std, s.quantization_step / np.sqrt(12.0))
        assert got[c] == pytest.approx(expected, rel=0.06), c
    # a dataset-like list of runs pools the windows; the moving second is left out
    two = sensor_noise_from([run, _measured(seed=1)[0]])
    assert two["x"] == pytest.approx(got["x"], rel=0.06)


def test_moving_runs_have_no_standstill_and_say_what_to_do():
    t = np.arange(int(2.0 * FS)) / FS
    run = Run("sine", {"t": t, "x": 0.1 + 0.05 * np.sin(2 * np.pi * t)}, fs=FS)
    with pytest.raises(ControlError, match="standstill windows.*--sensor-noise"):
        sensor_noise_from(run)
    with pytest.raises(ControlError, match="position x"):
        sensor_noise_from(Run("no-x", {"t": t, "p_a": np.full_like(t, 1e6)}, fs=FS))
    with pytest.raises(ControlError, match="Run, a Dataset"):
        sensor_noise_from("data/")


def test_exact_standstill_gives_the_quantization_alone():
    """Without noise the scatter is the converter's: a constant sits on one code (0), a slow
    ramp crosses codes and leaves step/√12 (within 15 %: the ramp covers few codes per window)."""
    t = np.arange(int(1.0 * FS)) / FS
    s = SensorModel("position", "x", "m", (0.0, 0.2))
    rng = np.random.default_rng(0)
    x = s.apply(0.05 + 0.5e-3 * t, rng)
    got = sensor_noise_from(Run("ramp", {"t": t, "x": x}, fs=FS))
    assert got["x"] == pytest.approx(s.quantization_step / np.sqrt(12.0), rel=0.15)


@pytest.mark.slow  # a PI design verified on the full model (3 tasks): 18-25 s on the shared machine
def test_cli_design_measures_the_verification_noise_from_a_dataset(tmp_path, capsys):
    """``control design --noise-from DATA`` verifies with the levels measured at standstill, and
    says so; together with ``--sensor-noise`` it is refused in one line (exit 2)."""
    from hydropwa.cli import main
    from hydropwa.control import load_controller
    from hydropwa.data import write_dataset

    data = tmp_path / "data"
    write_dataset([_measured()[0]], data)
    expected = sensor_noise_from(_measured()[0])
    ctrl = tmp_path / "pi.toml"
    args = [
        "control",
        "design",
        "-p",
        "paper",
        "--method",
        "pi",
        "--draws",
        "1",
        "--write-unverified",  # a PI fails the verification; this test is about the noise
        "--out",
        str(ctrl),
    ]
    assert main([*args, "--noise-from", str(data)]) == 0
    out = capsys.readouterr().out
    assert "sensor noise measured at standstill" in out and "um" in out
    noise = load_controller(ctrl).verification["settings"]["sensor_noise"]
    for c, v in expected.items():  # parquet round trip: the same samples, the same numbers
        assert noise[c] == pytest.approx(v, rel=1e-9)
    code = main([*args, "--force", "--noise-from", str(data), "--sensor-noise", "x=1 um"])
    err = capsys.readouterr().err
    assert code == 2 and "either --sensor-noise or --noise-from" in err and err.count("\n") == 1


@pytest.mark.slow  # an LQR design of 70 cells: 10-26 s on the shared 2-core machine
def test_cli_observer_is_designed_for_the_measured_noise(tmp_path, capsys):
    """``--observer --noise-from DATA`` writes the Kalman gains of the measured position noise
    (the steady-state filter of python-control's ``dlqe``, tested in test_controller_v2)."""
    from hydropwa.cli import main
    from hydropwa.control import load_controller, position_observer_gains
    from hydropwa.data import write_dataset

    data = tmp_path / "data"
    write_dataset([_measured()[0]], data)
    sx = sensor_noise_from(_measured()[0])["x"]
    ctrl = tmp_path / "lqr.toml"
    args = ["control", "design", "-p", "paper", "--no-verify", "--observer", "--out", str(ctrl)]
    assert main([*args, "--noise-from", str(data)]) == 0
    got = load_controller(ctrl).position_observer
    assert got == pytest.approx(position_observer_gains(5e-4, sx, 1.0), rel=1e-9)
    code = main([*args, "--force", "--sensor-noise", "x=0 um"])
    assert code == 2 and "position noise x > 0" in capsys.readouterr().err
    pi = [
        "control",
        "design",
        "-p",
        "paper",
        "--method",
        "pi",
        "--observer",
        "--out",
        str(tmp_path / "pi.toml"),
    ]
    assert main(pi) == 2 and "--observer needs --method lqr" in capsys.readouterr().err


def test_cli_simulate_runs_with_the_measured_noise(tmp_path, capsys):
    """``control simulate --noise-from DATA`` adds the measured noise to the controller's sensors.

    At a hold of the reduced model the exact loop's command is constant; with the noise it
    scatters by about k_p σ_x (the PI's position gain times the measured noise; the loop and
    the pressure terms change it by tens of percent: bound 0.5-1.5).
    """
    import pandas as pd

    from hydropwa.cli import main
    from hydropwa.control import load_controller
    from hydropwa.data import write_dataset

    data = tmp_path / "data"
    write_dataset([_measured()[0]], data)
    sx = sensor_noise_from(_measured()[0])["x"]
    ctrl = tmp_path / "pi.toml"
    assert (
        main(
            [
                "control",
                "design",
                "-p",
                "paper",
                "--method",
                "pi",
                "--no-verify",
                "--out",
                str(ctrl),
            ]
        )
        == 0
    )
    sim = ["control", "simulate", "--model", "reduced", "--controller", str(ctrl), "-p", "paper"]
    sim += ["--reference", "0.1", "--duration", "0.3"]
    for name, extra in (("exact", []), ("noisy", ["--noise-from", str(data)])):
        assert main([*sim, "--out", str(tmp_path / f"{name}.csv"), *extra]) == 0
    assert "sensor noise measured at standstill" in capsys.readouterr().out
    cmd = {}
    for name in ("exact", "noisy"):
        df = pd.read_csv(tmp_path / f"{name}.csv", comment="#")
        df.columns = [c.split(" ")[0] for c in df.columns]
        cmd[name] = df["command"][df["t"] >= 0.1].to_numpy()
    assert np.ptp(cmd["exact"]) < 1e-9
    kp = load_controller(ctrl).kp
    assert 0.5 * kp * sx < np.std(cmd["noisy"]) < 1.5 * kp * sx


def test_cli_dead_zone_hysteresis_is_refused_where_it_means_nothing(tmp_path, capsys):
    """``--dead-zone-hysteresis`` outside [0, 0.1), or without the dead-zone inverse of a state
    feedback design, is one line and exit 2 (checked before any design runs)."""
    from hydropwa.cli import main

    out = ["--no-verify", "--out", str(tmp_path / "c.toml")]
    cases = [
        # the command's own rule (< 0.1) and the CLI's range table (finite, in [0, 0.5])
        (["--dead-zone-hysteresis", "0.5"], "share of the opening"),
        (["--dead-zone-hysteresis", "nan"], "share of the opening"),
        (["--method", "pi", "--dead-zone-hysteresis", "0.005"], "needs the dead-zone inverse"),
        (
            ["--no-dead-zone-inverse", "--dead-zone-hysteresis", "0.005"],
            "needs the dead-zone inverse",
        ),
    ]
    for extra, words in cases:
        assert main(["control", "design", "-p", "paper", *extra, *out]) == 2
        err = capsys.readouterr().err
        assert words in err and err.count("\n") == 1, err
    assert not (tmp_path / "c.toml").exists()


@pytest.mark.slow  # an LQR design of 70 cells: 10-26 s on the shared 2-core machine
def test_cli_dead_zone_hysteresis_goes_into_the_file(tmp_path):
    """The band given at the command line is the one the written law carries (schema 2)."""
    from hydropwa.cli import main
    from hydropwa.control import load_controller

    ctrl = tmp_path / "lqr.toml"
    args = ["control", "design", "-p", "paper", "--no-verify", "--observer", "--out", str(ctrl)]
    assert main([*args, "--dead-zone-hysteresis", "0.005"]) == 0
    assert load_controller(ctrl).dead_zone_inverse.hysteresis == 0.005
