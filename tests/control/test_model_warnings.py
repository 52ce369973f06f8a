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


def test_the_loops_bandwidth_reaches_the_warning_of_compare(paper, default, tmp_path):
    """The design records its loop's bandwidth (the fastest cell's r → x, the table's maximum)
    in the controller and its file; ``closed_loop_fidelity`` (``control simulate --compare``)
    checks the valve against it: a machine whose 80 Hz valve is outside the ω_h band (ω_h
    227 Hz) but below 3 × the paper design's ~29 Hz bandwidth flags reduced and pwa; the
    paper's own 100 Hz valve (above 3 × 29 = 88 Hz) flags nothing."""
    from hydropwa.control import (
        as_reference,
        closed_loop_fidelity,
        design_state_feedback,
        load_controller,
        loop_bandwidth,
    )
    from hydropwa.control._fidelity import BANDWIDTH_FACTOR
    from hydropwa.linearization import linearize

    d = design_state_feedback(linearize(paper))
    assert loop_bandwidth(d.controller) == pytest.approx(float(d.table["bandwidth_hz"].max()))
    bw = loop_bandwidth(default)
    assert bw is not None and 20.0 < bw < 40.0
    save_controller(default, tmp_path / "c.toml", machine_parameters=paper)
    assert loop_bandwidth(load_controller(tmp_path / "c.toml")) == pytest.approx(bw)
    slow = paper.replace(**{"valve.omega0": 2 * math.pi * 80.0})
    wh = hydraulic_frequency(slow)
    assert slow.valve.omega0 < wh / VALVE_FACTOR  # outside the ω_h band: the bandwidth alone
    assert slow.valve.omega0 < BANDWIDTH_FACTOR * 2 * math.pi * bw < paper.valve.omega0
    ref = "steps:0=100 mm,0.05=110 mm"
    for prm, flagged in ((slow, True), (paper, False)):
        _, table = closed_loop_fidelity(
            default,
            as_reference(ref),
            params=prm,
            duration=0.3,
            models=("full", "reduced", "pwa"),
        )
        lines = [w for w in table.attrs["warnings"] if "the loop's bandwidth" in w]
        assert len(lines) == (2 if flagged else 0), table.attrs["warnings"]
        assert all(f"{bw:.0f} Hz" in w and "trust the full model" in w for w in lines)


def test_a_pwa_run_that_leaves_the_cells_is_flagged_with_its_share(paper, default):
    """A PWA model whose friction cells span ±50 mm/s only, on a trapezoid cruising at
    0.2 m/s: the pwa run leaves its cells for the cruise and is flagged with the share of its
    samples outside them, the share recomputed here from the run's P_L and v and the cells'
    boxes; on the default PWA model (−0.44…0.56 m/s) the same run stays inside, nothing said."""
    from hydropwa.control import as_reference, closed_loop_fidelity
    from hydropwa.control._fidelity import CELL_EXIT_SHARE
    from hydropwa.linearization import linearize

    ref = as_reference("trapezoid:from=50 mm,to=100 mm,v=0.2,a=5,start=0.05")
    for pwa, flagged in ((linearize(paper, friction_range=(-0.05, 0.05)), True), (None, False)):
        runs, table = closed_loop_fidelity(
            default, ref, params=paper, pwa=pwa, duration=0.4, models=("full", "pwa")
        )
        lines = [w for w in table.attrs["warnings"] if "leaves the PWA model's cells" in w]
        if not flagged:
            assert lines == [], table.attrs["warnings"]
            continue
        boxes = pwa.regions()
        lo = np.min([b[1] for b in boxes], axis=0)
        hi = np.max([b[2] for b in boxes], axis=0)
        assert (lo[1], hi[1]) == (-0.05, 0.05)
        pl, v = np.asarray(runs["pwa"]["p_l"]), np.asarray(runs["pwa"]["v"])
        share = np.mean((pl < lo[0]) | (pl > hi[0]) | (v < lo[1]) | (v > hi[1]))
        assert 0.3 < share < 0.8 and share > CELL_EXIT_SHARE  # the cruise: ~0.2 s of 0.4 s
        (line,) = lines
        assert f"in {share:.0%} of its samples" in line and "trust the full model" in line
