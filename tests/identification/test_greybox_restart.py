"""The fit's escapes from the wrong minimum of a rough cost (issue 19).

``_restart_from_probes``: on a rough cost the trust region shrinks on a ridge and
``least_squares`` stops with ``xtol`` though a central-difference point beside it is lower;
tested with a residual whose cost has ripple minima, it moves only downhill and as often as
allowed. ``_valley_scan``: after the locating stage, the single-shooting cost along each stick
parameter's valley picks the basin; tested on an exact quadratic with a correlated valley.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import optimize

from hydropwa.identification.greybox.objective import OutputErrorObjective as _Problem
from hydropwa.identification.greybox.stages import restart_from_probes as _restart_from_probes
from hydropwa.identification.greybox.stages import valley_scan as _valley_scan


def _residual(theta: np.ndarray) -> np.ndarray:
    # cost ½t² + 0.045·sin²(2πt/0.15): the global minimum at 0 and, from the ripple, local
    # ones near every multiple of 0.075 (within 2e-3: the slope of ½t² shifts them)
    t = float(theta[0])
    return np.array([t, 0.3 * np.sin(2 * np.pi * t / 0.15)])


class _Prob:
    """The two members of _Problem the restart uses: ``jac`` (sets ``probes``) and ``fd_step``."""

    def __init__(self, step: float) -> None:
        self.fd_step = step
        self.probes = None

    def jac(self, theta, step, central=True):
        thetas = [theta + step, theta - step]
        self.probes = (theta.copy(), thetas, [_residual(t) for t in thetas])
        return np.array([[(_residual(thetas[0]) - _residual(thetas[1]))[0] / (2 * step)]])


def _solve(theta0):
    return optimize.least_squares(_residual, np.atleast_1d(theta0), xtol=1e-10)


def _cost(r):
    return 0.5 * float(r @ r)


def test_restart_leaves_a_local_minimum_for_a_lower_neighbour():
    stuck = _solve([0.2])
    assert stuck.x[0] == pytest.approx(0.225, abs=2e-3)  # a ripple's minimum: stopped there
    sol, taken = _restart_from_probes(_Prob(0.075), stuck, _solve, _cost, n=5)
    # each restart starts at the lower probe, the next minimum down (0.15, 0.075, 0); at 0
    # both probes are higher and it stops
    assert taken == 3
    assert sol.x[0] == pytest.approx(0.0, abs=1e-6)
    assert sol.cost < stuck.cost
    assert sol.nfev > stuck.nfev  # the evaluations of all restarts are counted


def test_restart_count_is_limited():
    stuck = _solve([0.2])
    sol, taken = _restart_from_probes(_Prob(0.075), stuck, _solve, _cost, n=2)
    assert taken == 2
    assert sol.x[0] == pytest.approx(0.075, abs=2e-3)


def test_no_restart_at_the_global_minimum():
    best = _solve([0.01])
    assert abs(best.x[0]) < 1e-6
    sol, taken = _restart_from_probes(_Prob(0.03), best, _solve, _cost)
    assert taken == 0
    assert sol is best


# ----------------------------------------------------------------------------- valley scan
class _Linear:
    """A linear residual r = A θ − b: the cost is an exact quadratic with a correlated valley."""

    def __init__(self, A: np.ndarray, b: np.ndarray) -> None:
        self.A, self.b = A, b

    def values(self, theta):
        return np.asarray(theta, dtype=float)

    def simulate_many(self, sets, rtol=None):
        return [np.asarray(v) for v in sets]

    costs = _Problem.costs  # the fit's own batch of costs

    def residual_vector(self, theta):
        return self.A @ theta - self.b


def test_valley_scan_moves_along_the_profile_to_the_minimum():
    # two parameters, strongly correlated (the valley runs along θ0 ≈ θ1); minimum at (0, 0)
    A = np.array([[1.0, 1.0], [1.0, 1.02], [0.3, 0.25]])
    prob = _Linear(A, np.zeros(3))
    lo, hi = np.full(2, -5.0), np.full(2, 5.0)
    # a point 0.2 along parameter 0's valley direction from the minimum, where the other
    # parameter is at its best given θ0 (so a coordinate step cannot improve it much)
    Hinv = np.linalg.inv(A.T @ A)
    d = Hinv[:, 0] / Hinv[0, 0]
    start = 0.2 * d
    best, n = _scan(prob, start, A, lo, hi)
    assert n == 5  # the point and four steps
    np.testing.assert_allclose(best, 0.0, atol=1e-12)
    # from the minimum the scan stays
    best0, _ = _scan(prob, np.zeros(2), A, lo, hi)
    np.testing.assert_allclose(best0, 0.0, atol=0)


def _scan(prob, theta, J, lo, hi):
    return _valley_scan(prob, theta, J, [0], lo, hi, _cost)


def test_valley_scan_without_stick_parameters_does_nothing():
    prob = _Linear(np.eye(2), np.ones(2))
    theta = np.array([0.3, -0.1])
    best, n = _valley_scan(prob, theta, np.eye(2), [], -np.ones(2), np.ones(2), _cost)
    assert n == 0 and best is theta
