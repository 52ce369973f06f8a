"""Plots of simulation results in engineering units (%, mm, bar, N)."""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["plot_result", "save_figure", "DISPLAY"]

#: channel → (label, factor from SI, display unit)
DISPLAY = {
    "u": ("valve command", 100.0, "%"),
    "spool": ("spool position", 100.0, "%"),
    "z": ("orifice opening", 100.0, "%"),
    "x": ("rod position", 1e3, "mm"),
    "v": ("rod velocity", 1e3, "mm/s"),
    "p_a": ("P_A", 1e-5, "bar"),
    "p_b": ("P_B", 1e-5, "bar"),
    "p_l": ("P_L", 1e-5, "bar"),
    "p_s": ("P_S", 1e-5, "bar"),
    "f_l": ("load force", 1.0, "N"),
    "friction": ("friction force", 1.0, "N"),
}


def _group(channels):
    groups: dict[str, list[str]] = {}
    for ch in channels:
        unit = DISPLAY.get(ch, (ch, 1.0, ""))[2]
        groups.setdefault(unit, []).append(ch)
    return groups


def plot_result(result, channels=("u", "x", "p_a", "p_b", "p_s")):
    """Plot channels of a result (or Run) against time, one axis per display unit.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    chans = [c for c in channels if c in result.channels]
    groups = _group(chans)
    fig, axes = plt.subplots(
        len(groups), 1, sharex=True, figsize=(7.5, 1.9 * len(groups) + 0.8), squeeze=False
    )
    t = result.channels["t"]
    for ax, (unit, names) in zip(axes[:, 0], groups.items(), strict=True):
        for ch in names:
            label, fac, _ = DISPLAY.get(ch, (ch, 1.0, ""))
            ax.plot(t, result.channels[ch] * fac, label=label, lw=1.0)
        ax.set_ylabel(unit or "1")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
    axes[-1, 0].set_xlabel("time [s]")
    title = getattr(result, "model", None) or getattr(result, "name", "")
    if title:
        axes[0, 0].set_title(f"{title}")
    fig.tight_layout()
    return fig


def save_figure(fig, path: str | os.PathLike, dpi: int = 150) -> Path:
    """Save a figure atomically (format from the suffix) and close it."""
    import matplotlib.pyplot as plt

    from .._io import atomic_path

    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format=path.suffix.lstrip(".") or "png")
    plt.close(fig)
    return path
