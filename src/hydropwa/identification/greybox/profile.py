"""Profiles of the grey-box cost: one parameter held on a grid, the others refitted."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import numpy as np
from scipy import stats

from .._common import ParameterEstimate, within_physical_bounds
from .jacobian import FiniteDifferenceJacobian
from .objective import loss_cost
from .optimize import LeastSquares
from .result import Profile

__all__ = ["REACH", "ProfileTask", "carry", "crossing", "profile"]


class _Held:
    """The objective with parameter ``i`` held at ``th[i]``: residuals and forward-difference
    Jacobian of the other parameters (scipy sees only those)."""

    def __init__(self, prob: Any, th: np.ndarray, others: list[int]) -> None:
        self.prob, self.th, self.others = prob, th, others
        self.jac_full = FiniteDifferenceJacobian(prob, prob.fd_step, differences="forward")

    def _full(self, sub: np.ndarray) -> np.ndarray:
        full = self.th.copy()
        full[self.others] = sub
        return full

    def fun(self, sub: np.ndarray) -> np.ndarray:
        return self.prob.fun(self._full(sub))

    def jac(self, sub: np.ndarray) -> np.ndarray:
        return self.jac_full(self._full(sub))[:, self.others]


#: how far a profile walks from the optimum [ln p]: ×/÷ 20; a parameter whose profile stays
#: below the threshold that far (or to its bound) is not determined by the data
REACH = 3.0


@dataclasses.dataclass(frozen=True, kw_only=True)
class ProfileTask:
    """One profile to walk (:func:`profile`; a Dask task ships it whole).

    Attributes
    ----------
    prob : OutputErrorObjective
        The objective (residuals of θ = ln(p / ref)).
    theta : ndarray, shape (p,)
        The optimum [ln p].
    index : int
        The profiled parameter's position in θ.
    tlo, thi : ndarray, shape (p,)
        Bounds of θ.
    loss : str
        The optimiser's loss (scipy's ``least_squares``).
    f_scale : float
        The loss's soft margin [1].
    cost0 : float
        ½Σρ(r²) at the optimum [1].
    kappa : float
        The sandwich's variance correction of the parameter [1].
    z : float
        Normal quantile of the interval's level [1].
    sd : float
        Standard deviation of θ[index] [1]; the grid spans ±2z of it.
    n_points : int
        Grid points before the walk outward.
    """

    prob: Any
    theta: np.ndarray
    index: int
    tlo: np.ndarray
    thi: np.ndarray
    loss: str
    f_scale: float
    cost0: float
    kappa: float
    z: float
    sd: float
    n_points: int = 9


def profile(task: ProfileTask) -> Profile:
    """Cost along parameter i, the others refitted (few iterations) from the optimum.

    The grid spans ±2z standard deviations of ln p (at least ±0.1 %, at most ×/÷ 20, inside
    the bounds), so a well-determined parameter's interval is resolved by a few points. Where
    the statistic is still below the threshold at an end of the grid, the profile walks on,
    doubling the distance from the optimum, until it rises above it, reaches the bound or
    ×/÷ 20 (:data:`REACH`), as pyPESTO's profiler walks until its threshold. The statistic is
    2Δcost/κ (κ the sandwich's variance correction), compared with z².
    """
    prob, theta, i, tlo, thi = task.prob, task.theta, task.index, task.tlo, task.thi
    loss, f_scale, cost0, kappa, z, sd = (
        task.loss, task.f_scale, task.cost0, task.kappa, task.z, task.sd
    )  # fmt: skip
    span = min(max(2.0 * z * sd, 1e-3), REACH) if math.isfinite(sd) else REACH
    lo, hi = max(tlo[i], theta[i] - span), min(thi[i], theta[i] + span)
    grid = list(np.linspace(lo, hi, task.n_points))
    others = [k for k in range(theta.size) if k != i]
    refit = LeastSquares(loss=loss, f_scale=f_scale, max_nfev=8, xtol=1e-3, ftol=1e-4)

    def q_at(g: float, start: np.ndarray) -> tuple[float, np.ndarray]:
        th = start.copy()
        th[i] = g
        if others:
            held = _Held(prob, th, others)
            sol = refit.solve(held.fun, th[others], held.jac, (tlo[others], thi[others]))
            th[others] = sol.x
            c = float(sol.cost)
        else:
            c = loss_cost(prob.fun(th), loss, f_scale)
        return max(2.0 * (c - cost0) / kappa, 0.0), th

    at = _walk(q_at, grid, theta, i, (tlo[i], thi[i]), z**2)
    grid_a = np.asarray(sorted(at))
    vals_a = np.asarray([at[g][0] for g in grid_a])
    ths = np.asarray([at[g][1] for g in grid_a])
    pv = prob.ref[i] * np.exp(grid_a)
    refitted = {prob.free[k]: prob.ref[k] * np.exp(ths[:, k]) for k in others}
    ci = crossing(grid_a, vals_a, theta[i], z**2, prob.ref[i])
    return Profile(prob.free[i], pv, vals_a, ci, refitted)


def _walk(
    q_at: Callable[[float, np.ndarray], tuple[float, np.ndarray]],
    grid: list[float],
    theta: np.ndarray,
    i: int,
    bounds: tuple[float, float],
    level: float,
) -> dict[float, tuple[float, np.ndarray]]:
    """The profile's points (value → statistic, refitted θ): the grid walked outward from
    the optimum on each side, each point refitted from its neighbour's (pyPESTO's profiler:
    along a flat valley the few iterations of one refit then add up instead of restarting
    from the optimum every time), then on, doubling the distance, while the statistic stays
    within ``level``, up to the bound or :data:`REACH`."""
    k0 = int(np.argmin(np.abs(np.asarray(grid) - theta[i])))
    at: dict[float, tuple[float, np.ndarray]] = {}
    for side, bound in ((-1, bounds[0]), (1, bounds[1])):
        start = theta
        for k in range(k0, -1, -1) if side < 0 else range(k0, len(grid)):
            if grid[k] not in at:
                at[grid[k]] = q_at(grid[k], start)
            start = at[grid[k]][1]
        g_end = grid[0] if side < 0 else grid[-1]
        while at[g_end][0] <= level and side * (bound - g_end) > 1e-9:
            reach = abs(g_end - theta[i])
            if reach >= REACH - 1e-9:
                break
            g = theta[i] + side * min(2.0 * reach, REACH)
            g = max(g, bound) if side < 0 else min(g, bound)
            at[g] = q_at(g, at[g_end][1])
            g_end = g
    return at


def carry(
    estimates: dict[str, ParameterEstimate], profiles: dict[str, Profile], level: float
) -> tuple[dict[str, ParameterEstimate], list[str]]:
    """The intervals widened to every value a profile walked through within its threshold.

    Where parameter i's profile stays below ``level`` (z²), the data do not reject the
    point, and the other parameters, refitted there, take values the data do not reject
    either: parameter j's interval must hold them. Without this a parameter correlated
    with a weak one keeps the narrow interval of the weak one held at its estimate (issue
    49: F_s = 100.7 N, interval [96.95, 104.5], truth 118 N, while the shape and the
    smoothness were reported as not identified). Returns the estimates and the names whose
    intervals were widened.
    """
    out = dict(estimates)
    widened: list[str] = []
    for p in profiles.values():
        ok = np.asarray(p.cost) <= level
        for name, vals in p.refitted.items():
            if name not in out or not ok.any():
                continue
            e = out[name]
            got = np.asarray(vals)[ok]
            lo, hi = min(e.ci[0], float(got.min())), max(e.ci[1], float(got.max()))
            if (lo, hi) != tuple(e.ci):
                out[name] = within_physical_bounds(name, _widened(e, lo, hi))
                widened.append(name)
    return out, list(dict.fromkeys(widened))


def _widened(e: ParameterEstimate, lo: float, hi: float) -> ParameterEstimate:
    """``e`` with the interval (lo, hi) [SI] and the standard error of its half-width in
    ln p (the fit's coordinates) over the interval's z."""
    z = float(stats.norm.ppf(0.5 + 0.5 * e.level))
    if not (lo > 0 and e.value > 0):
        return dataclasses.replace(e, ci=(lo, hi))
    half = 0.5 * (math.log(hi) - math.log(lo))
    return dataclasses.replace(e, ci=(lo, hi), std=max(e.std, e.value * half / z))


def crossing(
    grid: np.ndarray, q: np.ndarray, th: float, level: float, ref: float
) -> tuple[float, float]:
    """The profile interval [SI]: on each side of the optimum ``th`` where the statistic
    ``q`` on ``grid`` (ln p/ref) first rises above ``level``, linearly interpolated between
    the grid points around the crossing (the grid's end where it never does: the data do
    not limit the parameter there); NaN where the optimum's own point is above it."""
    k0 = int(np.argmin(np.abs(grid - th)))
    if not q[k0] <= level:
        return (math.nan, math.nan)
    ends = []
    for step in (-1, 1):
        k = k0
        while 0 <= k + step < grid.size and q[k + step] <= level:
            k += step
        if 0 <= k + step < grid.size:
            a, b = q[k], q[k + step]
            f = (level - a) / (b - a) if b > a else 0.0
            ends.append(grid[k] + f * (grid[k + step] - grid[k]))
        else:
            ends.append(grid[k])
    return (float(ref * math.exp(ends[0])), float(ref * math.exp(ends[1])))
