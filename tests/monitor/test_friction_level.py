"""The friction level's healthy interval: exact, because Eq. (11) is linear in (F_c, F_s, σ).

Independent truth: a noise-free row set whose friction force is the Stribeck curve of another
machine θ' (the component function, not the monitor's basis); the one-unknown least squares
:func:`friction_scale_fit` must read s = Σ_j θ'_j g_j with the weights of
:func:`friction_level_weights`, and the weights must give 1 at the identified θ.
"""

from __future__ import annotations

import numpy as np
import pytest

from hydropwa.components import stribeck_friction
from hydropwa.monitor import HealthMonitor
from hydropwa.monitor._indicators import INDICATORS
from hydropwa.monitor._residuals import Signals, friction_level_weights, friction_scale_fit
from hydropwa.params import get_preset


def _rows(params, force: np.ndarray, v: np.ndarray) -> Signals:
    """Rows where A_A P_A − A_B P_B − f_l − m ẍ is ``force`` (P_B = 0, ẍ = 0, f_l = 0)."""
    n = v.size
    z = np.zeros(n)
    return Signals(
        t=np.arange(n) * 1e-3, u=z, nu=z, nu_model=z, x=np.full(n, 0.1), v=v, a=z,
        p_a=force / params.cylinder.area_a, p_b=z, dp_a=z, dp_b=z, p_s=None, f_l=z,
        measured_supply=False, measured_spool=False, speed_noise=1e-4,
    )  # fmt: skip


@pytest.mark.parametrize("scale", [(1.0, 1.0, 1.0), (1.055, 0.99, 1.007), (0.9, 1.2, 0.95)])
def test_the_level_of_another_machine_is_the_weighted_sum(scale):
    p = get_preset("paper")
    fr = p.friction
    v = np.concatenate([np.linspace(0.012, 0.2, 300), -np.linspace(0.015, 0.08, 200)])
    theta = np.array([fr.coulomb, fr.static, fr.viscous]) * np.array(scale)
    force = stribeck_friction(
        v, *theta, fr.stribeck_velocity, fr.shape, fr.smoothness
    )  # fmt: skip
    sig = _rows(p, force, v)
    mask = np.ones(v.size, bool)
    g = friction_level_weights(sig, p, mask)
    s = float(friction_scale_fit(sig, p, mask).theta[0])
    # both are ratios of the same sums over the same rows: equal to rounding
    assert s == pytest.approx(float(theta @ g), rel=1e-12)
    assert float(np.array([fr.coulomb, fr.static, fr.viscous]) @ g) == pytest.approx(1.0, rel=1e-12)


def test_the_healthy_interval_spans_the_weighted_ends():
    p = get_preset("paper")
    fr = p.friction
    mon = HealthMonitor(
        intervals={"friction.coulomb": (20.0, 23.0), "friction.static": (170.0, 180.0)}
    ).fit(p)
    v = np.linspace(0.012, 0.2, 300)
    sig = _rows(p, stribeck_friction(v, fr.coulomb, fr.static, fr.viscous, fr.stribeck_velocity,
                                     fr.shape, fr.smoothness), v)  # fmt: skip
    g = friction_level_weights(sig, p, np.ones(v.size, bool))
    (ind,) = [i for i in INDICATORS if i.name == "friction_scale"]
    lo, hi = mon._healthy(ind, g)
    sl, sh = mon.intervals_["friction.viscous"][0]
    assert lo == pytest.approx(20.0 * g[0] + 170.0 * g[1] + sl * g[2], rel=1e-12)
    assert hi == pytest.approx(23.0 * g[0] + 180.0 * g[1] + sh * g[2], rel=1e-12)
    assert lo < 1.0 < hi
