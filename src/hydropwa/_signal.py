"""Signal helpers shared by the data checks and the estimators: a robust noise level, runs of
a boolean mask, and stretches stuck at a converter's rail.

Written once here (they were copied in ``data/_validate.py``, the friction estimator and the
grey-box data preparation); numpy only, so every layer may use them.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["mask_runs", "robust_noise", "stuck_at_rails"]

#: 1/Φ⁻¹(3/4): the MAD of a normal sample times this is its standard deviation
MAD_TO_SIGMA = 1.4826


def robust_noise(y: np.ndarray, order: int = 1) -> float:
    """Standard deviation [unit of ``y``] of white noise on ``y``, from its ``order``-th
    differences.

    σ = 1.4826·MAD(Δᵏy)/√C(2k, k): the k-th difference removes a polynomial trend of degree
    k − 1, white noise of variance σ² gives Δᵏy the variance C(2k, k)·σ² (2, 6, 20, 70 for
    k = 1…4), and the median absolute deviation ignores sharp events. 0 for fewer than
    ``order + 1`` samples.
    """
    d = np.diff(np.asarray(y, dtype=float), order)
    if d.size == 0:
        return 0.0
    mad = float(np.median(np.abs(d - np.median(d))))
    return MAD_TO_SIGMA * mad / math.sqrt(math.comb(2 * order, order))


def mask_runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start indices and lengths of the runs of ``True`` in a boolean array."""
    edges = np.diff(np.concatenate(([0], np.asarray(mask).astype(np.int8), [0])))
    starts = np.flatnonzero(edges == 1)
    return starts, np.flatnonzero(edges == -1) - starts


def stuck_at_rails(
    v: np.ndarray, min_samples: int
) -> list[tuple[str, float, np.ndarray, np.ndarray]]:
    """Stretches of ``min_samples`` or more samples stuck at the record's maximum or minimum.

    A saturated sensor or converter is flat only at its rail; a quantised, slowly moving
    signal is flat everywhere, so a rail counts only where the signal otherwise changes from
    sample to sample (fewer than half of the other steps are zero). Non-finite samples are
    ignored for the extremes.

    Returns
    -------
    list of (side, level, starts, lengths)
        ``side`` is ``"maximum"`` or ``"minimum"``, ``level`` the rail value, ``starts`` and
        ``lengths`` the stretches at it; one entry per rail that has any.
    """
    v = np.asarray(v, dtype=float)
    fin = v[np.isfinite(v)]
    if fin.size < 2 * min_samples or fin.min() == fin.max():
        return []
    out = []
    for side, level in (("maximum", fin.max()), ("minimum", fin.min())):
        starts, lengths = mask_runs(v == level)
        long = lengths >= min_samples
        if not long.any():
            continue
        plateau = np.zeros(v.shape, dtype=bool)
        for s, n in zip(starts[long], lengths[long], strict=True):
            plateau[s : s + n] = True
        rest = np.diff(v[~plateau])
        if rest.size and np.mean(rest == 0) > 0.5:
            continue
        out.append((side, float(level), starts[long], lengths[long]))
    return out
