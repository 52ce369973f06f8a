"""Closed-loop fidelity: one controller on every model level, hold oscillations side by side.

A design model is only as good as its prediction of the closed loop. The load-pressure
models (reduced, ``pwa``) make the chamber pressures quasi-steady and drop the valve; a
controller they approve can hold the full model in a limit cycle. This study runs one
controller on the full, reduced, PWA and chamber-level PWA (``pwa-chamber``) models and
tabulates, per model, the peak-to-peak oscillation of every hold of the reference, the
tracking error and the saturation share (docs/models.md, "Which model for what").
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ._controllers import ControlError
from ._metrics import compare_models, tracking_metrics

__all__ = ["FIDELITY_MODELS", "hold_oscillations", "closed_loop_fidelity"]

#: The models of the fidelity study, in the order of its table.
FIDELITY_MODELS = ("full", "reduced", "pwa", "pwa-chamber")
#: Share of each hold skipped before its oscillation is measured (the settling after a move).
HOLD_SETTLE = 0.5


def hold_oscillations(result, settle: float = HOLD_SETTLE) -> list[dict[str, float]]:
    """Peak-to-peak rod oscillation of each hold of a closed-loop run's reference.

    Parameters
    ----------
    result : SimulationResult
        A closed-loop result (channels ``t``, ``x``, ``reference`` [m]).
    settle : float
        Share of each hold skipped at its start (0 ≤ settle < 1) so that the move's settling
        is not counted.

    Returns
    -------
    list of dict
        One per hold (a stretch of at least 20 samples over which the reference is constant):
        ``start``, ``end`` [s], ``reference`` [mm] and ``p2p`` [mm], the peak-to-peak of x
        over the hold's last (1 − settle) share.
    """
    if not 0.0 <= settle < 1.0:
        raise ControlError(f"settle = {settle!r} must lie in [0, 1)")
    try:
        t, x, r = result.t, result["x"], result["reference"]
    except KeyError:
        raise ControlError(
            "hold oscillations need a closed-loop result (simulate(..., controller=...))"
        ) from None
    moving = np.abs(np.diff(r)) > 1e-12 * max(1.0, float(np.max(np.abs(r))))
    cuts = np.concatenate(([0], np.flatnonzero(moving) + 1, [r.size]))
    out = []
    for a, b in zip(cuts[:-1], cuts[1:], strict=True):
        if b - a < 20:
            continue
        k = a + int(settle * (b - a))
        seg = x[k:b]
        out.append(
            {
                "start": float(t[a]),
                "end": float(t[b - 1]),
                "reference": float(r[a]) * 1e3,
                "p2p": float(np.max(seg) - np.min(seg)) * 1e3,
            }
        )
    return out


def closed_loop_fidelity(
    controller, reference, *, models=FIDELITY_MODELS, **case: Any
) -> tuple[dict[str, Any], Any]:
    """Run one controller on several model levels; hold oscillations and tracking side by side.

    Parameters
    ----------
    controller, reference
        As :func:`~hydropwa.control.compare_models`.
    models : tuple of str
        Model names (default :data:`FIDELITY_MODELS`).
    **case
        The run, as :func:`~hydropwa.control.compare_models` takes it: ``duration``
        (required), ``params``, ``pwa``, ``initial_position``, ``load_force``, ``rtol``.

    Returns
    -------
    results : dict of SimulationResult
    table : pandas.DataFrame
        One row per model: ``hold_<i>`` [mm] the peak-to-peak of hold i
        (:func:`hold_oscillations`), ``max_hold`` [mm], ``ratio_to_full`` (largest over the
        holds of p2p / the full model's p2p, where the full model's is ≥ 1 µm), ``iae``
        [mm·s], ``max_following_error`` [mm], ``saturation`` [%].
    """
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    results, _ = compare_models(controller, reference, models=tuple(models), **case)
    holds = {name: hold_oscillations(res) for name, res in results.items()}
    full = holds.get("full")
    rows = {}
    for name, res in results.items():
        m = tracking_metrics(res).display()  # the table's units: mm, %
        row: dict[str, float] = {f"hold_{i + 1}": h["p2p"] for i, h in enumerate(holds[name])}
        row["max_hold"] = max((h["p2p"] for h in holds[name]), default=float("nan"))
        ratios = [
            max(h["p2p"], 1e-3) / f["p2p"]
            for h, f in zip(holds[name], full or [], strict=False)
            if f["p2p"] >= 1e-3
        ]
        row["ratio_to_full"] = max(ratios, key=lambda q: abs(np.log(q)), default=float("nan"))
        for key in ("iae", "max_following_error", "saturation"):
            row[key] = m[key]
        rows[name] = row
    table = pd.DataFrame(rows).T
    table.index.name = "model"
    units = {c: "mm" for c in table.columns if c.startswith("hold_")}
    units.update(
        max_hold="mm", ratio_to_full="1", iae="mm·s", max_following_error="mm", saturation="%"
    )
    table.attrs["units"] = units
    return results, table
