"""Synthetic measurements with known parameters for the identification tests.

Everything here is generated from closed forms (second-order response, hinge
velocity, Eq. (11) friction) plus seeded noise, so each test knows the truth.
"""

from __future__ import annotations

import numpy as np
import pytest

from hydropwa.components import stribeck_friction
from hydropwa.data import Run
from hydropwa.params import get_preset
from hydropwa.simulation import simulate

FS = 2000.0  # Hz, the paper's sampling rate


def second_order_sine(t, amp, f, omega0, zeta):
    """Exact response of Eq. (1) (ζ < 1) to u = amp·sin(2πft) from rest: steady state + transient."""
    w = 2 * np.pi * f
    g = omega0**2 / ((1j * w) ** 2 + 2 * zeta * omega0 * 1j * w + omega0**2)
    y_ss = amp * np.abs(g) * np.sin(w * t + np.angle(g))
    y0 = amp * np.abs(g) * np.sin(np.angle(g))
    dy0 = amp * np.abs(g) * w * np.cos(np.angle(g))
    wd = omega0 * np.sqrt(1 - zeta**2)
    c1 = -y0
    c2 = (-dy0 + zeta * omega0 * c1) / wd
    return y_ss + np.exp(-zeta * omega0 * t) * (c1 * np.cos(wd * t) + c2 * np.sin(wd * t))


def stepped_sine_runs(
    omega0_by_amp,
    zeta=0.7,
    noise=0.01,
    seed=0,
    step=2.0,
    f_max_by_amp=None,
    periods=7,
    meta_frequency=True,
):
    """One run per (amplitude, frequency), 2 Hz steps, noise as a fraction of the amplitude."""
    rng = np.random.default_rng(seed)
    runs = []
    for amp, w0 in omega0_by_amp.items():
        fmax = (f_max_by_amp or {}).get(amp, 100.0)
        for f in np.arange(step, fmax + 1e-9, step):
            t = np.arange(0.0, max(periods / f, 0.1), 1.0 / FS)
            u = amp * np.sin(2 * np.pi * f * t)
            y = second_order_sine(t, amp, f, w0, zeta) + noise * amp * rng.standard_normal(t.size)
            meta = {"experiment": "frf", "signal": {"type": "sine", "amplitude": amp}}
            if meta_frequency:
                meta["signal"]["frequency"] = float(f)
            runs.append(
                Run(
                    f"frf_{int(amp * 100):02d}_{f:05.1f}Hz",
                    {"t": t, "u": u, "spool": y},
                    fs=FS,
                    meta=meta,
                )
            )
    return runs


def hinge_velocity(u, beta, gain, creep):
    """Velocity [m/s] against command with a dead band (discontinuous, Table IV as printed)."""
    u = np.asarray(u, dtype=float)
    return np.where(np.abs(u) > beta, gain * (u - beta * np.sign(u)), creep * u)


def constant_input_runs(
    levels,
    velocity_of,
    stroke=0.2,
    duration=2.0,
    noise=2e-5,
    seed=0,
    experiment="deadzone",
    extra=None,
):
    """Constant-command runs: position ramps from the start stop, clipped at the far stop."""
    rng = np.random.default_rng(seed)
    runs = []
    for k, lv in enumerate(levels):
        t = np.arange(0.0, duration, 1.0 / FS)
        v = float(velocity_of(lv))
        x0 = 0.0 if lv > 0 else stroke
        x = np.clip(x0 + v * t, 0.0, stroke) + noise * rng.standard_normal(t.size)
        ch = {"t": t, "x": x, "u": np.full(t.size, lv)}
        if extra is not None:
            ch.update(extra(lv, t, v, rng))
        runs.append(
            Run(
                f"{experiment}_{k:03d}",
                ch,
                fs=FS,
                meta={"experiment": experiment, "signal": {"type": "constant", "level": float(lv)}},
            )
        )
    return runs


@pytest.fixture
def table_ii():
    """Table II of the paper: amplitude [1] → ω0 [rad/s] (ζ = 0.7)."""
    return {0.10: 816.8, 0.25: 628.3, 0.90: 220.0}


def stribeck_points(fr, v, noise, seed):
    rng = np.random.default_rng(seed)
    f = stribeck_friction(
        v,
        fr["coulomb"],
        fr["static"],
        fr["viscous"],
        fr["stribeck_velocity"],
        fr["shape"],
        fr["smoothness"],
    )
    return f + noise * rng.standard_normal(v.size)


#: white sensor noise of the rig's channels [SI], as in rig/_sensors.py
NOISE = {"x": 5e-6, "p_a": 0.05e5, "p_b": 0.05e5, "p_s": 0.05e5, "f_l": 5.0, "spool": 1e-3}


def noisy_run(model, u, duration, seed, x0=0.05, load=0.0, ps=100e5, name="run"):
    """A run of ``model`` (simulated at rtol 1e-7) with white sensor noise at the rig's
    levels (``NOISE``), as the grey-box tests measure it."""
    res = simulate(
        model,
        u,
        duration=duration,
        initial_position=x0,
        load_force=load,
        supply_pressure=ps,
        rtol=1e-7,
    )
    rng = np.random.default_rng(seed)
    ch = {"t": res.t, "u": res["u"]}
    for c, s in NOISE.items():
        ch[c] = res[c] + rng.normal(0.0, s, res.t.size)
    return Run(
        name=name,
        channels=ch,
        units={
            "t": "s",
            "u": "1",
            "x": "m",
            "p_a": "Pa",
            "p_b": "Pa",
            "p_s": "Pa",
            "f_l": "N",
            "spool": "1",
        },
        fs=2000.0,
        meta={"experiment": "sine"},
    )


@pytest.fixture(scope="module")
def truth():
    """The paper rig with a piston leakage of 2e-12 m³/(s·Pa): the grey-box tests' truth."""
    return get_preset("paper").replace(**{"cylinder.leakage": 2e-12})
