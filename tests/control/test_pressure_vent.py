"""The pressure vent at rest (schema 2, ``DeadZoneInverse.pressure_vent``): inside the quiet band
the low-passed load-pressure share of the command still vents the pressure a stop leaves in the
closed chambers (issue 34, the paper rig's hold within 0.03 mm)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from paper_cases import paper_trapezoid

from hydropwa.control import (
    PRESSURE_VENT_SAMPLES,
    load_controller,
    save_controller,
)
from hydropwa.simulation import _controller as C


@settings(max_examples=300, deadline=None)
@given(
    c=st.floats(-0.1, 0.1),
    d=st.floats(-0.01, 0.01),
    q=st.floats(1e-4, 0.05),
    share=st.floats(-0.1, 0.1),
    ex=st.floats(-0.5, 0.5),
)
def test_pressure_vent_is_the_stated_continuous_odd_map(c, d, q, share, ex):
    """Inside ±q the opening is the vent v = sign(w)·min(|w| − 0.8q, q) beyond 0.8q (else 0) of
    the low-passed share w; between q and 2q the band's ramp plus (2 − |c|/q)·v; c from 2q on.
    Where the vent is 0 it is the quiet band exactly; odd in (c, w); Lipschitz 3 in c (the ramp's
    2 plus |v|/q ≤ 1: no jump of the flow at either edge); the integral leaks wherever |c| < 2q
    and holds as in the band."""
    o, held, leak = C.pressure_vent(c, q, share, ex)
    w = C.QUIET_VENT * q
    v = math.copysign(min(abs(share) - w, q), share) if abs(share) > w else 0.0
    assert C.quiet_vent(share, q) == pytest.approx(v, rel=1e-12, abs=1e-18)
    qb, qheld = C.quiet_band(c, q, ex)
    assert held == qheld and leak == (abs(c) < 2.0 * q)
    if abs(c) >= 2.0 * q:
        assert o == c
    elif abs(c) <= q:
        assert o == pytest.approx(v, rel=1e-12, abs=1e-18)
    else:
        assert o == pytest.approx(qb + (2.0 - abs(c) / q) * v, rel=1e-12, abs=1e-15)
    if v == 0.0:
        assert o == qb
    assert C.pressure_vent(-c, q, -share, ex)[0] == pytest.approx(-o, rel=1e-12, abs=1e-18)
    assert abs(C.pressure_vent(c + d, q, share, ex)[0] - o) <= 3.0 * abs(d) + 1e-12


def test_pressure_vent_round_trips_and_packs(default, tmp_path):
    """``control design``'s default is T_p = 40 T_s (20 ms at 2 kHz), written in ms and read back;
    it packs a_p = exp(−T_s/T_p) at X_DZPV; a file without it reads 0 (the band of the earlier
    law, a_p = 0); a negative value is one line."""
    dz = default.dead_zone_inverse
    assert dz.pressure_vent == pytest.approx(PRESSURE_VENT_SAMPLES * default.sample_time)
    assert dz.pressure_vent == pytest.approx(0.02)
    p = tmp_path / "c.toml"
    save_controller(default, p)
    text = p.read_text()
    assert 'pressure_vent = "20 ms"' in text
    back = load_controller(p)
    assert back.dead_zone_inverse.pressure_vent == pytest.approx(dz.pressure_vent, rel=1e-9)
    e0 = C.C_ROWS + C.ROW * len(default.rows)
    a_p = math.exp(-default.sample_time / dz.pressure_vent)
    assert back.pack()[e0 + C.X_DZPV] == pytest.approx(a_p, rel=1e-9)
    old = tmp_path / "old.toml"
    old.write_text("\n".join(ln for ln in text.splitlines() if "pressure_vent" not in ln) + "\n")
    prev = load_controller(old)
    assert prev.dead_zone_inverse.pressure_vent == 0.0 and prev.pack()[e0 + C.X_DZPV] == 0.0
    with pytest.raises(Exception, match=r"pressure_vent = -0.001 s must be >= 0"):
        dataclasses.replace(dz, pressure_vent=-1e-3)


def test_the_vent_keeps_the_paper_rigs_hold_after_the_trapezoid(paper, default):
    """Paper rig, full model, exact sensors, one sample of delay, hold over the last 0.2 s of
    0.9 s after the 50 → 150 mm trapezoid (benchmarks/control.py's case). Without the vent the
    rod parks ~20 µm past the target with the friction force stored in the closed chambers
    (P_L ≈ 0.3 bar), creeps out of the band and is pulled back across it: measured 0.034 mm.
    With it (the default) measured 0.003 mm (seeds 1-10: 0.009-0.032 mm, docs/control.md).
    Bounds: the issue's 0.03 mm with room for the tolerance-level spread of the compiled
    kernels, 0.012 mm, and at least 0.015 mm better than without (the measured gap is 0.031)."""
    pp = {}
    for name, vent in (("without", 0.0), ("with", default.dead_zone_inverse.pressure_vent)):
        ctrl = dataclasses.replace(
            default,
            dead_zone_inverse=dataclasses.replace(default.dead_zone_inverse, pressure_vent=vent),
        )
        res = paper_trapezoid(paper, ctrl)
        pp[name] = float(np.ptp(res["x"][res.t >= 0.7]))
    assert pp["with"] <= 12e-6, pp
    assert pp["without"] - pp["with"] >= 15e-6, pp
