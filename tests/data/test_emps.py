"""Import of the real EMPS benchmark files through the shipped channel map."""

from __future__ import annotations

from importlib import resources

import numpy as np
import pytest
import scipy.io

from hydropwa.data import builtin_channel_map, load_emps, read_run


def test_channel_map_ships_with_package():
    res = resources.files("hydropwa.data").joinpath("channel_maps").joinpath("emps.toml")
    assert res.is_file()
    cmap = builtin_channel_map("emps")
    assert cmap.channels["x"].source == "qm"
    assert cmap.channels["f_m"].gain == "@gtau"
    assert cmap.fs == 1000.0


@pytest.mark.parametrize("stem", ["DATA_EMPS", "DATA_EMPS_PULSES"])
def test_load_emps(emps_dir, stem):
    path = emps_dir / f"{stem}.mat"
    run = load_emps(path)
    raw = scipy.io.loadmat(path)
    assert run.name == stem and run.n_samples == 24841
    assert run.units == {
        "t": "s",
        "x": "m",
        "x_ref": "m",
        "f_m": "N",
        **({"pulses_N": "1"} if stem.endswith("PULSES") else {}),
    }
    assert run.fs == 1000.0
    np.testing.assert_allclose(np.median(np.diff(run.t)), 1e-3, rtol=1e-4)
    assert run.duration == pytest.approx(24.84)
    # position: a ball-screw stroke of about a quarter metre, starting near zero
    assert -1e-3 < run["x"].min() < 1e-3 and 0.2 < run["x"].max() < 0.3
    np.testing.assert_array_equal(run["x"], raw["qm"][:, 0])
    np.testing.assert_allclose(run["f_m"], 35.15065188 * raw["vir"][:, 0], rtol=1e-9)
    assert run.meta["kind"] == "closed_loop" and run.meta["source"] == f"{stem}.mat"


def test_pulses_channel_values(emps_dir):
    run = load_emps(emps_dir / "DATA_EMPS_PULSES.mat")
    assert set(np.unique(run["pulses_N"])) == {0.0, 5.0}


def test_read_run_with_builtin_map_name(emps_dir):
    run = read_run(emps_dir / "DATA_EMPS.mat", channel_map="emps")
    assert run.has("f_m") and run.n_samples == 24841
