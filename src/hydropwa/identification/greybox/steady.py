"""The steady stretches of a campaign as their means: what a segment selection would drop.

A constant-input run settles: over its steady stretch the rod moves at a constant speed and
the chamber pressures hold the values at which the valve's flow and the forces balance
(Eqs. (1)–(11) of the paper at rest in their derivatives). Every sample of that stretch
repeats the same two numbers, so its information is in their means, known to a standard
error many times below one sample's noise. A campaign selection (:mod:`hydropwa.identification.greybox.selection`) keeps
0.1 s of each run and drops the rest; on the virtual rig's friction campaign that left the
Coulomb friction within ±40 % (95 %) — its share of the force is a few newtons, resolved by
the means of all runs (a fit of Eq. (11) to them alone: F_c, F_s, σ within 1.5 %), not by
a few segments of noise.

:func:`steady_runs` turns each run's longest steady stretch into one short pseudo-run: the
model starts from the stretch's mean state and is driven by its mean inputs, and its
outputs are compared with the stretch's means (the position by its speed, the slope of
the line through it). Each channel's residuals are weighted (``_Segment.weight``) so that the
segment's cost is the squared error over the standard error of the mean,
(ŷ − ȳ)²/se², se from batch means (eight blocks, so the counter-force ripple and the
correlated noise count; never below the white-noise value σ/√N). The segment lasts
``duration``; its first half, in which the model settles from the measured means to its own
balance (a few ms for the pressures of the paper rig, tens of ms for its speed), counts
for nothing: compared over the whole segment, that settling alone made the speed's cost at
the true parameters 30 times its expectation on the virtual rig's friction campaign.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from .data import RunData, _mask_runs, _Segment
from .selection import events

__all__ = ["steady_runs", "steady_stretch"]

#: batch-means blocks per stretch (their spread gives the standard error of the mean)
_BLOCKS = 8


def steady_stretch(
    rd: RunData, v_move: float, settle: float, min_length: float
) -> tuple[int, int] | None:
    """Sample range [i0, i1) of the run's longest steady stretch, or None.

    Steady: a smooth run (single shooting: no oscillation), inside one valid span (outside the run's excluded stretches), ``settle`` s after
    the last command step or motion event before it and up to the next, the command
    constant, and the speed (in 20 ms means) of one sign and above ``v_move`` throughout
    (a creeping, stick-slip stretch has no steady state of the model), at least
    ``min_length`` s long.
    """
    if rd.speed is None or not rd.segments or rd.method != "single":
        return None  # an oscillating run's mean state is no balance of the model
    t = rd.t
    ev = np.array(events(rd, ("command", "motion"), v_move))
    valid = np.ones(t.size, bool)
    for a, b, _why in rd.excluded:
        valid &= (t < a) | (t > b)
    best: tuple[int, int] | None = None
    for a, b in _mask_runs(valid):
        cuts = [float(t[a])] + [e for e in ev if t[a] < e < t[b - 1]] + [float(t[b - 1])]
        for lo, hi in zip(cuts[:-1], cuts[1:], strict=True):
            i0 = int(np.searchsorted(t, lo + settle))
            i1 = int(np.searchsorted(t, hi))
            if t[min(i1, t.size) - 1] - t[min(i0, t.size - 1)] < min_length:
                continue
            u = rd.u[i0:i1]
            if float(np.ptp(u)) > 1e-6 + 1e-3 * abs(float(np.mean(u))):
                continue
            # the speed in 20 ms means: the smoothed speed's own noise (1.3 mm/s on the
            # paper rig) would reject the slow runs, which hold the Stribeck branch
            n_b = max(1, int(round(0.02 / float(np.median(np.diff(t))))))
            vb = np.array(
                [b.mean() for b in np.array_split(rd.speed[i0:i1], max(1, (i1 - i0) // n_b))]
            )
            if not (np.all(vb > v_move) or np.all(vb < -v_move)):
                continue
            got = _settled(rd, i0, i1, min_length)
            if got is not None and (best is None or got[1] - got[0] > best[1] - best[0]):
                best = got
    return best


def _settled(rd: RunData, i0: int, i1: int, min_length: float) -> tuple[int, int] | None:
    """The stretch's settled part: halved from its start while the mean of a channel (the
    speed, the logged pressures) over its first half differs from that over its second
    by more than 4√2 standard errors of the second (the sum of the chamber pressures of a
    critical-centre valve settles over tenths of seconds), None below ``min_length``."""
    assert rd.speed is not None
    series = [rd.speed] + [rd.y[c] for c in ("p_a", "p_b") if c in rd.y]
    sd = [rd.meas_sd.get("v", 0.0)] + [rd.sigma[c] for c in ("p_a", "p_b") if c in rd.y]
    while rd.t[i1 - 1] - rd.t[i0] >= min_length:
        mid = (i0 + i1) // 2
        if all(
            abs(float(np.mean(y[i0:mid])) - m) <= 4.0 * math.sqrt(2.0) * se
            for y, s in zip(series, sd, strict=True)
            for m, se in [_mean_se(y[mid:i1], s)]
        ):
            return i0, i1
        i0 = mid
    return None


def _mean_se(y: np.ndarray, sigma: float) -> tuple[float, float]:
    """Mean and its standard error from batch means (at least the white-noise value)."""
    blocks = np.array([b.mean() for b in np.array_split(y, _BLOCKS)])
    se = float(np.std(blocks, ddof=1)) / math.sqrt(_BLOCKS)
    return float(np.mean(y)), max(se, sigma / math.sqrt(y.size))


def _slope_se(t: np.ndarray, x: np.ndarray, sigma: float) -> tuple[float, float, float]:
    """Speed of the line through x(t), the position at the stretch's middle, and the speed's
    standard error from the blocks' slopes (at least the white-noise value)."""
    tc = t - t.mean()
    v = float(tc @ (x - x.mean()) / (tc @ tc))
    slopes = []
    for tb, xb in zip(np.array_split(t, _BLOCKS), np.array_split(x, _BLOCKS), strict=True):
        tbc = tb - tb.mean()
        slopes.append(float(tbc @ (xb - xb.mean()) / (tbc @ tbc)))
    se = float(np.std(slopes, ddof=1)) / _BLOCKS
    return v, float(x.mean()), max(se, sigma / math.sqrt(float(tc @ tc)))


def _steady_run(
    rd: RunData, i0: int, i1: int, channels: Sequence[str], sigma: dict[str, float], n: int
) -> RunData:
    """The pseudo-run of one steady stretch: constant mean inputs, mean outputs, weights."""
    t_run = rd.t[i0:i1]
    dt = float(np.median(np.diff(t_run)))
    t = t_run[0] + dt * np.arange(n)
    v, x_mid, se_v = _slope_se(t_run, rd.y["x"][i0:i1], rd.sigma["x"])
    # the position's place is taken by the speed: a position compared with the line through
    # the means would count the few ms in which the model settles as a speed error forever
    # the first half of the pseudo-run settles to the model's balance from the measured
    # means and counts for nothing; the second half compares the balance with the means
    late = np.arange(1, n) >= n // 2
    share = late / math.sqrt(float(late.sum()))
    y = {"v": np.full(n, v)}
    weight = {"v": sigma.get("v", 1.0) / se_v * share}
    meas_sd = {"v": se_v, "x": 0.0}
    for c in channels:
        if c not in rd.y or c in ("x", "v"):
            continue
        m, se = _mean_se(rd.y[c][i0:i1], rd.sigma[c])
        y[c] = np.full(n, m)
        weight[c] = sigma[c] / se * share
        meas_sd[c] = se
    # the pseudo-run's noise levels are its means' standard errors (the report's column)
    noise = {"v": se_v, **{c: meas_sd[c] for c in y if c != "v"}}
    meas = {"x": x_mid, "v": v}
    for c in ("p_a", "p_b"):
        meas[c] = float(np.mean(rd.y[c][i0:i1])) if c in rd.y else rd.segments[0].meas[c]
    ps = None if rd.p_s is None else np.full(n, float(np.mean(rd.p_s[i0:i1])))
    fl = None if rd.f_l is None else np.full(n, float(np.mean(rd.f_l[i0:i1])))
    after = [s for s in rd.segments if s.i0 >= i0]
    base = min(after or rd.segments, key=lambda s: abs(s.i0 - i0)).meas
    meas["p_s"] = float(ps[0]) if ps is not None else base["p_s"]
    # the spool (logged or not) settles with the valve's own dynamics from its value there
    meas["spool"] = base["spool"]
    if "spool_rate" in base:
        meas["spool_rate"] = 0.0
    seg = _Segment(0, n, rd.make_state(meas), meas, weight)
    return dataclasses.replace(
        rd, name=f"{rd.name} (steady means)", t=t, u=np.full(n, float(np.mean(rd.u[i0:i1]))),
        p_s=ps, f_l=fl, y=y, sigma=noise, reason="the means of its steady stretch", segments=[seg],
        excluded=[], meas_sd=meas_sd, input_noise={}, speed=None,
    )  # fmt: skip


def steady_runs(
    prepared: list[RunData],
    channels: Sequence[str],
    sigma: dict[str, float],
    v_move: float,
    settle: float,
    duration: float,
    min_length: float = 0.3,
) -> tuple[list[RunData], str]:
    """Per run its steady stretch's means as a pseudo-run (see the module), and a sentence.

    Parameters
    ----------
    prepared : the campaign's prepared runs (every segment, before a selection)
    channels, sigma : the fitted channels and their pooled noise levels [SI]
    v_move : speed [m/s] above which the rod counts as moving
    settle : seconds after an event before a stretch counts as steady
    duration : seconds each pseudo-run is simulated
    min_length : shortest steady stretch [s] used
    """
    out, seconds = [], 0.0
    for rd in prepared:
        if "x" not in rd.y:
            continue
        got = steady_stretch(rd, v_move, settle, min_length)
        if got is None:
            continue
        i0, i1 = got
        dt = float(np.median(np.diff(rd.t)))
        n = max(10, int(round(duration / dt)) + 1)
        out.append(_steady_run(rd, i0, i1, channels, sigma, n))
        seconds += float(rd.t[i1 - 1] - rd.t[i0])
    if not out:
        return out, ""
    note = (
        f"The steady stretches of {len(out)} run(s) ({seconds:.3g} s, from {settle:g} s after "
        f"the last event, constant command, moving) enter as their means: {1e3 * duration:.0f}"
        " ms from the mean state under the mean inputs each, weighted by the means' standard "
        "errors (the selection alone keeps a few samples of them)."
    )
    return out, note
