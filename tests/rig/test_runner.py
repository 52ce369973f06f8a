"""Datasets on disk: determinism per seed, --jobs, resume, --force, true parameters, CLI."""

from __future__ import annotations

import json

import pytest

from hydropwa import DataError, load_params
from hydropwa.cli import main
from hydropwa.data import check_dataset, read_dataset
from hydropwa.rig import TRUE_PARAMS, run_campaign, run_experiment


def _files(root):
    return {
        p.relative_to(root).as_posix(): p.read_bytes()
        for p in sorted(root.rglob("*"))
        if p.is_file()
    }


@pytest.fixture(scope="module")
def small_out(tmp_path_factory, rig, small_campaign):
    out = tmp_path_factory.mktemp("small")
    run_campaign(rig, small_campaign, out)
    return out


def test_campaign_layout_and_metadata(small_out, rig, small_campaign):
    assert (small_out / TRUE_PARAMS).is_file()
    assert load_params(small_out / TRUE_PARAMS) == rig.params
    for name, n in {"frf": 2, "deadzone": 4, "friction": 1, "sine": 1}.items():
        ds = read_dataset(small_out / name)
        assert len(ds) == n
        assert ds.meta["experiment"] == name and ds.meta["seed"] == small_campaign.seed
        assert ds.meta["true_params"]["supply"]["model"] == "pump"
        assert set(ds.meta["rig"]["sensors"]) == {"p_a", "p_b", "p_s", "x", "f_l", "spool"}
        assert check_dataset(ds) == []
        for run in ds:
            assert run.kind == name and "signal" in run.meta


def test_same_seed_gives_identical_files_and_jobs_do_not_matter(
    tmp_path, small_out, rig, small_campaign
):
    run_campaign(rig, small_campaign, tmp_path / "b", jobs=2)
    assert _files(tmp_path / "b") == _files(small_out)


def test_different_seed_gives_different_files(tmp_path, small_out, rig, small_campaign):
    run_experiment(rig, small_campaign["sine"], tmp_path, seed=small_campaign.seed + 1)
    a = (small_out / "sine" / "sine_f3_a20.parquet").read_bytes()
    b = (tmp_path / "sine" / "sine_f3_a20.parquet").read_bytes()
    assert a != b


def test_resume_skips_finished_runs(tmp_path, rig, small_campaign):
    exp = small_campaign["deadzone"]
    ds = run_experiment(rig, exp, tmp_path, seed=3)
    first = _files(tmp_path)
    # interrupt: drop the last run from the manifest and its file
    manifest = tmp_path / "deadzone" / "manifest.json"
    doc = json.loads(manifest.read_text())
    last = doc["runs"].pop()
    manifest.write_text(json.dumps(doc, indent=2) + "\n")
    (tmp_path / "deadzone" / last["file"]).unlink()
    keep = tmp_path / "deadzone" / doc["runs"][0]["file"]
    mtime = keep.stat().st_mtime_ns
    calls = []
    ds = run_experiment(rig, exp, tmp_path, seed=3, progress=lambda e, d, n: calls.append((d, n)))
    assert len(ds) == 4 and calls == [(4, 4)]  # only the missing run was simulated
    assert keep.stat().st_mtime_ns == mtime
    assert _files(tmp_path) == first


def test_other_settings_are_not_overwritten_without_force(tmp_path, rig, small_campaign):
    exp = small_campaign["sine"]
    run_experiment(rig, exp, tmp_path, seed=1)
    with pytest.raises(DataError, match="force"):
        run_experiment(rig, exp, tmp_path, seed=2)
    ds = run_experiment(rig, exp, tmp_path, seed=2, overwrite=True)
    assert ds.meta["seed"] == 2


def test_cli_runs_a_small_campaign(tmp_path, small_campaign_file, capsys):
    out = tmp_path / "cli"
    args = [
        "rig",
        "run",
        "all",
        "--params",
        "paper",
        "--campaign",
        str(small_campaign_file),
        "--out",
        str(out),
        "--quiet",
    ]
    assert main([*args, "--seed", "5"]) == 0
    assert "wrote 8 runs" in capsys.readouterr().out
    files = _files(out)
    assert main([*args, "--seed", "5", "--jobs", "2"]) == 0  # resume: nothing to do
    assert _files(out) == files
    capsys.readouterr()  # the resumed run's lines read out
    assert main([*args, "--seed", "6"]) == 2
    assert capsys.readouterr().err.startswith("error: ")
    assert main([*args, "--seed", "6", "--force"]) == 0
    assert _files(out) != files


def test_cli_single_experiment_and_params(tmp_path, small_campaign_file):
    out = tmp_path / "one"
    code = main(
        [
            "rig",
            "run",
            "sine",
            "-c",
            str(small_campaign_file),
            "-o",
            str(out),
            "-p",
            "symmetric",
            "-q",
        ]
    )
    assert code == 0
    assert sorted(p.name for p in out.iterdir()) == ["sine", TRUE_PARAMS]
    p = load_params(out / TRUE_PARAMS)
    assert p.cylinder.area_a == p.cylinder.area_b


def test_cli_bad_campaign_is_one_error_line(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("[sine]\nfrequencies = ['1 Hz']\namplitudes = ['200 %']\n")
    assert (
        main(["rig", "run", "sine", "-p", "paper", "-c", str(bad), "-o", str(tmp_path / "o")]) == 2
    )
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "amplitudes[0]" in err
