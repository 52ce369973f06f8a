"""Profiles of the grey-box cost: one parameter held on a grid, the others refitted."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .jacobian import FiniteDifferenceJacobian
from .objective import loss_cost
from .optimize import LeastSquares
from .result import Profile

__all__ = ["REACH", "crossing", "profile"]


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


def profile(
    prob: Any,
    theta: np.ndarray,
    i: int,
    tlo: np.ndarray,
    thi: np.ndarray,
    loss: str,
    f_scale: float,
    cost0: float,
    kappa: float,
    z: float,
    sd: float,
    n_points: int = 9,
) -> Profile:
    """Cost along parameter i, the others refitted (few iterations) from the optimum.

    The grid spans ±2z standard deviations of ln p (at least ±0.1 %, at most ×/÷ 20, inside
    the bounds), so a well-determined parameter's interval is resolved by a few points. Where
    the statistic is still below the threshold at an end of the grid, the profile walks on,
    doubling the distance from the optimum, until it rises above it, reaches the bound or
    ×/÷ 20 (:data:`REACH`), as pyPESTO's profiler walks until its threshold. The statistic is
    2Δcost/κ (κ the sandwich's variance correction), compared with z².
    """
    span = min(max(2.0 * z * sd, 1e-3), REACH) if math.isfinite(sd) else REACH
    grid = list(np.linspace(max(tlo[i], theta[i] - span), min(thi[i], theta[i] + span), n_points))
    others = [k for k in range(theta.size) if k != i]
    refit = LeastSquares(loss=loss, f_scale=f_scale, max_nfev=8, xtol=1e-3, ftol=1e-4)

    def q_at(g: float) -> float:
        th = theta.copy()
        th[i] = g
        if others:
            held = _Held(prob, th, others)
            sol = refit.solve(held.fun, theta[others], held.jac, (tlo[others], thi[others]))
            c = float(sol.cost)
        else:
            c = loss_cost(prob.fun(th), loss, f_scale)
        return max(2.0 * (c - cost0) / kappa, 0.0)

    vals = [q_at(g) for g in grid]
    for side, bound in ((-1, tlo[i]), (1, thi[i])):
        k = 0 if side < 0 else -1
        while vals[k] <= z**2 and side * (bound - grid[k]) > 1e-9:
            reach = abs(grid[k] - theta[i])
            if reach >= REACH - 1e-9:
                break
            g = theta[i] + side * min(2.0 * reach, REACH)
            g = max(g, bound) if side < 0 else min(g, bound)
            if side < 0:
                grid.insert(0, g)
                vals.insert(0, q_at(g))
            else:
                grid.append(g)
                vals.append(q_at(g))
    grid_a, vals_a = np.asarray(grid), np.asarray(vals)
    pv = prob.ref[i] * np.exp(grid_a)
    return Profile(prob.free[i], pv, vals_a, crossing(grid_a, vals_a, theta[i], z**2, prob.ref[i]))


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
