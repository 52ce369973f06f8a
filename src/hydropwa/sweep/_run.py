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
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pandas as pd

from ..simulation import SimulationResult, simulate, simulate_batch, summarize
from ._spec import SweepCase, SweepSpec

__all__ = ["run_case", "run_sweep"]


def _row(case: SweepCase, summary: dict[str, float]) -> dict[str, Any]:
    return {"case": case.index, **case.overrides, **summary}


def run_case(
    spec: SweepSpec, case: SweepCase, keep_result: bool = False
) -> tuple[dict, SimulationResult | None]:
    """Simulate one case; returns its summary row and, if asked, the full result.

    This is the task a Dask worker runs; it is a plain function of picklable
    arguments.
    """
    res = simulate(
        spec.model, spec.u, params=spec.params_for(case), duration=spec.duration, **spec.options
    )
    return _row(case, summarize(res)), (res if keep_result else None)


def _write_trajectory(directory: Path, case: SweepCase, result: SimulationResult) -> None:
    result.to_parquet(directory / f"case_{case.index:05d}.parquet")


def _run_local(spec, cases, jobs, traj_dir, progress) -> list[dict]:
    """Threads via simulate_batch, in chunks so trajectories need not all sit in memory."""
    jobs = jobs or os.cpu_count() or 1
    chunk = len(cases) if traj_dir is None else max(4 * jobs, 1)
    rows: list[dict] = []
    for start in range(0, len(cases), chunk):
        part = cases[start : start + chunk]
        params = [spec.params_for(c) for c in part]

        def tick(done, _total, offset=start):
            if progress is not None:
                progress(offset + done, len(cases))

        results = simulate_batch(
            params,
            spec.u,
            model=spec.model,
            jobs=jobs,
            summary=traj_dir is None,
            progress=tick,
            duration=spec.duration,
            **spec.options,
        )
        for case, res in zip(part, results, strict=True):
            if traj_dir is not None:
                _write_trajectory(traj_dir, case, res)
                res = summarize(res)
            rows.append(_row(case, res))
    return rows


def _run_dask(spec, cases, scheduler, jobs, traj_dir, progress) -> list[dict]:
    """Client.map over the cases on a Dask cluster (LocalCluster for ``"local"``)."""
    from dask.distributed import Client, LocalCluster, as_completed

    cluster = None
    if scheduler == "local":
        cluster = LocalCluster(
            n_workers=jobs or os.cpu_count() or 1,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
        )
        client = Client(cluster)
    else:
        client = Client(scheduler)
    try:
        spec_f = client.scatter(spec, broadcast=True)
        keep = traj_dir is not None
        futures = client.map(run_case, [spec_f] * len(cases), cases, keep_result=keep, pure=False)
        index = {f.key: i for i, f in enumerate(futures)}
        rows: list[dict | None] = [None] * len(cases)
        for done, fut in enumerate(as_completed(futures), start=1):
            i = index[fut.key]
            row, res = fut.result()
            if res is not None:
                _write_trajectory(traj_dir, cases[i], res)
            rows[i] = row
            fut.release()
            if progress is not None:
                progress(done, len(cases))
        return rows  # type: ignore[return-value]
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def run_sweep(
    spec: SweepSpec,
    *,
    jobs: int | None = None,
    scheduler: str | None = None,
    trajectories: str | os.PathLike | None = None,
    progress: Callable[[int, int], None] | None = None,
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
        Folder for one Parquet file of all channels per case (``case_00000.parquet``).
    progress : callable, optional
        ``progress(done, total)`` after each case.

    Returns
    -------
    pandas.DataFrame
        Columns: ``case``, the varied parameters (SI), then the summary
        metrics of :data:`~hydropwa.simulation.SUMMARY_COLUMNS`; ordered by case.
    """
    cases = spec.cases()
    traj_dir = None
    if trajectories is not None:
        traj_dir = Path(trajectories)
        traj_dir.mkdir(parents=True, exist_ok=True)
    if scheduler is None:
        rows = _run_local(spec, cases, jobs, traj_dir, progress)
    else:
        rows = _run_dask(spec, cases, scheduler, jobs, traj_dir, progress)
    return pd.DataFrame(rows)
