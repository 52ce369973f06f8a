"""Datasets: manifest, lazy loading, kind filter, interrupted writes, conversion."""

from __future__ import annotations

import json

import numpy as np
import pyarrow.parquet as pq
import pytest

from hydropwa._errors import DataError
from hydropwa.data import MANIFEST, Dataset, check_dataset, convert, read_dataset, write_dataset


@pytest.fixture
def runs(make_run):
    return [
        make_run("step_01", seed=1),
        make_run("step_02", seed=2),
        make_run("stribeck_01", seed=3, kind="stribeck"),
    ]


@pytest.mark.parametrize("fmt", ["parquet", "csv", "mat"])
def test_write_and_read_dataset(tmp_path, runs, fmt):
    write_dataset(runs, tmp_path / "ds", format=fmt, meta={"campaign": "paper"})
    doc = json.loads((tmp_path / "ds" / MANIFEST).read_text(encoding="utf-8"))
    assert doc["format"] == "hydropwa-dataset" and doc["format_version"] == 1
    assert doc["meta"] == {"campaign": "paper"}
    assert [e["file"] for e in doc["runs"]] == [f"{r.name}.{fmt}" for r in runs]
    assert doc["runs"][2]["kind"] == "stribeck" and doc["runs"][0]["n_samples"] == 500
    assert doc["runs"][0]["channels"]["p_a"] == "Pa"
    ds = read_dataset(tmp_path / "ds")
    assert len(ds) == 3 and ds.names == ["step_01", "step_02", "stribeck_01"]
    for run, back in zip(runs, ds, strict=True):
        assert back.meta == run.meta
        np.testing.assert_array_equal(back["p_l"], run["p_l"])


def test_kind_filter(tmp_path, runs):
    ds = write_dataset(runs, tmp_path / "ds")
    assert read_dataset(tmp_path / "ds").filter(kind="step").names == ["step_01", "step_02"]
    assert ds.filter(kind="stribeck").names == ["stribeck_01"]
    assert ds.filter(rig="virtual").names == ds.names
    assert ds.filter(kind="sine").names == []


def test_dataset_units_written_in_bar(tmp_path, runs):
    write_dataset(runs, tmp_path / "ds", units={"p_a": "bar"})
    table = pq.read_table(tmp_path / "ds" / "step_01.parquet")
    assert table.schema.field("p_a").metadata[b"unit"] == b"bar"
    back = read_dataset(tmp_path / "ds")["step_01"]["p_a"]
    np.testing.assert_allclose(back, runs[0]["p_a"], rtol=4.5e-16, atol=0)  # one ulp via bar


def test_interrupted_write_keeps_finished_runs(tmp_path, runs, monkeypatch):
    real = pq.write_table
    calls = []

    def flaky(table, where, *args, **kwargs):
        calls.append(where)
        if len(calls) == 3:
            with open(where, "wb") as fh:  # half a file, then the crash
                fh.write(b"PAR1 partial")
            raise KeyboardInterrupt("power cut while writing run 3")
        return real(table, where, *args, **kwargs)

    monkeypatch.setattr(pq, "write_table", flaky)
    with pytest.raises(KeyboardInterrupt):
        write_dataset(runs, tmp_path / "ds")
    monkeypatch.setattr(pq, "write_table", real)
    ds = read_dataset(tmp_path / "ds")
    assert ds.names == ["step_01", "step_02"]
    np.testing.assert_array_equal(ds["step_02"]["x"], runs[1]["x"])
    assert sorted(p.name for p in (tmp_path / "ds").iterdir()) == [
        MANIFEST,
        "step_01.parquet",
        "step_02.parquet",
    ]
    # resume: add the missing run to the existing dataset
    Dataset(tmp_path / "ds").add_run(runs[2])
    assert read_dataset(tmp_path / "ds").names == ["step_01", "step_02", "stribeck_01"]


def test_existing_dataset_is_not_overwritten(tmp_path, runs):
    write_dataset(runs[:1], tmp_path / "ds")
    with pytest.raises(DataError, match=r"already holds a dataset; hint: .*overwrite=True"):
        write_dataset(runs, tmp_path / "ds")
    with pytest.raises(DataError, match=r"run 'step_01' exists"):
        Dataset(tmp_path / "ds").add_run(runs[0])
    write_dataset(runs, tmp_path / "ds", overwrite=True)
    assert len(read_dataset(tmp_path / "ds")) == 3


def test_missing_manifest_and_missing_file(tmp_path, runs):
    with pytest.raises(DataError, match=r"no manifest.json, so it is not a hydropwa dataset"):
        read_dataset(tmp_path)
    write_dataset(runs, tmp_path / "ds")
    (tmp_path / "ds" / "step_02.parquet").unlink()
    with pytest.raises(
        DataError,
        match=r"run 'step_02': file 'step_02.parquet' listed in "
        r"manifest.json is missing",
    ):
        read_dataset(tmp_path / "ds")
    issues = check_dataset(tmp_path / "ds")
    assert [(i.code, i.run) for i in issues] == [("unreadable", "step_02")]


def test_check_dataset_reports_bad_run(tmp_path, runs):
    bad = runs[1].replace(channels={**runs[1].channels, "x": runs[1]["x"] * 1000})
    write_dataset([runs[0], bad], tmp_path / "ds")
    with pytest.raises(DataError, match=r"run 'step_02', channel 'x', sample 0"):
        read_dataset(tmp_path / "ds")
    issues = check_dataset(tmp_path / "ds")
    assert [(i.run, i.channel, i.code) for i in issues] == [
        ("step_02", "x", "implausible_magnitude")
    ]


def test_convert_dataset_between_formats(tmp_path, runs):
    write_dataset(runs, tmp_path / "pq")
    out = convert(tmp_path / "pq", tmp_path / "csv", format="csv")
    ds = read_dataset(out)
    assert [p.suffix for p in map(ds.path_of, ds.names)] == [".csv"] * 3
    np.testing.assert_array_equal(ds["stribeck_01"]["f_l"], runs[2]["f_l"])


def test_convert_single_file(tmp_path, runs):
    write_dataset(runs, tmp_path / "pq")
    out = convert(tmp_path / "pq" / "step_01.parquet", tmp_path / "one.mat")
    ds = read_dataset(tmp_path / "pq")
    from hydropwa.data import read_run

    np.testing.assert_array_equal(read_run(out)["p_b"], ds["step_01"]["p_b"])
