"""Shared fixtures: canonical parameter sets."""

import matplotlib
import pytest

matplotlib.use("Agg")


@pytest.fixture(scope="session")
def paper():
    from hydropwa import get_preset

    return get_preset("paper")


@pytest.fixture(scope="session")
def symmetric():
    from hydropwa import get_preset

    return get_preset("symmetric")
