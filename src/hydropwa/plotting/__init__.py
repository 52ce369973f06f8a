"""The one plotting layer: every figure of the package, in engineering units (%, mm, bar, N).

Functions take plain arrays or result objects (the attributes they read from a result of a
layer above are declared as protocols in ``_shapes``; this package imports only numpy,
matplotlib and the package's leaf modules, never a layer above it) and an optional ``ax``
to draw into, and return a :class:`matplotlib.figure.Figure` made without pyplot: no
global state, no backend chosen here, shown inline by Jupyter when returned from a cell.
:func:`save_figure` writes any of them atomically (nothing overwritten without
``overwrite=True``). See ``docs/architecture.md``.
"""

from ._base import DISPLAY, MODEL_STYLE, InlineFigure, moving_average, new_figure, save_figure
from ._engineering import (
    plot_cell_margins,
    plot_error_bound_map,
    plot_pole_map,
    plot_small_signal_bode,
)
from ._identification import (
    plot_bode,
    plot_dead_zone,
    plot_estimates,
    plot_greybox_fit,
    plot_greybox_profiles,
    plot_greybox_residuals,
    plot_inverse_dynamics,
    plot_stribeck,
)
from ._pwa import plot_cell_occupancy, plot_cq, plot_cqp
from ._results import (
    plot_cell_design,
    plot_closed_loop,
    plot_compare,
    plot_evaluation,
    plot_metrics,
    plot_result,
    plot_supply_pressure,
)

__all__ = [
    "DISPLAY",
    "MODEL_STYLE",
    "InlineFigure",
    "moving_average",
    "new_figure",
    "plot_bode",
    "plot_cell_margins",
    "plot_error_bound_map",
    "plot_pole_map",
    "plot_small_signal_bode",
    "plot_cell_occupancy",
    "plot_cell_design",
    "plot_closed_loop",
    "plot_compare",
    "plot_cq",
    "plot_cqp",
    "plot_dead_zone",
    "plot_estimates",
    "plot_evaluation",
    "plot_greybox_fit",
    "plot_greybox_profiles",
    "plot_greybox_residuals",
    "plot_inverse_dynamics",
    "plot_metrics",
    "plot_result",
    "plot_stribeck",
    "plot_supply_pressure",
    "save_figure",
]
