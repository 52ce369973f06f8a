"""Validation on load: each failure from a small bad file, reported with run, channel, sample."""

from __future__ import annotations

import numpy as np
import pytest

from hydropwa._errors import DataError
from hydropwa.data import Run, check_run, read_run, validate_run, write_run


def _write_bad(make_run, tmp_path, name, **changes):
    """Write a copy of the clean run with some channels replaced, as CSV (SI units)."""
    run = make_run(name=name)
    chans = {k: np.array(v) for k, v in run.channels.items()}
    for k, fn in changes.items():
        chans[k] = fn(chans[k])
    return write_run(
        Run(name, chans, run.units, fs=run.fs, meta=run.meta), tmp_path / f"{name}.csv"
    )


def _set(index, value):
    def fn(a):
        a[index] = value
        return a

    return fn


def test_clean_run_passes(clean_run):
    assert check_run(clean_run) == []
    report = validate_run(clean_run)
    assert report.ok and report.run is clean_run and report.repairs == []


def test_duplicated_time_stamp(make_run, tmp_path):
    path = _write_bad(make_run, tmp_path, "dup", t=_set(100, 0.099))
    with pytest.raises(DataError) as err:
        read_run(path)
    msg = str(err.value)
    assert "run 'dup', channel 't', sample 100 (t = 0.099 s)" in msg
    assert "repeats the previous time stamp" in msg and "drop_duplicates=True" in msg


def test_decreasing_time(make_run, tmp_path):
    path = _write_bad(make_run, tmp_path, "back", t=_set(300, 0.1))
    with pytest.raises(
        DataError,
        match=r"run 'back', channel 't', sample 300 \(t = 0.1 s\): "
        r"time goes backwards",
    ):
        read_run(path)


def test_duplicates_dropped_only_on_request(make_run, tmp_path):
    run = make_run("dup")
    rows = np.insert(np.arange(500), 101, 100)  # sample 100 logged twice
    dup = run.replace(channels={k: v[rows] for k, v in run.channels.items()})
    path = write_run(dup, tmp_path / "dup.csv")
    with pytest.raises(DataError, match=r"channel 't', sample 101 \(t = 0.1 s\): repeats"):
        read_run(path)
    fixed = read_run(path, drop_duplicates=True)
    assert fixed.n_samples == 500
    np.testing.assert_array_equal(fixed["p_a"], run["p_a"])


def test_non_uniform_sampling_and_explicit_resample(make_run, tmp_path):
    path = _write_bad(
        make_run, tmp_path, "jit", t=lambda t: t + np.where(np.arange(t.size) == 250, 3e-4, 0)
    )
    with pytest.raises(
        DataError,
        match=r"run 'jit', channel 't', sample 250 \(t = 0.2503 s\): "
        r"non-uniform sampling.*hint: resample explicitly",
    ):
        read_run(path)
    raw = read_run(path, validate=False)
    report = validate_run(raw, resample=True)
    assert report.repairs == ["resampled to a uniform grid at 1000 Hz"]
    np.testing.assert_allclose(np.diff(report.run.t), 1e-3, rtol=1e-9)
    assert report.run.n_samples == 500


def test_time_gap(make_run, tmp_path):
    run = make_run("gap")
    keep = np.r_[0:200, 250:500]
    gap = Run("gap", {k: v[keep] for k, v in run.channels.items()}, run.units, fs=1000.0)
    path = write_run(gap, tmp_path / "gap.parquet")
    with pytest.raises(
        DataError,
        match=r"run 'gap', channel 't', sample 200 \(t = 0.25 s\): gap in "
        r"time: t jumps 0.051 s from sample 199",
    ):
        read_run(path)


def test_nan_in_channel(make_run, tmp_path):
    path = _write_bad(make_run, tmp_path, "nan", p_b=_set(slice(42, 45), np.nan))
    with pytest.raises(DataError) as err:
        read_run(path)
    msg = str(err.value)
    assert "run 'nan', channel 'p_b', sample 42 (t = 0.042 s): 3 NaN/inf value(s)" in msg
    assert "interpolate_gaps=True" in msg
    run = read_run(path, interpolate_gaps=True)
    p = read_run(path, validate=False)["p_b"]
    np.testing.assert_allclose(run["p_b"][42:45], p[41] + (p[45] - p[41]) * np.arange(1, 4) / 4)


def test_nan_is_kept_without_repair(make_run, tmp_path):
    path = _write_bad(make_run, tmp_path, "nan", p_b=_set(42, np.nan))
    run = read_run(path, validate=False)
    assert run.n_samples == 500 and np.isnan(run["p_b"][42])


def test_clipped_adc(make_run, tmp_path):
    def clip(p):
        p[300:340] = p.max() + 1e5
        return p

    path = _write_bad(make_run, tmp_path, "clip", p_a=clip)
    with pytest.raises(DataError) as err:
        read_run(path)
    msg = str(err.value)
    assert "run 'clip', channel 'p_a', sample 300 (t = 0.3 s): stuck at its maximum" in msg
    assert "for 40 samples" in msg and "saturated" in msg


def test_clipping_at_minimum_reported_by_check(clean_run):
    chans = dict(clean_run.channels)
    f = np.array(chans["f_l"])
    f[f < -1500.0] = -1500.0
    chans["f_l"] = f
    f[100:120] = -1500.0
    issues = check_run(clean_run.replace(channels=chans))
    assert [(i.code, i.channel, i.sample) for i in issues] == [("clipped", "f_l", 100)]
    assert "minimum -1500 N for 20 samples" in issues[0].message


def test_saturated_command_is_not_clipping(clean_run):
    chans = dict(clean_run.channels)
    chans["u"] = np.clip(3 * chans["u"], -1, 1)
    assert check_run(clean_run.replace(channels=chans)) == []


def test_pressure_in_bar_declared_as_pa(tmp_path):
    path = tmp_path / "bar_as_pa.csv"
    t = np.arange(100) / 1000
    p = 80.0 + 5 * np.sin(2 * np.pi * 10 * t)
    path.write_text(
        "t [s],p_a [Pa]\n"
        + "".join(f"{a!r},{b!r}\n" for a, b in zip(t.tolist(), p.tolist(), strict=True)),
        encoding="utf-8",
    )
    with pytest.raises(DataError) as err:
        read_run(path)
    msg = str(err.value)
    assert "run 'bar_as_pa', channel 'p_a', sample 25 (t = 0.025 s): peak |value| 85 Pa" in msg
    assert "look like bar" in msg and "'p_a [bar]'" in msg


def test_position_in_mm_declared_as_m(make_run, tmp_path):
    path = _write_bad(make_run, tmp_path, "mm", x=lambda x: x * 1000.0)
    with pytest.raises(DataError) as err:
        read_run(path)
    msg = str(err.value)
    assert "run 'mm', channel 'x', sample 0 (t = 0 s): value 100" in msg
    assert "outside the plausible range [-0.05, 2] m" in msg and "look like mm" in msg


def test_valve_command_in_percent_declared_as_fraction(clean_run):
    chans = dict(clean_run.channels)
    chans["u"] = chans["u"] * 100.0
    issues = check_run(clean_run.replace(channels=chans))
    assert any(i.channel == "u" and "percent" in i.hint for i in issues)


def test_check_run_lists_every_issue_without_raising(clean_run):
    chans = {k: np.array(v) for k, v in clean_run.channels.items()}
    chans["t"][10] = chans["t"][9]
    chans["p_s"][5] = np.nan
    chans["x"] = chans["x"] * 1000
    issues = check_run(clean_run.replace(channels=chans))
    assert {(i.code, i.channel) for i in issues} == {
        ("time_duplicate", "t"),
        ("nonfinite", "p_s"),
        ("implausible_magnitude", "x"),
    }
    dup = next(i for i in issues if i.code == "time_duplicate")
    assert (dup.run, dup.sample, dup.severity) == ("step_01", 10, "error")
    with pytest.raises(DataError, match=r"\[2 more error\(s\)"):
        validate_run(clean_run.replace(channels=chans))
    report = validate_run(clean_run.replace(channels=chans), raise_on_error=False)
    assert not report.ok and len(report.issues) == 3


def test_declared_fs_mismatch_is_a_warning(clean_run):
    issues = check_run(clean_run.replace(fs=500.0))
    assert [(i.code, i.severity) for i in issues] == [("fs_mismatch", "warning")]
    assert validate_run(clean_run.replace(fs=500.0)).issues == issues


def test_a_huge_value_on_a_flat_channel_is_an_issue_not_an_overflow(make_run):
    """A channel at one value except a sample of 1.2e154 (found by the fuzz test): the spike
    check's spread (the MAD is 0 there) no longer overflows the sum of squares; the value is
    reported by the range check like any implausible number."""
    import warnings

    run = make_run("huge")
    chans = dict(run.channels)
    f = np.full_like(chans["f_l"], 100.0)
    f[50] = 1.2067969983934732e154
    chans["f_l"] = f
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        issues = check_run(Run("huge", chans, run.units, fs=run.fs))
    assert any(i.channel == "f_l" for i in issues)
