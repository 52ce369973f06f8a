"""Inverse dynamics (IDIM-LS): synthetic recovery and the EMPS benchmark (real data)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hydropwa.identification import EMPS_PUBLISHED, identify_emps, identify_inverse_dynamics

DATA = Path("/work/shared/data")
EMPS = DATA / "DATA_EMPS.mat"
PULSES = DATA / "DATA_EMPS_PULSES.mat"


def test_synthetic_axis_recovered():
    """A known axis driven by a smooth multisine: M, F_v, F_c, offset within 1 %."""
    fs = 1000.0
    t = np.arange(0.0, 20.0, 1 / fs)
    q = 0.05 * np.sin(2 * np.pi * 0.3 * t) + 0.02 * np.sin(2 * np.pi * 1.1 * t + 1.0)
    dq = np.gradient(q, 1 / fs)
    ddq = np.gradient(dq, 1 / fs)
    m, fv, fc, off = 80.0, 150.0, 25.0, -2.0
    f = (
        m * ddq
        + fv * dq
        + fc * np.sign(dq)
        + off
        + 0.5 * np.random.default_rng(0).standard_normal(t.size)
    )
    res = identify_inverse_dynamics(
        t, q + 1e-7 * np.random.default_rng(1).standard_normal(t.size), f
    )
    e = res.estimates
    assert e["mass"].value == pytest.approx(m, rel=0.01)
    assert e["viscous"].value == pytest.approx(fv, rel=0.01)
    assert e["coulomb"].value == pytest.approx(fc, rel=0.02)
    assert e["offset"].value == pytest.approx(off, abs=0.1)
    fr = res.friction()
    assert fr.coulomb == pytest.approx(fc, rel=0.02) and fr.viscous == pytest.approx(fv, rel=0.01)


@pytest.mark.skipif(not EMPS.is_file(), reason="EMPS benchmark data not available")
def test_emps_matches_the_published_idim_ls():
    """Measured: M −0.01 %, F_v −0.18 %, F_c +0.22 %, offset −0.47 %; errors 4.12 % / 6.00 %.

    The brief allows 5 %; we assert 1 % (2 % for the small offset), which is the
    measured deviation plus margin for scipy versions of ``decimate``/``filtfilt``.
    The remaining differences come from the decimation filter and edge handling,
    as the benchmark README says of its own Python re-computation.
    """
    res = identify_emps(EMPS, PULSES if PULSES.is_file() else None)
    dev = res.deviations()
    for k in ("mass", "viscous", "coulomb"):
        assert abs(dev[k]) < 0.01, (k, dev[k])
    assert abs(dev["offset"]) < 0.02
    assert res.fit.relative_error == pytest.approx(EMPS_PUBLISHED["relative_error"], abs=0.002)
    if res.cross_test_error is not None:
        assert res.cross_test_error == pytest.approx(EMPS_PUBLISHED["cross_test_error"], abs=0.002)
    assert "mass" in res.summary_markdown()
