"""The quiet band's opening delay (schema 2, ``DeadZoneInverse.quiet_open``): at rest the band
opens the valve only on the n-th consecutive sample beyond q on one side, n sized from the
command noise's correlation, and the pressure vent no longer pushes the rod away from the target
beyond the band (issue 34, the paper rig's hold within 0.03 mm on every noise seed)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from paper_cases import NOISE, paper_trapezoid

from hydropwa.control import (
    QUIET_OPEN_CORRELATION,
    ControlError,
    command_noise,
    command_noise_correlation,
    load_controller,
    quiet_open_for,
    save_controller,
)
from hydropwa.simulation import _controller as C


@settings(max_examples=200, deadline=None)
@given(
    cs=st.lists(st.floats(-0.05, 0.05), min_size=1, max_size=40),
    q=st.floats(1e-4, 0.03),
    n=st.integers(0, 8),
    fars=st.lists(st.booleans(), min_size=40, max_size=40),
)
def test_quiet_open_passes_c_only_after_a_run_of_n_samples_on_one_side(cs, q, n, fars):
    """Over any sequence of commands: the count is the signed run of samples beyond q on this
    sample's side (0 within ±q), whether or not the error is beyond the integral band; c passes
    unchanged exactly where that run has reached n or the error is beyond the integral band
    (``far``), and is limited to ±q elsewhere (the band's edge: parked or the vent's opening);
    n ≤ 1 never changes c (the band as before); a command alternating in sign beyond q never
    opens with n ≥ 2; odd in c."""
    count, run, side = 0.0, 0, 0
    for c, far in zip(cs, fars, strict=False):
        prev = count
        out, count = C.quiet_open(c, q, count, float(n), far)
        s = 1 if c > q else (-1 if c < -q else 0)
        run = run + 1 if (s != 0 and s == side) else (1 if s != 0 else 0)
        side = s
        assert count == s * run
        if run >= n or n <= 1 or far:
            assert out == c
        else:
            assert out == min(max(c, -q), q) and abs(out) <= q
        assert C.quiet_open(-c, q, -prev, float(n), far) == (-out, -count)
    if n >= 2:
        count = 0.0
        for i in range(20):
            out, count = C.quiet_open((-1) ** i * 3.0 * q, q, count, float(n), False)
            assert abs(out) == q


@settings(max_examples=200, deadline=None)
@given(share=st.floats(-0.05, 0.05), ex=st.floats(-0.1, 0.1), q=st.floats(1e-4, 0.03))
def test_the_vent_does_not_push_away_from_the_target_beyond_the_band(share, ex, q):
    """With the delay the vent's share is 0 exactly where it points away from the target
    (share·k_x e < 0) while |k_x e| > q; elsewhere it is unchanged."""
    out = C.vent_toward_target(share, q, ex)
    assert out == (0.0 if share * ex < 0.0 and abs(ex) > q else share)


def test_correlation_is_the_observer_error_recursion(default):
    """ρ(k) of :func:`command_noise_correlation` against the observer's error recursion driven
    by seeded white noise (ε⁺ = A ε − L n, the command noise g·ε + k_pl·n_PL) over 400 000
    samples: within 0.02 at lags 1-15 (the sample autocorrelation's standard error is about
    1/√N·√(1 + 2Σρ²) ≈ 0.004). The variance at lag 0 is :func:`command_noise`'s."""
    ts = default.sample_time
    lx, lv = default.position_observer
    L = np.array([lx, lv])
    A = (np.eye(2) - np.outer(L, [1.0, 0.0])) @ np.array([[1.0, ts], [0.0, 1.0]])
    rng = np.random.default_rng(34)
    n = 400_000
    nx = rng.normal(0.0, NOISE["x"], n)
    eps = np.zeros((n, 2))
    for i in range(1, n):
        eps[i] = A @ eps[i - 1] - L * nx[i]
    row = default.rows[3]
    ratio = 0.00076 / 0.0013
    spl = np.hypot(NOISE["p_a"], ratio * NOISE["p_b"])
    c = eps[1000:] @ [row.k_x, row.k_v] + row.k_pl * rng.normal(0.0, spl, n - 1000)
    sig = command_noise(default, NOISE, ratio)[3]
    assert c.std() == pytest.approx(sig, rel=0.01)
    rho = command_noise_correlation(default, NOISE, ratio, 15)[3]
    emp = [np.mean(c[:-k] * c[k:]) / np.mean(c * c) for k in range(1, 16)]
    np.testing.assert_allclose(emp, rho, atol=0.02)
    # white noise without the observer: ρ = 0 and the band without a delay
    plain = dataclasses.replace(default, position_observer=None)
    assert not command_noise_correlation(plain, NOISE, ratio, 5).any()
    assert quiet_open_for(plain, NOISE, ratio) == 1


def test_quiet_open_for_is_the_first_lag_below_the_correlation(default):
    """n is the first lag whose median ρ over the hold rows is below QUIET_OPEN_CORRELATION
    (paper rig: 12 samples, 6 ms at 2 kHz; the observer's noise decorrelates over its
    time constant); a lower threshold gives a longer delay; a threshold outside (0, 1) is
    one line."""
    ratio = 0.00076 / 0.0013
    n = quiet_open_for(default, NOISE, ratio)
    assert default.dead_zone_inverse.quiet_open == n
    rho = np.median(command_noise_correlation(default, NOISE, ratio, n)[[3, 10, 17]], axis=0)
    assert rho[n - 1] < QUIET_OPEN_CORRELATION <= rho[n - 2]
    assert 5 <= n <= 20
    assert quiet_open_for(default, NOISE, ratio, correlation=0.05) > n
    with pytest.raises(ControlError, match=r"correlation 1.5 must be between 0 and 1"):
        quiet_open_for(default, NOISE, ratio, correlation=1.5)


def test_quiet_open_round_trips_and_packs(default, tmp_path):
    """Written as a plain number of samples and read back; packed at X_DZQO; a file without it
    reads 0 (the band of the earlier law); a fraction or a negative value is one line."""
    dz = default.dead_zone_inverse
    p = tmp_path / "c.toml"
    save_controller(default, p)
    text = p.read_text()
    assert f"quiet_open = {dz.quiet_open:g}" in text
    back = load_controller(p)
    assert back.dead_zone_inverse.quiet_open == dz.quiet_open
    e0 = C.C_ROWS + C.ROW * len(default.rows)
    assert back.pack()[e0 + C.X_DZQO] == dz.quiet_open
    old = tmp_path / "old.toml"
    old.write_text("\n".join(ln for ln in text.splitlines() if "quiet_open" not in ln) + "\n")
    prev = load_controller(old)
    assert prev.dead_zone_inverse.quiet_open == 0.0 and prev.pack()[e0 + C.X_DZQO] == 0.0
    with pytest.raises(ControlError, match=r"quiet_open = 2.5 samples must be a whole number"):
        dataclasses.replace(dz, quiet_open=2.5)
    with pytest.raises(ControlError, match=r"quiet_open = -1 samples must be >= 0"):
        dataclasses.replace(dz, quiet_open=-1.0)


def test_the_delay_keeps_the_worst_noise_seeds_hold_within_the_issue(paper, default):
    """Paper rig, full model, 20 µm / 0.1 bar, one sample of delay, hold over the last 0.2 s of
    0.9 s after the 50 → 150 mm trapezoid (benchmarks/independent_plant.py's task). Noise seeds
    6, 17 and 19 held 0.032 / 0.046 / 0.034 mm with the law before (the band opening on single
    noisy samples, tens of sign changes/s); with the delay measured 0.008 / 0.019 / 0.023 mm
    and 0 sign changes/s (85 / 5 / 55 per s before). Bounds: the issue's 0.03 mm on each (room
    for the tolerance-level spread of the compiled kernels, which moves a seed's hold by up to
    ~0.003 mm) and 20 sign changes/s (|u| > 1 % of the limit, as the benchmark counts them)."""
    for seed in (6, 17, 19):
        res = paper_trapezoid(
            paper, default, sensor_noise=NOISE, seed=seed, rtol=1e-6, fs=1.0 / default.sample_time
        )
        hold = float(np.ptp(res["x"][res.t >= 0.7 - 1e-12]))
        assert hold <= 30e-6, (seed, hold)
        u = res.control["u"][res.control["t"] >= 0.7 - 1e-12]
        flips = np.count_nonzero(np.diff(np.sign(u[np.abs(u) > 0.01])))
        assert flips / 0.2 <= 20.0, (seed, flips)
