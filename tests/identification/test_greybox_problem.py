"""The grey-box problem's bounds stay inside what the parameter objects accept."""

from __future__ import annotations

import math

import pytest

from hydropwa import IdentificationError, ParameterError
from hydropwa.identification.greybox.problem import VALID_UPPER, GreyBoxProblem
from hydropwa.params import get_preset


@pytest.mark.parametrize("name", sorted(VALID_UPPER))
def test_each_valid_upper_limit_is_the_parameter_validations(name):
    """At the table's value the parameters validate; one step above they do not (the table
    mirrors params/_params.py, so it cannot drift from it silently)."""
    p = get_preset("paper")
    limit = VALID_UPPER[name]
    p.replace(**{name: limit})
    with pytest.raises(ParameterError):
        p.replace(**{name: math.nextafter(limit, math.inf) * (1 + 1e-12)})


def test_default_bounds_stop_at_the_valid_range_and_given_ones_beyond_it_are_refused():
    """The heavy axis's friction shape starts at 1.04: a decade above is 10.4, above the
    validation's 10 (the friction check's refit once tried 10.37 and died in it)."""
    p = get_preset("paper").replace(**{"friction.shape": 1.04, "valve.zeta": 2.0})
    prob = GreyBoxProblem.build(("friction.shape", "valve.zeta", "flow.K"), p, None, None)
    assert prob.upper[0] == 10.0 and prob.upper[1] == 10.0
    assert prob.upper[2] == pytest.approx(10 * p.flow.K)  # no limit: a decade
    with pytest.raises(IdentificationError, match="above the largest valid value 10"):
        GreyBoxProblem.build(("friction.shape",), p, None, {"friction.shape": (0.1, 20.0)})


def test_a_difference_point_past_a_valid_limit_is_evaluated_at_the_limit():
    """The optimiser stays inside the bounds, but a finite-difference point one step above a
    parameter lying at its limit (the heavy axis's shape at 10 in the 20-seed study) must not
    end the fit in the parameter validation: it is evaluated at the limit; others untouched."""
    import numpy as np

    from hydropwa.identification.greybox.objective import OutputErrorObjective
    from hydropwa.models import FullOrderModel

    model = FullOrderModel(get_preset("paper"))
    obj = OutputErrorObjective(model, [], ("friction.shape", "flow.K"), ("x",), 1e-5, 1, {})
    p = obj.params_at(np.array([10.3, 2.0 * model.params.flow.K]))
    assert p.friction.shape == 10.0
    assert p.flow.K == 2.0 * model.params.flow.K
