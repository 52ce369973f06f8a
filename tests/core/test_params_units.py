"""Quantities at the boundaries (issue 18, item 7): bare numbers, valve ratings, areas, sections."""

from __future__ import annotations

import math

import pytest

from hydropwa import ParameterError, SignalError
from hydropwa.params import (
    Cylinder,
    flow_coefficient_from_rating,
    get_preset,
    load_params,
    params_from_dict,
    save_params,
)
from hydropwa.simulation import parse_signal


@pytest.mark.parametrize(
    "section, key, value, hint",
    [
        ("supply", "pressure", 100, "did you mean 100 bar"),
        ("supply", "relief_pressure", 230, "did you mean 230 bar"),
        ("cylinder", "stroke", 500, "did you mean 500 mm"),
        ("cylinder", "area_a", 3117, "did you mean 3117 mm²"),
        ("supply", "pump_flow", 60, "did you mean 60 L/min"),
        ("oil", "bulk_modulus", 1500, "did you mean 1500 MPa"),
        ("dead_zone", "beta", 5, "did you mean 5 %"),
    ],
)
def test_implausible_bare_number_names_the_likely_unit(section, key, value, hint):
    with pytest.raises(ParameterError, match=hint):
        params_from_dict({"base": "paper", section: {key: value}}, "axis.toml")


def test_plausible_bare_si_numbers_and_units_are_taken_as_written():
    p = params_from_dict(
        {"base": "paper", "supply": {"pressure": 210e5}, "cylinder": {"stroke": "500 mm"}}
    )
    assert p.supply.pressure == 210e5 and p.cylinder.stroke == pytest.approx(0.5)
    # an explicit unit is never second-guessed, even when small
    assert (
        params_from_dict({"base": "paper", "supply": {"pressure": "50 bar"}}).supply.pressure
        == 50e5
    )


def test_valve_rating_per_valve_is_half_the_drop_per_land():
    """A whole-valve rating at 70 bar is 35 bar across each metering edge: √2 more K."""
    land = flow_coefficient_from_rating(60e-3 / 60, 70e5, per="land")
    valve = flow_coefficient_from_rating(60e-3 / 60, 70e5, per="valve")
    assert valve / land == pytest.approx(math.sqrt(2.0), rel=1e-12)
    assert valve == pytest.approx(1e-3 / math.sqrt(35e5), rel=1e-12)
    p = params_from_dict(
        {
            "base": "paper",
            "flow": {"rating": {"flow": "60 L/min", "pressure_drop": "70 bar", "per": "valve"}},
        }
    )
    assert p.flow.K == pytest.approx(valve, rel=1e-12)
    with pytest.raises(ParameterError, match="'land'.*'valve'"):
        params_from_dict(
            {"flow": {"rating": {"flow": "60 L/min", "pressure_drop": "70 bar", "per": "edge"}}}
        )
    with pytest.raises(ParameterError, match=r"did you mean 70 bar.*pressure_drop = \"70 bar\""):
        params_from_dict({"flow": {"rating": {"flow": "60 L/min", "pressure_drop": 70}}})


def test_swapped_areas_are_an_error():
    with pytest.raises(ParameterError, match="swapped"):
        Cylinder(area_a=2.1e-3, area_b=3.1e-3)
    with pytest.raises(ParameterError, match="swapped"):
        params_from_dict(
            {"base": "paper", "cylinder": {"area_a": "21 cm**2", "area_b": "31 cm**2"}}
        )


def test_file_without_base_must_give_every_section(tmp_path):
    full = save_params(get_preset("paper"), tmp_path / "full.toml")
    text = full.read_text()
    start = text.index("[friction]")
    end = text.index("[supply]")
    cut = tmp_path / "cut.toml"
    cut.write_text(text[:start] + text[end:])
    with pytest.raises(
        ParameterError, match=r"missing section\(s\) \[friction\].*base = \"paper\""
    ):
        load_params(cut)
    based = tmp_path / "based.toml"
    based.write_text('base = "paper"\n' + text[:start] + text[end:])
    assert load_params(based).friction == get_preset("paper").friction


@pytest.mark.parametrize(
    "spec, unit, match",
    [
        ("sine:amplitude=40,frequency=1", "", "4000 %.*'40 %'"),
        ("40", "", "4000 %"),
        ("step:after=25", "", "2500 %"),
        ("95", "Pa", "did you mean '95 bar'"),
        ("sine:amplitude=5,offset=95,frequency=1", "Pa", "did you mean '5 bar'"),
    ],
)
def test_signal_spec_percent_and_pressure_ambiguity_is_rejected(spec, unit, match):
    with pytest.raises(SignalError, match=match):
        parse_signal(spec, unit, "--input")


def test_signal_spec_with_units_or_fractions_is_accepted():
    assert parse_signal("sine:amplitude=40 %,frequency=1").amplitude == pytest.approx(0.4)
    assert parse_signal("sine:amplitude=0.4,frequency=1").amplitude == pytest.approx(0.4)
    assert parse_signal("95 bar", "Pa")(0.0) == pytest.approx(95e5)
    assert parse_signal("9.5e6", "Pa")(0.0) == pytest.approx(9.5e6)


def test_cli_bare_supply_pressure_is_rejected_with_the_unit(tmp_path, capsys):
    from hydropwa.cli import main

    code = main(
        [
            "simulate",
            "--params",
            "paper",
            "--model",
            "reduced",
            "--supply-pressure",
            "95",
            "--duration",
            "0.01",
            "--out",
            str(tmp_path / "r.csv"),
        ]
    )
    assert code == 2
    assert "did you mean '95 bar'" in capsys.readouterr().err
