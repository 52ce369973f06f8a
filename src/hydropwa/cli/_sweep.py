"""``hydropwa sweep``: run a parameter grid or random sample from TOML and write a summary table."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from .._errors import ParameterError


def _write_table(df, out: Path) -> None:
    """CSV or Parquet by suffix, written atomically."""
    from .._io import atomic_path

    with atomic_path(out) as tmp:
        if out.suffix.lower() == ".parquet":
            df.to_parquet(tmp, index=False)
        else:
            df.to_csv(tmp, index=False)


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
        typer.Option(
            "--jobs", "-j", min=1, help="Threads, or LocalCluster workers (default: all cores)."
        ),
    ] = None,
    scheduler: Annotated[
        str | None,
        typer.Option(
            "--scheduler",
            help="Dask scheduler address (tcp://host:8786), or 'local' for a LocalCluster.",
        ),
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")] = False,
    force: Annotated[bool, typer.Option("--force", help="Overwrite an existing summary table.")] = False,
) -> None:
    """Run every case of a sweep (in-process threads or on Dask) and write the summary table."""
    from .._errors import check_output

    check_output(out, force)
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeRemainingColumn,
    )

    from ..sweep import load_sweep, run_sweep

    if not spec.is_file():
        raise ParameterError(f"sweep file {spec} does not exist")
    sweep = load_sweep(spec)
    n = len(sweep.cases())
    console = Console(stderr=True)
    columns = (TextColumn("sweep"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn())
    with Progress(*columns, console=console, disable=quiet) as bar:
        task = bar.add_task("sweep", total=n)
        df = run_sweep(
            sweep,
            jobs=jobs,
            scheduler=scheduler,
            trajectories=trajectories,
            progress=lambda done, total: bar.update(task, completed=done),
        )
    _write_table(df, out)
    failed = int((df["status"] != 0).sum()) if "status" in df else 0
    where = "in-process" if scheduler is None else f"on Dask ({scheduler})"
    console.print(
        f"{n} cases {where} → {out}"
        + (f"; {failed} failed (see the status column)" if failed else "")
    )
