"""The paper's figures from this package's objects, in engineering units (mm, bar, %).

Figs. 1, 2 (C_q, C_qp and their PWA cells), 5 (valve Bode plots), 6 (dead-zone), 8 (Stribeck),
10–13 (measurement and models on the sine runs) and a cell-occupancy plot of the PWA model.
Every function returns a matplotlib figure (Agg backend); :func:`save_figure` writes it.
Nothing here computes physics: curves come from the linearization and identification layers.
"""

from __future__ import annotations

import numpy as np

from .plots import DISPLAY

__all__ = [
    "MODEL_STYLE",
    "moving_average",
    "plot_evaluation",
    "plot_cq",
    "plot_cqp",
    "plot_bode",
    "plot_dead_zone",
    "plot_stribeck",
    "plot_cell_occupancy",
]

#: Line style per model variant (colour, line style, label).
MODEL_STYLE = {
    "full": ("tab:blue", "-", "full-order"),
    "reduced": ("tab:green", "--", "reduced (mean P_S)"),
    "reduced-scheduled": ("tab:olive", "--", "reduced (P_S(t))"),
    "pwa": ("tab:red", "-.", "PWA (mean P_S)"),
    "pwa-scheduled": ("tab:purple", ":", "PWA scheduled (P_S(t))"),
    "reduced-paper": ("tab:gray", "--", "reduced, paper form (mean area)"),
    "pwa-paper": ("tab:brown", "-.", "PWA, paper form (mean area)"),
}


def _plt():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def moving_average(y, n: int) -> np.ndarray:
    """Centred moving average over ``n`` samples (edges use the samples available); display only."""
    y = np.asarray(y, dtype=float)
    if n <= 1 or y.size < n:
        return y.copy()
    kernel = np.ones(n)
    num = np.convolve(y, kernel, mode="same")
    den = np.convolve(np.ones_like(y), kernel, mode="same")
    return num / den


def plot_evaluation(result, models=None, channels=("u", "x", "p_l"), smooth: float = 0.01):
    """Measurement and model outputs over time, like Figs. 10–13 of the paper.

    Parameters
    ----------
    result : EvaluationResult
    models : sequence of str, optional
        Variants to draw (default: all simulated).
    channels : sequence of str
        One axis each (``u`` shows the command only).
    smooth : float
        Moving-average window [s] applied to the measurement for display only (Sec. VII).

    Returns
    -------
    matplotlib.figure.Figure
    """
    plt = _plt()
    meas = result.measured
    t = meas["t"] - meas["t"][0]
    dt = float(np.median(np.diff(meas["t"]))) if t.size > 1 else 1.0
    n = max(1, int(round(smooth / dt)))
    models = list(result.simulations) if models is None else list(models)
    fig, axes = plt.subplots(
        len(channels), 1, sharex=True, figsize=(7.5, 1.9 * len(channels) + 0.9), squeeze=False
    )
    for ax, ch in zip(axes[:, 0], channels, strict=True):
        label, fac, unit = DISPLAY.get(ch, (ch, 1.0, ""))
        if ch in meas:
            y = meas[ch] if ch == "u" else moving_average(meas[ch], n)
            # drawn over the models (zorder) and dashed, so a model that fits does not hide it
            ax.plot(
                t,
                y * fac,
                color="k",
                lw=1.2,
                ls="--" if ch != "u" else "-",
                zorder=10,
                label="command" if ch == "u" else "measurement",
            )
        if ch != "u":
            for m in models:
                res = result.simulations[m]
                color, ls, lab = MODEL_STYLE.get(m, ("gray", "-", m))
                ax.plot(
                    res.t - meas["t"][0],
                    res.channels[ch] * fac,
                    color=color,
                    ls=ls,
                    lw=1.1,
                    label=lab,
                )
        ax.set_ylabel(f"{label} [{unit}]")
        ax.grid(True, alpha=0.3)
    handles, labels = axes[-1, 0].get_legend_handles_labels()
    fig.legend(
        handles, labels, loc="lower center", ncol=min(len(labels), 3), fontsize=8, frameon=False
    )
    axes[-1, 0].set_xlabel("time from the start of the compared period [s]")
    amp, freq = result.meta.get("amplitude"), result.meta.get("frequency")
    what = f"{100 * amp:g} % valve opening, {freq:g} Hz" if amp and freq else result.run
    axes[0, 0].set_title(f"Measurement and simulation, sine with {what}", fontsize=10)
    fig.tight_layout(rect=(0.0, 0.07, 1.0, 1.0))
    return fig


def plot_cq(pwa, supply_pressure: float | None = None):
    """Fig. 1: Ĉ_q over P_L and its PWA cells, Eqs. (18), (20), at the given P_S [Pa]."""
    from ..linearization import cq_shape

    plt = _plt()
    ps = pwa.supply_pressure if supply_pressure is None else supply_pressure
    cells = pwa.cells_at(ps)["cq"]
    pl = np.linspace(-0.999 * ps, 0.999 * ps, 800)
    scale = pwa.params.flow.K * np.sqrt(0.5 * ps)
    fig, ax = plt.subplots(figsize=(6.5, 4.0))
    ax.plot(pl / 1e5, scale * cq_shape(pl / ps) * 6e4, "k", lw=1.6, label="Ĉ_q (18)")
    ax.plot(pl / 1e5, cells(pl) * 6e4, "r--", lw=1.2, label=f"PWA, {cells.n_cells} cells (20)")
    for b in cells.breakpoints:
        ax.axvline(b / 1e5, color="r", lw=0.5, alpha=0.4)
    ax.set_xlabel("load pressure P_L [bar]")
    ax.set_ylabel("Ĉ_q [L/min per unit opening]")
    ax.set_title(f"Fig. 1: Ĉ_q and its linearization (P_S = {ps / 1e5:.1f} bar)", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def plot_cqp(pwa, supply_pressure: float | None = None, openings=(0.25, 0.5, 0.75, 1.0)):
    """Fig. 2: Ĉ_qp over P_L for several openings z and the PWA cells, Eqs. (19), (21)."""
    from ..linearization import cqp_shape

    plt = _plt()
    ps = pwa.supply_pressure if supply_pressure is None else supply_pressure
    cells = pwa.cells_at(ps)["cqp"]
    hi = min(pwa.cqp.interval[1], 0.95) * ps
    pl = np.linspace(-0.999 * ps, hi, 800)
    scale = pwa.params.flow.K / (4.0 * np.sqrt(0.5 * ps))
    fig, ax = plt.subplots(figsize=(6.5, 4.0))
    for i, z in enumerate(openings):
        c = plt.cm.viridis(i / max(1, len(openings) - 1))
        ax.plot(
            pl / 1e5,
            z * scale * cqp_shape(pl / ps) * 6e9,
            color=c,
            lw=1.5,
            label=f"Ĉ_qp, z = {z:g}",
        )
        ax.plot(pl / 1e5, z * cells(pl) * 6e9, color=c, ls="--", lw=1.0)
    ax.plot([], [], "k--", lw=1.0, label=f"PWA, {cells.n_cells} cells (21)")
    ax.set_xlabel("load pressure P_L [bar]")
    ax.set_ylabel("Ĉ_qp [L/min per bar]")
    ax.set_title(f"Fig. 2: Ĉ_qp and its linearization (P_S = {ps / 1e5:.1f} bar)", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def plot_bode(frf: dict, fits: dict | None = None):
    """Fig. 5: measured valve FRFs per command amplitude and the fitted model (1).

    Parameters
    ----------
    frf : dict[float, FrequencyResponse]
        ``ValveFrfIdentifier.frf_`` (or points read back: objects with ``frequency``, ``response``).
    fits : dict[float, SecondOrderFit], optional
        ``ValveFrfIdentifier.fits_``; anything with ``response(omega)``.
    """
    plt = _plt()
    fig, (am, ph) = plt.subplots(2, 1, sharex=True, figsize=(6.5, 5.0))
    for i, (amp, r) in enumerate(sorted(frf.items())):
        c = plt.cm.tab10(i)
        f = np.asarray(r.frequency)
        h = np.asarray(r.response)
        am.semilogx(
            f,
            20 * np.log10(np.abs(h)),
            "o",
            ms=3,
            color=c,
            label=f"measured, |u| = {100 * amp:g} %",
        )
        ph.semilogx(f, np.degrees(np.unwrap(np.angle(h))), "o", ms=3, color=c)
        if fits and amp in fits:
            ff = np.geomspace(f.min(), f.max(), 300)
            hm = fits[amp].response(2 * np.pi * ff)
            am.semilogx(ff, 20 * np.log10(np.abs(hm)), "-", color=c, lw=1.0)
            ph.semilogx(ff, np.degrees(np.unwrap(np.angle(hm))), "-", color=c, lw=1.0)
    am.plot([], [], "k-", lw=1.0, label="fitted model (1)")
    am.set_ylabel("magnitude [dB]")
    ph.set_ylabel("phase [°]")
    ph.set_xlabel("frequency [Hz]")
    am.set_title("Fig. 5: measured valve FRFs versus linear model fit", fontsize=10)
    for a in (am, ph):
        a.grid(True, which="both", alpha=0.3)
    am.legend(fontsize=7)
    fig.tight_layout()
    return fig


def plot_dead_zone(u, v, fit_u=None, fit_v=None):
    """Fig. 6: steady velocity over constant commands [%, mm/s] and the fitted dead-zone."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.5, 4.0))
    ax.plot(np.asarray(u) * 100, np.asarray(v) * 1e3, "o", ms=3.5, label="measured (slope of x)")
    if fit_u is not None:
        ax.plot(
            np.asarray(fit_u) * 100,
            np.asarray(fit_v) * 1e3,
            "r-",
            lw=1.2,
            label="PWA dead-zone fit (16)",
        )
    ax.set_xlabel("valve command u [%]")
    ax.set_ylabel("rod velocity [mm/s]")
    ax.set_title("Fig. 6: experimental test of the dead-zone and linearization", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def plot_stribeck(v, f, friction=None, cells=None, true_friction=None):
    """Fig. 8: friction points, the fitted Stribeck curve (11) and its PWA cells (22).

    Parameters
    ----------
    v, f : array_like
        Measured steady velocities [m/s] and friction forces [N].
    friction : Friction, optional
        Identified Stribeck parameters.
    cells : PiecewiseAffine, optional
        PWA friction cells (v [m/s] → N).
    true_friction : Friction, optional
        True parameters (virtual rig), drawn thin.
    """
    from ..linearization import friction_function

    plt = _plt()
    v = np.asarray(v, dtype=float)
    vmax = 1.1 * max(float(np.max(np.abs(v))), 1e-3) if v.size else 0.2
    vv = np.linspace(-vmax, vmax, 1200)
    fig, ax = plt.subplots(figsize=(6.5, 4.0))
    ax.plot(v * 1e3, f, "o", ms=3.5, label="measured")
    if friction is not None:
        ax.plot(
            vv * 1e3,
            friction_function(friction)(vv),
            "k-",
            lw=1.3,
            label="fitted Stribeck model (11)",
        )
    if cells is not None:
        ax.plot(vv * 1e3, cells(vv), "r--", lw=1.1, label=f"PWA, {cells.n_cells} cells (22)")
    if true_friction is not None:
        ax.plot(
            vv * 1e3,
            friction_function(true_friction)(vv),
            color="gray",
            lw=0.8,
            label="true (virtual rig)",
        )
    ax.set_xlabel("rod velocity [mm/s]")
    ax.set_ylabel("friction force [N]")
    ax.set_title("Fig. 8: measured data points and fitted Stribeck model", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def plot_cell_occupancy(cell_metrics, pwa=None, trajectory=None):
    """Time share of each PWA cell over the evaluated runs, and the (u, P_L) partition.

    Parameters
    ----------
    cell_metrics : pandas.DataFrame
        ``EvaluationResult.cell_metrics`` of one or more runs (``set``, ``cell``, ``fraction``).
    pwa : PwaModel, optional
        Draws the dead-zone (u) and C_q (P_L) cell boundaries under the trajectory.
    trajectory : SimulationResult, optional
        A PWA simulation whose (u, P_L) path is drawn, coloured by the C_q cell.
    """
    plt = _plt()
    ncol = 2 if pwa is not None and trajectory is not None else 1
    fig, axes = plt.subplots(1, ncol, figsize=(5.2 * ncol, 4.0), squeeze=False)
    ax = axes[0, 0]
    names = {"g": "dead-zone", "o": "C_q", "n": "C_qp", "w": "friction"}
    if len(cell_metrics):
        occ = cell_metrics.groupby(["set", "cell"])["fraction"].mean()
        x0 = 0
        for s, label in names.items():
            if s not in occ.index.get_level_values(0):
                continue
            part = occ.loc[s]
            xs = x0 + np.arange(len(part))
            ax.bar(xs, 100 * part.to_numpy(), label=label)
            for xx, c in zip(xs, part.index, strict=True):
                ax.text(xx, 1, str(c), ha="center", fontsize=6)
            x0 = xs[-1] + 2
    ax.set_xticks([])
    ax.set_ylabel("time active [%]")
    ax.set_title("PWA cell occupancy (mean over runs; numbers: cell)", fontsize=9)
    ax.legend(fontsize=7)
    if ncol == 2:
        ax = axes[0, 1]
        ch = trajectory.channels
        ps = pwa.supply_pressure
        cells = pwa.cells_at(ps)
        for b in cells["dead_zone"].breakpoints:
            ax.axvline(100 * b, color="gray", lw=0.6)
        for b in cells["cq"].breakpoints:
            ax.axhline(b / 1e5, color="gray", lw=0.6)
        sc = ax.scatter(100 * ch["u"], ch["p_l"] / 1e5, c=ch["cell_o"], s=2, cmap="viridis")
        fig.colorbar(sc, ax=ax, label="C_q cell")
        ax.set_xlabel("valve command u [%]")
        ax.set_ylabel("load pressure P_L [bar]")
        ax.set_title("partition (u, P_L) and one trajectory", fontsize=9)
    fig.tight_layout()
    return fig
