"""Valve FRF (Sec. VI-A, Table II): sinusoid fits, H1 estimate, second-order model fit."""

from __future__ import annotations

import numpy as np
import pytest
from ident_support import FS, second_order_sine, stepped_sine_runs
from scipy import signal

from hydropwa.data import Run
from hydropwa.identification import (
    FrequencyResponse,
    ValveFrfIdentifier,
    estimate_frf_h1,
    fit_second_order,
    fit_sinusoid,
    second_order_response,
)


def test_fit_sinusoid_recovers_amplitude_phase_and_ignores_the_transient():
    t = np.arange(0.0, 1.0, 1 / FS)
    y = 0.3 * np.sin(2 * np.pi * 10 * t + 0.4) + 0.05 + 0.01 * t + 2.0 * np.exp(-t / 0.05)
    fit = fit_sinusoid(t, y, 10.0, n_periods=4)
    assert fit.amplitude == pytest.approx(0.3, rel=1e-3)
    assert fit.phase == pytest.approx(0.4, abs=1e-3)
    assert fit.window[0] == pytest.approx(1.0 - 0.4, abs=2 / FS)


def test_stepped_sine_recovers_table_ii_within_5_percent(table_ii):
    """Noisy (1 % of the amplitude) stepped-sine runs 2–100 Hz (2–50 Hz at 90 %), as in Sec. VI-A."""
    runs = stepped_sine_runs(table_ii, zeta=0.7, noise=0.01, seed=3, f_max_by_amp={0.90: 50.0})
    ident = ValveFrfIdentifier().fit(runs)
    assert ident is not None and ident.skipped_ == []
    assert sorted(ident.fits_) == [0.10, 0.25, 0.90]
    for amp, w0 in table_ii.items():
        fit = ident.fits_[amp]
        assert fit.omega0.value == pytest.approx(w0, rel=0.05)
        assert fit.zeta.value == pytest.approx(0.7, rel=0.05)
        # the interval is honest: it holds the truth (noise is white here)
        assert fit.omega0.ci[0] - 3 * fit.omega0.std <= w0 <= fit.omega0.ci[1] + 3 * fit.omega0.std
    assert ident.valve_.omega0_table == tuple(
        (a, ident.fits_[a].omega0.value) for a in (0.10, 0.25, 0.90)
    )
    assert ident.valve_.omega0_at(0.25) == pytest.approx(628.3, rel=0.05)


def test_frequency_estimated_from_the_command_when_metadata_lack_it():
    runs = stepped_sine_runs({0.25: 628.3}, noise=0.005, seed=1, step=10.0, meta_frequency=False)
    ident = ValveFrfIdentifier().fit(runs)
    assert ident.fits_[0.25].omega0.value == pytest.approx(628.3, rel=0.05)


def test_h1_on_a_chirp():
    """A linear chirp 1–150 Hz through Eq. (1): H1 matches G where coherence is high."""
    w0, zeta = 500.0, 0.6
    t = np.arange(0.0, 20.0, 1 / FS)
    u = 0.2 * signal.chirp(t, 1.0, t[-1], 150.0)
    sys = signal.lti([w0**2], [1, 2 * zeta * w0, w0**2])
    # simulate on a 10x finer grid so the linear interpolation of lsim costs nothing
    tf = np.arange(0.0, 20.0, 0.1 / FS)
    _, yf, _ = signal.lsim(sys, 0.2 * signal.chirp(tf, 1.0, t[-1], 150.0), tf)
    y = yf[::10] + 0.002 * np.random.default_rng(0).standard_normal(t.size)
    frf = estimate_frf_h1(t, u, y, nperseg=4096, f_max=150.0, amplitude=0.2)
    band = (frf.frequency > 5) & (frf.frequency < 140)
    assert np.median(frf.coherence[band]) > 0.95
    g = second_order_response(frf.omega[band], w0, zeta)
    assert np.median(np.abs(frf.response[band] / g - 1)) < 0.05
    fit = fit_second_order(
        FrequencyResponse(frf.frequency[band], frf.response[band], frf.coherence[band], 0.2)
    )
    assert fit.omega0.value == pytest.approx(w0, rel=0.05)
    assert fit.zeta.value == pytest.approx(zeta, rel=0.05)
    run = Run(
        "chirp",
        {"t": t, "u": u, "spool": y},
        fs=FS,
        meta={"experiment": "frf", "signal": {"type": "chirp", "amplitude": 0.2}},
    )
    ident = ValveFrfIdentifier(f_max=140.0, nperseg=4096).fit([run])
    assert ident.fits_[0.2].omega0.value == pytest.approx(w0, rel=0.05)


def test_second_order_fit_on_exact_points_is_exact():
    f = np.arange(2.0, 101.0, 2.0)
    h = second_order_response(2 * np.pi * f, 816.8, 0.7)
    fit = fit_second_order(FrequencyResponse(f, h, None, 0.1))
    assert fit.omega0.value == pytest.approx(816.8, rel=1e-6)
    assert fit.zeta.value == pytest.approx(0.7, rel=1e-6)


def test_exact_sine_response_helper_is_the_ode_solution():
    t = np.arange(0.0, 0.05, 1e-5)
    y = second_order_sine(t, 1.0, 20.0, 300.0, 0.5)
    sys = signal.lti([300.0**2], [1, 300.0, 300.0**2])
    _, y2, _ = signal.lsim(sys, np.sin(2 * np.pi * 20 * t), t)
    assert np.max(np.abs(y - y2)) < 1e-4
