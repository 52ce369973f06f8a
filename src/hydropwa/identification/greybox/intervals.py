"""Intervals checked against the cost: the valley scan that widens a Wald interval where the
cost rises slower than its quadratic, and the estimates built from the half-widths."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable
from typing import Any

import numpy as np

from .._common import ParameterEstimate
from .uncertainty import kappa as _kappa

__all__ = ["interval_scan", "scan_widen", "valley"]


def valley(Hinv: np.ndarray, i: int) -> np.ndarray:
    """Parameter i's valley: i moves by one, the others by their regression on it
    (H⁻¹e_i/(H⁻¹)_ii), the direction in which the linearised cost rises least."""
    return Hinv[:, i] / Hinv[i, i]


def interval_scan(
    prob: Any,
    theta: np.ndarray,
    Hinv: np.ndarray,
    sd: np.ndarray,
    kappa: np.ndarray,
    z: float,
    bounds: tuple[np.ndarray, np.ndarray],
    cost: Callable[[np.ndarray], float],
    min_half_width: float = 0.002,
    only: Iterable[int] | None = None,
) -> tuple[np.ndarray, np.ndarray, dict[int, tuple[float, float]]]:
    """Check intervals against the cost itself: widen one where the cost rises slower.

    The Wald interval θ_i ± z·σ_i assumes the cost is the Gauss–Newton quadratic. Along
    parameter i's valley (direction H⁻¹e_i/(H⁻¹)_ii: the others follow their regression on
    it, the linearised profile) the cost is evaluated at ±2z·σ_i and expressed as the
    profile's statistic q = 2Δcost/κ_i (κ_i = σ_i²/(H⁻¹)_ii, so the quadratic gives
    q = (s/σ_i)², 4z² ≈ 15.4 there). A side whose q stays below z² ends beyond the scan, at
    2z·σ + σ·√(z² − max(q, 0)) (the quadratic's curvature from there on); a side with
    z² ≤ q < 4z² ends where the quadratic through the origin and the scanned point reaches
    z², 2z·σ·z/√q; a steeper side keeps z·σ (the scan never narrows).

    The scan and its reference point are simulated at a tenth of the fit's tolerance: at
    the fit's own the step sequence's jitter moved q at F_c's and σ's points by 5–14 for a
    shift of 4e-5 of the step (rig sine runs, rtol 1e-5); at a tenth by < 0.4, and q agreed
    with rtol 1e-7 within 0.3. Parameters whose interval is narrower than
    ±``min_half_width`` (in ln p) are not scanned: there even that cost is the integrator's
    jitter (E at ±0.05 %: q from −4 to 64 for the same shift at rtol 1e-6).

    Measured on the rig's 5 s sine runs with stick events (seed 1, six parameters free, at
    rtol 1e-7): q = 5.0 and 1.4 for the Coulomb friction, 1.5 and 13.7 for the viscous
    friction (the quadratic: 15.4): the Jacobian's 3 % differences see the stick pattern's
    steep local slope, the cost over ±9 % a flat floor; the truth lay 2.3 and 3.1 σ away.

    Each scanned point also moves the other parameters (by their regression on i): where its
    statistic on parameter j's scale, 2Δcost/κ_j, is within z², the point lies in j's profile
    region, and j's interval is widened to reach it. Measured on the same runs: K's truth
    lay 2.4 σ from the estimate on seeds 1 and 4, along the valleys of σ and F_c, whose
    scanned points moved K by 4.3 and 2.5 σ at costs within K's threshold.

    ``only``: scan these parameters' valleys alone (their points still widen the others).

    Returns the lower and upper half-widths in θ (each at least z·σ_i) and, per scanned
    parameter, q at the lower and upper point (NaN: that point is outside the bounds).
    """
    p = theta.size
    chosen = set(range(p) if only is None else only)
    lo = z * sd.copy()
    hi = z * sd.copy()
    tlo, thi = bounds
    sets, where = _scan_points(theta, Hinv, sd, kappa, z, tlo, thi, chosen, min_half_width)
    scan: dict[int, tuple[float, float]] = {}
    if not where:
        return lo, hi, scan
    costs = iter(prob.costs(sets, cost, rtol=prob.rtol / 10.0))
    c0 = next(costs)
    q_at: dict[tuple[int, float], float] = {}
    k = 1
    for i, side, inside in where:
        if not inside:
            q_at[(i, side)] = math.nan
            continue
        q = 2.0 * (next(costs) - c0) / kappa[i]
        q_at[(i, side)] = q
        off = sets[k] - theta  # this point's offset (sets[0] is θ itself)
        k += 1
        if np.isfinite(q):
            lo, hi = _widen(lo, hi, i, side, q, off, sd, kappa, z)
    for i, _side, _in in where:
        scan[i] = (q_at[(i, -1.0)], q_at[(i, 1.0)])
    return lo, hi, scan


def _scan_points(
    theta: np.ndarray,
    Hinv: np.ndarray,
    sd: np.ndarray,
    kappa: np.ndarray,
    z: float,
    tlo: np.ndarray,
    thi: np.ndarray,
    chosen: set[int],
    min_half_width: float,
) -> tuple[list[np.ndarray], list[tuple[int, float, bool]]]:
    """θ and the points at ±2z·σ_i along each chosen parameter's valley inside the bounds,
    and per point (parameter, side, inside the bounds)."""
    sets, where = [theta], []
    for i in range(theta.size):
        if i not in chosen or not (
            Hinv[i, i] > 0 and np.isfinite(sd[i]) and z * sd[i] >= min_half_width and kappa[i] > 0
        ):
            continue
        d = valley(Hinv, i)
        for side in (-1.0, 1.0):
            t = theta + side * 2.0 * z * sd[i] * d
            where.append((i, side, bool(np.all(t > tlo) and np.all(t < thi))))
            if where[-1][2]:
                sets.append(t)
    return sets, where


def _widen(
    lo: np.ndarray,
    hi: np.ndarray,
    i: int,
    side: float,
    q: float,
    off: np.ndarray,
    sd: np.ndarray,
    kappa: np.ndarray,
    z: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The half-widths after parameter i's scanned point at offset ``off`` with statistic q."""
    # the point is inside every other parameter j's profile region where its statistic on
    # j's scale, 2Δcost/κ_j, is within z²: j's interval must reach the point's offset
    within = q * kappa[i] / kappa <= z * z
    within[i] = False
    lo = np.where(within & (off < 0), np.maximum(lo, -off), lo)
    hi = np.where(within & (off > 0), np.maximum(hi, off), hi)
    if q < z * z:
        half = 2.0 * z * sd[i] + sd[i] * math.sqrt(z * z - max(q, 0.0))
    else:
        half = max(z * sd[i], 2.0 * z * sd[i] * z / math.sqrt(q))
    if side < 0:
        lo[i] = half
    else:
        hi[i] = half
    return lo, hi


def scan_widen(
    prob: Any,
    theta: np.ndarray,
    Hinv: np.ndarray,
    cov: np.ndarray,
    z: float,
    tlo: np.ndarray,
    thi: np.ndarray,
    cost: Callable[[np.ndarray], float],
    only: Iterable[int] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[int, tuple[float, float]]]:
    """:func:`interval_scan` at an optimum and the covariance scaled to its half-widths.

    Returns the scaled covariance (correlations unchanged, each σ the larger of its own and
    the interval's mean half-width over z), the half-widths below and above θ in ln p, and
    the scan's q per scanned parameter.
    """
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    half_lo, half_hi, scan_i = interval_scan(
        prob, theta, Hinv, sd, _kappa(cov, Hinv), z, (tlo, thi), cost, only=only
    )
    wider = np.maximum(sd, (half_lo + half_hi) / (2.0 * z))
    with np.errstate(invalid="ignore", divide="ignore"):
        f = np.where(sd > 0, wider / sd, 1.0)
    if np.any(f > 1.0):
        cov = cov * np.outer(f, f)
    return cov, half_lo, half_hi, scan_i


def estimate(
    e: ParameterEstimate, value: float, sd: float, half_lo: float, half_hi: float
) -> ParameterEstimate:
    """``e`` at ``value`` [SI] with standard error ``sd`` and interval half-widths
    ``half_lo``/``half_hi`` below and above, all in ln p (the fit's coordinates); a new
    interval, so no end of it is clipped yet (``clipped`` is cleared)."""
    v = float(value)
    ci = log_interval(v, half_lo, half_hi)
    return dataclasses.replace(e, value=v, std=v * float(sd), ci=ci, clipped="")


def log_interval(value: float, half_lo: float, half_hi: float) -> tuple[float, float]:
    """The interval (value·e^−half_lo, value·e^half_hi) of half-widths in ln p.

    A half-width beyond 700 (an optimiser stopped far from its optimum adds its whole
    remaining step; an infinite standard error) is clipped there: the side reaches
    value·e^∓700 (about 1e∓304 times the value) instead of overflowing.
    """
    v = float(value)
    return (v * math.exp(-min(float(half_lo), 700.0)), v * math.exp(min(float(half_hi), 700.0)))
