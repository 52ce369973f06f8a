"""The README's walkthrough runs as written, top to bottom, in an empty folder.

Every fenced ``python`` and ``bash`` block of README.md is run in order in a temporary folder
that holds only a copy of ``examples/`` (what a fresh clone has besides the package). The two
set-up commands (they create a virtual environment and install the package) are left out:
the test runs inside an installed environment, whose ``hydropwa`` is put on the PATH.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def readme_blocks() -> list[tuple[str, str]]:
    text = (ROOT / "README.md").read_text()
    return [(m[1], m[2]) for m in re.finditer(r"```(python|bash)\n(.*?)```", text, re.S)]


def test_readme_has_exactly_the_two_setup_commands():
    setups = [code for lang, code in readme_blocks() if lang == "bash" and "python -m venv" in code]
    assert len(setups) == 2
    assert "hydropwa paper" in setups[0] and "pytest" in setups[1]


@pytest.mark.slow
def test_readme_walkthrough_runs_in_an_empty_folder(tmp_path):
    """Run twice in the same folder: the second run meets every file of the first (issue 37)."""
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    env = dict(os.environ, MPLBACKEND="Agg")
    env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")
    ran = 0
    for lang, code in readme_blocks() * 2:
        if lang == "bash" and "python -m venv" in code:
            continue  # set-up commands: the test already runs in an installed environment
        if lang == "python":
            cmd = [sys.executable, "-c", code]
        else:
            cmd = ["bash", "-e", "-o", "pipefail", "-c", code]
        proc = subprocess.run(
            cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900
        )
        assert proc.returncode == 0, (
            f"README block failed:\n{code}\n--- stderr ---\n{proc.stderr[-3000:]}"
        )
        ran += 1
    assert ran == 6
    for out in (
        "full_sine.parquet",
        "pwa_paper.json",
        "run.parquet",
        "run.png",
        "chirp.parquet",
        "identified.toml",
        "pwa.json",
        "pwa.csv",
        "summary.csv",
    ):
        assert (tmp_path / out).is_file(), out
