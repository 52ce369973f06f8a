"""``hydropwa export``: the model as an FMU for other simulation tools and HIL targets.

``hydropwa export fmu --params P.toml --out axis.fmu``. A thin wrapper over
:func:`hydropwa.simulation.export_axis_fmu`; user errors are :class:`~hydropwa.HydropwaError`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from .._io import check_output
from .._limits import check_position
from ._app import new_app
from ._options import ParamsOption, resolve_params

__all__ = ["app", "fmu_command"]

app = new_app("export", help="Export the model for other tools (FMI).")


@app.command("fmu")
def fmu_command(
    out: Annotated[Path, typer.Option("--out", "-o", help="The FMU file to write (.fmu).")] = Path(
        "axis.fmu"
    ),
    params: ParamsOption = None,
    x0: Annotated[
        str | None,
        typer.Option("--x0", help="Initial rod position ('100 mm'); default mid-stroke."),
    ] = None,
    rtol: Annotated[
        float, typer.Option("--rtol", help="Relative tolerance of the FMU's integrator.")
    ] = 1e-6,
    force: Annotated[bool, typer.Option("--force", help="Overwrite existing files.")] = False,
) -> None:
    """Build the full-order axis as an FMI 2.0 co-simulation FMU (needs a C compiler)."""
    from ..params import (
        parse_quantity,  # deferred: loaded only when this command runs (a fast --help)
    )
    from ..simulation import (
        export_axis_fmu,  # deferred: loaded only when this command runs (a fast --help)
    )

    prm = resolve_params(params)  # an FMU is a machine: none given is one line, exit 2
    check_output(out, force, option="--out")
    start = parse_quantity(x0, "m", "--x0") if x0 is not None else None
    check_position(start, prm)
    export_axis_fmu(prm, out, initial_position=start, rtol=rtol, overwrite=force)
    typer.echo(f"wrote {out} (FMI 2.0 co-simulation, full-order axis)")
