"""``compare(run, *models)``: models against a measurement in one figure, fit % in the legend.

The one-liner of system identification toolboxes (MATLAB's ``compare(data, sys1, sys2)``):
each model is simulated with the run's measured inputs (command ``u``, supply pressure ``p_s``
and load ``f_l`` where the run has them) from the run's initial position, and its output is
drawn under the measurement with the NRMSE fit of :func:`~hydropwa.evaluation.nrmse_fit`
(the figure is :func:`hydropwa.plotting.plot_compare`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._errors import DataError
from ..simulation import Sampled, simulate
from ._metrics import nrmse_fit

__all__ = ["compare"]


def _channels(obj):
    """(name, t, channels) of a Run or a SimulationResult."""
    if hasattr(obj, "channels") and hasattr(obj, "t"):
        name = getattr(obj, "name", None) or f"{getattr(obj, 'model', 'data')} model"
        return name, np.asarray(obj.t, dtype=float), obj.channels
    raise DataError(
        f"compare: expected a Run or SimulationResult as the reference, got {type(obj).__name__}"
    )


def _simulate_on(model, t, channels, rtol):
    t0 = t - t[0]
    if "u" not in channels:
        raise DataError("compare: the reference has no valve command 'u' to drive the models with")
    kwargs: dict[str, Any] = {}
    if "p_s" in channels:
        kwargs["supply_pressure"] = Sampled(t0, np.asarray(channels["p_s"], dtype=float))
    if "f_l" in channels:
        kwargs["load_force"] = Sampled(t0, np.asarray(channels["f_l"], dtype=float))
    if "x" in channels:
        kwargs["initial_position"] = float(channels["x"][0])
    return simulate(
        model, Sampled(t0, np.asarray(channels["u"], dtype=float)), timepts=t0, rtol=rtol, **kwargs
    )


def compare(run, *models, channel: str = "x", rtol: float = 1e-4, ax=None):
    """Simulate ``models`` with the inputs of ``run`` and plot them against it, fit % in the legend.

    Parameters
    ----------
    run : hydropwa.data.Run or SimulationResult
        The reference (a measurement, or a simulation of another model). It must hold the
        valve command ``u`` [1] and ``channel``; ``p_s`` [Pa] and ``f_l`` [N] are used as the
        models' supply pressure and load when present, ``x`` [m] sets the initial position.
    *models : FullOrderModel, ReducedModel, PwaModel or SimulationResult
        Models to simulate on the run's inputs, or results already simulated on the same
        time grid.
    channel : str
        Channel compared (default ``"x"``, the rod position; ``"p_l"``, ``"v"``, ...).
    rtol : float
        Relative tolerance of the simulations [1].
    ax : matplotlib.axes.Axes, optional
        Axes to draw into (default: a new figure).

    Returns
    -------
    matplotlib.figure.Figure
        The reference is drawn last, in black, over the models; ``fig.fits`` maps each
        legend label to its NRMSE fit [%] (100 = perfect, 0 = no better than the mean).

    Raises
    ------
    DataError
        The reference lacks ``u`` or ``channel``, or a result's time grid differs.
    """
    from ..plotting import plot_compare  # deferred: matplotlib loads only when plotting

    name, t, ref = _channels(run)
    if channel not in ref:
        raise DataError(f"compare: the reference has no channel {channel!r} (has {', '.join(ref)})")
    y = np.asarray(ref[channel], dtype=float)
    fits: dict[str, float] = {}
    outputs: dict[str, np.ndarray] = {}
    for i, m in enumerate(models):
        if hasattr(m, "channels") and hasattr(m, "t"):
            res = m
            if res.t.size != t.size:
                raise DataError(
                    f"compare: result {i + 1} has {res.t.size} samples, the reference {t.size}; "
                    "simulate it on the reference's time grid (timepts=...)"
                )
        else:
            res = _simulate_on(m, t, ref, rtol)
        y_hat = np.asarray(res.channels[channel], dtype=float)
        fit = nrmse_fit(y, y_hat)
        lbl = f"{getattr(res, 'model', 'model')} ({fit:.1f} %)"
        fits[lbl] = fit
        outputs[lbl] = y_hat
    fig = plot_compare(t, y, outputs, channel=channel, reference_label=f"{name} (reference)", ax=ax)
    fig.fits = fits  # the NRMSE fits, read by callers
    return fig
