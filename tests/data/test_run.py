"""Run: construction rules, SI units inside, pandas, select and resample."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from hydropwa._errors import DataError
from hydropwa.data import Run, convert_units, to_si


def test_canonical_units_are_filled_in(clean_run):
    assert clean_run.units["p_a"] == "Pa"
    assert clean_run.units["x"] == "m"
    assert clean_run.units["u"] == "1"
    assert clean_run.units["temp_oil"] == "K"
    assert clean_run.fs == 1000.0
    assert clean_run.duration == pytest.approx(0.499)
    assert clean_run.kind == "step"
    assert clean_run.has("p_s") and not clean_run.has("q_a")


def test_arrays_are_read_only(clean_run):
    with pytest.raises(ValueError):
        clean_run["p_a"][0] = 1.0


def test_missing_time_channel_is_rejected():
    with pytest.raises(DataError, match=r"run 'r': has no time channel 't'"):
        Run("r", {"x": np.zeros(3)})


def test_non_si_unit_for_canonical_channel_is_rejected():
    with pytest.raises(
        DataError, match=r"channel 'p_a': unit 'bar' inside a Run, expected SI 'Pa'"
    ):
        Run("r", {"t": np.arange(3.0), "p_a": np.ones(3)}, units={"p_a": "bar"})


def test_length_mismatch_names_channel():
    with pytest.raises(DataError, match=r"channel 'x': has 2 samples but 't' has 3"):
        Run("r", {"t": np.arange(3.0), "x": np.ones(2)})


def test_missing_channel_access_names_run_and_channel(clean_run):
    with pytest.raises(DataError, match=r"run 'step_01': no channel 'q_a'"):
        clean_run["q_a"]


def test_fs_estimated_from_time_stamps():
    run = Run("r", {"t": np.arange(11) / 500.0})
    assert run.fs == 500.0


def test_from_pandas_converts_labelled_units_to_si():
    df = pd.DataFrame(
        {
            "t [s]": [0.0, 0.001, 0.002],
            "p_a [bar]": [2.5, 100.0, 210.0],
            "x [mm]": [12.5, 100.0, 250.0],
            "u [%]": [0.0, 50.0, -100.0],
            "q [L/min]": [60.0, 0.0, 6.0],
            "f_l [kN]": [1.5, 0.0, -2.0],
        }
    )
    run = Run.from_pandas(df, name="r")
    np.testing.assert_array_equal(run["p_a"], [2.5e5, 100e5, 210e5])
    np.testing.assert_array_equal(run["x"], [0.0125, 0.1, 0.25])
    np.testing.assert_array_equal(run["u"], [0.0, 0.5, -1.0])
    np.testing.assert_allclose(run["q"], [1e-3, 0.0, 1e-4], rtol=1e-14)
    np.testing.assert_array_equal(run["f_l"], [1500.0, 0.0, -2000.0])
    assert run.units["q"] == "m**3/s"


def test_to_pandas_round_trip(clean_run):
    df = clean_run.to_pandas()
    assert list(df.columns)[0] == "t"
    back = Run.from_pandas(df)
    assert back.name == clean_run.name and back.meta == clean_run.meta
    for ch in clean_run.channels:
        np.testing.assert_array_equal(back[ch], clean_run[ch])


def test_psi_and_mpa_conversion():
    np.testing.assert_allclose(to_si([1.0], "psi", "p_a")[0], [6894.757293168361], rtol=1e-14)
    assert to_si([2.0], "MPa", "p_s")[0][0] == 2e6
    assert convert_units([1.0], "V", "V")[0] == 1.0


def test_wrong_dimension_is_a_data_error():
    with pytest.raises(DataError, match=r"channel 'p_a'.*'mm' cannot be converted to 'Pa'"):
        to_si([1.0], "mm", "p_a", "run 'r', channel 'p_a'")


def test_unknown_unit_is_a_data_error():
    with pytest.raises(DataError, match=r"unknown unit 'barr'.*hint"):
        to_si([1.0], "barr", "p_a")


def test_select_window(clean_run):
    part = clean_run.select(0.1, 0.2)
    assert part.t[0] == pytest.approx(0.1) and part.t[-1] == pytest.approx(0.2)
    assert part.n_samples == 101
    with pytest.raises(DataError, match="no sample in"):
        clean_run.select(5.0, 6.0)


def test_resample_linear_signal_exactly():
    t = np.array([0.0, 0.0011, 0.0019, 0.003, 0.004])
    run = Run("r", {"t": t, "x": 0.1 + 2.0 * t}, fs=1000.0)
    out = run.resample()
    np.testing.assert_allclose(out.t, [0.0, 0.001, 0.002, 0.003, 0.004], atol=1e-15)
    np.testing.assert_allclose(out["x"], 0.1 + 2.0 * out.t, rtol=1e-14)
    assert out.fs == 1000.0


def test_resample_refuses_duplicates():
    run = Run("r", {"t": np.array([0.0, 0.001, 0.001, 0.002])}, fs=1000.0)
    with pytest.raises(DataError, match=r"channel 't', sample 2 .*does not increase"):
        run.resample()
