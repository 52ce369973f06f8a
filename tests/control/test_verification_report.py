"""The verification verdict beside the textbook PI baseline, and its section of the report."""

from __future__ import annotations

import pytest

from hydropwa.control import VerificationCriteria, closed_loop_verification, design_pi
from hydropwa.linearization import linearize


@pytest.fixture(scope="module")
def table(paper):
    pwa = linearize(paper)
    return closed_loop_verification(pwa, design_pi(pwa, delay=True).controller)


def test_verdicts_follow_the_measured_numbers_and_the_criteria(table):
    """Each row's verdict is what its worst numbers say against the default criteria.

    Both controllers ran the same noisy task set with the delay; a PI with feed-forward tracks
    the half-speed trapezoid and holds without saturating, so its numbers are finite and
    positive, and the baseline carries the design's delay (the same sampled plant).
    """
    crit = VerificationCriteria()
    assert list(table.index) == ["design", "textbook PI + FF (baseline)"]
    for name, row in table.iterrows():
        within = (
            row["hold_peak_to_peak_mm"] <= crit.hold_peak_to_peak * 1e3
            and row["saturation_percent"] <= crit.saturation * 100
            and row["sign_changes_per_s"] <= crit.sign_changes
            and row["limit_cycles"] == 0
        )
        assert (row["verdict"] == "pass") == (row["failed_checks"] == 0), name
        if row["verdict"] == "pass":
            assert within, name
        else:
            assert row["first_failure"], name
        assert 0 < row["following_error_mm"] < 5.0 and row["hold_peak_to_peak_mm"] > 0, name


def test_report_section_shows_both_verdicts(table, tmp_path):
    from hydropwa.studies.paper._report_control import closed_loop_verification_html

    assert closed_loop_verification_html(tmp_path) == ""  # no table: no section
    (tmp_path / "tables").mkdir()
    table.reset_index().to_csv(tmp_path / "tables" / "closed_loop_verification.csv", index=False)
    page = closed_loop_verification_html(tmp_path)
    for name, row in table.iterrows():
        assert f"{name}: <b>{row['verdict'].upper()}</b>" in page
    assert page.count("<tr>") == 3 and "sign changes at holds [1/s]" in page
