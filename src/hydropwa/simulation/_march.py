"""The integration loop: work arrays, the step loop and its open/closed-loop drivers."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .. import _jitcache  # noqa: F401  (one cache stamp for all compiled modules)
from ._controller import N_CST, N_LOG
from ._dispatch import _rhs_for
from ._kcommon import (
    INLINE_JIT,
    MAX_STEPS,
    N_STATS,
    NON_FINITE,
    OK,
    SOLVER_JIT,
    ST_JAC,
    ST_REJECTED,
    ST_RHS,
    ST_STEPS,
    STEP_COLLAPSE,
    _inputs,
    jac_depends_on_u,
    n_norm,
    n_states,
)
from ._outputs import _dense_output
from ._rosenbrock import (
    ROS34PW2,
    _factor,
    _jacobian,
    _step_for,
    method_error_order,
    method_fsal,
    method_gamma,
    method_w,
)
from ._sampling import _closed, _n_samples, _sample, _sample_time
from ._signals import NO_REFCOUNT
from ._stepcontrol import _accepted_factor, _error_norm, _rejected_factor


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _work_arrays(n, n_out, y0):
    """The integrator's work arrays for n states and n_out output samples (y starts at y0)."""
    return (
        np.empty((n_out, n)),
        y0.copy(),
        np.empty(n),
        np.empty(n),
        np.empty(n),
        np.empty(n),
        np.empty(n),
        np.empty(n),
        np.empty(n),
        np.empty((4, n)),
        np.empty((n, n)),
        np.empty((n, n)),
        np.empty(n, dtype=np.int64),
        np.zeros(N_STATS, dtype=np.int64),
    )


@njit(**INLINE_JIT)
def _tolerances(run, jac_reuse, gustafsson, exact_jac):
    """The step loop's tolerance tuple (:func:`_march`) from a :class:`~._entries.SolverRun`."""
    rtol = run.rtol
    return (
        rtol,
        run.scale,
        rtol * run.scale,
        run.h0,
        run.hmax,
        run.max_steps,
        jac_reuse,
        gustafsson,
        exact_jac,
    )


@njit(**INLINE_JIT)
def _integrate(kind, run, method=ROS34PW2, jac_reuse=True, gustafsson=True, exact_jac=True):
    """Integrate model ``kind`` from t_out[0] with a Rosenbrock method, dense output at ``t_out``.

    Parameters
    ----------
    kind : int
        FULL, REDUCED, PWA or CHAMBER.
    run : SolverRun
        The problem and its tolerances: y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps
        (:class:`~._entries.SolverRun`).
    method : int
        ROS34PW2 (default), ROS4LS or ROS23.
    jac_reuse : bool
        ROS34PW2 only: keep the Jacobian of the last evaluation after an accepted
        step whose error was small (below 0.2 of the tolerance with exact Jacobians,
        0.5 with differences; the W-method keeps its order); recomputed after every
        rejection and at least every 8 steps.
    gustafsson : bool
        Use Gustafsson's predictive step-size controller after accepted steps.
    exact_jac : bool
        Exact ∂f/∂y and ∂f/∂t of every model (:func:`jac_full`, :func:`jac_reduced`,
        :func:`jac_pwa`, :func:`jac_chamber`) instead of finite differences; a model whose
        exact Jacobian declines (the full model with a gas accumulator) uses differences.

    Returns
    -------
    Y : ndarray, shape (len(t_out), n)
    n_done : int
        Number of output rows filled.
    status : int
        OK, MAX_STEPS, STEP_COLLAPSE or NON_FINITE.
    t_fail : float
    y_fail : ndarray
    stats : ndarray
        [accepted steps, rejected steps, rhs evaluations, Jacobian evaluations].

    Notes
    -----
    The error of a step is the RMS over states of e_i / (atol_i + rtol·max(|y_i|, |y_new,i|));
    the step factor is 0.9·err^(−1/3) (a cube root, cheaper than pow), clipped to [0.2, 5] (no growth right after a rejection).
    """
    work = _work_arrays(n_states(kind), run.t_out.shape[0], run.y0)
    tol = _tolerances(run, jac_reuse, gustafsson, exact_jac)
    loop = (None, None, None, None, None)
    k_out, status, t = _march(kind, method, run.t_out, run.p, run.sg, tol, work, loop)
    Y, y, stats = work[0], work[1], work[13]
    return Y, k_out, status, t, y, stats


@njit(**SOLVER_JIT, **NO_REFCOUNT)
def _march(kind, method, t_out, p, sg, tol, work, loop):  # noqa: C901 (compiled step loop)
    """The step loop of :func:`_integrate` on arrays it owns; returns (rows filled, status, t).

    Allocation-free and compiled without reference counting, so the calls of the
    stepper, the Jacobian and the dense output pass their many work arrays for free
    (in a reference-counted caller each array argument costs an incref/decref pair).
    ``y`` holds y0 on entry and the last accepted state on return; ``stats`` receives
    [accepted steps, rejected steps, rhs evaluations, Jacobian evaluations].

    Closed loop (``ctl`` an array, see :mod:`._controller`; None in open loop, which
    compiles none of the controller's code): the steps end on every
    sample instant t_k = t_0 + k·ctl[0] (k < ``log.shape[1]``), where
    :func:`~._controller.controller_sample` writes the new valve command into the
    constant input slot sg[16]; f is re-evaluated there (and the exact Jacobians of the
    reduced and PWA models, which depend on u, refreshed; the full model's ∂f/∂y does
    not depend on u, so its Jacobian is kept).
    """
    rtol, scale, atol, h0, hmax, max_steps, jac_reuse, gustafsson, exact_jac = tol
    Y, y, f0, fnew, ft, yt, ynew, yerr, dfdt, U, J, W, piv, stats = work
    ctl, cst, ref, dref, log = loop
    n = n_states(kind)
    n_err = n_norm(kind, p)  # n, less a kind's absent trailing states (registry row)
    n_out = t_out.shape[0]
    closed = _closed(ctl)
    n_smp = _n_samples(log)
    dt_smp = _sample_time(ctl)
    # the method's constants (its row of _rosenbrock.METHODS)
    gamma = method_gamma(method)
    # only a W-method keeps its order with an old Jacobian: the others take one at every step
    reuse = jac_reuse and method_w(method)
    order = method_error_order(method)  # step factor err^(-1/(order + 1))
    fsal = method_fsal(method)  # its stepper fills f(t + h, ynew)
    # after an accepted step whose error exceeds this fraction of the tolerance the Jacobian
    # is refreshed: exact ones (reduced, PWA: no rhs call) at 0.2, differences at 0.5.
    # Measured on the paper rig: 0.2 saves the reduced model 8 % of its steps for 40 % more
    # (cheap) Jacobians; see docs/architecture_performance.md.
    jac_err = 0.2 if exact_jac else 0.5
    t = t_out[0]
    t_end = t_out[n_out - 1]
    for i in range(n):
        Y[0, i] = y[i]
    k_out = 1
    t_stop = t_end
    k_smp = 0
    if closed:  # first sample at t_0, the next one ends the first steps
        _sample(kind, 0, t, y, p, ctl, cst, ref, dref, sg, log)
        k_smp = 1
        if k_smp < n_smp:
            t_stop = min(t_end, t_out[0] + k_smp * dt_smp)
    u, ps, fl = _inputs(t, sg)
    _rhs_for(kind, y, u, ps, fl, p, f0)
    nfev = 1
    n_jac = 0
    h = min(h0, hmax)
    n_acc = 0
    n_rej = 0
    status = OK
    need_jac = True
    jac_age = 0
    h_fact = -1.0
    last_rejected = False
    h_acc = -1.0
    cb_acc = 1.0
    while k_out < n_out:
        if n_acc + n_rej >= max_steps:
            status = MAX_STEPS
            break
        hmin = 1e-14 * max(1.0, abs(t)) + 1e-15
        if h < hmin:
            status = STEP_COLLAPSE
            break
        if t + h > t_stop or (closed and t + 1.1 * h > t_stop):
            h = t_stop - t  # closed loop: also no sliver of a step left before the sample
            if h < hmin:
                h = hmin
        if need_jac:  # u, ps, fl hold the inputs at t (from the last step's end or a sample)
            nfev += _jacobian(kind, t, y, f0, u, ps, fl, p, sg, scale, J, dfdt, yt, ft, exact_jac)
            n_jac += 1
            need_jac = False
            jac_age = 0
            h_fact = -1.0
        if h != h_fact:
            _factor(kind, J, W, piv, h * gamma, p)
            h_fact = h
        n_rhs, u1, ps1, fl1 = _step_for(
            method, kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg
        )
        nfev += n_rhs
        err, finite = _error_norm(n_err, y, ynew, yerr, atol, rtol)
        # f(t + h, ynew) (next step's first stage, dense output) only if accepted, unless the
        # method's error estimate needs it (fsal: its stepper has filled it)
        fresh = not fsal and finite and err <= 1.0
        if fresh:
            _rhs_for(kind, ynew, u1, ps1, fl1, p, fnew)
            nfev += 1
        if fresh or fsal:
            for i in range(n):
                if not math.isfinite(fnew[i]):
                    finite = False
        if not finite or not math.isfinite(err):
            n_rej += 1
            h *= 0.25
            need_jac = True
            last_rejected = True
            if h < hmin:
                status = NON_FINITE
                break
            continue
        if err <= 1.0:
            k_out = _dense_output(kind, Y, k_out, t_out, t, h, y, f0, ynew, fnew)
            t = t + h
            u, ps, fl = u1, ps1, fl1  # the stepper's inputs at t + h, bit for bit _inputs(t, sg)
            for i in range(n):
                y[i] = ynew[i]
                f0[i] = fnew[i]
            n_acc += 1
            jac_age += 1
            need_jac = not reuse or jac_age >= 8 or err > jac_err
            if closed and k_smp < n_smp and t >= t_stop - 1e-12 * max(1.0, abs(t_stop)):
                t = t_stop
                _sample(kind, k_smp, t, y, p, ctl, cst, ref, dref, sg, log)
                k_smp += 1
                t_stop = min(t_end, t_out[0] + k_smp * dt_smp) if k_smp < n_smp else t_end
                u, ps, fl = _inputs(t, sg)
                _rhs_for(kind, y, u, ps, fl, p, f0)
                nfev += 1
                if jac_depends_on_u(kind):  # the registry row's flag (reduced, PWA)
                    need_jac = True
            fac, cb_acc = _accepted_factor(
                err, h, h_acc, cb_acc, gustafsson, last_rejected, need_jac, order
            )
            h_acc = h
            h *= fac
            if h > hmax:
                h = hmax
            last_rejected = False
        else:
            n_rej += 1
            h *= _rejected_factor(err, order)
            need_jac = reuse and jac_age > 0
            last_rejected = True
    stats[ST_STEPS] = n_acc
    stats[ST_REJECTED] = n_rej
    stats[ST_RHS] = nfev
    stats[ST_JAC] = n_jac
    return k_out, status, t


@njit(**SOLVER_JIT)
def _integrate_closed(kind, run, method, ctl, ref, dref):
    """:func:`_integrate` with the discrete controller ``ctl`` in the loop (see :mod:`._controller`).

    ``sg`` must hold the valve command as a constant signal; its value slot is the
    controller's output. ``ref``, ``dref``: reference position [m] and rate [m/s] at the
    sample instants t_0 + k·ctl[0], k < len(ref). Returns :func:`_integrate`'s tuple and
    the per-sample log, shape (N_LOG, len(ref)) (rows in :mod:`._controller`).
    """
    work = _work_arrays(n_states(kind), run.t_out.shape[0], run.y0)
    tol = _tolerances(run, True, True, True)
    log = np.full((N_LOG, ref.shape[0]), np.nan)
    loop = (ctl, np.zeros(N_CST), ref, dref, log)
    k_out, status, t = _march(kind, method, run.t_out, run.p, run.sg, tol, work, loop)
    Y, y, stats = work[0], work[1], work[13]
    return Y, k_out, status, t, y, stats, log
