"""The estimators' shape: no hidden rig, strategy objects, learned values, apply, optimiser status."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from ident_support import constant_input_runs, hinge_velocity, stepped_sine_runs
from test_pipeline_cli import _campaign

from hydropwa._errors import IdentificationError, ParameterError
from hydropwa.identification import (
    BreakawayConstrained,
    DeadZoneIdentifier,
    IdentificationWarning,
    InstantaneousBins,
    OptimizerStatus,
    ParameterEstimate,
    RigGeometry,
    SteadyStateAverage,
    StribeckIdentifier,
    ValveFrfIdentifier,
    fit_dead_zone,
    fit_stribeck,
    identify,
)
from hydropwa.identification._friction import STRIBECK_NAMES
from hydropwa.params import get_preset

LEVELS = np.concatenate([np.arange(0.01, 0.2001, 0.01), -np.arange(0.01, 0.2001, 0.01)])


# ------------------------------------------------------------------ no hidden rig


@pytest.mark.parametrize("cls", [StribeckIdentifier, DeadZoneIdentifier])
def test_no_default_rig(cls):
    """Without params or geometry there is no rig to read areas or stroke from: one clear error."""
    with pytest.raises(ParameterError, match=r"needs the rig's .*params=.*geometry=RigGeometry"):
        cls()


def test_identify_needs_params():
    runs = constant_input_runs(LEVELS, lambda u: hinge_velocity(u, 0.1, 0.5, 0.02), duration=1.0)
    with pytest.raises(ParameterError, match=r"record no machine.*params=get_preset\('paper'\)"):
        identify(runs, ["deadzone"])


def test_geometry_must_hold_what_the_method_reads():
    # the steady-state average reads areas and stroke, not the mass
    StribeckIdentifier(geometry=RigGeometry(stroke=0.2, area_a=2e-3, area_b=1e-3))
    # the per-sample forces subtract m·ẍ: the mass is required
    with pytest.raises(ParameterError, match=r"RigGeometry\.mass"):
        StribeckIdentifier(
            geometry=RigGeometry(stroke=0.2, area_a=2e-3, area_b=1e-3), method=InstantaneousBins()
        )
    with pytest.raises(ParameterError, match=r"RigGeometry\.area_a, area_b"):
        StribeckIdentifier(geometry=RigGeometry(stroke=0.2))
    # the break-away constraint holds γ at a value someone must give
    with pytest.raises(ParameterError, match="smoothness"):
        StribeckIdentifier(
            geometry=RigGeometry(stroke=0.2, area_a=2e-3, area_b=1e-3, mass=20.0),
            method=BreakawayConstrained(),
        )
    StribeckIdentifier(
        geometry=RigGeometry(stroke=0.2, area_a=2e-3, area_b=1e-3, mass=20.0),
        method=BreakawayConstrained(smoothness=1e4),
    )
    with pytest.raises(ParameterError, match=r"RigGeometry\.stroke"):
        RigGeometry(stroke=-0.2)


def test_geometry_of_params_is_what_the_estimator_reads():
    p = get_preset("paper")
    g = RigGeometry.of(p)
    assert (g.stroke, g.area_a, g.area_b, g.mass) == (
        p.cylinder.stroke,
        p.cylinder.area_a,
        p.cylinder.area_b,
        p.load.mass,
    )
    assert StribeckIdentifier(p).geometry == g
    # an explicit geometry wins over the params'
    g2 = RigGeometry(stroke=0.5)
    assert DeadZoneIdentifier(p, geometry=g2).geometry.stroke == 0.5


# ------------------------------------------------------------------ strategy objects


def test_strategies_are_frozen_and_validated():
    s = SteadyStateAverage(window=0.2)
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.window = 0.3  # type: ignore[misc]
    with pytest.raises(ParameterError, match=r"SteadyStateAverage\.window = -0\.1"):
        SteadyStateAverage(window=-0.1)
    with pytest.raises(ParameterError, match=r"InstantaneousBins\.taps"):
        InstantaneousBins(taps=0)
    with pytest.raises(ParameterError, match="SteadyStateAverage.*InstantaneousBins"):
        BreakawayConstrained(points="average")  # type: ignore[arg-type]
    assert BreakawayConstrained().points == InstantaneousBins()
    assert {SteadyStateAverage.name, InstantaneousBins.name, BreakawayConstrained.name} == {
        "average",
        "instantaneous",
        "breakaway",
    }


def test_a_method_string_is_refused_with_the_classes_to_use():
    with pytest.raises(ParameterError, match=r"SteadyStateAverage\(\), InstantaneousBins\(\)"):
        StribeckIdentifier(get_preset("paper"), method="average")  # type: ignore[arg-type]


# ------------------------------------------------------------------ fit, learned values, status


def _status_ok(st):
    assert isinstance(st, OptimizerStatus)
    assert st.success and st.message and st.nfev > 0


def test_dead_zone_learned_values_apply_and_status():
    p = get_preset("paper")
    runs = constant_input_runs(LEVELS, lambda u: hinge_velocity(u, 0.1, 0.5, 0.02), duration=1.0)
    est = DeadZoneIdentifier(p)
    with pytest.raises(IdentificationError, match="not fitted"):
        est.apply(p)
    assert est.fit(runs) is est
    assert est.beta_ is est.fit_.beta and est.creep_slope_ is est.fit_.creep_slope
    assert est.beta_.value == pytest.approx(0.1, abs=0.005)
    _status_ok(est.status_)
    # the split search: one linear solve per split of the 20 + 20 levels (19·19 splits)
    assert est.status_.nfev == 19 * 19
    out = est.apply(p)
    assert out.dead_zone == est.fit_.dead_zone(p.dead_zone.alpha)
    assert out.replace(dead_zone=p.dead_zone) == p  # nothing else changed
    assert est.uncertainty()["beta"]["value"] == est.beta_.value


def test_valve_learned_values_and_status():
    runs = stepped_sine_runs({0.1: 816.8, 0.9: 220.0}, noise=0.01, seed=0, step=10.0)
    est = ValveFrfIdentifier().fit(runs)
    assert est.omega0_.value == est.valve_.omega0
    assert est.zeta_.value == est.valve_.zeta
    for fit in est.fits_.values():
        _status_ok(fit.status)
    _status_ok(est.status_)
    assert est.status_.nfev == sum(f.status.nfev for f in est.fits_.values())
    p = get_preset("paper")
    assert est.apply(p).valve == est.valve_
    assert est.uncertainty()["optimizer"]["nfev"] == est.status_.nfev


def test_numpy_level_fits_carry_their_status():
    rng = np.random.default_rng(1)
    u = np.concatenate([np.linspace(0.02, 0.2, 10), -np.linspace(0.02, 0.2, 10)])
    v = hinge_velocity(u, 0.08, 0.5, 0.02) + 1e-4 * rng.standard_normal(u.size)
    _status_ok(fit_dead_zone(u, v).status)
    fr = get_preset("paper").friction
    vv = np.concatenate([np.geomspace(0.003, 0.2, 12), -np.geomspace(0.003, 0.2, 12)])
    from hydropwa.components import stribeck_friction

    f = stribeck_friction(
        vv,
        fr.coulomb,
        fr.static,
        fr.viscous,
        fr.stribeck_velocity,
        fr.shape,
        fr.smoothness,
    ) + 2.0 * rng.standard_normal(vv.size)
    st = fit_stribeck(vv, f, n_starts=4).status
    _status_ok(st)
    # 2 γ families × 4 starts, each with at least one residual evaluation, plus the robust refits
    assert st.nfev >= 8


# ------------------------------------------------------------------ identify() = the apply chain


def test_identify_is_the_apply_chain(tmp_path):
    root = _campaign(tmp_path / "data")
    p = get_preset("paper")
    fr_method = SteadyStateAverage(window=0.08)
    with pytest.warns(IdentificationWarning, match="not identified by the data"):
        rep = identify(
            root,
            params=p,
            estimators={"friction": StribeckIdentifier(p, method=fr_method, n_starts=6)},
        )
    # the same estimators fitted by hand and applied in turn
    runs = {k: [r for r in _read(root / k)] for k in ("frf", "deadzone", "friction")}
    chain = p
    for est, part in (
        (ValveFrfIdentifier(), "frf"),
        (DeadZoneIdentifier(p), "deadzone"),
        (StribeckIdentifier(p, method=fr_method, n_starts=6), "friction"),
    ):
        chain = est.fit(runs[part]).apply(chain)
    assert rep.params.replace(meta={}) == chain.replace(meta={})
    assert rep.friction is not None and rep.friction.method == fr_method
    # learned values with intervals, and each part's optimiser status in the provenance
    unidentified = rep.friction.fit_.unidentified  # χ, γ from runs at >= 4 mm/s (issue 37)
    for name in STRIBECK_NAMES:
        e = getattr(rep.friction, name + "_")
        assert isinstance(e, ParameterEstimate)
        written = getattr(rep.params.friction, name)
        expect = getattr(p.friction, name) if name in unidentified else e.value
        assert written == pytest.approx(expect)
    ident = rep.params.meta["identification"]
    for field in ("valve", "dead_zone", "friction"):
        assert "optimiser: converged" in ident[field]
        assert rep.params.meta["uncertainty"][field] is not None
    assert rep.params.meta["uncertainty"]["friction"]["optimizer"]["success"] is True


def _read(folder):
    from hydropwa.data import read_dataset

    ds = read_dataset(folder)
    return [ds[n] for n in ds.names]


def test_identify_refuses_an_estimator_under_the_wrong_part():
    p = get_preset("paper")
    runs = constant_input_runs(LEVELS, lambda u: hinge_velocity(u, 0.1, 0.5, 0.02), duration=1.0)
    with pytest.raises(ParameterError, match=r"estimators\['frf'\] = DeadZoneIdentifier"):
        identify(runs, ["deadzone"], params=p, estimators={"frf": DeadZoneIdentifier(p)})


# ------------------------------------------------------------------ γ profile (issue 18)

#: Stribeck points of the paper rig, coverage campaign (tests/identification/test_coverage.py),
#: seed 20: one creeping run at 1.5 mm/s on the tanh corner. Before the γ profile its F_s
#: interval was 161.0 ± 0.7 N, 19σ from the truth (174.8 N).
_SEED20_V = [-0.10749519, -0.09776071, -0.08780923, -0.07763068, -0.06723438, -0.05660841,
             -0.04575522, -0.03466462, -0.02334668, -0.01181749, 0.00151009, 0.01600717,
             0.03169814, 0.04714376, 0.06233294, 0.07727005, 0.09195619, 0.10639711,
             0.12059118, 0.13453693, 0.14824614]  # fmt: skip
_SEED20_F = [-148.1374, -138.153, -127.5945, -117.212, -107.5693, -98.5344, -91.416, -87.2968,
             -88.743, -102.9931, 144.8029, 95.4014, 86.7638, 91.7029, 103.2847, 117.0165,
             131.7637, 147.1416, 162.9918, 178.1684, 193.7144]  # fmt: skip


def test_intervals_include_the_gamma_the_data_cannot_pin():
    true = get_preset("paper").friction
    v, f = np.array(_SEED20_V), np.array(_SEED20_F)
    fit = fit_stribeck(v, f)
    assert "smoothness" in fit.weak and "shape profiled" in fit.status.message
    # the true γ fits as well as the optimum by the F criterion the profile uses ...
    at_true = fit_stribeck(v, f, fixed={"smoothness": true.smoothness}, n_starts=8)
    ssr0, ssr1 = np.sum(fit.residuals**2), np.sum(at_true.residuals**2)
    assert ssr1 - ssr0 <= 3.84 * ssr0 / (v.size - 6)
    # ... so every interval holds the value of that fit, and here the truth
    for name in ("coulomb", "static", "viscous", "stribeck_velocity", "shape"):
        lo, hi = fit.estimates[name].ci
        assert lo <= getattr(at_true.friction, name) <= hi, name
        assert lo <= getattr(true, name) <= hi, name
