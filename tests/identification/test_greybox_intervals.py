"""The interval scan of the grey-box fit (``_interval_scan``) on costs with known profiles.

A quadratic cost ½θᵀAθ whose curvature A differs from the Gauss–Newton one (H) by a factor
c along the valley has the exact profile interval z·σ/√c: the scan must find it where the
cost is flatter (c < 1, up to the scanned range), never narrow the interval where it is
steeper (c ≥ 1), and simulate at a tenth of the fit's tolerance.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hydropwa.identification.greybox.intervals import interval_scan as _interval_scan
from hydropwa.identification.greybox.objective import OutputErrorObjective as _Problem

Z = 1.959963984540054  # 95 %


class _Quadratic:
    """Stands in for the fit's problem: θ are the values, residuals Lᵀθ with L Lᵀ = A."""

    def __init__(self, A: np.ndarray, rtol: float = 1e-5):
        self.L = np.linalg.cholesky(A)
        self.rtol = rtol
        self.rtols_seen: list[float | None] = []

    def values(self, theta):
        return np.asarray(theta, dtype=float)

    def simulate_many(self, sets, rtol=None):
        self.rtols_seen.append(rtol)
        return [np.asarray(v, dtype=float) for v in sets]

    costs = _Problem.costs  # the fit's own batch of costs

    def residual_vector(self, sim):
        return self.L.T @ sim


def _cost(r):
    return 0.5 * float(r @ r)


def _scan(A, H, sd, bounds=50.0, **kw):
    p = A.shape[0]
    Hinv = np.linalg.inv(H)
    kappa = sd**2 / np.diag(Hinv)
    prob = _Quadratic(A)
    lo, hi, scan = _interval_scan(
        prob,
        np.zeros(p),
        Hinv,
        sd,
        kappa,
        Z,
        (np.full(p, -bounds), np.full(p, bounds)),
        _cost,
        **kw,
    )
    return prob, lo, hi, scan


@settings(max_examples=60, deadline=None)
@given(c=st.floats(0.25, 4.0), rho=st.floats(-0.95, 0.95), infl=st.floats(1.0, 30.0))
def test_flatter_cost_gives_the_profile_interval_steeper_keeps_wald(c, rho, infl):
    """A = c·H (the valley the same): the profile interval is z·σ/√c (exact for c ≥ 1/4,
    i.e. up to the scanned 2z·σ); a steeper cost (c > 1) keeps the Wald z·σ. ``infl`` is the
    sandwich inflation κ (σ² = κ·(H⁻¹)_ii), which the statistic q = 2Δcost/κ divides out."""
    H = np.array([[4.0, 2.0 * rho * 3.0], [2.0 * rho * 3.0, 9.0]]) * 1e2
    sd = np.sqrt(infl * np.diag(np.linalg.inv(H)))
    _prob, lo, hi, scan = _scan(c * H, H, sd)
    want = Z * sd / math.sqrt(min(c, 1.0))
    # 1e-6: at c = 1/4 (q = z²) the branch beyond the scan takes √(z² − q) of a roundoff
    np.testing.assert_allclose(lo, want, rtol=1e-6)
    np.testing.assert_allclose(hi, want, rtol=1e-6)
    for i in range(2):  # the quadratic's statistic at 2z·σ is c·(2z)²
        np.testing.assert_allclose(scan[i], (c * 4 * Z**2,) * 2, rtol=1e-9)


def test_flat_side_ends_beyond_the_scan_and_sides_are_separate():
    """A side flatter than 1/4 of the quadratic ends beyond 2z·σ with the quadratic's
    curvature from there (a bound on what the scan saw); a cost lower at the scanned point
    than at the estimate (q < 0) ends at 3z·σ. The other side is unchanged."""
    sd = np.array([0.1])
    H = np.array([[1.0 / sd[0] ** 2]])

    class Kinked(_Quadratic):
        def residual_vector(self, sim):
            t = float(sim[0]) / sd[0]
            return np.array([t if t > 0 else math.sqrt(self.a) * t])

    for a, want_lo in ((0.1, 2 * Z + Z * math.sqrt(1 - 0.4)), (0.0, 3 * Z)):
        prob = Kinked(np.eye(1))
        prob.a = a
        lo, hi, scan = _interval_scan(
            prob, np.zeros(1), np.linalg.inv(H), sd, np.ones(1), Z, (-np.ones(1), np.ones(1)), _cost
        )
        assert scan[0][0] == pytest.approx(a * 4 * Z**2)
        assert lo[0] == pytest.approx(want_lo * sd[0], rel=1e-9)
        assert hi[0] == pytest.approx(Z * sd[0], rel=1e-9)


def test_scan_runs_at_a_tenth_of_the_tolerance():
    """One batch (the estimate and the scanned points) at rtol/10; the problem's own rtol and
    its cached residuals are left alone."""
    H = np.diag([1e4, 1e2])
    prob, *_ = _scan(0.5 * H, H, np.sqrt(np.diag(np.linalg.inv(H))))
    assert prob.rtols_seen == [pytest.approx(1e-6)]
    assert prob.rtol == 1e-5


def test_narrow_intervals_and_points_outside_the_bounds_are_not_scanned():
    """σ below the jitter threshold (z·σ < 1 % in ln p) or a point outside the bounds: the
    Wald half-width stays and q is NaN for that side."""
    H = np.diag([1.0 / 0.001**2, 1.0 / 0.1**2])
    sd = np.sqrt(np.diag(np.linalg.inv(H)))
    prob, lo, hi, scan = _scan(0.1 * H, H, sd, bounds=0.3)  # 2z·0.1 = 0.39 > 0.3
    assert 0 not in scan
    assert np.isnan(scan[1][0]) and np.isnan(scan[1][1])
    np.testing.assert_allclose(lo, Z * sd)
    np.testing.assert_allclose(hi, Z * sd)


@settings(max_examples=40, deadline=None)
@given(c=st.floats(0.02, 2.0), rho=st.floats(-0.99, 0.99))
def test_points_on_another_valley_widen_a_parameter_they_fall_inside_for(c, rho):
    """Parameter 1 is too narrow to scan (z·σ₁ < 0.2 %) and correlated (ρ) with parameter 0,
    whose valley is scanned: the scanned points move parameter 1 by ±2z·ρ·σ₁ (its regression on
    parameter 0). Where those points are inside the region (q = 4z²c ≤ z², the same κ for
    both), parameter 1's interval reaches them; otherwise it keeps its Wald z·σ₁."""
    sd = np.array([0.05, 0.0005])
    cov = np.array([[sd[0] ** 2, rho * sd[0] * sd[1]], [rho * sd[0] * sd[1], sd[1] ** 2]])
    H = np.linalg.inv(cov)
    _prob, lo, hi, scan = _scan(c * H, H, sd)
    assert 1 not in scan
    reach = 2 * Z * abs(rho) * sd[1] if 4 * c <= 1 else 0.0
    want = max(Z * sd[1], reach)
    assert lo[1] == pytest.approx(want, rel=1e-9) and hi[1] == pytest.approx(want, rel=1e-9)


def test_an_optimum_at_a_bound_is_reported_as_not_determined():
    """Issue 36 item 3: a leakage fitted to its lower bound (a tight cylinder) has an
    interval that reaches that bound and an infinite standard error, and the side the data
    do bound is kept; a parameter inside its bounds keeps its interval."""
    import types

    from hydropwa.identification._common import ParameterEstimate
    from hydropwa.identification.greybox.estimator import _bounded
    from hydropwa.identification.greybox.problem import GreyBoxProblem
    from hydropwa.params import get_preset

    names = ("cylinder.leakage", "flow.K")
    problem = GreyBoxProblem.build(names, get_preset("paper"))
    tlo, _thi = problem.theta_bounds
    theta = np.array([tlo[0], 0.0])  # the leakage at its lower bound, K at its start
    values = problem.ref * np.exp(theta)
    est = types.SimpleNamespace(
        problem=problem, theta=theta, at_bound=["cylinder.leakage"],
        estimates={
            n: ParameterEstimate(float(v), 0.01 * float(v), (0.99 * v, 1.01 * v))
            for n, v in zip(names, values, strict=True)
        },
    )  # fmt: skip
    assert _bounded(est, []) == ["cylinder.leakage"]
    leak = est.estimates["cylinder.leakage"]
    assert math.isinf(leak.std)
    assert leak.ci == (pytest.approx(problem.lower[0]), pytest.approx(1.01 * values[0]))
    assert est.estimates["flow.K"].ci == (0.99 * values[1], 1.01 * values[1])
    # already undetermined (bounds as its interval): left alone
    assert _bounded(est, ["cylinder.leakage"]) == []
