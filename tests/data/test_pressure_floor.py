"""A chamber held at a gauge sensor's 0 bar is cavitation, not a clipped converter (issue 37).

The heavy axis' own rig campaign failed its own ``hydropwa data check``: its 90 % FRF runs
drive p_a below ambient for 10–11 samples, where the 0–400 bar transmitter reads its lowest
code. The check now tells the two apart: a chamber pressure at the lowest value of a converter
that starts near ambient lies between it and vacuum (at most 1.013 bar lost), a physical floor
(a ``note``); the top of a range, or a floor well above ambient, is clipping (an ``error``).
"""

from __future__ import annotations

import numpy as np
import pytest

from hydropwa.cli import main
from hydropwa.data import Dataset, Run, check_run
from hydropwa.rig import SensorModel


def _pressure_run(true_p: np.ndarray, lo: float, hi: float) -> Run:
    """p_a (true_p [Pa]) through a transmitter of range (lo, hi) [Pa], 16 bit, 0.08 bar noise."""
    sensor = SensorModel("pt", "p_a", "Pa", (lo, hi), noise_std=8e3)
    n = true_p.size
    p = sensor.apply(true_p, np.random.default_rng(3))
    t = np.arange(n) / 2000.0
    return Run(
        "frf_a90",
        {"t": t, "p_a": p, "u": 0.9 * np.sin(2 * np.pi * 35.0 * t)},
        fs=2000.0,
        meta={"converter_limits": {"p_a": list(sensor.recorded_limits)}},
    )


def _dipping(depth: float, n: int = 4000) -> np.ndarray:
    """30 bar ± 35 bar at 35 Hz, floored at ``depth`` [Pa] (the chamber cannot go lower)."""
    t = np.arange(n) / 2000.0
    return np.maximum(30e5 + 35e5 * np.sin(2 * np.pi * 35.0 * t), depth)


def test_a_chamber_at_a_gauge_sensors_zero_is_a_physical_floor():
    run = _pressure_run(_dipping(-0.95e5), 0.0, 400e5)
    issues = check_run(run)
    assert [i.code for i in issues] == ["pressure_floor"], [str(i) for i in issues]
    (note,) = issues
    assert note.severity == "note" and note.channel == "p_a"
    assert "cavitating" in note.message and "not a clipped converter" in note.message
    assert "1.013e+05 Pa under the reading" in note.message  # the most that can be lost


def test_the_top_of_the_range_is_still_clipping():
    p = np.minimum(_dipping(1e5) + 200e5, 600e5)
    issues = [i for i in check_run(_pressure_run(p, 0.0, 250e5)) if i.severity == "error"]
    assert [i.code for i in issues] == ["clipped"] and "highest" in issues[0].message


def test_a_floor_well_above_ambient_is_clipping():
    """A 50–250 bar transmitter at 50 bar hides up to 51 bar: that is a clipped converter."""
    issues = check_run(_pressure_run(_dipping(-0.95e5), 50e5, 250e5))
    assert [(i.code, i.severity) for i in issues] == [("clipped", "error")]
    assert "lowest" in issues[0].message


def test_a_whole_run_at_zero_is_still_an_error():
    """A sensor reading 0 bar for the whole run is dead or unplugged, not cavitation."""
    issues = check_run(_pressure_run(np.full(2000, -0.5e5), 0.0, 400e5))
    assert any(i.code == "clipped" and i.severity == "error" for i in issues)


def test_data_check_passes_with_notes(tmp_path, capsys):
    Dataset.create(tmp_path / "frf").write([_pressure_run(_dipping(-0.95e5), 0.0, 400e5)])
    assert main(["data", "check", str(tmp_path / "frf"), "--plain"]) == 0
    out = capsys.readouterr().out
    assert out.count("note: ") == 1 and "ok:" in out and "1 note(s)" in out


@pytest.mark.parametrize("channel", ["p_a", "p_b"])
def test_the_plateau_check_does_not_call_the_floor_clipping(channel):
    """The plateau check (a flat extreme in a changing signal) sees the same samples."""
    run = _pressure_run(_dipping(-0.95e5), 0.0, 400e5)
    if channel == "p_b":
        ch = dict(run.channels)
        ch["p_b"] = ch.pop("p_a")
        run = Run(run.name, ch, fs=run.fs, meta={"converter_limits": {"p_b": [0.0, 4e7]}})
    assert [i.severity for i in check_run(run)] == ["note"]
