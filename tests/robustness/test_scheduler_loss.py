"""A Dask scheduler lost in the middle of a sweep (issue 49, item 7): one line, the finished
cases kept, within the client's time-out; never a traceback or a wait without end."""

from __future__ import annotations

import contextlib
import logging
import time

import pytest

import hydropwa.sweep._run as sweep_run
from hydropwa._errors import HydropwaError
from hydropwa.sweep import SweepJournal, parse_sweep, run_sweep

SPEC = {
    "base": "paper",
    "grid": {"load.mass": [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]},
    "input": {"duration": 0.02, "model": "reduced", "fs": 500},
}


class _ClosedOnScatter:
    """A client whose scheduler went away before the first call: Dask raises CommClosedError,
    an OSError, from ``scatter`` (before: the CLI's 'file system' error and Dask's traceback)."""

    def scatter(self, *a, **k):
        from distributed.comm.core import CommClosedError

        raise CommClosedError("in <TCP (closed) ConnectionPool.scatter>: Stream is closed")


def test_a_scheduler_gone_before_the_cases_run_loses_them_in_one_line(monkeypatch, tmp_path):
    spec = parse_sweep(SPEC)
    monkeypatch.setattr(sweep_run, "check_scheduler", lambda address: address)
    monkeypatch.setattr(
        sweep_run, "dask_client", lambda *a, **k: contextlib.nullcontext(_ClosedOnScatter())
    )
    with pytest.raises(HydropwaError) as info:
        run_sweep(spec, scheduler="tcp://127.0.0.1:8786", journal=tmp_path / "j.jsonl")
    msg = str(info.value)
    assert "\n" not in msg
    assert msg.startswith("6 of 6 cases did not finish on Dask (first: case 0, the connection")
    assert "CommClosedError" in msg and "rerun to run the rest" in msg


def _closes_the_scheduler_at_case_2(spec_, case, keep_result=False):
    """The real case, but case 2 first closes the (in-process) scheduler and waits for the
    client to notice."""
    if case.index == 2:
        from distributed import Scheduler

        for s in list(Scheduler._instances):
            s.loop.add_callback(s.close)
        time.sleep(2.0)
    return _REAL(spec_, case, keep_result)


_REAL = sweep_run.run_case


def test_a_scheduler_lost_mid_run_ends_the_sweep_in_one_line_with_the_finished_cases(
    monkeypatch, tmp_path
):
    """One worker, cases in order; the scheduler closes while case 2 runs: the sweep ends with
    one HydropwaError within the client's time-out (2 × CONNECT_TIMEOUT = 10 s; measured
    0.2 s), cases 0 and 1 (those done by then) in the journal, the rest named as lost."""
    from dask.distributed import LocalCluster

    spec = parse_sweep(SPEC)
    monkeypatch.setattr(sweep_run, "run_case", _closes_the_scheduler_at_case_2)
    journal = tmp_path / "j.jsonl"
    logging.getLogger("distributed").setLevel(logging.CRITICAL)  # the in-process worker's noise
    with LocalCluster(
        n_workers=1,
        threads_per_worker=1,
        processes=False,
        protocol="tcp://",
        dashboard_address=None,
    ) as cluster:
        address = cluster.scheduler_address
        run_sweep(parse_sweep({**SPEC, "grid": {"load.mass": [1.0]}}), scheduler=address)  # warm
        t0 = time.perf_counter()
        with pytest.raises(HydropwaError, match=r"cases did not finish on Dask") as info:
            run_sweep(spec, scheduler=address, journal=journal)
        elapsed = time.perf_counter() - t0
    msg = str(info.value)
    assert "\n" not in msg and "rerun to run the rest" in msg
    assert elapsed < 2 * sweep_run.CONNECT_TIMEOUT + 10.0  # the 2 s wait, the cases, the loss
    done = sorted(SweepJournal(journal, spec).rows)
    assert 2 not in done and set(done) <= {0, 1}
    n_lost = int(msg.split(" of ")[0])
    assert n_lost == 6 - len(done)
