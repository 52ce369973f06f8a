"""Running experiments: datasets on disk, resume, seeds, process pool and progress.

Layout written by :func:`run_campaign` (and :func:`run_experiment` for one experiment)::

    OUT/true_params.toml         the rig's true parameters (load_params reads it)
    OUT/<experiment>/manifest.json, <run>.parquet   one hydropwa Dataset per experiment

Runs are written one by one (file, then manifest, both atomically), so an interrupted
campaign resumes where it stopped: a rerun with the same settings skips every run the
manifest lists whose file exists. Different settings in an existing output are an error
unless ``overwrite`` is given.
"""

from __future__ import annotations

import concurrent.futures as cf
import dataclasses
import hashlib
import itertools
import json
import os
import signal
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from functools import partial
from pathlib import Path
from typing import Any

from .. import __version__, _interrupt
from .._errors import DataError, ParameterError
from .._io import atomic_write_text, overwrite_flag
from ..data import MANIFEST, Dataset
from ..params import params_to_toml
from ._campaign import EXPERIMENTS, Campaign, Experiment
from ._experiments import RunSpec, execute, plan, run_seed
from ._faults import Fault, inject
from ._rig import Rig

__all__ = ["run_experiment", "run_campaign", "TRUE_PARAMS"]

#: File name of the true parameters next to the datasets.
TRUE_PARAMS = "true_params.toml"

Progress = Callable[[str, int, int], None]


def _json_safe(obj: Any) -> Any:
    return json.loads(json.dumps(obj, default=list))


def _dataset_meta(
    rig: Rig, experiment: Experiment, campaign_name: str, seed: int, faults: Sequence[Fault] = ()
) -> dict[str, Any]:
    definition = {"experiment": experiment.name, **dataclasses.asdict(experiment)}
    if faults:  # a faulty campaign is other settings than the healthy one (no silent resume)
        definition["faults"] = [dataclasses.asdict(f) for f in faults]
    meta = {
        "generator": f"hydropwa {__version__} virtual rig",
        "experiment": experiment.name,
        "campaign": campaign_name,
        "seed": int(seed),
        "definition": definition,
        "rig": rig.describe(),
        "true_params": rig.params.to_dict(),
    }
    meta = _json_safe(meta)
    text = json.dumps(
        {k: meta[k] for k in ("experiment", "seed", "definition", "rig", "true_params")},
        sort_keys=True,
    )
    meta["fingerprint"] = hashlib.sha256(text.encode()).hexdigest()[:16]
    return meta


def _true_params_text(rig: Rig) -> str:
    return params_to_toml(
        rig.params, "true parameters of the virtual rig that produced the datasets here"
    )


def _write_true_params(rig: Rig, out: Path, force: bool) -> None:
    path = out / TRUE_PARAMS
    text = _true_params_text(rig)
    if path.exists() and not force and path.read_text(encoding="utf-8") != text:
        raise DataError(
            f"{str(path)!r} holds other parameters than this rig's; hint: pass --force (overwrite=True) "
            "to overwrite the output, or choose another output folder"
        )
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        atomic_write_text(path, text)


def _open_dataset(root: Path, meta: dict[str, Any], force: bool) -> Dataset:
    """Open a matching dataset to resume, or create a new one."""
    if (root / MANIFEST).exists():
        try:
            old = Dataset(root, validate=False)
        except DataError:
            old = None
        if old is not None and not force:
            if old.meta.get("fingerprint") == meta["fingerprint"]:
                return old
            raise DataError(
                f"{str(root)!r} already holds a dataset made with other settings "
                f"(fingerprint {old.meta.get('fingerprint')!r}, now {meta['fingerprint']!r}); "
                "hint: pass --force (overwrite=True) to overwrite it, or choose another output folder"
            )
        if old is not None:
            for e in old.manifest["runs"]:
                f = root / str(e.get("file", ""))
                if f.is_file() and f.parent == root:
                    f.unlink()
        elif not force:
            raise DataError(
                f"{str(root)!r}: unreadable manifest; hint: pass --force to overwrite it"
            )
    return Dataset.create(root, meta=meta, overwrite=True)


def _complete(ds: Dataset, name: str) -> bool:
    if name not in ds.names:
        return False
    path = ds.path_of(name)
    return path.is_file() and path.stat().st_size > 0


def _init_worker(parent_pid: int) -> None:
    """Pool worker set-up: leave Ctrl-C to the parent, and exit if the parent dies.

    A killed parent cannot shut its pool down; forked workers would wait forever on a queue
    whose other end they hold themselves. A daemon thread notices the new parent pid instead.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})  # see _sigint_blocked

    def watch() -> None:
        while os.getppid() == parent_pid:
            time.sleep(0.2)
        os._exit(1)

    threading.Thread(target=watch, daemon=True, name="hydropwa-parent-watch").start()


@contextmanager
def _sigint_blocked() -> Iterator[None]:
    """Hold back SIGINT in this thread while pool workers are forked.

    A worker forked with SIGINT deliverable could receive a Ctrl-C (sent to the whole process
    group) before :func:`_init_worker` ignores it, die half started and leave the pool unable
    to shut down. Forked with SIGINT blocked, it ignores the signal before unblocking it; the
    parent gets a Ctrl-C that arrived meanwhile as soon as the block is lifted.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _worker(seed: int, base_meta: dict[str, Any], job: tuple[Rig, RunSpec]):
    rig, spec = job
    return execute(rig, spec, run_seed(seed, spec.experiment, spec.name), base_meta)


def _faulty_jobs(
    rig: Rig, specs: list[RunSpec], faults: Sequence[Fault]
) -> list[tuple[Rig, RunSpec]]:
    """Each run with the rig of its own faults (:func:`~hydropwa.rig.inject`; sizes by plan index)."""
    if not faults:
        return [(rig, s) for s in specs]
    jobs = []
    for i, spec in enumerate(specs):
        params, offset, applied = inject(rig.params, faults, i, len(specs))
        faulty = dataclasses.replace(rig, params=params, supply=params.supply)
        meta = {**spec.meta, "faults": applied}
        jobs.append((faulty, dataclasses.replace(spec, command_offset=offset, meta=meta)))
    return jobs


@contextmanager
def _results(
    specs: list[tuple[Rig, RunSpec]], seed: int, base_meta: dict, jobs: int
) -> Iterator[Iterator]:
    """Measured runs in plan order, computed in this process or in a process pool.

    A context manager around the iterator, not a generator of runs: an exception in the
    caller's loop body (a Ctrl-C while a run is written) then passes through here, and the
    pool is shut down at once (pending runs cancelled). Left to a suspended generator, the
    shutdown waited for garbage collection; at interpreter exit multiprocessing then joined
    workers that never got their stop sentinel, and ``hydropwa paper`` hung after Ctrl-C.
    """
    fn = partial(_worker, seed, base_meta)
    if jobs <= 1 or len(specs) <= 1:
        yield map(fn, specs)
        return
    # The first run in this process: it compiles (or loads) the solver once before the pool
    # starts, so on a fresh installation the workers load it from the cache (or inherit it
    # when forked) instead of each compiling its own copy at the same time (~13 CPU-s each).
    first = fn(specs[0])
    with cf.ProcessPoolExecutor(
        max_workers=min(jobs, len(specs) - 1), initializer=_init_worker, initargs=(os.getpid(),)
    ) as pool:
        with _sigint_blocked():  # the workers start here; they inherit the blocked mask
            runs = pool.map(fn, specs[1:], chunksize=1)
        try:
            yield itertools.chain([first], runs)
        except BaseException:
            pool.shutdown(wait=True, cancel_futures=True)
            raise


def _rich_progress():
    from rich.progress import (  # deferred: rich, only for progress on a terminal
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
    )

    return Progress(
        TextColumn("{task.description:<10}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        transient=False,
    )


def run_experiment(
    rig: Rig,
    experiment: Experiment,
    out_dir: str | os.PathLike,
    seed: int = 0,
    jobs: int = 1,
    progress: bool | Progress = False,
    *,
    overwrite: bool = False,
    campaign_name: str = "",
    format: str = "parquet",
    force: bool | None = None,
    faults: Sequence[Fault] = (),
) -> Dataset:
    """Run one experiment on the rig and write it as ``out_dir/<experiment>/``.

    Parameters
    ----------
    rig : Rig
        The virtual rig (true parameters, sensors, rate).
    experiment : Experiment
        An experiment of a :class:`~hydropwa.rig.Campaign` (``campaign["frf"]``).
    out_dir : path-like
        Output root; ``true_params.toml`` is written there too.
    seed : int
        Campaign seed; run seeds derive from it and the run names.
    jobs : int
        Worker processes (1: run here). Does not change the results.
    progress : bool or callable
        Show a progress bar (rich), or call ``progress(experiment, done, total)``.
    overwrite : bool
        Overwrite an existing output made with other settings (else :class:`DataError`).
    campaign_name : str
        Recorded in the dataset metadata.
    format : {"parquet", "csv", "mat"}
        File format of the runs.
    force : bool, optional
        Former name of ``overwrite`` (deprecated).
    faults : sequence of Fault
        Faults injected into the runs (:mod:`hydropwa.rig._faults`; sizes by plan index); each
        run's ``meta["faults"]`` lists those present.

    Returns
    -------
    Dataset
        The experiment's dataset (runs already present are kept, not recomputed).
    """
    if not isinstance(jobs, int) or jobs < 1:
        raise ParameterError(f"jobs = {jobs!r} must be an integer >= 1")
    overwrite = overwrite_flag(overwrite, force, "run_experiment")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    _write_true_params(rig, out, overwrite)
    meta = _dataset_meta(rig, experiment, campaign_name, seed, faults)
    ds = _open_dataset(out / experiment.name, meta, overwrite)
    planned = _faulty_jobs(rig, plan(experiment, rig), faults)
    specs = [job for job in planned if not _complete(ds, job[1].name)]
    total = len(planned)
    done = total - len(specs)
    base_meta = {"campaign": campaign_name, "seed": int(seed)}
    bar = task = None
    if progress is True:
        bar = _rich_progress()
        bar.start()
        task = bar.add_task(experiment.name, total=total, completed=done)
    try:
        with _results(specs, seed, base_meta, jobs) as results:
            for run in results:
                ds.add_run(run, format=format, overwrite=True)
                _interrupt.checkpoint()  # a Ctrl-C a finalizer swallowed stops here (see hydropwa._interrupt)
                done += 1
                if bar is not None:
                    bar.update(task, completed=done)
                elif callable(progress):
                    progress(experiment.name, done, total)
    finally:
        if bar is not None:
            bar.stop()
    return ds


def run_campaign(
    rig: Rig,
    campaign: Campaign,
    out_dir: str | os.PathLike,
    *,
    experiments: Iterable[str] | None = None,
    seed: int | None = None,
    jobs: int = 1,
    progress: bool | Progress = False,
    overwrite: bool = False,
    format: str = "parquet",
    force: bool | None = None,
    faults: Sequence[Fault] | None = None,
) -> dict[str, Dataset]:
    """Run a campaign's experiments, each into ``out_dir/<experiment>/``.

    Parameters
    ----------
    rig : Rig
    campaign : Campaign
        From :func:`~hydropwa.rig.load_campaign`.
    out_dir : path-like
        Output root (``true_params.toml`` and one dataset folder per experiment).
    experiments : iterable of str, optional
        Names to run (default: all of the campaign's, in the order frf, deadzone, friction, sine).
    seed : int, optional
        Overrides the campaign's seed.
    jobs : int
        Parallel worker processes, as in :func:`run_experiment`.
    progress : bool or Progress
        As in :func:`run_experiment`.
    overwrite : bool
        As in :func:`run_experiment`.
    format : str
        Run file format, as in :func:`run_experiment`.
    force : bool, optional
        Former name of ``overwrite`` (deprecated), as in :func:`run_experiment`.
    faults : sequence of Fault, optional
        Faults to inject into every experiment (default: the campaign's ``[[faults]]``).

    Returns
    -------
    dict[str, Dataset]
        Dataset per experiment.
    """
    overwrite = overwrite_flag(overwrite, force, "run_campaign")
    names = list(campaign.experiments) if experiments is None else list(experiments)
    for n in names:
        if n not in EXPERIMENTS:
            raise ParameterError(f"unknown experiment {n!r}; choose from {', '.join(EXPERIMENTS)}")
    seed = campaign.seed if seed is None else int(seed)
    if campaign.sensors or campaign.supply:
        rig = rig.with_overrides(campaign.sensors, campaign.supply)
    return {
        n: run_experiment(
            rig,
            campaign[n],
            out_dir,
            seed,
            jobs,
            progress,
            overwrite=overwrite,
            campaign_name=campaign.name,
            format=format,
            faults=campaign.faults if faults is None else tuple(faults),
        )
        for n in names
    }
