"""simulate(): signals, results, files, failures and the CLI."""

import numpy as np
import pytest

from hydropwa import (
    Chirp,
    FullOrderModel,
    ReducedModel,
    Sampled,
    SignalError,
    SimulationError,
    Sine,
    Step,
    parse_signal,
    simulate,
)
from hydropwa.cli import main


@pytest.mark.parametrize(
    "spec, t, expected",
    [
        ("constant:0.2", 3.0, 0.2),
        ("0.25", 1.0, 0.25),
        ("constant:value=40 %", 1.0, 0.4),
        ("step:time=0.5,before=0,after=0.3", 0.49, 0.0),
        ("step:time=0.5,before=0,after=0.3", 0.5, 0.3),
        ("sine:amplitude=0.4,frequency=1", 0.25, 0.4),
        ("sine:amplitude=0.4,frequency=1,offset=0.1", 0.75, -0.3),
        ("ramp:t0=0,t1=2,v0=0,v1=1", 0.5, 0.25),
        ("chirp:amplitude=1,f0=0,f1=2,duration=1", 0.5, np.sin(2 * np.pi * 0.25)),
    ],
)
def test_signal_specs(spec, t, expected):
    assert parse_signal(spec)(t) == pytest.approx(expected, abs=1e-12)


def test_signal_specs_with_units():
    assert parse_signal("constant:95 bar", unit="Pa")(0.0) == pytest.approx(95e5)
    assert parse_signal("sine:amplitude=5 bar,frequency=2 Hz,offset=100 bar", unit="Pa")(
        0.125
    ) == pytest.approx(105e5)


@pytest.mark.parametrize(
    "spec, message",
    [
        ("square:1", "unknown signal kind 'square'"),
        ("sine:amplitud=1", "no parameter 'amplitud'"),
        ("sine:amplitude=1,frequency", "needs the form key=value"),
        ("sine:amplitude=abc", "cannot be read"),
        ("ramp:t0=1,t1=0", "t1 > t0"),
        ("sine:frequency=3 bar", "wrong dimension"),
    ],
)
def test_bad_signal_specs(spec, message):
    with pytest.raises(SignalError, match=message):
        parse_signal(spec, name="--input")


def test_sampled_signal_interpolates_and_holds():
    s = Sampled(np.array([0.0, 1.0, 2.0]), np.array([0.0, 1.0, 0.0]))
    assert s(0.5) == pytest.approx(0.5)
    assert s(5.0) == 0.0
    with pytest.raises(SignalError, match="non-finite value at sample 1"):
        Sampled(np.array([0.0, 1.0]), np.array([0.0, np.nan]))


def test_replayed_measured_command_reproduces_the_analytic_run(paper):
    t = np.linspace(0, 1, 2001)
    u = 0.3 * np.sin(2 * np.pi * 2 * t)
    a = simulate(ReducedModel(paper), Sampled(t, u), duration=1.0, rtol=1e-7)
    b = simulate(ReducedModel(paper), Sine(amplitude=0.3, frequency=2), duration=1.0, rtol=1e-7)
    # linear interpolation of a 2 kHz sampled sine: command error < 0.3·(2π·2/2000)²/8 ≈ 1.5e-6
    assert np.max(np.abs(a["x"] - b["x"])) < 2e-6


def test_result_channels_units_and_pandas(paper):
    res = simulate(FullOrderModel(paper), Step(time=0.01, after=0.3), duration=0.1, fs=1000)
    for ch in ("t", "u", "spool", "z", "p_a", "p_b", "p_l", "p_s", "f_l", "x", "v"):
        assert ch in res.channels and res[ch].shape == (101,)
    assert res.units["p_a"] == "Pa" and res.units["x"] == "m"
    np.testing.assert_allclose(res["p_l"], res["p_a"] - res["p_b"])
    df = res.to_pandas()
    assert list(df.index[:2]) == [0.0, 0.001] and df.attrs["units"]["v"] == "m/s"
    with pytest.raises(KeyError, match="available"):
        res["nope"]


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_result_file_round_trip(tmp_path, paper, suffix):
    from hydropwa.data import read_run

    res = simulate(ReducedModel(paper), "sine:amplitude=0.3,frequency=1", duration=0.5)
    path = (
        res.to_csv(tmp_path / f"r{suffix}")
        if suffix == ".csv"
        else res.to_parquet(tmp_path / f"r{suffix}")
    )
    run = read_run(path, validate=False)
    for ch in ("t", "x", "p_a", "u"):
        np.testing.assert_allclose(run[ch], res[ch], rtol=1e-12, atol=0)


def test_amplitude_schedule_of_omega0(paper):
    r10 = simulate(FullOrderModel(paper), Sine(amplitude=0.10, frequency=5), duration=0.05)
    r90 = simulate(FullOrderModel(paper), Sine(amplitude=0.90, frequency=5), duration=0.05)
    assert r10.stats["omega0"] == pytest.approx(816.8)
    assert r90.stats["omega0"] == pytest.approx(220.0)


def test_ros4ls_closed_loop_constant_command_equals_the_open_loop(paper):
    """The third solver (ROS4LS) through the closed loop's sampled steps: a controller that
    only outputs u_ff = 0.3 gives ROS34PW2's open-loop run with u = 0.3 to the integration
    tolerance (rtol 1e-7; measured 3.5e-9 m and 3.0e-7·P_S)."""
    from hydropwa.control import GainRow, StateFeedbackController

    prm = paper.replace(**{"valve.omega0_table": ()})
    inf = float("inf")
    ctl = StateFeedbackController(rows=(GainRow((-inf,) * 4, (inf,) * 4, 0.0, 0.0, 0.0, 0.0, 0.3),))
    kw = dict(params=prm, duration=0.1, rtol=1e-7, initial_position=0.05)
    closed = simulate("full", controller=ctl, reference=0.05, solver="ros4ls", **kw)
    opened = simulate("full", 0.3, **kw)
    assert closed.stats["solver"] == "ros4ls" and closed.stats["steps"] >= 200
    # ROS4LS takes a Jacobian at every accepted step (it is not a W-method)
    assert closed.stats["jacobians"] >= closed.stats["steps"]
    np.testing.assert_allclose(closed["x"], opened["x"], atol=1e-7)
    np.testing.assert_allclose(closed["p_a"], opened["p_a"], atol=1e-5 * prm.supply.pressure)


def test_failed_integration_names_time_state_and_keeps_partial_result(paper):
    with pytest.raises(
        SimulationError, match=r"failed at t = .* s: the step budget.*State: spool="
    ) as info:
        simulate(
            FullOrderModel(paper),
            Chirp(amplitude=0.5, f0=1, f1=50, duration=1),
            duration=1.0,
            max_steps=200,
        )
    err = info.value
    assert 0 < err.t < 1.0 and set(err.state) >= {"p_a", "x"}
    assert err.partial is not None and err.partial.t[-1] <= err.t


def test_stiff_dead_volume_failure_explains_cause(paper):
    # ROS34PW2 is L-stable and copes with this, but needs tiny steps (~490 over these 50 ms,
    # against ~25 with the real dead volumes): a budget of 300 runs out
    p = paper.replace(**{"cylinder.dead_volume_a": 1e-9, "cylinder.dead_volume_b": 1e-9})
    with pytest.raises(
        SimulationError, match=r"dead volume 1e-09 m³ makes the chamber stiffness 1.69e\+12 N/m"
    ):
        simulate(
            FullOrderModel(p),
            Step(time=0.0, after=0.5),
            duration=0.05,
            initial_position=0.0,
            max_steps=300,
            rtol=1e-5,
        )


def test_bad_duration(paper):
    with pytest.raises(SignalError, match="duration must be a positive"):
        simulate(ReducedModel(paper), 0.1, duration=-1)


def test_cli_simulate_writes_csv_and_plot(tmp_path, capsys):
    out = tmp_path / "run.csv"
    code = main(
        [
            "simulate",
            "--params",
            "paper",
            "--model",
            "reduced",
            "--input",
            "sine:amplitude=40 %,frequency=1",
            "--duration",
            "1",
            "--out",
            str(out),
            "--plot",
            str(tmp_path / "run.png"),
        ]
    )
    assert code == 0
    assert out.exists() and (tmp_path / "run.png").stat().st_size > 1000
    header = [line for line in out.read_text().splitlines() if not line.startswith("#")][0]
    assert "x [m]" in header and "p_a [Pa]" in header


@pytest.mark.parametrize(
    "args, message",
    [
        (["simulate", "-p", "paper", "--model", "foo"], "--model 'foo' is unknown"),
        (["simulate", "-p", "paper", "--input", "sine:amplitud=1"], "no parameter 'amplitud'"),
        (["simulate", "--params", "missing.toml"], "not found"),
        (["simulate", "-p", "paper", "--supply-pressure", "95 kg"], "wrong dimension"),
        (["params", "show", "nope.toml"], "not found"),
    ],
)
def test_cli_bad_input_is_one_line_exit_2(tmp_path, capsys, args, message):
    code = main(args + (["--out", str(tmp_path / "r.csv")] if args[0] == "simulate" else []))
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert (
        err.startswith("error: ") and message in err and "\n" not in err and "Traceback" not in err
    )


def test_cli_params_export_and_show(tmp_path, capsys):
    out = tmp_path / "p.toml"
    assert main(["params", "export", "paper", "-o", str(out)]) == 0
    assert main(["params", "export", "paper", "-o", str(out)]) == 2  # exists, no --force
    assert main(["params", "show", str(out)]) == 0
    assert "bulk_modulus" in capsys.readouterr().out


def test_cli_registers_every_layer(capsys):
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    for command in ("simulate", "params", "data", "rig", "identify", "linearize", "sweep", "paper"):
        assert command in out


@pytest.mark.parametrize(
    "args", [["simulate", "--nope"], ["linearize", "--bogus"], ["rig", "run", "nothing"]]
)
def test_cli_usage_errors_exit_2_without_traceback(capsys, args):
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "rror" in err


def test_cli_does_not_overwrite_without_force(tmp_path, capsys):
    out = tmp_path / "run.csv"
    args = ["simulate", "-p", "paper", "--model", "reduced", "--duration", "0.1", "--out", str(out)]
    assert main(args) == 0
    before = out.read_bytes()
    assert main(args) == 2
    assert "exists; pass --force" in capsys.readouterr().err
    assert out.read_bytes() == before
    assert main(args + ["--force"]) == 0
