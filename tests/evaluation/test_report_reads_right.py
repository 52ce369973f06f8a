"""The report's first screen says what was measured and what the fits mean; the measurement
is drawn over the models; Tables IV-IX and Fig. 9 are in it; intervals keep their ends apart."""

from __future__ import annotations

import re

from hydropwa.evaluation._report import _interval_digits


def test_interval_digits_tell_the_ends_apart():
    assert _interval_digits(219.6, 220.4, 220.0) == 4  # 219.6 … 220.4
    assert _interval_digits(220.01, 220.03, 220.02) == 5  # 4 digits would print 220 … 220
    assert f"{220.01:.{_interval_digits(220.01, 220.03, 220.02)}g}" != f"{220.03:.5g}"


def test_report_summary_tables_and_figures(small_study):
    page = (small_study.out / "index.html").read_text()
    summary = page.index("<h2>Summary</h2>")
    assert summary < page.index("<h2>Position fit")  # the summary comes first
    assert "Self-consistency, not validation" in page  # virtual rig
    assert "headline: medians over the sine runs" in page
    for table in ("IV", "V", "VI", "VII", "VIII", "IX"):
        assert f"<summary>Table {table}</summary>" in page
    assert (small_study.out / "figures" / "fig09_supply_pressure.png").is_file()
    assert re.search(r"<details><summary>per run, model and channel \(\d+ rows\)</summary>", page)
    # every interval row says whether the rig's true value lies inside it
    assert page.count("<td>yes</td>") + page.count("no: outside") >= 3


def test_a_truth_just_outside_its_interval_prints_apart_from_the_end():
    lo, hi, value, true = 627.98, 628.29, 628.14, 628.30  # the valve's ω0 at 25 %, rad/s
    d = _interval_digits(lo, hi, value, true)
    assert f"{hi:.{d}g}" != f"{true:.{d}g}"
