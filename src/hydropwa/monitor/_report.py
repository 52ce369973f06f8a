"""``health.json`` and ``health.html``: the indicators of every run and their trends over runs.

The trends are small inline SVG charts (value, its interval and the threshold per run, in
the indicator's display unit), so the page needs no plotting library and opens offline.
"""

from __future__ import annotations

import html
import json
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .._io import atomic_write_text, check_output
from ._indicators import INDICATORS, Indicator

if TYPE_CHECKING:
    from ._monitor import HealthReport

__all__ = ["write_report", "HEALTH_JSON", "HEALTH_HTML"]

HEALTH_JSON = "health.json"
HEALTH_HTML = "health.html"

_W, _H, _PAD = 520, 150, 36


def _trend_svg(report: HealthReport, ind: Indicator) -> str:
    """One indicator over the runs: intervals as bars, values as dots, thresholds dashed."""
    pts = []
    for i, r in enumerate(report.runs):
        iv = r.indicators[ind.name]
        if iv.available:
            pts.append((i, iv))
    if not pts:
        return "<p>not available from these runs</p>"
    s = ind.display_scale
    ys = [y * s for _, iv in pts for y in iv.interval]
    ys += [t * s for _, iv in pts for t in iv.threshold if t is not None and math.isfinite(t)]
    lo, hi = min(ys), max(ys)
    span = (hi - lo) or (abs(hi) or 1.0)
    lo, hi = lo - 0.05 * span, hi + 0.05 * span
    n = max(1, len(report.runs) - 1)

    def X(i: float) -> float:
        return _PAD + (_W - 2 * _PAD) * (i / n if len(report.runs) > 1 else 0.5)

    def Y(v: float) -> float:
        return _H - _PAD / 2 - (_H - _PAD) * (v - lo) / (hi - lo)

    parts = [f'<svg width="{_W}" height="{_H}" xmlns="http://www.w3.org/2000/svg">']
    parts.append(f'<rect x="0" y="0" width="{_W}" height="{_H}" fill="white" stroke="#ccc"/>')
    for side in (0, 1):
        line = [
            (X(i), Y(t * s))
            for i, iv in pts
            if (t := iv.threshold[side]) is not None and math.isfinite(t)
        ]
        if line:
            d = " ".join(f"{x:.1f},{y:.1f}" for x, y in line)
            parts.append(
                f'<polyline points="{d}" fill="none" stroke="#c00" stroke-dasharray="4 3"/>'
            )
    for i, iv in pts:
        x = X(i)
        colour = "#c00" if iv.alarm else "#246"
        parts.append(
            f'<line x1="{x:.1f}" x2="{x:.1f}" y1="{Y(iv.interval[0] * s):.1f}" '
            f'y2="{Y(iv.interval[1] * s):.1f}" stroke="{colour}" opacity="0.5"/>'
        )
        parts.append(f'<circle cx="{x:.1f}" cy="{Y(iv.value * s):.1f}" r="2.5" fill="{colour}"/>')
    for v in (lo, hi):
        parts.append(f'<text x="2" y="{Y(v) + 4:.1f}" font-size="10">{v:.3g}</text>')
    parts.append("</svg>")
    return "".join(parts)


def _run_table(report: HealthReport) -> str:
    rows = []
    for r in report.runs:
        state = f"ALARM: {', '.join(r.faults)}" if r.alarm else "healthy"
        rows.append(
            f"<tr><td>{html.escape(r.run)}</td><td>{html.escape(state)}</td><td>{r.rows}</td></tr>"
        )
    return (
        "<table><tr><th>run</th><th>state (fault named first)</th><th>rows</th></tr>"
        + "".join(rows)
        + "</table>"
    )


def _html(report: HealthReport) -> str:
    sections = []
    for ind in INDICATORS:
        note = "" if ind.alarms else " (estimate only, no threshold)"
        sections.append(
            f"<h3>{ind.name} [{html.escape(ind.display_unit)}]{note}</h3>{_trend_svg(report, ind)}"
        )
    skipped = "".join(f"<li>{html.escape(s)}</li>" for s in report.skipped)
    return (
        "<!doctype html><html><head><meta charset='utf-8'><title>hydropwa health</title>"
        "<style>body{font-family:sans-serif;max-width:60em;margin:auto}"
        "td,th{padding:2px 8px;border-bottom:1px solid #ddd}</style></head><body>"
        f"<h1>Axis health: {len(report.runs)} runs, {len(report.alarms)} alarming</h1>"
        f"<p>Thresholds sized for a false-alarm probability of {report.false_alarm:g} per healthy run "
        f"(k = {report.k:.2f} standard errors plus the held parameters' bound; see docs/monitoring.md). "
        "Dots: estimates; bars: ± k standard errors; dashed: thresholds; red: alarm.</p>"
        f"{_run_table(report)}{'<h2>Skipped</h2><ul>' + skipped + '</ul>' if skipped else ''}"
        f"<h2>Trends over runs</h2>{''.join(sections)}</body></html>"
    )


def write_report(
    report: HealthReport, out: str | os.PathLike, *, overwrite: bool = False
) -> dict[str, Any]:
    """Write ``out/health.json`` and ``out/health.html``; returns ``{"json": path, "html": path}``.

    Raises
    ------
    OutputExistsError
        Either file exists and ``overwrite`` is False.
    """
    folder = Path(out)
    check_output(folder, overwrite, folder=True, files=(HEALTH_JSON, HEALTH_HTML))
    folder.mkdir(parents=True, exist_ok=True)
    doc = json.dumps(report.to_dict(), indent=1, allow_nan=False)
    js = atomic_write_text(folder / HEALTH_JSON, doc, overwrite=overwrite)
    page = atomic_write_text(folder / HEALTH_HTML, _html(report), overwrite=overwrite)
    return {"json": js, "html": page}
