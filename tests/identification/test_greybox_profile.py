"""Profile-likelihood intervals of the grey-box fit (greybox/profile.py, issue 36).

On residuals with known profiles: a linear one (the profile is the quadratic, its interval
the Wald interval θ ± z·σ), a saturating one (the cost rises to a plateau below the
threshold: the profile walks to ×/÷ 20 and the parameter is not determined there), and
the interpolated crossing of a piecewise-linear statistic (exact).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from hydropwa.identification.greybox.profile import REACH, ProfileTask, crossing, profile

Z = 1.959963984540054


def _task(prob, theta, i, lo, hi, sd):
    """Linear loss, unit scale, optimum cost 0, no variance correction (κ = 1)."""
    return ProfileTask(
        prob=prob, theta=theta, index=i, tlo=lo, thi=hi, loss="linear", f_scale=1.0,
        cost0=0.0, kappa=1.0, z=Z, sd=sd,
    )  # fmt: skip


class _Residuals:
    """r(θ) = f(θ) for the profile: values are ref·exp(θ), one residual vector per θ."""

    def __init__(self, f, p):
        self.f, self.ref, self.free, self.fd_step = f, np.ones(p), [f"p{k}" for k in range(p)], 1e-4

    def fun(self, theta):
        return np.asarray(self.f(np.asarray(theta, dtype=float)), dtype=float)

    def jac(self, theta, step, r0=None, central=False):
        """Forward differences, as the output-error objective takes them."""
        r0 = self.fun(theta) if r0 is None else r0
        cols = []
        for j in range(theta.size):
            e = np.zeros(theta.size)
            e[j] = step
            cols.append((self.fun(theta + e) - r0) / step)
        return np.column_stack(cols)


def test_a_linear_model_profiles_to_the_wald_interval():
    """r = (θ0 − 0.2)/s0, (θ0 + θ1 − 0.1)/s1: θ0's profile, θ1 refitted, is ((θ0−0.2)/s0)²,
    its interval 0.2 ± z·s0 (the refit's tolerance and the interpolation: 1e-3 of s0)."""
    s0, s1 = 0.05, 0.02
    prob = _Residuals(lambda t: [(t[0] - 0.2) / s0, (t[0] + t[1] - 0.1) / s1], 2)
    theta = np.array([0.2, -0.1])
    lo, hi = np.full(2, -5.0), np.full(2, 5.0)
    p = profile(_task(prob, theta, 0, lo, hi, s0))
    assert math.log(p.ci[0]) == pytest.approx(0.2 - Z * s0, abs=1e-3 * s0 * 10)
    assert math.log(p.ci[1]) == pytest.approx(0.2 + Z * s0, abs=1e-3 * s0 * 10)
    assert p.cost.max() > Z**2  # the grid reaches beyond the threshold on both sides


def test_a_parameter_the_data_do_not_limit_is_walked_to_its_reach():
    """r1 = 0.5·tanh(θ1 − 0.3): the cost rises to 0.125·2 = 0.25 < z² and stays there; the
    profile walks to ×/÷ 20 on both sides and its interval is that reach, not a narrow one."""
    prob = _Residuals(lambda t: [(t[0] - 0.2) / 0.05, 0.5 * math.tanh((t[1] - 0.3) / 0.01)], 2)
    theta = np.array([0.2, 0.3])
    lo, hi = np.full(2, -10.0), np.full(2, 10.0)
    p = profile(_task(prob, theta, 1, lo, hi, 0.01))
    assert p.cost.max() < Z**2
    assert math.log(p.values[0]) == pytest.approx(0.3 - REACH)
    assert math.log(p.values[-1]) == pytest.approx(0.3 + REACH)
    assert math.log(p.ci[0]) == pytest.approx(0.3 - REACH) and math.log(p.ci[1]) == pytest.approx(
        0.3 + REACH
    )
    # a bound nearer than the reach ends the walk there
    p = profile(_task(prob, theta, 1, lo, np.array([10.0, 1.0]), 0.01))
    assert math.log(p.values[-1]) == pytest.approx(1.0) and p.cost[-1] < Z**2


def test_the_crossing_is_interpolated_between_grid_points():
    grid = np.array([-2.0, -1.0, 0.0, 1.0, 2.0])
    q = np.array([9.0, 3.0, 0.0, 1.0, 5.0])  # level 4: at −1 − 1/6 and at 1 + 3/4
    lo, hi = crossing(grid, q, 0.0, 4.0, 2.0)
    assert lo == pytest.approx(2.0 * math.exp(-1.0 - 1.0 / 6.0))
    assert hi == pytest.approx(2.0 * math.exp(1.75))
    assert all(math.isnan(c) for c in crossing(grid, q + 5.0, 0.0, 4.0, 1.0))
