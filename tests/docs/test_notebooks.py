"""The tutorials in docs/tutorials/ run top to bottom without an error (nbclient)."""

from __future__ import annotations

import time
from pathlib import Path

import nbclient  # test extra: a missing one is an error, not a skip
import nbformat
import pytest

TUTORIALS = Path(__file__).resolve().parents[2] / "docs" / "tutorials"


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(p.name for p in TUTORIALS.glob("*.ipynb")))
def test_tutorial_runs(name):
    """Each tutorial runs top to bottom twice in its folder (the second run meets the first's
    files: nothing may refuse to overwrite what the tutorial wrote itself)."""
    for _ in range(2):
        nb = nbformat.read(TUTORIALS / name, as_version=4)
        client = nbclient.NotebookClient(
            nb, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(TUTORIALS)}}
        )
        t0 = time.perf_counter()
        client.execute()
        wall = time.perf_counter() - t0
        errors = [
            o
            for c in nb.cells
            if c.cell_type == "code"
            for o in c.get("outputs", [])
            if o.get("output_type") == "error"
        ]
        assert not errors, errors
        print(f"{name}: {wall:.1f} s")


@pytest.mark.parametrize("name", sorted(p.name for p in TUTORIALS.glob("*.ipynb")))
def test_tutorials_are_stored_with_their_outputs(name):
    """The docs site shows the stored outputs (mkdocs-jupyter does not execute by default):
    every code cell has run, in order, and no output is an error."""
    nb = nbformat.read(TUTORIALS / name, as_version=4)
    code = [c for c in nb.cells if c.cell_type == "code"]
    counts = [c.get("execution_count") for c in code]
    assert all(isinstance(n, int) for n in counts), f"{name}: cells not executed: {counts}"
    assert counts == sorted(counts), f"{name}: cells executed out of order: {counts}"
    assert sum(bool(c.get("outputs")) for c in code) >= len(code) // 2, name
    assert not [o for c in code for o in c.get("outputs", []) if o.get("output_type") == "error"]
