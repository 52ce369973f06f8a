"""The report's coverage section: which load pressures and PWA cells the evaluation visited and
how every model fits there (tables written by the study from :mod:`._coverage`)."""

from __future__ import annotations

import html
from collections.abc import Callable
from pathlib import Path

__all__ = ["coverage_section"]


def _pct(df, cols):
    out = df.copy()
    for c in cols:
        out[c] = 100.0 * out[c]
    return out.rename(columns={c: f"{c} [%]" for c in cols})


def _bands_display(bands):
    """Per model × direction × band: time share [%], RMSE of x [mm], P_A, P_B, P_L [bar]."""
    out = _pct(bands, ["time_share"])
    out["rmse_x"] = 1e3 * out["rmse_x"]
    for c in ("rmse_p_a", "rmse_p_b", "rmse_p_l"):
        out[c] = out[c] / 1e5
    return out.rename(
        columns={
            "rmse_x": "rmse_x [mm]",
            "rmse_p_a": "rmse_p_a [bar]",
            "rmse_p_b": "rmse_p_b [bar]",
            "rmse_p_l": "rmse_p_l [bar]",
        }
    )


def _families(cells):
    """Per model and cell family: cells visited and the time share of the most used cell."""
    if len(cells) == 0:
        return cells
    g = cells.groupby(["model", "set"], as_index=False)
    fam = g.agg(cells_visited=("cell", "nunique"), busiest_cell_share=("time_share", "max"))
    return _pct(fam, ["busiest_cell_share"])


def coverage_section(out: Path, table: Callable[..., str]) -> str:
    """HTML of the coverage section, or ``""`` where the study wrote no coverage tables.

    Parameters
    ----------
    out : Path
        Report folder with ``tables/coverage_load_pressure.csv``, ``coverage_bands.csv`` and
        ``coverage_cells.csv``.
    table : callable
        The report's table renderer ``table(df, caption) -> str``.
    """
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    files = [out / "tables" / f"coverage_{n}.csv" for n in ("load_pressure", "bands", "cells")]
    if not all(f.is_file() for f in files):
        return ""
    lp, bands, cells = (pd.read_csv(f) for f in files)
    lp_show = _pct(lp, ["time_share", "covered", "low", "high"])
    for c in ("range_low", "range_high"):
        lp_show[c] = lp_show[c] / 1e5
    lp_show = lp_show.rename(
        columns={"range_low": "range_low [bar]", "range_high": "range_high [bar]"}
    )
    worst = min(lp["covered"]) if len(lp) else float("nan")
    return f"""<h2>Coverage of the partition</h2>
<p>Which load pressures P_L = P_A − αP_B the evaluation runs visit, per flow direction (sign of
the command outside the dead band), against the range in which the valve meters steadily with
both chambers between tank and supply pressure (per sample on the measured P_S). Sine runs alone
stay near the no-load P_L; the campaign's load runs (<code>[sine.load]</code>: counter-force steps
and ramps) walk through the range. Least covered direction: <b>{100 * worst:.0f} %</b> of its
range (low/high: the extreme positions reached, 0 % and 100 % the range's ends).</p>
{table(lp_show, "load-pressure coverage per flow direction")}
<p>Every model per band of that range (band 0 at the low end): time share and RMSE while the
measurement is in the band.</p>
<details><summary>per model, direction and band ({len(bands)} rows)</summary>
{table(_bands_display(bands), "fit per load-pressure band")}
</details>
<p>PWA cells visited per model and cell family (pwa: g dead zone, o C_q, n C_qp, w friction;
pwa-chamber: g dead zone, qa/qb the metering edges of chambers A and B, x the chamber volumes,
w friction), with the per-cell time share and fit in <code>tables/coverage_cells.csv</code>.</p>
{table(_families(cells), "cells visited per model and family")}
<details><summary>per cell ({len(cells)} rows)</summary>
{table(_bands_display(cells.drop(columns=["cells_visited"])) if len(cells) else cells, "fit per cell")}
</details>
<p class="small">{html.escape("Pooled over runs: RMSE = √(Σ n·rmse² / Σ n).")}</p>"""
