"""``hydropwa rig``: run the paper's experiments on the virtual rig.

Errors (:class:`~hydropwa.HydropwaError`) go through the CLI's one error path
(``_app.exit_code``): one ``error: ...`` line, exit 2.
"""

from __future__ import annotations

import os
import tempfile
import time
from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer

from ._app import error_line, new_app
from ._options import (
    ParamsOption,
    jobs_option,
    parse_sample_time,
    resolve_params,
    sample_time_option,
)

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
        str,
        typer.Option(
            "--campaign",
            "-c",
            help="Campaign TOML file or built-in name; 'machine': sized from --params.",
        ),
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
        campaign_for,
        parse_fault_spec,
        run_campaign,
    )

    check_jobs(jobs)
    if seed is not None and seed > 2**63 - 1:  # the seed is kept as a signed 64-bit integer
        from hydropwa._errors import ParameterError  # deferred: loaded only when this command runs

        raise ParameterError(f"--seed {seed} is larger than 2**63 - 1; give a smaller seed")
    check_output(out, True, folder=True, option="--out")  # a file there is not a folder
    faults = [parse_fault_spec(f) for f in fault] if fault else None
    machine = resolve_params(params)
    camp = campaign_for(campaign, machine)
    rig = Rig.from_params(machine).with_overrides(camp.sensors, camp.supply)
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
    from hydropwa.rig import (  # deferred: loaded only when this command runs (a fast --help)
        SIZED,
        builtin_campaigns,
    )

    for name in builtin_campaigns():
        typer.echo(name)
    typer.echo(f"{SIZED}  (the paper's experiments sized from --params: rig run, rig plan)")


def _limit(opt: str, help: str) -> typer.models.OptionInfo:  # noqa: A002 - typer's own word
    return typer.Option(opt, help=help)


@app.command("plan")
def plan_command(
    out: Annotated[
        Path,
        typer.Option("--out", "-o", help="Plan folder: manifest.json, commands/, plan.html."),
    ] = Path("plan"),
    params: ParamsOption = None,
    campaign: Annotated[
        str,
        typer.Option(
            "--campaign",
            "-c",
            help="Campaign TOML file (its [limits] table is read) or built-in name; "
            "'machine' (default): sized from --params.",
        ),
    ] = "machine",
    sample_time: Annotated[
        str,
        sample_time_option("The rig controller's sampling: a period ('1 ms') or a rate ('1 kHz')."),
    ] = "1 kHz",
    stroke_margin: Annotated[
        str | None, _limit("--stroke-margin", "Distance to each end stop (default 5 mm).")
    ] = None,
    min_pressure: Annotated[
        str | None, _limit("--min-pressure", "Lowest chamber pressure (default 0 bar).")
    ] = None,
    max_pressure: Annotated[
        str | None,
        _limit("--max-pressure", "Highest chamber pressure (default: the relief pressure)."),
    ] = None,
    max_velocity: Annotated[
        str | None, _limit("--max-velocity", "Highest rod speed (default 1 m/s).")
    ] = None,
    max_opening: Annotated[
        str | None, _limit("--max-opening", "Largest |valve command| [1] (default 1).")
    ] = None,
    max_duration: Annotated[
        str | None, _limit("--max-run-length", "Longest run (default 30 s).")
    ] = None,
    strict: Annotated[
        bool, typer.Option("--strict", help="Refuse a run that breaks a limit; do not adapt it.")
    ] = False,
    controller: Annotated[
        Path | None,
        typer.Option(
            "--controller",
            help="Position controller file (hydropwa control design) for the positioning "
            "moves; copied into the plan.",
        ),
    ] = None,
    force: Annotated[
        bool, typer.Option("--force", help="Replace an existing plan folder.")
    ] = False,
) -> None:
    """Plan a campaign for a real rig: command files, each run checked on the full model.

    Without --controller the positioning moves' controller is designed here (the default
    design at the rig's sample time, verified on the full model) and written into the plan
    with its verdict. Exit 0: every run planned and a verified controller written; exit 1:
    the plan is written, but runs were refused or the designed controller failed its
    verification (the manifest's ``refused`` and ``controller_design`` say why); exit 2:
    bad input, or --strict and a run breaks a limit (nothing written).
    """
    from hydropwa._io import (  # deferred: loaded only when this command runs (a fast --help)
        check_output,
        output_lock,
    )
    from hydropwa.rig import (  # deferred: loaded only when this command runs (a fast --help)
        campaign_for,
        parse_limits,
        plan_campaign,
    )
    from hydropwa.rig._plan import campaign_limits  # deferred: as above

    check_output(out, force, folder=True, option="--out")
    machine = resolve_params(params)
    given_design = {} if controller is None else _check_controller(controller, machine)
    camp = campaign_for(campaign, machine)
    given = {
        "stroke_margin": stroke_margin,
        "min_pressure": min_pressure,
        "max_pressure": max_pressure,
        "max_velocity": max_velocity,
        "max_opening": max_opening,
        "max_duration": max_duration,
    }
    table = {**campaign_limits(campaign), **{k: v for k, v in given.items() if v is not None}}
    limits = parse_limits(table, "limits")
    rate = 1.0 / parse_sample_time(sample_time)
    result = plan_campaign(machine, camp, limits, rate=rate, strict=strict)
    with tempfile.TemporaryDirectory(prefix="hydropwa-plan-") as tmp:
        written, design = (
            _default_controller(machine, 1.0 / rate, Path(tmp))
            if controller is None
            else (controller, given_design)
        )
        with output_lock(out.parent, "hydropwa rig plan", name=f".{out.name}.lock", clean=False):
            result.write(out, overwrite=force, controller=written, controller_design=design)
    typer.echo(result.summary())
    typer.echo(f"controller: {design['source']}: {_verdict_line(design)}")
    typer.echo(f"wrote {out}/manifest.json, commands/, plan.html")
    failed = [
        f"{len(result.refused)} run(s) refused (manifest 'refused')" if result.refused else "",
        "the controller failed its verification (manifest 'controller_design')"
        if written is None
        else "",
    ]
    if any(failed):
        error_line(f"the plan in {out} is incomplete: {'; '.join(f for f in failed if f)}")
        raise typer.Exit(code=1)


def _verdict_line(design: dict) -> str:
    v = design.get("verification")
    if not v:
        return "no verification recorded"
    n = len(v.get("failures", ()))
    return f"verification {v.get('verdict', '?')}" + (f", {n} failed check(s)" if n else "")


def _default_controller(machine, sample_time: float, tmp: Path) -> tuple[Path | None, dict]:
    """The default design (``DEFAULT_DESIGN``) at the rig's sample time, verified on the full
    model: its file in ``tmp`` (None when it fails its verification) and its record."""
    from hydropwa.control import (  # deferred: loaded only when this command runs
        DEFAULT_DESIGN,
        design_controller,
        save_controller,
    )
    from hydropwa.linearization import linearize  # deferred: as above

    typer.echo("designing the positioning controller (the default design, verified) ...")
    d = design_controller(linearize(machine), sample_time=sample_time)
    v = d.verification
    record = {
        "source": "designed by rig plan (the default design, control DEFAULT_DESIGN, "
        f"at the plan's sample time {1e3 * sample_time:g} ms)",
        "settings": {
            "method": DEFAULT_DESIGN.method,
            "sample_time": sample_time,
            "delay": DEFAULT_DESIGN.delay,
            "quiet": DEFAULT_DESIGN.quiet,
            "sensor_noise": dict(DEFAULT_DESIGN.sensor_noise),
            "draws": DEFAULT_DESIGN.draws,
            "seed": DEFAULT_DESIGN.seed,
        },
        "verification": None if v is None else v.to_dict(),
    }
    if v is not None and not v.passed:
        record["reason"] = (
            f"not written: it failed {len(v.failures)} check(s) of its verification on the "
            "full model; design one with `hydropwa control design` and give rig plan --controller"
        )
        return None, record
    path = tmp / "controller.toml"
    save_controller(d.controller, path, machine_parameters=machine)
    return path, record


def _check_controller(path: Path, machine) -> dict:
    """The controller file loads, and was designed for this machine's cylinder (if it says);
    its record for the manifest (``source``, the verdict the file carries)."""
    from hydropwa.control import (
        load_controller,  # deferred: loaded only when this command runs (a fast --help)
    )
    from hydropwa.identification import (
        check_same_machine,  # deferred: loaded only when this command runs (a fast --help)
    )

    from ._control import _machine_of  # deferred: the control CLI, only with --controller

    ctrl = load_controller(path)  # names a file that is not a controller
    check_same_machine(machine, _machine_of(path), str(path), "the controller's machine")
    return {"source": f"given (--controller {path})", "verification": ctrl.verification}
