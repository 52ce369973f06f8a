"""The paper study's second process (``_stages.prefetch``): a stage it ran is reused by the
parent in its turn and recorded as computed; one it failed is computed by the parent."""

from __future__ import annotations

import os

import pytest

from hydropwa.studies.paper._stages import ENV_OVERLAP, StageRunner, prefetch


def _stage(runner: StageRunner, name: str, fail_in: int | None = None):
    def work():
        if fail_in is not None and os.getpid() != fail_in:
            raise RuntimeError("second process fails")
        path = runner.out / f"{name}.txt"
        path.write_text(f"{name} by {os.getpid()}\n")
        return [path], {"notes": [f"{name} note"]}

    return runner.run(name, "inputs-1", work)


@pytest.mark.parametrize("overlap", ["1", "0"])
def test_a_prefetched_stage_is_reused_in_its_turn(tmp_path, monkeypatch, overlap):
    monkeypatch.setenv(ENV_OVERLAP, overlap)
    runner = StageRunner(tmp_path)
    join = prefetch(runner, lambda: _stage(runner, "second"))
    _stage(runner, "first")
    join()
    m = _stage(runner, "second")  # in its turn: finished on disk
    assert m["notes"] == ["second note"]
    assert runner.record["second"]["reused"] is False  # computed in this study
    writer = int((tmp_path / "second.txt").read_text().split()[-1])
    assert (writer != os.getpid()) == (overlap == "1" and hasattr(os, "fork"))
    again = StageRunner(tmp_path)
    _stage(again, "second")
    assert again.record["second"]["reused"] is True


@pytest.mark.skipif(not hasattr(os, "fork"), reason="no second process without fork")
def test_a_stage_the_second_process_failed_is_computed_here(tmp_path, monkeypatch):
    monkeypatch.setenv(ENV_OVERLAP, "1")
    runner = StageRunner(tmp_path)
    here = os.getpid()  # the stage fails in any other process
    join = prefetch(runner, lambda: _stage(runner, "second", fail_in=here))
    join()
    assert "second" not in runner.elsewhere and not (tmp_path / "second.txt").exists()
    _stage(runner, "second", fail_in=here)
    assert runner.record["second"]["reused"] is False
    assert (tmp_path / "second.txt").read_text() == f"second by {os.getpid()}\n"
