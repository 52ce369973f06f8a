"""Falsification of a loop certificate on the full model (issue 51).

:func:`falsify` starts the **full** model (Eqs. (1)–(11)) in closed loop with the package's
law, sensor noise and the file's delay from states inside a box of (position error, velocity,
load-pressure deviation) at a hold, random and then by a small adversarial search (a random
local search from the worst starts, maximising the final error), and reports the largest
|position error| seen after the reach time against the claimed bound ē: the tightness.

A certificate is falsified when a run ends outside ē after the reach time or leaves the box's
error bound (``escaped``); a run never proves it, the checker does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._layout import FULL_KIND
from ..models import as_model
from ..simulation import simulate

__all__ = ["FalsificationResult", "falsify"]

#: the window after the reach time over which the final error is taken [s]
SETTLE_WINDOW = 0.2


@dataclass(frozen=True)
class FalsificationResult:
    """Runs, the worst final |e| [m], its start, the counts beyond ē and out of the box."""

    runs: int
    adversarial: int
    worst_final: float
    worst_start: tuple[float, float, float]
    beyond_bound: int
    escaped: int
    e_bar: float

    @property
    def tightness(self) -> float:
        """Largest final |e| seen / ē (≤ 1 where the bound held on every run)."""
        return self.worst_final / self.e_bar if self.e_bar > 0 else float("inf")

    def summary(self) -> str:
        return (
            f"falsification: {self.runs} runs ({self.adversarial} adversarial), worst final "
            f"|e| {self.worst_final * 1e3:.4g} mm, tightness {self.tightness:.3g} against ē "
            f"{self.e_bar * 1e3:.4g} mm; {self.beyond_bound} beyond ē, {self.escaped} left the box"
        )


def _start_state(full, params, x_ref: float, start) -> np.ndarray:
    """The full state of a start (e [m], ẋ [m/s], ΔP_L [Pa]) at the hold, the spool centred
    and P_A + P_B kept at the rest's (P_S: :meth:`FullOrderModel.initial_state`)."""
    c = params.cylinder
    y = full.initial_state(x_ref)
    alpha = c.area_b / c.area_a
    p_l = params.load.force / c.area_a + start[2]
    total = float(y[2] + y[3])
    pb = (total - p_l) / (1.0 + alpha)
    y[2], y[3], y[4], y[5] = total - pb, pb, x_ref + start[0], start[1]
    return y


def _final_error(controller, params, full, x_ref, start, duration, settle, noise, seed):
    """(largest |e| over the last ``settle`` seconds, largest |e| over the run) of one start."""
    res = simulate(
        full,
        controller=controller,
        reference=x_ref,
        initial_state=_start_state(full, params, x_ref, start),
        duration=duration,
        sensor_noise=noise,
        seed=seed,
    )
    t = np.asarray(res["t"], float)
    e = np.abs(np.asarray(res["x"], float) - x_ref)
    return float(e[t >= duration - settle].max()), float(e.max())


def falsify(
    controller,
    params,
    *,
    e_bar: float,
    box: tuple[float, float, float],
    reach_time: float,
    starts: int = 100,
    adversarial: int = 0,
    seed: int = 0,
    sensor_noise=None,
) -> FalsificationResult:
    """Random and adversarial starts of the full model in closed loop inside ``box``.

    Parameters
    ----------
    controller : StateFeedbackController
        The law (the package's, as :func:`~hydropwa.simulation.simulate` runs it).
    params : SystemParams
        The machine (the full model's parameters).
    e_bar : float
        The claimed bound [m].
    box : (float, float, float)
        Half-widths of the starts' (e [m], ẋ [m/s], ΔP_L [Pa]); a run whose |e| exceeds the
        box's error bound by 2× (and ē) is counted as escaped.
    reach_time : float
        [s] after which the error must lie within ē (the window :data:`SETTLE_WINDOW` after it).
    starts : int
        Random starts.
    adversarial : int
        Then evaluations of the local search from the worst start so far.
    seed : int
    sensor_noise : mapping, optional
        Standard deviations {"x", "p_a", "p_b"} (default the default design's).
    """
    from ._defaults import DEFAULT_DESIGN  # deferred: the defaults record imports the law

    noise = dict(DEFAULT_DESIGN.sensor_noise if sensor_noise is None else sensor_noise)
    full = as_model(FULL_KIND.name, params)
    x_ref = 0.5 * params.cylinder.stroke
    duration = float(reach_time) + SETTLE_WINDOW
    rng = np.random.default_rng(seed)
    half = np.asarray(box, float)
    seen: list[tuple[float, np.ndarray]] = []
    escaped = 0

    def run(start: np.ndarray) -> float:
        nonlocal escaped
        fin, peak = _final_error(
            controller,
            params,
            full,
            x_ref,
            start,
            duration,
            SETTLE_WINDOW,
            noise,
            int(rng.integers(2**31)),
        )
        escaped += int(peak > max(2.0 * half[0], e_bar))
        seen.append((fin, start))
        return fin

    for _ in range(starts):
        run(rng.uniform(-1.0, 1.0, 3) * half)
    for k in range(adversarial):  # a local search around the worst start so far
        best = max(seen, key=lambda s: s[0])[1]
        step = 0.3 * half * (0.5 ** (k // max(adversarial // 4, 1)))
        run(np.clip(best + rng.normal(size=3) * step, -half, half))
    worst = max(seen, key=lambda s: s[0])
    return FalsificationResult(
        runs=len(seen),
        adversarial=adversarial,
        worst_final=worst[0],
        worst_start=tuple(float(v) for v in worst[1]),  # type: ignore[arg-type]
        beyond_bound=sum(fin > e_bar for fin, _ in seen),
        escaped=escaped,
        e_bar=float(e_bar),
    )
