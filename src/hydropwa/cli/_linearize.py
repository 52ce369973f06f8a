"""``hydropwa linearize``: build the PWA model (Sec. IV), export it, write Figs. 1–2 and Tables IV–IX.

Registered by the main CLI with ``register(app)`` (or ``app.add_typer(app_linearize)``).
User errors raise :class:`~hydropwa.HydropwaError`; the main CLI prints ``error: …`` and
exits with code 2.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hydropwa._errors import PwaError

__all__ = ["linearize_command", "parse_cells", "register", "app"]


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
            raise PwaError(f"--cells {text!r}: {val.strip()!r} is not an integer count for {key}") from None
        out[key] = n
    return out


def linearize_command(
    out: Path,
    params_file: Path | None = None,
    supply_pressure: str | None = None,
    cells: str | None = None,
    breakpoints: str = "paper",
    form: str = "consistent",
    scheduled: bool = False,
    sample_time: str | None = None,
    figures: Path | None = None,
    tables: Path | None = None,
) -> list[Path]:
    """Build, export and document the PWA model; returns the written paths.

    Parameters mirror the command-line options; quantities are strings with units
    (``"95 bar"``, ``"1 ms"``) or plain SI numbers.
    """
    from hydropwa.linearization import linearize, save_pwa
    from hydropwa.params import get_preset, load_params, parse_quantity

    params = load_params(params_file) if params_file is not None else get_preset("paper")
    ps = None if supply_pressure is None else parse_quantity(supply_pressure, "Pa", "--supply-pressure")
    dt = None if sample_time is None else parse_quantity(sample_time, "s", "--sample-time")
    from ._progress import step

    with step("fitting the PWA cells"):
        model = linearize(params, supply_pressure=ps, cells=parse_cells(cells), breakpoints=breakpoints,
                          form=form, scheduled=scheduled)
    with step("exporting the cells" + (" (ZOH)" if dt is not None else "")):
        written = [save_pwa(model, out, sample_time=dt)]
    if figures is not None:
        from hydropwa.linearization._report import write_figures

        with step("writing Figs. 1-2"):
            written += write_figures(model, figures)
    if tables is not None:
        from hydropwa.linearization._report import write_tables

        with step("regenerating Tables IV-IX"):
            written += write_tables(model, tables)
    return written


def _run(
    out: Annotated[Path, typer.Option("--out", "-o", help="PWA JSON document to write.")],
    params_file: Annotated[Path | None, typer.Option("--params", help="Parameter TOML (default: paper preset).")] = None,
    supply_pressure: Annotated[str | None, typer.Option("--supply-pressure", help='Fixed P_S, e.g. "95 bar".')] = None,
    cells: Annotated[str | None, typer.Option("--cells", help="Cell counts, e.g. cq=5,cqp=5,friction=7.")] = None,
    breakpoints: Annotated[str, typer.Option("--breakpoints", help="paper, tangent, optimized or optimized-rms.")] = "paper",
    form: Annotated[str, typer.Option("--form", help="consistent (Q_L = z·C_q) or paper (Eq. (17) as printed).")] = "consistent",
    scheduled: Annotated[bool, typer.Option("--scheduled", help="Cells follow the P_S(t) input.")] = False,
    sample_time: Annotated[str | None, typer.Option("--sample-time", help='ZOH-discretise the cells, e.g. "1 ms".')] = None,
    figures: Annotated[Path | None, typer.Option("--figures", help="Folder for Figs. 1-2 (PNG+SVG).")] = None,
    tables: Annotated[Path | None, typer.Option("--tables", help="Folder for Tables IV-IX (md+csv).")] = None,
    force: Annotated[bool, typer.Option("--force", help="Overwrite an existing JSON file.")] = False,
) -> None:
    """Build the piecewise-affine model (paper Sec. IV) and write it as JSON."""
    from hydropwa._errors import check_output

    check_output(out, force)
    paths = linearize_command(out, params_file, supply_pressure, cells, breakpoints, form, scheduled,
                              sample_time, figures, tables)
    for p in paths:
        typer.echo(f"wrote {p}")


app = typer.Typer(help="Piecewise-affine linearization (paper Sec. IV).", add_completion=False)
app.command("linearize")(_run)


def register(main_app: typer.Typer) -> None:
    """Add the ``linearize`` command to the main CLI app."""
    main_app.command("linearize", help="Build the PWA model (paper Sec. IV), export JSON, figures, tables.")(_run)

