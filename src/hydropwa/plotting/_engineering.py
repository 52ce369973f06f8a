"""A control engineer's figures: small-signal Bode, pole map with the valve, per-cell margins,
the PWA error-bound map. The numbers come from :mod:`hydropwa.evaluation` (read by duck typing).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.colors import LogNorm

from ._base import new_figure
from ._shapes import BodeComparisonShape, CellLoopsShape, Columns, require

__all__ = [
    "plot_cell_margins",
    "plot_error_bound_map",
    "plot_pole_map",
    "plot_small_signal_bode",
]


def plot_small_signal_bode(bode: BodeComparisonShape, *, ax: Axes | None = None) -> Any:
    """Bode plot of u → ẋ: linearized (PWA cell + valve) against the full model's small signal.

    Each axis response is shown relative to its own static velocity gain (given in the
    legend in (mm/s)/%), so the measured valve FRF ν/u [1] shares the axes: the valve's
    roll-off against the hydraulic resonance, marked at the cell's natural frequency.

    Parameters
    ----------
    bode : BodeComparison
        ``frequency`` [Hz], ``linearized``, ``full`` [m/s per unit command], ``measured``
        {amplitude: (f [Hz], H [1])}, ``natural_frequency``, ``valve_frequency`` [Hz],
        ``working_point``.
    ax : sequence of two Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    require(bode, BodeComparisonShape, "plot_small_signal_bode")
    fig, axes = new_figure(2, 1, ax=ax, figsize=(7.0, 5.5), sharex=True)
    am, ap = axes[0, 0], axes[1, 0]
    f = np.asarray(bode.frequency)
    for name, h, style in (
        ("full model, small signal", bode.full, ("tab:blue", "-")),
        ("linearized: PWA cell + valve", bode.linearized, ("tab:red", "--")),
    ):
        h = np.asarray(h)
        k0 = abs(h[0])
        am.semilogx(
            f,
            20 * np.log10(np.abs(h) / k0),
            color=style[0],
            ls=style[1],
            label=f"{name} (÷ {k0 * 10:.3g} (mm/s)/%)",
        )
        ap.semilogx(f, np.degrees(np.unwrap(np.angle(h))), color=style[0], ls=style[1])
    for amp, (fm, hm) in sorted(bode.measured.items()):
        am.semilogx(
            fm, 20 * np.log10(np.abs(hm)), "o", ms=3, label=f"measured valve ν/u at {100 * amp:g} %"
        )
        ap.semilogx(fm, np.degrees(np.unwrap(np.angle(hm))), "o", ms=3)
    for a in (am, ap):
        a.axvline(bode.natural_frequency, color="k", lw=0.7, ls=":")
        a.axvline(bode.valve_frequency, color="gray", lw=0.7, ls="-.")
        a.grid(True, which="both", alpha=0.3)
    am.text(
        bode.natural_frequency,
        am.get_ylim()[0],
        f" hydraulic {bode.natural_frequency:.0f} Hz",
        fontsize=7,
        va="bottom",
    )
    am.text(
        bode.valve_frequency,
        am.get_ylim()[1],
        f" valve ω0 {bode.valve_frequency:.0f} Hz",
        fontsize=7,
        va="top",
        color="gray",
    )
    wp = bode.working_point
    am.set_title(
        f"u → ẋ at x = {wp['x'] * 1e3:.0f} mm, u = {100 * wp['u']:.0f} %, "
        f"P_L = {wp['p_l'] / 1e5:.1f} bar, ẋ = {wp['v'] * 1e3:.0f} mm/s",
        fontsize=9,
    )
    am.set_ylabel("magnitude [dB]")
    ap.set_ylabel("phase [deg]")
    ap.set_xlabel("frequency [Hz]")
    am.legend(fontsize=7, loc="lower left")
    return fig


def plot_pole_map(loops: CellLoopsShape, *, ax: Axes | None = None) -> Any:
    """Poles of every cell with the servo valve: open loop (×) and the designed closed loop (o).

    Parameters
    ----------
    loops : CellLoops
        ``open_loop`` and ``closed_loop``: {cell label: continuous-time poles [1/s]}.
    ax : Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    require(loops, CellLoopsShape, "plot_pole_map")
    fig, axes = new_figure(ax=ax, figsize=(6.5, 5.0))
    a = axes[0, 0]
    for poles, marker, label in (
        (loops.open_loop, "x", "open loop, cell + valve"),
        (loops.closed_loop, "o", "closed loop, sampled (ln z / T_s)"),
    ):
        if not poles:
            continue
        p = np.concatenate([np.asarray(v, complex) for v in poles.values()])
        p = p[np.abs(p) < 1e6]  # a pole at z = 0 (the delay's) is infinitely fast: off the map
        a.scatter(
            p.real / (2 * math.pi),
            p.imag / (2 * math.pi),
            marker=marker,
            s=18,
            facecolors="none" if marker == "o" else None,
            edgecolors="tab:blue" if marker == "o" else None,
            color="tab:red" if marker == "x" else None,
            label=f"{label}, {len(poles)} cells",
        )
    a.axvline(0.0, color="k", lw=0.8)
    a.set_xscale("symlog", linthresh=10.0)
    a.set_xlabel("real part / 2π [Hz]")
    a.set_ylabel("imaginary part / 2π [Hz]")
    a.grid(True, alpha=0.3)
    a.legend(fontsize=8)
    a.set_title("poles per PWA cell with the servo valve (Eq. (1))", fontsize=9)
    return fig


def plot_cell_margins(loops: CellLoopsShape, *, ax: Axes | None = None) -> Any:
    """Gain margin [dB] and phase margin [deg] of each cell's designed loop (bars).

    Parameters
    ----------
    loops : CellLoops
        Its ``table`` with ``cell``, ``gain_margin [dB]``, ``phase_margin [deg]``.
    ax : sequence of two Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    require(loops, CellLoopsShape, "plot_cell_margins")
    t = loops.table
    fig, axes = new_figure(2, 1, ax=ax, figsize=(7.5, 5.0), sharex=True)
    x = np.arange(len(t))
    gm = np.asarray(t["gain_margin [dB]"], float)
    pm = np.asarray(t["phase_margin [deg]"], float)
    axes[0, 0].bar(
        x, np.where(np.isfinite(gm), gm, 0.0), color=np.where(gm < 6, "tab:red", "tab:blue")
    )
    axes[0, 0].axhline(6.0, color="k", lw=0.7, ls="--", label="6 dB")
    axes[0, 0].set_ylabel("gain margin [dB]")
    axes[1, 0].bar(x, pm, color=np.where(pm < 30, "tab:red", "tab:blue"))
    axes[1, 0].axhline(30.0, color="k", lw=0.7, ls="--", label="30°")
    axes[1, 0].set_ylabel("phase margin [deg]")
    for a in axes[:, 0]:
        a.legend(fontsize=7)
        a.grid(True, axis="y", alpha=0.3)
    axes[1, 0].set_xticks(x, list(t["cell"]), rotation=90, fontsize=6)
    axes[0, 0].set_title("margins of each cell's loop (broken at the valve command)", fontsize=9)
    return fig


def plot_error_bound_map(bounds: Columns, *, ax: Axes | None = None) -> Any:
    """Heat map of the PWA model's guaranteed Ṗ_L error bound [bar/s] per cell.

    One panel per flow direction (extending s = +1, retracting s = −1); rows the load-pressure
    cells (their P_L range in bar), columns the command (dead-zone) cells (their range of u in
    %); each entry the largest bound over the friction cells (Ṗ_L does not depend on them),
    written in the cell; logarithmic colour scale.

    Parameters
    ----------
    bounds : pandas.DataFrame
        :func:`hydropwa.evaluation.error_bound_map`.
    ax : sequence of two Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, axes = new_figure(1, 2, ax=ax, figsize=(10.0, 4.8))
    b = bounds
    grids = {}
    for s in (1, -1):
        part = b[b["s"] == s]
        if not part.empty:
            grids[s] = (part, part.groupby(["o", "g"])["error_bound"].max().unstack("g") / 1e5)
    vals: Any = np.concatenate([g.to_numpy().ravel() for _, g in grids.values()]) if grids else []
    vals = np.asarray(vals, float)
    vals = vals[np.isfinite(vals) & (vals > 0)]
    norm = LogNorm(vmin=float(vals.min()), vmax=float(vals.max())) if vals.size else None
    im = None
    for a, s in zip(axes[0], (1, -1), strict=True):
        if s not in grids:
            a.set_visible(False)
            continue
        part, grid = grids[s]
        p_rng = part.groupby("o").agg(lo=("p_l_lo", "min"), hi=("p_l_hi", "max"))
        u_rng = part.groupby("g").agg(lo=("u_lo", "min"), hi=("u_hi", "max"))
        data = grid.to_numpy(float)
        im = a.imshow(data, aspect="auto", origin="lower", norm=norm, cmap="viridis")
        for (i, j), v in np.ndenumerate(data):
            if np.isfinite(v):
                bright = norm is not None and v > 0 and norm(v) > 0.6  # viridis turns yellow
                a.text(
                    j,
                    i,
                    f"{v:.3g}",
                    ha="center",
                    va="center",
                    fontsize=7,
                    color="k" if bright else "w",
                )
        a.set_yticks(
            range(len(grid.index)),
            [
                f"{p_rng.loc[o, 'lo'] / 1e5:.4g} … {p_rng.loc[o, 'hi'] / 1e5:.4g}"
                for o in grid.index
            ],
            fontsize=7,
        )
        a.set_xticks(
            range(len(grid.columns)),
            [
                f"{100 * u_rng.loc[g, 'lo']:.3g} … {100 * u_rng.loc[g, 'hi']:.3g}"
                for g in grid.columns
            ],
            fontsize=7,
        )
        a.set_ylabel("P_L cell [bar]")
        a.set_xlabel("command cell, u [%]")
        a.set_title("extending (s = +1)" if s > 0 else "retracting (s = −1)", fontsize=9)
    if im is not None:
        fig.colorbar(im, ax=list(axes[0]), label="guaranteed |Ṗ_L error| [bar/s]")
    return fig
