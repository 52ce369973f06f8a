"""What a new user meets first: short reprs, HTML views, compare(), to_frd(), --version,
compile time reported apart from simulation time, and the generated CLI reference."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import hydropwa as hp
from hydropwa.cli import main
from hydropwa.data import Run
from hydropwa.evaluation import compare, nrmse_fit
from hydropwa.identification import FrequencyResponse
from hydropwa.linearization import linearize

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def sim(paper):
    return hp.simulate(
        hp.ReducedModel(paper), "sine:amplitude=0.4,frequency=2", duration=0.5, fs=1000
    )


def test_reprs_are_one_short_line_and_html_tables(paper, sim):
    run = sim.to_run("r1")
    pwa = linearize(paper)
    for obj in (paper, run, sim, pwa):
        text = repr(obj)
        assert "\n" not in text and len(text) < 250, text  # no array dumps
        page = obj._repr_html_()
        assert page.startswith("<div>") and "<table>" in page
    assert "100 bar" in repr(paper)  # engineering units: P_S of the paper preset
    assert "5/5/5/7" in repr(pwa)  # cells of Tables IV, VI-VII, VIII-IX, V
    # the run's table shows the position range in mm: 100 mm start, mid-stroke of the paper rig
    assert f"{run['x'].min() * 1e3:.4g}" in run._repr_html_()


def test_to_pandas_has_t_as_first_column(sim):
    df = sim.to_pandas()
    assert df.columns[0] == "t"
    np.testing.assert_array_equal(df["t"].to_numpy(), sim.t)
    assert sim.to_run("r").to_pandas().columns[0] == "t"


def test_compare_scores_a_result_against_itself_at_100_percent(sim, paper):
    fig = compare(sim, sim, hp.FullOrderModel(paper), channel="x")
    fits = list(fig.fits.values())
    assert fits[0] == pytest.approx(100.0)
    # the full model is simulated on the reference's inputs; its fit is the NRMSE of that simulation
    full = hp.simulate(
        hp.FullOrderModel(paper),
        hp.Sampled(sim.t, sim["u"]),
        timepts=sim.t,
        supply_pressure=hp.Sampled(sim.t, sim["p_s"]),
        load_force=hp.Sampled(sim.t, sim["f_l"]),
        initial_position=float(sim["x"][0]),
        rtol=1e-4,
    )
    assert fits[1] == pytest.approx(nrmse_fit(sim["x"], full["x"]), abs=1e-9)
    assert all(f"({f:.1f} %)" in label for label, f in fig.fits.items())


def test_compare_names_what_is_missing(sim):
    bare = Run(name="no_u", channels={"t": sim.t, "x": sim["x"]})
    with pytest.raises(hp.DataError, match="no valve command 'u'"):
        compare(bare, hp.ReducedModel(sim.params))
    with pytest.raises(hp.DataError, match="no channel 'q'"):
        compare(sim, sim, channel="q")


def test_frequency_response_to_frd_keeps_every_point():
    f = np.array([2.0, 10.0, 50.0])
    h = 1.0 / (1.0 + 1j * f / 40.0)
    frd = FrequencyResponse(f, h, amplitude=0.25).to_frd()
    np.testing.assert_allclose(frd.omega, 2 * np.pi * f)
    np.testing.assert_allclose(frd(1j * 2 * np.pi * f[1]), h[1])
    assert frd.name == "valve_25pct"


def test_version(capsys):
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"hydropwa {hp.__version__}"


def test_compile_time_is_reported_apart_and_only_once(paper):
    first = hp.simulate(hp.ReducedModel(paper), "step:time=0.01,after=0.2", duration=0.05)
    again = hp.simulate(hp.ReducedModel(paper), "step:time=0.01,after=0.2", duration=0.05)
    assert first.stats["compile_time"] >= 0.0
    assert again.stats["compile_time"] == 0.0  # loaded (or compiled) once per process
    assert again.stats["wall_time"] > 0.0


def test_cli_reference_lists_every_command():
    spec = importlib.util.spec_from_file_location(
        "cli_reference", ROOT / "docs" / "_hooks" / "cli_reference.py"
    )
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    text = mod.cli_reference()
    for cmd in (
        "simulate",
        "linearize",
        "paper",
        "sweep",
        "params show",
        "data check",
        "identify all",
        "rig run",
    ):
        assert f"`hydropwa {cmd}`" in text, cmd
    assert "`--sample-time PERIOD\\|RATE`" in text  # options come from the typer definitions
    assert "`--specimen-stiffness <str>`" in text  # control design's force/pressure output
