"""An interrupted `hydropwa paper` keeps what it finished and resumes from it (issue: nothing lost).

The study runs in a subprocess on the small test campaign. It is killed (SIGKILL, as a crash or
an OOM kill would) or interrupted (SIGINT, Ctrl-C) while the rig stage is writing runs; the
runs the dataset manifests list must load, and the rerun must reuse them byte for byte and
finish the report.
"""

from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

CAMPAIGN = Path(__file__).parents[1] / "evaluation" / "small_campaign.toml"


def _listed_runs(out: Path) -> dict[str, str]:
    """Run files listed by the dataset manifests under out/data, with their content hashes."""
    files = {}
    for manifest in (out / "data").glob("*/manifest.json"):
        try:
            doc = json.loads(manifest.read_text())
        except (json.JSONDecodeError, OSError):
            pytest.fail(f"{manifest} is not valid JSON after the interruption")
        for entry in doc.get("runs", []):
            path = manifest.parent / entry["file"]
            files[str(path)] = hashlib.sha256(path.read_bytes()).hexdigest()
    return files


def _foreground_sigint() -> None:
    """In the child before exec: Ctrl-C at its default, as for a job in the foreground of a terminal.

    A process started in the background by a non-interactive shell (``cmd &``, as CI runners
    and ``nohup`` do) has SIGINT ignored, and an ignored signal stays ignored across exec: the
    study then never saw the Ctrl-C, ran to the end and exited 0 with nothing on stderr.
    """
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _start(out: Path) -> subprocess.Popen:
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    return subprocess.Popen(
        [
            sys.executable,
            "-m",
            "hydropwa",
            "paper",
            "--out",
            str(out),
            "--campaign",
            str(CAMPAIGN),
            "-q",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
        start_new_session=True,  # its own process group, like a job in a terminal
        preexec_fn=_foreground_sigint,
    )


def _wait_for_runs(proc: subprocess.Popen, out: Path, n: int, timeout: float = 400.0) -> None:
    """Return once the datasets list ``n`` runs (the study is then inside its rig stage)."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        if proc.poll() is not None:
            pytest.fail(f"the study ended (code {proc.returncode}) before it could be interrupted")
        try:
            if len(_listed_runs(out)) >= n:
                return
        except (FileNotFoundError, KeyError):  # a manifest caught between writes
            pass
        time.sleep(0.01)
    pytest.fail(f"no {n} runs written within {timeout} s")


def _finish(out: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [
            sys.executable,
            "-m",
            "hydropwa",
            "paper",
            "--out",
            str(out),
            "--campaign",
            str(CAMPAIGN),
            "-q",
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )


@pytest.mark.parametrize("how", [signal.SIGKILL, signal.SIGINT], ids=["killed", "ctrl-c"])
def test_interrupted_paper_run_resumes_from_finished_runs(tmp_path, how):
    from hydropwa.data import read_dataset

    out = tmp_path / "report"
    proc = _start(out)
    try:
        _wait_for_runs(proc, out, n=4)
        # Ctrl-C reaches the whole foreground group; a crash or OOM kill hits the main process
        if how == signal.SIGINT:
            os.killpg(proc.pid, how)
        else:
            proc.send_signal(how)
        _, err = proc.communicate(timeout=120)  # returns only once no worker holds its pipes
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
    if how == signal.SIGINT:
        assert proc.returncode in (130, -signal.SIGINT), err.decode()
        assert b"Traceback" not in err
        if proc.returncode == 130:  # handled (a signal before Python's handler is set gives −2)
            assert b"interrupted; finished files are kept" in err, err.decode()
    else:
        assert proc.returncode == -signal.SIGKILL
    before = _listed_runs(out)
    assert before, "the interrupted run kept none of its finished runs"
    for ds in (out / "data").glob("*/manifest.json"):
        read_dataset(ds.parent, validate=False)  # every listed run loads
    assert not (out / "index.html").exists()

    done = _finish(out)
    assert done.returncode == 0, done.stderr
    after = _listed_runs(out)
    for path, digest in before.items():
        assert after.get(path) == digest, f"{path} was not reused as it was"
    assert (out / "index.html").exists() and (out / "identified.toml").exists()
