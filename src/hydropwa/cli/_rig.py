"""``hydropwa rig``: run the paper's experiments on the virtual rig.

Errors (:class:`~hydropwa.HydropwaError`) go through the CLI's one error path
(``_app.exit_code``): one ``error: ...`` line, exit 2.
"""

from __future__ import annotations

import os
import time
from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer

from ._app import new_app
from ._options import ParamsOption, jobs_option, resolve_params

__all__ = ["app"]

app = new_app("rig", help="Virtual test rig: simulate the paper's experiments into datasets.")


class Which(StrEnum):
    frf = "frf"
    deadzone = "deadzone"
    friction = "friction"
    sine = "sine"
    all = "all"


@app.command("run")
def run_command(
    experiment: Annotated[
        Which, typer.Argument(help="Experiment to run, or all of the campaign's.")
    ],
    out: Annotated[
        Path,
        typer.Option(
            "--out",
            "-o",
            help="Output folder: DIR/<experiment>/ datasets and DIR/true_params.toml.",
        ),
    ] = Path("campaign"),
    params: ParamsOption = None,
    campaign: Annotated[
        str, typer.Option("--campaign", "-c", help="Campaign TOML file or built-in name.")
    ] = "paper",
    seed: Annotated[
        int | None,
        typer.Option("--seed", min=0, help="Campaign seed ≥ 0 (default: the campaign's)."),
    ] = None,
    jobs: Annotated[
        int | None,
        jobs_option("Worker processes; results do not depend on it"),
    ] = None,
    force: Annotated[
        bool, typer.Option("--force", help="Overwrite an output made with other settings.")
    ] = False,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")] = False,
    fault: Annotated[
        list[str] | None,
        typer.Option(
            "--fault",
            help="Inject a fault as KIND=SIZE, optionally @AT (a leakage's rated pressure) and "
            ":growing (repeatable; replaces the campaign's faults tables), e.g. "
            "'internal_leakage=0.1 L/min@50 bar', 'friction=30 %:growing'.",
        ),
    ] = None,
) -> None:
    """Simulate experiments on the virtual rig; reruns resume and skip finished runs."""
    from hydropwa._io import (  # deferred: loaded only when this command runs (a fast --help)
        check_output,
        output_lock,
    )
    from hydropwa._limits import (
        check_jobs,  # deferred: loaded only when this command runs (a fast --help)
    )
    from hydropwa.rig import (  # deferred: loaded only when this command runs (a fast --help)
        Rig,
        load_campaign,
        parse_fault_spec,
        run_campaign,
    )

    check_jobs(jobs)
    if seed is not None and seed > 2**63 - 1:  # the seed is kept as a signed 64-bit integer
        from hydropwa._errors import ParameterError  # deferred: loaded only when this command runs

        raise ParameterError(f"--seed {seed} is larger than 2**63 - 1; give a smaller seed")
    check_output(out, True, folder=True, option="--out")  # a file there is not a folder
    faults = [parse_fault_spec(f) for f in fault] if fault else None
    camp = load_campaign(campaign)
    rig = Rig.from_params(resolve_params(params)).with_overrides(camp.sensors, camp.supply)
    if not quiet:
        typer.echo(_describe(rig))
    names = None if experiment is Which.all else [experiment.value]
    t0 = time.perf_counter()
    with output_lock(out, "hydropwa rig run"):  # one campaign per folder; clears stale temps
        datasets = run_campaign(
            rig,
            camp,
            out,
            experiments=names,
            seed=seed,
            jobs=jobs or os.cpu_count() or 1,
            progress=not quiet,
            overwrite=force,
            faults=faults,
        )
    runs = sum(len(ds) for ds in datasets.values())
    typer.echo(
        f"wrote {runs} runs in {len(datasets)} dataset(s) under {out} "
        f"({', '.join(datasets)}) in {time.perf_counter() - t0:.1f} s"
    )


def _describe(rig) -> str:
    """One line: the sensors and supply the rig uses for this machine (sized or overridden)."""
    s, sup = rig.sensors, rig.supply
    x = s.get("x")
    p = s.get("p_a")
    f = s.get("f_l")
    parts = []
    if x is not None:
        parts.append(f"position {1e3 * x.range[0]:g}…{1e3 * x.range[1]:g} mm")
    if p is not None:
        parts.append(f"pressures {p.range[0] / 1e5:g}–{p.range[1] / 1e5:g} bar")
    if f is not None:
        parts.append(f"load cell ±{f.range[1] / 1e3:g} kN")
    parts.append(
        f"pump {sup.pump_flow * 6e4:.3g} L/min at {sup.pressure / 1e5:g} bar, relief "
        f"{sup.relief_pressure / 1e5:g} bar"
    )
    return "rig: " + ", ".join(parts)


@app.command("campaigns")
def campaigns_command() -> None:
    """List the built-in campaigns."""
    from hydropwa.rig import (
        builtin_campaigns,  # deferred: loaded only when this command runs (a fast --help)
    )

    for name in builtin_campaigns():
        typer.echo(name)
