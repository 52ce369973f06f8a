"""The paper study: stages, resume, refusal to overwrite, CLI, and the report in a browser."""

import os
import shutil
from pathlib import Path

import pytest

from hydropwa.studies.paper import StudyError, run_paper_study

SMALL_CAMPAIGN = Path(__file__).parent / "small_campaign.toml"


def _hashes(root: Path) -> dict[str, tuple[int, int]]:
    return {
        p.relative_to(root).as_posix(): (p.stat().st_mtime_ns, p.stat().st_size)
        for p in root.rglob("*")
        if p.is_file() and ".stages" not in p.parts
    }


def test_study_writes_the_report_folder(small_study):
    out = small_study.out
    for rel in (
        "index.html",
        "identified.toml",
        "pwa.json",
        "tables/metrics.csv",
        "tables/metrics.md",
        "tables/identified.csv",
        "tables/position_fit.md",
        "figures/fig01_cq.svg",
        "figures/fig05_valve_bode.png",
        "figures/fig08_stribeck.png",
        "figures/pwa_cells.png",
        "tables/closed_loop.csv",
        "tables/closed_loop_verification.csv",
        "controller.toml",
        "figures/closed_loop.png",
    ):
        assert (out / rel).is_file(), rel
    assert len(list((out / "figures").glob("fig1[0-3]_*.png"))) == 4
    page = (out / "index.html").read_text(encoding="utf-8")
    assert "<h2>Closed loop</h2>" in page
    assert "verification verdict: the design and the textbook PI" in page
    assert small_study.position_fit("full").min() >= 90.0
    assert set(small_study.metrics.model) >= {
        "full",
        "reduced",
        "pwa",
        "pwa-scheduled",
        "full (true params)",
    }
    from hydropwa.linearization import load_pwa
    from hydropwa.params import load_params

    ident = load_params(out / "identified.toml")
    assert ident.dead_zone.beta == pytest.approx(0.1, abs=0.01)
    assert load_pwa(out / "pwa.json").params.cylinder == ident.cylinder


def test_study_reports_the_coverage_of_the_partition(small_study):
    """The campaign's load runs are evaluated like the sines; the study writes the P_L coverage
    per flow direction, every model per band and the cells visited, and the report shows them."""
    import pandas as pd

    out = small_study.out
    lp = pd.read_csv(out / "tables" / "coverage_load_pressure.csv").set_index("direction")
    # levels 0.1 → 0.9 of each direction's range: at least 70 % of the bins visited
    assert (lp["covered"] >= 0.7).all()
    bands = pd.read_csv(out / "tables" / "coverage_bands.csv")
    assert {"full", "reduced", "pwa", "pwa-chamber"} <= set(bands["model"])
    cells = pd.read_csv(out / "tables" / "coverage_cells.csv")
    assert {"qa", "qb"} <= set(cells[cells["model"] == "pwa-chamber"]["set"])
    assert "pwa-chamber" in set(small_study.metrics.model)
    page = (out / "index.html").read_text(encoding="utf-8")
    assert "<h2>Coverage of the partition</h2>" in page
    assert "load-pressure coverage per flow direction" in page


def test_rerun_reuses_every_stage(small_study):
    before = _hashes(small_study.out)
    again = run_paper_study(small_study.out, campaign=SMALL_CAMPAIGN, progress=False)
    # every stage reports reuse and no file changed (not a wall-clock comparison: that would
    # depend on the machine's load)
    assert all(s["reused"] for s in again.stages.values()), again.stages
    assert _hashes(small_study.out) == before


def test_a_removed_output_reruns_its_stage_only(small_study, tmp_path):
    out = tmp_path / "copy"
    shutil.copytree(small_study.out, out)
    (out / "index.html").unlink()
    res = run_paper_study(out, campaign=SMALL_CAMPAIGN, progress=False)
    assert {k for k, s in res.stages.items() if not s["reused"]} == {"report"}
    assert (out / "index.html").is_file()


def test_other_inputs_are_refused_without_force(small_study, tmp_path):
    with pytest.raises(StudyError, match="other inputs; pass --force"):
        run_paper_study(
            small_study.out, campaign=SMALL_CAMPAIGN, params="symmetric", progress=False
        )
    (tmp_path / "x.txt").write_text("mine")
    with pytest.raises(StudyError, match="not empty"):
        run_paper_study(tmp_path, campaign=SMALL_CAMPAIGN, progress=False)


def test_study_from_a_data_folder(small_study, tmp_path):
    res = run_paper_study(tmp_path / "rep", data=small_study.out / "data", progress=False)
    assert res.true_params is not None  # read from data/true_params.toml
    assert res.position_fit("full").min() >= 90.0
    assert not (tmp_path / "rep" / "data").exists()


def test_cli_errors_are_one_line(tmp_path, capsys):
    from hydropwa.cli import main

    code = main(["paper", "--out", str(tmp_path / "r"), "--data", str(tmp_path / "missing"), "-q"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith("error: data folder") and err.count("\n") == 1


CHROMIUM, CHROMEDRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"


def test_report_renders_in_chromium(small_study, tmp_path):
    if not (os.path.exists(CHROMIUM) and os.path.exists(CHROMEDRIVER)):
        pytest.skip(
            "chromium and chromium-driver are not installed (apt-get install chromium chromium-driver)"
        )
    webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is not installed")
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.by import By

    os.environ["SE_OFFLINE"] = "true"
    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for a in (
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--no-first-run",
        f"--user-data-dir={tmp_path / 'profile'}",
        "--window-size=1200,3000",
    ):
        opts.add_argument(a)
    driver = webdriver.Chrome(options=opts, service=Service(executable_path=CHROMEDRIVER))
    try:
        driver.get((small_study.out / "index.html").resolve().as_uri())
        imgs = driver.find_elements(By.TAG_NAME, "img")
        assert len(imgs) >= 10
        widths = [
            driver.execute_script("return arguments[0].complete && arguments[0].naturalWidth", i)
            for i in imgs
        ]
        assert all(w and w > 0 for w in widths), widths
        tables = driver.find_elements(By.TAG_NAME, "table")
        assert len(tables) >= 3
        text = driver.find_element(By.TAG_NAME, "body").text
        assert (
            "Position fit" in text and "Identified parameters" in text and "pwa-scheduled" in text
        )
        shot = Path(os.environ.get("HYDROPWA_SCREENSHOT_DIR", tmp_path)) / "report.png"
        driver.save_screenshot(str(shot))
        assert shot.stat().st_size > 10_000
    finally:
        driver.quit()


@pytest.mark.slow
def test_default_paper_command(tmp_path):
    """The real default `hydropwa paper` (full paper campaign on the virtual rig)."""
    from hydropwa.cli import main

    assert main(["paper", "--out", str(tmp_path / "report"), "-q"]) == 0
    import pandas as pd

    m = pd.read_csv(tmp_path / "report" / "tables" / "metrics.csv")
    fit = m[(m.model == "full") & (m.channel == "x")]["nrmse_fit"]
    assert len(fit) == 11 and fit.min() >= 90.0  # 9 sines and the two [sine.load] runs


def test_report_has_the_greybox_fit(small_study):
    """Grey-box section: E and K fitted on two short sine runs, near the rig's true values."""
    import pandas as pd

    out = small_study.out
    assert "Grey-box fit" in (out / "index.html").read_text()
    assert (out / "figures" / "greybox_fit.png").is_file()
    df = pd.read_csv(out / "tables" / "greybox.csv").set_index("parameter")
    # two 1 s runs pin E and K to a few per cent even from the identified (not true) parameters
    assert df.loc["oil.bulk_modulus", "value"] == pytest.approx(
        df.loc["oil.bulk_modulus", "true"], rel=0.1
    )
    assert df.loc["flow.K", "value"] == pytest.approx(df.loc["flow.K", "true"], rel=0.1)
