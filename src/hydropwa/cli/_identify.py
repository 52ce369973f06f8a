"""``hydropwa identify``: parameters from measurements (Sec. VI of the paper).

Each command calls one public function of :mod:`hydropwa.identification` and
writes files; user errors print ``error: ...`` on stderr and exit 2, and skipped
runs are reported as ``warning: ...`` lines (both by the CLI's ``_app``).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Annotated, Any

import typer

from hydropwa._errors import IdentificationError, ParameterError
from hydropwa._io import check_output
from hydropwa._layout import DEFAULT_KIND, MEASURABLE_MODELS

from ._app import new_app
from ._options import BaseParamsAlias, jobs_option, params_source, resolve_params
from ._options import MachineParamsOption as ParamsOption

__all__ = ["app"]

app = new_app(
    "identify", help="Identify valve, dead-zone and friction parameters from measurements."
)

DataDir = Annotated[
    Path,
    typer.Argument(help="Dataset folder, or a campaign folder with one dataset per experiment."),
]
Out = Annotated[Path, typer.Option("--out", "-o", help="Parameter TOML to write.")]
Figures = Annotated[Path | None, typer.Option("--figures", help="Folder for the figures (PNG).")]
Summary = Annotated[
    Path | None, typer.Option("--summary", help="Markdown summary (default: OUT with .md).")
]
Force = Annotated[
    bool, typer.Option("--force", help="Overwrite an existing parameter file, summary and figures.")
]


#: Figures ``identify`` writes (``IdentificationReport.save``); other files may share the folder.
_FIGURES = ("fig05_valve_bode.png", "fig06_dead_zone.png", "fig08_stribeck.png")
Band = Annotated[
    str | None,
    typer.Option(
        "--band",
        help="FRF band used in the fit, 'F0:F1' ('2:150' in Hz, or '2 Hz:0.15 kHz'); default: each "
        "broadband run's excited band, all stepped-sine points.",
    ),
]
DeadZoneForm = Annotated[
    str | None,
    typer.Option(
        "--dead-zone-form",
        help="Dead-zone form fitted: 'table' (Table IV, with the jump) or 'continuous'; "
        "default: the form of --params.",
    ),
]


def _options(band: str | None, dead_zone_form: str | None) -> tuple[dict, dict]:
    """Estimator settings from the CLI options (``ParameterError`` on bad values)."""
    from hydropwa._errors import (
        ParameterError,  # deferred: loaded only when this command runs (a fast --help)
    )
    from hydropwa.params import (
        parse_quantity,  # deferred: loaded only when this command runs (a fast --help)
    )

    frf: dict = {}
    dz: dict = {}
    if band is not None:
        lo, sep, hi = band.partition(":")
        if not sep:
            raise ParameterError(f"--band {band!r} must be 'F0:F1', e.g. '2:150' (Hz)")
        f0, f1 = (
            parse_quantity(lo.strip(), "Hz", "--band F0"),
            parse_quantity(hi.strip(), "Hz", "--band F1"),
        )
        if not (0 < f0 < f1):
            raise ParameterError(f"--band {band!r}: need 0 < F0 < F1")
        frf["band"] = (f0, f1)
    if dead_zone_form is not None:
        if dead_zone_form not in ("table", "continuous"):
            raise ParameterError(
                f"--dead-zone-form {dead_zone_form!r} must be 'table' or 'continuous'"
            )
        dz["continuous"] = dead_zone_form == "continuous"
    return frf, dz


def _machine(data_dir: Path, source: str | None):
    """``--params`` checked against the data's machine, else the data's; none: exit 2."""
    from hydropwa.identification import (
        machine_for,  # deferred: loaded only when this command runs (a fast --help)
    )

    given = None if source is None else resolve_params(source)
    return machine_for(data_dir, given)


def _run(
    parts: tuple[str, ...],
    data_dir: Path,
    out: Path,
    figures: Path | None,
    base: str | None,
    summary: Path | None,
    force: bool = False,
    band: str | None = None,
    dead_zone_form: str | None = None,
) -> None:
    from hydropwa.identification import (  # deferred: loaded only when this command runs (a fast --help)
        DeadZoneIdentifier,
        ValveFrfIdentifier,
        identify,
    )

    if out.suffix.lower() != ".toml":
        raise ParameterError(f"--out {out} must end in .toml")
    check_output(out, force, option="--out")
    summary_path = summary if summary is not None else out.with_suffix(".md")
    if summary_path.resolve() == out.resolve():
        raise ParameterError("--summary and --out name the same file; give two names")
    check_output(summary_path, force, option="--summary")
    if figures is not None:
        check_output(figures, force, folder=True, option="--figures", files=_FIGURES)
    frf_opts, dz_opts = _options(band, dead_zone_form)
    params = _machine(data_dir, base)
    from ._progress import step  # deferred: loaded only when this command runs (a fast --help)

    with step(f"identifying {', '.join(parts)} from {data_dir}"):
        report = identify(
            data_dir,
            parts,
            params=params,
            estimators={
                "frf": ValveFrfIdentifier(**frf_opts),
                "deadzone": DeadZoneIdentifier(params, **dz_opts),
            },
        )
    with step("writing parameters, figures and summary"):
        written = report.save(out, figures, summary, overwrite=True)  # checked with --force above
    for role, path in written.items():
        typer.echo(f"wrote {role}: {path}")
    if report.skipped:
        typer.echo(f"{len(report.skipped)} run(s) or part(s) skipped; see {written['summary']}")


@app.command("frf")
def frf(
    data_dir: DataDir,
    out: Out = Path("identified.toml"),
    figures: Figures = None,
    params: ParamsOption = None,
    base_params: BaseParamsAlias = None,
    summary: Summary = None,
    force: Force = False,
    band: Band = None,
) -> None:
    """Servo valve ω0 and ζ per amplitude from stepped-sine or broadband runs (Sec. VI-A)."""
    _run(
        ("frf",),
        data_dir,
        out,
        figures,
        params_source(params, base_params),
        summary,
        force,
        band=band,
    )


@app.command("deadzone")
def deadzone(
    data_dir: DataDir,
    out: Out = Path("identified.toml"),
    figures: Figures = None,
    params: ParamsOption = None,
    base_params: BaseParamsAlias = None,
    summary: Summary = None,
    force: Force = False,
    dead_zone_form: DeadZoneForm = None,
) -> None:
    """Dead band β and creep slope from constant-input runs (Sec. VI-B)."""
    _run(
        ("deadzone",),
        data_dir,
        out,
        figures,
        params_source(params, base_params),
        summary,
        force,
        dead_zone_form=dead_zone_form,
    )


@app.command("friction")
def friction(
    data_dir: DataDir,
    out: Out = Path("identified.toml"),
    figures: Figures = None,
    params: ParamsOption = None,
    base_params: BaseParamsAlias = None,
    summary: Summary = None,
    force: Force = False,
) -> None:
    """Stribeck friction from constant-input runs against a counter force (Sec. VI-C)."""
    _run(("friction",), data_dir, out, figures, params_source(params, base_params), summary, force)


@app.command("all")
def identify_all(
    data_dir: DataDir,
    out: Out = Path("identified.toml"),
    figures: Figures = None,
    params: ParamsOption = None,
    base_params: BaseParamsAlias = None,
    summary: Summary = None,
    force: Force = False,
    band: Band = None,
    dead_zone_form: DeadZoneForm = None,
) -> None:
    """Valve, dead zone and friction from whatever experiments the data hold."""
    _run(
        ("frf", "deadzone", "friction"),
        data_dir,
        out,
        figures,
        params_source(params, base_params),
        summary,
        force,
        band=band,
        dead_zone_form=dead_zone_form,
    )


@app.command("emps")
def emps(
    file: Annotated[Path, typer.Argument(help="EMPS benchmark estimation file (DATA_EMPS.mat).")],
    validation: Annotated[
        Path | None,
        typer.Option(
            "--validation",
            help="Cross-test file (default: DATA_EMPS_PULSES.mat beside FILE, if present).",
        ),
    ] = None,
    figures: Figures = None,
    summary: Annotated[
        Path | None, typer.Option("--summary", help="Markdown summary to write.")
    ] = None,
    asymmetric: Annotated[
        bool, typer.Option("--asymmetric", help="Separate Coulomb levels per direction.")
    ] = False,
    force: Annotated[
        bool, typer.Option("--force", help="Overwrite an existing summary and figure.")
    ] = False,
) -> None:
    """Mass, viscous and Coulomb friction and offset of the EMPS benchmark by IDIM-LS."""
    from hydropwa.identification import (
        identify_emps,  # deferred: loaded only when this command runs (a fast --help)
    )
    from hydropwa.plotting import (  # deferred: loaded only when this command runs (a fast --help)
        plot_inverse_dynamics,
        save_figure,
    )

    if validation is None:
        cand = file.with_name("DATA_EMPS_PULSES.mat")
        validation = cand if cand.is_file() and cand.resolve() != file.resolve() else None
    if not file.is_file():
        raise FileNotFoundError(2, "no such file", str(file))
    if summary is not None:
        check_output(summary, force, option="--summary")
    if figures is not None:
        check_output(figures, force, folder=True, option="--figures", files=("emps_force.png",))
    res = identify_emps(file, validation, asymmetric=asymmetric)
    text = res.summary_markdown()
    if summary is not None:
        from hydropwa._io import (
            atomic_write_text,  # deferred: loaded only when this command runs (a fast --help)
        )

        atomic_write_text(summary, text, overwrite=force)
    if figures is not None:
        figures.mkdir(parents=True, exist_ok=True)
        save_figure(plot_inverse_dynamics(res), figures / "emps_force.png", overwrite=True)
    typer.echo(text, nl=False)


def _truth(data_dir: Path, names: Sequence[str]) -> dict[str, float] | None:
    """The true values of ``names`` where the data are a virtual rig's (its
    ``true_params.toml``), else None: the summary then flags an interval that misses one."""
    import json  # deferred: loaded only when this command runs

    from hydropwa._io import read_text  # deferred: loaded only when this command runs
    from hydropwa.data import MANIFEST  # deferred: loaded only when this command runs
    from hydropwa.identification import (  # deferred: loaded only when this command runs
        MACHINE_FILE,
        recorded_machine,
    )
    from hydropwa.identification.greybox.problem import get_value  # deferred: as above

    found = recorded_machine(data_dir)
    if found is None:
        return None
    rig = found[1].endswith(MACHINE_FILE)
    if not rig and found[1].endswith(MANIFEST):  # a dataset the virtual rig wrote
        meta = json.loads(read_text(found[1], "manifest")).get("meta") or {}
        rig = "true_params" in meta
    return {n: get_value(found[0], n) for n in names} if rig else None


def _joint_start(start: str, free: str) -> str | None:
    """``--start`` for :func:`~hydropwa.identification.greybox.fit_campaign` (None: the
    ordinary fit): ``auto`` makes ``--free all`` a joint fit (the library then starts from
    parameters identify all wrote, else runs it first)."""
    if start not in ("auto", "identify", "params"):
        raise IdentificationError(f"--start {start!r}: choose auto, identify or params")
    if start == "auto" and "all" not in [f.strip() for f in free.split(",")]:
        return None
    return start


@app.command("model")
def model(
    data_dir: DataDir,
    free: Annotated[
        str,
        typer.Option(
            "--free",
            help="Parameters to fit, comma-separated dotted names as in the parameter file "
            "(friction.static, oil.bulk_modulus, cylinder.leakage, flow.K) or groups (friction).",
        ),
    ],
    out: Out = Path("fitted.toml"),
    model_kind: Annotated[
        str, typer.Option("--model", help="Model to fit: full or reduced.")
    ] = DEFAULT_KIND.name,
    params_src: ParamsOption = None,
    base_params: BaseParamsAlias = None,
    channels: Annotated[
        str | None,
        typer.Option(
            "--channels",
            help="Fitted channels, comma-separated (default x,p_a,p_b and v where logged).",
        ),
    ] = None,
    shooting: Annotated[
        str, typer.Option("--shooting", help="auto (by each run's content), single or multiple.")
    ] = "auto",
    window: Annotated[
        float, typer.Option("--window", help="Multiple-shooting window in seconds.")
    ] = 0.02,
    starts: Annotated[
        int, typer.Option("--starts", help="Number of optimiser starts (multi-start).")
    ] = 1,
    loss: Annotated[
        str, typer.Option("--loss", help="linear, soft_l1, huber, cauchy or arctan.")
    ] = "linear",
    jobs: Annotated[
        int | None,
        jobs_option("Threads"),
    ] = None,
    sliding: Annotated[
        bool | None,
        typer.Option(
            "--sliding/--no-sliding",
            help="With friction.coulomb free: refit all but the breakaway parameters on the "
            "stretches sliding faster than twice the Stribeck velocity (the sliding stage; "
            "default: on, off in the joint fit of --free all).",
        ),
    ] = None,
    select: Annotated[
        str,
        typer.Option(
            "--select",
            help="Data of a campaign: auto (select above 60 s of data), events (always select "
            "the segments that excite the free parameters) or all.",
        ),
    ] = "auto",
    budget: Annotated[
        float,
        typer.Option("--budget", help="Seconds of data a selection keeps over the campaign."),
    ] = 6.0,
    validate: Annotated[
        float,
        typer.Option(
            "--validate",
            help="Share of the runs held out of the fit; the summary reports the fit % of "
            "every channel on them (0: none).",
        ),
    ] = 0.0,
    scheduler: Annotated[
        str | None,
        typer.Option(
            "--scheduler",
            help="Dask scheduler address or 'local' for the starts and profiles (default: a "
            "local cluster when --jobs > 1 and --starts > 1, else in-process).",
        ),
    ] = None,
    start: Annotated[
        str,
        typer.Option(
            "--start",
            help="Where the fit starts: auto (with --free all, run identify all first unless "
            "--params is a file identify all wrote), identify (run it first) or params.",
        ),
    ] = "auto",
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress output.")] = False,
    figures: Figures = None,
    summary: Summary = None,
    force: Force = False,
) -> None:
    """Grey-box fit: simulate the model with each run's measured inputs and fit free parameters.

    With --free all (or --start identify) the whole campaign is fitted jointly: every
    experiment contributes the channels it logs (x, p_a, p_b, spool), started from the
    per-experiment estimates of identify all."""
    from hydropwa.identification import (  # deferred: loaded only when this command runs (a fast --help)
        Shooting,
        fit_model,
        load_runs,
    )
    from hydropwa.identification.greybox import (  # deferred: loaded only when this command runs (a fast --help)
        Selection,
    )

    from ._progress import (
        fit_progress,  # deferred: loaded only when this command runs (a fast --help)
    )

    check_output(out, force)
    summary = summary or out.with_suffix(".md")
    check_output(summary, force)
    if figures is not None:
        check_output(figures, force, folder=True, option="--figures", files=("greybox_*.png",))
    if model_kind not in MEASURABLE_MODELS:
        choose = " or ".join(MEASURABLE_MODELS)
        raise IdentificationError(f"--model {model_kind!r}: choose {choose}")
    selection = Selection(method=select, budget=budget)
    if scheduler is not None:
        from hydropwa.sweep import (  # deferred: loaded only when this command runs (a fast --help)
            check_scheduler,
        )

        check_scheduler(scheduler)
    elif (jobs or 1) > 1 and starts > 1:
        scheduler = "local"
    params = _machine(data_dir, params_source(params_src, base_params))
    begin = _joint_start(start, free)
    chans = [c.strip() for c in channels.split(",") if c.strip()] if channels else None
    settings: dict[str, Any] = dict(
        channels=chans, shooting=Shooting(method=shooting, window=window), starts=starts,
        loss=loss, jobs=jobs, validate=validate, scheduler=scheduler,
    )  # fmt: skip
    if sliding is not None:  # else each fit's own default (fit_model: on; fit_campaign: off)
        settings["sliding"] = sliding
    with fit_progress("grey-box fit", quiet) as progress:
        if begin is None:
            runs = load_runs(data_dir, params=params)
            fit = fit_model(
                model_kind, runs, free, params=params, selection=selection,
                progress=progress, **settings,
            )  # fmt: skip
        else:
            from hydropwa.identification.greybox import (  # deferred: loaded only when this command runs (a fast --help)
                fit_campaign,
            )

            joint = Selection(method="events", budget=budget, by_experiment=True)
            fit = fit_campaign(
                str(data_dir), free, params=params, start=begin, model=model_kind,
                selection=selection if select != "auto" else joint, progress=progress,
                **settings,
            ).fit  # fmt: skip
    fit.save(out, overwrite=force)
    from hydropwa._io import (
        atomic_write_text,  # deferred: loaded only when this command runs (a fast --help)
    )

    atomic_write_text(summary, fit.summary_markdown(_truth(data_dir, fit.free)), overwrite=force)
    if figures is not None:
        _fit_figures(fit, figures)
    for n, e in fit.estimates_.items():
        typer.echo(f"{n} = {e}")
    typer.echo(f"wrote parameters: {out}")
    typer.echo(f"wrote summary: {summary}")


def _fit_figures(fit, figures: Path) -> None:
    """``identify model --figures``: the fit and residuals of the first six runs, the profiles."""
    from hydropwa.plotting import (  # deferred: loaded only when this command runs (a fast --help)
        plot_greybox_fit,
        plot_greybox_profiles,
        plot_greybox_residuals,
        save_figure,
    )

    figures.mkdir(parents=True, exist_ok=True)
    for r in fit.runs_[:6]:
        save_figure(
            plot_greybox_fit(fit, r.name), figures / f"greybox_{r.name}.png", overwrite=True
        )
        save_figure(
            plot_greybox_residuals(fit, r.name),
            figures / f"greybox_residuals_{r.name}.png",
            overwrite=True,
        )
    if fit.profiles_:
        save_figure(plot_greybox_profiles(fit), figures / "greybox_profiles.png", overwrite=True)
