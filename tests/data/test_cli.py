"""`hydropwa data check|convert` through typer's CliRunner."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from hydropwa.cli._data import app
from hydropwa.data import read_dataset, read_run, write_dataset, write_run


@pytest.fixture
def cli():
    return CliRunner()


def test_check_clean_dataset(cli, tmp_path, make_run):
    write_dataset([make_run("a"), make_run("b", seed=4)], tmp_path / "ds")
    res = cli.invoke(app, ["check", str(tmp_path / "ds")])
    assert res.exit_code == 0, res.output
    assert "has no issues" in res.stdout


def test_check_reports_issues_with_exit_1(cli, tmp_path, make_run):
    run = make_run("bad")
    chans = {k: np.array(v) for k, v in run.channels.items()}
    chans["p_a"][7] = np.nan
    path = write_run(run.replace(channels=chans), tmp_path / "bad.csv")
    res = cli.invoke(app, ["check", str(path), "--plain"])
    assert res.exit_code == 1
    assert (
        "error: run 'bad', channel 'p_a', sample 7 (t = 0.007 s): 1 NaN/inf value(s)" in res.stdout
    )


def test_check_unreadable_input_exit_2(cli, tmp_path):
    res = cli.invoke(app, ["check", str(tmp_path / "missing")])
    assert res.exit_code == 2
    assert res.stderr.startswith("error: ") and "no such file or folder" in res.stderr
    assert "Traceback" not in res.output
    (tmp_path / "junk.parquet").write_bytes(b"not parquet")
    res = cli.invoke(app, ["check", str(tmp_path / "junk.parquet")])
    assert res.exit_code == 2 and "not a readable Parquet file" in res.stderr


def test_convert_file_and_error(cli, tmp_path, make_run):
    src = write_run(make_run("a"), tmp_path / "a.parquet")
    res = cli.invoke(app, ["convert", str(src), str(tmp_path / "a.csv")])
    assert res.exit_code == 0, res.output
    np.testing.assert_array_equal(read_run(tmp_path / "a.csv")["x"], make_run("a")["x"])
    res = cli.invoke(app, ["convert", str(src), str(tmp_path / "a.txt")])
    assert res.exit_code == 2 and "cannot tell the format from suffix '.txt'" in res.stderr


def test_convert_emps_folder_with_channel_map(cli, tmp_path, emps_dir):
    res = cli.invoke(
        app,
        [
            "convert",
            str(emps_dir),
            str(tmp_path / "emps"),
            "--channel-map",
            "emps",
            "--format",
            "parquet",
        ],
    )
    assert res.exit_code == 0, res.output
    ds = read_dataset(tmp_path / "emps")
    assert ds.names == ["DATA_EMPS", "DATA_EMPS_PULSES"]
    assert ds["DATA_EMPS"].n_samples == 24841


def test_convert_mat_without_map_fails_cleanly(cli, tmp_path, emps_dir):
    res = cli.invoke(app, ["convert", str(emps_dir / "DATA_EMPS.mat"), str(tmp_path / "e.csv")])
    assert res.exit_code == 2
    assert "MAT file without hydropwa metadata" in res.stderr and "--channel-map" in res.stderr


def test_check_folder_of_raw_files(cli, emps_dir, tmp_path):
    res = cli.invoke(app, ["check", str(emps_dir), "--channel-map", "emps"])
    assert res.exit_code == 0, res.output
    res = cli.invoke(app, ["check", str(emps_dir), "--plain"])
    assert res.exit_code == 1
    assert res.stdout.count("MAT file without hydropwa metadata") == 2
    res = cli.invoke(app, ["check", str(tmp_path)])
    assert res.exit_code == 2 and "no manifest.json" in res.stderr
