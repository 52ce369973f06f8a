"""Which model can represent a loop (issue 49): the load-pressure models leave the valve out,
which is wrong where ω0 is near ω_h; ``control simulate --compare`` honours its options and
says so."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from hydropwa import load_params, save_params
from hydropwa.cli import main
from hydropwa.control import (
    VALVE_FACTOR,
    hydraulic_frequency,
    save_controller,
    valve_warning,
)
from hydropwa.models import FullOrderModel
from hydropwa.simulation._small_signal import full_small_signal


@pytest.mark.parametrize("machine", ["paper", "tests/machines/industrial.toml"])
def test_hydraulic_frequency_is_the_full_models_oil_spring_mode(machine, paper):
    """ω_h of the closed form is the undamped mode of the compiled full model's Jacobian at mid
    stroke with the valve closed (friction slope removed): the eigenvalues ±jω_h of its
    [P_A, P_B, x, v] block, to 1e-9 (a different path: the kernel's Jacobian)."""
    prm = paper if machine == "paper" else load_params(machine)
    ideal = prm.replace(**{"supply.model": "ideal"})
    x = 0.5 * prm.cylinder.stroke
    ss = full_small_signal(FullOrderModel(ideal), 0.0, x, float(prm.supply.pressure), 0.0)
    block = np.array(ss.A)[2:, 2:].copy()
    assert ss.states[2:] == ("p_a", "p_b", "x", "v")
    block[3, 3] = 0.0  # the friction's slope at rest: the undamped oil spring alone
    wn = float(np.max(np.abs(np.linalg.eigvals(block).imag)))
    assert hydraulic_frequency(prm) == pytest.approx(wn, rel=1e-9)


def test_valve_warning_names_the_models_that_leave_the_valve_out(paper):
    """ω0 = ω_h: the reduced and pwa models are flagged, naming the model to trust; the full
    and pwa-chamber models keep the valve. The paper rig (ω0 = 0.44 ω_h) and a valve 2.2x
    faster than ω_h are outside the band; the loop's bandwidth is a second test."""
    wh = hydraulic_frequency(paper)
    near = paper.replace(**{"valve.omega0": wh})
    for model in ("reduced", "pwa"):
        w = valve_warning(near, model)
        assert f"the {model} model leaves the servo valve out" in w and "trust the full model" in w
    assert valve_warning(near, "full") == valve_warning(near, "pwa-chamber") == ""
    assert paper.valve.omega0 < wh / VALVE_FACTOR and valve_warning(paper, "pwa") == ""
    fast = paper.replace(**{"valve.omega0": 1.1 * VALVE_FACTOR * wh})
    assert valve_warning(fast, "pwa") == ""
    bw = paper.valve.omega0 / (2 * math.pi) / 2.0  # ω0 only twice the bandwidth
    assert "the loop's bandwidth" in valve_warning(paper, "pwa", bandwidth=bw)


def test_compare_honours_the_sensor_noise_and_warns_for_a_valve_near_omega_h(
    paper, default, tmp_path, capsys
):
    """``control simulate --compare`` on a machine with ω0 = ω_h: the rows with 0 and 200 µm
    of position noise differ (before: identical), every load-pressure model is flagged on
    stderr; ``--model`` with ``--compare`` is one line, exit 2."""
    near = paper.replace(**{"valve.omega0": hydraulic_frequency(paper)})
    save_params(near, tmp_path / "near.toml")
    ctrl = tmp_path / "c.toml"
    save_controller(default, ctrl, machine_parameters=paper)
    base = [
        "control",
        "simulate",
        "--controller",
        str(ctrl),
        "--params",
        str(tmp_path / "near.toml"),
    ]
    base += ["--reference", "steps:0=100 mm,0.05=110 mm", "--duration", "0.4 s", "--compare"]
    tables = {}
    for noise in ("0 um", "200 um"):
        out = tmp_path / f"cmp_{noise.split()[0]}.csv"
        assert main([*base, "--sensor-noise", f"x={noise}", "--out", str(out)]) == 0
        err = capsys.readouterr().err
        for model in ("reduced", "pwa"):
            assert f"warning: the {model} model leaves the servo valve out" in err, err
        assert "the full model leaves" not in err
        tables[noise] = pd.read_csv(out, index_col=0)
    a, b = tables["0 um"], tables["200 um"]
    assert list(a.index) == ["full", "reduced", "pwa", "pwa-chamber"]
    # the noise reaches every model: its hold and tracking columns move
    for model in a.index:
        assert not np.allclose(a.loc[model].to_numpy(), b.loc[model].to_numpy()), model
    assert main([*base, "--model", "pwa", "--out", str(tmp_path / "x.csv")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--compare" in err[0] and "--model" in err[0], err
