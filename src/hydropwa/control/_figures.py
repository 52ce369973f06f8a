"""Figures of closed-loop runs (matplotlib ``Figure`` objects, no pyplot state)."""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["plot_closed_loop", "save_control_figure"]

_COLORS = {"full": "C0", "reduced": "C1", "pwa": "C2"}


def plot_closed_loop(results, title: str | None = None):
    """Reference and position, following error and valve command of one or more runs.

    Parameters
    ----------
    results : SimulationResult or dict of str → SimulationResult
        Closed-loop results, e.g. one controller on the full, reduced and PWA models.
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    if not isinstance(results, dict):
        results = {results.model: results}
    fig = Figure(figsize=(8.0, 7.0))
    ax = fig.subplots(3, 1, sharex=True)
    first = True
    for name, res in results.items():
        c = _COLORS.get(name)
        t = res.t
        if first:
            ax[0].plot(t, res["reference"] * 1e3, "k--", lw=1.0, label="reference")
            first = False
        ax[0].plot(t, res["x"] * 1e3, color=c, lw=1.0, label=name)
        ax[1].plot(t, res["error"] * 1e3, color=c, lw=1.0, label=name)
        ax[2].step(
            res.control["t"], res.control["u"] * 100.0, where="post", color=c, lw=0.8, label=name
        )
    ax[0].set_ylabel("rod position [mm]")
    ax[1].set_ylabel("following error [mm]")
    ax[2].set_ylabel("valve command [%]")
    ax[2].set_xlabel("time [s]")
    for a in ax:
        a.grid(True, alpha=0.3)
        a.legend(loc="upper right", fontsize=8)
    if title:
        ax[0].set_title(title)
    fig.tight_layout()
    return fig


def save_control_figure(fig, path: str | os.PathLike, dpi: int = 150) -> Path:
    """Save a figure atomically (format from the suffix)."""
    from .._io import atomic_path

    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format=path.suffix.lstrip(".") or "png")
    return path
