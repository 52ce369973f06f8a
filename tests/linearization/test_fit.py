"""The fitting primitive: continuity, modes, errors, property tests."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hydropwa._errors import PwaError
from hydropwa.linearization import cq_shape, fit_pwa, tangent_pwa


def _assert_continuous(pwa, scale=1.0):
    assert np.all(np.abs(pwa.jumps()) <= 1e-9 * scale)


@pytest.mark.parametrize("method", ["minimax", "rms"])
def test_given_breakpoints_continuous_and_exact_for_pwa_target(method):
    target = lambda x: np.abs(x - 0.2) + 0.5 * np.abs(x + 0.4)  # noqa: E731
    fit = fit_pwa(target, (-1, 1), breakpoints=[-0.4, 0.2], method=method)
    _assert_continuous(fit.pwa)
    assert fit.max_error < 1e-9
    np.testing.assert_allclose(fit.pwa.breakpoints, [-0.4, 0.2])


def test_tangent_mode_reproduces_function_and_slope_at_working_points():
    wp = [0.3, 0.7, 0.9]
    fit = tangent_pwa(cq_shape, wp, (0, 0.95), lambda p: -0.5 / np.sqrt(1 - p))
    _assert_continuous(fit.pwa)
    np.testing.assert_allclose(fit.pwa(np.array(wp)), cq_shape(np.array(wp)), rtol=1e-12)
    np.testing.assert_allclose(fit.pwa.slopes, -0.5 / np.sqrt(1 - np.array(wp)))
    # concave function: tangents lie above it, the min of tangents is the PWA
    x = np.linspace(0, 0.95, 500)
    assert np.all(fit.pwa(x) >= cq_shape(x) - 1e-12)


def test_optimised_minimax_equioscillates_on_parabola():
    # x² on [0, 1], n equal cells: interpolation error h²/4 at mid-cell, halved by the
    # minimax shift, so 1/(8 n²)
    fit = fit_pwa(np.square, (0, 1), n_cells=4)
    assert fit.max_error == pytest.approx(1 / (8 * 16), rel=0.02)
    np.testing.assert_allclose(fit.pwa.breakpoints, [0.25, 0.5, 0.75], atol=0.02)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"n_cells": 0}, "positive integer"),
        ({"breakpoints": [0.5, 0.2]}, "strictly increasing"),
        ({"breakpoints": [0.5, 1.5]}, "inside the fit interval"),
        ({}, "exactly one"),
        ({"n_cells": 3, "method": "l7"}, "method"),
    ],
)
def test_bad_inputs_raise_pwa_error(kwargs, match):
    with pytest.raises(PwaError, match=match):
        fit_pwa(np.square, (0, 1), **kwargs)


def test_bad_interval_raises():
    with pytest.raises(PwaError, match="lo < hi"):
        fit_pwa(np.square, (1, 0), n_cells=2)


def test_tangents_out_of_order_raise():
    with pytest.raises(PwaError, match="do not meet in order"):
        tangent_pwa(lambda x: x**3, [-1.0, 1.0], (-2, 2))  # parallel tangents


@settings(max_examples=12, deadline=None)
@given(
    a=st.floats(0.2, 3.0),
    b=st.floats(-2.0, 2.0),
    c=st.floats(0.5, 4.0),
)
def test_property_continuity_and_error_decreases_with_cells(a, b, c):
    func = lambda x: a * np.exp(0.5 * c * x) + b * x  # noqa: E731  convex, smooth
    errs = []
    for n in (1, 2, 4):
        fit = fit_pwa(func, (-1.0, 1.0), n_cells=n, n_grid=150, maxiter=150)
        _assert_continuous(fit.pwa, scale=max(1.0, np.max(np.abs(fit.pwa.offsets))))
        errs.append(fit.max_error)
    assert errs[1] <= errs[0] * (1 + 1e-6)
    assert errs[2] <= errs[1] * (1 + 1e-6)
