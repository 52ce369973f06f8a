"""Profiles of the grey-box cost: one parameter held on a grid, the others refitted."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .jacobian import FiniteDifferenceJacobian
from .objective import loss_cost
from .optimize import LeastSquares
from .result import Profile

__all__ = ["profile"]


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
    the bounds), so a well-determined parameter's interval is resolved by a few points and a
    weak one's profile reaches its bounds. The statistic is 2Δcost/κ (κ the sandwich's
    variance correction), compared with z².
    """
    span = min(max(2.0 * z * sd, 1e-3), 3.0) if math.isfinite(sd) else 3.0
    grid = np.linspace(max(tlo[i], theta[i] - span), min(thi[i], theta[i] + span), n_points)
    others = [k for k in range(theta.size) if k != i]
    refit = LeastSquares(loss=loss, f_scale=f_scale, max_nfev=8, xtol=1e-3, ftol=1e-4)
    vals = []
    for g in grid:
        th = theta.copy()
        th[i] = g
        if others:
            held = _Held(prob, th, others)
            sol = refit.solve(held.fun, theta[others], held.jac, (tlo[others], thi[others]))
            c = float(sol.cost)
        else:
            c = loss_cost(prob.fun(th), loss, f_scale)
        vals.append(2.0 * (c - cost0) / kappa)
    vals_a = np.maximum(np.asarray(vals), 0.0)
    ok = vals_a <= z**2
    pv = prob.ref[i] * np.exp(grid)
    ci = (float(pv[ok][0]), float(pv[ok][-1])) if ok.any() else (math.nan, math.nan)
    return Profile(prob.free[i], pv, vals_a, ci)
