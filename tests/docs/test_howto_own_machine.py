"""The how-to "your own machine" (docs/howto_own_machine.md): its parameter file loads and is
the machine it describes (issue 37)."""

from __future__ import annotations

import dataclasses
import math
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

from hydropwa.params import FIELD_UNITS, load_params, params_from_dict

PAGE = Path(__file__).resolve().parents[2] / "docs" / "howto_own_machine.md"


def test_the_pages_parameter_file_is_the_axis_it_describes():
    import tomllib

    (toml,) = re.findall(r"```toml\n(.*?)```", PAGE.read_text(), re.S)
    p = params_from_dict(tomllib.loads(toml), source="howto")
    assert p.cylinder.area_a * 1e4 == pytest.approx(31.17, abs=0.005)  # as the page says
    assert p.cylinder.area_b * 1e4 == pytest.approx(20.99, abs=0.005)
    assert p.cylinder.stroke == 0.5 and p.load.mass == 250.0
    assert p.supply.pressure == 210e5 < p.supply.relief_pressure
    assert p.valve.omega0 == pytest.approx(2 * math.pi * 45.0)


def test_the_howto_machine_is_the_industrial_axis():
    """docs/howto_own_machine.md's machine file is the axis it names
    (tests/machines/industrial.toml): its own valve schedule, dead zone, friction, oil and load,
    nothing of the paper rig's left but the end-stop contact (a numerical penalty)."""
    page = PAGE.read_text(encoding="utf-8")
    block = re.search(r"```toml\n(.*?)```", page, re.S)
    assert block is not None
    howto = params_from_dict(tomllib.loads(block.group(1)), "howto")
    industrial = load_params(PAGE.parents[1] / "tests/machines/industrial.toml")
    inherited = {k for k, v in howto.provenance.items() if v == "base 'paper'"}
    assert inherited <= {
        "cylinder.end_stop_stiffness",
        "cylinder.end_stop_damping",
        "oil.density",
        "oil.vapour_pressure",
        "oil.release_pressure",
        "dead_zone.alpha",
        "dead_zone.continuous",
        "supply.tank_pressure",
        "supply.model",
        "cylinder.leakage",
        "load.damping",
    } | {f"supply.{k}" for k in FIELD_UNITS["supply"]} | {
        f"accumulator.{k}" for k in FIELD_UNITS["accumulator"]
    }
    for comp in ("valve", "dead_zone", "flow", "friction", "load", "oil"):
        a, b = getattr(howto, comp), getattr(industrial, comp)
        for f in dataclasses.fields(a):
            va, vb = getattr(a, f.name), getattr(b, f.name)
            if isinstance(va, tuple):
                np.testing.assert_allclose(va, vb, rtol=1e-12, err_msg=f"{comp}.{f.name}")
            elif isinstance(va, float):
                assert va == pytest.approx(vb, rel=1e-12), f"{comp}.{f.name}"
            else:
                assert va == vb, f"{comp}.{f.name}"
    # 63/36 mm bore/rod against the file's 31.17/20.99 cm² (four digits)
    for f in ("area_a", "area_b", "stroke", "dead_volume_a", "dead_volume_b"):
        assert getattr(howto.cylinder, f) == pytest.approx(
            getattr(industrial.cylinder, f), rel=2e-4
        )
