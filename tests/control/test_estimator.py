"""The per-cell steady-state Kalman filter (issue 34): its gains and the compiled law's filter."""

from __future__ import annotations

import dataclasses
import warnings

import control
import numpy as np
import pytest
from paper_cases import NOISE

from hydropwa.control import (
    ControlError,
    design_cell_estimator,
    design_state_feedback,
)
from hydropwa.control._estimator import _EST_SCALE, N_EST, cell_estimator
from hydropwa.linearization import linearize
from hydropwa.simulation import _controller as C


@pytest.fixture(scope="module")
def designed(paper):
    pwa = linearize(paper)
    d = design_state_feedback(pwa, delay=True)
    return pwa, d, design_cell_estimator(pwa, d, NOISE)


def test_cell_gains_are_the_kalman_filter_of_python_control(paper):
    """L against ``control.dlqe`` on the same (scaled) model: python-control's predictor gain is
    Φ L (x̂_{k+1} = Φ x̂_k + Γ u + Φ L (y − H x̂_k)), from the same Riccati solution (1e-7)."""
    pwa = linearize(paper)
    dyn = pwa.state_space(cells=(3, 1, 0, 6))
    A, B, f = dyn.A.copy(), dyn.B.copy(), dyn.f.copy()
    proc = {"acceleration": 0.3, "force_drift": 0.05, "pressure_drift": 2e3, "pressure": 1e5}
    ts, spl, sx = 5e-4, 1.2e4, 20e-6
    phi, gam, aff, L, init = cell_estimator(
        A, B, f, sample_time=ts, omega0=paper.valve.omega0, zeta=paper.valve.zeta,
        sigma_pl=spl, sigma_x=sx, process=proc,
    )  # fmt: skip
    T, Ti = np.diag(_EST_SCALE), np.diag(1.0 / _EST_SCALE)
    H = np.zeros((2, N_EST))
    H[0, 0], H[1, 2] = 1.0, 1.0
    W = np.zeros((N_EST, 4))
    W[1, 0], W[5, 1], W[6, 2], W[0, 3] = ts * 0.3, 0.05, 2e3, 1e5
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        Lp, _P, _E = control.dlqe(Ti @ phi @ T, Ti @ W, H @ T, np.eye(4), np.diag([spl**2, sx**2]))
    np.testing.assert_allclose(T @ np.asarray(Lp), phi @ L, rtol=1e-7, atol=1e-12)
    # the model: ZOH of the cell with the valve in series, exact rest equilibrium at k = 0
    assert init == (A[1, 0], A[0, 0], f[1], f[0])
    np.testing.assert_allclose(phi[2, 2], 1.0)
    assert np.max(np.abs(np.linalg.eigvals((np.eye(N_EST) - L @ H) @ phi))) < 1.0


def test_compiled_law_runs_the_filter_of_the_row_it_used_last(designed):
    """The law's ẑ against the filter written out in NumPy, on a noisy move of the reduced model's
    measurements (prediction with the last sample's row and the command the valve received)."""
    pwa, d, est = designed
    ctrl = dataclasses.replace(d.controller, estimator=est)
    ctl = ctrl.pack()
    assert ctl[C.C_ROWS + C.ROW * len(ctrl.rows) + C.X_EST] == 1.0
    n, ts = 400, ctrl.sample_time
    rng = np.random.default_rng(3)
    t = np.arange(n) * ts
    x = 0.1 + 0.01 * np.sin(2 * np.pi * 2 * t) + rng.normal(0, 20e-6, n)
    pl = 2e5 * np.cos(2 * np.pi * 2 * t) + rng.normal(0, 1.2e4, n)
    r = np.full(n, 0.1)
    ch = np.zeros((C.N_RCH, n))
    cst, log, sg = np.zeros(C.N_CST), np.zeros((C.N_LOG, n)), np.zeros(32)
    y = np.zeros(3)
    P = est.packed_rows()
    z = None
    for k in range(n):
        cin, last = cst[C.S_CAPP], int(cst[C.S_ROW])
        y[:] = (pl[k], 0.0, x[k])  # LOAD_STATES order [p_l, v, x]
        C.controller_sample(1, k, k * ts, y, 1.0, 0.5, ctl, cst, r, ch, sg, log)
        if k == 0:
            b = P[int(log[C.L_ROW, 0])]
            z = np.array(
                [pl[0], 0.0, x[0], 0.0, 0.0, -b[77] * pl[0] - b[79], -b[78] * pl[0] - b[80]]
            )
        else:
            b = P[last]
            zp = b[:49].reshape(7, 7) @ z + b[49:56] * cin + b[56:63]
            z = zp + b[63:77].reshape(7, 2) @ np.array([pl[k] - zp[0], x[k] - zp[2]])
        np.testing.assert_allclose(cst[C.S_Z : C.S_Z + 7], z, rtol=1e-9, atol=1e-12)


def test_estimator_refuses_what_it_cannot_design(designed):
    pwa, d, est = designed
    with pytest.raises(ControlError, match="positive sensor noise"):
        design_cell_estimator(pwa, d, {"x": 0.0, "p_a": 1e4})
    with pytest.raises(ControlError, match="unknown process noise"):
        design_cell_estimator(pwa, d, NOISE, {"jerk": 1.0})
    with pytest.raises(ControlError, match="one filter per gain row"):
        dataclasses.replace(
            d.controller, estimator=dataclasses.replace(est, phi=est.phi[:1], gamma=est.gamma[:1],
                                                        affine=est.affine[:1], gain=est.gain[:1],
                                                        init=est.init[:1])
        )  # fmt: skip
    # schema 2 without the filter packs as before the filter existed (X_EST 0)
    ctl = d.controller.pack()
    assert ctl[C.C_ROWS + C.ROW * len(d.controller.rows) + C.X_EST] == 0.0
