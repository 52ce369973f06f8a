"""Inheritance from a base preset is explicit (issue 49, item 1): a scalar given replaces the
base's table, provenance says where every value came from, and bare numbers are checked for
plausibility in every unit-bearing field."""

from __future__ import annotations

import math
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

from hydropwa import FullOrderModel, ParameterError, simulate
from hydropwa.params import (
    FIELD_UNITS,
    PLAUSIBLE,
    SUPERSEDES,
    get_preset,
    load_params,
    params_from_dict,
    params_to_toml,
)

ROOT = Path(__file__).resolve().parents[2]
HZ40 = 2.0 * math.pi * 40.0


@pytest.fixture(scope="module")
def valve40():
    return params_from_dict({"base": "paper", "valve": {"omega0": "40 Hz"}}, "axis.toml")


def test_scalar_omega0_drops_the_base_table(valve40):
    assert get_preset("paper").valve.omega0_table  # the base has a Table II schedule
    assert valve40.valve.omega0_table == ()
    for amplitude in (0.05, 0.1, 0.25, 0.5, 0.9, 1.0):
        assert valve40.valve.omega0_at(amplitude) == pytest.approx(HZ40, rel=1e-12)
    assert valve40.provenance["valve.omega0"] == "file"
    assert valve40.provenance["valve.omega0_table"] == (
        "dropped from base 'paper': valve.omega0 given"
    )
    # a file that gives both keeps both (nothing is inherited there)
    both = params_from_dict(
        {"base": "paper", "valve": {"omega0": "40 Hz", "omega0_table": [["10 %", "50 Hz"]]}}
    )
    assert both.valve.omega0_table == ((0.1, pytest.approx(2 * math.pi * 50)),)
    assert both.provenance["valve.omega0_table"] == "file"


@pytest.mark.parametrize("amplitude", [0.1, 0.5, 0.9])
def test_the_model_simulates_a_40_hz_valve(valve40, amplitude):
    """The spool's step response is the closed-form second-order one at ω0 = 2π·40 rad/s, ζ =
    0.7, at every opening (the paper's schedule would give 816.8/…/220 rad/s)."""
    res = simulate(
        FullOrderModel(valve40),
        f"step:time=0,before=0,after={amplitude}",
        duration=0.03,
        rtol=1e-8,
    )
    assert res.stats["omega0"] == pytest.approx(HZ40, rel=1e-12)
    t, nu = np.asarray(res["t"]), np.asarray(res["spool"])
    z, w = 0.7, HZ40
    wd = w * math.sqrt(1 - z * z)
    truth = amplitude * (
        1 - np.exp(-z * w * t) * (np.cos(wd * t) + z / math.sqrt(1 - z * z) * np.sin(wd * t))
    )
    # rtol 1e-8 leaves ~4e-9 of the amplitude (measured); 39.9 Hz would differ by 1e-3
    np.testing.assert_allclose(nu, truth, rtol=0, atol=1e-6 * amplitude)


def test_provenance_marks_base_file_and_default(tmp_path):
    p = params_from_dict({"base": "paper", "load": {"mass": "250 kg"}}, "axis.toml")
    prov = p.provenance
    assert set(prov) == {
        f"{c}.{f}" for c, units in FIELD_UNITS.items() for f in units
    }  # every field
    assert prov["load.mass"] == "file"
    assert {v for k, v in prov.items() if k != "load.mass"} == {"base 'paper'"}
    assert p.meta["source"] == "axis.toml (base 'paper')"
    # a value changed after loading is no longer the base's
    assert p.replace(**{"oil.bulk_modulus": 1.2e9}).provenance["oil.bulk_modulus"] == (
        "changed after loading"
    )
    # a complete file: the fields it leaves out are the class defaults, and said so
    industrial = load_params(ROOT / "tests/machines/industrial.toml")
    assert industrial.provenance["valve.omega0"] == "file"
    assert industrial.provenance["accumulator.gas_volume"] == "default"
    assert set(get_preset("paper").provenance.values()) == {"preset 'paper'"}
    # the notebook view shows it too
    assert "<td style='text-align:left'>base &#x27;paper&#x27;</td>" in p._repr_html_()


def test_base_notes_about_overridden_fields_are_not_inherited():
    paper = get_preset("paper")
    assert {"K", "friction", "dead_volumes"} <= set(paper.meta)
    p = params_from_dict(
        {
            "base": "paper",
            "flow": {"rating": {"flow": "60 L/min", "pressure_drop": "70 bar"}},
            "friction": {"coulomb": "30 N"},
        }
    )
    assert "K" not in p.meta and "friction" not in p.meta and "dead_volumes" in p.meta


def test_params_show_marks_the_source_of_every_value(tmp_path, capsys):
    from hydropwa.cli import main

    path = tmp_path / "axis.toml"
    path.write_text('base = "paper"\n[valve]\nomega0 = "40 Hz"\n[load]\nmass = "250 kg"\n')
    assert main(["params", "show", str(path)]) == 0
    out = capsys.readouterr().out
    rows = {
        (cells[1], cells[2]): cells[-2]
        for line in out.splitlines()
        if (cells := [c.strip() for c in re.split(r"[│┃]", line)]) and len(cells) > 6
    }
    assert rows[("valve", "omega0")] == "file"
    assert rows[("load", "mass")] == "file"
    assert rows[("valve", "omega0_table")].startswith("dropped from base 'paper'")
    assert rows[("friction", "coulomb")] == "base 'paper'"
    assert rows[("dead_zone", "beta")] == "base 'paper'"


def _unit_fields():
    return [(c, k) for c, units in FIELD_UNITS.items() for k, u in units.items() if u is not None]


def test_every_unit_bearing_field_has_a_plausible_range():
    missing = [f"{c}.{k}" for c, k in _unit_fields() if (c, k) not in PLAUSIBLE]
    assert not missing, f"no bare-number range for {missing}"
    for target in (t for ts in SUPERSEDES.values() for t in ts):
        comp, key = target.split(".")
        assert key in FIELD_UNITS[comp]


@pytest.mark.parametrize(("comp", "key"), _unit_fields())
def test_a_bare_number_outside_its_field_range_is_one_line_error(comp, key):
    """Far above (and, where the range does not start at 0, far below) the plausible magnitude,
    a bare number is refused with the field's name; the same number with its SI unit is not
    second-guessed by this check."""
    lo, hi, _ = PLAUSIBLE[(comp, key)]
    outside = [hi * 1e3] + ([lo * 1e-3] if lo > 0 else [])
    for value in outside:
        with pytest.raises(ParameterError, match=rf"{comp}\.{key} = .*implausible") as err:
            params_from_dict({"base": "paper", comp: {key: value}}, "axis.toml")
        assert "\n" not in str(err.value)


@pytest.mark.parametrize(
    ("comp", "key", "value", "hint"),
    [
        ("valve", "omega0", 40, 'did you mean 40 Hz.*omega0 = "40 Hz"'),
        ("friction", "stribeck_velocity", 20, "did you mean 20 mm/s"),
        ("oil", "vapour_pressure", -0.95, "did you mean -0.95 bar"),
        ("supply", "tank_pressure", 2, "did you mean 2 bar"),
        ("accumulator", "hose_diameter", 12, "did you mean 12 mm"),
        ("accumulator", "gas_volume", 4, "did you mean 4 L"),
        ("cylinder", "leakage", 0.1, "did you mean 0.1 L/min/bar"),
        ("load", "mass", 2e6, "did you mean 2e\\+06 t|implausible"),
    ],
)
def test_bare_number_hint_names_the_likely_unit(comp, key, value, hint):
    with pytest.raises(ParameterError, match=hint):
        params_from_dict({"base": "paper", comp: {key: value}})


def test_omega0_table_entries_are_checked_too():
    with pytest.raises(ParameterError, match="omega0_table omega0 = 40.*40 Hz"):
        params_from_dict({"base": "paper", "valve": {"omega0_table": [[0.1, 40]]}})
    with pytest.raises(ParameterError, match="omega0_table amplitude = 10.*10 %"):
        params_from_dict({"base": "paper", "valve": {"omega0_table": [[10, "40 Hz"]]}})


def test_an_export_with_implausible_bare_values_reads_back_exactly(tmp_path):
    """A value the bare-number check would refuse (an identified 5 Hz valve) is written with its
    SI unit, so every export reads back to the same parameters."""
    odd = get_preset("paper").replace(
        **{
            "valve.omega0": 31.4,
            "valve.omega0_table": ((0.1, 40.0), (0.9, 30.0)),
            "friction.stribeck_velocity": 3e-7,
        }
    )
    text = params_to_toml(odd)
    assert 'omega0 = "31.4 rad/s"' in text
    back = params_from_dict(tomllib.loads(text))
    assert back == odd
