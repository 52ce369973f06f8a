"""Bad data is skipped loudly (IdentificationWarning + skipped_) or ends in one IdentificationError."""

from __future__ import annotations

import numpy as np
import pytest
from ident_support import FS, constant_input_runs, hinge_velocity, stepped_sine_runs
from test_friction import _friction_run

from hydropwa._errors import IdentificationError
from hydropwa.data import Run
from hydropwa.identification import (
    DeadZoneIdentifier,
    IdentificationWarning,
    RigGeometry,
    StribeckIdentifier,
    ValveFrfIdentifier,
)
from hydropwa.params import get_preset

LEVELS = np.concatenate([np.arange(0.01, 0.2001, 0.01), -np.arange(0.01, 0.2001, 0.01)])


def _frf_runs():
    return stepped_sine_runs({0.25: 628.3}, noise=0.005, seed=0, step=10.0)


def test_missing_channel_is_skipped():
    runs = _frf_runs()
    bad = Run("no_spool", {"t": runs[0]["t"], "u": runs[0]["u"]}, fs=FS, meta=runs[0].meta)
    with pytest.warns(IdentificationWarning, match="no_spool.*missing channel"):
        ident = ValveFrfIdentifier().fit(runs + [bad])
    assert [s.run for s in ident.skipped_] == ["no_spool"]
    assert "spool" in ident.skipped_[0].reason


def test_run_too_short_for_four_periods_is_skipped():
    runs = _frf_runs()
    t = np.arange(0.0, 1.5 / 2.0, 1 / FS)  # 1.5 periods of 2 Hz
    short = Run(
        "short",
        {"t": t, "u": 0.25 * np.sin(4 * np.pi * t), "spool": 0.25 * np.sin(4 * np.pi * t)},
        fs=FS,
        meta={"experiment": "frf", "frequency": 2.0, "amplitude": 0.25},
    )
    with pytest.warns(IdentificationWarning, match="need 4 full periods"):
        ident = ValveFrfIdentifier().fit(runs + [short])
    assert ident.skipped_[0].run == "short"
    assert ident.fits_[0.25].omega0.value == pytest.approx(628.3, rel=0.05)


def test_non_finite_samples_are_skipped():
    runs = _frf_runs()
    y = np.array(runs[0]["spool"])
    y[5] = np.nan
    bad = runs[0].replace(name="nan_run", channels={**runs[0].channels, "spool": y})
    with pytest.warns(IdentificationWarning, match="non-finite"):
        ident = ValveFrfIdentifier().fit(runs[1:] + [bad])
    assert ident.skipped_[0].run == "nan_run"


def test_no_steady_state_is_skipped():
    p = get_preset("paper")
    speeds = np.concatenate([np.linspace(0.01, 0.17, 6), -np.linspace(0.01, 0.17, 6)])
    runs = [
        _friction_run(
            f"fr_{i}",
            0.1,
            float(v),
            p.friction,
            p.cylinder.area_a,
            p.cylinder.area_b,
            seed=i,
            duration=1.0,
        )
        for i, v in enumerate(speeds)
    ]
    t = runs[0]["t"]
    accel = runs[0].replace(
        name="accelerating", channels={**runs[0].channels, "x": 0.02 + 0.15 * t**2}
    )
    with pytest.warns(IdentificationWarning, match="accelerating.*no steady state"):
        ident = StribeckIdentifier(p).fit(runs + [accel])
    assert [s.run for s in ident.skipped_] == ["accelerating"]


def test_run_that_hits_the_end_stop_is_skipped_or_truncated():
    good = constant_input_runs(LEVELS, lambda u: hinge_velocity(u, 0.1, 0.5, 0.02), duration=1.0)
    # 2 m/s: the rod is at the far stop within 0.1 s; too little is left before it
    fast = constant_input_runs([0.3], lambda u: 2.0, duration=1.0, experiment="deadzone")[
        0
    ].replace(name="fast")
    with pytest.warns(IdentificationWarning, match="fast.*hit the end stop"):
        ident = DeadZoneIdentifier(geometry=RigGeometry(stroke=0.2)).fit(good + [fast])
    assert ident.skipped_[0].run == "fast"
    # a run that reaches the stop late is truncated, not skipped
    late = constant_input_runs([0.19], lambda u: 0.3, duration=1.0)[0].replace(name="late")
    ident = DeadZoneIdentifier(geometry=RigGeometry(stroke=0.2)).fit(good[1:] + [late])
    row = ident.points_.set_index("run").loc["late"]
    assert bool(row["hit_stop"]) and row["v"] == pytest.approx(0.3, rel=1e-3)


def test_nothing_usable_is_one_clear_error():
    runs = [
        Run(f"r{i}", {"t": np.arange(0, 1, 1 / FS)}, fs=FS, meta={"experiment": "deadzone"})
        for i in range(3)
    ]
    with (
        pytest.warns(IdentificationWarning),
        pytest.raises(IdentificationError, match="0 usable run"),
    ):
        DeadZoneIdentifier(geometry=RigGeometry(stroke=0.2)).fit(runs)
    with pytest.raises(IdentificationError, match="no runs"):
        ValveFrfIdentifier().fit([])
