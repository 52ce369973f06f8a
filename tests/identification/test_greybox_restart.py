"""The restart from a lower difference point (``_restart_from_probes``, issue 19).

On a rough cost the trust region shrinks on a ridge and ``least_squares`` stops with ``xtol``
though a central-difference point beside it is lower. These tests drive the restart with a
one-parameter residual whose cost has a spurious local minimum, and check that it moves only
downhill.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import optimize

from hydropwa.identification._greybox import _restart_from_probes


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
