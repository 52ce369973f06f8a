"""Jacobian strategies of the grey-box fit: finite differences, with Broyden updates between.

A strategy is an object holding its own state (the last Jacobian, point and residuals), made
afresh for each least-squares stage; nothing lives in a closure.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..._errors import IdentificationError

__all__ = ["DIFFERENCES", "FiniteDifferenceJacobian"]

#: the finite-difference schemes
DIFFERENCES = ("central", "forward")


class FiniteDifferenceJacobian:
    """Jacobian of an objective's residuals by finite differences in log parameters.

    Parameters
    ----------
    objective : OutputErrorObjective
        Its ``fun`` and ``jac`` give the residuals and the difference columns.
    step : float
        Difference step in ln p [1].
    differences : {"central", "forward"}
        Central (2p simulations, error O(h²)) or forward (p simulations, error O(h)).
    refresh : int
        Differences every ``refresh``-th call, Broyden rank-one updates from the accepted
        steps in between (an update costs no simulation); 1: always differences.

    Attributes
    ----------
    central : tuple of (ndarray, ndarray) or None
        The last central-difference Jacobian and the point it was taken at (the covariance
        at the optimum reuses it when the optimiser ended there).
    """

    def __init__(
        self, objective: Any, step: float, differences: str = "central", refresh: int = 1
    ) -> None:
        if differences not in DIFFERENCES:
            raise IdentificationError(f"differences = {differences!r}; choose central or forward")
        self.objective = objective
        self.step = float(step)
        self.differences = differences
        self.refresh = max(int(refresh), 1)
        self.calls = 0
        self.central: tuple[np.ndarray, np.ndarray] | None = None
        self._last: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None  # θ, J, r

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        prob = self.objective
        r_new = prob.fun(theta)
        calls, self.calls = self.calls, self.calls + 1
        if calls % self.refresh == 0 or self._last is None:
            if self.differences == "central":
                J = prob.jac(theta, self.step, central=True)
                self.central = (theta.copy(), J)
            else:
                J = prob.jac(theta, self.step, r0=r_new)
        else:
            th_old, J_old, r_old = self._last
            J = J_old.copy()
            d = theta - th_old
            dd = float(d @ d)
            if dd > 0:
                J += np.outer(r_new - r_old - J @ d, d) / dd
        self._last = (theta.copy(), J, r_new.copy())
        return J
