"""The helpers the PWA models share (issue 33: written once, used by both model levels).

- :func:`~hydropwa.linearization._cells.dead_zone_interval`: the input interval of a
  dead-zone cell and a sign of z, checked on a hand-made dead zone against the interval
  written out from Eq. (16), and on the paper's dead zone against the sign of z sampled
  densely over the interval;
- the states of the smooth model (``SmoothModelStates``): the PWA models' scales and rest
  state are those of the reduced and the full model;
- the halving refinement of the chamber cells: every cell meets the tolerance it was asked
  for, and halving the tolerance never leaves fewer cells.
"""

from __future__ import annotations

import numpy as np
import pytest

from hydropwa import FullOrderModel, ReducedModel, get_preset
from hydropwa.components import PiecewiseAffine
from hydropwa.linearization import capacitance_cells, linearize
from hydropwa.linearization._cells import dead_zone_cells, dead_zone_interval
from hydropwa.linearization._chamber import _capacitance_error

#: z = u + 0.1 below −0.2, creep z = 0.25 u in [−0.2, 0.2], z = u − 0.1 above 0.2 (continuous)
_HAND = PiecewiseAffine(np.array([-0.2, 0.2]), np.array([1.0, 0.25, 1.0]), np.array([0.1, 0, -0.1]))


@pytest.mark.parametrize(
    ("g", "s", "expected"),
    [
        (0, -1, (-1.0, -0.2)),  # z = u + 0.1 < 0 on the whole outer cell: sign −1 keeps it
        (0, 1, (-1.0, -0.2)),  # z has no zero inside (u₀ = −0.1 lies outside): nothing split
        (1, 1, (0.0, 0.2)),  # the creep cell split at u₀ = 0
        (1, -1, (-0.2, 0.0)),
        (2, 1, (0.2, 1.0)),
    ],
)
def test_dead_zone_interval_is_the_cell_split_where_z_changes_sign(g, s, expected):
    assert dead_zone_interval(_HAND, g, s, -1.0, 1.0) == pytest.approx(expected, abs=1e-15)


def test_dead_zone_interval_holds_one_sign_of_z_on_the_paper_dead_zone():
    dz = dead_zone_cells(get_preset("paper").dead_zone)
    edges = np.concatenate(([-1.0], dz.breakpoints, [1.0]))
    split = 0
    for g in range(dz.slopes.size):
        cell = (max(edges[g], -1.0), min(edges[g + 1], 1.0))
        neg, pos = (dead_zone_interval(dz, g, s, -1.0, 1.0) for s in (-1, 1))
        if neg == pos:  # no zero of z inside: the whole cell for either sign
            assert neg == pytest.approx(cell, abs=0)
            continue
        split += 1  # the two halves meet at the zero of z and cover the cell
        assert (neg[0], neg[1], pos[1]) == pytest.approx((cell[0], pos[0], cell[1]), abs=0)
        for s, (lo, hi) in ((-1, neg), (1, pos)):
            u = np.linspace(lo, hi, 101)[1:-1]
            assert np.all(np.sign(dz.slopes[g] * u + dz.offsets[g]) == s)
    assert split == 1  # the paper's creep cell (Table IV) holds z = 0


def test_pwa_models_take_scales_and_rest_from_their_smooth_model():
    params = get_preset("paper")
    pwa = linearize(params)
    full, reduced = FullOrderModel(params), ReducedModel(params, "asymmetric")
    assert pwa.smooth == reduced
    np.testing.assert_array_equal(pwa.state_scale(), reduced.state_scale())
    np.testing.assert_array_equal(
        pwa.initial_state(0.1, 90e5, 500.0), reduced.initial_state(0.1, 90e5, 500.0)
    )
    chamber = linearize(params, form="chamber")
    assert chamber.smooth == full
    np.testing.assert_array_equal(chamber.state_scale(), full.state_scale())
    np.testing.assert_array_equal(
        chamber.initial_state(0.1, 90e5, 500.0), full.initial_state(0.1, 90e5, 500.0)
    )


@pytest.mark.parametrize("tolerance", [0.05, 0.02, 0.01])
def test_halving_meets_the_tolerance_on_every_capacitance_cell(tolerance):
    params = get_preset("paper")
    cells = capacitance_cells(params, tolerance)
    edges = np.concatenate(([0.0], cells.breakpoints, [params.cylinder.stroke]))
    errors = [_capacitance_error(a, b, params) for a, b in zip(edges[:-1], edges[1:], strict=True)]
    np.testing.assert_allclose(cells.bounds, errors, rtol=0, atol=0)
    assert max(errors) <= tolerance
    np.testing.assert_allclose(cells.centres, 0.5 * (edges[:-1] + edges[1:]), rtol=1e-15)
    assert capacitance_cells(params, tolerance / 2).n_cells >= cells.n_cells
