"""Shared pieces of the plotting layer: new figures without pyplot, the one ``save_figure``,
display units of the channels and the line style of each model variant."""

from __future__ import annotations

import io
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from .._display import channel_unit
from .._io import atomic_path
from .._layout import MODEL_KINDS, OUTPUT_CHANNELS

__all__ = [
    "DISPLAY",
    "MODEL_STYLE",
    "InlineFigure",
    "moving_average",
    "new_figure",
    "save_figure",
]

_LABELS = {
    "u": "valve command",
    "spool": "spool position",
    "z": "orifice opening",
    "x": "rod position",
    "v": "rod velocity",
    "p_a": "P_A",
    "p_b": "P_B",
    "p_l": "P_L",
    "p_s": "P_S",
    "f_l": "load force",
    "friction": "friction force",
}
#: channel → (label, factor from SI, display unit): the channel's SI unit from the layout,
#: shown in the package's engineering unit (:data:`hydropwa._display.ENGINEERING_UNITS`)
DISPLAY: dict[str, tuple[str, float, str]] = {
    name: (_LABELS[name], channel_unit(unit)[1], channel_unit(unit)[0])
    for name, unit in OUTPUT_CHANNELS
    if name in _LABELS
}

#: Line style per model variant (colour, line style, label): each model kind's from its registry
#: row (:attr:`hydropwa._layout.ModelKind.style`), then the evaluation's other variants.
MODEL_STYLE: dict[str, tuple[str, str, str]] = {
    **{name: row.style for name, row in MODEL_KINDS.items()},
    "reduced-scheduled": ("tab:olive", "--", "reduced (P_S(t))"),
    "pwa-scheduled": ("tab:purple", ":", "PWA scheduled (P_S(t))"),
    "reduced-paper": ("tab:gray", "--", "reduced, paper form (mean area)"),
    "pwa-paper": ("tab:brown", "-.", "PWA, paper form (mean area)"),
}


class InlineFigure(Figure):
    """A :class:`~matplotlib.figure.Figure` that Jupyter shows inline as PNG.

    Figures here are made without pyplot, so no backend registers them with IPython; the
    ``_repr_png_`` below is IPython's display protocol, and a figure returned as the last
    expression of a cell is drawn whatever the backend (``Agg`` included). Where the inline
    backend is active its own printer takes precedence, so a figure is never shown twice.
    """

    #: NRMSE fit [%] per legend label, set by :func:`hydropwa.evaluation.compare`.
    fits: dict[str, float]

    def _repr_png_(self) -> bytes:
        buf = io.BytesIO()
        self.savefig(buf, format="png", dpi=100)
        return buf.getvalue()


def new_figure(
    nrows: int = 1,
    ncols: int = 1,
    *,
    ax: Axes | Sequence[Axes] | None = None,
    figsize: tuple[float, float] = (7.0, 5.0),
    **subplots: Any,
) -> tuple[Any, np.ndarray]:
    """A figure and its axes as an ``(nrows, ncols)`` array, or the axes the caller gave.

    Built with :class:`matplotlib.figure.Figure`, not pyplot: no global state, no backend
    needed, and Jupyter still shows a returned figure inline (its ``_repr_png_``).

    Parameters
    ----------
    nrows, ncols : int
        Grid of a new figure.
    ax : Axes or sequence of Axes, optional
        Draw into these instead (``nrows * ncols`` of them); the figure is theirs.
    figsize : (float, float)
        Size of a new figure [in].
    **subplots
        Passed to :meth:`Figure.subplots` (``sharex``, ``height_ratios``, ...).

    Returns
    -------
    (Figure, numpy.ndarray of Axes)

    Raises
    ------
    ValueError
        ``ax`` holds a number of axes other than ``nrows * ncols``.
    """
    if ax is not None:
        axes = np.atleast_1d(np.asarray(ax, dtype=object)).ravel()
        if axes.size != nrows * ncols:
            raise ValueError(
                f"this figure draws into {nrows * ncols} axes, {axes.size} were given in ax"
            )
        return axes[0].figure, axes.reshape(nrows, ncols)
    fig = InlineFigure(figsize=figsize, layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False, **subplots)
    return fig, axes


def save_figure(
    fig: Figure, path: str | os.PathLike[str], *, dpi: int = 120, overwrite: bool = False
) -> Path:
    """Write a figure atomically; the format comes from the suffix (default PNG).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    path : path-like
        The target file (``.png``, ``.svg``, ``.pdf``, ...).
    dpi : int
        Resolution of raster formats [dots per inch].
    overwrite : bool
        Replace an existing file; by default an existing file raises
        :class:`~hydropwa.OutputExistsError` and nothing is written.

    Returns
    -------
    pathlib.Path
        The written file.
    """
    path = Path(path)
    with atomic_path(path, overwrite=overwrite) as tmp:
        fig.savefig(tmp, dpi=dpi, format=path.suffix.lstrip(".") or "png")
    return path


def moving_average(y: Any, n: int) -> np.ndarray:
    """Centred moving average over ``n`` samples (edges use the samples available); display only."""
    a: np.ndarray = np.asarray(y, dtype=float)
    if n <= 1 or a.size < n:
        return a.copy()
    kernel = np.ones(n)
    num = np.convolve(a, kernel, mode="same")
    den = np.convolve(np.ones_like(a), kernel, mode="same")
    return num / den
