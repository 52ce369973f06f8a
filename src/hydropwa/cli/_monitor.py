"""``hydropwa monitor``: the health of logged runs of an identified axis.

Errors (:class:`~hydropwa.HydropwaError`) go through the CLI's one error path
(``_app.exit_code``): one ``error: ...`` line, exit 2.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ._app import new_app
from ._options import ParamsOption, resolve_params

__all__ = ["app"]

app = new_app()


@app.command("monitor")
def monitor_command(
    data: Annotated[
        Path,
        typer.Argument(
            help="A dataset folder (manifest.json), or a campaign folder of datasets (all are checked)."
        ),
    ],
    params: ParamsOption = None,
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Report folder: health.json and health.html.")
    ] = Path("health"),
    false_alarm: Annotated[
        float,
        typer.Option(
            "--false-alarm",
            help="False-alarm probability per healthy run the thresholds are sized for (default 1e-3).",
        ),
    ] = 1e-3,
    c_dir: Annotated[
        Path | None,
        typer.Option(
            "--c",
            help="Also write the residual generator as C99 for the target (hydropwa_monitor.h, "
            "hydropwa_monitor.c, README.md), its thresholds the widest of these runs'.",
        ),
    ] = None,
    force: Annotated[
        bool,
        typer.Option("--force", help="Overwrite an existing health.json / health.html (and --c)."),
    ] = False,
) -> None:
    """Health indicators, thresholds and alarms of each run (the identified machine in --params)."""
    from hydropwa._io import (  # deferred: loaded only when this command runs (a fast --help)
        check_output,
    )
    from hydropwa.monitor import (  # deferred: loaded only when this command runs (a fast --help)
        HealthMonitor,
    )
    from hydropwa.monitor._report import (  # deferred: loaded only when this command runs
        HEALTH_HTML,
        HEALTH_JSON,
    )

    machine = resolve_params(params)
    check_output(out, force, folder=True, option="--out", files=(HEALTH_JSON, HEALTH_HTML))
    if c_dir is not None:
        check_output(c_dir, force, folder=True, option="--c")
    monitor = HealthMonitor(false_alarm=false_alarm).fit(machine)
    runs = list(_runs(data))
    report = monitor.check_dataset(runs)
    paths = report.write(out, overwrite=force)
    typer.echo(report.summary())
    typer.echo(f"wrote {paths['json']} and {paths['html']}")
    if c_dir is not None:
        _export_c(monitor, report, runs, c_dir, force)


def _export_c(monitor, report, runs, c_dir: Path, force: bool) -> None:
    """The on-target generator, sized on the checked runs (one sampling rate)."""
    from hydropwa._errors import DataError  # deferred: loaded only when this command runs
    from hydropwa.monitor._target import export_c  # deferred: the C writer, only with --c

    checked = {r.run for r in report.runs}
    rates = {float(r.fs) for r in runs if r.name in checked}
    if len(rates) != 1:
        raise DataError(
            f"--c needs runs of one sampling rate (the filter's coefficients); got "
            f"{sorted(rates) or 'no checked run'} Hz: give a dataset of one rate"
        )
    export_c(monitor, report, rates.pop(), c_dir, overwrite=force)
    typer.echo(f"wrote the on-target residual generator to {c_dir}")


def _runs(data: Path):
    """The runs of a dataset folder, or of every dataset folder in a campaign folder, in order."""
    from hydropwa._errors import DataError  # deferred: loaded only when this command runs
    from hydropwa.data import MANIFEST, read_dataset  # deferred: pandas/pint at this boundary

    if (data / MANIFEST).is_file():
        yield from read_dataset(data)
        return
    folders = sorted(p for p in data.iterdir() if (p / MANIFEST).is_file()) if data.is_dir() else []
    if not folders:
        raise DataError(
            f"{data}: no dataset here (no {MANIFEST}, nor a folder with one); give a dataset folder "
            "or a campaign folder written by `hydropwa rig run`"
        )
    for folder in folders:
        yield from read_dataset(folder)
