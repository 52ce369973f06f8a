"""The tutorials in docs/tutorials/ run top to bottom without an error (nbclient), and the
outputs stored with them (which the docs site shows) come from their current code.

``python tests/docs/test_notebooks.py [NAME ...]`` re-executes tutorials in place and stamps
each with the hash of its code cells (``metadata.hydropwa.code_sha256``).
"""

from __future__ import annotations

import hashlib
import re
import sys
import time
from pathlib import Path

import nbclient  # test extra: a missing one is an error, not a skip
import nbformat
import pytest

TUTORIALS = Path(__file__).resolve().parents[2] / "docs" / "tutorials"
#: The C header the generator writes (package data): its structs are the target's interface.
C_HEADER = TUTORIALS.parents[1] / "src" / "hydropwa" / "control" / "_c" / "hydropwa_ctrl.h"


def code_hash(nb) -> str:
    """SHA-256 of a notebook's code cells, in order (what its stored outputs came from)."""
    code = "\n\0".join(c.source for c in nb.cells if c.cell_type == "code")
    return hashlib.sha256(code.encode("utf-8")).hexdigest()


def execute_and_stamp(name: str) -> float:
    """Run one tutorial in its folder, store its outputs and the hash of the code that made
    them; returns the wall time [s]."""
    nb = nbformat.read(TUTORIALS / name, as_version=4)
    client = nbclient.NotebookClient(
        nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(TUTORIALS)}}
    )
    t0 = time.perf_counter()
    client.execute()
    nb.metadata.setdefault("hydropwa", {})["code_sha256"] = code_hash(nb)
    nbformat.write(nb, TUTORIALS / name)
    return time.perf_counter() - t0


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


@pytest.mark.parametrize("name", sorted(p.name for p in TUTORIALS.glob("*.ipynb")))
def test_stored_outputs_come_from_the_current_code(name):
    """A code cell edited after the outputs were stored (tutorial 04's loop once showed outputs
    of an older generator) fails here; re-run ``python tests/docs/test_notebooks.py NAME``."""
    nb = nbformat.read(TUTORIALS / name, as_version=4)
    stamp = nb.metadata.get("hydropwa", {}).get("code_sha256")
    assert stamp == code_hash(nb), (
        f"{name}: its stored outputs are not from its current code; re-execute it with "
        f"`python tests/docs/test_notebooks.py {name}`"
    )


@pytest.mark.parametrize("name", sorted(p.name for p in TUTORIALS.glob("*.ipynb")))
def test_a_tutorial_calling_the_c_sets_every_input_the_header_asks_for(name):
    """A loop around ``hydropwa_ctrl_step`` sets every field of the header's measurement and
    reference structs (tutorial 04 once left ``r_rate_pre`` unset when the header added it)."""
    from hydropwa.control import c_structs

    nb = nbformat.read(TUTORIALS / name, as_version=4)
    code = "\n".join(c.source for c in nb.cells if c.cell_type == "code")
    if "hydropwa_ctrl_step" not in code:
        pytest.skip(f"{name} does not call the generated C")
    structs = c_structs(C_HEADER)
    for struct, var in (("hydropwa_ctrl_meas", "m"), ("hydropwa_ctrl_ref", "rf")):
        fields = {f for f, _ in structs[struct]._fields_}
        # `var.a = ...` and `var.a, var.b = ...`
        set_ = {
            f
            for lhs in re.findall(rf"^\s*((?:{var}\.\w+\s*,\s*)*{var}\.\w+)\s*=", code, re.M)
            for f in re.findall(rf"{var}\.(\w+)", lhs)
        }
        assert fields <= set_, f"{name}: {struct} fields never set: {sorted(fields - set_)}"


if __name__ == "__main__":
    for arg in sys.argv[1:] or sorted(p.name for p in TUTORIALS.glob("*.ipynb")):
        print(f"{arg}: {execute_and_stamp(Path(arg).name):.1f} s")
