"""Figures of time series: simulation results and runs, the evaluation figures (Figs. 9–13),
``compare``'s model-against-reference plot and closed-loop runs.

Inputs are duck-typed: a result is anything with ``channels`` (name → SI array, ``t``
included), like :class:`~hydropwa.SimulationResult` and :class:`~hydropwa.data.Run`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from numpy.typing import ArrayLike

from .._layout import MODEL_KINDS
from ._base import DISPLAY, MODEL_STYLE, moving_average, new_figure
from ._shapes import ClosedLoopRun, EvaluationShape, MetricTable, Recorded, require

__all__ = [
    "plot_result",
    "plot_evaluation",
    "plot_compare",
    "plot_closed_loop",
    "plot_supply_pressure",
    "plot_cell_design",
    "plot_metrics",
]

_AxesArg = Axes | Sequence[Axes] | None


def _display(ch: str) -> tuple[str, float, str]:
    return DISPLAY.get(ch, (ch, 1.0, ""))


def plot_result(
    result: Recorded,
    channels: Sequence[str] = ("u", "x", "p_a", "p_b", "p_s"),
    *,
    ax: _AxesArg = None,
) -> Any:
    """Channels of a result (or run) against time, one axes per display unit (%, mm, bar, N).

    Parameters
    ----------
    result : SimulationResult or Run
        ``channels`` holds ``t`` [s] and the channels in SI; ``model`` or ``name`` titles it.
    channels : sequence of str
        Channels to draw; those the result lacks are skipped.
    ax : sequence of Axes, optional
        One per display unit among the drawn channels.

    Returns
    -------
    matplotlib.figure.Figure
    """
    require(result, Recorded, "plot_result")
    groups: dict[str, list[str]] = {}
    for ch in channels:
        if ch in result.channels:
            groups.setdefault(_display(ch)[2], []).append(ch)
    fig, axes = new_figure(
        max(1, len(groups)), 1, ax=ax, sharex=True, figsize=(7.5, 1.9 * len(groups) + 0.8)
    )
    t = result.channels["t"]
    for a, (unit, names) in zip(axes[:, 0], groups.items(), strict=False):
        for ch in names:
            label, fac, _ = _display(ch)
            a.plot(t, result.channels[ch] * fac, label=label, lw=1.0)
        a.set_ylabel(unit or "1")
        a.grid(True, alpha=0.3)
        a.legend(loc="upper right", fontsize=8)
    axes[-1, 0].set_xlabel("time [s]")
    title = getattr(result, "model", None) or getattr(result, "name", "")
    if title:
        axes[0, 0].set_title(f"{title}")
    return fig


def plot_evaluation(
    result: EvaluationShape,
    models: Sequence[str] | None = None,
    channels: Sequence[str] = ("u", "x", "p_l"),
    smooth: float = 0.01,
    *,
    ax: _AxesArg = None,
) -> Any:
    """Measurement and model outputs over time, like Figs. 10–13 of the paper.

    Parameters
    ----------
    result : EvaluationResult
        ``measured`` (channel → SI array, ``t`` included), ``simulations`` (variant → result),
        ``meta`` (``amplitude`` [1], ``frequency`` [Hz]) and ``run`` (its name).
    models : sequence of str, optional
        Variants to draw (default: all simulated).
    channels : sequence of str
        One axes each (``u`` shows the command only).
    smooth : float
        Moving-average window [s] applied to the measurement for display only (Sec. VII).
    ax : sequence of Axes, optional
        One per channel.

    Returns
    -------
    matplotlib.figure.Figure
    """
    require(result, EvaluationShape, "plot_evaluation")
    meas = result.measured
    t = meas["t"] - meas["t"][0]
    dt = float(np.median(np.diff(meas["t"]))) if t.size > 1 else 1.0
    n = max(1, int(round(smooth / dt)))
    models = list(result.simulations) if models is None else list(models)
    fig, axes = new_figure(
        len(channels), 1, ax=ax, sharex=True, figsize=(7.5, 1.9 * len(channels) + 0.9)
    )
    for a, ch in zip(axes[:, 0], channels, strict=True):
        label, fac, unit = _display(ch)
        if ch in meas:
            y = meas[ch] if ch == "u" else moving_average(meas[ch], n)
            # drawn over the models (zorder) and dashed, so a model that fits does not hide it
            a.plot(
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
                a.plot(
                    res.t - meas["t"][0],
                    res.channels[ch] * fac,
                    color=color,
                    ls=ls,
                    lw=1.1,
                    label=lab,
                )
        a.set_ylabel(f"{label} [{unit}]")
        a.grid(True, alpha=0.3)
    handles, labels = axes[-1, 0].get_legend_handles_labels()
    if ax is None:
        fig.legend(
            handles,
            labels,
            loc="outside lower center",
            ncol=min(len(labels), 3) or 1,
            fontsize=8,
            frameon=False,
        )
    else:
        axes[-1, 0].legend(fontsize=8)
    axes[-1, 0].set_xlabel("time from the start of the compared period [s]")
    amp, freq = result.meta.get("amplitude"), result.meta.get("frequency")
    what = f"{100 * amp:g} % valve opening, {freq:g} Hz" if amp and freq else result.run
    axes[0, 0].set_title(f"Measurement and simulation, sine with {what}", fontsize=10)
    return fig


def plot_compare(
    t: Any,
    reference: Any,
    outputs: Mapping[str, Any],
    *,
    channel: str = "x",
    reference_label: str = "reference",
    ax: Axes | None = None,
) -> Any:
    """Model outputs under a reference signal (the drawing of :func:`hydropwa.evaluation.compare`).

    Parameters
    ----------
    t : array_like
        Time [s].
    reference : array_like
        The reference channel in SI, drawn last, dashed black, over the models.
    outputs : mapping of str to array_like
        Legend label (e.g. ``"pwa (93.1 %)"``) → model output in SI on ``t``.
    channel : str
        Channel name, for the axis label and display unit.
    reference_label : str
        Legend label of the reference.
    ax : Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, axes = new_figure(ax=ax, figsize=(8.0, 3.5))
    a = axes[0, 0]
    label, fac, unit = _display(channel)
    t = np.asarray(t, dtype=float)
    for lbl, y in outputs.items():
        a.plot(t, np.asarray(y, dtype=float) * fac, lw=1.2, label=lbl)
    a.plot(
        t,
        np.asarray(reference, dtype=float) * fac,
        color="black",
        lw=1.0,
        ls="--",
        label=reference_label,
        zorder=10,
    )
    a.set_xlabel("time [s]")
    a.set_ylabel(f"{label} [{unit or 'SI'}]")
    a.legend(loc="best", fontsize="small", title="fit (NRMSE)")
    a.grid(True, alpha=0.3)
    return fig


#: The closed-loop plot's colour of each model kind: the colour cycle in registry order.
_LOOP_COLORS = {name: f"C{row.kernel}" for name, row in MODEL_KINDS.items()}


def plot_closed_loop(
    results: ClosedLoopRun | Mapping[str, ClosedLoopRun],
    title: str | None = None,
    *,
    ax: _AxesArg = None,
) -> Any:
    """Reference and position, following error and valve command of closed-loop runs.

    Parameters
    ----------
    results : SimulationResult or dict of str to SimulationResult
        Closed-loop results (channels ``reference``, ``x``, ``error`` [m], ``control`` with
        ``t`` [s] and ``u`` [1]), e.g. one controller on the full, reduced and PWA models.
    title : str, optional
    ax : sequence of three Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    if not isinstance(results, Mapping):
        results = {results.model: results}
    for res in results.values():
        require(res, ClosedLoopRun, "plot_closed_loop")
    fig, axes = new_figure(3, 1, ax=ax, sharex=True, figsize=(8.0, 7.0))
    a = axes[:, 0]
    for i, (name, res) in enumerate(results.items()):
        c = _LOOP_COLORS.get(name)
        if i == 0:
            a[0].plot(res.t, res["reference"] * 1e3, "k--", lw=1.0, label="reference")
        a[0].plot(res.t, res["x"] * 1e3, color=c, lw=1.0, label=name)
        a[1].plot(res.t, res["error"] * 1e3, color=c, lw=1.0, label=name)
        a[2].step(
            res.control["t"], res.control["u"] * 100.0, where="post", color=c, lw=0.8, label=name
        )
    a[0].set_ylabel("rod position [mm]")
    a[1].set_ylabel("following error [mm]")
    a[2].set_ylabel("valve command [%]")
    a[2].set_xlabel("time [s]")
    for ax_ in a:
        ax_.grid(True, alpha=0.3)
        ax_.legend(loc="upper right", fontsize=8)
    if title:
        a[0].set_title(title)
    return fig


def plot_supply_pressure(
    t: Any, supply_pressure: Any, *, name: str = "", ax: Axes | None = None
) -> Any:
    """Fig. 9: the supply pressure recorded during an evaluation run.

    Parameters
    ----------
    t : array_like
        Time [s] (drawn from its first sample).
    supply_pressure : array_like
        P_S [Pa].
    name : str
        Run name, for the title.
    ax : Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    t = np.asarray(t, dtype=float)
    fig, axes = new_figure(ax=ax, figsize=(6.0, 3.0))
    a = axes[0, 0]
    a.plot(t - t[0], np.asarray(supply_pressure, dtype=float) / 1e5, "k", lw=0.8)
    a.set_xlabel("time [s]")
    a.set_ylabel("P_S [bar]")
    a.set_title(f"Fig. 9: supply pressure during {name}".rstrip(), fontsize=10)
    a.grid(True, alpha=0.3)
    return fig


def plot_cell_design(damping: ArrayLike, bandwidth_hz: ArrayLike, *, ax: _AxesArg = None) -> Any:
    """Smallest closed-loop damping and bandwidth r → x of each cell of a controller design.

    Parameters
    ----------
    damping : array_like
        Smallest damping ratio of the closed-loop poles per cell [1].
    bandwidth_hz : array_like
        Closed-loop bandwidth per cell [Hz].
    ax : sequence of two Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    zeta, bw = np.asarray(damping, dtype=float), np.asarray(bandwidth_hz, dtype=float)
    fig, axes = new_figure(2, 1, ax=ax, sharex=True, figsize=(6.5, 4.5))
    cells = np.arange(zeta.size)
    axes[0, 0].bar(cells, zeta, color="C0")
    axes[0, 0].set_ylabel("smallest damping [1]")
    axes[1, 0].bar(cells, bw, color="C1")
    axes[1, 0].set_ylabel("bandwidth [Hz]")
    axes[1, 0].set_xlabel("cell (row of the design table)")
    for a in axes[:, 0]:
        a.grid(True, axis="y", alpha=0.3)
    axes[0, 0].set_title("Closed loop per cell", fontsize=10)
    return fig


def plot_metrics(
    table: MetricTable,
    *,
    limits: Mapping[str, float] | None = None,
    title: str | None = None,
    ax: Axes | None = None,
) -> Any:
    """Headline metrics of a result as horizontal bars, each in its display unit.

    Parameters
    ----------
    table : MetricTable
        ``display()`` (name → value) and ``display_units()`` (name → unit), e.g.
        :class:`~hydropwa.control.TrackingMetrics` or :class:`~hydropwa.control.Verification`.
    limits : mapping of str to float, optional
        A limit per metric in the same unit: marked on its bar, and a bar above it is red.
    title : str, optional
    ax : Axes, optional

    Returns
    -------
    matplotlib.figure.Figure

    Notes
    -----
    The units differ between metrics, so each bar is labelled with its value and unit; a
    metric that could not be computed (NaN) shows as "n/a".
    """
    require(table, MetricTable, "plot_metrics")
    values, units = dict(table.display()), dict(table.display_units())
    limits = dict(limits or {})
    fig, axes = new_figure(1, 1, ax=ax, figsize=(7.0, 0.4 * len(values) + 1.2))
    a = axes[0, 0]
    names = list(values)
    y = np.arange(len(names))
    shown = np.array([values[n] if np.isfinite(values[n]) else 0.0 for n in names])
    over = [n in limits and values[n] > limits[n] for n in names]
    a.barh(y, shown, color=["C3" if o else "C0" for o in over])
    for i, n in enumerate(names):
        text = f"{values[n]:.4g} {units.get(n, '')}" if np.isfinite(values[n]) else "n/a"
        a.annotate(text, (shown[i], y[i]), xytext=(3, 0), textcoords="offset points",
                   va="center", fontsize=8)  # fmt: skip
        if n in limits:
            a.plot([limits[n]] * 2, [y[i] - 0.4, y[i] + 0.4], "k-", lw=1.5)
    a.set_yticks(y, [f"{n} [{units.get(n, '')}]" for n in names])
    a.invert_yaxis()
    a.set_xlabel("value [display unit of each row]")
    a.grid(True, axis="x", alpha=0.3)
    if title:
        a.set_title(title)
    return fig
