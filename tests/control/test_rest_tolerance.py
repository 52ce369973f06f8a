"""The law's "at rest" test has a tolerance (issue 49): a reference rate of 1e-9 m/s at rest holds
as quietly as an exact 0, in the package's loop and in the C (the lockstep of test_target_c
covers the C with the same tables; here its rest test is checked against the loop's)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from paper_cases import NOISE, TRAPEZOID

from hydropwa.control import MotionProfile, as_reference, tracking_metrics
from hydropwa.simulation import _controller as C
from hydropwa.simulation import simulate


@dataclasses.dataclass(frozen=True)
class _Creeping(MotionProfile):
    """The motion profile with ``offset`` [m/s] added to its rate where it is at rest: what a
    reference generator that rounds (or a decaying filter) reports instead of an exact 0."""

    offset: float = 0.0

    def rate(self, t):
        r = np.asarray(super().rate(t), dtype=float)
        return np.where(r == 0.0, self.offset, r)


def _creeping(offset: float) -> _Creeping:
    p = as_reference(TRAPEZOID)
    return _Creeping(**{f.name: getattr(p, f.name) for f in dataclasses.fields(p)}, offset=offset)


def test_rest_test_has_the_stated_tolerance():
    """|ṙ|, |ṙ_ff| ≤ REST_RATE and |r̈| ≤ REST_ACCELERATION count as rest; just above does not.
    The pre-opening reads the same test on ṙ(t_k) and ṙ(t_k + τ_o)."""
    assert C.REST_RATE == 1e-6 and C.REST_ACCELERATION == 1e-3
    ctl = np.zeros(C.N_EXT + 1)
    ctl[C.X_DZQR] = 1.0  # e0 = 0 here: the band only at rest
    rch = np.zeros((C.N_RCH, 1))
    for row, limit in ((C.RC_DR, 1e-6), (C.RC_DRFF, 1e-6), (C.RC_DDR, 1e-3)):
        for value, rest in ((1e-9, True), (-limit, True), (1.01 * limit, False)):
            rch[:] = 0.0
            rch[row, 0] = value
            assert bool(C.quiet_acts(ctl, 0, rch[:, 0])) is rest, (row, value)
    w = 0.004
    assert C.pre_open(0.0, w, 1e-9, 0.2) == w  # at rest now, moving ahead: pre-open
    assert C.pre_open(0.0, w, 0.0, -1e-9) == 0.0  # 1e-9 ahead is no move
    assert C.pre_open(0.0, w, 2e-6, 0.2) == 0.0  # moving now


def test_a_creeping_rest_rate_holds_as_quietly_as_zero(paper, default):
    """The default design on the full model, 20 µm / 0.1 bar noise, the paper trapezoid and its
    hold (0.5-0.9 s). With ṙ = 1e-9 m/s at rest the hold is the exact-zero hold: the same sign
    changes (±10/s: the command differs by the feed-forward of 1e-9 m/s, ~1e-9 of an opening,
    which can flip a sample that sits on a threshold) and hold error (±1 µm, 1/20 of the noise).
    With 2e-6 m/s (above the tolerance, what the exact test did for any non-zero rate) the band
    never acts at the hold: measured 500+ sign changes/s, so the test can fail."""
    out = {}
    for offset in (0.0, 1e-9, 2e-6):
        res = simulate(
            "full",
            params=paper,
            duration=0.9,
            controller=default,
            reference=_creeping(offset),
            initial_position=0.05,
            sensor_noise=NOISE,
            seed=1,
        )
        hold = tracking_metrics(res, t0=0.5).display()
        err = float(np.mean(np.abs(res["error"][res.t >= 0.5]))) * 1e3
        out[offset] = (hold["chattering"], err)
    assert out[0.0][0] <= 100.0, out
    assert out[1e-9][0] == pytest.approx(out[0.0][0], abs=10.0), out
    assert out[1e-9][1] == pytest.approx(out[0.0][1], abs=1e-3), out
    assert out[2e-6][0] > 3 * max(out[0.0][0], 50.0), out


def test_the_c_law_rests_with_the_same_tolerance_in_lockstep(paper, default, tmp_path):
    """The exported C steps the default controller over a noisy hold of the trapezoid with
    ṙ = 1e-9 m/s at rest and gives the package's commands (lockstep, as test_target_c); at the
    hold's samples both park the valve (u in the dead zone's middle, 0) as often as with an
    exact 0: the C's rest test is the loop's."""
    from c_support import compile_shared, package_load_pressure, replay_c, replay_package

    from hydropwa.control import export_c

    lib = compile_shared(export_c(default, tmp_path / "c"), tmp_path / "libctrl.so")
    ctl = default.pack()
    ts = default.sample_time
    tk = ts * np.arange(int(0.9 / ts) + 1)
    res = simulate(
        "full",
        timepts=tk,
        params=paper,
        controller=default,
        reference=_creeping(0.0),
        initial_position=0.05,
        sensor_noise=NOISE,
        seed=1,
        rtol=1e-6,
    )
    a_a, a_b = paper.cylinder.area_a, paper.cylinder.area_b
    x, v = np.asarray(res["x"]), np.asarray(res["v"])
    pl = package_load_pressure(ctl, np.asarray(res["p_a"]), np.asarray(res["p_b"]), a_a, a_b)
    rng = np.random.default_rng(49)
    x = x + rng.normal(0.0, NOISE["x"], x.size)
    hold = tk >= 0.5
    parked = {}
    for offset in (0.0, 1e-9):
        from c_support import reference_channels

        r, rch = reference_channels(default, _creeping(offset), tk)
        pkg = replay_package(ctl, x, v, pl, r, rch, a_a, a_b)
        c = replay_c(lib, x, v, pl, r, rch)
        np.testing.assert_allclose(c["u"], pkg["u"], rtol=1e-9, atol=1e-12)
        parked[offset] = int(np.count_nonzero(c["u"][hold] == 0.0))
    assert parked[0.0] > 0.5 * np.count_nonzero(hold), parked
    assert parked[1e-9] == pytest.approx(parked[0.0], rel=0.02), parked
