"""``hydropwa sweep``: run a parameter grid or random sample from TOML and write a summary table."""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Annotated

import typer

from .._errors import ParameterError
from ._app import new_app
from ._options import jobs_option

__all__ = ["app", "sweep_command"]

#: The top-level ``sweep`` command.
app = new_app()


def _write_table(df, out: Path) -> None:
    """CSV or Parquet by suffix, written atomically."""
    from .._io import atomic_path  # deferred: loaded only when this command runs (a fast --help)

    with atomic_path(out, overwrite=True) as tmp:
        if out.suffix.lower() == ".parquet":
            df.to_parquet(tmp, index=False)
        else:
            df.to_csv(tmp, index=False)


@app.command("sweep")
def sweep_command(
    spec: Annotated[
        Path, typer.Argument(help="Sweep definition (TOML with [grid], [random], [input]).")
    ],
    out: Annotated[
        Path,
        typer.Option("--out", "-o", help="Summary table, one row per case (.csv or .parquet)."),
    ] = Path("summary.csv"),
    trajectories: Annotated[
        Path | None,
        typer.Option(
            "--trajectories", help="Folder for one Parquet file of all channels per case."
        ),
    ] = None,
    jobs: Annotated[
        int | None,
        jobs_option("Threads, or LocalCluster workers"),
    ] = None,
    scheduler: Annotated[
        str | None,
        typer.Option(
            "--scheduler",
            help="Dask scheduler address (tcp://host:8786), or 'local' for a LocalCluster.",
        ),
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")] = False,
    force: Annotated[
        bool,
        typer.Option(
            "--force",
            help="Overwrite an existing summary table and trajectories; start an interrupted sweep over.",
        ),
    ] = False,
) -> None:
    """Run every case of a sweep (in-process threads or on Dask) and write the summary table.

    Finished cases are kept as they finish (a journal beside the summary table, and the
    trajectory files): after a Ctrl-C, a kill or a dead Dask worker, the same command runs
    only the cases that are left.
    """
    from .._io import (  # deferred: loaded only when this command runs (a fast --help)
        check_output,
        output_lock,
        remove_stale_temps,
    )

    if out.suffix.lower() not in (".csv", ".parquet"):
        raise ParameterError(f"--out {out} must end in .csv or .parquet")
    check_output(out, force, option="--out")
    from .._limits import check_jobs  # deferred: loaded only when this command runs (a fast --help)

    check_jobs(jobs)
    if trajectories is not None:
        check_output(trajectories, True, folder=True, option="--trajectories")
    from ..sweep import (  # deferred: loaded only when this command runs (a fast --help)
        SweepJournal,
        check_scheduler,
        load_sweep,
        run_sweep,
    )

    sweep = load_sweep(spec)
    if scheduler is not None:
        check_scheduler(scheduler)
    journal_path = out.parent / f".{out.name}.sweep.jsonl"
    with contextlib.ExitStack() as locks:
        locks.enter_context(
            output_lock(out.parent, "hydropwa sweep", name=f".{out.name}.lock", clean=False)
        )
        remove_stale_temps(out.parent, recursive=False, target=out.name)
        resume = journal_path.is_file() and not force
        if trajectories is not None:
            # the trajectories folder is this sweep's alone while it runs
            locks.enter_context(output_lock(trajectories, "hydropwa sweep", clean=False))
            if not resume:
                check_output(
                    trajectories,
                    force,
                    folder=True,
                    option="--trajectories",
                    files=("case_*.parquet",),
                )
            _check_disk(sweep, trajectories)
            remove_stale_temps(trajectories, recursive=False)
        journal = SweepJournal(journal_path, sweep, fresh=not resume)
        _run(sweep, out, trajectories, jobs, scheduler, quiet, journal, run_sweep)
        journal.remove()


#: Bytes per sample of a trajectory file (12 float64 channels; Parquet compresses little).
_TRAJECTORY_BYTES_PER_SAMPLE = 12 * 8


def _check_disk(sweep, folder: Path) -> None:
    """Refuse trajectories that cannot fit on the disk, with the estimate."""
    import shutil  # deferred: loaded only when this command runs (a fast --help)

    from .._limits import (
        human_bytes,  # deferred: loaded only when this command runs (a fast --help)
    )

    fs = float(sweep.options.get("fs", 2000.0))
    need = sweep.n_cases * (sweep.duration * fs + 1) * _TRAJECTORY_BYTES_PER_SAMPLE
    where = (
        folder if folder.exists() else next((p for p in folder.parents if p.exists()), Path("."))
    )
    free = shutil.disk_usage(where).free
    if need > free:
        raise ParameterError(
            f"--trajectories {folder}: {sweep.n_cases} cases of {sweep.duration:g} s at {fs:g} Hz "
            f"need about {human_bytes(need)} and {human_bytes(free)} are free there; write the "
            "summary only, or choose another disk"
        )


def _run(sweep, out, trajectories, jobs, scheduler, quiet, journal, run_sweep) -> None:
    from rich.console import Console  # deferred: loaded only when this command runs (a fast --help)
    from rich.progress import (  # deferred: loaded only when this command runs (a fast --help)
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeRemainingColumn,
    )

    n = sweep.n_cases
    console = Console(stderr=True)
    if journal.rows and not quiet:
        console.print(f"resuming: {len(journal.rows)} of {n} cases finished earlier")
    columns = (TextColumn("sweep"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn())
    with Progress(*columns, console=console, disable=quiet) as bar:
        task = bar.add_task("sweep", total=n)
        df = run_sweep(
            sweep,
            jobs=jobs,
            scheduler=scheduler,
            trajectories=trajectories,
            progress=lambda done, total: bar.update(task, completed=done),
            journal=journal,
        )
    _write_table(df, out)
    failed = int((df["status"] != 0).sum()) if "status" in df else 0
    where = "in-process" if scheduler is None else f"on Dask ({scheduler})"
    console.print(
        f"{n} cases {where} → {out}"
        + (f"; {failed} failed (see the status column)" if failed else "")
    )
