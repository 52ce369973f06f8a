"""The on-target continuity fit from running sums (issue 53, point 4) against NumPy.

``gram_add`` / ``solve5`` / ``continuity_result`` of ``monitor/_residuals.py`` (what the C
runs) against an independent two-pass weighted least squares written here with
``numpy.linalg.lstsq`` over the stacked rows, on random well-posed blocks.
"""

from __future__ import annotations

import numpy as np
import pytest

from hydropwa.monitor import _residuals as R


def test_solve5_is_numpys_solve_on_random_systems():
    """Gaussian elimination with partial pivoting against numpy.linalg.solve: 200 random 5 × 5
    systems (condition ≤ 1e6, rows permuted so that pivoting matters), 1e-9 relative to the
    solution's largest entry (cond · eps ≈ 2e-10 in the worst case)."""
    rng = np.random.default_rng(53)
    for _ in range(200):
        u, _s, vt = np.linalg.svd(rng.normal(size=(5, 5)))
        a = u @ np.diag(np.logspace(0, -rng.uniform(0, 6), 5)) @ vt
        a = a[rng.permutation(5)]
        b = rng.normal(size=5)
        w = np.zeros(R.N_W)
        w[:30] = np.column_stack([a, b]).ravel()
        R.solve5(w)
        want = np.linalg.solve(a, b)
        assert np.max(np.abs(w[30:35] - want)) <= 1e-9 * np.max(np.abs(want))


def _wls_numpy(blocks, scale):
    """Two-pass weighted least squares over stacked rows (each block by its residual RMS)."""
    weights = [1.0, 1.0]
    for _ in range(3):
        a = np.vstack([blk[0] * scale / w for blk, w in zip(blocks, weights, strict=True)])
        y = np.concatenate([blk[1] / w for blk, w in zip(blocks, weights, strict=True)])
        theta = np.linalg.lstsq(a, y, rcond=None)[0] * scale
        weights = [float(np.sqrt(np.mean((blk[1] - blk[0] @ theta) ** 2))) for blk in blocks]
    return theta


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_continuity_result_is_the_weighted_least_squares_of_its_rows(seed):
    """Random rows of the two chambers' continuity blocks (columns of the monitor's magnitudes,
    unequal noise per block) summed by gram_add and solved by continuity_result: E, C_L, C_eA,
    C_eB equal the stacked-row lstsq within 1e-8 relative (the normal equations square the
    scaled columns' condition, here ≤ 1e3: 1e-10 expected); a value beyond a threshold alarms."""
    rng = np.random.default_rng(seed)
    n = 400
    scale = R.CONTINUITY_SCALE
    truth = np.array([1.0 / 1.2e9, 3e-13, 1e-13, 2e-13, 0.004])
    cols = rng.normal(size=(2, n, 5)) * np.array([1e3, 5e6, 5e6, 5e6, 1e-4])
    cols[0, :, 3] = 0.0  # block A has no C_eB column, block B no C_eA column
    cols[1, :, 2] = 0.0
    noise = (2e-7, 6e-7)
    blocks = [(cols[i], cols[i] @ truth + rng.normal(0.0, noise[i], n)) for i in range(2)]
    P = np.zeros(R.N_P)
    P[R.MP_CS : R.MP_CS + 5] = scale
    P[[R.MP_E_LO, R.MP_CL_LO, R.MP_CEA_LO, R.MP_CEB_LO]] = -np.inf
    P[[R.MP_E_HI, R.MP_CL_HI, R.MP_CEA_HI, R.MP_CEB_HI]] = np.inf
    P[R.MP_CL_HI] = 1e-13  # C_L is 3e-13: an alarm
    S = np.zeros(R.N_S)
    S[R.MS_N] = n
    for k in range(n):
        for o, (a, y) in zip((R.MS_CA, R.MS_CB), blocks, strict=True):
            R.gram_add(S, o, *(a[k] * scale), y[k])
    out = R.continuity_result(S, P, np.zeros(R.N_W))
    want = _wls_numpy(blocks, scale)
    got = np.array([1.0 / out[0], out[1], out[2], out[3]])
    np.testing.assert_allclose(got, want[:4], rtol=1e-8)
    assert out[4:] == (0.0, 1.0, 0.0, 0.0)
    few = np.zeros(R.N_S)
    few[R.MS_N] = 3
    assert all(np.isnan(v) for v in R.continuity_result(few, P, np.zeros(R.N_W))[:4])
