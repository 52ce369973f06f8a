"""Forecast for issue 34: command noise at a hold, measured states against a per-cell Kalman filter.

Usage::

    python benchmarks/control_estimator.py

For the default design (``design_state_feedback(delay=True)``) of the paper rig and the heavy axis
(``tests/machines/industrial.toml``), per hold cell (s = +1, o = 0, friction cells 3, 4, 6) the
standard deviation of the command c that the sensor noise (20 µm on x, 0.1 bar on each chamber,
so σ(P_L) = 0.1 bar·√(1 + α²)) leaves at a hold:

* **now**: the law feeds back the measured P_L and x, σ_c = √((k_pl σ_PL)² + (k_x σ_x)²);
* **LQG**: a steady-state Kalman filter on the cell's plant states [P_L, ẋ, x, ν, ν̇] (the valve-aware
  design model of ``_valve_augment`` with the one-sample delay), measured [P_L, x], process noise a
  white force σ_F on the rod and a white flow σ_Q into the chambers per sample
  (``control.dlqe`` on the scaled model); σ_c = √(K P Kᵀ) with P the a-posteriori error
  covariance and K the row's gains on those states.

Linear, nominal-model numbers (no parameter error, no load mismatch, no quantization): what a
designed estimator could give at best. The sign-change goal needs σ_c well below the dead-zone
inverse's threshold: |u| > 1 % is |c| > 0.01·z_w/(z_w + β) = 0.0004 on the paper rig.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

_HERE = Path(__file__).resolve().parent
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != _HERE]

import numpy as np  # noqa: E402

from hydropwa.control import design_state_feedback  # noqa: E402
from hydropwa.control._design import _VALVE_SCALE, _valve_augment, cell_plant  # noqa: E402
from hydropwa.linearization import linearize  # noqa: E402
from hydropwa.params import get_preset, load_params  # noqa: E402

SX, SP = 20e-6, 0.1e5
PROCESS = ((100.0, 1e-6), (30.0, 3e-7), (10.0, 1e-7), (3.0, 3e-8))  # (σ_F [N], σ_Q [m³/s])


def forecast(name: str, prm) -> None:
    import control

    pwa = linearize(prm)
    ctrl = design_state_feedback(pwa, delay=True).controller
    ts, m = ctrl.sample_time, prm.load.mass
    alpha = prm.cylinder.area_b / prm.cylinder.area_a
    sp = SP * np.hypot(1.0, alpha)
    slopes = pwa.friction.pwa.slopes
    kw_max = max(slopes[0], slopes[-1], 0.0)
    g = int(pwa.dead_zone.cell(0.5))
    C = np.zeros((2, 5))
    C[0, 0], C[1, 2] = 1.0, 1.0
    R = np.diag([sp**2, SX**2])
    T, Ti = np.diag(_VALVE_SCALE[:5]), np.diag(1.0 / _VALVE_SCALE[:5])
    for row in ctrl.rows:
        w = int(row.label.split("w=")[1])
        if not row.label.startswith("s=+1 o=0") or w not in (3, 4, 6):
            continue
        A, B, _ = cell_plant(pwa, cells=(g, 1, 0, w), opening_input=True)
        A[1, 1] = -min(max(-A[1, 1] * m, 0.0), kw_max) / m  # the design's friction clipping
        Aa, _Ba = _valve_augment(A, B, ts, prm.valve.omega0, prm.valve.zeta, True)
        K = np.array([row.k_pl, row.k_v, row.k_x, row.k_nu, row.k_dnu])
        now = float(np.hypot(row.k_pl * sp, row.k_x * SX))
        out = []
        for s_f, s_q in PROCESS:
            G = np.zeros((5, 2))
            G[1, 0] = ts / m
            G[0, 1] = -ts * A[0, 1] / prm.cylinder.area_a  # dṖ_L/dQ = (dṖ_L/dẋ)/A_A
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                _L, P, _E = control.dlqe(
                    Ti @ Aa[:5, :5] @ T, Ti @ G, C @ T, np.diag([s_f**2, s_q**2]), R
                )
            P = T @ P @ T
            M = P - P @ C.T @ np.linalg.solve(C @ P @ C.T + R, C @ P)
            out.append(f"{float(np.sqrt(K @ M @ K)):.5f} ({np.sqrt(M[2, 2]) * 1e6:.1f} um)")
        print(f"{name:<11}{row.label:<17}{now:>9.5f}   " + "   ".join(out))


def main() -> None:
    head = "   ".join(f"F {f:g} N, Q {q:.0e}" for f, q in PROCESS)
    print(f"{'machine':<11}{'cell':<17}{'now':>9}   LQG sigma_c (sigma_x): {head}")
    forecast("paper rig", get_preset("paper"))
    path = _HERE.parent / "tests" / "machines" / "industrial.toml"
    forecast("heavy axis", load_params(path))


if __name__ == "__main__":
    main()
