"""Figures 1–2 (curves computed here, drawn by :mod:`hydropwa.plotting`) and Tables IV–IX as
files (markdown and CSV)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .._io import atomic_write_text
from ._cells import cq_shape, cqp_shape
from ._paper_tables import reproduce_paper_tables

__all__ = ["cq_figure", "cqp_figure", "write_figures", "write_tables"]


def cq_figure(model, p_s: float | None = None):
    """Fig. 1 of ``model``: Ĉ_q of Eq. (18) and its PWA cells (20) over P_L at P_S = ``p_s`` [Pa].

    The curve is computed here (Ĉ_q = K·r·√(1 − P_L/P_e), :func:`cq_shape`, with the edge
    pressure P_e and root r of :meth:`PwaModel.edge_pressure`: P_S and √(P_S/2) in the paper
    form, the single-rod values in the asymmetric form) and drawn by
    :func:`hydropwa.plotting.plot_cq`. Returns the figure.
    """
    from ..plotting import plot_cq  # deferred: matplotlib loads only when plotting

    ps = model.supply_pressure if p_s is None else float(p_s)
    pe, root = model.edge_pressure(ps, 1)
    p_l = np.linspace(-0.999 * ps, 0.999 * pe, 800)
    exact = model.params.flow.K * root * cq_shape(p_l / pe)
    return plot_cq(p_l, exact, model.cells_at(ps)["cq"], supply_pressure=ps)


def cqp_figure(model, p_s: float | None = None, openings=(0.25, 0.5, 0.75, 1.0)):
    """Fig. 2 of ``model``: Ĉ_qp of Eq. (19) and its PWA cells (21) for several openings z.

    Ĉ_qp = z·K/(4r)·1/√(1 − P_L/P_e) (:func:`cqp_shape`; P_e, r as in :func:`cq_figure`),
    drawn by :func:`hydropwa.plotting.plot_cqp` up to the fitted interval. Returns the figure.
    """
    from ..plotting import plot_cqp  # deferred: matplotlib loads only when plotting

    ps = model.supply_pressure if p_s is None else float(p_s)
    pe, root = model.edge_pressure(ps, 1)
    p_l = np.linspace(-0.999 * ps, min(model.cqp.interval[1], 0.95) * pe, 800)
    scale = model.params.flow.K / (4.0 * root)
    exact = {float(z): z * scale * cqp_shape(p_l / pe) for z in openings}
    return plot_cqp(p_l, exact, model.cells_at(ps)["cqp"], supply_pressure=ps)


def write_figures(model, folder: str | os.PathLike, *, overwrite: bool = True) -> list[Path]:
    """Write fig01_cq and fig02_cqp as PNG and SVG into ``folder``; return the paths.

    ``overwrite`` as in :func:`hydropwa.plotting.save_figure` (the CLI checks the folder
    with ``--force`` first).
    """
    from ..plotting import save_figure  # deferred: matplotlib loads only when plotting

    out = []
    folder = Path(folder)
    for name, fig in (("fig01_cq", cq_figure(model)), ("fig02_cqp", cqp_figure(model))):
        for ext in ("png", "svg"):
            out.append(save_figure(fig, folder / f"{name}.{ext}", dpi=150, overwrite=overwrite))
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
    import pandas as pd  # deferred: pandas loads only for tables

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
        for key, df in reproduce_paper_tables().items():
            tables[f"paper_table_{key}"] = df
    out = []
    for name, df in tables.items():
        out.append(atomic_write_text(folder / f"{name}.csv", df.to_csv(index=False)))
        out.append(atomic_write_text(folder / f"{name}.md", f"# {name}\n\n" + _markdown(df)))
    return out
