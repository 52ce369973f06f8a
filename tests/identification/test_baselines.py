"""Linear baselines (ARX, DMDc): recovery of known systems, simulation from u alone, pykoop agreement."""

from __future__ import annotations

import numpy as np
import pytest

from hydropwa import ParameterError
from hydropwa.identification import fit_arx, fit_dmdc, select_arx


def _arx_truth(n=3000, seed=1):
    """y_k = 1.5 y_{k-1} − 0.7 y_{k-2} + 0.4 u_{k-2} + 0.1 u_{k-3} + 0.05, from a random input."""
    u = np.random.default_rng(seed).standard_normal(n)
    y = np.zeros(n)
    for k in range(3, n):
        y[k] = 1.5 * y[k - 1] - 0.7 * y[k - 2] + 0.4 * u[k - 2] + 0.1 * u[k - 3] + 0.05
    return u, y


def test_arx_recovers_a_known_process_and_simulates_it_exactly():
    u, y = _arx_truth()
    model = fit_arx(u, y, na=2, nb=2, delay=2)
    np.testing.assert_allclose(model.a[0], [1.5, -0.7], atol=1e-10)
    np.testing.assert_allclose(model.b[0], [0.4, 0.1], atol=1e-10)
    assert model.c[0] == pytest.approx(0.05, abs=1e-10)
    # driven by u alone from rest at y[1000] it forgets that start (poles of modulus 0.84:
    # 0.84^200 ≈ 1e-15) and then is the process
    sim = model.simulate(u[1000:], np.array([y[1000]]))
    assert np.max(np.abs(sim[200:, 0] - y[1200:])) < 1e-9 * np.std(y)


def test_select_arx_finds_the_order_and_delay_of_a_noise_free_process():
    u, y = _arx_truth()
    model = select_arx(u, y, orders=range(1, 4), delays=range(0, 4))
    assert (model.a.shape[1], model.delay) in {(2, 2), (3, 2), (3, 1), (2, 1)}
    sim = model.simulate(u[2000:], np.array([y[2000]]))
    assert np.max(np.abs(sim[200:, 0] - y[2200:])) < 1e-6 * np.std(y)


def test_dmdc_recovers_a_known_two_output_system():
    rng = np.random.default_rng(2)
    A = np.array([[0.95, 0.1], [-0.05, 0.9]])
    B, c = np.array([0.2, -0.1]), np.array([0.01, 0.0])
    u = rng.standard_normal(2000)
    y = np.zeros((2000, 2))
    for k in range(1999):
        y[k + 1] = A @ y[k] + B * u[k] + c
    model = fit_dmdc(u, y)
    np.testing.assert_allclose(model.A, A, atol=1e-10)
    np.testing.assert_allclose(model.B, B, atol=1e-10)
    np.testing.assert_allclose(model.c, c, atol=1e-10)
    np.testing.assert_allclose(model.simulate(u[:500], y[0]), y[:500], atol=1e-9)


def test_bad_orders_are_refused_in_one_line():
    with pytest.raises(ParameterError, match="ARX orders"):
        fit_arx(np.zeros(10), np.zeros(10), na=0, nb=1)
    with pytest.raises(ParameterError, match="one length"):
        fit_dmdc(np.zeros(10), np.zeros(9))


def test_dmdc_agrees_with_pykoop_where_installed():
    """pykoop's EDMDc without lifting, a constant as a second input, is the same regression."""
    pykoop = pytest.importorskip("pykoop")  # optional: not a dependency (it pulls GPL-3 picos)
    rng = np.random.default_rng(3)
    u = rng.standard_normal(800)
    y = np.cumsum(rng.standard_normal((800, 2)) * 0.01, axis=0) + np.outer(np.sin(u), [1, 0.5])
    ours = fit_dmdc(u[:600], y[:600]).simulate(u[600:], y[600])
    x = np.column_stack([np.zeros(800), y, u, np.ones(800)])
    pipe = pykoop.KoopmanPipeline(regressor=pykoop.Edmd()).fit(
        x[:600], n_inputs=2, episode_feature=True
    )
    x_test = x[600:].copy()
    x_test[:, 1:3] = y[600]
    theirs = np.asarray(pipe.predict_trajectory(x_test))[:, 1:3]
    np.testing.assert_allclose(ours, theirs, rtol=1e-6, atol=1e-9 * np.abs(ours).max())
