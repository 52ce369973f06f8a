"""``hydropwa control``: design a controller on the PWA model and simulate it in closed loop.

``hydropwa control design --params P.toml --out ctrl.toml`` and
``hydropwa control simulate --model full --controller ctrl.toml --reference "..." --out run.parquet --plot run.png``,
``hydropwa control export ctrl.toml --c DIR [--fmu ctrl.fmu]``.
Thin wrappers over :mod:`hydropwa.control`; user errors are :class:`~hydropwa.HydropwaError`.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated, Any

import typer

from .._errors import HydropwaError, PwaError
from .._io import check_output, read_text
from .._layout import CHAMBER_KIND, DEFAULT_KIND, DESIGN_KIND
from .._limits import check_position
from ._app import error_line, new_app
from ._options import (
    MachineParamsOption,
    ParamsOption,
    duration_option,
    parse_sample_time,
    resolve_params,
    sample_time_option,
    sample_time_source,
)

__all__ = ["app", "design_command", "simulate_command", "export_command", "certify_command"]

app = new_app(
    "control", help="Closed-loop position control: design on the PWA model, verify on any model."
)


def _linearized_model(name: str, params_src, pwa_file: Path | None):
    """The PWA model of kind ``name``: from a ``--pwa`` document of that kind, or built by name.

    A document must hold a model of the kind asked for (``hydropwa linearize`` writes one per
    ``--form``) and of the machine given (:func:`_same_machine`); without one the model is
    built from the parameters by the registry (:func:`hydropwa._layout.build_model`).
    """
    from .._layout import build_model  # deferred: loaded only when this command runs
    from ..linearization import load_pwa  # deferred: loaded only when this command runs
    from ..params import SystemParams  # deferred: loaded only when this command runs

    if pwa_file is not None:
        model = load_pwa(pwa_file)
        if model.name != name:
            raise PwaError(
                f"--pwa {pwa_file} holds a {model.name} model; --model {name} needs one written "
                f"by 'hydropwa linearize' of that kind"
            )
        return _same_machine(model, params_src, pwa_file)
    prm = params_src if isinstance(params_src, SystemParams) else resolve_params(params_src)
    return build_model(name, prm)


def _pwa_model(params_src, pwa_file: Path | None):
    """The load-pressure PWA model (the default kind of the control commands)."""
    return _linearized_model(DESIGN_KIND.name, params_src, pwa_file)


def _same_machine(model, params_src, pwa_file: Path):
    """A ``--pwa`` document's model, refused when the machine given (``--params``, or a
    controller file's) has other areas or stroke (1 %) than the document's."""
    from ..identification import (
        check_same_machine,  # deferred: loaded only when this command runs (a fast --help)
    )
    from ..params import SystemParams  # deferred: loaded only when this command runs

    if params_src is not None:
        prm = params_src if isinstance(params_src, SystemParams) else resolve_params(params_src)
        check_same_machine(
            prm,
            model.params,
            f"--pwa {pwa_file}",
            holder="the PWA document's",
            fix="give the PWA document of this machine (hydropwa linearize --params FILE)",
        )
    return model


def _machine_of(controller: Path):
    """The machine a controller file records (a ``machine`` parameter table); none: exit 2.

    No default machine: a controller simulated on another cylinder than its own gives a
    result with no meaning (a 500 mm controller on the paper's 200 mm cylinder).
    """
    import json  # deferred: loaded only when this command runs (a fast --help)
    import tomllib  # deferred: loaded only when this command runs (a fast --help)

    from ..params import (
        params_from_dict,  # deferred: loaded only when this command runs (a fast --help)
    )

    doc = None
    try:
        text = read_text(controller, "controller file")
        doc = json.loads(text) if controller.suffix.lower() == ".json" else tomllib.loads(text)
    except (OSError, ValueError, RecursionError, HydropwaError):
        pass  # load_controller names the problem
    machine = doc.get("machine") if isinstance(doc, dict) else None
    from ..control import (  # deferred: loaded only when this command runs
        MACHINE_KEYS,
        ControlError,
    )

    if isinstance(machine, dict) and isinstance(machine.get("parameters"), dict):
        return params_from_dict(
            machine["parameters"], source=f"{controller} [machine.parameters]", check_bare=False
        )
    if isinstance(machine, dict) and machine and set(machine) <= set(MACHINE_KEYS):
        # schema 2 records the areas, stroke and design P_S for the machine check only
        raise ControlError(
            f"{controller} records no machine parameters (only the areas and stroke of "
            "[machine]); give the machine with --params PRESET|FILE, or add its parameter "
            "table as [machine.parameters]"
        )
    if isinstance(machine, dict):
        return params_from_dict(machine, source=f"{controller} [machine]", check_bare=False)

    if doc is None:
        from ..control import load_controller  # deferred: names the file's problem

        load_controller(controller)
    raise ControlError(
        f"{controller} records no machine; give the machine the controller was designed for "
        "with --params PRESET|FILE"
    )


def _design_on_chamber(model, *, method, weights, verify, params, **kw):
    """``control design --model pwa-chamber``: :func:`hydropwa.control.design_on_chamber`."""
    from ..control import design_on_chamber  # deferred: loaded only when this command runs

    vkw = {k: kw.pop(k) for k in ("draws", "seed", "sensor_noise", "scheduler")}
    return design_on_chamber(model, weights=weights, verify=verify, verify_kwargs=vkw, **kw)


def _weights(text: str | None) -> dict[str, float]:
    from ..control import (  # deferred: loaded only when this command runs (a fast --help)
        DEFAULT_WEIGHTS,
        ControlError,
    )
    from ..params import (
        parse_quantity,  # deferred: loaded only when this command runs (a fast --help)
    )

    units = {"p_l": "Pa", "v": "m/s", "x": "m", "integral": "m*s", "u": ""}
    out: dict[str, float] = {}
    for part in (p for p in (text or "").split(",") if p.strip()):
        key, eq, val = part.partition("=")
        key = key.strip()
        if not eq or key not in DEFAULT_WEIGHTS:
            raise ControlError(
                f"--weights {text!r}: write key=value with key one of {', '.join(DEFAULT_WEIGHTS)}"
            )
        out[key] = parse_quantity(val.strip(), units[key], f"--weights {key}")
    return out


def _sensor_noise(text: str | None, option: str = "--sensor-noise") -> dict[str, float] | None:
    """``"x=20 um,p_a=0.1 bar,p_b=0.1 bar,spool=0.2 %"`` → standard deviations in SI (None: not given)."""
    from ..control import (
        ControlError,  # deferred: loaded only when this command runs (a fast --help)
    )
    from ..params import (
        parse_quantity,  # deferred: loaded only when this command runs (a fast --help)
    )

    if text is None:
        return None
    units = {"x": "m", "p_a": "Pa", "p_b": "Pa", "spool": ""}
    out: dict[str, float] = {}
    for part in (p for p in text.split(",") if p.strip()):
        key, eq, val = part.partition("=")
        key = key.strip()
        if not eq or key not in units:
            raise ControlError(
                f"{option} {text!r}: write key=value with key one of x, p_a, p_b, spool "
                "(e.g. 'x=20 um,p_a=0.1 bar,spool=0.2 %')"
            )
        v = parse_quantity(val.strip(), units[key], f"{option} {key}")
        if not v >= 0:
            raise ControlError(
                f"{option} {key} = {val.strip()!r} must be a standard deviation >= 0"
            )
        out[key] = v
    return out


def _sample_time(sample_time: str | None, rate: str | None) -> float:
    """T_s [s] from ``--sample-time`` (or its old name ``--rate``); default 0.5 ms (2 kHz)."""
    return parse_sample_time(sample_time_source(sample_time, rate, "--rate", "Hz"))


def _noise_from(path: Path, given: str | None) -> dict[str, float]:
    """Sensor noise measured from a dataset's standstill stretches (``--noise-from``), printed."""
    from ..control import ControlError, sensor_noise_from  # deferred: a fast --help
    from ..data import read_dataset

    if given is not None:
        raise ControlError("give either --sensor-noise or --noise-from, not both")
    noise = sensor_noise_from(read_dataset(path))
    units = {"x": (1e6, "um"), "p_a": (1e-5, "bar"), "p_b": (1e-5, "bar"), "spool": (1e2, "%")}
    shown = ", ".join(f"{c} {v * units[c][0]:.3g} {units[c][1]}" for c, v in noise.items())
    typer.echo(f"sensor noise measured at standstill in {path}: {shown}")
    return noise


def _noise_options(kw: dict, method, sensor_noise, noise_from, observer, dead_zone_hysteresis):
    """The design's sensor noise and the law elements that answer it (observer, hysteresis)."""
    from ..control import (  # deferred: loaded only when this command runs (a fast --help)
        DEFAULT_SENSOR_NOISE,
        ControlError,
    )

    noise = _sensor_noise(sensor_noise)
    if noise_from is not None:
        noise = _noise_from(noise_from, sensor_noise)
    if observer:
        if method == "pi":
            raise ControlError("--observer needs --method lqr or place (state feedback)")
        sx = (noise or DEFAULT_SENSOR_NOISE).get("x", 0.0)
        if not sx > 0:
            raise ControlError("--observer needs a position noise x > 0 (--sensor-noise 'x=20 um')")
        kw["position_noise"] = sx
    if not 0.0 <= dead_zone_hysteresis < 0.1:
        raise ControlError(
            f"--dead-zone-hysteresis {dead_zone_hysteresis} must be a share of the opening in "
            "[0, 0.1), e.g. 0.005"
        )
    if dead_zone_hysteresis > 0.0:
        if method == "pi" or not kw["dead_zone_inverse"]:
            raise ControlError(
                "--dead-zone-hysteresis needs the dead-zone inverse of --method lqr or place"
            )
        kw["dead_zone_hysteresis"] = dead_zone_hysteresis
    return noise


def _spool_option(kw: dict, spool: str, method: str, model_name: str) -> None:
    """``--spool measured|estimated``: the valve-aware LQR's spool terms (``spool=`` of the design)."""
    from ..control import ControlError  # deferred: a fast --help

    if spool not in ("estimated", "measured"):
        raise ControlError(f"--spool {spool!r} must be estimated or measured")
    if spool == "measured":
        if method != "lqr" or model_name != DESIGN_KIND.name:
            raise ControlError(
                "--spool measured needs the valve-aware design of --method lqr on "
                f"--model {DESIGN_KIND.name}"
            )
        kw["spool"] = "measured"


@app.command("design")
def design_command(
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Controller file to write (.toml or .json).")
    ] = Path("controller.toml"),
    params: ParamsOption = None,
    pwa: Annotated[
        Path | None, typer.Option("--pwa", help="Design on this PWA JSON document instead.")
    ] = None,
    method: Annotated[
        str | None,
        typer.Option("--method", help="lqr (per cell), place (per cell) or pi (default: lqr)."),
    ] = None,
    sample_time: Annotated[
        str | None,
        sample_time_option(
            "Controller sampling: a period ('0.5 ms') or a rate ('2 kHz') (default: 0.5 ms)."
        ),
    ] = None,
    rate: Annotated[
        str | None,
        typer.Option("--rate", hidden=True, help="Deprecated name of --sample-time."),
    ] = None,
    delay: Annotated[
        bool | None,
        typer.Option(
            "--delay/--no-delay",
            help="One sample of computation delay (default: on, as on any target).",
        ),
    ] = None,
    weights: Annotated[
        str | None,
        typer.Option(
            "--weights", help="LQR Bryson maxima, e.g. 'x=2 mm,integral=1e-4,v=1,p_l=100 bar'."
        ),
    ] = None,
    load_force: Annotated[
        str | None,
        typer.Option("--load-force", help="Load force the cells are linearized at ('500 N')."),
    ] = None,
    no_dead_zone_inverse: Annotated[
        bool,
        typer.Option("--no-dead-zone-inverse", help="Leave the valve dead zone uncompensated."),
    ] = False,
    table: Annotated[
        Path | None, typer.Option("--table", help="Also write the per-cell table (CSV).")
    ] = None,
    model_name: Annotated[
        str,
        typer.Option(
            "--model",
            "-m",
            help="Design model: pwa, or pwa-chamber (its integral tuning chosen and checked on the chamber-level model).",
        ),
    ] = DESIGN_KIND.name,
    verify: Annotated[
        bool,
        typer.Option(
            "--verify/--no-verify",
            help="Verify on the full model (task set, parameter draws, sensor noise) before writing.",
        ),
    ] = True,
    draws: Annotated[
        int | None,
        typer.Option(
            "--draws", help="Parameter draws of the verification (nominal + draws-1; default 4)."
        ),
    ] = None,
    seed: Annotated[
        int | None,
        typer.Option("--seed", help="Seed of the draws and the sensor noise (default 0)."),
    ] = None,
    sensor_noise: Annotated[
        str | None,
        typer.Option(
            "--sensor-noise",
            help="Verification sensor noise, e.g. 'x=20 um,p_a=0.1 bar,p_b=0.1 bar' (default those).",
        ),
    ] = None,
    noise_from: Annotated[
        Path | None,
        typer.Option(
            "--noise-from",
            help="Measure the verification's sensor noise from this dataset's standstill stretches.",
        ),
    ] = None,
    scheduler: Annotated[
        str | None,
        typer.Option(
            "--scheduler", help="Dask scheduler address or 'local' for the verification runs."
        ),
    ] = None,
    observer: Annotated[
        bool,
        typer.Option(
            "--observer",
            help="Add the position observer (Kalman filter of x, v) designed for the sensor noise "
            "(--sensor-noise, --noise-from, or 20 um).",
        ),
    ] = False,
    dead_zone_hysteresis: Annotated[
        float,
        typer.Option(
            "--dead-zone-hysteresis",
            metavar="SHARE",
            help="Band h of the dead-zone inverse's side, a share of the opening, e.g. 0.005 "
            "(default 0: none); quiets the valve at a hold under sensor noise (with --observer).",
        ),
    ] = 0.0,
    quiet_band: Annotated[
        bool | None,
        typer.Option(
            "--quiet-band/--no-quiet-band",
            help="Keep the valve closed while the sensor noise alone moves the command: the "
            "position observer and a quiet band sized from the sensor noise, with the "
            "integral's band and leak, and the valve pre-opened to the dead zone's edge before "
            "a profile starts (default: on for "
            "--method lqr or place with the dead-zone inverse, --model pwa; opt-in for "
            "--model pwa-chamber).",
        ),
    ] = None,
    spool: Annotated[
        str,
        typer.Option(
            "--spool",
            help="The spool position: estimated by the valve model (default), or measured (the "
            "valve reports it): the valve model corrected by the measured spool through a Kalman "
            "gain for its noise (--sensor-noise 'spool=0.2 %'; default 0.1 %).",
        ),
    ] = "estimated",
    write_unverified: Annotated[
        bool,
        typer.Option(
            "--write-unverified",
            help="Write the controller even when it fails its verification (the file records "
            "the failed verdict; without this option a failed design exits 1 and writes nothing).",
        ),
    ] = False,
    certify: Annotated[
        bool,
        typer.Option(
            "--certify",
            help="Certify the loop at a hold (ultimate bound, region of attraction) before "
            "writing; a design that cannot be certified says why and is not written.",
        ),
    ] = False,
    output: Annotated[
        str,
        typer.Option(
            "--output",
            help="Controlled output: position (default), force (A_A*P_A - A_B*P_B from the "
            "pressure sensors) or pressure (P_L); force/pressure design on the chamber PWA model.",
        ),
    ] = "position",
    specimen_stiffness: Annotated[
        str | None,
        typer.Option(
            "--specimen-stiffness",
            help="Estimated specimen stiffness for --output force/pressure ('1e7 N/m', '10 kN/mm'); "
            "default the parameters' load.specimen_stiffness.",
        ),
    ] = None,
    force: Annotated[bool, typer.Option("--force", help="Overwrite existing files.")] = False,
) -> None:
    """Design a controller on the PWA model, verify it on the full model, write it with its per-cell table."""
    from ..control import (  # deferred: loaded only when this command runs (a fast --help)
        DEFAULT_DESIGN,
        ControlError,
        design_controller,
        save_controller,
    )
    from ..params import (
        parse_quantity,  # deferred: loaded only when this command runs (a fast --help)
    )

    if output != "position":
        opts: dict[str, Any] = {"sample_time": _sample_time(sample_time, rate), "delay": delay}
        opts["verify"] = verify
        opts |= {"draws": draws, "seed": seed, "noise": _sensor_noise(sensor_noise)}
        opts |= {"table": table, "force": force, "write_unverified": write_unverified}
        _design_force(out, params, output, specimen_stiffness, opts)
        return
    # the defaults of the one default design (the Python API's, the paper study's)
    method = DEFAULT_DESIGN.method if method is None else method
    delay = DEFAULT_DESIGN.delay if delay is None else delay
    draws = DEFAULT_DESIGN.draws if draws is None else draws
    seed = DEFAULT_DESIGN.seed if seed is None else seed
    _check_design_outputs(out, table, force)
    _check_design_model(model_name, method, certify)
    model = _linearized_model(model_name, params, pwa)
    ts = _sample_time(sample_time, rate)
    dzi = not no_dead_zone_inverse
    if method not in ("lqr", "place", "pi"):
        raise ControlError(f"--method {method!r} must be lqr, place or pi")
    kw: dict = {"sample_time": ts, "delay": delay, "dead_zone_inverse": dzi}
    if method != "pi":
        kw["load_force"] = (
            None if load_force is None else parse_quantity(load_force, "N", "--load-force")
        )
    if draws < 1:
        raise ControlError(f"--draws {draws} must be at least 1")
    noise = _noise_options(kw, method, sensor_noise, noise_from, observer, dead_zone_hysteresis)
    _spool_option(kw, spool, method, model_name)
    if quiet_band and (method == "pi" or not dzi):
        raise ControlError("--quiet-band needs --method lqr or place and the dead-zone inverse")
    # on by default for --model pwa; opt-in for pwa-chamber
    kw["quiet"] = (
        (DEFAULT_DESIGN.quiet if quiet_band is None else quiet_band)
        if model_name == DESIGN_KIND.name
        else bool(quiet_band)
    )
    design = design_controller if model_name == DESIGN_KIND.name else _design_on_chamber
    d = design(
        model,
        method=method,
        weights=_weights(weights) if method != "pi" and weights else None,
        verify=verify,
        params=model.params,
        draws=draws,
        seed=seed,
        sensor_noise=noise,
        scheduler=scheduler,
        **kw,
    )
    _report_design(d, out, write_unverified)
    cert = _design_certificate(d.controller, model) if certify else None
    # the machine goes with the controller: `control simulate` needs no --params to run it
    save_controller(d.controller, out, overwrite=force, machine_parameters=model.params)
    if cert is not None:
        from ..control import write_certificate  # deferred: loaded only with --certify

        write_certificate(out, cert)
    written = [str(out)]
    if table is not None:
        from .._io import (
            atomic_write_text,  # deferred: loaded only when this command runs (a fast --help)
        )

        atomic_write_text(table, d.table.to_csv(index=False))
        written.append(str(table))
    typer.echo(f"wrote {', '.join(written)}")


def _check_design_model(model_name: str, method: str, certify: bool) -> None:
    """``control design --model``: a linearized kind, and the methods and options it takes."""
    from .._layout import LINEARIZED_MODELS  # deferred: loaded only when this command runs
    from ..control import ControlError  # deferred: a fast --help

    if model_name not in LINEARIZED_MODELS:
        raise ControlError(f"--model {model_name!r} must be {' or '.join(LINEARIZED_MODELS)}")
    if certify and (model_name != DESIGN_KIND.name or method == "pi"):
        raise ControlError(f"--certify needs --method lqr or place on --model {DESIGN_KIND.name}")
    if model_name == CHAMBER_KIND.name and method != "lqr":
        raise ControlError(f"--model {model_name} designs an LQR; drop --method {method}")


def _report_design(d, out: Path, write_unverified: bool) -> None:
    """The design's warnings and summary; a failed verification exits 1 (nothing written)
    unless ``--write-unverified``."""
    for w in d.warnings:
        print(f"warning: {w}", file=sys.stderr)
    typer.echo(d.summary().split("\nwarning:")[0])
    failed = d.verification is not None and not d.verification.passed
    if failed and not write_unverified:
        error_line(
            f"the controller failed its verification on the full model "
            f"({len(d.verification.failures)} failed checks above); {out} not written (give "
            "--write-unverified to write it with its failed verdict)"
        )
        raise typer.Exit(code=1)
    if failed:
        print(
            "warning: the controller failed its verification on the full model; written with "
            "--write-unverified, the file records the failed checks ([verification])",
            file=sys.stderr,
        )


def _check_design_outputs(out: Path, table: Path | None, force: bool) -> None:
    """``control design``'s output files: not there (or ``--force``), a .toml or .json file."""
    from ..control import ControlError  # deferred: a fast --help

    check_output(out, force, option="--out")
    if table is not None:
        check_output(table, force, option="--table")
    if out.suffix.lower() not in (".toml", ".json"):
        raise ControlError(f"--out {out} must end in .toml or .json")


def _design_force(out: Path, params, output: str, stiffness: str | None, opts: dict) -> None:
    """``control design --output force|pressure``: :func:`~hydropwa.control.design_force` on the
    chamber PWA model, :func:`~hydropwa.control.verify_force` on the full model, the file."""
    from ..control import (  # deferred: loaded only when this command runs (a fast --help)
        DEFAULT_DESIGN,
        ControlError,
        design_force,
        save_controller,
        verify_force,
    )
    from ..params import parse_quantity  # deferred: a fast --help

    if output not in ("force", "pressure"):
        raise ControlError(f"--output {output!r} must be position, force or pressure")
    _check_design_outputs(out, opts["table"], opts["force"])
    prm = resolve_params(params)
    if stiffness is not None:
        k = parse_quantity(stiffness, "N/m", "--specimen-stiffness")
        prm = prm.replace(**{"load.specimen_stiffness": k})
    delay = DEFAULT_DESIGN.delay if opts["delay"] is None else opts["delay"]
    d = design_force(prm, output=output, sample_time=opts["sample_time"], delay=delay)
    typer.echo(d.table.to_string(index=False))
    ctrl = d.controller
    if opts["verify"] is not False:
        draws = DEFAULT_DESIGN.draws if opts["draws"] is None else opts["draws"]
        seed = DEFAULT_DESIGN.seed if opts["seed"] is None else opts["seed"]
        v = verify_force(ctrl, prm, draws=draws, seed=seed, sensor_noise=opts["noise"])
        typer.echo(f"verification on the full model: {v.verdict} ({len(v.rows)} runs)")
        for line in v.failures[:10]:
            typer.echo(f"  {line}")
        if not v.passed and not opts["write_unverified"]:
            error_line(
                f"the controller failed its verification on the full model; {out} not written "
                "(give --write-unverified to write it with its failed verdict)"
            )
            raise typer.Exit(code=1)
        import dataclasses  # deferred: loaded only when this command runs

        ctrl = dataclasses.replace(ctrl, verification=v.record())
    save_controller(ctrl, out, overwrite=opts["force"], machine_parameters=prm)
    if opts["table"] is not None:
        from .._io import atomic_write_text  # deferred: a fast --help

        atomic_write_text(opts["table"], d.table.to_csv(index=False))
    typer.echo(f"wrote {out}")


def _design_certificate(controller, model):
    """``control design --certify``: the certificate of the design; none: exit 1, nothing written."""
    from ..control import certify  # deferred: loaded only when this command runs

    cert = certify(controller, model)
    typer.echo(cert.summary())
    if not cert.success:
        error_line(f"the design cannot be certified ({cert.status.name.lower()}); nothing written")
        raise typer.Exit(code=1)
    return cert


@app.command("simulate")
def simulate_command(
    controller: Annotated[
        Path,
        typer.Option(
            "--controller", "-c", help="Controller file (.toml/.json) from 'control design'."
        ),
    ],
    reference: Annotated[
        str,
        typer.Option(
            "--reference",
            "-r",
            help="Position reference, e.g. 'trapezoid:from=50 mm,to=150 mm,v=0.2,a=5,start=0.05', 'steps:0=100 mm,0.1=120 mm', 'file:run.csv#x'; a force (pressure) controller's in N (Pa), e.g. 'sine:amplitude=2 kN,frequency=10,offset=5 kN', 'random:rms=1 kN,f0=1,f1=10,duration=2,offset=5 kN,seed=1'.",
        ),
    ],
    model: Annotated[
        str | None,
        typer.Option("--model", "-m", help="full (default), reduced, pwa or pwa-chamber."),
    ] = None,
    params: MachineParamsOption = None,
    pwa: Annotated[
        Path | None,
        typer.Option("--pwa", help="PWA JSON document (model pwa; default: linearize the params)."),
    ] = None,
    duration: Annotated[
        str | None,
        duration_option(
            "Simulated time [s], e.g. '2 s' (default: end of the move + 0.5 s, else 2 s)."
        ),
    ] = None,
    x0: Annotated[
        str | None,
        typer.Option("--x0", help="Initial position ('100 mm'); default the reference at t = 0."),
    ] = None,
    load_force: Annotated[
        str | None, typer.Option("--load-force", help="Constant ('500 N') or signal spec for F_L.")
    ] = None,
    supply_pressure: Annotated[
        str | None,
        typer.Option("--supply-pressure", help="Constant ('95 bar') or signal spec for P_S."),
    ] = None,
    rtol: Annotated[
        float, typer.Option("--rtol", help="Relative tolerance of the integrator.")
    ] = 1e-3,
    out: Annotated[
        Path,
        typer.Option(
            "--out", "-o", help="Trajectory (.csv or .parquet) with reference, error, command."
        ),
    ] = Path("run.parquet"),
    plot: Annotated[
        Path | None, typer.Option("--plot", help="Also write a plot (.png/.svg/.pdf).")
    ] = None,
    sensor_noise: Annotated[
        str | None,
        typer.Option(
            "--sensor-noise",
            help="Noise on the controller's sensors, e.g. 'x=20 um,p_a=0.1 bar,p_b=0.1 bar'.",
        ),
    ] = None,
    noise_from: Annotated[
        Path | None,
        typer.Option(
            "--noise-from",
            help="Sensor noise measured from this dataset's standstill stretches.",
        ),
    ] = None,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the sensor noise.")] = 0,
    force: Annotated[bool, typer.Option("--force", help="Overwrite existing files.")] = False,
    compare: Annotated[
        bool,
        typer.Option(
            "--compare",
            help="Run the controller on full, reduced, pwa and pwa-chamber side by side: hold peak-to-peak, tracking error, saturation; --out gets the table.",
        ),
    ] = False,
) -> None:
    """Simulate a model under a controller file and print the tracking metrics."""
    from .._layout import MODEL_NAMES, model_kind  # deferred: loaded only when this command runs
    from ..control import (  # deferred: loaded only when this command runs (a fast --help)
        METRIC_UNITS,
        ControlError,
        MotionProfile,
        as_reference,
        check_machine,
        load_controller,
        tracking_metrics,
    )
    from ..params import (
        parse_quantity,  # deferred: loaded only when this command runs (a fast --help)
    )
    from ..plotting import (  # deferred: loaded only when this command runs (a fast --help)
        plot_closed_loop,
        save_figure,
    )
    from ..simulation import (
        simulate,  # deferred: loaded only when this command runs (a fast --help)
    )

    if compare and model is not None:
        raise ControlError(
            f"--compare runs every model side by side; drop --model {model} (or drop --compare)"
        )
    model = DEFAULT_KIND.name if model is None else model
    if model not in MODEL_NAMES:
        raise ControlError(f"--model {model!r} is unknown; choose {', '.join(MODEL_NAMES)}")
    _check_run_outputs(out, plot, force)
    prm = _machine_of(controller) if params is None else resolve_params(params)
    ctrl = load_controller(controller)
    check_machine(ctrl, prm)
    noise = _sensor_noise(sensor_noise)
    if noise_from is not None:
        noise = _noise_from(noise_from, sensor_noise)
    if ctrl.output != "position":
        run = {"duration": duration, "x0": x0, "rtol": rtol, "noise": noise, "seed": seed}
        run |= {"model": model, "load_force": load_force, "supply_pressure": supply_pressure}
        _simulate_force(ctrl, prm, reference, run, out, plot)
        return
    ref = as_reference(reference)
    if duration is None:
        t_end = ref.start_time + ref.duration + 0.5 if isinstance(ref, MotionProfile) else 2.0
    else:
        t_end = parse_quantity(duration, "s", "--duration")
    if compare:
        case = {"x0": x0, "load_force": load_force, "supply_pressure": supply_pressure}
        _compare(ctrl, ref, prm, pwa, t_end, case, rtol, out, plot, noise, seed)
        return
    mdl = _linearized_model(model, prm, pwa) if model_kind(model).linearized else model
    start = _start_position(x0, ref, prm)
    res = simulate(
        mdl,
        duration=t_end,
        params=prm,
        controller=ctrl,
        reference=ref,
        initial_position=start,
        load_force=load_force,
        supply_pressure=supply_pressure,
        rtol=rtol,
        sensor_noise=noise,
        seed=seed,
    )
    res.save(out, overwrite=True)  # checked with --force above
    m = tracking_metrics(res).display()
    typer.echo("  ".join(f"{k} = {v:.4g} {METRIC_UNITS[k]}" for k, v in m.items()))
    _loop_warnings(res, prm, model, ctrl, controller)
    msg = f"wrote {out} ({res.t.size} samples, {res.stats['steps']} steps, {res.stats['wall_time'] * 1e3:.1f} ms)"
    if plot is not None:
        save_figure(
            plot_closed_loop(res, f"{model} model, {ctrl.kind} controller"),
            plot,
            dpi=150,
            overwrite=True,
        )
        msg += f" and {plot}"
    typer.echo(msg)


def _loop_warnings(res, prm, model: str, ctrl, controller: Path) -> None:
    """``control simulate``'s warnings on stderr: the run's, whether ``model`` can represent
    the loop (its valve), and a controller file that failed its verification."""
    from ..control import (  # deferred: loaded only when this command runs
        closed_loop_warnings,
        loop_bandwidth,
        valve_warning,
    )

    for w in closed_loop_warnings(res):
        print(f"warning: {w}", file=sys.stderr)
    valve = valve_warning(prm, model, loop_bandwidth(ctrl))
    if valve:
        print(f"warning: {valve}", file=sys.stderr)
    if ctrl.verification.get("verdict") == "fail":
        print(
            f"warning: {controller} failed its verification on the full model "
            f"({len(ctrl.verification.get('failures', []))} failed checks; see its [verification])",
            file=sys.stderr,
        )


def _check_run_outputs(out: Path, plot: Path | None, force: bool) -> None:
    """``control simulate``'s output files: a .csv or .parquet run, not there (or ``--force``)."""
    from ..control import ControlError  # deferred: a fast --help

    if out.suffix.lower() not in (".csv", ".parquet"):
        raise ControlError(f"--out {out} must end in .csv or .parquet")
    check_output(out, force, option="--out")
    if plot is not None:
        check_output(plot, force, option="--plot")


def _simulate_force(ctrl, prm, reference: str, run: dict, out: Path, plot: Path | None) -> None:
    """``control simulate`` with a force or pressure controller: the reference in N (kN, ...) or
    Pa (bar, ...) as a signal spec, the start at the specimen's contact force, the force metrics."""
    from ..control import ControlError, parse_random  # deferred: a fast --help
    from ..params import parse_quantity  # deferred: a fast --help
    from ..simulation import Signal, parse_signal, simulate  # deferred: a fast --help

    unit = "N" if ctrl.output == "force" else "Pa"
    ref: Signal
    if reference.strip().lower().startswith("random:"):
        ref = parse_random(reference.strip(), unit, "reference")
    else:
        ref = parse_signal(reference, unit, "reference")
    t_end = 2.0 if run["duration"] is None else parse_quantity(run["duration"], "s", "--duration")
    ld = prm.load
    if run["x0"] is not None:
        start = parse_quantity(run["x0"], "m", "--x0")
    elif ld.specimen_stiffness > 0:
        per = 1.0 if ctrl.output == "force" else prm.cylinder.area_a
        f0 = per * float(ref(0.0)) - ld.force - ld.preload
        start = ld.contact_position + f0 / ld.specimen_stiffness
    else:
        raise ControlError("a force reference needs the specimen (load.specimen_stiffness) or --x0")
    res = simulate(
        run["model"],
        duration=t_end,
        params=prm,
        controller=ctrl,
        reference=ref,
        initial_position=start,
        load_force=run["load_force"],
        supply_pressure=run["supply_pressure"],
        rtol=run["rtol"],
        sensor_noise=run["noise"],
        seed=run["seed"],
    )
    res.save(out, overwrite=True)  # checked with --force by the caller
    e = res["force_error"]
    p_min = min(float(res["p_a"].min()), float(res["p_b"].min()))
    typer.echo(
        f"force RMS error = {float((e**2).mean() ** 0.5):.4g} N  max |error| = "
        f"{float(abs(e).max()):.4g} N  lowest chamber = {p_min / 1e5:.3g} bar"
    )
    if plot is not None:
        from ..plotting import plot_result, save_figure  # deferred: a fast --help

        fig = plot_result(res, channels=("force_reference", "force", "u"))
        save_figure(fig, plot, dpi=150, overwrite=True)
    typer.echo(f"wrote {out}" + (f" and {plot}" if plot is not None else ""))


@app.command("export")
def export_command(
    controller: Annotated[
        Path, typer.Argument(help="Controller file (.toml/.json) from 'control design'.")
    ],
    c_dir: Annotated[
        Path | None,
        typer.Option(
            "--c", help="Folder for the C99 code (hydropwa_ctrl.h, hydropwa_ctrl.c, README.md)."
        ),
    ] = None,
    fmu: Annotated[
        Path | None,
        typer.Option(
            "--fmu", help="Also build an FMI co-simulation FMU (.fmu; needs a C compiler)."
        ),
    ] = None,
    fmi_version: Annotated[
        str, typer.Option("--fmi-version", help="FMI version of the FMU: 2.0 or 3.0.")
    ] = "2.0",
    write_unverified: Annotated[
        bool,
        typer.Option(
            "--write-unverified",
            help="Export a controller that failed its verification or was never verified (the "
            "C, its README and the FMU state the verdict).",
        ),
    ] = False,
    force: Annotated[bool, typer.Option("--force", help="Overwrite existing files.")] = False,
) -> None:
    """Export a controller file as dependency-free C99 code and/or an FMU for a real-time target."""
    from ..control import (  # deferred: loaded only when this command runs (a fast --help)
        ControlError,
        export_c,
        export_fmu,
        load_controller,
    )

    if c_dir is None and fmu is None:
        raise ControlError("give --c DIR (the C code) and/or --fmu FILE.fmu")
    if fmi_version not in ("2.0", "3.0"):
        raise ControlError(f"--fmi-version {fmi_version!r}: choose 2.0 or 3.0")
    if c_dir is not None:
        check_output(c_dir, force, folder=True, option="--c")
    if fmu is not None:
        from ..simulation._fmu import (
            find_compiler,  # deferred: loaded only when this command runs (a fast --help)
        )

        check_output(fmu, force, option="--fmu")
        find_compiler()  # before anything is written: no C folder without its FMU
    ctrl = load_controller(controller)
    if ctrl.verdict != "pass" and not write_unverified:
        why = "failed its verification" if ctrl.verdict == "fail" else "records no verification"
        raise ControlError(
            f"{controller} {why} on the full model; design one that passes (hydropwa control "
            "design), or give --write-unverified to export it with that verdict stated"
        )
    written = []
    if c_dir is not None:
        export_c(ctrl, c_dir, overwrite=force)
        written.append(f"{c_dir}/hydropwa_ctrl.h, hydropwa_ctrl.c, README.md")
    if fmu is not None:
        export_fmu(ctrl, fmu, fmi_version=fmi_version, overwrite=force)
        written.append(str(fmu))
    typer.echo(f"wrote {'; '.join(written)} ({ctrl.kind} controller, verification {ctrl.verdict})")


@app.command("certify")
def certify_command(
    controller: Annotated[
        Path, typer.Argument(help="Controller file (.toml/.json) from 'control design'.")
    ],
    params: MachineParamsOption = None,
    delay_samples: Annotated[
        int | None,
        typer.Option(
            "--delay-samples",
            help="Samples of delay between computation and valve (default: the file's, 0 or 1).",
        ),
    ] = None,
    soundness_samples: Annotated[
        int,
        typer.Option(
            "--soundness-samples",
            help="Check the disturbance set one sample at a time on the full model over N "
            "(state, command) pairs and grow it to what they need (the PWA's error and the "
            "flow's curvature); 0 (default): not checked, listed as not modelled. About 0.2 s "
            "per pair on the paper rig.",
        ),
    ] = 0,
    write: Annotated[
        bool,
        typer.Option("--write", help="Write the [certificate] table into the controller file."),
    ] = False,
    force: Annotated[
        bool, typer.Option("--force", help="Replace a [certificate] the file holds.")
    ] = False,
) -> None:
    """Certify the loop at a hold: the ultimate bound on the position error and the region it is reached from."""
    from ..control import load_controller  # deferred: loaded only when this command runs
    from ..control._certify import (  # deferred: loaded only when this command runs
        certify,
        write_certificate,
    )
    from ..linearization import linearize  # deferred: loaded only when this command runs

    prm = _machine_of(controller) if params is None else resolve_params(params)
    ctrl = load_controller(controller)
    cert = certify(
        ctrl, linearize(prm), delay_samples=delay_samples, soundness_samples=soundness_samples
    )
    typer.echo(cert.summary())
    if write:
        write_certificate(controller, cert, overwrite=force)
        typer.echo(f"wrote [certificate] into {controller}")
    if not cert.success:
        raise typer.Exit(code=1)


def _start_position(x0: str | None, ref, params) -> float:
    """The loop's start [m]: ``--x0``, else the reference at t = 0; on the stroke."""
    from ..params import (
        parse_quantity,  # deferred: loaded only when this command runs (a fast --help)
    )

    start = parse_quantity(x0, "m", "--x0") if x0 is not None else float(ref(0.0))
    check_position(start, params, "--x0" if x0 is not None else "the reference at t = 0")
    return start


def _compare(ctrl, ref, prm, pwa, duration, case, rtol, out, plot, noise, seed):
    """``control simulate --compare``: :func:`~hydropwa.control.closed_loop_fidelity`, written;
    every option of ``control simulate`` reaches every model (the sensor noise with the same
    draws), ``--model`` and ``--supply-pressure`` are refused; the model warnings printed."""
    from ..control import (  # deferred: loaded only when this command runs (a fast --help)
        ControlError,
        closed_loop_fidelity,
    )

    if case["supply_pressure"] is not None:
        raise ControlError(
            "--compare runs every model at the parameters' P_S; drop --supply-pressure"
        )
    pwa_model = _pwa_model(prm, pwa) if pwa is not None else None
    start = _start_position(case["x0"], ref, prm)
    results, table = closed_loop_fidelity(
        ctrl,
        ref,
        params=prm,
        pwa=pwa_model,
        duration=duration,
        initial_position=start,
        load_force=case["load_force"],
        rtol=rtol,
        sensor_noise=noise,
        seed=seed,
    )
    units = table.attrs["units"]
    typer.echo(
        table.rename(columns={c: f"{c} [{units[c]}]" for c in table.columns}).to_string(
            float_format=lambda v: f"{v:.4g}"
        )
    )
    for w in table.attrs.get("warnings", []):
        print(f"warning: {w}", file=sys.stderr)
    _write_compare(table, results, out, plot, f"{ctrl.kind} controller on every model")


def _write_compare(table, results, out: Path, plot: Path | None, title: str) -> None:
    """The ``--compare`` table (``--out``, .csv or .parquet) and its figure (``--plot``)."""
    if out.suffix.lower() == ".csv":
        table.to_csv(out)
    else:
        table.to_parquet(out)
    msg = f"wrote {out} (one row per model)"
    if plot is not None:
        from ..plotting import (  # deferred: loaded only when this command runs (a fast --help)
            plot_closed_loop,
            save_figure,
        )

        save_figure(plot_closed_loop(results, title), plot, dpi=150, overwrite=True)
        msg += f" and {plot}"
    typer.echo(msg)
