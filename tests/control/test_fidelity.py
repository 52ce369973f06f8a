"""Closed-loop fidelity of the design models: one controller on full, reduced, pwa and
pwa-chamber (``closed_loop_fidelity``, ``hydropwa control simulate --compare``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from hydropwa import load_params, simulate
from hydropwa.cli import app
from hydropwa.control import (
    ControlError,
    as_reference,
    closed_loop_fidelity,
    design_state_feedback,
    hold_oscillations,
    save_controller,
)
from hydropwa.linearization import linearize

INDUSTRIAL = Path(__file__).parents[1] / "machines" / "industrial.toml"
STEPS = "steps:0 s=25 mm,0.1 s=450 mm,2.5 s=50 mm,5 s=250 mm"


def test_hold_oscillations_of_a_known_signal():
    """A sine of 0.2 mm amplitude on each hold gives a peak-to-peak of 0.4 mm (to 1 %)."""

    class R:
        t = np.linspace(0.0, 2.0, 4001)
        channels = {
            "reference": np.where(t < 1.0, 0.1, 0.2),
            "x": np.where(t < 1.0, 0.1, 0.2) + 0.2e-3 * np.sin(2 * np.pi * 40 * t),
        }

        def __getitem__(self, k):
            return self.channels[k]

    holds = hold_oscillations(R())
    assert [round(h["reference"], 6) for h in holds] == [100.0, 200.0]
    assert all(abs(h["p2p"] - 0.4) < 0.004 for h in holds)
    with pytest.raises(ControlError, match="settle"):
        hold_oscillations(R(), settle=1.0)


@pytest.fixture(scope="module")
def heavy():
    """The industrial axis (63/36 × 500 mm, 250 kg, 210 bar) at 5 kN and the LQR that was the
    default before the valve-aware design (cells without the servo valve, no feed-forward):
    the controller of issue 38's measurement."""
    prm = load_params(INDUSTRIAL).replace(**{"load.force": 5000.0})
    pwa = linearize(prm)
    return prm, pwa, design_state_feedback(pwa, valve=False, feedforward=False, delay=False)


def test_chamber_model_predicts_the_limit_cycle_of_the_heavy_axis(heavy):
    """The valve-blind LQR limit-cycles on the full model (measured 9.4 / 5.1 / 8.6 mm p-p at
    the holds); the load-pressure models see a quiet hold (< 0.1 mm), pwa-chamber predicts each
    hold's p-p within a factor 1.5 of the full model's (measured within 2 %)."""
    prm, pwa, design = heavy
    ref = as_reference(STEPS)
    _, table = closed_loop_fidelity(
        design.controller, ref, params=prm, pwa=pwa, duration=7.0, initial_position=0.025
    )
    holds = [c for c in table.columns if c.startswith("hold_")][1:]  # hold 1: before the move
    full, ch = table.loc["full", holds].to_numpy(), table.loc["pwa-chamber", holds].to_numpy()
    assert np.all(full > 1.0)  # the limit cycle
    assert np.all(table.loc["pwa", holds].to_numpy() < 0.1)
    assert np.all((ch / full > 1 / 1.5) & (ch / full < 1.5)), table
    assert abs(table.loc["pwa-chamber", "saturation"] - table.loc["full", "saturation"]) < 5.0


def test_cli_compare_writes_the_table(heavy, tmp_path):
    prm, pwa, design = heavy
    save_controller(design.controller, tmp_path / "c.toml")
    out = tmp_path / "cmp.csv"
    res = CliRunner().invoke(
        app,
        [
            "control",
            "simulate",
            "-c",
            str(tmp_path / "c.toml"),
            "-p",
            str(INDUSTRIAL),
            "--load-force",
            "5 kN",
            "-r",
            "steps:0 s=25 mm,0.1 s=150 mm",
            "-d",
            "0.8",
            "--compare",
            "--out",
            str(out),
        ],
    )
    assert res.exit_code == 0, res.output
    table = pd.read_csv(out, index_col=0)
    assert list(table.index) == ["full", "reduced", "pwa", "pwa-chamber"]
    assert "max_hold" in table.columns and "saturation" in table.columns
    assert "pwa-chamber" in res.output


def test_cli_simulates_and_linearizes_the_chamber_model(tmp_path):
    r = CliRunner().invoke(
        app,
        [
            "simulate",
            "-p",
            "paper",
            "--model",
            "pwa-chamber",
            "-d",
            "0.2",
            "-o",
            str(tmp_path / "r.csv"),
        ],
    )
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(
        app,
        [
            "linearize",
            "--params",
            "paper",
            "--form",
            "chamber",
            "-o",
            str(tmp_path / "c.json"),
            "--units",
            "engineering",
        ],
    )
    assert r.exit_code == 0, r.output
    assert "cell combinations" in r.output
    from hydropwa.linearization import ChamberPwaModel, load_pwa

    assert isinstance(load_pwa(tmp_path / "c.json"), ChamberPwaModel)
    r = CliRunner().invoke(
        app,
        [
            "linearize",
            "-p",
            "paper",
            "--form",
            "chamber",
            "-o",
            str(tmp_path / "d.json"),
            "--refine-tol",
            "5e6",
        ],
    )
    assert r.exit_code == 2 and "chamber form" in r.output and "Traceback" not in r.output


def test_simulate_by_name_says_how_to_build_it(paper):
    from hydropwa import ParameterError

    with pytest.raises(ParameterError, match=r"linearize\(params, form='chamber'\)"):
        simulate("pwa-chamber", 0.1, duration=0.01, params=paper)


def test_chamber_model_agrees_on_the_quiet_default_design(heavy):
    """Today's default (valve-aware LQR with feed-forward) holds the heavy axis on the full model
    (measured 0.063 / 0.062 / 0.057 mm p-p); pwa-chamber shows the same quiet holds, each within
    a factor 1.5 of the full model's or both below 0.1 mm (issue 38: a controller the full model
    holds, the chamber model holds too)."""
    prm, pwa, _ = heavy
    design = design_state_feedback(pwa, delay=False)
    _, table = closed_loop_fidelity(
        design.controller,
        as_reference(STEPS),
        params=prm,
        pwa=pwa,
        duration=7.0,
        initial_position=0.025,
        models=("full", "pwa-chamber"),
    )
    holds = [c for c in table.columns if c.startswith("hold_")][1:]
    full, ch = table.loc["full", holds].to_numpy(), table.loc["pwa-chamber", holds].to_numpy()
    assert np.all(full < 0.1), table
    ratio_ok = (ch / full > 1 / 1.5) & (ch / full < 1.5)
    assert np.all(ratio_ok | ((full < 0.1) & (ch < 0.1))), table


@pytest.mark.parametrize("machine", ["heavy axis", "paper rig"])
def test_a_hold_within_50_um_on_the_full_model_is_one_on_pwa_chamber(machine, heavy, paper):
    """Issue 38: for a controller that the full model holds within 0.05 mm, pwa-chamber also
    shows ≤ 0.05 mm. The default LQR with a 10× larger integral maximum (1e-3 m·s: weaker
    integral action) stops the 2 Hz dead-band hunting of the default (0.057-0.063 mm on the
    heavy axis at 5 kN). Measured: heavy axis full 0.027 / 0.031 / 0.018 mm, pwa-chamber
    0.028 / 0.036 / 0.016 mm; paper rig full 0.009 / 0.013 / 0.005 mm, pwa-chamber 0.010 /
    0.011 / 0.003 mm. The integral still removes the offset: mean error ≤ 0.05 mm per hold."""
    if machine == "heavy axis":
        prm, pwa, _ = heavy
        ref, dur, x0 = as_reference(STEPS), 7.0, 0.025
    else:
        prm, pwa = paper, linearize(paper)
        ref = as_reference("steps:0 s=20 mm,0.1 s=150 mm,1.5 s=40 mm,3 s=100 mm")
        dur, x0 = 4.5, 0.02
    design = design_state_feedback(pwa, weights={"integral": 1e-3}, delay=False)
    results, table = closed_loop_fidelity(
        design.controller,
        ref,
        params=prm,
        pwa=pwa,
        duration=dur,
        initial_position=x0,
        models=("full", "pwa-chamber"),
    )
    holds = [c for c in table.columns if c.startswith("hold_")][1:]
    assert np.all(table.loc["full", holds].to_numpy() <= 0.05), table
    assert np.all(table.loc["pwa-chamber", holds].to_numpy() <= 0.05), table
    res = results["full"]
    for h in hold_oscillations(res)[1:]:
        sel = (res.t >= h["end"] - 0.25 * (h["end"] - h["start"])) & (res.t <= h["end"])
        assert abs(np.mean(res["x"][sel] - res["reference"][sel])) <= 0.05e-3, h
