"""The files of a plan folder: command and positioning files, the HTML page and its figure.

Written by :meth:`hydropwa.rig.Plan.write` into its temporary folder (nothing half-written).
"""

from __future__ import annotations

import html
import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from ._plan import Plan, PlannedRun

__all__ = ["envelope_figure", "plan_html", "positioning_reference", "write_plan_files"]

_HOLD = 0.5  # [s] at the start position before the run's command begins


def positioning_reference(
    x_from: float, x_to: float, rate: float, v: float, a: float = 1.0
) -> tuple[np.ndarray, np.ndarray]:
    """Trapezoidal position reference r(t) [m] from ``x_from`` to ``x_to``, then a hold.

    Parameters
    ----------
    x_from, x_to : float
        Positions [m].
    rate : float
        Sample rate [Hz].
    v : float
        Cruise speed [m/s] of the move.
    a : float
        Acceleration [m/s²] of the move (default 1 m/s²).

    Returns
    -------
    t, r : ndarray
        Times [s] from 0 and the reference [m]; ``_HOLD`` s at ``x_to`` at the end.
    """
    d = abs(x_to - x_from)
    t_acc = min(v / a, math.sqrt(d / a))
    v_top = a * t_acc
    t_move = 2 * t_acc + (d - a * t_acc**2) / v_top if d > 0 else 0.0
    t = np.arange(int(math.ceil((t_move + _HOLD) * rate)) + 1) / rate
    s = np.where(
        t < t_acc,
        0.5 * a * t**2,
        np.where(
            t < t_move - t_acc,
            0.5 * a * t_acc**2 + v_top * (t - t_acc),
            d - 0.5 * a * np.clip(t_move - t, 0.0, None) ** 2,
        ),
    )
    s = np.clip(s, 0.0, d)
    return t, x_from + np.sign(x_to - x_from) * s


def _csv(path: Path, columns: dict[str, np.ndarray]) -> None:
    data = np.column_stack(list(columns.values()))
    np.savetxt(path, data, delimiter=",", header=",".join(columns), comments="", fmt="%.9g")


def _write_commands(plan: Plan, root: Path) -> None:
    from scipy.io import savemat  # deferred: SciPy's MAT writer, only here

    (root / "commands").mkdir()
    (root / "positioning").mkdir()
    (root / "predicted").mkdir()
    lim = plan.limits
    v_pos = min(0.1, 0.2 * lim.max_velocity)
    x_prev = 0.5 * plan.params.cylinder.stroke
    for r in plan.runs:
        cols = {"t": r.t, "u": r.u}
        if r.f_l is not None:
            cols["f_l"] = r.f_l
        _csv(root / "commands" / f"{r.name}.csv", cols)
        savemat(
            root / "commands" / f"{r.name}.mat",
            {k: np.asarray(v, dtype=float).reshape(-1, 1) for k, v in cols.items()},
            do_compression=True,
        )
        _csv(root / "predicted" / f"{r.name}.csv", {"t": r.t, **r.predicted})
        t, ref = positioning_reference(x_prev, r.start_position, plan.rate, v_pos)
        _csv(root / "positioning" / f"{r.name}.csv", {"t": t, "r": ref})
        x_prev = r.envelope.end_position


def _sparkline(r: PlannedRun, width: int = 240, height: int = 40) -> str:
    """An inline SVG of the command u(t) (at most ``width`` points)."""
    idx = np.linspace(0, r.t.size - 1, min(width, r.t.size)).astype(int)
    t, u = r.t[idx], r.u[idx]
    xs = width * t / max(float(r.t[-1]), 1e-9)
    ys = height * (0.5 - 0.5 * u)
    pts = " ".join(f"{x:.1f},{y:.1f}" for x, y in zip(xs, ys, strict=True))
    return (
        f'<svg width="{width}" height="{height}" viewBox="0 0 {width} {height}">'
        f'<line x1="0" y1="{height / 2}" x2="{width}" y2="{height / 2}" stroke="#ccc"/>'
        f'<polyline fill="none" stroke="#1f77b4" points="{pts}"/></svg>'
    )


def _cell(value: float, bad: bool, fmt: str) -> str:
    style = ' style="background:#fdd"' if bad else ""
    return f"<td{style}>{format(value, fmt)}</td>"


def _row(r: PlannedRun, plan: Plan) -> str:
    e, lim = r.envelope, plan.limits
    return (
        f"<tr><td>{html.escape(r.name)}</td><td>{r.duration:.3g}</td><td>{_sparkline(r)}</td>"
        + _cell(e.p_max / 1e5, e.p_max > (lim.max_pressure or math.inf), ".1f")
        + _cell(e.p_min / 1e5, e.p_min < lim.min_pressure, ".1f")
        + _cell(e.cavitation_margin / 1e5, False, ".2f")
        + _cell(1e3 * e.stroke_used, False, ".1f")
        + _cell(1e3 * e.to_retracted, e.to_retracted < lim.stroke_margin, ".1f")
        + _cell(1e3 * e.to_extended, e.to_extended < lim.stroke_margin, ".1f")
        + _cell(e.v_peak, e.v_peak > lim.max_velocity, ".3g")
        + _cell(100 * e.saturation, False, ".0f")
        + f"<td>{html.escape(r.adaptation)}</td></tr>"
    )


def plan_html(plan: Plan, page: bool = True) -> str:
    """The plan as HTML: limits, refused runs and one row per run (``page``: a whole page)."""
    return _html(plan) if page else _runs_table(plan)


def _runs_table(plan: Plan) -> str:
    head = (
        "<tr><th>run</th><th>s</th><th>command u(t)</th><th>p max [bar]</th>"
        "<th>p min [bar]</th><th>cavitation margin [bar]</th><th>stroke used [mm]</th>"
        "<th>to retracted [mm]</th><th>to extended [mm]</th><th>|v| max [m/s]</th>"
        "<th>saturated [%]</th><th>adapted</th></tr>"
    )
    body = "".join(_row(r, plan) for r in plan.runs)
    return f"<p>{html.escape(plan.message)}</p><table>{head}{body}</table>"


def _html(plan: Plan) -> str:
    lim = plan.limits
    refused = "".join(f"<li>{html.escape(str(r))}</li>" for r in plan.refused) or "<li>none</li>"
    return (
        "<!doctype html><html><head><meta charset='utf-8'><title>hydropwa plan</title>"
        "<style>body{font-family:sans-serif}td,th{border:1px solid #ccc;padding:2px 6px}"
        "table{border-collapse:collapse}</style></head><body>"
        f"<h1>Plan: {html.escape(plan.campaign)}</h1>"
        f"<p>Limits: end stops ≥ {1e3 * lim.stroke_margin:g} mm, chambers "
        f"{lim.min_pressure / 1e5:g} … {(lim.max_pressure or math.nan) / 1e5:g} bar, "
        f"|v| ≤ {lim.max_velocity:g} m/s, |u| ≤ {lim.max_opening:g}, runs ≤ "
        f"{lim.max_duration:g} s. Envelopes from the full-order model playing each sampled "
        "command; a red cell breaks its limit.</p>"
        "<img src='plan.png' alt='envelopes against the limits'>"
        f"<h2>Refused</h2><ul>{refused}</ul>"
        f"<h2>Runs</h2>{_runs_table(plan)}</body></html>"
    )


def envelope_figure(plan: Plan, ax=None):
    """Each run's envelope (plan order) against the limits, on four axes (or the four given)."""
    from ..plotting import new_figure  # deferred: matplotlib loads only here

    e = [r.envelope for r in plan.runs]
    k = np.arange(len(e))
    lim = plan.limits
    fig, grid = new_figure(4, 1, ax=ax, figsize=(9, 9), sharex=True)
    axes = grid.ravel()
    ax = axes[0]
    ax.plot(k, [x.p_max / 1e5 for x in e], "^", label="p max")
    ax.plot(k, [x.p_min / 1e5 for x in e], "v", label="p min")
    ax.axhline((lim.max_pressure or math.nan) / 1e5, color="r", lw=1)
    ax.axhline(lim.min_pressure / 1e5, color="r", lw=1)
    ax.set_ylabel("chamber [bar]")
    ax.legend(loc="best", fontsize=8)
    ax = axes[1]
    ax.plot(k, [1e3 * min(x.to_retracted, x.to_extended) for x in e], "o", ms=3)
    ax.axhline(1e3 * lim.stroke_margin, color="r", lw=1)
    ax.set_ylabel("to end stop [mm]")
    axes[2].plot(k, [x.v_peak for x in e], "o", ms=3)
    axes[2].axhline(lim.max_velocity, color="r", lw=1)
    axes[2].set_ylabel("|v| max [m/s]")
    axes[3].plot(k, [100 * x.saturation for x in e], "o", ms=3)
    axes[3].set_ylabel("saturated [%]")
    axes[3].set_xlabel("run (plan order)")
    return fig


def write_plan_files(plan: Plan, root: Path) -> None:
    """Commands, positioning references, ``plan.html`` and ``plan.png`` into ``root``."""
    _write_commands(plan, root)
    if plan.runs:
        from ..plotting import save_figure  # deferred: matplotlib loads only here

        save_figure(envelope_figure(plan), root / "plan.png", overwrite=True)
    (root / "plan.html").write_text(_html(plan), encoding="utf-8")
