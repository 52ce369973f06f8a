"""Writers and readers: CSV, Parquet, MAT; units preserved; channel maps for raw logs."""

from __future__ import annotations

import json

import numpy as np
import pyarrow.parquet as pq
import pytest
import scipy.io
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from hydropwa._errors import DataError
from hydropwa.data import ChannelMap, Run, read_run, write_run

FORMATS = ["csv", "parquet", "mat"]


@pytest.mark.parametrize("fmt", FORMATS)
def test_round_trip_si(tmp_path, clean_run, fmt):
    path = write_run(clean_run, tmp_path / f"r.{fmt}")
    back = read_run(path)
    assert back.name == "step_01"
    assert back.units == clean_run.units
    assert back.fs == 1000.0
    assert back.meta == clean_run.meta
    assert list(back.channels) == list(clean_run.channels)
    for ch in clean_run.channels:
        np.testing.assert_array_equal(back[ch], clean_run[ch], err_msg=ch)


@pytest.mark.parametrize("fmt", FORMATS)
def test_round_trip_through_bar_and_mm(tmp_path, clean_run, fmt):
    units = {
        "p_a": "bar",
        "p_s": "MPa",
        "x": "mm",
        "v": "mm/s",
        "u": "%",
        "f_l": "kN",
        "temp_oil": "degC",
    }
    path = write_run(clean_run, tmp_path / f"r.{fmt}", units=units)
    back = read_run(path)
    assert back.units["p_a"] == "Pa" and back.units["x"] == "m" and back.units["temp_oil"] == "K"
    for ch in clean_run.channels:
        np.testing.assert_allclose(back[ch], clean_run[ch], rtol=2e-16 * 4, atol=0, err_msg=ch)
    # the file really holds bar and mm
    if fmt == "parquet":
        table = pq.read_table(path)
        assert table.schema.field("p_a").metadata[b"unit"] == b"bar"
        np.testing.assert_allclose(table.column("p_a").to_numpy(), clean_run["p_a"] / 1e5)
    if fmt == "mat":
        raw = scipy.io.loadmat(path)
        assert raw["x"].shape == (clean_run.n_samples, 1)
        np.testing.assert_allclose(raw["x"][:, 0], clean_run["x"] * 1000.0)


def test_handwritten_csv_in_bar_and_mm_reads_exact_si(tmp_path):
    path = tmp_path / "manual.csv"
    path.write_text(
        "# hand-written log\n"
        '# hydropwa: {"name": "manual", "meta": {"kind": "stribeck"}}\n'
        "t [s], p_a [bar], x [mm], u [%], f_l [kN]\n"
        "0.000, 2.5, 12.5, 10, 1.5\n"
        "0.001, 100, 100, 50, 0\n"
        "0.002, 210.0, 250, -100, -2\n",
        encoding="utf-8",
    )
    run = read_run(path)
    assert run.name == "manual" and run.kind == "stribeck" and run.fs == 1000.0
    np.testing.assert_array_equal(run["p_a"], [250000.0, 1e7, 2.1e7])
    np.testing.assert_array_equal(run["x"], [0.0125, 0.1, 0.25])
    np.testing.assert_array_equal(run["u"], [0.1, 0.5, -1.0])
    np.testing.assert_array_equal(run["f_l"], [1500.0, 0.0, -2000.0])


def test_csv_format_header_and_metadata_line(tmp_path, clean_run):
    path = write_run(clean_run, tmp_path / "r.csv", units={"p_a": "bar"})
    lines = path.read_text(encoding="utf-8").splitlines()
    assert lines[0].startswith("# hydropwa: ")
    header = json.loads(lines[0][len("# hydropwa: ") :])
    assert header["format_version"] == 1 and header["fs"] == 1000.0
    assert header["meta"]["signal"] == {"type": "step", "amplitude": 0.5}
    assert lines[1].split(",")[:5] == ["t [s]", "u [1]", "spool [1]", "z [1]", "x [m]"]
    assert "p_a [bar]" in lines[1].split(",")
    assert len(lines) == 2 + clean_run.n_samples


def test_csv_text_cell_names_channel_and_sample(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("t [s],x [m]\n0.0,0.1\n0.001,oops\n", encoding="utf-8")
    with pytest.raises(
        DataError, match=r"channel 'x', sample 1 \(line 3\): 'oops' is not a number"
    ):
        read_run(path)


def test_csv_channel_without_unit_is_rejected(tmp_path):
    path = tmp_path / "nounit.csv"
    path.write_text("t [s],pressure\n0.0,1\n0.001,2\n", encoding="utf-8")
    with pytest.raises(
        DataError, match=r"channel 'pressure': no unit declared.*'pressure \[unit\]'"
    ):
        read_run(path)


def test_unknown_suffix(tmp_path, clean_run):
    with pytest.raises(DataError, match=r"suffix '.xlsx'"):
        write_run(clean_run, tmp_path / "r.xlsx")


def test_mat_without_metadata_needs_channel_map(tmp_path):
    path = tmp_path / "log.mat"
    scipy.io.savemat(path, {"time": np.arange(5.0)[:, None]})
    with pytest.raises(DataError, match=r"MAT file without hydropwa metadata.*channel map"):
        read_run(path)


def _speedgoat_matrix_log(tmp_path):
    """A real-time log: one (N, 4) matrix of volts plus a time vector and a scalar gain."""
    n = 200
    t = np.arange(n) / 500.0
    rng = np.random.default_rng(3)
    volts = np.column_stack(
        [
            4.0 + 0.1 * rng.normal(size=n),  # p_a: 25 bar/V
            2.0 + 0.1 * rng.normal(size=n),  # p_b
            1.0 + 0.5 * np.sin(2 * np.pi * t),  # x: 50 mm/V, offset -10 mm
            3.0 * np.sin(2 * np.pi * 3 * t),  # u: +-10 V -> +-100 %
        ]
    )
    path = tmp_path / "speedgoat.mat"
    scipy.io.savemat(path, {"tg_time": t[:, None], "data": volts.T, "k_pa": np.array([[25.0]])})
    cmap_path = tmp_path / "map.toml"
    cmap_path.write_text(
        '[map]\nname = "rig1"\n[meta]\nrig = "test bench"\n'
        '[channels.t]\nsource = "tg_time"\n'
        '[channels.p_a]\nsource = "data"\ncolumn = 1\nunit = "bar"\ngain = "@k_pa"\n'
        '[channels.p_b]\nsource = "data"\ncolumn = 2\nunit = "bar"\ngain = 25.0\n'
        '[channels.x]\nsource = "data"\ncolumn = 3\nunit = "mm"\ngain = 50.0\noffset = -10.0\n'
        '[channels.u]\nsource = "data"\ncolumn = 4\nunit = "%"\ngain = 10.0\n',
        encoding="utf-8",
    )
    return path, cmap_path, t, volts


def test_mat_matrix_log_through_channel_map(tmp_path):
    path, cmap_path, t, volts = _speedgoat_matrix_log(tmp_path)
    run = read_run(path, channel_map=cmap_path)
    assert run.meta["rig"] == "test bench" and run.meta["channel_map"] == "rig1"
    assert run.fs == 500.0
    np.testing.assert_allclose(run["p_a"], volts[:, 0] * 25.0 * 1e5, rtol=1e-15)
    np.testing.assert_allclose(run["p_b"], volts[:, 1] * 25.0 * 1e5, rtol=1e-15)
    np.testing.assert_allclose(run["x"], (volts[:, 2] * 50.0 - 10.0) / 1000.0, rtol=1e-14)
    np.testing.assert_allclose(run["u"], volts[:, 3] * 10.0 / 100.0, rtol=1e-15)


def test_channel_map_column_out_of_range(tmp_path):
    path, _, _, _ = _speedgoat_matrix_log(tmp_path)
    cmap = ChannelMap.from_dict(
        {"channels": {"t": {"source": "tg_time"}, "p_a": {"source": "data", "column": 7}}}
    )
    with pytest.raises(
        DataError, match=r"channel 'p_a' \(source 'data'\): column 7 out of range 1..4"
    ):
        read_run(path, cmap)


def test_channel_map_matrix_without_column(tmp_path):
    path, _, _, _ = _speedgoat_matrix_log(tmp_path)
    cmap = ChannelMap.from_dict({"channels": {"t": "tg_time", "p_a": "data"}})
    with pytest.raises(DataError, match=r"has shape \(4, 200\); hint: give column"):
        read_run(path, cmap)


def test_dspace_struct_export(tmp_path):
    n = 100
    t = np.arange(n) / 1000.0
    y = np.array(
        [("p_A", 50.0 + np.sin(t)), ("p_B", 30.0 + np.cos(t))], dtype=[("Name", "O"), ("Data", "O")]
    )
    path = tmp_path / "dspace.mat"
    scipy.io.savemat(path, {"rec": {"X": {"Data": t}, "Y": y}})
    cmap = ChannelMap.from_dict(
        {
            "channels": {
                "t": {"source": "rec.X.Data"},
                "p_a": {"source": "rec.Y{p_A}.Data", "unit": "bar"},
                "p_b": {"source": "rec.Y(2).Data", "unit": "bar"},
            }
        }
    )
    run = read_run(path, cmap)
    np.testing.assert_allclose(run["p_a"], (50.0 + np.sin(t)) * 1e5, rtol=1e-15)
    np.testing.assert_allclose(run["p_b"], (30.0 + np.cos(t)) * 1e5, rtol=1e-15)


def test_channel_map_unknown_variable(tmp_path):
    path, _, _, _ = _speedgoat_matrix_log(tmp_path)
    cmap = ChannelMap.from_dict({"channels": {"t": "time"}})
    with pytest.raises(
        DataError, match=r"variable 'time' not found \(have \['data', 'k_pa', 'tg_time'\]\)"
    ):
        read_run(path, cmap)


def test_channel_map_toml_syntax_error(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[channels.t\nsource = 't'\n", encoding="utf-8")
    with pytest.raises(DataError, match=r"invalid TOML"):
        ChannelMap.from_toml(bad)


def test_channel_map_for_csv_columns(tmp_path):
    path = tmp_path / "raw.csv"
    path.write_text("time,ch1,ch2\n0,1.0,2\n0.01,1.5,2\n0.02,2.0,2\n", encoding="utf-8")
    cmap = ChannelMap.from_dict(
        {"channels": {"t": "time", "p_s": {"source": "ch1", "unit": "MPa"}}}
    )
    run = read_run(path, cmap, validate=False)
    np.testing.assert_array_equal(run["p_s"], [1e6, 1.5e6, 2e6])
    assert run.fs == 100.0 and set(run.channels) == {"t", "p_s"}


finite = st.floats(
    min_value=-1e12, max_value=1e12, allow_nan=False, allow_infinity=False, allow_subnormal=False
)


@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    data=arrays(np.float64, st.tuples(st.integers(1, 30), st.integers(1, 4)), elements=finite),
    fmt=st.sampled_from(["csv", "parquet"]),
)
def test_property_round_trip_random_finite_channels(tmp_path, data, fmt):
    n, m = data.shape
    chans = {"t": np.arange(n) * 0.01}
    chans.update({f"ch{j}": data[:, j] for j in range(m)})
    run = Run("prop", chans, units={f"ch{j}": "V" for j in range(m)}, fs=100.0)
    back = read_run(write_run(run, tmp_path / f"p.{fmt}"), validate=False)
    assert back.units == run.units
    for ch in run.channels:
        np.testing.assert_array_equal(back[ch], run[ch])
