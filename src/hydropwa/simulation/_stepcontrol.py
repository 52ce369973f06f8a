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
def _error_norm(n, y, ynew, yerr, atol, rtol):
    """RMS over states of e_i / (atol_i + rtol·max(|y_i|, |y_new,i|)); and whether ynew is finite."""
    err = 0.0
    finite = True
    for i in range(n):
        sc = atol[i] + rtol * max(abs(y[i]), abs(ynew[i]))
        err += (yerr[i] / sc) ** 2
        if not math.isfinite(ynew[i]):
            finite = False
    return math.sqrt(err / n), finite


@njit(**INLINE_NRT_JIT)
def _err_root(err, fourth):
    """err^(1/3) (a cube root, cheaper than pow), or err^(1/4) (two square roots) if ``fourth``.

    The step factor's exponent is 1/(q + 1) for an error estimate of order q: 2 for ROS34PW2
    and ROS2(3), 3 for ROS4LS.
    """
    return math.sqrt(math.sqrt(err)) if fourth else np.cbrt(err)


@njit(**INLINE_NRT_JIT)
def _accepted_factor(err, h, h_acc, cb_acc, gustafsson, last_rejected, need_jac, fourth):
    """Next-step factor after an accepted step of error ``err`` (≤ 1); returns (factor, cb_acc).

    0.9·err^(−1/3) (:func:`_err_root`; err^(−1/4) if ``fourth``), with Gustafsson's predictive
    controller (1994) after an accepted step of size ``h_acc`` whose clipped error root was
    ``cb_acc``: fewer rejections in a row. Clipped to [0.2, 5], no growth right after a
    rejection, and 1 when the step would barely change (the factorisation is kept).
    """
    cb = _err_root(err, fourth) if err > 0.0 else 0.0
    fac = 0.9 / cb if err > 0.0 else 5.0
    if gustafsson and h_acc > 0.0 and err > 0.0:
        # (err_acc / err²)^(1/3) from the cube roots already taken (likewise fourth roots)
        fac = min(fac, 0.9 * (h / h_acc) * cb_acc / (cb * cb))
    floor = 0.1 if fourth else _CBRT_1E4  # the root of 1e-4
    cb_next = cb if err > 1e-4 else floor  # root of max(err, 1e-4)
    fac = min(5.0, max(0.2, fac))
    if last_rejected and fac > 1.0:
        fac = 1.0
    if not (need_jac or fac < 1.0 or fac > 1.2):
        fac = 1.0
    return fac, cb_next


@njit(**INLINE_NRT_JIT)
def _rejected_factor(err, fourth):
    """Step factor after a rejected step of error ``err`` (> 1): 0.9·err^(−1/3) (err^(−1/4) if
    ``fourth``), at least 0.2."""
    return max(0.2, 0.9 / _err_root(err, fourth))
