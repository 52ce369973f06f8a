"""``hydropwa linearize``: build the PWA model (Sec. IV), export it, write Figs. 1–2 and Tables IV–IX.

User errors raise :class:`~hydropwa.HydropwaError`; the CLI's one error path prints
``error: …`` and exits with code 2.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from hydropwa._errors import PwaError

from ._app import new_app
from ._options import ParamsOption, parse_sample_time, resolve_params, sample_time_option

if TYPE_CHECKING:
    from hydropwa.params import SystemParams

__all__ = ["app", "linearize_command", "parse_cells"]

#: The top-level ``linearize`` command.
app = new_app()
#: The run whose visited cell combinations ``--form chamber`` exports (from mid-stroke).
CHAMBER_EXPORT_RUN = "sine:amplitude=0.4,frequency=1"
CHAMBER_EXPORT_DURATION = 5.0


def parse_cells(text: str | None) -> dict[str, int]:
    """Parse ``cq=5,cqp=5,friction=7`` into a dict; PwaError on malformed input."""
    if text is None or not text.strip():
        return {}
    out: dict[str, int] = {}
    for part in text.split(","):
        key, sep, val = part.partition("=")
        key = key.strip()
        if not sep or not key:
            raise PwaError(f"--cells {text!r}: write name=count pairs like cq=5,cqp=5,friction=7")
        try:
            n = int(val.strip())
        except ValueError:
            raise PwaError(
                f"--cells {text!r}: {val.strip()!r} is not an integer count for {key}"
            ) from None
        out[key] = n
    return out


def linearize_command(
    out: Path,
    params: str | None = None,
    supply_pressure: str | None = None,
    cells: str | None = None,
    breakpoints: str = "machine",
    form: str = "asymmetric",
    scheduled: bool = False,
    sample_time: str | None = None,
    figures: Path | None = None,
    tables: Path | None = None,
    refine_tol: str | None = None,
    units: str = "si",
    mat: Path | None = None,
    force: bool = False,
) -> list[Path]:
    """Build, export and document the PWA model; returns the written paths.

    Parameters mirror the command-line options (``params``: a preset name or a TOML/JSON
    file); quantities are strings with units (``"95 bar"``, ``"1 ms"``) or plain SI numbers.
    """
    from hydropwa.linearization import (
        linearize,  # deferred: loaded only when this command runs (a fast --help)
    )

    prm, ps, dt, tol = _quantities(params, supply_pressure, sample_time, refine_tol)
    chamber = form == "chamber"
    if chamber and (tol is not None or figures is not None or tables is not None):
        raise PwaError(
            "--refine-tol, --figures and --tables belong to the load-pressure forms; "
            "the chamber form's cells follow its error tolerances"
        )
    from ._progress import step  # deferred: loaded only when this command runs (a fast --help)

    with step("fitting the PWA cells"):
        model = linearize(
            prm,
            supply_pressure=ps,
            cells=parse_cells(cells),
            breakpoints=breakpoints,
            form=form,
            scheduled=scheduled,
        )
    selected = _visited_cells(model) if chamber else None
    written, doc = _export(model, out, mat, dt, tol, units, force, selected)
    _echo_error_bound(doc, chamber)
    return written + _write_reports(model, figures, tables)


def _quantities(
    params: str | None, supply_pressure: str | None, sample_time: str | None, refine_tol: str | None
) -> tuple[SystemParams, float | None, float | None, float | None]:
    """(parameters, P_S [Pa] or None, sample time [s] or None, refine tolerance [Pa/s] or
    None) from the command's options."""
    from hydropwa.params import (
        parse_quantity,  # deferred: loaded only when this command runs (a fast --help)
    )

    prm = resolve_params(params)
    ps = (
        None
        if supply_pressure is None
        else parse_quantity(supply_pressure, "Pa", "--supply-pressure")
    )
    dt = None if sample_time is None else parse_sample_time(sample_time)
    tol = None if refine_tol is None else parse_quantity(refine_tol, "Pa/s", "--refine-tol")
    return prm, ps, dt, tol


def _visited_cells(model):
    """The cell combinations a simulated run of the chamber form visits: its cell sets
    multiply to ~10^5 combinations, so only those are exported."""
    from hydropwa.simulation import (
        simulate,  # deferred: loaded only when this command runs (a fast --help)
    )

    from ._progress import step  # deferred: loaded only when this command runs (a fast --help)

    with step(f"simulating {CHAMBER_EXPORT_RUN} for the cells it visits"):
        run = simulate(model, CHAMBER_EXPORT_RUN, duration=CHAMBER_EXPORT_DURATION)
        return model.visited_cells(run)


def _export(
    model,
    out: Path,
    mat: Path | None,
    dt: float | None,
    tol: float | None,
    units: str,
    force: bool,
    selected,
) -> tuple[list[Path], dict]:
    """Write the JSON document (and the MAT file if asked); the written paths and the
    exported document."""
    from hydropwa.linearization import (  # deferred: loaded only when this command runs (a fast --help)
        export_pwa,
        save_pwa,
        save_pwa_mat,
    )

    from ._progress import step  # deferred: loaded only when this command runs (a fast --help)

    with step("exporting the cells" + (" (ZOH)" if dt is not None else "")):
        written = [
            save_pwa(
                model,
                out,
                sample_time=dt,
                refine_tol=tol,
                units=units,
                overwrite=True,
                cells=selected,
            )
        ]
        doc = export_pwa(model, refine_tol=tol, units=units, cells=selected)
        if mat is not None:
            written.append(
                save_pwa_mat(
                    model,
                    mat,
                    sample_time=dt,
                    refine_tol=tol,
                    units=units,
                    overwrite=force,
                    cells=selected,
                )
            )
    return written, doc


def _echo_error_bound(doc: dict, chamber: bool) -> None:
    """Print the number of cells and the largest guaranteed vector-field error of a cell."""
    if chamber:
        unit = doc["state"][2]["unit"]
        typer.echo(
            f"{len(doc['cells'])} cell combinations (those {CHAMBER_EXPORT_RUN} visits in "
            f"{CHAMBER_EXPORT_DURATION:g} s); largest guaranteed vector-field error of a cell "
            f"{doc['max_error_bound']:.4g} {unit}/s on dP_A/dt, dP_B/dt"
        )
    else:
        unit = doc["state"][0]["unit"]
        typer.echo(
            f"{len(doc['cells'])} cells; largest guaranteed vector-field error of a cell "
            f"{doc['max_error_bound']:.4g} {unit}/s on dP_L/dt (A y + B u + f against the PWA model)"
        )


def _write_reports(model, figures: Path | None, tables: Path | None) -> list[Path]:
    """Write Figs. 1-2 and Tables IV-IX where asked; the written paths."""
    from ._progress import step  # deferred: loaded only when this command runs (a fast --help)

    written: list[Path] = []
    if figures is not None:
        from hydropwa.linearization._report import (
            write_figures,  # deferred: loaded only when this command runs (a fast --help)
        )

        with step("writing Figs. 1-2"):
            written += write_figures(model, figures)
    if tables is not None:
        from hydropwa.linearization._report import (
            write_tables,  # deferred: loaded only when this command runs (a fast --help)
        )

        with step("regenerating Tables IV-IX"):
            written += write_tables(model, tables)
    return written


@app.command("linearize")
def _run(
    out: Annotated[Path, typer.Option("--out", "-o", help="PWA JSON document to write.")] = Path(
        "pwa.json"
    ),
    params: ParamsOption = None,
    supply_pressure: Annotated[
        str | None, typer.Option("--supply-pressure", help='Fixed P_S, e.g. "95 bar".')
    ] = None,
    cells: Annotated[
        str | None, typer.Option("--cells", help="Cell counts, e.g. cq=5,cqp=5,friction=7.")
    ] = None,
    breakpoints: Annotated[
        str,
        typer.Option(
            "--breakpoints",
            help="machine (cells from the machine's range), paper (Table V), tangent, optimized or optimized-rms.",
        ),
    ] = "machine",
    form: Annotated[
        str,
        typer.Option(
            "--form",
            help="asymmetric (single-rod, default), consistent (mean area, Q_L = z·C_q), paper (Eq. (17) as printed) or chamber (pwa-chamber: spool, P_A, P_B; exports the cells a 40 %, 1 Hz sine visits).",
        ),
    ] = "asymmetric",
    scheduled: Annotated[
        bool, typer.Option("--scheduled", help="Cells follow the P_S(t) input.")
    ] = False,
    sample_time: Annotated[
        str | None,
        sample_time_option("ZOH-discretise the cells: a period ('1 ms') or a rate ('1 kHz')."),
    ] = None,
    figures: Annotated[
        Path | None, typer.Option("--figures", help="Folder for Figs. 1-2 (PNG+SVG).")
    ] = None,
    tables: Annotated[
        Path | None, typer.Option("--tables", help="Folder for Tables IV-IX (md+csv).")
    ] = None,
    refine_tol: Annotated[
        str | None,
        typer.Option(
            "--refine-tol",
            help='Split cells until the error bound is below this, e.g. "50 bar/s" or 5e6 (Pa/s).',
        ),
    ] = None,
    units: Annotated[
        str, typer.Option("--units", help="si (Pa, m/s, m, 1) or engineering (bar, mm/s, mm, %).")
    ] = "si",
    mat: Annotated[
        Path | None,
        typer.Option("--mat", help="Also write an MPT3-style MATLAB file (A, B, f, H, h)."),
    ] = None,
    force: Annotated[
        bool,
        typer.Option(
            "--force", help="Overwrite an existing JSON file, MAT file, figures and tables."
        ),
    ] = False,
) -> None:
    """Build the piecewise-affine model and write it as JSON, figures and tables (paper Sec. IV)."""
    from hydropwa._io import (
        check_output,  # deferred: loaded only when this command runs (a fast --help)
    )

    if out.suffix.lower() != ".json":
        raise PwaError(f"--out {out} must end in .json")
    check_output(out, force, option="--out")
    if mat is not None:
        if mat.suffix.lower() != ".mat":
            raise PwaError(f"--mat {mat} must end in .mat")
        check_output(mat, force, option="--mat")
    names = {"--figures": ("fig01_cq.*", "fig02_cqp.*"), "--tables": ("*.csv", "*.md")}
    for option, folder in (("--figures", figures), ("--tables", tables)):
        if folder is not None:
            check_output(folder, force, folder=True, option=option, files=names[option])
    if supply_pressure is not None:
        from hydropwa._limits import (
            check_supply_pressure,  # deferred: loaded only when this command runs (a fast --help)
        )
        from hydropwa.params import (
            parse_quantity,  # deferred: loaded only when this command runs (a fast --help)
        )

        base = resolve_params(params)
        check_supply_pressure(parse_quantity(supply_pressure, "Pa", "--supply-pressure"), base, 1.0)
    if sample_time is not None:
        from hydropwa.params import (
            parse_quantity,  # deferred: loaded only when this command runs (a fast --help)
        )

        dt = parse_sample_time(sample_time)
        if not (0.0 < dt <= 1.0):
            raise PwaError(f"--sample-time {sample_time!r} must be in (0, 1] s, e.g. '1 ms'")
    if units not in ("si", "engineering"):
        raise PwaError(f"--units {units!r} must be si or engineering")
    paths = linearize_command(
        out,
        params,
        supply_pressure,
        cells,
        breakpoints,
        form,
        scheduled,
        sample_time,
        figures,
        tables,
        refine_tol,
        units,
        mat,
        force,
    )
    for p in paths:
        typer.echo(f"wrote {p}")
