"""Figures 1–2 equivalents and Tables IV–IX as files (markdown and CSV)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .._io import atomic_path, atomic_write_text

__all__ = ["plot_cq", "plot_cqp", "write_figures", "write_tables"]


def plot_cq(model, p_s: float | None = None):
    """Fig. 1: Ĉ_q of Eq. (18) and its PWA cells C_q (20) over P_L, z > 0. Returns the Figure."""
    from matplotlib.figure import Figure

    ps = model.supply_pressure if p_s is None else float(p_s)
    p_l = np.linspace(-ps, ps * 0.99999, 2000)
    K = model.params.flow.K
    exact = K * np.sqrt(np.maximum(0.5 * (ps - p_l), 0.0))
    cells = model.cells_at(ps)["cq"]
    fig = Figure(figsize=(6, 4))
    ax = fig.add_subplot()
    ax.plot(p_l / 1e5, exact * 1e3, label=r"$\hat C_q$, Eq. (18)")
    ax.plot(p_l / 1e5, cells(p_l) * 1e3, "--", label=f"PWA $C_q$, {cells.n_cells} cells")
    ax.plot(cells.breakpoints / 1e5, cells(cells.breakpoints) * 1e3, "k.", label="breakpoints")
    ax.set_xlabel(r"$P_L$ [bar]")
    ax.set_ylabel(r"$C_q$ [L/s per unit opening]")
    ax.set_title(f"Fig. 1: C_q at P_S = {ps / 1e5:.1f} bar")
    ax.legend()
    ax.grid(True, alpha=0.3)
    return fig


def plot_cqp(model, p_s: float | None = None, openings=(1.0, 0.6, 0.3)):
    """Fig. 2: Ĉ_qp of Eq. (19) and its PWA cells (21) for several openings z. Returns the Figure."""
    from matplotlib.figure import Figure

    ps = model.supply_pressure if p_s is None else float(p_s)
    hi = ps * min(model.cqp.interval[1], 0.999)
    p_l = np.linspace(-ps, hi, 2000)
    K = model.params.flow.K
    cells = model.cells_at(ps)["cqp"]
    fig = Figure(figsize=(6, 4))
    ax = fig.add_subplot()
    for z in openings:
        exact = z * K / (4 * np.sqrt(0.5 * (ps - p_l)))
        (line,) = ax.plot(p_l / 1e5, exact * 1e12, label=f"$\\hat C_{{qp}}$, z = {z:g}")
        ax.plot(p_l / 1e5, z * cells(p_l) * 1e12, "--", color=line.get_color())
    ax.set_xlabel(r"$P_L$ [bar]")
    ax.set_ylabel(r"$C_{qp}$ [$10^{-12}$ m³/(s·Pa)]")
    ax.set_title(f"Fig. 2: C_qp (dashed: {cells.n_cells} PWA cells), P_S = {ps / 1e5:.1f} bar")
    ax.legend()
    ax.grid(True, alpha=0.3)
    return fig


def write_figures(model, folder: str | os.PathLike) -> list[Path]:
    """Write fig1_cq and fig2_cqp as PNG and SVG into ``folder``; return the paths."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    out = []
    folder = Path(folder)
    for name, fig in (("fig1_cq", plot_cq(model)), ("fig2_cqp", plot_cqp(model))):
        for ext in ("png", "svg"):
            path = folder / f"{name}.{ext}"
            with atomic_path(path) as tmp:
                fig.savefig(tmp, format=ext, dpi=150, bbox_inches="tight")
            out.append(path)
    return out


def _markdown(df) -> str:
    cols = list(df.columns)
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for row in df.itertuples(index=False):
        lines.append(
            "| " + " | ".join(f"{v:.6g}" if isinstance(v, float) else str(v) for v in row) + " |"
        )
    return "\n".join(lines) + "\n"


def model_tables(model, p_s: float | None = None) -> dict:
    """Tables IV–IX of ``model`` at ``p_s`` [Pa] (z > 0 branch): DataFrames of k and d per cell."""
    import pandas as pd

    cells = model.cells_at(p_s)
    roman = ["I", "II", "III", "IV", "V", "VI", "VII", "VIII", "IX", "X", "XI", "XII"]

    def frame(pwa, k, d, ku, du):
        n = pwa.n_cells
        lab = [roman[i] if i < len(roman) else str(i + 1) for i in range(n)]
        lo = np.concatenate(([-np.inf], pwa.breakpoints))
        hi = np.concatenate((pwa.breakpoints, [np.inf]))
        return pd.DataFrame(
            {
                "cell": lab,
                "from": lo,
                "to": hi,
                f"{k} [{ku}]": pwa.slopes,
                f"{d} [{du}]": pwa.offsets,
            }
        )

    return {
        "IV_dead_zone": frame(cells["dead_zone"], "k_g", "d_g", "1", "1"),
        "V_friction": frame(cells["friction"], "k_w", "d_w", "N·s/m", "N"),
        "VI_VII_cq": frame(cells["cq"], "k_o", "d_o", "m³/(s·Pa)", "m³/s"),
        "VIII_IX_cqp": frame(cells["cqp"], "k_n", "d_n", "m³/(s·Pa²)", "m³/(s·Pa)"),
    }


def write_tables(model, folder: str | os.PathLike, *, with_paper: bool = True) -> list[Path]:
    """Write the model's Tables IV–IX (and, optionally, the paper reproduction) as .md and .csv."""
    folder = Path(folder)
    tables = dict(model_tables(model))
    if with_paper:
        from ._paper_tables import reproduce_paper_tables

        for key, df in reproduce_paper_tables().items():
            tables[f"paper_table_{key}"] = df
    out = []
    for name, df in tables.items():
        out.append(atomic_write_text(folder / f"{name}.csv", df.to_csv(index=False)))
        out.append(atomic_write_text(folder / f"{name}.md", f"# {name}\n\n" + _markdown(df)))
    return out
