"""Run a sweep in-process (threads) or on a Dask cluster, with identical results.

Each case is one :func:`~hydropwa.simulation.simulate` call reduced to a row of
:func:`~hydropwa.simulation.summarize` metrics, so the table does not depend on
where a case ran (apart from the ``wall_time`` column).

Dask
----
Start a scheduler and workers on the machines (each with hydropwa installed)::

    dask scheduler                      # prints tcp://HOST:8786
    dask worker tcp://HOST:8786         # on every machine; --nworkers N --nthreads 1

then ``hydropwa sweep spec.toml --out summary.csv --scheduler tcp://HOST:8786``
(``--scheduler local`` starts a LocalCluster on this machine).

Finished cases are kept
-----------------------
With a ``journal`` (the CLI keeps one beside the summary table), each case's row is
appended to a JSON-lines file as soon as the case finishes, and its trajectory file is
written then too. A Ctrl-C, a killed process or a dead Dask worker loses only the cases
that were running; a rerun of the same sweep reads the journal and runs only the rest.
Cases a dead worker took down are reported in one error after every other case ran.
"""

from __future__ import annotations

import asyncio
import contextlib
import hashlib
import json
import os
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait
from pathlib import Path
from typing import Any

import pandas as pd

from .. import _interrupt
from .._dask import dask_client, parse_address, probe_scheduler
from .._errors import HydropwaError, ParameterError
from .._io import atomic_write_text, read_bytes
from .._layout import build_model
from ..simulation import SimulationResult, simulate, summarize
from ._spec import SweepCase, SweepSpec

__all__ = ["run_case", "run_sweep", "SweepJournal", "check_scheduler"]

#: Seconds to wait for a Dask scheduler to answer before giving up.
CONNECT_TIMEOUT = 5.0


def _row(case: SweepCase, summary: dict[str, float]) -> dict[str, Any]:
    return {"case": case.index, **case.overrides, **summary}


def run_case(
    spec: SweepSpec, case: SweepCase, keep_result: bool = False
) -> tuple[dict, SimulationResult | None]:
    """Simulate one case; returns its summary row and, if asked, the full result.

    A failed integration does not raise: its row carries the solver ``status`` (and the
    metrics of the partial result). This is the task a Dask worker runs; it is a plain
    function of picklable arguments.
    """
    params = spec.params_for(case)
    model = build_model(spec.model, params)  # each case's model from its parameters
    res = simulate(
        model,
        spec.u,
        params=params,
        duration=spec.duration,
        raise_on_failure=False,
        **spec.options,
    )
    return _row(case, summarize(res)), (res if keep_result else None)


def _trajectory_path(directory: Path, case: SweepCase) -> Path:
    return directory / f"case_{case.index:05d}.parquet"


def _write_trajectory(directory: Path, case: SweepCase, result: SimulationResult) -> None:
    result.to_parquet(
        _trajectory_path(directory, case), overwrite=True
    )  # the journal decides what reruns


def fingerprint(spec: SweepSpec) -> str:
    """A hash of everything that decides a sweep's rows (to resume only the same sweep)."""
    text = repr(
        (
            spec.base,
            spec.grid,
            spec.random,
            spec.n_random,
            spec.seed,
            spec.u,
            spec.duration,
            spec.model,
            sorted(spec.options.items()),
        )
    )
    return hashlib.sha256(text.encode()).hexdigest()[:32]


class SweepJournal:
    """The rows of finished cases, one JSON line each, appended as the cases finish.

    Parameters
    ----------
    path : path-like
        The journal file (JSON lines; the first line names the sweep's fingerprint).
    spec : SweepSpec
        The sweep; a journal of another sweep is refused.
    fresh : bool
        Start over: discard an existing journal.

    Attributes
    ----------
    rows : dict[int, dict]
        Finished rows by case index (read from an existing journal).
    """

    def __init__(self, path: str | os.PathLike, spec: SweepSpec, fresh: bool = False) -> None:
        self.path = Path(path)
        self.key = fingerprint(spec)
        self.rows: dict[int, dict] = {}
        if self.path.is_file() and not fresh:
            self._read()
        else:
            atomic_write_text(self.path, json.dumps({"sweep": self.key}) + "\n")

    def _read(self) -> None:
        data = read_bytes(self.path, "sweep results", ParameterError)
        try:
            lines = data.decode("utf-8").splitlines()
            head = json.loads(lines[0]) if lines else {}
        except (ValueError, IndexError):
            head = {}
        if not isinstance(head, dict) or head.get("sweep") != self.key:
            raise ParameterError(
                f"{self.path} holds the finished cases of another sweep; pass --force to start "
                "this one over, or choose another --out"
            )
        for line in lines[1:]:
            try:
                row = json.loads(line)
                self.rows[int(row["case"])] = row
            except (ValueError, KeyError, TypeError):
                continue  # the last line of a killed run may be cut short

    def add(self, rows: list[dict]) -> None:
        """Append finished rows (flushed to disk before returning)."""
        if not rows:
            return
        text = "".join(json.dumps(r, default=_plain) + "\n" for r in rows)
        with open(self.path, "a", encoding="utf-8") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        for r in rows:
            self.rows[int(r["case"])] = r

    def remove(self) -> None:
        """Delete the journal (after the summary table is written)."""
        with contextlib.suppress(FileNotFoundError):
            self.path.unlink()


def _plain(value):
    """numpy scalars as Python numbers for JSON."""
    if hasattr(value, "item"):
        return value.item()
    raise TypeError(f"{type(value).__name__} is not JSON serializable")


def check_scheduler(address: str, timeout: float = CONNECT_TIMEOUT) -> str:
    """A Dask scheduler address that is well formed and answers, else one ParameterError.

    ``"local"`` (a LocalCluster) is accepted as is; an address is ``tcp://HOST:PORT`` or
    ``HOST:PORT`` (:func:`hydropwa._dask.parse_address`), and must answer with a Dask
    handshake within ``timeout`` seconds (:func:`hydropwa._dask.probe_scheduler`).
    """
    if address == "local":
        return address
    host, port = parse_address(address, ParameterError, "--scheduler")
    why = probe_scheduler(host, port, timeout)
    if why is not None:
        raise ParameterError(
            f"--scheduler {address!r}: cannot reach the scheduler ({why}); start it with "
            "`dask scheduler` and check the address, or run in-process without --scheduler"
        )
    return address


def _run_local(spec, cases, jobs, traj_dir, on_done) -> None:
    """Threads (the kernel releases the GIL), a bounded window of cases in flight."""
    jobs = jobs or os.cpu_count() or 1
    todo = iter(cases)
    pool = ThreadPoolExecutor(max_workers=jobs)
    running: dict = {}
    try:
        while True:
            while len(running) < 2 * jobs:
                case = next(todo, None)
                if case is None:
                    break
                running[pool.submit(run_case, spec, case, traj_dir is not None)] = case
            if not running:
                break
            done, _ = wait(running, return_when=FIRST_COMPLETED)
            for fut in done:
                case = running.pop(fut)
                row, res = fut.result()
                on_done(case, row, res)
            _interrupt.checkpoint()
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _run_dask(spec, cases, scheduler, jobs, traj_dir, on_done) -> list[tuple[SweepCase, str]]:
    """Client.map over the cases on a Dask cluster (LocalCluster for ``"local"``).

    Returns the cases that did not finish (a dead worker, a lost connection), with why.
    """
    with dask_client(
        scheduler,
        jobs,
        timeout_s=CONNECT_TIMEOUT * 2,
        error=ParameterError,
        option="--scheduler",
        hint="run in-process without --scheduler",
    ) as client:
        return _gather_dask(client, spec, cases, traj_dir, on_done)


def _gather_dask(client, spec, cases, traj_dir, on_done) -> list[tuple[SweepCase, str]]:
    """The cases' results as they complete on ``client``; the ones lost, with why.

    A scheduler lost mid-run (its connection closed, the client's reconnection timed out
    after its time-out, ``2 × CONNECT_TIMEOUT``) loses every case not finished by then: they
    are returned with the reason, so that the sweep ends in one line with the finished cases
    kept, not in a traceback or a wait without end.
    """
    from dask.distributed import (
        as_completed,  # deferred: dask.distributed costs ~1 s, only for a cluster
    )

    lost: list[tuple[SweepCase, str]] = []
    done: set[int] = set()
    try:
        spec_f = client.scatter(spec, broadcast=True)
        keep = traj_dir is not None
        futures = client.map(run_case, [spec_f] * len(cases), cases, keep_result=keep, pure=False)
        index = {f.key: i for i, f in enumerate(futures)}
        for fut in as_completed(futures):
            i = index[fut.key]
            done.add(i)
            try:
                row, res = fut.result()
            except HydropwaError:
                raise
            except (Exception, asyncio.CancelledError) as exc:  # KilledWorker, cancelled...
                lost.append((cases[i], _reason(exc)))
                continue
            finally:
                fut.release()
            on_done(cases[i], row, res)
            _interrupt.checkpoint()
    except (OSError, TimeoutError, asyncio.CancelledError) as exc:  # the scheduler is gone
        why = f"the connection to the scheduler was lost ({_reason(exc)})"
        lost += [(c, why) for i, c in enumerate(cases) if i not in done]
    return lost


def _reason(exc: BaseException) -> str:
    """An exception as one line (Dask's messages span lines)."""
    return " ".join(f"{type(exc).__name__}: {exc}".split())


def run_sweep(
    spec: SweepSpec,
    *,
    jobs: int | None = None,
    scheduler: str | None = None,
    trajectories: str | os.PathLike | None = None,
    progress: Callable[[int, int], None] | None = None,
    journal: SweepJournal | str | os.PathLike | None = None,
) -> pd.DataFrame:
    """Run every case of a sweep and return one row of summary metrics per case.

    Parameters
    ----------
    spec : SweepSpec
    jobs : int, optional
        Threads (in-process) or LocalCluster workers (default: all cores).
    scheduler : str, optional
        ``None``: in-process threads; ``"local"``: a Dask LocalCluster;
        otherwise a Dask scheduler address such as ``tcp://host:8786``.
    trajectories : path, optional
        Folder for one Parquet file of all channels per case (``case_00000.parquet``),
        each written when its case finishes.
    progress : callable, optional
        ``progress(done, total)`` after each case.
    journal : SweepJournal or path, optional
        Where finished rows are appended as the cases finish; the cases it already holds
        (with their trajectory file, if trajectories are asked for) are not run again.

    Returns
    -------
    pandas.DataFrame
        Columns: ``case``, the varied parameters (SI), then the summary
        metrics of :data:`~hydropwa.simulation.SUMMARY_COLUMNS`; ordered by case.

    Raises
    ------
    HydropwaError
        Cases a dead Dask worker or a lost connection took down; the finished ones are in
        the journal, and a rerun runs only the rest.
    """
    if scheduler is not None:
        check_scheduler(scheduler)
    cases = spec.cases()
    traj_dir = None
    if trajectories is not None:
        traj_dir = Path(trajectories)
        traj_dir.mkdir(parents=True, exist_ok=True)
    if journal is not None and not isinstance(journal, SweepJournal):
        journal = SweepJournal(journal, spec)
    rows: dict[int, dict] = dict(journal.rows) if journal is not None else {}
    if traj_dir is not None:  # a row without its trajectory file is run again
        rows = {i: r for i, r in rows.items() if _trajectory_path(traj_dir, cases[i]).is_file()}
    rows = {i: r for i, r in rows.items() if i < len(cases)}
    todo = [c for c in cases if c.index not in rows]
    total = len(cases)
    if progress is not None:
        progress(len(rows), total)

    def on_done(case: SweepCase, row: dict, res) -> None:
        if res is not None and traj_dir is not None:
            _write_trajectory(traj_dir, case, res)
        if journal is not None:
            journal.add([row])
        rows[case.index] = row
        if progress is not None:
            progress(len(rows), total)

    if scheduler is None:
        _run_local(spec, todo, jobs, traj_dir, on_done)
    else:
        lost = _run_dask(spec, todo, scheduler, jobs, traj_dir, on_done)
        if lost:
            kept = f"; the {len(rows)} finished ones are kept in {journal.path}" if journal else ""
            raise HydropwaError(
                f"{len(lost)} of {total} cases did not finish on Dask (first: case "
                f"{lost[0][0].index}, {lost[0][1]}){kept}; check the workers and rerun to run "
                "the rest"
            )
    return pd.DataFrame([rows[c.index] for c in cases])
