"""A cylinder given as a catalogue gives it: bore and rod diameter (issue 37)."""

from __future__ import annotations

import math

import pytest

from hydropwa._errors import ParameterError
from hydropwa.params import Cylinder, params_from_dict


def test_areas_from_bore_and_rod_are_the_circle_and_the_annulus():
    c = Cylinder.from_diameters(0.063, 0.036, 0.5)
    assert c.area_a == pytest.approx(math.pi * 0.063**2 / 4, rel=1e-15)  # 31.17 cm²
    assert c.area_b == pytest.approx(math.pi * (0.063**2 - 0.036**2) / 4, rel=1e-15)  # 20.99 cm²
    assert c.area_a * 1e4 == pytest.approx(31.17, abs=0.005)
    assert c.area_b * 1e4 == pytest.approx(20.99, abs=0.005) and c.stroke == 0.5


def test_toml_takes_bore_and_rod_with_units():
    p = params_from_dict(
        {"base": "paper", "cylinder": {"bore": "63 mm", "rod": "3.6 cm", "stroke": "500 mm"}}
    )
    assert p.cylinder.stroke == 0.5
    assert p.cylinder.area_a == pytest.approx(math.pi * 0.063**2 / 4, rel=1e-12)
    assert p.cylinder.area_b == pytest.approx(math.pi * (0.063**2 - 0.036**2) / 4, rel=1e-12)


@pytest.mark.parametrize(
    "cyl, match",
    [
        ({"bore": "63 mm"}, "without rod"),
        ({"rod": "36 mm"}, "without bore"),
        ({"bore": "36 mm", "rod": "63 mm"}, "0 < rod < bore"),
        ({"bore": "63 mm", "rod": "36 mm", "area_a": "31 cm**2"}, "give one of the two"),
        ({"bore": 63, "rod": 36}, 'bore = "63 mm"'),
        ({"bore": "63 bar", "rod": "36 mm"}, "bore"),
    ],
)
def test_bad_diameters_are_one_error(cyl, match):
    with pytest.raises(ParameterError, match=match):
        params_from_dict({"base": "paper", "cylinder": cyl})
