"""``hydropwa params`` and ``hydropwa simulate``: thin wrappers over the public API."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Annotated

import typer

from .._display import ENGINEERING_UNITS
from .._errors import ParameterError, SignalError
from .._io import check_output
from .._layout import DEFAULT_KIND
from ..params import FIELD_UNITS, PRESETS, parse_quantity, save_params
from ._app import new_app
from ._options import (
    MACHINE_FIX,
    ParamsOption,
    duration_option,
    parse_sample_time,
    resolve_params,
    sample_time_option,
    sample_time_source,
)

__all__ = ["app", "params_app", "simulate_command"]

#: File types of ``--plot`` (matplotlib picks the format from the suffix).
PLOT_SUFFIXES = (".png", ".svg", ".pdf")

#: Top-level commands of this module (``simulate``) and the ``params`` group.
app = new_app()
params_app = new_app("params", help="Show and export parameter sets (presets or TOML/JSON files).")
app.add_typer(params_app)

#: SI unit → (display unit, factor) for `params show`: the package's table for the units
#: shown otherwise than in SI, and dimensionless fields (unit "") as percentages
_ENGINEERING = {u: ENGINEERING_UNITS[u] for u in ("Pa", "m**3", "m**3/s", "m**2", "m", "m/s")} | {
    "": ENGINEERING_UNITS["1"]
}
_NOT_PERCENT = {"zeta", "shape", "creep_slope"}


@params_app.command("show")
def params_show(
    source: Annotated[
        str,
        typer.Argument(
            metavar="PRESET|FILE", help=f"Preset ({', '.join(PRESETS)}) or TOML/JSON file."
        ),
    ] = "paper",
) -> None:
    """Print a parameter set with SI values, engineering units and where each value came from.

    The ``from`` column is :attr:`SystemParams.provenance`: ``file``, ``base '<preset>'``
    (inherited), ``default`` (the class default of a field a complete file left out),
    ``preset '<name>'``, or a base table the file's own value dropped.
    """
    from rich.console import Console  # deferred: loaded only when this command runs (a fast --help)
    from rich.table import Table  # deferred: loaded only when this command runs (a fast --help)

    params = resolve_params(source, option="parameter set")
    table = Table(title=f"parameters: {source}")
    for col in ("group", "field", "SI value", "SI unit", "engineering", "from"):
        table.add_column(col)
    provenance = params.provenance
    for comp, units in FIELD_UNITS.items():
        obj = getattr(params, comp)
        for f in dataclasses.fields(obj):
            val = getattr(obj, f.name)
            unit = units[f.name]
            eng = ""
            if unit is not None and isinstance(val, float):
                if unit in _ENGINEERING and not (unit == "" and f.name in _NOT_PERCENT):
                    u_disp, fac = _ENGINEERING[unit]
                    eng = f"{val * fac:.6g} {u_disp}"
            table.add_row(
                comp,
                f.name,
                f"{val:.6g}" if isinstance(val, float) else str(val),
                unit or "1" if unit is not None else "",
                eng,
                provenance[f"{comp}.{f.name}"],
            )
    Console(width=150).print(table)


@params_app.command("export")
def params_export(
    source: Annotated[
        str,
        typer.Argument(
            metavar="PRESET|FILE", help=f"Preset ({', '.join(PRESETS)}) or TOML/JSON file."
        ),
    ] = "paper",
    out: Annotated[Path, typer.Option("--out", "-o", help="TOML file to write.")] = Path(
        "params.toml"
    ),
    force: Annotated[bool, typer.Option("--force", help="Overwrite an existing file.")] = False,
) -> None:
    """Write a parameter set to a hand-editable TOML file."""
    if out.suffix.lower() != ".toml":
        raise ParameterError(f"--out {out} must end in .toml")
    check_output(out, force, option="--out")
    params = resolve_params(source, option="parameter set")
    save_params(
        params, out, header=f"exported from {source}", overwrite=True
    )  # checked with --force above
    typer.echo(f"wrote {out}")


@app.command("simulate")
def simulate_command(
    model: Annotated[
        str, typer.Option("--model", "-m", help="full, reduced, pwa or pwa-chamber.")
    ] = DEFAULT_KIND.name,
    params: ParamsOption = None,
    input: Annotated[
        str | None,
        typer.Option(
            "--input",
            "-i",
            help="Valve command spec, e.g. 'sine:amplitude=0.4,frequency=1' (fractions; '40 %' works).",
        ),
    ] = None,
    input_file: Annotated[
        Path | None,
        typer.Option(
            "--input-file",
            help="Replay the command channel 'u' of a measured run (CSV/Parquet/MAT); in volts where the machine sets [valve] command_voltage.",
        ),
    ] = None,
    duration: Annotated[
        str | None,
        duration_option(
            "Simulated time [s], e.g. '2 s' or '500 ms' (default: 5, or the input file's length)."
        ),
    ] = None,
    supply_pressure: Annotated[
        str | None,
        typer.Option("--supply-pressure", help="Constant ('95 bar') or signal spec for P_S."),
    ] = None,
    load_force: Annotated[
        str | None, typer.Option("--load-force", help="Constant ('500 N') or signal spec for F_L.")
    ] = None,
    x0: Annotated[
        str | None,
        typer.Option("--x0", help="Initial rod position ('100 mm'); default mid-stroke."),
    ] = None,
    sample_time: Annotated[
        str | None,
        sample_time_option(
            "Output sampling: a period ('0.5 ms') or a rate ('2 kHz') (default: 0.5 ms)."
        ),
    ] = None,
    fs: Annotated[
        str | None, typer.Option("--fs", hidden=True, help="Deprecated name of --sample-time.")
    ] = None,
    rtol: Annotated[
        float,
        typer.Option(
            "--rtol",
            help="Relative tolerance of the integrator (default 1e-3: position within 0.1 mm on the paper rig).",
        ),
    ] = 1e-3,
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Output file (.csv or .parquet).")
    ] = Path("run.csv"),
    plot: Annotated[
        Path | None, typer.Option("--plot", help="Also write a plot (.png/.svg/.pdf).")
    ] = None,
    force: Annotated[
        bool, typer.Option("--force", help="Overwrite existing output files.")
    ] = False,
) -> None:
    """Simulate a model and write the trajectory (CSV or Parquet) and optionally a plot."""
    from .._layout import (  # deferred: loaded only when this command runs
        MODEL_NAMES,
        build_model,
        model_kind,
    )
    from ..models import Model  # deferred: loaded only when this command runs (a fast --help)
    from ..simulation import (  # deferred: loaded only when this command runs (a fast --help)
        Sampled,
        WarmUp,
        simulate,
    )

    if model not in MODEL_NAMES:
        raise ParameterError(f"--model {model!r} is unknown; choose {', '.join(MODEL_NAMES)}")
    from .._limits import (  # deferred: loaded only when this command runs (a fast --help)
        check_position,
        check_rtol,
        check_samples,
        check_supply_pressure,
    )

    if out.suffix.lower() not in (".csv", ".parquet"):
        raise ParameterError(f"--out {out} must end in .csv or .parquet")
    if plot is not None and plot.suffix.lower() not in PLOT_SUFFIXES:
        raise ParameterError(f"--plot {plot} must end in {', '.join(PLOT_SUFFIXES)}")
    check_output(out, force, option="--out")
    if plot is not None:
        check_output(plot, force, option="--plot")
        if plot.resolve() == out.resolve():
            raise ParameterError("--plot and --out name the same file; give two names")
    check_rtol(rtol)
    if input is not None and input_file is not None:
        raise SignalError("give either --input or --input-file, not both")
    duration_s = None if duration is None else parse_quantity(duration, "s", "--duration")
    sampling = sample_time_source(sample_time, fs, "--fs", "Hz")
    fs_hz = round(1.0 / parse_sample_time(sampling), 9)  # '0.5 ms' → exactly 2000 Hz
    u: Sampled | str
    volts = ""
    if input_file is not None:
        prm, u, run_duration, volts = _replayed_command(input_file, params)
        duration_s = run_duration if duration_s is None else duration_s
    else:
        prm = resolve_params(params)
        u = input if input is not None else "sine:amplitude=0.4,frequency=1"
    duration_f = 5.0 if duration_s is None else duration_s
    check_samples(duration_f, fs_hz)
    check_supply_pressure(supply_pressure, prm, duration_f)
    x_init = parse_quantity(x0, "m", "--x0") if x0 is not None else None
    check_position(x_init, prm)
    # with a given P_S (constant or a signal) the PWA cells follow it online: the scheduled model
    linearized = model_kind(model).linearized
    mdl: Model = build_model(
        model, prm, **({"scheduled": supply_pressure is not None} if linearized else {})
    )
    # on a fresh install, the output pass compiles on the other core while this process
    # compiles the solver (nothing starts when it is cached)
    WarmUp([f"output-{model}"])
    res = simulate(
        mdl,
        u,
        duration=duration_f,
        supply_pressure=supply_pressure,
        load_force=load_force,
        initial_position=x_init,
        fs=fs_hz,
        rtol=rtol,
    )
    res.save(out, overwrite=True)  # checked with --force above
    msg = f"wrote {out} ({res.t.size} samples, {res.stats['steps']} steps, {res.stats['wall_time'] * 1e3:.1f} ms"
    if res.stats.get("compile_time", 0.0) > 0.5:
        msg += f"; solver loaded/compiled in {res.stats['compile_time']:.1f} s, once"
    msg += f"{volts})"
    if plot is not None:
        from ..plotting import (  # deferred: loaded only when this command runs (a fast --help)
            plot_result,
            save_figure,
        )

        save_figure(plot_result(res), plot, dpi=150, overwrite=True)  # checked with --force above
        msg += f" and {plot}"
    typer.echo(msg)


def _replayed_command(input_file: Path, params):
    """``--input-file``: the machine (``--params``, or the run's, or both agree), the run's
    valve command (read in volts where the machine takes volts), its duration [s] and the
    note on the volts for the command's message."""
    from ..data import read_run, validate_run  # deferred: see simulate_command
    from ..simulation import Sampled  # deferred: see simulate_command

    run = read_run(input_file, validate=False)
    prm = _replay_machine(params, input_file, run)
    run = validate_run(run, ranges=_command_ranges(prm)).run
    if not run.has("u"):
        raise SignalError(
            f"{input_file} has no valve command channel 'u'; map one with a channel map"
        )
    command = run["u"]
    volts = ""
    if prm.valve.command_voltage > 0.0:  # the machine's commands are volts ([valve])
        command = prm.valve.command_from_volts(command)
        null = prm.valve.null_voltage
        sign = "-" if null >= 0.0 else "+"
        volts = f"; u read in V as (u {sign} {abs(null):g} V)/{prm.valve.command_voltage:g} V"
    return prm, Sampled(run.t - run.t[0], command), float(run.t[-1] - run.t[0]), volts


def _command_ranges(prm):
    """Plausible ranges of a replayed run: the command in volts where the machine takes volts."""
    from ..data import PLAUSIBLE_RANGES, Plausible  # deferred: see simulate_command

    valve = prm.valve
    if valve.command_voltage <= 0.0:
        return PLAUSIBLE_RANGES
    span = 1.05 * valve.command_voltage
    hint = "commands beyond the valve's full scale: check [valve] command_voltage [V]"
    return {
        **PLAUSIBLE_RANGES,
        "u": Plausible(valve.null_voltage - span, valve.null_voltage + span, high_hint=hint),
    }


def _replay_machine(params: str | None, input_file: Path, run):
    """The machine of ``simulate --input-file``: ``--params``, else the one the run records.

    A run records its machine in its metadata (``machine`` or ``true_params``) or, in a
    dataset folder, in the manifest or the campaign's ``true_params.toml`` beside it
    (:func:`hydropwa.identification.recorded_machine`). Given both, their areas and stroke
    must agree (1 %); given neither, one line says how to give it (exit 2).
    """
    from ..data import MANIFEST  # deferred: loaded only when this command runs (a fast --help)
    from ..identification import (  # deferred: loaded only when this command runs
        check_same_machine,
        recorded_machine,
    )

    found = recorded_machine([run])
    if found is None and (input_file.parent / MANIFEST).is_file():
        found = recorded_machine(input_file.parent)  # a run of a dataset: the dataset's machine
    if params is None:
        if found is None:
            raise ParameterError(f"{input_file} records no machine: {MACHINE_FIX}")
        return found[0]
    prm = resolve_params(params)
    if found is not None:
        check_same_machine(
            prm,
            found[0],
            found[1],
            holder="the run's machine",
            fix="give the parameters of the machine the run was measured on",
        )
    return prm
