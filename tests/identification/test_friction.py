"""Stribeck friction (Sec. VI-C, Eqs. (10)–(11), Fig. 8)."""

from __future__ import annotations

import numpy as np
import pytest
from ident_support import FS, stribeck_points

from hydropwa.components import stribeck_friction
from hydropwa.data import Run
from hydropwa.identification import StribeckIdentifier, fit_stribeck, friction_point
from hydropwa.params import get_preset

# Speeds of the paper's campaign: 5–50 % opening gives roughly 3–180 mm/s.
V = np.concatenate([np.linspace(0.003, 0.18, 46), -np.linspace(0.003, 0.18, 45)])

SETS = [
    dict(
        coulomb=90.0,
        static=150.0,
        viscous=1100.0,
        stribeck_velocity=0.01,
        shape=1.0,
        smoothness=1e4,
    ),
    dict(
        coulomb=50.0, static=120.0, viscous=600.0, stribeck_velocity=0.02, shape=2.0, smoothness=1e3
    ),
    dict(
        coulomb=40.0,
        static=100.0,
        viscous=800.0,
        stribeck_velocity=0.015,
        shape=1.0,
        smoothness=3e3,
    ),
]


@pytest.mark.parametrize("truth", SETS)
@pytest.mark.parametrize("seed", [0, 1])
def test_fc_fs_sigma_within_10_percent(truth, seed):
    """3 N force noise (about 2 % of the largest force)."""
    f = stribeck_points(truth, V, 3.0, seed)
    fit = fit_stribeck(V, f)
    for k in ("coulomb", "static", "viscous"):
        assert fit.estimates[k].value == pytest.approx(truth[k], rel=0.10), k
    assert fit.rms_residual < 4.5
    assert fit.friction.static >= fit.friction.coulomb


def test_smoothness_is_reported_weak_when_all_speeds_saturate_tanh():
    """|ẋ| ≥ 3 mm/s and γ = 1e4: tanh(γẋ) = 1 on every point, γ is not identifiable."""
    f = stribeck_points(SETS[0], V, 3.0, 0)
    fit = fit_stribeck(V, f)
    assert "smoothness" in fit.weak
    e = fit.estimates["smoothness"]
    assert not np.isfinite(e.std) or e.ci[1] > 2.0 * e.ci[0]


def test_robust_loss_resists_an_outlier():
    truth = SETS[1]
    f = stribeck_points(truth, V, 2.0, 4)
    f[10] += 400.0
    fit = fit_stribeck(V, f)
    assert fit.estimates["viscous"].value == pytest.approx(truth["viscous"], rel=0.05)
    assert abs(fit.residuals[10]) > 300


def test_fixed_shape():
    truth = SETS[0]
    fit = fit_stribeck(V, stribeck_points(truth, V, 2.0, 5), fixed={"shape": 1.0})
    assert fit.friction.shape == 1.0 and "shape" not in fit.free
    assert fit.friction.static == pytest.approx(150.0, rel=0.1)


def _friction_run(name, level, v, fr, area_a, area_b, stroke=0.2, seed=0, duration=None):
    """Constant input against a 2 kN counter force; pressures with a start transient."""
    rng = np.random.default_rng(seed)
    duration = duration or min(0.9 * stroke / abs(v), 3.0)
    t = np.arange(0.0, duration, 1 / FS)
    x0 = 0.0 if v > 0 else stroke
    x = np.clip(x0 + v * t, 0, stroke) + 2e-5 * rng.standard_normal(t.size)
    f = stribeck_friction(
        v, fr.coulomb, fr.static, fr.viscous, fr.stribeck_velocity, fr.shape, fr.smoothness
    )
    f_l = 2000.0 * np.sign(v) + 5.0 * rng.standard_normal(t.size)
    net = f + 2000.0 * np.sign(v)  # P_A A_A − P_B A_B at steady state, Eq. (10)
    low = 10e5 + 2e4 * rng.standard_normal(t.size)
    transient = 5e5 * np.exp(-t / 0.02)
    if net >= 0:  # extending: A drives
        p_b = low
        p_a = (net + p_b * area_b) / area_a + transient + 2e4 * rng.standard_normal(t.size)
    else:
        p_a = low
        p_b = (p_a * area_a - net) / area_b + transient + 2e4 * rng.standard_normal(t.size)
    return Run(
        name,
        {"t": t, "x": x, "p_a": p_a, "p_b": p_b, "f_l": f_l, "u": np.full(t.size, level)},
        fs=FS,
        meta={"experiment": "friction", "signal": {"type": "constant", "level": level}},
    )


def test_friction_point_averages_the_steady_part():
    p = get_preset("paper")
    fr = p.friction
    run = _friction_run("r", 0.2, 0.05, fr, p.cylinder.area_a, p.cylinder.area_b)
    pt = friction_point(
        run["t"],
        run["x"],
        run["p_a"],
        run["p_b"],
        run["f_l"],
        p.cylinder.area_a,
        p.cylinder.area_b,
        p.cylinder.stroke,
    )
    f_true = stribeck_friction(
        0.05, fr.coulomb, fr.static, fr.viscous, fr.stribeck_velocity, fr.shape, fr.smoothness
    )
    assert pt.velocity == pytest.approx(0.05, rel=1e-3)
    assert pt.force == pytest.approx(f_true, abs=3.0)
    assert pt.window[0] > 0.05  # the pressure transient is left out


def test_identifier_on_runs_recovers_the_preset_curve():
    p = get_preset("paper")
    fr = p.friction
    speeds = np.concatenate([np.linspace(0.004, 0.17, 16), -np.linspace(0.004, 0.17, 16)])
    runs = [
        _friction_run(
            f"fr_{i:02d}",
            float(np.sign(v) * 0.1),
            float(v),
            fr,
            p.cylinder.area_a,
            p.cylinder.area_b,
            seed=i,
        )
        for i, v in enumerate(speeds)
    ]
    ident = StribeckIdentifier(p).fit(runs)
    assert ident.skipped_ == []
    vv = np.linspace(0.005, 0.17, 50)
    model = stribeck_friction(
        vv, fr.coulomb, fr.static, fr.viscous, fr.stribeck_velocity, fr.shape, fr.smoothness
    )
    assert np.max(np.abs(ident.fit_.force_at(vv) - model)) < 5.0
    assert ident.friction_.static == pytest.approx(fr.static, rel=0.1)


def test_oscillating_run_is_flagged():
    """A limit cycle (force swinging ±100 N at 40 Hz) is marked and noted, not hidden."""
    p = get_preset("paper")
    speeds = np.concatenate([np.linspace(0.02, 0.17, 6), -np.linspace(0.02, 0.17, 6)])
    runs = [
        _friction_run(
            f"fr_{i}",
            0.1,
            float(v),
            p.friction,
            p.cylinder.area_a,
            p.cylinder.area_b,
            seed=i,
            duration=1.0,
        )
        for i, v in enumerate(speeds)
    ]
    t = runs[0]["t"]
    p_a = runs[0]["p_a"] + 100.0 / p.cylinder.area_a * np.sin(2 * np.pi * 40.0 * t)
    runs[0] = runs[0].replace(channels={**runs[0].channels, "p_a": p_a})
    ident = StribeckIdentifier(p).fit(runs)
    flagged = ident.points_.set_index("run")["oscillating"]
    assert flagged["fr_0"] and flagged.sum() == 1
    assert ident.notes_ and "oscillate" in ident.notes_[0]
