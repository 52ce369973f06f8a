"""Figures of the piecewise-affine model: Ĉ_q and Ĉ_qp with their cells (Figs. 1, 2) and the
cell occupancy of evaluated runs.

The exact curves are computed by the caller (:mod:`hydropwa.linearization`); cells are any
callable with ``breakpoints`` and ``n_cells`` (a :class:`~hydropwa.components.PiecewiseAffine`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import matplotlib
import numpy as np
from matplotlib.axes import Axes

from ._base import new_figure

__all__ = ["plot_cq", "plot_cqp", "plot_cell_occupancy"]


def plot_cq(
    load_pressure: Any,
    exact: Any,
    cells: Callable[[np.ndarray], Any],
    *,
    supply_pressure: float,
    ax: Axes | None = None,
) -> Any:
    """Fig. 1: Ĉ_q of Eq. (18) over P_L and its PWA cells C_q, Eq. (20).

    Parameters
    ----------
    load_pressure : array_like
        P_L [Pa].
    exact : array_like
        Ĉ_q at ``load_pressure`` [m³/s per unit opening].
    cells : PiecewiseAffine
        The cells at this supply pressure, P_L [Pa] → m³/s.
    supply_pressure : float
        P_S [Pa], for the title.
    ax : Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    p_l = np.asarray(load_pressure, dtype=float)
    fig, axes = new_figure(ax=ax, figsize=(6.5, 4.0))
    a = axes[0, 0]
    a.plot(p_l / 1e5, np.asarray(exact) * 6e4, "k", lw=1.6, label="Ĉ_q, Eq. (18)")
    a.plot(
        p_l / 1e5,
        cells(p_l) * 6e4,
        "r--",
        lw=1.2,
        label=f"PWA, {getattr(cells, 'n_cells', '?')} cells (20)",
    )
    for b in getattr(cells, "breakpoints", ()):
        a.axvline(b / 1e5, color="r", lw=0.5, alpha=0.4)
    a.set_xlabel("load pressure P_L [bar]")
    a.set_ylabel("Ĉ_q [L/min per unit opening]")
    a.set_title(
        f"Fig. 1: Ĉ_q and its linearization (P_S = {supply_pressure / 1e5:.1f} bar)", fontsize=10
    )
    a.grid(True, alpha=0.3)
    a.legend(fontsize=8)
    return fig


def plot_cqp(
    load_pressure: Any,
    exact: Mapping[float, Any],
    cells: Callable[[np.ndarray], Any],
    *,
    supply_pressure: float,
    ax: Axes | None = None,
) -> Any:
    """Fig. 2: Ĉ_qp of Eq. (19) over P_L for several openings z and the PWA cells, Eq. (21).

    Parameters
    ----------
    load_pressure : array_like
        P_L [Pa].
    exact : mapping of float to array_like
        Opening z [1] → Ĉ_qp at ``load_pressure`` [m³/(s·Pa)]; the cells are drawn scaled
        by z, as in Eq. (21).
    cells : PiecewiseAffine
        The cells at |z| = 1, P_L [Pa] → m³/(s·Pa).
    supply_pressure : float
        P_S [Pa], for the title.
    ax : Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib import colormaps  # deferred: matplotlib loads only when plotting

    p_l = np.asarray(load_pressure, dtype=float)
    fig, axes = new_figure(ax=ax, figsize=(6.5, 4.0))
    a = axes[0, 0]
    cmap = colormaps["viridis"]
    for i, (z, y) in enumerate(exact.items()):
        c = cmap(i / max(1, len(exact) - 1))
        a.plot(p_l / 1e5, np.asarray(y) * 6e9, color=c, lw=1.5, label=f"Ĉ_qp, z = {z:g}")
        a.plot(p_l / 1e5, z * cells(p_l) * 6e9, color=c, ls="--", lw=1.0)
    a.plot([], [], "k--", lw=1.0, label=f"PWA, {getattr(cells, 'n_cells', '?')} cells (21)")
    a.set_xlabel("load pressure P_L [bar]")
    a.set_ylabel("Ĉ_qp [L/min per bar]")
    a.set_title(
        f"Fig. 2: Ĉ_qp and its linearization (P_S = {supply_pressure / 1e5:.1f} bar)", fontsize=10
    )
    a.grid(True, alpha=0.3)
    a.legend(fontsize=8)
    return fig


def plot_cell_occupancy(
    cell_metrics: Any,
    pwa: Any = None,
    trajectory: Any = None,
    *,
    ax: Axes | Sequence[Axes] | None = None,
) -> Any:
    """Time share of each PWA cell over the evaluated runs, and the (u, P_L) partition.

    Parameters
    ----------
    cell_metrics : pandas.DataFrame
        ``EvaluationResult.cell_metrics`` of one or more runs (``set``, ``cell``, ``fraction``).
    pwa : PwaModel, optional
        Its dead-zone (u) and C_q (P_L) cell boundaries (``cells_at``) are drawn under the
        trajectory.
    trajectory : SimulationResult, optional
        A PWA simulation whose (u, P_L) path is drawn, coloured by the C_q cell.
    ax : Axes, or two Axes with ``pwa`` and ``trajectory``, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    ncol = 2 if pwa is not None and trajectory is not None else 1
    fig, axes = new_figure(1, ncol, ax=ax, figsize=(5.2 * ncol, 4.0))
    a = axes[0, 0]
    names = {"g": "dead-zone", "o": "C_q", "n": "C_qp", "w": "friction"}
    if len(cell_metrics):
        occ = cell_metrics.groupby(["set", "cell"])["fraction"].mean()
        x0 = 0
        for s, label in names.items():
            if s not in occ.index.get_level_values(0):
                continue
            part = occ.loc[s]
            xs = x0 + np.arange(len(part))
            a.bar(xs, 100 * part.to_numpy(), label=label)
            for xx, c in zip(xs, part.index, strict=True):
                a.text(xx, 1, str(c), ha="center", fontsize=6)
            x0 = xs[-1] + 2
    a.set_xticks([])
    a.set_ylabel("time active [%]")
    a.set_title("PWA cell occupancy (mean over runs; numbers: cell)", fontsize=9)
    if len(cell_metrics):  # no occupancy given: no bars, no legend
        a.legend(fontsize=7)
    if ncol == 2:
        a = axes[0, 1]
        ch = trajectory.channels
        cells = pwa.cells_at(pwa.supply_pressure)
        for b in cells["dead_zone"].breakpoints:
            a.axvline(100 * b, color="gray", lw=0.6)
        for b in cells["cq"].breakpoints:
            a.axhline(b / 1e5, color="gray", lw=0.6)
        # one colour per C_q cell, whatever the trajectory visits (a trajectory in one cell
        # drew a colour bar of -0.1...0.1 with matplotlib's autoscaling)
        n_cells = len(cells["cq"].breakpoints) + 1
        cmap = matplotlib.colormaps["viridis"].resampled(n_cells)
        sc = a.scatter(
            100 * ch["u"],
            ch["p_l"] / 1e5,
            c=ch["cell_o"],
            s=2,
            cmap=cmap,
            vmin=-0.5,
            vmax=n_cells - 0.5,
        )
        fig.colorbar(sc, ax=a, label="C_q cell (index, Table VI)", ticks=range(n_cells))
        a.set_xlabel("valve command u [%]")
        a.set_ylabel("load pressure P_L [bar]")
        a.set_title("partition (u, P_L) and one trajectory", fontsize=9)
    return fig
