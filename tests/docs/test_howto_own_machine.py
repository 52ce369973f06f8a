"""The how-to "your own machine" (docs/howto_own_machine.md): its parameter file loads and is
the machine it describes (issue 37)."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from hydropwa.params import params_from_dict

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
