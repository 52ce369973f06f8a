"""One-step soundness of the certificate's disturbance set on the full model (issue 51, item 3):
the full model integrated over one sample from states over the region, its mismatch to the cell
prediction explained by the set's columns."""

import pytest

from hydropwa.control._certify import SECTOR_FRICTION, loop_data
from hydropwa.control._certsound import GROWTH, LEFTOVER_TOL, grow, one_step_soundness


@pytest.fixture(scope="module")
def checked(default, paper_pwa):
    # openings to 20 %: the region's command limit (87 %) reaches states with 80 % open at rest,
    # where a chamber cavitates within the sample (Ṗ_L errors of 1e9 Pa/s, reported by the
    # benchmark, not asserted here)
    return one_step_soundness(default, paper_pwa, samples=24, seed=3, opening=0.2)


def test_the_valve_and_mechanics_rows_are_explained(checked):
    # the valve of Eq. (1) at the hold's ω0 (Table II at small amplitude) and ẋ, x are linear in
    # the full model: after the friction and Ṗ_L columns nothing is left beyond the friction's
    # change within one sample (LEFTOVER_TOL in the scaled states: 0.01 bar, mm/s, mm, %)
    assert checked.samples >= 20
    assert checked.max_leftover < LEFTOVER_TOL
    # Coulomb + Stribeck beyond the viscous slope stays inside the set's F_s
    assert 0 < checked.max_friction <= checked.friction_bound
    # but the force held over a sample is not always against the velocity at its start (the
    # rod reverses within it): the friction's sector F·ẋ₀ ≤ 0 is not sound, and it is off
    assert checked.sector_violations > 0 and not SECTOR_FRICTION


def test_the_pressure_row_needs_the_set_to_grow(checked, default, paper_pwa):
    # the cells' Ṗ_L row (flow gain at a small opening, the two pressure vertices) misses the
    # full model's ∂Q/∂P_L at larger openings: the set's bound 0 is violated by every sample;
    # grown to GROWTH × the largest error seen, the same draw has none left
    assert checked.error_bound == 0.0 and checked.violations == checked.samples
    assert checked.grown_error_bound == pytest.approx(GROWTH * checked.max_error)
    grown = grow(loop_data(default, paper_pwa), checked)
    same = one_step_soundness(default, paper_pwa, samples=24, seed=3, opening=0.2, data=grown)
    assert same.violations == 0
    # a fresh draw: the error is heavy-tailed (measured: 2 of 24 beyond the grown bound, at
    # ~25 bar below the hold with the valve open), so a bound grown from few samples is not
    # sound: the benchmark grows it from 10³ samples
    fresh = one_step_soundness(default, paper_pwa, samples=24, seed=4, opening=0.2, data=grown)
    assert 0 <= fresh.violations <= 4
