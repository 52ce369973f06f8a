"""Parameter objects, TOML files with units, presets and the Table V recovery."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hydropwa import (
    Cylinder,
    Friction,
    ParameterError,
    SystemParams,
    flow_coefficient_from_rating,
    get_preset,
    load_params,
    save_params,
)
from hydropwa.components import stribeck_friction
from hydropwa.params import (
    params_from_dict,
    recover_stribeck_from_table_v,
    table_v_friction,
    table_v_pwa,
)
from hydropwa.params._paper import TABLE_V_RMS_RESIDUAL, TABLE_V_STRIBECK


def test_flow_coefficient_from_rating_matches_table_iii():
    # 40 L/min at 70 bar is the paper's K = 0.252e-6 m³/(s·√Pa) (docs/errata.md E9), 3 digits printed.
    K = flow_coefficient_from_rating(40e-3 / 60, 70e5)
    assert K == pytest.approx(0.252e-6, rel=1e-3)


def test_validation_names_field_value_and_unit():
    with pytest.raises(ParameterError, match=r"Cylinder.area_a = -1 m² must be greater than 0"):
        Cylinder(area_a=-1.0)
    with pytest.raises(
        ParameterError, match=r"Friction.static = 10 N must be at least Friction.coulomb = 20 N"
    ):
        Friction(coulomb=20.0, static=10.0)
    with pytest.raises(ParameterError, match="not finite"):
        Cylinder(stroke=math.nan)


def test_implausible_dead_volume_warns_with_hint():
    with pytest.warns(UserWarning, match=r"did you mean 0.7 L"):
        Cylinder(dead_volume_a=0.7)


def test_toml_round_trip_is_exact(tmp_path, paper):
    path = save_params(paper, tmp_path / "p.toml")
    back = load_params(path)
    assert back == paper


def test_toml_units_are_converted_to_si():
    p = params_from_dict(
        {
            "supply": {"pressure": "95 bar"},
            "flow": {"rating": {"flow": "40 L/min", "pressure_drop": "70 bar"}},
            "cylinder": {"dead_volume_a": "0.7 L", "stroke": "200 mm"},
            "dead_zone": {"beta": "10 %"},
            "valve": {"omega0_table": [["10 %", "130 Hz"]]},
        }
    )
    assert p.supply.pressure == pytest.approx(95e5)
    assert p.flow.K == pytest.approx(40e-3 / 60 / math.sqrt(70e5))
    assert p.cylinder.dead_volume_a == pytest.approx(0.7e-3)
    assert p.cylinder.stroke == pytest.approx(0.2)
    assert p.dead_zone.beta == pytest.approx(0.1)
    assert p.valve.omega0_table[0][1] == pytest.approx(2 * math.pi * 130)


@pytest.mark.parametrize(
    "data, message",
    [
        ({"supply": {"pressure": "95 kg"}}, "wrong dimension"),
        ({"supply": {"presure": 1e7}}, "unknown field"),
        ({"pump": {}}, "unknown section"),
        ({"supply": {"pressure": "lots"}}, "cannot be read"),
        ({"load": {"mass": -1}}, "Load.mass = -1 kg"),
    ],
)
def test_bad_toml_values_raise_one_clear_error(data, message):
    with pytest.raises(ParameterError, match=message):
        params_from_dict(data, "test.toml")


def test_bad_toml_file(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[supply\npressure = 3")
    with pytest.raises(ParameterError, match="invalid TOML"):
        load_params(bad)
    with pytest.raises(ParameterError, match="not found"):
        load_params(tmp_path / "missing.toml")


def test_paper_preset_holds_tables_ii_iii_iv(paper):
    assert paper.valve.omega0_at(0.10) == pytest.approx(816.8)
    assert paper.valve.omega0_at(0.25) == pytest.approx(628.3)
    assert paper.valve.omega0_at(0.90) == pytest.approx(220.0)
    assert paper.valve.zeta == 0.7
    assert paper.cylinder.area_a == 1.3e-3 and paper.cylinder.area_b == 0.76e-3
    assert paper.cylinder.dead_volume_a == 0.7e-3  # 0.7 L, docs/errata.md E2
    assert paper.load.mass == 1.394 and paper.oil.bulk_modulus == 1e9
    assert (paper.dead_zone.alpha, paper.dead_zone.beta, paper.dead_zone.creep_slope) == (
        1.0,
        0.1,
        0.04,
    )


def test_table_v_breakpoints_are_consistent():
    # With the middle slope read as 1.833e5 (docs/errata.md E8) neighbouring lines meet at
    # about ±0.8, ±14.5 and ±54 mm/s, in increasing order.
    b = table_v_pwa().breakpoints * 1e3
    np.testing.assert_allclose(np.abs(b), [54.4, 14.5, 0.785, 0.785, 14.6, 54.3], rtol=0.01)


def test_stribeck_recovery_reproduces_table_v_within_5_newton():
    rec = recover_stribeck_from_table_v()
    f = rec.friction
    assert rec.rms_residual < 5.0
    # regenerate the curve independently of the fit residual
    v = rec.velocities
    model = stribeck_friction(
        v, f.coulomb, f.static, f.viscous, f.stribeck_velocity, f.shape, f.smoothness
    )
    assert np.sqrt(np.mean((model - table_v_pwa()(v)) ** 2)) == pytest.approx(
        rec.rms_residual, rel=1e-6
    )
    assert 0 < f.coulomb < f.static
    assert f.viscous == pytest.approx(1105, rel=0.1)  # the outer cells' slope


def test_paper_preset_friction_is_the_table_v_fit():
    # the preset stores the fit's result; a change of the fit (or of scipy's optimum) must show
    # here. rel 1e-6: least_squares stops at xtol 1e-8 relative, far inside this
    rec = recover_stribeck_from_table_v()
    f = rec.friction
    fit = (f.coulomb, f.static, f.viscous, f.stribeck_velocity, f.shape, f.smoothness)
    np.testing.assert_allclose(TABLE_V_STRIBECK, fit, rtol=1e-6)
    assert TABLE_V_RMS_RESIDUAL == pytest.approx(rec.rms_residual, rel=1e-6)
    assert get_preset("paper").friction == table_v_friction()


def test_replace_with_dotted_names(paper):
    q = paper.replace(**{"supply.pressure": 80e5, "load.mass": 2.0})
    assert q.supply.pressure == 80e5 and q.load.mass == 2.0 and q.cylinder == paper.cylinder
    with pytest.raises(ParameterError, match="unknown parameter supply.presure"):
        paper.replace(**{"supply.presure": 1.0})


@settings(max_examples=50, deadline=None)
@given(
    p=st.floats(1e5, 3.5e7),
    mass=st.floats(0.1, 1e3),
    area=st.floats(5e-5, 1e-2),
)
def test_toml_round_trip_property(tmp_path_factory, p, mass, area):
    params = SystemParams().replace(
        **{
            "supply.pressure": p,
            "load.mass": mass,
            "cylinder.area_a": area,
            "cylinder.area_b": 0.6 * area,
        }
    )
    path = save_params(params, tmp_path_factory.mktemp("t") / "p.toml")
    assert load_params(path) == params


def test_preset_unknown():
    with pytest.raises(ParameterError, match="unknown preset"):
        get_preset("nope")
