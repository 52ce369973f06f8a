"""The grey-box fit's optimiser: the one place that calls :func:`scipy.optimize.least_squares`."""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np
from scipy import optimize

__all__ = ["LeastSquares"]


@dataclasses.dataclass(frozen=True)
class LeastSquares:
    """Trust-region reflective least squares with its settings (scipy's names and meaning).

    Attributes
    ----------
    loss : str
        ``linear``, ``soft_l1``, ``huber``, ``cauchy`` or ``arctan``.
    f_scale : float
        Scale of the robust loss [noise σ].
    x_scale : float, "jac" or array
        Scale of the coordinates (log parameters: 1 is a relative change of a factor e).
    max_nfev : int
        Residual evaluations allowed.
    xtol, ftol, gtol : float
        Step, cost and gradient tolerances.
    verbose : int
        0, 1 or 2.
    """

    loss: str = "linear"
    f_scale: float = 3.0
    x_scale: Any = 1.0
    max_nfev: int = 40
    xtol: float = 1e-4
    ftol: float = 1e-6
    gtol: float = 1e-8
    verbose: int = 0

    def with_tolerance(self, tol: float) -> LeastSquares:
        """These settings with step and cost tolerance ``tol`` (a locating stage's)."""
        return dataclasses.replace(self, xtol=tol, ftol=tol)

    def solve(
        self,
        fun: Callable[[np.ndarray], np.ndarray],
        theta0: np.ndarray,
        jac: Callable[[np.ndarray], np.ndarray],
        bounds: tuple[np.ndarray, np.ndarray],
    ) -> optimize.OptimizeResult:
        """Minimise ½Σρ(fun(θ)²) from ``theta0`` within ``bounds`` (scipy's result)."""
        with warnings.catch_warnings():
            # a simulation that fails at a trial point gives large finite residuals; the
            # overflow warnings of its cost are expected there
            warnings.simplefilter("ignore", RuntimeWarning)
            return optimize.least_squares(
                fun,
                theta0,
                jac=jac,
                bounds=bounds,
                loss=self.loss,
                f_scale=self.f_scale,
                x_scale=self.x_scale,
                max_nfev=self.max_nfev,
                xtol=self.xtol,
                ftol=self.ftol,
                gtol=self.gtol,
                verbose=self.verbose,
            )
