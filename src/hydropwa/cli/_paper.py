"""``hydropwa paper``: the paper's study end to end (rig or measured data → report folder).

A thin wrapper over :func:`hydropwa.studies.paper.run_paper_study`; errors
(:class:`~hydropwa.HydropwaError`) go through the CLI's one error path (one line, exit 2).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ._app import new_app
from ._options import PRESET_NAMES, params_option, resolve_params

__all__ = ["app", "paper_command"]

#: The top-level ``paper`` command.
app = new_app()


@app.command("paper")
def paper_command(
    out: Annotated[
        Path,
        typer.Option(
            "--out",
            "-o",
            help="Report folder (index.html, figures/, tables/, identified.toml, pwa.json).",
        ),
    ] = Path("report"),
    data: Annotated[
        Path | None,
        typer.Option(
            "--data",
            "-d",
            help="Measured dataset folder with frf/, deadzone/, friction/, sine/ (default: run the virtual rig).",
        ),
    ] = None,
    params: Annotated[
        str | None,
        params_option(
            f"Parameter set: a preset ({PRESET_NAMES}) or a TOML/JSON parameter file; the "
            "rig's true parameters, or with --data the base (datasheet) parameters (default: "
            "paper; with --data the machine the data record, their true_params.toml or a manifest's "
            "'machine' entry; data that record none need --params)."
        ),
    ] = None,
    campaign: Annotated[
        str | None,
        typer.Option(
            "--campaign",
            "-c",
            help="Campaign TOML file or built-in name for the rig (default: paper).",
        ),
    ] = None,
    force: Annotated[
        bool, typer.Option("--force", help="Overwrite a report folder made from other inputs.")
    ] = False,
    fresh: Annotated[
        bool,
        typer.Option("--fresh", help="Recompute every stage instead of reusing finished ones."),
    ] = False,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bars.")] = False,
) -> None:
    """Run the paper's study: data → identification → PWA → evaluation → report; reruns reuse finished stages."""
    from hydropwa.studies.paper import (
        run_paper_study,  # deferred: loaded only when this command runs (a fast --help)
    )

    res = run_paper_study(
        out,
        data=data,
        params=None if params is None else resolve_params(params),
        campaign=campaign,
        fresh=fresh,
        overwrite=force,
        progress=not quiet,
    )
    fit = res.position_fit()  # the full model's (its default)
    reused = [k for k, v in res.stages.items() if v["reused"]]
    typer.echo(f"report: {res.report}")
    typer.echo(
        f"full-order position fit: mean {fit.mean():.1f} %, min {fit.min():.1f} % over {fit.size} sine runs"
    )
    if reused:
        typer.echo(f"reused stages: {', '.join(reused)}")
    typer.echo(f"done in {res.elapsed:.1f} s")
