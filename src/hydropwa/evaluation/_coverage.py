"""Coverage of the partition: which load pressures and cells the evaluation runs visit, and the
fit of every model there (issue 38, item 3).

The pressure cells of the PWA models are cells over the load pressure P_L = P_A − α P_B per flow
direction (``pwa``: C_q and C_qp over sign(z)·P_L; ``pwa-chamber``: each metering edge over its
own drop). Sine runs alone keep P_L near its no-load value (within ±3 bar on the paper rig), so
they score one pressure cell; the campaign's load runs (``[sine.load]``) walk P_L through its
range. This module measures that and scores each model per band of the range and per cell:

- :func:`load_pressure_coverage`: per flow direction, the share of the direction's range of
  P_L (:func:`hydropwa.components.load_pressure_range`) that the runs visit, and the time share;
- :func:`pressure_band_scores`: per model, direction and band of that range, the time share and
  the RMSE of x, P_A, P_B and P_L while the measurement is in the band;
- :func:`cell_coverage`: per PWA model, cell family and cell, the runs and time share in which
  the cell is active and the pooled RMSE there (from ``EvaluationResult.cell_metrics``).

:func:`coverage_study` bundles the three for a list of :class:`EvaluationResult`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from .._channels import CHANNEL, SCORED_CHANNELS
from ..components import load_pressure_range

__all__ = [
    "CoverageResult",
    "cell_coverage",
    "coverage_study",
    "load_pressure_coverage",
    "pressure_band_scores",
]

_DIRECTIONS = {1: "extend", -1: "retract"}
#: Error channels of the band scores: the channel and its unit (the evaluation's scored channels
#: but the velocity, an estimate from x).
_BAND_CHANNELS = tuple((c, CHANNEL[c].unit) for c in SCORED_CHANNELS if c != "v")


def _channels(run) -> Mapping[str, np.ndarray]:
    """The channel dict of a Run, an EvaluationResult (its measured channels) or a dict."""
    if hasattr(run, "measured"):
        return run.measured
    if hasattr(run, "channels"):
        return run.channels
    return run


def _range_position(ch: Mapping[str, np.ndarray], params) -> tuple[np.ndarray, np.ndarray]:
    """(flow direction per sample, position of P_L in that direction's range [1]).

    The direction is the sign of the valve command where it lies outside the dead band
    (|u| > β), 0 inside it; the range uses the measured P_S(t) where recorded.
    """
    cyl, sup = params.cylinder, params.supply
    alpha = cyl.area_b / cyl.area_a
    u = np.asarray(ch["u"], dtype=float)
    n = u.size
    p_s = np.asarray(ch["p_s"], dtype=float)[:n] if "p_s" in ch else np.full(n, sup.pressure)
    p_l = np.asarray(ch["p_a"], dtype=float)[:n] - alpha * np.asarray(ch["p_b"], dtype=float)[:n]
    direction = np.where(np.abs(u) > params.dead_zone.beta, np.sign(u), 0.0).astype(int)
    lam = np.full(n, np.nan)
    for d in (1, -1):
        sel = direction == d
        if np.any(sel):
            # the range is linear in (P_S, P_T): evaluated per sample on the measured P_S(t)
            lo1, hi1 = load_pressure_range(d, 1.0, alpha, 0.0)
            lo0, hi0 = load_pressure_range(d, 0.0, alpha, sup.tank_pressure)
            lo, hi = lo0 + lo1 * p_s[sel], hi0 + hi1 * p_s[sel]
            lam[sel] = (p_l[sel] - lo) / (hi - lo)
    return direction, lam


def load_pressure_coverage(runs: Iterable[Any], params, *, bins: int = 20, min_samples: int = 4):
    """Share of each flow direction's load-pressure range that the runs visit.

    Parameters
    ----------
    runs : iterable of Run, EvaluationResult or dict
        Channels ``u``, ``p_a``, ``p_b`` [1, Pa, Pa] and, where recorded, ``p_s`` [Pa].
    params : SystemParams
        The machine (areas, supply and tank pressure, dead band β).
    bins : int
        The range is cut into this many equal bins [1].
    min_samples : int
        A bin counts as visited once this many samples (over all runs) fall in it [1].

    Returns
    -------
    pandas.DataFrame
        One row per direction (``extend``, ``retract``): ``samples``, ``time_share`` [1] (of
        all samples), ``covered`` [1] (share of the bins visited), ``low``, ``high`` [1]
        (lowest and highest position in the range reached, 0 and 1 its ends; outside [0, 1]
        beyond them), ``range_low``, ``range_high`` [Pa] (the range at the nominal P_S).

    Notes
    -----
    The range is :func:`hydropwa.components.load_pressure_range`: P_L = P_A − α P_B at which the
    valve meters steadily in the direction with both chambers between tank and supply pressure,
    per sample at the measured P_S(t). The direction is the sign of the command outside the
    dead band (|u| > β).
    """
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    counts = {d: np.zeros(bins, dtype=int) for d in _DIRECTIONS}
    samples = dict.fromkeys(_DIRECTIONS, 0)
    extent = {d: [np.inf, -np.inf] for d in _DIRECTIONS}
    total = 0
    for run in runs:
        direction, lam = _range_position(_channels(run), params)
        total += direction.size
        for d in _DIRECTIONS:
            v = lam[direction == d]
            samples[d] += v.size
            if v.size:
                extent[d] = [min(extent[d][0], float(v.min())), max(extent[d][1], float(v.max()))]
                inside = v[(v >= 0.0) & (v <= 1.0)]
                counts[d] += np.bincount(
                    np.minimum((inside * bins).astype(int), bins - 1), minlength=bins
                )
    sup, alpha = params.supply, params.cylinder.area_b / params.cylinder.area_a
    rows = []
    for d, name in _DIRECTIONS.items():
        lo, hi = load_pressure_range(d, sup.pressure, alpha, sup.tank_pressure)
        n = samples[d]
        rows.append(
            {
                "direction": name,
                "samples": n,
                "time_share": n / total if total else 0.0,
                "covered": float(np.mean(counts[d] >= min_samples)),
                "low": extent[d][0] if np.isfinite(extent[d][0]) else np.nan,
                "high": extent[d][1] if np.isfinite(extent[d][1]) else np.nan,
                "range_low": lo,
                "range_high": hi,
            }
        )
    return pd.DataFrame(rows)


def pressure_band_scores(results: Iterable[Any], params, *, bands: int = 5):
    """Every model's error per flow direction and band of the load-pressure range.

    Parameters
    ----------
    results : iterable of EvaluationResult
        Evaluated runs (:func:`~hydropwa.evaluation.evaluate_run`).
    params : SystemParams
        The machine.
    bands : int
        Equal bands of each direction's range [1]; samples beyond the range join the end bands.

    Returns
    -------
    pandas.DataFrame
        Per ``model``, ``direction``, ``band`` (0 = the range's low end): ``samples``,
        ``time_share`` [1] (of all compared samples), and ``rmse_x`` [m], ``rmse_p_a``,
        ``rmse_p_b``, ``rmse_p_l`` [Pa] over the samples in the band (pooled over runs; a
        model's samples after a failed integration are left out).
    """
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    sums: dict[tuple[str, str, int], np.ndarray] = {}
    total = 0
    for res in results:
        meas = res.measured
        direction, lam = _range_position(meas, params)
        band = np.clip(np.floor(np.nan_to_num(lam) * bands), 0, bands - 1).astype(int)
        total += direction.size
        for model, sim in res.simulations.items():
            k = min(sim.t.size, direction.size)
            err = [sim.channels[c][:k] - meas[c][:k] for c, _u in _BAND_CHANNELS]
            for d, name in _DIRECTIONS.items():
                for b in range(bands):
                    sel = (direction[:k] == d) & (band[:k] == b)
                    if not np.any(sel):
                        continue
                    acc = sums.setdefault((model, name, b), np.zeros(1 + len(err)))
                    acc[0] += np.count_nonzero(sel)
                    acc[1:] += [float(np.sum(e[sel] ** 2)) for e in err]
    rows = [
        {
            "model": model,
            "direction": name,
            "band": b,
            "samples": int(acc[0]),
            "time_share": acc[0] / total if total else 0.0,
            **{
                f"rmse_{c}": float(np.sqrt(s / acc[0]))
                for (c, _u), s in zip(_BAND_CHANNELS, acc[1:], strict=True)
            },
        }
        for (model, name, b), acc in sorted(sums.items())
    ]
    cols = ["model", "direction", "band", "samples", "time_share"]
    return pd.DataFrame(rows, columns=cols + [f"rmse_{c}" for c, _u in _BAND_CHANNELS])


def cell_coverage(cell_metrics):
    """Cells visited per PWA model and cell family, with time share and pooled fit.

    Parameters
    ----------
    cell_metrics : pandas.DataFrame
        Rows of ``EvaluationResult.cell_metrics`` over runs (with ``samples``).

    Returns
    -------
    pandas.DataFrame
        Per ``model``, ``set`` (cell family), ``cell``: ``runs`` (runs in which it is active),
        ``time_share`` [1] (of the model's compared samples) and the pooled ``rmse_x`` [m],
        ``rmse_p_a``, ``rmse_p_b``, ``rmse_p_l`` [Pa] while it is active; ``cells_visited``:
        the number of cells of the family that are active at all.
    """
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    cols = ["rmse_x", "rmse_p_a", "rmse_p_b", "rmse_p_l"]
    out_cols = ["model", "set", "cell", "runs", "time_share", *cols, "cells_visited"]
    if cell_metrics is None or len(cell_metrics) == 0:
        return pd.DataFrame(columns=out_cols)
    df = cell_metrics.copy()
    n = df["samples"].astype(float)
    for c in cols:
        df[c] = df[c] ** 2 * n  # pooled: Σ n·rmse² / Σ n
    g = df.assign(n=n).groupby(["model", "set", "cell"], as_index=False)
    agg = g.agg(runs=("run", "nunique"), n=("n", "sum"), **{c: (c, "sum") for c in cols})
    per_model = df.assign(n=n).groupby(["model", "set"])["n"].sum()
    agg["time_share"] = agg["n"] / [
        per_model[(m, s)] for m, s in zip(agg["model"], agg["set"], strict=True)
    ]
    for c in cols:
        agg[c] = np.sqrt(agg[c] / agg["n"])
    agg["cells_visited"] = agg.groupby(["model", "set"])["cell"].transform("nunique")
    return agg[out_cols]


@dataclasses.dataclass
class CoverageResult:
    """What :func:`coverage_study` measured.

    Attributes
    ----------
    load_pressure : pandas.DataFrame
        :func:`load_pressure_coverage` of the measured runs.
    bands : pandas.DataFrame
        :func:`pressure_band_scores`: every model per direction and band of the P_L range.
    cells : pandas.DataFrame
        :func:`cell_coverage`: per PWA model, family and cell.
    """

    load_pressure: Any
    bands: Any
    cells: Any

    def covered(self, direction: str) -> float:
        """Share [1] of the direction's (``extend``/``retract``) P_L range visited."""
        row = self.load_pressure[self.load_pressure["direction"] == direction]
        return float(row["covered"].iloc[0])


def coverage_study(
    results: Iterable[Any], params, *, bins: int = 20, bands: int = 5
) -> CoverageResult:
    """Load-pressure coverage, per-band scores of every model and per-cell coverage.

    Parameters
    ----------
    results : iterable of EvaluationResult
        Evaluated runs.
    params : SystemParams
        The machine.
    bins : int
        Load-pressure bins, as in :func:`load_pressure_coverage`.
    bands : int
        Pressure bands, as in :func:`pressure_band_scores`.

    Returns
    -------
    CoverageResult
    """
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    results = list(results)
    frames = [r.cell_metrics for r in results if len(r.cell_metrics)]
    return CoverageResult(
        load_pressure=load_pressure_coverage(results, params, bins=bins),
        bands=pressure_band_scores(results, params, bands=bands),
        cells=cell_coverage(pd.concat(frames, ignore_index=True) if frames else None),
    )
