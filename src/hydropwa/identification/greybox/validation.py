"""Validation on held-out runs: the fitted model simulated over each run it never saw.

:func:`split_runs` keeps a share of the runs out of the fit (evenly spread over the campaign,
so every operating point's neighbourhood stays in the fit); :func:`validate` simulates each of
them with the fitted parameters in single shooting over its whole valid stretches (from the
measured state at their start, as a user would run the model) and reports the normalised
fit of every channel, as MATLAB's ``compare`` does:
fit = 100·(1 − ‖y − ŷ‖ / ‖y − mean(y)‖) [%].
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from ..._errors import IdentificationError
from .data import Shooting, prepare_run
from .objective import OutputErrorObjective

__all__ = ["Validation", "normalized_fit", "split_runs", "validate"]


def split_runs(runs: list, share: float) -> tuple[list, list]:
    """(fitted, held-out) runs: ``share`` of them held out, evenly spaced in the given order."""
    if not (0.0 <= share < 1.0):
        raise IdentificationError(f"validate = {share!r} must lie in [0, 1) (a share of the runs)")
    n = len(runs)
    n_hold = int(round(share * n))
    if share > 0 and n_hold == 0 and n >= 2:
        n_hold = 1
    if n_hold == 0:
        return list(runs), []
    if n_hold >= n:
        raise IdentificationError(
            f"validate = {share:g} holds out all {n} runs; keep at least one for the fit"
        )
    held = {int((k + 0.5) * n / n_hold) for k in range(n_hold)}
    return [r for i, r in enumerate(runs) if i not in held], [
        r for i, r in enumerate(runs) if i in held
    ]


def normalized_fit(y: np.ndarray, y_hat: np.ndarray) -> float:
    """100·(1 − ‖y − ŷ‖/‖y − mean(y)‖) [%] (NaN for a constant ``y``)."""
    den = float(np.linalg.norm(y - np.mean(y)))
    if not den > 0:
        return math.nan
    return 100.0 * (1.0 - float(np.linalg.norm(y - y_hat)) / den)


@dataclasses.dataclass(frozen=True)
class Validation:
    """Fit of the fitted model on runs left out of the fit.

    Attributes
    ----------
    runs : dict[str, dict[str, float]]
        Per held-out run, the normalised fit per channel [%].
    mean : dict[str, float]
        Per channel, the mean fit over the runs [%].
    seconds : float
        Seconds of data simulated.
    """

    runs: dict[str, dict[str, float]]
    mean: dict[str, float]
    seconds: float

    def summary(self) -> str:
        """One sentence for the summary."""
        chans = ", ".join(f"{c} {v:.1f} %" for c, v in self.mean.items())
        return (
            f"Validation on {len(self.runs)} held-out run(s) ({self.seconds:.3g} s, single "
            f"shooting over each valid stretch): mean fit {chans}."
        )


def validate(
    held: list,
    work_model: Any,
    values: np.ndarray,
    names: tuple[str, ...],
    channels: tuple[str, ...],
    sigma: dict[str, float],
    rtol: float,
    jobs: int | None,
    input_cutoff: float | None,
    feedback: float | Callable[[Any], float] = 0.0,
) -> Validation | None:
    """Simulate each held-out run with the parameters ``values`` of ``names`` (``feedback``:
    the load damping the fit took out of the measured force, see ``prepare_run``)."""
    whole = Shooting(method="single", segment=None)
    prepared = [
        rd
        for r in held
        if (
            rd := prepare_run(
                r, work_model, channels, whole, [], input_cutoff,
                feedback=feedback(r) if callable(feedback) else feedback,
            )
        )
    ]  # fmt: skip
    if not prepared:
        return None
    prob = OutputErrorObjective(work_model, prepared, names, channels, rtol, jobs, sigma)
    sims = prob.simulate_all(np.asarray(values, dtype=float))
    out: dict[str, dict[str, float]] = {}
    for rd, sim in zip(prepared, sims, strict=True):
        fits = {}
        for c in rd.y:
            y = np.concatenate([rd.y[c][s.i0 : s.i1] for s in rd.segments])
            y_hat = np.concatenate([sim[k][c] for k in range(len(rd.segments))])
            fits[c] = normalized_fit(y, y_hat)
        out[rd.name] = fits
    chans = [c for c in channels if any(c in f for f in out.values())]
    mean = {c: float(np.nanmean([f[c] for f in out.values() if c in f])) for c in chans}
    seconds = float(sum(rd.t[s.i1 - 1] - rd.t[s.i0] for rd in prepared for s in rd.segments))
    return Validation(out, mean, seconds)
