"""The LU and the solves of W = I − hγJ on its leading block (``_rosenbrock._n_solve``).

The full and chamber models' trailing states P_S (without the pump model) and P_acc (without
an accumulator) are constant; their rows and columns of J vanish, so the kernel factorises
and solves only the leading block. Checked here against a dense solve of the whole W, for
the three machine variants the block size depends on.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numba import njit

import hydropwa as hp
from hydropwa.models import as_model
from hydropwa.params import Accumulator
from hydropwa.simulation import _kernel as K
from hydropwa.simulation._kcommon import FULL  # a global: a literal kind in compiled code
from hydropwa.simulation._rosenbrock import (
    _factor,
    _lu,
    _lu_block,
    _n_solve,
    _solve,
    _solve_block,
)

_PAPER = hp.get_preset("paper")
#: machine variant -> (parameters, states left to the LU)
_VARIANTS = {
    "plain": (_PAPER, 6),
    "pump": (_PAPER.replace(**{"supply.model": "pump"}), 7),
    "accumulator": (_PAPER.replace(accumulator=Accumulator(gas_volume=0.5e-3)), 8),
}


@pytest.mark.parametrize("variant", list(_VARIANTS))
def test_block_size_follows_the_inert_states(variant):
    params, n_lu = _VARIANTS[variant]
    p = as_model("full", params).pack(command_amplitude=0.4)
    assert _n_solve(K.FULL, p) == n_lu
    assert _n_solve(K.REDUCED, p) == 3  # the load-pressure models have no inert state


@settings(max_examples=30, deadline=None)
@given(
    variant=st.sampled_from(list(_VARIANTS)),
    seed=st.integers(0, 2**32 - 1),
    log_hg=st.floats(-9.0, -2.0),
)
def test_block_solve_equals_the_dense_solve(variant, seed, log_hg):
    """x from the kernel's LU of the leading block equals numpy's solve of the whole W.

    J is random with the inert rows and columns zero (as the right-hand side makes them) and
    the spool's rows zero outside the spool's columns (the servo valve's law; see
    :func:`test_the_spool_rows_of_the_jacobian_are_closed`), scaled like the model's (pressure
    rows ~1e9, others ~1e3); the stage vector b is zero on the inert states (their rates are
    0). Relative 1e-9 of |x|: LU with partial pivoting on these well-conditioned W
    (hγ|J| ≲ 1e3) against LAPACK's.
    """
    params, n_lu = _VARIANTS[variant]
    p = as_model("full", params).pack(command_amplitude=0.4)
    rng = np.random.default_rng(seed)
    n = 8
    J = rng.standard_normal((n, n)) * np.array([1e3, 1e3, 1e9, 1e9, 1e3, 1e3, 1e9, 1e9])[:, None]
    J[n_lu:, :] = 0.0
    J[:, n_lu:] = 0.0
    J[:2, 2:] = 0.0
    b = rng.standard_normal(n) * 1e2
    b[n_lu:] = 0.0
    hg = 10.0**log_hg
    W = np.empty((n, n))
    piv = np.empty(n, dtype=np.int64)
    B = b.reshape(1, n).copy()
    _factor_and_solve_full(J, W, piv, hg, p, B, n_lu)
    x = np.linalg.solve(np.eye(n) - hg * J, b)
    np.testing.assert_allclose(B[0], x, rtol=1e-9, atol=1e-9 * np.max(np.abs(x)))
    assert np.all(B[0, n_lu:] == 0.0)  # the inert states' stage values stay exactly 0


@njit(cache=False)
def _factor_and_solve_full(J, W, piv, hg, p, B, n_lu):
    """The step loop's factorisation and solve for the full model (its kind a literal, as in
    every entry point: the kind's block structure is chosen while typing)."""
    _factor(FULL, J, W, piv, hg, p)
    _solve_block(FULL, W, piv, B, 0, n_lu)


@njit(cache=False)
def _factor_and_solve_runtime(W, piv, B, n):
    _lu(W, piv, n)  # the dense LU, the block size as a runtime value
    _solve(W, piv, B, 0, n)


@njit(cache=False)
def _factor_and_solve_block(W, piv, B, n):
    _lu_block(FULL, W, piv, n)  # the full model's path: the 2 + 4 block LU at size 6
    _solve_block(FULL, W, piv, B, 0, n)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), log_hg=st.floats(-9.0, -2.0))
def test_the_full_models_block_lu_equals_the_dense_lu(seed, log_hg):
    """The full model's 6×6 path (``_lu_block`` → ``_lu_full``, ``_solve_block`` → ``_solve_full``
    from its registry row's ``lu_blocks`` = (2, 6):
    the spool block and the chambers–piston block factorised apart) solves W x = b as the
    dense LU with pivoting over all six rows does, for W with the model's structure (the
    spool's rows of J zero outside the spool's columns). Within 1e-9 of |x|: the two orders
    of elimination round differently, amplified by W's condition number (up to ~1e7 at
    hγ = 1e-2 with these J)."""
    rng = np.random.default_rng(seed)
    n = 8
    J = rng.standard_normal((n, n)) * np.array([1e3, 1e3, 1e9, 1e9, 1e3, 1e3, 0, 0])[:, None]
    J[:2, 2:] = 0.0
    J[:, 6:] = 0.0
    W = np.eye(n) - 10.0**log_hg * J
    b = rng.standard_normal((1, n)) * 1e2
    b[0, 6:] = 0.0
    x = []
    for solve in (_factor_and_solve_runtime, _factor_and_solve_block):
        w, piv, B = W.copy(), np.zeros(n, dtype=np.int64), b.copy()
        solve(w, piv, B, 6)
        x.append(B[0])
    np.testing.assert_allclose(x[1], x[0], rtol=0, atol=1e-9 * np.max(np.abs(x[0])))


@settings(max_examples=25, deadline=None)
@given(
    nu=st.floats(-1.0, 1.0),
    dnu=st.floats(-50.0, 50.0),
    pa=st.floats(1e5, 2e7),
    pb=st.floats(1e5, 2e7),
    x=st.floats(-0.01, 0.21),
    v=st.floats(-1.0, 1.0),
    u=st.floats(-1.0, 1.0),
)
def test_the_spool_rows_of_the_jacobian_are_closed(nu, dnu, pa, pb, x, v, u):
    """The block LU's premise: the spool's rows of the full model's exact Jacobian are zero
    outside the spool's columns (the servo valve (3) sees ν, ν̇ and u only), and so are the
    forward differences of ``rhs_full`` there (exactly: those rates do not change)."""
    from hydropwa.simulation._rhs_full import jac_full, rhs_full

    p = as_model("full", _PAPER).pack(command_amplitude=0.4)
    y = np.array([nu, dnu, pa, pb, x, v, 100e5, 0.0])
    J = np.empty((8, 8))
    assert jac_full(y, u, 100e5, 0.0, p, J)
    assert np.all(J[:2, 2:] == 0.0) and J[0, 1] == 1.0 and J[1, 0] < 0.0
    f0, f1 = np.empty(8), np.empty(8)
    rhs_full(y, u, 100e5, 0.0, p, f0)
    for j in range(2, 6):
        yj = y.copy()
        yj[j] += 1e-3 * max(abs(y[j]), 1.0)
        rhs_full(yj, u, 100e5, 0.0, p, f1)
        assert np.array_equal(f1[:2], f0[:2]), j
