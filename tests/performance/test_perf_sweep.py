"""Sweeps from TOML: case generation, the CLI, and Dask giving the in-process table."""

import pandas as pd
import pytest

from hydropwa._errors import ParameterError
from hydropwa.sweep import load_sweep, parse_sweep, run_sweep

SPEC = """
base = "paper"
[grid]
"load.mass" = [1.0, 2.0]
"supply.pressure" = ["80 bar", "100 bar"]
[random]
n = 2
seed = 1
"friction.coulomb" = {uniform = [10, 40]}
[input]
u = "sine:amplitude=0.4,frequency=2"
duration = 0.5
model = "reduced"
rtol = 1e-3
"""


@pytest.fixture
def spec_file(tmp_path):
    path = tmp_path / "sweep.toml"
    path.write_text(SPEC)
    return path


def test_cases_are_the_grid_times_the_draws_in_si(spec_file):
    spec = load_sweep(spec_file)
    cases = spec.cases()
    assert len(cases) == 2 * 2 * 2
    assert {c.overrides["supply.pressure"] for c in cases} == {8e6, 1e7}
    assert all(10 <= c.overrides["friction.coulomb"] <= 40 for c in cases)
    assert [c.overrides for c in spec.cases()] == [
        c.overrides for c in cases
    ]  # reproducible from the seed
    assert spec.params_for(cases[-1]).load.mass == 2.0


def test_unknown_field_names_the_groups():
    with pytest.raises(ParameterError, match="unknown parameter 'load.weight'"):
        parse_sweep({"base": "paper", "grid": {"load.weight": [1.0]}})


def test_cli_writes_summary_and_trajectories(spec_file, tmp_path):
    from hydropwa.cli import main

    out = tmp_path / "summary.csv"
    code = main(
        [
            "sweep",
            str(spec_file),
            "--out",
            str(out),
            "--trajectories",
            str(tmp_path / "traj"),
            "-q",
            "-j",
            "2",
        ]
    )
    assert code == 0
    df = pd.read_csv(out)
    assert len(df) == 8 and list(df["case"]) == list(range(8))
    assert (df["status"] == 0).all()
    assert len(list((tmp_path / "traj").glob("case_*.parquet"))) == 8
    # heavier load, lower supply pressure: never faster
    assert df["peak_velocity"].max() < 1.0


@pytest.mark.filterwarnings("ignore::ResourceWarning")
@pytest.mark.filterwarnings("ignore::DeprecationWarning")
@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
@pytest.mark.filterwarnings("ignore:.*[Pp]ort.*:UserWarning")
@pytest.mark.filterwarnings("ignore:.*clean.*:UserWarning")
def test_dask_local_cluster_gives_the_in_process_table(spec_file):
    spec = load_sweep(spec_file)
    local = run_sweep(spec, jobs=2)
    dask = run_sweep(spec, scheduler="local", jobs=2)
    pd.testing.assert_frame_equal(
        local.drop(columns="wall_time"), dask.drop(columns="wall_time"), check_exact=True
    )
