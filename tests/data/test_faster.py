"""The FASTER record (real servo-hydraulic fatigue rig): its reader and the model fitted to it.

The reader is checked on the record (every sample kept, a uniform clock within the stamps'
rounding) and on synthetic stamps of a known clock. The shipped ``examples/faster/faster.toml``
is replayed through the CLI exactly as the docs say and must reproduce the stored held-out
prediction (written by ``examples/faster/fit_faster.py --write``) and beat, on the held-out
part, the linear baselines fitted here on the same fitting part.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from hydropwa import DataError
from hydropwa.cli import app
from hydropwa.data import load_faster, read_run, uniform_clock
from hydropwa.evaluation import nrmse_fit
from hydropwa.identification import fit_dmdc, select_arx
from hydropwa.params import load_params

FASTER = Path(__file__).resolve().parents[2] / "examples" / "faster"


@pytest.fixture(scope="module")
def record():
    return load_faster(FASTER / "faster.csv")


def test_reader_restores_the_clock_and_keeps_every_sample(record):
    raw = np.loadtxt(FASTER / "faster.csv", delimiter=",", skiprows=1)
    assert record.n_samples == raw.shape[0] == 14188
    dt = np.diff(record.t)
    assert np.ptp(dt) < 1e-12 and record.fs == pytest.approx(128.98, abs=0.01)
    # every logged stamp is the restored clock rounded to 5 significant digits
    raw_t = raw[:, 0]
    quantum = np.where(raw_t > 0, 10 ** (np.floor(np.log10(np.maximum(raw_t, 1e-300))) - 4), 0.0)
    assert np.all(np.abs(record.t - raw_t) <= 0.5 * quantum + 1e-3 * dt[0])
    assert np.array_equal(record["u_v"], raw[:, 2])  # volts, unchanged
    np.testing.assert_allclose(record["x"], raw[:, 4] * 1e-3, rtol=1e-12)  # mm to m, no filter
    assert "290 repeated stamps" in record.meta["timing"]


def test_uniform_clock_recovers_a_known_clock_and_refuses_jitter():
    dt_true = 1 / 333.3
    t = 0.004 + dt_true * np.arange(40000)
    stamps = np.array([float(f"{v:.5g}") for v in t])  # repeats from 100 s on
    clock, dt, worst = uniform_clock(stamps, 5)
    # rounding up to 5 ms spread over a 120 s span: the slope is good to ~1e-7
    assert dt == pytest.approx(dt_true, rel=1e-6) and worst <= 1.0
    assert np.max(np.abs(clock - t)) < 0.01 * dt_true
    rng = np.random.default_rng(0)
    jittered = t + rng.uniform(-0.3, 0.3, t.size) * dt_true
    with pytest.raises(DataError, match="not uniformly sampled"):
        uniform_clock(jittered, 9)


@pytest.fixture(scope="module")
def results():
    return json.loads((FASTER / "results.json").read_text(encoding="utf-8"))


def test_beam_stiffness_is_the_slope_of_force_over_displacement(record, results):
    fit = record.t < results["fit_until_s"]
    slope = np.polyfit(record["x"][fit], record["f_norm"][fit], 1)[0]  # [1/m]
    k = load_params(FASTER / "faster.toml").load.specimen_stiffness
    # the toml's k is per F_ref; the damping term moves the least-squares slope by < 0.5 %
    assert k / results["assumptions"]["F_ref_N"] == pytest.approx(slope, rel=5e-3)


def test_shipped_toml_reproduces_the_prediction_and_beats_the_baselines(record, results, tmp_path):
    """``hydropwa simulate --params faster.toml --input-file heldout_u.csv`` as documented."""
    prm = load_params(FASTER / "faster.toml")
    x0 = prm.cylinder.stroke / 2 + results["heldout_d0_m"]
    out = tmp_path / "pred.csv"
    args = ["simulate", "--params", str(FASTER / "faster.toml"), "--input-file"]
    args += [str(FASTER / "heldout_u.csv"), "--x0", f"{x0!r} m", "--sample-time"]
    args += [f"{record.fs!r} Hz", "--rtol", "1e-6", "--out", str(out)]
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 0, res.output
    sim = read_run(out)
    stored = np.loadtxt(FASTER / "prediction.csv", delimiter=",", skiprows=1)
    d = np.interp(stored[:, 0], sim.t, sim["x"]) - prm.cylinder.stroke / 2
    y = np.interp(stored[:, 0], sim.t, sim["f_spec"]) / results["assumptions"]["F_ref_N"]
    # the stored prediction ran the same model at the same rtol; interpolation of a 129 Hz
    # grid onto itself is exact, so only the integrator's path may differ: 1e-3 of the RMS
    assert np.max(np.abs(d - stored[:, 1])) < 1e-3 * stored[:, 1].std()
    assert np.max(np.abs(y - stored[:, 2])) < 1e-3 * stored[:, 2].std()
    # the held-out fits against the record, and the linear baselines fitted on the same part
    test = record.t >= results["heldout_start_s"]
    fit = record.t < results["fit_until_s"]
    dy = np.column_stack([record["x"], record["f_norm"]])
    ours = (nrmse_fit(dy[test, 0], d), nrmse_fit(dy[test, 1], y))
    u = record["u_v"]
    arx = select_arx(u[fit], dy[fit], orders=range(1, 7), delays=range(0, 3))
    for base in (
        arx.simulate(u[test], dy[test][0]),
        fit_dmdc(u[fit], dy[fit]).simulate(u[test], dy[test][0]),
    ):
        assert ours[0] >= nrmse_fit(dy[test, 0], base[:, 0])
        assert ours[1] >= nrmse_fit(dy[test, 1], base[:, 1])
    table = results["nrmse_percent"]["physical (full model, faster.toml)"]
    assert ours == pytest.approx((table["d"], table["y"]), abs=0.05)
