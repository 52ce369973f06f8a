"""The reliability audit's leftovers (issue 37): each case accepted silently before, or raising
something other than the package's documented error; each must fail without its fix."""

from __future__ import annotations

import json

import numpy as np
import pytest
from _fuzzutil import cli_violation, run_cli

from hydropwa import simulate
from hydropwa._errors import DataError, ParameterError
from hydropwa.control import ControlError, load_controller
from hydropwa.data import Run, read_run, write_run
from hydropwa.params import get_preset, load_params
from hydropwa.sweep import load_sweep


@pytest.mark.parametrize("rtol", [-1.0, 0.0, 2.0, 0.5, 1e-13])
def test_simulate_refuses_an_rtol_out_of_range(rtol):
    """rtol −1 and 2 ran silently (the CLI checked, the Python API did not)."""
    with pytest.raises(ParameterError, match=r"rtol = .* is outside \[1e-12, 0.1\]"):
        simulate("reduced", duration=0.01, params=get_preset("paper"), rtol=rtol)


@pytest.mark.parametrize(
    "ps, bound",
    [
        (0.0, "greater than"),
        (-5e5, "greater than"),
        (1e14, "at most 1e\\+09 Pa"),  # 10⁹ bar
        ("sine:offset=50 bar,amplitude=80 bar,frequency=5", "greater than"),  # dips below 0
    ],
)
def test_simulate_refuses_a_supply_pressure_a_parameter_file_refuses(ps, bound):
    """``simulate(..., supply_pressure=...)`` gets the bounds of ``Supply.pressure``."""
    with pytest.raises(ParameterError, match=bound):
        simulate("reduced", duration=0.2, params=get_preset("paper"), supply_pressure=ps)


def test_a_supply_signal_inside_the_bounds_runs():
    r = simulate(
        "reduced",
        duration=0.05,
        params=get_preset("paper"),
        supply_pressure="sine:offset=100 bar,amplitude=20 bar,frequency=5",
    )
    assert r.success


@pytest.mark.parametrize("unit, scale", [("ms", 1e3), ("us", 1e6), ("ns", 1e9)])
@pytest.mark.parametrize("kind", ["timestamp", "duration"])
def test_parquet_time_columns_in_ms_are_read_as_seconds(tmp_path, unit, scale, kind):
    """An Arrow timestamp/duration column in ms holds 1000 per second: t must come out in s."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    t = np.arange(0.0, 0.5, 0.001)
    typ = pa.timestamp(unit) if kind == "timestamp" else pa.duration(unit)
    ticks = pa.array(np.round(t * scale).astype("int64"), type=typ)
    pq.write_table(pa.table({"t": ticks, "x": pa.array(0.1 + 0.0 * t)}), tmp_path / "r.parquet")
    run = read_run(tmp_path / "r.parquet")
    assert run.t[1] - run.t[0] == pytest.approx(1e-3, rel=1e-9)
    assert run.t[-1] == pytest.approx(0.499, rel=1e-9) and run.fs == pytest.approx(1000.0)


@pytest.fixture
def deep_toml(tmp_path):
    path = tmp_path / "deep.toml"
    path.write_text("a = " + "[" * 100_000 + "]" * 100_000 + "\n")
    return path


def test_a_deeply_nested_parameter_file_is_one_error(deep_toml):
    with pytest.raises(ParameterError, match="nested too deeply"):
        load_params(deep_toml)


def test_a_deeply_nested_controller_file_is_one_error(deep_toml, tmp_path):
    with pytest.raises(ControlError, match="nested too deeply"):
        load_controller(deep_toml)
    deep_json = tmp_path / "deep.json"
    deep_json.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(ControlError, match="nested too deeply"):
        load_controller(deep_json)


def _with_version(tmp_path, version) -> object:
    t = np.arange(0.0, 0.1, 0.001)
    path = write_run(Run("r", {"t": t, "x": 0.1 + 0.0 * t}), tmp_path / "r.csv")
    head, body = path.read_text().split("\n", 1)
    header = json.loads(head.removeprefix("# hydropwa: "))
    assert header["format_version"] == 1
    header["format_version"] = version
    path.write_text(f"# hydropwa: {json.dumps(header)}\n{body}")
    return path


@pytest.mark.parametrize("version", [2, 99, 0, -1, 1.5, "1", "x"])
def test_an_unknown_format_version_is_refused(tmp_path, version):
    with pytest.raises(DataError, match="format_version"):
        read_run(_with_version(tmp_path, version))


def test_the_known_format_version_loads(tmp_path):
    assert read_run(_with_version(tmp_path, 1)).t.size == 100


@pytest.mark.parametrize(
    "text",
    ["", "[grid]\n", '[input]\nduration = 0.1\nmodel = "reduced"\n', "[random]\nn = 0\n"],
)
def test_a_sweep_with_nothing_to_vary_is_refused(tmp_path, text):
    """It ran one case of the base parameters and exited 0."""
    spec = tmp_path / "s.toml"
    spec.write_text('base = "paper"\n' + text)
    with pytest.raises(ParameterError, match="nothing to sweep"):
        load_sweep(spec)
    argv = ["sweep", str(spec), "--out", str(tmp_path / "out.csv")]
    code, out, err = run_cli(argv, tmp_path)
    assert cli_violation(argv, code, out, err) is None
    assert code == 2 and "nothing to sweep" in err and not (tmp_path / "out.csv").exists()
