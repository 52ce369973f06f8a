"""Fixtures of the closed-loop tests: parameter sets whose linear analysis is exact enough."""

import pytest


@pytest.fixture(scope="module")
def linear_valve(paper):
    """Paper rig without dead band, with viscous friction only (no Stribeck peak to linearize across)."""
    return paper.replace(
        **{
            "dead_zone.beta": 0.0,
            "dead_zone.creep_slope": 0.0,
            "friction.coulomb": 0.0,
            "friction.static": 0.0,
            "friction.viscous": 1000.0,
        }
    )
