"""The reliability audit's classes (issue 49, item 7), each checked on several representatives.

1. every file read has a size ceiling per kind, and a structural one where size is not the
   issue (gain rows, manifest runs); 2. every text file is UTF-8 (a BOM allowed), anything
   else is one line naming the byte; 3. every numeric option is range-checked before the
   command runs; 4. every output is locked while a command writes it; 5. a scheduler address
   is refused in one line (unsupported scheme, silent or dead address) instead of hanging;
   6. temporary folders a killed run left are removed by the next run; 7. a dataset may not
   read a file linked from outside it, and a fit refuses data that excite nothing.

Each CLI case runs in-process and must end with exit 2 and exactly one ``error:`` line (the
contract of ``_fuzzutil.cli_violation``); every check happens before any simulation.
"""

from __future__ import annotations

import json
import os
import re
import socket
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import typer
from _fuzzutil import cli_violation, run_cli

from hydropwa._dask import dask_client
from hydropwa._errors import DataError, IdentificationError, ParameterError
from hydropwa._io import (
    READ_LIMITS,
    SCRATCH_GRACE_S,
    read_text,
    remove_stale_scratch,
    scratch_folder,
    target_lock,
)
from hydropwa.cli import app
from hydropwa.cli._options import NUMBER_RANGES, OUTPUT_OPTIONS
from hydropwa.control import ControlError, load_controller
from hydropwa.data import MANIFEST, ChannelMap, Run, write_dataset
from hydropwa.identification import recorded_machine
from hydropwa.identification.greybox.estimator import MIN_EXCITATION, check_excitation
from hydropwa.params import get_preset, load_params, save_params


def refused(argv: list[str], cwd: Path) -> str:
    """Run the command; it must exit 2 with one ``error:`` line, which is returned."""
    code, out, err = run_cli([str(a) for a in argv], cwd)
    problem = cli_violation(argv, code, out, err)
    assert problem is None, f"{argv}: {problem}; stderr: {err[-400:]}"
    assert code == 2, f"{argv}: exit {code}, expected 2; stderr: {err[-400:]}"
    (line,) = [ln for ln in err.splitlines() if ln.startswith("error: ")]
    return line


def sparse(path: Path, size: int) -> Path:
    """A file of ``size`` bytes that takes no disk (the ceiling is checked before reading)."""
    with open(path, "wb") as fh:
        fh.truncate(size)
    return path


def _params_file(tmp_path: Path) -> Path:
    return save_params(get_preset("paper"), tmp_path / "m.toml")


def _dataset(tmp_path: Path, name: str = "ds", u=None) -> Path:
    t = np.arange(0.0, 0.2, 1e-3)
    u = np.zeros_like(t) if u is None else u(t)
    run = Run(
        "r0",
        {"t": t, "u": u, "x": 0.1 + 0 * t, "p_a": 5e6 + 0 * t, "p_b": 5e6 + 0 * t},
        meta={"kind": "step"},
    )
    write_dataset([run], tmp_path / name, format="csv")
    return tmp_path / name


# ----------------------------------------------------------------------------- 1. sizes
def _size(limit_kind: str) -> int:
    return READ_LIMITS[limit_kind][0] + 1


@pytest.mark.parametrize(
    "kind, argv",
    [
        ("parameter file", ["params", "show", "{f}"]),
        ("parameter file", ["simulate", "--params", "{f}", "--out", "o.csv"]),
        (
            "controller file",
            [
                "control",
                "simulate",
                "--controller",
                "{f}",
                "--reference",
                "steps:0=0.1",
                "--params",
                "paper",
            ],
        ),  # fmt: skip
        ("controller file", ["control", "export", "{f}", "--c", "c_out"]),
        ("sweep file", ["sweep", "{f}", "--out", "s.csv"]),
        (
            "campaign file",
            ["rig", "run", "frf", "--params", "paper", "--campaign", "{f}", "--out", "rig"],
        ),  # fmt: skip
        (
            "measurement file",
            ["simulate", "--params", "paper", "--input-file", "{f}", "--out", "o.csv"],
        ),  # fmt: skip
    ],
)
def test_a_file_above_its_kinds_ceiling_is_one_line(tmp_path, kind, argv):
    suffix = ".csv" if kind == "measurement file" else ".toml"
    f = sparse(tmp_path / f"big{suffix}", _size(kind))
    line = refused([a.replace("{f}", str(f)) for a in argv], tmp_path)
    assert f"the {kind} is" in line and "more than the" in line and str(f) in line


def test_a_manifest_above_its_ceiling_is_one_line(tmp_path):
    (tmp_path / "ds").mkdir()
    sparse(tmp_path / "ds" / MANIFEST, _size("manifest"))
    assert "the manifest is" in refused(["data", "check", tmp_path / "ds"], tmp_path)


@pytest.mark.parametrize(
    "reader, kind, error",
    [
        (ChannelMap.from_toml, "channel map", DataError),
        (load_params, "parameter file", ParameterError),
        (load_controller, "controller file", ControlError),
    ],
)
def test_the_api_readers_share_the_ceiling(tmp_path, reader, kind, error):
    f = sparse(tmp_path / "big.toml", _size(kind))
    with pytest.raises(error, match=f"the {kind} is .* more than the"):
        reader(f)


def test_the_ceiling_is_checked_on_the_bytes_read_too(tmp_path):
    """A size the file system does not report (a FIFO, a device) is bounded by the read."""
    fifo = tmp_path / "pipe.toml"
    os.mkfifo(fifo)
    limit = READ_LIMITS["parameter file"][0]

    def feed():
        with open(fifo, "wb") as fh:
            fh.write(b"#" * (limit + 10))

    writer = threading.Thread(target=feed, daemon=True)
    writer.start()
    with pytest.raises(ParameterError, match="more than the 1 MB"):
        read_text(fifo, "parameter file", ParameterError)
    writer.join(5)


def _controller_doc(rows: int) -> dict:
    row = {
        "lower": {"x": 0.0, "v": -1.0, "p_l": -1e7},
        "upper": {"x": 0.2, "v": 1.0, "p_l": 1e7},
    }
    return {
        "schema": "hydropwa.controller/1",
        "kind": "state_feedback",
        "sample_time": 1e-3,
        "cells": [row] * rows,
    }


def test_a_controller_with_more_gain_rows_than_a_pwa_model_has_is_refused(tmp_path):
    """140 000 rows hung `control simulate` and `control export`; the ceiling is 5000."""
    from hydropwa.control._io import MAX_GAIN_ROWS

    f = tmp_path / "huge.json"
    f.write_text(json.dumps(_controller_doc(MAX_GAIN_ROWS + 1)))
    assert f.stat().st_size < READ_LIMITS["controller file"][0]  # the row count decides
    t0 = time.perf_counter()
    line = refused(["control", "export", f, "--c", "c_out"], tmp_path)
    assert f"{MAX_GAIN_ROWS + 1} gain rows, more than the {MAX_GAIN_ROWS}" in line
    assert time.perf_counter() - t0 < 30.0


def test_a_manifest_with_too_many_runs_is_refused_before_its_entries(tmp_path):
    from hydropwa.data._dataset import MAX_RUNS

    root = tmp_path / "ds"
    root.mkdir()
    runs = [{"name": f"r{i}", "file": f"r{i}.csv"} for i in range(MAX_RUNS + 1)]
    doc = {"format": "hydropwa-dataset", "format_version": 1, "runs": runs}
    (root / MANIFEST).write_text(json.dumps(doc))
    line = refused(["data", "check", root], tmp_path)
    assert f"lists {MAX_RUNS + 1} runs, more than the {MAX_RUNS}" in line


# ----------------------------------------------------------------------------- 2. decoding
_NOT_UTF8 = re.compile(
    r"is not UTF-8 text \(byte 0x([0-9a-f]{2}) at offset (\d+)\): save it as UTF-8"
)


@pytest.mark.parametrize(
    "name, text, argv",
    [
        ("m.toml", '# Maschine für Prüfstand\nbase = "paper"\n', ["params", "show", "{f}"]),
        ("m.json", '{"base": "paper", "note": "é"}', ["params", "show", "{f}"]),
        (
            "c.toml",
            'schema = "hydropwa.controller/2"  # Regler für Achse é\n',
            [
                "control",
                "simulate",
                "--controller",
                "{f}",
                "--reference",
                "steps:0=0.1",
                "--params",
                "paper",
            ],
        ),  # fmt: skip
        ("c.toml", "# é\n", ["control", "export", "{f}", "--c", "c_out"]),
        ("s.toml", 'base = "paper"  # é\n', ["sweep", "{f}", "--out", "s.csv"]),
        (
            "r.csv",
            "t,u\n0,0\n# é\n",
            ["simulate", "--params", "paper", "--input-file", "{f}", "--out", "o.csv"],
        ),  # fmt: skip
        (
            "k.toml",
            "# é\n",
            ["rig", "run", "frf", "--params", "paper", "--campaign", "{f}", "--out", "rig"],
        ),  # fmt: skip
    ],
)
def test_a_latin1_file_is_one_line_naming_the_byte(tmp_path, name, text, argv):
    f = tmp_path / name
    f.write_bytes(text.encode("latin-1"))
    line = refused([a.replace("{f}", str(f)) for a in argv], tmp_path)
    m = _NOT_UTF8.search(line)
    assert m, line
    assert str(f) in line
    byte, offset = int(m.group(1), 16), int(m.group(2))
    data = f.read_bytes()
    assert data[offset] == byte and byte in "üéä".encode("latin-1")  # it names the byte
    assert data[:offset].decode("utf-8")  # and the first one that is not UTF-8


def test_a_latin1_manifest_and_channel_map_are_one_line(tmp_path):
    root = _dataset(tmp_path)
    manifest = root / MANIFEST
    doc = json.loads(manifest.read_text())
    doc["meta"] = {"rig": "Prüfstand"}
    manifest.write_bytes(json.dumps(doc, ensure_ascii=False).encode("latin-1"))
    assert _NOT_UTF8.search(refused(["data", "check", root], tmp_path))
    cmap = tmp_path / "map.toml"
    cmap.write_bytes("# Kanäle\n".encode("latin-1"))
    with pytest.raises(DataError, match=_NOT_UTF8.pattern):
        ChannelMap.from_toml(cmap)


def test_a_byte_order_mark_is_allowed(tmp_path):
    f = _params_file(tmp_path)
    text = f.read_text(encoding="utf-8")
    f.write_bytes(b"\xef\xbb\xbf" + text.encode("utf-8"))
    assert load_params(f) == load_params(_params_file(tmp_path / "plain"))
    code, _out, err = run_cli(["params", "show", str(f)], tmp_path)
    assert code == 0, err


# ----------------------------------------------------------------------------- 3. numbers
@pytest.mark.parametrize(
    "argv, option",
    [
        *[
            (["export", "fmu", "--params", "paper", "--rtol", v, "--out", "a.fmu"], "--rtol")
            for v in ("0", "-1", "2", "1e-20", "nan", "inf")
        ],
        *[
            (["simulate", "--params", "paper", "--rtol", v, "--out", "o.csv"], "--rtol")
            for v in ("0", "0.5", "-inf")
        ],
        *[
            (
                ["simulate", "--params", "paper", "--sample-time", v, "--out", "o.csv"],
                "--sample-time",
            )
            for v in ("", " ", "0", "-1 ms", "nan", "0 Hz", "1e-20 s", "2 h")
        ],  # fmt: skip
        *[
            (["simulate", "--params", "paper", "--duration", v, "--out", "o.csv"], "--duration")
            for v in ("", "0", "-1 s", "inf", "nan", "1e400 s")
        ],
        (["simulate", "--params", "paper", "--x0", "-5 mm", "--out", "o.csv"], "--x0"),
        (["simulate", "--params", "paper", "--x0", "nan", "--out", "o.csv"], "--x0"),
        *[
            (["identify", "model", "{data}", "--free", "flow.K", "--out", "i.toml", opt, v], opt)
            for opt, v in (
                ("--starts", "0"),
                ("--starts", "-3"),
                ("--starts", "100000"),
                ("--window", "0"),
                ("--window", "nan"),
                ("--budget", "-1"),
                ("--validate", "1.5"),
                ("--validate", "nan"),
                ("--jobs", "0"),
            )
        ],  # fmt: skip
        (["control", "design", "--params", "paper", "--load-force", "nan"], "--load-force"),
        (["control", "design", "--params", "paper", "--load-force", "1e12 N"], "--load-force"),
        (
            ["simulate", "--params", "paper", "--supply-pressure", "inf", "--out", "o.csv"],
            "--supply-pressure",
        ),  # fmt: skip
        (["control", "design", "--params", "paper", "--draws", "0"], "--draws"),
        (["control", "design", "--params", "paper", "--seed", "-1"], "--seed"),
        (
            ["control", "design", "--params", "paper", "--dead-zone-hysteresis", "nan"],
            "--dead-zone-hysteresis",
        ),  # fmt: skip
    ],
)
def test_a_numeric_option_out_of_its_range_is_one_line(tmp_path, argv, option):
    (tmp_path / "data").mkdir()
    line = refused([a.replace("{data}", str(tmp_path / "data")) for a in argv], tmp_path)
    assert option in line
    assert not (tmp_path / "o.csv").exists() and not (tmp_path / "a.fmu").exists()


def test_an_fmu_start_position_off_the_stroke_is_refused(tmp_path):
    stroke = get_preset("paper").cylinder.stroke
    line = refused(
        ["export", "fmu", "--params", "paper", "--x0", f"{stroke * 1e3 + 1:g} mm"], tmp_path
    )
    assert "off the stroke" in line
    from hydropwa.simulation import export_axis_fmu

    with pytest.raises(ParameterError, match="off the stroke"):
        export_axis_fmu(get_preset("paper"), tmp_path / "a.fmu", initial_position=-0.01)
    with pytest.raises(ParameterError, match="rtol"):
        export_axis_fmu(get_preset("paper"), tmp_path / "a.fmu", rtol=0.0)


def _leaves(cmd, path=()):
    subs = getattr(cmd, "commands", None)
    if not subs:
        yield " ".join(path), cmd
        return
    for name, sub in subs.items():
        yield from _leaves(sub, (*path, name))


def _annotation(prm) -> str:
    return str(prm.type_descriptor.annotation)


#: Every option or argument typed as a path that is read, not written.
_INPUTS = {
    "--input-file", "--channel-map", "--pwa", "--noise-from", "--validation", "--controller",
    "source", "src", "data_dir", "file", "controller", "spec", "--data", "--reference",
    "data", "logs", "--plan",
}  # fmt: skip


def test_every_numeric_option_has_a_declared_range_and_every_path_a_role():
    """A new option typed int/float needs a row in NUMBER_RANGES; a new path option must be
    named an output (locked) or an input here."""
    root = typer.main.get_command(app)
    numeric, paths, seen = set(), set(), set()
    for _path, cmd in _leaves(root):
        for prm in cmd.params:
            name = ([o for o in prm.opts if o.startswith("--")] or list(prm.opts))[0]
            seen.add(name)
            ann = _annotation(prm)
            if re.search(r"\b(int|float)\b", ann) and not prm.is_flag:
                numeric.add(name)
            if "Path" in ann:
                paths.add(name)
    assert numeric - set(NUMBER_RANGES) == set()
    assert paths - OUTPUT_OPTIONS - _INPUTS == set()
    assert OUTPUT_OPTIONS <= seen and set(NUMBER_RANGES) <= seen  # no stale rows


def test_the_cli_rtol_range_is_simulates():
    from hydropwa.simulation._simulate import RTOL_RANGE

    rng = NUMBER_RANGES["--rtol"]
    assert (rng.low, rng.high) == RTOL_RANGE


# ----------------------------------------------------------------------------- 4. locks
def test_an_output_another_run_writes_is_refused(tmp_path):
    with target_lock(tmp_path / "run.csv"):
        line = refused(["simulate", "--params", "paper", "--out", "run.csv"], tmp_path)
    assert "run.csv: another run writes this output" in line
    assert not (tmp_path / "run.csv").exists()
    assert not list(tmp_path.glob(".*lock"))  # the lock file goes with its holder


def test_two_commands_into_one_out_meet_at_its_lock(tmp_path):
    """`identify frf` and `identify deadzone` into one --out: the second one is refused."""
    ds = _dataset(tmp_path)
    with target_lock(tmp_path / "i.toml"):
        line = refused(["identify", "deadzone", ds, "--params", "paper", "--out", "i.toml"],
                       tmp_path)  # fmt: skip
    assert "another run writes this output" in line


def test_a_lock_removes_the_temporary_files_a_killed_writer_left(tmp_path):
    left = tmp_path / ".run.csv.abcd1234.tmp.csv"
    other = tmp_path / ".other.csv.abcd1234.tmp.csv"
    left.write_text("half")
    other.write_text("half")
    with target_lock(tmp_path / "run.csv") as lock:
        assert lock is not None and lock.exists()
        assert not left.exists() and other.exists()  # only this output's
    assert not lock.exists()


def test_a_lock_leaves_no_folder_it_made_for_nothing(tmp_path):
    with target_lock(tmp_path / "a" / "b" / "run.csv"):
        assert (tmp_path / "a" / "b").is_dir()
    assert not (tmp_path / "a").exists()


_RACER = textwrap.dedent(
    """
    import sys, time
    from pathlib import Path
    import hydropwa.cli._core as core
    from hydropwa.cli import main

    write = core.save_params

    def slow(*args, **kwargs):  # hold the output long enough for the other run to meet it
        time.sleep(1.5)
        return write(*args, **kwargs)

    core.save_params = slow
    go = Path(sys.argv[1])
    Path(sys.argv[2]).touch()
    while not go.exists():
        time.sleep(0.01)
    sys.exit(main(["params", "export", "paper", "--out", "same.toml", "--force"]))
    """
)


def test_two_runs_into_one_out_at_once_one_succeeds(tmp_path):
    """Both passed the existence check and both wrote (with --force, even without it)."""
    script = tmp_path / "racer.py"
    script.write_text(_RACER)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    go = tmp_path / "go"
    procs = [
        subprocess.Popen(
            [sys.executable, str(script), str(go), str(tmp_path / f"ready{i}")],
            cwd=tmp_path,
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )  # fmt: skip
        for i in range(2)
    ]
    deadline = time.monotonic() + 120
    while not all((tmp_path / f"ready{i}").exists() for i in range(2)):
        assert time.monotonic() < deadline, "the racers did not start"
        time.sleep(0.05)
    go.touch()
    outs = [p.communicate(timeout=120) for p in procs]
    results = [(p.returncode, err) for p, (_out, err) in zip(procs, outs, strict=True)]
    codes = sorted(code for code, _ in results)
    assert codes == [0, 2], results
    loser = next(err for code, err in results if code == 2)
    assert "another run writes this output" in loser
    assert load_params(tmp_path / "same.toml") == get_preset("paper")


def test_identify_model_figures_into_an_occupied_folder_needs_force(tmp_path):
    figs = tmp_path / "figs"
    figs.mkdir()
    (figs / "greybox_r0.png").write_bytes(b"old")
    line = refused(
        ["identify", "model", tmp_path, "--free", "flow.K", "--figures", figs, "--out", "i.toml"],
        tmp_path,
    )
    assert "--figures" in line and "--force" in line
    assert (figs / "greybox_r0.png").read_bytes() == b"old"


# ----------------------------------------------------------------------------- 5. remote
def _spec(tmp_path: Path) -> Path:
    spec = tmp_path / "s.toml"
    spec.write_text(
        'base = "paper"\n[input]\nduration = 0.1\nmodel = "reduced"\n'
        '[grid]\n"supply.pressure" = ["80 bar", "90 bar"]\n'
    )
    return spec


@pytest.mark.parametrize(
    "address, why",
    [
        ("tls://127.0.0.1:8786", "scheme tls:// is not supported"),
        ("ws://127.0.0.1:8786", "scheme ws:// is not supported"),
        ("ucx://127.0.0.1:8786", "scheme ucx:// is not supported"),
        ("127.0.0.1", "not a Dask scheduler address"),
        ("127.0.0.1:0", "not a Dask scheduler address"),
        ("tcp://127.0.0.1:70000", "not a Dask scheduler address"),
    ],
)
def test_an_unsupported_scheduler_address_is_one_line(tmp_path, address, why):
    line = refused(["sweep", _spec(tmp_path), "--out", "s.csv", "--scheduler", address], tmp_path)
    assert why in line


@pytest.fixture
def silent_listener():
    """A port that accepts connections and never says a word (a dead service)."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)
    held = []

    def accept():
        while True:
            try:
                held.append(srv.accept()[0])
            except OSError:
                return

    threading.Thread(target=accept, daemon=True).start()
    yield f"tcp://127.0.0.1:{srv.getsockname()[1]}"
    srv.close()
    for c in held:
        c.close()


def test_a_silent_or_closed_scheduler_fails_within_the_timeout(silent_listener):
    """The silent one hung `Client(..., timeout=...)` for good; a closed port is refused."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        closed = f"127.0.0.1:{s.getsockname()[1]}"
    for address, why in ((silent_listener, "no answer within 1 s"), (closed, "cannot connect")):
        t0 = time.perf_counter()
        with (
            pytest.raises(ParameterError, match=re.escape(why)),
            dask_client(
                address,
                None,
                timeout_s=1.0,
                error=ParameterError,
                option="--scheduler",
                hint="run in-process",
            ),  # fmt: skip
        ):
            pass
        assert time.perf_counter() - t0 < 15.0


# ----------------------------------------------------------------------------- 6. temporaries
def test_a_scratch_folder_a_killed_run_left_is_removed_by_the_next(tmp_path):
    stale = tmp_path / "hydropwa-fmu-stale"
    stale.mkdir()
    (stale / "axis.so").write_bytes(b"half")
    young = tmp_path / "hydropwa-fmu-young"
    young.mkdir()
    other = tmp_path / "hydropwa-other-stale"
    other.mkdir()
    old = time.time() - 2 * SCRATCH_GRACE_S
    for folder in (stale, other):
        os.utime(folder, (old, old))
    with scratch_folder("fmu", root=tmp_path) as live:
        os.utime(live, (old, old))
        assert not stale.exists()  # its lock was free: the run that made it is gone
        assert young.exists() and other.exists()  # too young / another kind
        assert remove_stale_scratch("fmu", root=tmp_path) == []  # the live one is held
        assert live.is_dir()
    assert not live.exists()


def test_a_killed_process_leaves_a_scratch_folder_the_next_run_removes(tmp_path):
    code = (
        "import os, sys; from hydropwa._io import scratch_folder\n"
        "with scratch_folder('fmu', root=sys.argv[1]) as f:\n"
        "    print(f, flush=True); os.kill(os.getpid(), 9)\n"
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    proc = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path)], capture_output=True, text=True, env=env
    )
    left = Path(proc.stdout.strip())
    assert proc.returncode == -9 and left.is_dir()
    old = time.time() - 2 * SCRATCH_GRACE_S
    os.utime(left, (old, old))
    assert remove_stale_scratch("fmu", root=tmp_path) == [left]


# ----------------------------------------------------------------------------- 7. data safety
def test_a_machine_file_linked_from_outside_the_campaign_is_refused(tmp_path):
    outside = _params_file(tmp_path)
    campaign = tmp_path / "campaign"
    ds = _dataset(campaign, "frf", u=lambda t: 0.2 * np.sin(40 * t))
    (campaign / "true_params.toml").symlink_to(outside)
    with pytest.raises(DataError, match="leads out of"):
        recorded_machine(campaign)
    with pytest.raises(DataError, match="leads out of"):
        recorded_machine(ds)  # the parent's machine file, for one dataset of the campaign
    line = refused(["identify", "frf", campaign, "--out", "i.toml"], tmp_path)
    assert "true_params.toml" in line and "leads out of" in line


def test_a_machine_file_inside_the_campaign_is_read(tmp_path):
    campaign = tmp_path / "campaign"
    _dataset(campaign, "frf")
    _params_file(campaign).rename(campaign / "true_params.toml")
    assert recorded_machine(campaign)[0] == get_preset("paper")


def test_runs_that_excite_nothing_are_refused_in_one_line(tmp_path):
    """A constant valve command ended `identify model` in an internal NaN error."""
    ds = _dataset(tmp_path)
    line = refused(
        ["identify", "model", ds, "--params", "paper", "--free", "flow.K", "--out", "i.toml"],
        tmp_path,
    )
    assert "no run excites the axis" in line
    t = np.arange(0.0, 0.1, 1e-3)
    flat = Run("flat", {"t": t, "u": 0.3 + 0.2 * MIN_EXCITATION * np.sin(9 * t), "x": 0 * t})
    with pytest.raises(IdentificationError, match="varies by at most"):
        check_excitation([flat])
    step = Run("step", {"t": t, "u": np.where(t > 0.05, 0.2, 0.0), "x": 0 * t})
    check_excitation([flat, step])  # one run that moves the valve is enough
    steady = Run("steady", {"t": t, "u": 0.3 + 0 * t, "x": 0.05 + 0.01 * t})  # 1 mm travel
    check_excitation([steady])  # a constant command that moves the rod excites it
    still = Run("still", {"t": t, "u": 0.3 + 0 * t, "x": 0.05 + 5e-5 * np.sin(40 * t)})
    with pytest.raises(IdentificationError, match="rod travels less than 0.1 mm"):
        check_excitation([still])
