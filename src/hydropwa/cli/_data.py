"""``hydropwa data``: check and convert measurement files and datasets.

Exit codes: 0 clean / done, 1 issues found (``check``), 2 unreadable input or error
(through the CLI's one error path, ``_app.exit_code``).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from ._app import new_app
from ._options import params_option, resolve_params

__all__ = ["app"]

app = new_app("data", help="Check and convert measurement files and datasets.")


#: ``--channel-map/-m``, shared by ``check`` and ``convert``.
ChannelMapOption = Annotated[
    Path | None,
    typer.Option(
        "--channel-map",
        "-m",
        help="Channel map TOML (or a built-in map name, e.g. emps) for raw files.",
    ),
]


def _print_issues(issues, plain: bool) -> None:
    if plain or not sys.stdout.isatty():
        for issue in issues:
            typer.echo(f"{issue.severity}: {issue}")
        return
    from rich.console import Console  # deferred: loaded only when this command runs (a fast --help)
    from rich.table import Table  # deferred: loaded only when this command runs (a fast --help)

    table = Table(title=f"{len(issues)} issue(s)")
    for col in ("severity", "run", "channel", "sample", "t [s]", "message", "hint"):
        table.add_column(col)
    for i in issues:
        table.add_row(
            i.severity,
            i.run,
            i.channel or "",
            "" if i.sample is None else str(i.sample),
            "" if i.time is None else f"{i.time:.6g}",
            i.message,
            i.hint,
        )
    Console().print(table)


@app.command("check")
def check(
    source: Annotated[
        Path, typer.Argument(help="Dataset folder or run file (.csv/.parquet/.mat).")
    ],
    channel_map: ChannelMapOption = None,
    plain: Annotated[bool, typer.Option("--plain", help="Plain lines instead of a table.")] = False,
) -> None:
    """Validate a dataset or a single run file and list every issue found."""
    from hydropwa.data import (
        check_dataset,  # deferred: loaded only when this command runs (a fast --help)
    )

    issues = check_dataset(source, channel_map)
    if not issues:
        typer.echo(f"ok: {source} has no issues")
        return
    _print_issues(issues, plain)
    if all(i.severity == "note" for i in issues):  # physical facts, nothing to repair
        typer.echo(f"ok: {source} has no issues ({len(issues)} note(s) above)")
        return
    raise typer.Exit(code=1)


@app.command("convert")
def convert(
    src: Annotated[Path, typer.Argument(help="Run file, dataset folder, or folder of raw files.")],
    dst: Annotated[Path, typer.Argument(help="Destination file or folder.")],
    channel_map: ChannelMapOption = None,
    format: Annotated[
        str | None, typer.Option("--format", "-f", help="Output format: csv, parquet or mat.")
    ] = None,
    resample: Annotated[
        bool, typer.Option("--resample", help="Resample non-uniform time bases (explicit repair).")
    ] = False,
    overwrite: Annotated[
        bool,
        typer.Option(
            "--force", "--overwrite", help="Replace an existing destination file or dataset."
        ),
    ] = False,
    params: Annotated[
        str | None,
        params_option(
            "The machine the runs were measured on (a TOML/JSON parameter file or a "
            "preset), recorded in the dataset's manifest as its 'machine' entry: identify and "
            "paper --data read it (a folder only)."
        ),
    ] = None,
) -> None:
    """Convert a run file or a folder to CSV, Parquet or MAT (validated, SI units)."""
    from hydropwa.data import (
        convert as convert_data,  # deferred: loaded only when this command runs (a fast --help)
    )

    meta = None if params is None else {"machine": resolve_params(params).to_dict()}
    out = convert_data(
        src,
        dst,
        channel_map=channel_map,
        format=format,
        overwrite=overwrite,
        resample=resample,
        meta=meta,
    )
    typer.echo(f"wrote {out}")


@app.command("import")
def import_command(
    logs: Annotated[
        Path, typer.Argument(help="Folder of the rig's logs, one <run>.csv/.parquet/.mat per run.")
    ],
    plan: Annotated[Path, typer.Option("--plan", help="The plan folder (hydropwa rig plan).")],
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Dataset folder: OUT/<experiment>/ datasets.")
    ] = Path("dataset"),
    channel_map: ChannelMapOption = None,
    format: Annotated[
        str, typer.Option("--format", "-f", help="Format of the runs: csv, parquet or mat.")
    ] = "parquet",
    force: Annotated[bool, typer.Option("--force", help="Replace an existing output.")] = False,
) -> None:
    """Import a real rig's logs of a plan: aligned, checked, ready for identify all."""
    from hydropwa.data import (
        import_logs,  # deferred: loaded only when this command runs (a fast --help)
    )

    result = import_logs(logs, plan, out, channel_map=channel_map, format=format, overwrite=force)
    typer.echo(result.summary())
