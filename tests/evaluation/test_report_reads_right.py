"""The report's first screen says what was measured and what the fits mean; the measurement
is drawn over the models; Tables IV-IX and Fig. 9 are in it; intervals keep their ends apart."""

from __future__ import annotations

import re
import shutil

import pytest

from hydropwa.studies.paper._report import _interval_digits


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


def test_the_first_screen_is_the_verdict(small_study):
    """Verdict (checks, thresholds, values, pass/fail) and contents before anything else."""
    page = (small_study.out / "index.html").read_text()
    verdict = page.index("<h2>Verdict</h2>")
    assert verdict < page.index('<nav class="toc">') < page.index("<h2>Summary</h2>")
    head = page[verdict : page.index('<nav class="toc">')]
    assert "<th>threshold</th>" in head and ("PASS" in head or "FAIL" in head)
    assert "full model reproduces the sine runs" in head and "≥ 90 %" in head
    assert head.count("class='pass'>pass<") + head.count("class='fail'>fail<") >= 3
    # every section is in the contents and its anchor exists
    toc = page[page.index('<nav class="toc">') : page.index("</nav>")]
    for slug in re.findall(r'href="#([a-z0-9-]+)"', toc):
        assert f'<a id="{slug}"></a><h2>' in page
    assert re.findall(r'href="#([a-z0-9-]+)"', toc).count("the-papers-forms") == 1


def test_the_papers_forms_have_their_own_section(small_study):
    page = (small_study.out / "index.html").read_text()
    headline = page[
        page.index("headline: medians") : page.index("</table>", page.index("headline"))
    ]
    assert "-paper" not in headline
    forms = page.index("<h2>The paper's forms</h2>")
    assert "reduced-paper" in page[forms : page.index("<h2>", forms + 5)]


def test_units_in_headers_tables_wrap_and_figures_exist(small_study):
    page = (small_study.out / "index.html").read_text()
    # tables scroll sideways rather than break a number or a word in two (issue 49)
    assert "overflow-x:auto" in page and "overflow-wrap:normal" in page
    assert "anywhere" not in page and "break-all" not in page
    assert "<th>full [%]</th>" in page
    if "<h2>Closed loop</h2>" in page:
        closed = page[page.index("<h2>Closed loop</h2>") :]
        assert "steady_state_error [mm]" in closed
        # a trapezoid's rise time is its own ramp's; the table leaves it out (issue 49)
        assert "rise_time" not in closed[: closed.index("</table>")]
        assert "baseline" in closed  # the baseline is in the table and the figure
    # a caption names an SVG only where one is written
    for stem in re.findall(r"\((\w+); SVG in figures/\)", page):
        assert (small_study.out / "figures" / f"{stem}.svg").is_file(), stem


def test_every_stage_warning_is_shown_in_its_section(small_study):
    page = (small_study.out / "index.html").read_text()
    for note in small_study.notes:
        import html

        assert page.count(html.escape(note)) >= 2, note  # in its section and in the notes


def test_the_engineering_section_shows_written_figures(small_study):
    """Bode, pole map, per-cell margins and the error-bound map are in the report, and every
    file their captions and texts name is written."""
    out = small_study.out
    page = (out / "index.html").read_text()
    sec = page[page.index("Small signal, poles and margins</h2>") :]
    sec = sec[: sec.index("<h2>")]
    for title in (
        "Small-signal Bode plot",
        "Pole map with the valve",
        "Per-cell margins",
        "Error-bound map",
    ):
        assert f"<h3>{title}</h3>" in sec
    assert "could not" not in sec and '<p class="small">(' not in sec  # nothing fell back
    named = set(re.findall(r"((?:figures|tables)/[\w.]+\.(?:png|svg|csv))", sec))
    assert len(named) >= 10
    for rel in named:
        assert (out / rel).is_file(), rel
    m = re.search(r"differ by at most ([\d.]+) % in magnitude and ([\d.]+)° in phase", sec)
    assert m and float(m.group(1)) < 3.0 and float(m.group(2)) < 3.0


def test_detrended_position_rows_are_in_mm_like_the_position():
    """``x_detrended`` is a position: its RMSE shows in mm under the table's "mm" note."""
    import pandas as pd

    from hydropwa.studies.paper._report import metrics_for_display

    raw = pd.DataFrame(
        {
            "run": ["s1", "s1"],
            "model": ["full", "full"],
            "channel": ["x", "x_detrended"],
            "unit": ["m", "m"],
            "nrmse_fit": [90.0, 95.0],
            "rmse": [1.5e-3, 0.5e-3],
            "peak_error": [3e-3, 1e-3],
        }
    )
    shown = metrics_for_display(raw).set_index("channel")
    assert shown.loc["x", "unit"] == shown.loc["x_detrended", "unit"] == "mm"
    assert shown.loc["x_detrended", "rmse"] == pytest.approx(0.5)
    assert shown.loc["x_detrended", "peak_error"] == pytest.approx(1.0)


def test_the_papers_tables_are_shown_for_the_paper_rig_only(small_study, tmp_path):
    from hydropwa.studies.paper import write_report

    page = (small_study.out / "index.html").read_text()
    assert "<h2>The paper's Tables IV–IX</h2>" in page  # the study's machine is the paper's
    other = tmp_path / "other"
    shutil.copytree(small_study.out, other)
    info = {"paper_machine": False, "params_source": "axis.toml", "stage_notes": {}}
    write_report(other, small_study.params, small_study.true_params, [], info)
    assert "Tables IV–IX" not in (other / "index.html").read_text()


def test_a_normal_greybox_termination_is_not_a_warning(small_study):
    page = (small_study.out / "index.html").read_text()
    section = page[page.index("<h2>Grey-box fit</h2>") : page.index("<h2>Identification")]
    boxes = re.findall(r"<div class='warnbox'>.*?</div>", section, re.S)
    # scipy's words for a converged least-squares fit are its status, never a warning
    assert not any("termination condition" in b for b in boxes), boxes
    if "No grey-box fit" not in section:
        assert re.search(r"<p class='small'>grey-box fit: .*evaluations", section)


def test_the_verdict_includes_the_controllers_verification(small_study, tmp_path):
    """The first screen's verdict has the closed-loop design's verification as a check: never
    PASS beside a closed-loop FAIL. The study's own table decides; a copy of the report folder
    whose design row is turned to fail makes the verdict FAIL (the test can fail)."""
    import shutil

    import pandas as pd

    from hydropwa.studies.paper._report import _controller_verdict_rows

    out = small_study.out
    ver = pd.read_csv(out / "tables" / "closed_loop_verification.csv", keep_default_na=False)
    design = ver[ver["controller"] == "design"].iloc[0]
    page = (out / "index.html").read_text()
    head = page[page.index("<h2>Verdict</h2>") : page.index('<nav class="toc">')]
    assert "closed-loop design verified on the full model" in head
    if design["verdict"] == "fail":
        assert "class='fail'>FAIL</span>" in head
    (row,) = _controller_verdict_rows(out)
    assert row[3] is (design["verdict"] == "pass")
    copy = tmp_path / "report"
    shutil.copytree(out / "tables", copy / "tables")
    ver.loc[ver["controller"] == "design", ["verdict", "failed_checks", "first_failure"]] = [
        "fail",
        2,
        "steps +50 % force, draw 1: hold 0.2 mm peak to peak > 0.1 mm",
    ]
    ver.to_csv(copy / "tables" / "closed_loop_verification.csv", index=False)
    (row,) = _controller_verdict_rows(copy)
    assert row[3] is False and "fail: 2 checks" in row[2]
