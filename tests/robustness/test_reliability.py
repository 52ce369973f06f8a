"""Nothing overwritten, nothing read from outside a dataset, every failure one line (issue 20).

One section per class of failure: data loss, path escape, OSError, malformed input,
silently accepted input; and valid input that must keep working. Commands run in-process
through ``hydropwa.cli.main`` (``_fuzzutil.run_cli``) and are held to the CLI contract.
"""

from __future__ import annotations

import errno
import json
import os
import re
import tempfile

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
import scipy.io
from _fuzzutil import cli_violation, run_cli

from hydropwa import DataError, HydropwaError, ParameterError
from hydropwa._errors import OutputExistsError, OutputLockedError
from hydropwa._io import LOCK_NAME, atomic_path, atomic_write_text, output_lock
from hydropwa.data import (
    Run,
    check_dataset,
    convert,
    read_dataset,
    read_run,
    write_dataset,
    write_run,
)
from hydropwa.sweep import SweepJournal, check_scheduler, load_sweep, parse_sweep, run_sweep


def _run(name="r", n=64) -> Run:
    t = np.arange(n) / 1000.0
    return Run(
        name=name,
        channels={
            "t": t,
            "u": 0.3 * np.sin(40 * t),
            "x": 0.1 + 0.01 * t,
            "p_a": np.full(n, 50e5),
            "p_b": np.linspace(30e5, 31e5, n),
        },
        fs=1000.0,
        meta={"kind": "sine"},
    )


def cli(tmp_path, *argv):
    """Run a command; assert the CLI contract; return (code, stdout, the error line or '')."""
    code, out, err = run_cli(list(argv), tmp_path)
    problem = cli_violation(list(argv), code, out, err)
    assert problem is None, f"hydropwa {argv}: {problem}\n{err}"
    line = next((ln for ln in err.splitlines() if ln.startswith("error: ")), "")
    return code, out, line


SWEEP = 'base = "paper"\n[grid]\n"load.mass" = [1.0, 2.0, 3.0, 4.0]\n[input]\nduration = 0.02\nmodel = "reduced"\nfs = 500\n'


# ============================================================================ data loss
def test_convert_refuses_an_existing_file_and_force_replaces_it(tmp_path):
    src = write_run(_run(), tmp_path / "a.csv")
    dst = tmp_path / "b.parquet"
    dst.write_bytes(b"precious")
    code, _, line = cli(tmp_path, "data", "convert", "a.csv", "b.parquet")
    assert code == 2 and "b.parquet" in line and "--force" in line
    assert dst.read_bytes() == b"precious"
    with pytest.raises(DataError, match="exists"):
        convert(src, dst)
    code, _, _ = cli(tmp_path, "data", "convert", "a.csv", "b.parquet", "--force")
    assert code == 0
    np.testing.assert_array_equal(read_run(dst)["x"], _run()["x"])


def test_convert_refuses_a_non_empty_folder(tmp_path):
    write_dataset([_run()], tmp_path / "ds")
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "notes.txt").write_text("mine")
    code, _, line = cli(tmp_path, "data", "convert", "ds", "out")
    assert code == 2 and "not empty" in line
    assert (tmp_path / "out" / "notes.txt").read_text() == "mine"


def test_atomic_no_clobber_refuses_and_leaves_no_temp(tmp_path):
    target = tmp_path / "t.txt"
    target.write_text("old")
    with pytest.raises(OutputExistsError):
        atomic_write_text(target, "new", overwrite=False)
    # the target appears while the file is written: still refused, nothing replaced
    late = tmp_path / "late.txt"
    with pytest.raises(OutputExistsError), atomic_path(late, overwrite=False) as tmp:
        tmp.write_text("new")
        late.write_text("other writer")
    assert target.read_text() == "old" and late.read_text() == "other writer"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["late.txt", "t.txt"]


@pytest.mark.parametrize(
    "argv, victim",
    [
        (["identify", "frf", "nowhere", "--out", "id.toml", "--summary", "keep.md"], "keep.md"),
        (["identify", "frf", "nowhere", "--out", "keep.toml"], "keep.toml"),
        (["identify", "emps", "keep.mat", "--summary", "keep.md"], "keep.md"),
        (
            ["linearize", "-p", "paper", "--out", "new.json", "--figures", "keepdir"],
            "keepdir/fig01_cq.png",
        ),
        (
            ["linearize", "-p", "paper", "--out", "new.json", "--tables", "keepdir"],
            "keepdir/V_friction.csv",
        ),
        (
            [
                "simulate",
                "-p",
                "paper",
                "--duration",
                "0.02",
                "--out",
                "new.csv",
                "--plot",
                "keep.png",
            ],
            "keep.png",
        ),
        (["params", "export", "--out", "keep.toml"], "keep.toml"),
        (
            ["sweep", "spec.toml", "-q", "--out", "new.csv", "--trajectories", "keepdir"],
            "keepdir/case_00001.parquet",
        ),
        (["sweep", "spec.toml", "-q", "--out", "keep.csv"], "keep.csv"),
        (
            ["identify", "frf", "nowhere", "--out", "id.toml", "--figures", "keepdir"],
            "keepdir/fig05_valve_bode.png",
        ),
    ],
)
def test_every_writer_refuses_existing_output_without_force(tmp_path, argv, victim):
    for name in ("keep.md", "keep.toml", "keep.png", "keep.csv", victim):
        (tmp_path / name).parent.mkdir(exist_ok=True)
        (tmp_path / name).write_bytes(b"precious " + name.encode())
    (tmp_path / "keep.mat").write_bytes(b"x")  # emps: the summary check comes before the read
    (tmp_path / "spec.toml").write_text(SWEEP)
    code, _, line = cli(tmp_path, *argv)
    assert code == 2, line
    assert "--force" in line and victim.split("/")[0] in line
    assert (tmp_path / victim).read_bytes() == b"precious " + victim.encode()


def test_a_figures_folder_may_hold_other_files(tmp_path):
    """Only the files a command writes need --force: one folder collects several commands' figures."""
    (tmp_path / "figs").mkdir()
    (tmp_path / "figs" / "fig05_valve_bode.png").write_bytes(b"from identify")
    code, _, line = cli(
        tmp_path, "linearize", "-p", "paper", "--out", "l.json", "--figures", "figs"
    )
    assert code == 0, line
    assert (tmp_path / "figs" / "fig05_valve_bode.png").read_bytes() == b"from identify"
    assert (tmp_path / "figs" / "fig01_cq.png").is_file()
    code, _, line = cli(
        tmp_path, "linearize", "-p", "paper", "--out", "l2.json", "--figures", "figs"
    )
    assert code == 2 and "fig01_cq" in line


def test_sweep_keeps_finished_cases_and_resumes(tmp_path):
    spec = parse_sweep(
        {
            "base": "paper",
            "grid": {"load.mass": [1.0, 2.0, 3.0, 4.0]},
            "input": {"duration": 0.02, "model": "reduced", "fs": 500},
        }
    )
    full = run_sweep(spec, jobs=1)
    seen = []

    def stop_after_two(done, total):
        seen.append(done)
        if done == 2:
            raise KeyboardInterrupt

    journal = tmp_path / "j.jsonl"
    with pytest.raises(KeyboardInterrupt):
        run_sweep(
            spec, jobs=1, journal=journal, trajectories=tmp_path / "traj", progress=stop_after_two
        )
    kept = SweepJournal(journal, spec).rows
    assert sorted(kept) == [0, 1]  # the two finished cases survived the interrupt
    assert sorted(p.name for p in (tmp_path / "traj").iterdir()) == [
        "case_00000.parquet",
        "case_00001.parquet",
    ]
    ran = []
    resumed = run_sweep(
        spec,
        jobs=1,
        journal=journal,
        trajectories=tmp_path / "traj",
        progress=lambda d, t: ran.append(d),
    )
    assert ran == [2, 3, 4]  # started at 2 finished, ran only the other two
    cols = [c for c in full.columns if c != "wall_time"]
    pd.testing.assert_frame_equal(resumed[cols], full[cols], check_dtype=False)


def test_sweep_cli_resumes_after_interrupt_and_refuses_another_sweeps_journal(tmp_path):
    (tmp_path / "spec.toml").write_text(SWEEP)
    spec = load_sweep(tmp_path / "spec.toml")
    journal = SweepJournal(tmp_path / ".s.csv.sweep.jsonl", spec)
    row = run_sweep(
        parse_sweep(
            {
                "base": "paper",
                "grid": {"load.mass": [1.0]},
                "input": {"duration": 0.02, "model": "reduced", "fs": 500},
            }
        )
    ).iloc[0]
    journal.add(
        [{**row.to_dict(), "case": 0, "final_x": 123.0}]
    )  # marked: must be reused, not rerun
    code, _, _ = cli(tmp_path, "sweep", "spec.toml", "-q", "--out", "s.csv")
    assert code == 0
    table = pd.read_csv(tmp_path / "s.csv")
    assert table["final_x"].iloc[0] == 123.0 and len(table) == 4
    assert not (tmp_path / ".s.csv.sweep.jsonl").exists()
    (tmp_path / "other.toml").write_text(SWEEP.replace("4.0]", "5.0]"))
    SweepJournal(tmp_path / ".t.csv.sweep.jsonl", spec)
    code, _, line = cli(tmp_path, "sweep", "other.toml", "-q", "--out", "t.csv")
    assert code == 2 and "another sweep" in line and "--force" in line


def test_lock_keeps_a_second_run_out_and_a_stale_lock_is_taken_over(tmp_path):
    with output_lock(tmp_path), pytest.raises(OutputLockedError, match=f"process {os.getpid()}"):
        with output_lock(tmp_path):
            pass
    assert not (tmp_path / LOCK_NAME).exists()
    # a lock file left by a killed run (no process holds it) is stale
    (tmp_path / LOCK_NAME).write_text(json.dumps({"pid": 999999, "host": "x", "started": "then"}))
    with output_lock(tmp_path) as path:
        assert json.loads(path.read_text())["pid"] == os.getpid()


def test_paper_refuses_a_folder_another_run_holds(tmp_path):
    from hydropwa.studies.paper import run_paper_study

    with output_lock(tmp_path / "rep"), pytest.raises(OutputLockedError, match="another run"):
        run_paper_study(tmp_path / "rep", progress=False)


def test_stale_temp_files_of_a_killed_writer_are_removed(tmp_path):
    (tmp_path / "figures").mkdir()
    stale = tmp_path / "figures" / ".fig1.png.k3j_9xq2.tmp.png"
    stale.write_bytes(b"half a png")
    kept = tmp_path / "figures" / ".gitignore"
    kept.write_text("x")
    with output_lock(tmp_path):
        pass
    assert not stale.exists() and kept.exists()


# ============================================================================ path escape
@pytest.fixture
def outside(tmp_path):
    return write_run(_run("secret"), tmp_path / "secret" / "secret.csv")


def _manifest(root, file):
    root.mkdir(parents=True, exist_ok=True)
    entry = {"name": "r", "file": file, "format": "csv"}
    (root / "manifest.json").write_text(
        json.dumps({"format": "hydropwa-dataset", "format_version": 1, "meta": {}, "runs": [entry]})
    )
    return root


@pytest.mark.parametrize("how", ["dotdot", "absolute", "symlink", "symlinked-folder"])
def test_a_dataset_reads_nothing_outside_its_folder(tmp_path, outside, how):
    ds = tmp_path / "ds"
    if how == "dotdot":
        _manifest(ds, "../secret/secret.csv")
    elif how == "absolute":
        _manifest(ds, str(outside.resolve()))
    elif how == "symlink":
        _manifest(ds, "r.csv")
        (ds / "r.csv").symlink_to(outside)
    else:
        _manifest(ds, "sub/secret.csv")
        (ds / "sub").symlink_to(outside.parent)
    with pytest.raises(DataError, match="out of the dataset folder|absolute path"):
        read_dataset(ds)
    with pytest.raises(DataError):
        check_dataset(ds)
    with pytest.raises(DataError):
        convert(ds, tmp_path / "copy")
    assert not (tmp_path / "copy").exists()
    for argv in (
        ["data", "check", "ds"],
        ["data", "convert", "ds", "copy2"],
        ["paper", "--data", "ds", "-q"],
    ):
        code, _, line = cli(tmp_path, *argv)
        assert code == 2 and "dataset" in line, (argv, line)


def test_a_folder_of_raw_files_with_a_link_out_is_refused(tmp_path, outside):
    (tmp_path / "raw").mkdir()
    (tmp_path / "raw" / "a.csv").symlink_to(outside)
    with pytest.raises(DataError, match="out of the dataset folder"):
        check_dataset(tmp_path / "raw")


def test_a_run_name_cannot_write_outside_the_dataset(tmp_path):
    from hydropwa.data import Dataset

    ds = Dataset.create(tmp_path / "ds")
    with pytest.raises(DataError, match="run name"):
        ds.add_run(_run("../escaped"))
    assert not (tmp_path / "escaped.parquet").exists()


# ============================================================================ OSError
@pytest.mark.parametrize("code_", [errno.EROFS, errno.ENOSPC])
@pytest.mark.parametrize(
    "argv",
    [
        ["simulate", "-p", "paper", "--duration", "0.02", "--out", "o.csv"],
        ["params", "export", "--out", "p.toml"],
        ["data", "convert", "a.csv", "b.parquet"],
        ["linearize", "-p", "paper", "--out", "l.json"],
    ],
)
def test_read_only_and_full_disks_are_one_line_naming_the_file(tmp_path, monkeypatch, argv, code_):
    write_run(_run(), tmp_path / "a.csv")

    def broken(*args, **kwargs):
        raise OSError(code_, os.strerror(code_), kwargs.get("dir"))

    monkeypatch.setattr(tempfile, "mkstemp", broken)
    code, _, line = cli(tmp_path, *argv)
    assert code == 2
    target = argv[argv.index("--out") + 1] if "--out" in argv else argv[-1]
    assert target in line
    assert ("read-only" if code_ == errno.EROFS else "no space left") in line


def test_disk_full_while_writing_names_the_target_not_the_temp_file(tmp_path, monkeypatch):
    def full(src, dst):
        raise OSError(errno.ENOSPC, "No space left on device", str(src))

    monkeypatch.setattr(os, "replace", full)
    with pytest.raises(OSError) as info:
        atomic_write_text(tmp_path / "out.txt", "x")
    assert info.value.filename == str(tmp_path / "out.txt")
    assert list(tmp_path.iterdir()) == []  # the temporary file is gone


@pytest.mark.parametrize(
    "argv",
    [
        ["simulate", "-p", "paper", "--duration", "0.02", "--out", "afile/x.csv"],
        ["paper", "--out", "afile", "-q"],
        ["rig", "run", "frf", "-p", "paper", "--out", "afile", "-q"],
        ["sweep", "spec.toml", "-q", "--out", "s.csv", "--trajectories", "afile"],
        ["linearize", "-p", "paper", "--out", "l.json", "--figures", "afile"],
        ["data", "convert", "ds", "afile"],
    ],
)
def test_a_file_where_a_folder_is_expected_is_one_line(tmp_path, argv):
    (tmp_path / "afile").write_text("x")
    (tmp_path / "spec.toml").write_text(SWEEP)
    write_dataset([_run()], tmp_path / "ds")
    code, _, line = cli(tmp_path, *argv)
    assert code == 2 and "afile" in line and ("folder" in line or "a file" in line)


# ============================================================================ malformed input
@pytest.mark.parametrize(
    "content, expect",
    [
        (b"[]", "expected an object"),
        (
            json.dumps(
                {"format": "hydropwa-dataset", "runs": [{"file": "a.csv"}, {"name": "b"}]}
            ).encode(),
            'needs a "name"',
        ),
        (b'{"format": "\xff"}', "not UTF-8"),
        (b"[" * 100000 + b"]" * 100000, "nested too deeply"),
        (
            json.dumps(
                {
                    "format": "hydropwa-dataset",
                    "runs": [{"name": "a", "file": "a.csv", "fs": "fast"}],
                }
            ).encode(),
            "'fs'",
        ),
    ],
)
def test_malformed_manifests_are_one_clear_error(tmp_path, content, expect):
    (tmp_path / "ds").mkdir()
    (tmp_path / "ds" / "manifest.json").write_bytes(content)
    with pytest.raises(DataError, match=expect):
        read_dataset(tmp_path / "ds")
    code, _, line = cli(tmp_path, "data", "check", "ds")
    assert code == 2 and "manifest" in line


def test_every_manifest_problem_is_named(tmp_path):
    doc = {
        "format": "hydropwa-dataset",
        "runs": [{"name": "a", "file": "../x.csv"}, {"name": "a", "file": "y.txt"}, 5],
    }
    _manifest(tmp_path / "ds", "x")
    (tmp_path / "ds" / "manifest.json").write_text(json.dumps(doc))
    with pytest.raises(DataError) as info:
        read_dataset(tmp_path / "ds")
    msg = str(info.value)
    assert "4 problem(s)" in msg
    for part in (
        "out of the dataset folder",
        "also runs[0]'s",
        "no run-file suffix",
        "runs[2] is a JSON int",
    ):
        assert part in msg


@pytest.mark.parametrize(
    "text, expect",
    [
        ("[gird]\n'load.mass' = [1.0]\n", "unknown section 'gird'.*did you mean 'grid'"),
        ("[grid\n", "not valid TOML"),
        ("[random]\nn = 3\n'friction.coulomb' = {uniform = [40, 10]}\n", "needs a < b; swap"),
        ("[random]\nn = 3\n'load.mass' = {loguniform = [0, 2]}\n", "0 < a < b"),
        ("[grid]\n'load.mass' = []\n", "empty list"),
        ("[input]\nduration = 1\nduration = 2\n", "not valid TOML"),
        ("[input]\ndurration = 1\n", "did you mean 'duration'"),
        ("[input]\nrtol = 2\n", r"outside \[1e-12, 0.1\]"),
        ("[input]\nmodel = 'fast'\n", "choose full, reduced, pwa"),
        ("[input]\nu = 'sine:amplitude=0.4,amplitude=0.5'\n", "'amplitude' is given twice"),
        ("[input]\nsupply_pressure = '0 bar'\n", "greater than 0"),
        ("[input]\nduration = 1e9\nfs = 1e6\n", "samples, about .* of memory"),
        ("[random]\nn = 100000000\n'load.mass' = {uniform = [1, 2]}\n", "1e\\+08 cases"),
        ("[grid]\n'load.mass' = [-1.0]\n", "Load.mass"),
        ("[random]\nn = -1\n", "whole number"),
    ],
)
def test_sweep_specs_are_validated_up_front(tmp_path, text, expect):
    (tmp_path / "s.toml").write_text('base = "paper"\n' + text)
    with pytest.raises(HydropwaError, match=expect):
        load_sweep(tmp_path / "s.toml")
    code, _, line = cli(tmp_path, "sweep", "s.toml", "-q", "--out", "o.csv")
    assert code == 2 and "s.toml" in line


@pytest.mark.parametrize(
    "address, expect",
    [
        ("nonsense", "not a Dask scheduler address"),
        ("tcp://host:99999", "not a Dask scheduler address"),
        ("tcp://127.0.0.1:1", "cannot reach the scheduler"),
    ],
)
def test_scheduler_addresses_fail_fast(address, expect):
    with pytest.raises(ParameterError, match=expect):
        check_scheduler(address, timeout=2.0)


@pytest.mark.parametrize(
    "argv, expect",
    [
        (["rig", "run", "frf", "-p", "paper", "--out", "x", "--seed", "-1"], "--seed"),
        (["simulate", "--bogus"], "No such option: --bogus"),
        (["simulate", "-p", "paper", "--sample-time", "abc"], "--sample-time"),
        (["data", "check"], "Missing argument"),
        (["nosuch"], "No such command"),
        (["simulate", "-p", "paper", "--duration", "1e9", "--out", "o.csv"], "samples, about"),
        (["simulate", "-p", "paper", "--sample-time", "1e-12", "--out", "o.csv"], "samples, about"),
        (
            ["simulate", "-p", "paper", "--duration", "1e-6", "--out", "o.csv"],
            "fewer than two output samples",
        ),
        (
            ["simulate", "-p", "paper", "--duration", "1e308", "--out", "o.csv"],
            "more output samples than can be counted",
        ),
        (
            ["simulate", "-p", "paper", "--duration", "0.02", "--plot", "x.xyz", "--out", "o.csv"],
            "--plot x.xyz must end in",
        ),
        (["sweep", "spec.toml", "--out", "x.txt"], "--out x.txt must end in .csv or .parquet"),
        (["params", "show", "deep.toml"], "nested too deeply|deep.toml"),
        (
            ["rig", "run", "frf", "-p", "paper", "--campaign", "binary.toml", "--out", "x"],
            r"binary.toml is not UTF-8 text \(byte 0xff at offset 0\): save it as UTF-8",
        ),
        (
            ["data", "check", "r.csv", "--channel-map", "binary.toml"],
            r"binary.toml is not UTF-8 text \(byte 0xff at offset 0\)",
        ),
        (
            ["rig", "run", "frf", "-p", "paper", "--campaign", "deep.toml", "--out", "x"],
            "deep.toml: nested too deeply",
        ),
    ],
)
def test_bad_arguments_are_one_error_line(tmp_path, argv, expect):
    (tmp_path / "deep.toml").write_text("a = " + "[" * 5000 + "]" * 5000 + "\n")
    (tmp_path / "binary.toml").write_bytes(b"\xff\xfe junk")
    write_run(_run(), tmp_path / "r.csv")
    (tmp_path / "spec.toml").write_text(SWEEP)
    code, _, line = cli(tmp_path, *argv)
    assert code == 2
    assert re.search(expect, line), line


# ============================================================================ silent acceptance
@pytest.mark.parametrize(
    "value, expect",
    [
        ("-5 bar", "greater than 0"),
        ("0 bar", "greater than 0"),
        ("1e9 bar", "at most 1e\\+09 Pa"),
        ("step:after=-1e6", "greater than 0"),
    ],
)
def test_cli_quantities_get_the_parameter_bounds(tmp_path, value, expect):
    for argv in (
        [
            "simulate",
            "-p",
            "paper",
            "--duration",
            "0.02",
            "--out",
            "o.csv",
            "--supply-pressure",
            value,
        ],
        ["linearize", "-p", "paper", "--out", "l.json", "--supply-pressure", value],
    ):
        if argv[0] == "linearize" and ":" in value:
            continue
        code, _, line = cli(tmp_path, *argv)
        assert code == 2 and "--supply-pressure" in line and re.search(expect, line), line
    assert not (tmp_path / "o.csv").exists()


@pytest.mark.parametrize("rtol", ["-1", "2", "0"])
def test_rtol_out_of_range_is_refused(tmp_path, rtol):
    code, _, line = cli(
        tmp_path, "simulate", "-p", "paper", "--duration", "0.02", "--out", "o.csv", "--rtol", rtol
    )
    assert code == 2 and "--rtol" in line


def test_x0_off_the_stroke_is_refused(tmp_path):
    code, _, line = cli(
        tmp_path, "simulate", "-p", "paper", "--duration", "0.02", "--out", "o.csv", "--x0", "5 m"
    )
    assert code == 2 and "off the stroke" in line


@pytest.mark.parametrize("unit, scale", [("ms", 1e-3), ("us", 1e-6), ("ns", 1e-9)])
def test_parquet_timestamp_time_base_is_seconds(tmp_path, unit, scale):
    n = 50
    per_s = round(1 / scale)
    ticks = 1_700_000_000 * per_s + np.arange(n, dtype="int64") * (per_s // 1000)
    table = pa.table(
        {"t": pa.array(ticks, type=pa.timestamp(unit)), "x": pa.array(np.linspace(0.1, 0.2, n))}
    )
    pq.write_table(table, tmp_path / "ts.parquet")
    run = read_run(tmp_path / "ts.parquet", validate=False)
    np.testing.assert_allclose(run.t, np.arange(n) * 1e-3, rtol=0, atol=1e-9)
    assert run.fs == pytest.approx(1000.0)


@pytest.mark.parametrize("dst, fmt", [("b.parquet", "csv"), ("b.dat", "csv"), ("b.csv", "mat")])
def test_convert_output_format_follows_the_suffix(tmp_path, dst, fmt):
    write_run(_run(), tmp_path / "a.csv")
    code, _, line = cli(tmp_path, "data", "convert", "a.csv", dst, "--format", fmt)
    assert code == 2 and dst in line and "suffix" in line
    assert not (tmp_path / dst).exists()


def test_complex_mat_channels_are_refused(tmp_path):
    write_run(_run(), tmp_path / "r.mat")
    data = scipy.io.loadmat(tmp_path / "r.mat")
    data["x"] = data["x"] + 1j * 0.5
    scipy.io.savemat(tmp_path / "c.mat", {k: v for k, v in data.items() if not k.startswith("__")})
    with pytest.raises(DataError, match="complex"):
        read_run(tmp_path / "c.mat")


def test_a_byte_order_mark_is_not_part_of_the_csv(tmp_path):
    path = write_run(_run(), tmp_path / "r.csv")
    bom = tmp_path / "bom.csv"
    bom.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    a, b = read_run(path), read_run(bom)
    assert b.name == a.name and b.fs == a.fs
    for ch in a.channels:
        np.testing.assert_array_equal(b[ch], a[ch])


# ============================================================================ valid input
def test_valid_commands_still_work(tmp_path):
    write_run(_run(), tmp_path / "a.csv")
    (tmp_path / "spec.toml").write_text(SWEEP)
    (tmp_path / "empty").mkdir()
    for argv in (
        ["data", "convert", "a.csv", "b.parquet"],
        ["data", "convert", "a.csv", "b.parquet", "--overwrite"],
        [
            "simulate",
            "--params",
            "paper",
            "--model",
            "reduced",
            "--duration",
            "0.05",
            "--sample-time",
            "2 ms",
            "--supply-pressure",
            "sine:offset=95e5,amplitude=5e5,frequency=2",
            "--out",
            "s.csv",
        ],
        ["linearize", "-p", "paper", "--out", "l.json", "--tables", "empty"],
        ["sweep", "spec.toml", "-q", "--out", "sw.parquet", "--trajectories", "traj"],
    ):
        code, _, line = cli(tmp_path, *argv)
        assert code == 0, (argv, line)
    assert len(pd.read_parquet(tmp_path / "sw.parquet")) == 4
    assert len(list((tmp_path / "traj").glob("case_*.parquet"))) == 4
    assert any(p.suffix == ".csv" for p in (tmp_path / "empty").iterdir())
    assert not any(p.name.endswith(".lock") or ".tmp" in p.name for p in tmp_path.rglob(".*"))


def test_a_case_lost_on_dask_keeps_the_finished_ones(tmp_path, monkeypatch):
    """A case that never comes back (here: its task fails on the worker, as a dead worker's
    KilledWorker does) is reported in one error after the others ran; they are journaled
    and a rerun runs only the lost one."""
    from dask.distributed import LocalCluster

    import hydropwa.sweep._run as sweep_run

    spec = parse_sweep(
        {
            "base": "paper",
            "grid": {"load.mass": [1.0, 2.0, 3.0, 4.0]},
            "input": {"duration": 0.02, "model": "reduced", "fs": 500},
        }
    )
    real = sweep_run.run_case

    def dies_on_case_2(spec_, case, keep_result=False):
        if case.index == 2:
            raise RuntimeError("worker lost")
        return real(spec_, case, keep_result)

    monkeypatch.setattr(sweep_run, "run_case", dies_on_case_2)  # threads: workers see the patch
    journal = tmp_path / "j.jsonl"
    with LocalCluster(
        n_workers=1, processes=False, protocol="tcp://", dashboard_address=None
    ) as cluster:
        with pytest.raises(
            HydropwaError, match=r"1 of 4 cases did not finish on Dask \(first: case 2"
        ):
            run_sweep(spec, scheduler=cluster.scheduler_address, journal=journal)
        assert sorted(SweepJournal(journal, spec).rows) == [0, 1, 3]
        monkeypatch.setattr(sweep_run, "run_case", real)
        ran = []
        table = run_sweep(
            spec,
            scheduler=cluster.scheduler_address,
            journal=journal,
            progress=lambda d, t: ran.append(d),
        )
    assert ran == [3, 4] and list(table["case"]) == [0, 1, 2, 3]


@pytest.mark.parametrize("how", ["SIGKILL", "SIGINT"], ids=["killed", "ctrl-c"])
def test_sweep_killed_or_interrupted_keeps_finished_cases_and_resumes(tmp_path, how):
    """`hydropwa sweep` in a subprocess, stopped once some cases are journaled; the rerun runs
    only the rest, and its table equals an uninterrupted one (apart from wall time)."""
    import signal
    import subprocess
    import sys
    import time

    (tmp_path / "spec.toml").write_text(
        'base = "paper"\n[grid]\n"load.mass" = [1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5]\n"supply.pressure" = ["80 bar", "100 bar"]\n'
        '[input]\nduration = 0.5\nmodel = "full"\nfs = 200\nrtol = 1e-5\n'
    )
    argv = [
        sys.executable,
        "-m",
        "hydropwa",
        "sweep",
        "spec.toml",
        "-q",
        "--jobs",
        "1",
        "--out",
        "s.csv",
        "--trajectories",
        "traj",
    ]
    proc = subprocess.Popen(
        argv,
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    journal = tmp_path / ".s.csv.sweep.jsonl"
    t0 = time.monotonic()
    while time.monotonic() - t0 < 300:
        if proc.poll() is not None:
            pytest.fail(f"the sweep ended (code {proc.returncode}) before it could be stopped")
        if journal.is_file() and len(journal.read_text().splitlines()) >= 3:  # header + 2 cases
            break
        time.sleep(0.01)
    os.killpg(proc.pid, getattr(signal, how))
    _, err = proc.communicate(timeout=120)
    if how == "SIGINT":
        assert proc.returncode == 130 and err.decode().strip().splitlines()[-1].startswith(
            "error: interrupted"
        )
    kept = [
        json.loads(line)["case"]
        for line in journal.read_text().splitlines()[1:]
        if line.endswith("}")
    ]
    assert len(kept) >= 2 and not (tmp_path / "s.csv").exists()
    stamps = {}
    for case in kept:  # every journaled case has its complete trajectory
        path = tmp_path / "traj" / f"case_{case:05d}.parquet"
        assert len(pd.read_parquet(path)) == 101
        stamps[path] = path.stat().st_mtime_ns
    done = subprocess.run(argv, cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert all(p.stat().st_mtime_ns == t for p, t in stamps.items())  # finished cases not rerun
    table = pd.read_csv(tmp_path / "s.csv")
    assert list(table["case"]) == list(range(16)) and not journal.exists()
    reference = run_sweep(load_sweep(tmp_path / "spec.toml"), jobs=1)
    cols = [c for c in reference.columns if c != "wall_time"]
    pd.testing.assert_frame_equal(table[cols], reference[cols], check_dtype=False, check_exact=True)


def test_more_workers_than_four_per_core_are_refused(tmp_path):
    jobs = str(4 * (os.cpu_count() or 1) + 1)
    (tmp_path / "spec.toml").write_text(SWEEP)
    for argv in (
        ["sweep", "spec.toml", "-q", "--out", "o.csv", "--jobs", jobs],
        ["rig", "run", "frf", "-p", "paper", "--out", "rig", "--jobs", jobs],
    ):
        code, _, line = cli(tmp_path, *argv)
        assert code == 2 and "--jobs" in line, line
    assert not (tmp_path / "rig").exists()
