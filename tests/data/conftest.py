"""Shared fixtures of the data-layer tests: a clean synthetic run and the EMPS files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hydropwa.data import Run

EMPS_DIR = Path("/work/shared/data")


def make_run(
    name: str = "step_01", n: int = 500, fs: float = 1000.0, seed: int = 0, kind: str = "step"
) -> Run:
    """A plausible run with every canonical channel, SI units, sensor noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    u = 0.5 * np.sin(2 * np.pi * 2.0 * t)
    x = 0.1 + 0.05 * np.sin(2 * np.pi * 1.0 * t) + 1e-5 * rng.normal(size=n)
    return Run(
        name=name,
        channels={
            "t": t,
            "u": u,
            "spool": u + 1e-3 * rng.normal(size=n),
            "z": u,
            "x": x,
            "v": np.gradient(x, t),
            "p_a": 60e5 + 2e5 * rng.normal(size=n),
            "p_b": 40e5 + 2e5 * rng.normal(size=n),
            "p_s": 140e5 + 1e5 * rng.normal(size=n),
            "p_l": 20e5 + 3e5 * rng.normal(size=n),
            "f_l": 1e3 * rng.normal(size=n),
            "temp_oil": 313.15 + 0.1 * rng.normal(size=n),
        },
        units={"temp_oil": "K"},
        fs=fs,
        meta={
            "kind": kind,
            "signal": {"type": "step", "amplitude": 0.5},
            "rig": "virtual",
            "true_params": {"A_a": 1.96e-3},
        },
    )


@pytest.fixture
def clean_run() -> Run:
    return make_run()


@pytest.fixture
def emps_dir() -> Path:
    if not (EMPS_DIR / "DATA_EMPS.mat").is_file():
        pytest.skip("EMPS benchmark files not available")
    return EMPS_DIR


@pytest.fixture(name="make_run")
def make_run_fixture():
    """The :func:`make_run` factory, for tests that build variants of the clean run."""
    return make_run
