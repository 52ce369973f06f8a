"""Fixtures of the closed-loop tests: parameter sets whose linear analysis is exact enough."""

import pytest

from hydropwa.control import design_controller
from hydropwa.linearization import linearize


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


@pytest.fixture(scope="module")
def paper_pwa(paper):
    """The paper rig's PWA model (the default linearization), once per test module."""
    return linearize(paper)


@pytest.fixture(scope="module")
def default(paper_pwa):
    """The paper rig's default `control design` controller (one sample of delay, no verification)."""
    return design_controller(paper_pwa, verify=False, delay=True).controller
