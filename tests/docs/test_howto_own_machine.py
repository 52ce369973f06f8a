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
        # absent on the industrial axis too: no external leakage, no specimen, no volt scale
        "cylinder.external_leakage_a",
        "cylinder.external_leakage_b",
        "load.specimen_stiffness",
        "load.specimen_damping",
        "load.contact_position",
        "load.preload",
        "valve.command_voltage",
        "valve.null_voltage",
    } | {f"supply.{k}" for k in FIELD_UNITS["supply"]} | {
        f"accumulator.{k}" for k in FIELD_UNITS["accumulator"]
    } | {f"lines.{k}" for k in FIELD_UNITS["lines"]}  # no hose lines on the industrial axis
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


def test_the_pages_campaign_ships_with_the_package_and_fits_its_machine():
    """Issue 49 item 6: no file of the source tree; the sized campaign has sine runs (step 5's
    `paper --data`) and no friction input inside the machine's dead band (none skipped)."""
    import tomllib

    from hydropwa.rig import SIZED, Rig, campaign_for, no_load_velocity, plan

    text = PAGE.read_text()
    assert "tests/" not in "".join(re.findall(r"```bash\n(.*?)```", text, re.S))
    assert f"--campaign {SIZED}" in text
    (toml,) = re.findall(r"```toml\n(.*?)```", text, re.S)
    p = params_from_dict(tomllib.loads(toml), source="howto")
    c = campaign_for(SIZED, p)
    rig = Rig.from_params(p)
    sine = plan(c["sine"], rig)
    assert len(sine) == 9 + 2  # 3 frequencies x 3 amplitudes, and the two load runs
    assert min(c["friction"].inputs) > p.dead_zone.beta
    # the largest sine's rod amplitude v(z)/(2πf) at 1 Hz stays within a quarter of the stroke
    z = max(c["sine"].amplitudes) - p.dead_zone.beta
    assert no_load_velocity(p, z) / (2 * math.pi) <= 0.25 * p.cylinder.stroke * 1.01
