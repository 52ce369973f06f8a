"""Step-size control of the integration loop: the error norm and the step factors.

Inlined into the step loop (:func:`~._march._march`), compiled with its flags.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .. import _jitcache  # noqa: F401  (one cache stamp for all compiled modules)
from ._kcommon import _CBRT_1E4, INLINE_NRT_JIT


@njit(**INLINE_NRT_JIT)
def _error_norm(n, n_used, y, ynew, yerr, atol, rtol):
    """RMS over the first ``n_used`` of the ``n`` states of e_i / (atol_i + rtol·max(|y_i|,
    |y_new,i|)); and whether ynew is finite (all ``n`` states).

    ``n`` is the kind's state count, a compile-time constant in the step loop, so the loop is
    unrolled; ``n_used`` (:func:`~._kcommon.n_norm`, known only at run time) only masks terms:
    looping to it instead cost the full model ~3 % of its time (4.83 → 4.67 ms in ``benchmarks/
    side_by_side.py``).
    """
    err = 0.0
    finite = True
    for i in range(n):
        if i < n_used:
            sc = atol[i] + rtol * max(abs(y[i]), abs(ynew[i]))
            err += (yerr[i] / sc) ** 2
        if not math.isfinite(ynew[i]):
            finite = False
    return math.sqrt(err / n_used), finite


@njit(**INLINE_NRT_JIT)
def _err_root(err, order):
    """err^(1/(q + 1)) for an error estimate of order q = ``order`` (a method's ``error_order``).

    A cube root for q = 2 (ROS34PW2, ROS2(3); cheaper than pow), two square roots for q = 3
    (ROS4LS), pow otherwise. ``order`` is a compile-time constant in the step loop.
    """
    if order == 2:
        return np.cbrt(err)
    if order == 3:
        return math.sqrt(math.sqrt(err))
    return err ** (1.0 / (order + 1))


@njit(**INLINE_NRT_JIT)
def _err_root_floor(order):
    """The :func:`_err_root` of 1e-4 (the smallest error the predictive controller remembers)."""
    if order == 2:
        return _CBRT_1E4
    if order == 3:
        return 0.1  # exactly 1e-4 ** 0.25
    return 1e-4 ** (1.0 / (order + 1))


@njit(**INLINE_NRT_JIT)
def _accepted_factor(err, h, h_acc, cb_acc, gustafsson, last_rejected, need_jac, order):
    """Next-step factor after an accepted step of error ``err`` (≤ 1); returns (factor, cb_acc).

    0.9·err^(−1/(q + 1)) for the error order q = ``order`` (:func:`_err_root`), with Gustafsson's predictive
    controller (1994) after an accepted step of size ``h_acc`` whose clipped error root was
    ``cb_acc``: fewer rejections in a row. Clipped to [0.2, 5], no growth right after a
    rejection, and 1 when the step would barely change (the factorisation is kept).
    """
    cb = _err_root(err, order) if err > 0.0 else 0.0
    fac = 0.9 / cb if err > 0.0 else 5.0
    if gustafsson and h_acc > 0.0 and err > 0.0:
        # (err_acc / err²)^(1/(q + 1)) from the roots already taken
        fac = min(fac, 0.9 * (h / h_acc) * cb_acc / (cb * cb))
    floor = _err_root_floor(order)
    cb_next = cb if err > 1e-4 else floor  # root of max(err, 1e-4)
    fac = min(5.0, max(0.2, fac))
    if last_rejected and fac > 1.0:
        fac = 1.0
    if not (need_jac or fac < 1.0 or fac > 1.2):
        fac = 1.0
    return fac, cb_next


@njit(**INLINE_NRT_JIT)
def _rejected_factor(err, order):
    """Step factor after a rejected step of error ``err`` (> 1): 0.9·err^(−1/(q + 1)) for the
    error order q = ``order``, at least 0.2."""
    return max(0.2, 0.9 / _err_root(err, order))
