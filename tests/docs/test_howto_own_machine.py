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
