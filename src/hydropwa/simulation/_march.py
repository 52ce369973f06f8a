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
    INLINE_NRT_JIT,
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


@njit(**INLINE_NRT_JIT)
def _step_to_stop(t, h, t_stop, closed, hmin):
    """``h`` cut to end on ``t_stop`` (the next output or sample); in closed loop also no
    sliver of a step left before the sample (h > t_stop − t over 1.1); at least ``hmin``."""
    if t + h > t_stop or (closed and t + 1.1 * h > t_stop):
        h = t_stop - t
        if h < hmin:
            h = hmin
    return h


@njit(**INLINE_NRT_JIT)
def _all_finite(n, v, finite):
    """``finite`` and every one of the first ``n`` entries of ``v`` finite."""
    for i in range(n):
        if not math.isfinite(v[i]):
            finite = False
    return finite


@njit(**INLINE_NRT_JIT)
def _accept_state(n, y, f0, ynew, fnew):
    """The accepted step's state and its rate become the current ones."""
    for i in range(n):
        y[i] = ynew[i]
        f0[i] = fnew[i]


@njit(**INLINE_NRT_JIT)
def _sample_stop(k_smp, n_smp, t_out, t_end, dt_smp):
    """Where the steps end next: sample instant k_smp (t_0 + k·T_s, at most t_end), or t_end
    once every sample is taken."""
    return min(t_end, t_out[0] + k_smp * dt_smp) if k_smp < n_smp else t_end


@njit(**INLINE_NRT_JIT)
def _first_sample(kind, t, t_out, t_end, y, p, sg, loop, closed, n_smp, dt_smp):
    """Closed loop: the sample at t_0; returns (samples done, the first steps' end)."""
    ctl, cst, ref, dref, log = loop
    k_smp = 0
    t_stop = t_end
    if closed:  # first sample at t_0, the next one ends the first steps
        _sample(kind, 0, t, y, p, ctl, cst, ref, dref, sg, log)
        k_smp = 1
        t_stop = _sample_stop(k_smp, n_smp, t_out, t_end, dt_smp)
    return k_smp, t_stop


@njit(**INLINE_NRT_JIT)
def _sample_if_due(kind, k_smp, t, t_stop, t_out, t_end, y, f0, p, sg, loop, closed, n_smp,
                   dt_smp, u, ps, fl, need_jac):  # fmt: skip
    """Closed loop, after an accepted step that ends on the next sample instant: the sample
    (new command in sg), f re-evaluated there and, where ∂f/∂y depends on u (the registry
    row's flag: reduced, PWA), a new Jacobian asked for. Returns (t, k_smp, t_stop, u, ps,
    fl, rhs calls, need_jac)."""
    nfev = 0
    if closed and k_smp < n_smp and t >= t_stop - 1e-12 * max(1.0, abs(t_stop)):
        ctl, cst, ref, dref, log = loop
        t = t_stop
        _sample(kind, k_smp, t, y, p, ctl, cst, ref, dref, sg, log)
        k_smp += 1
        t_stop = _sample_stop(k_smp, n_smp, t_out, t_end, dt_smp)
        u, ps, fl = _inputs(t, sg)
        _rhs_for(kind, y, u, ps, fl, p, f0)
        nfev = 1
        if jac_depends_on_u(kind):
            need_jac = True
    return t, k_smp, t_stop, u, ps, fl, nfev, need_jac


@njit(**INLINE_NRT_JIT)
def _method_constants(method, jac_reuse, exact_jac):
    """The step loop's constants of the method (its row of ``_rosenbrock.METHODS``): γ,
    whether an old Jacobian is reused, the error order, FSAL, and the error fraction above
    which an accepted step refreshes the Jacobian."""
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
    return gamma, reuse, order, fsal, jac_err


@njit(**INLINE_NRT_JIT)
def _matrices(kind, t, h, y, f0, u, ps, fl, p, sg, scale, work, exact_jac, need_jac, h_fact,
              gamma):  # fmt: skip
    """A new Jacobian where asked for (its rhs calls: the first value returned), and
    W = I − hγJ factorised again where h changed. Returns (rhs calls, Jacobians taken,
    need_jac, h_fact)."""
    _Y, _y, _f0, _fnew, ft, yt, _ynew, _yerr, dfdt, _U, J, W, piv, _stats = work
    nfev = 0
    n_jac = 0
    if need_jac:  # u, ps, fl hold the inputs at t (from the last step's end or a sample)
        nfev = _jacobian(kind, t, y, f0, u, ps, fl, p, sg, scale, J, dfdt, yt, ft, exact_jac)
        n_jac = 1
        need_jac = False
        h_fact = -1.0
    if h != h_fact:
        _factor(kind, J, W, piv, h * gamma, p)
        h_fact = h
    return nfev, n_jac, need_jac, h_fact


@njit(**INLINE_NRT_JIT)
def _grown_step(err, h, h_acc, cb_acc, gustafsson, last_rejected, need_jac, order, hmax):
    """The next step after an accepted one (at most hmax). Returns (h, h_acc, cb_acc)."""
    fac, cb_acc = _accepted_factor(
        err, h, h_acc, cb_acc, gustafsson, last_rejected, need_jac, order
    )
    h_acc = h
    h *= fac
    if h > hmax:
        h = hmax
    return h, h_acc, cb_acc


@njit(**INLINE_NRT_JIT)
def _write_stats(stats, n_acc, n_rej, nfev, n_jac):
    """[accepted steps, rejected steps, rhs evaluations, Jacobian evaluations]."""
    stats[ST_STEPS] = n_acc
    stats[ST_REJECTED] = n_rej
    stats[ST_RHS] = nfev
    stats[ST_JAC] = n_jac


@njit(**INLINE_NRT_JIT)
def _budget_status(n_acc, n_rej, max_steps, t, h):
    """Whether the loop must stop before the next attempt (``MAX_STEPS``, ``STEP_COLLAPSE``;
    else ``OK``) and the smallest step at t."""
    hmin = 1e-14 * max(1.0, abs(t)) + 1e-15
    if n_acc + n_rej >= max_steps:
        return MAX_STEPS, hmin
    if h < hmin:
        return STEP_COLLAPSE, hmin
    return OK, hmin


@njit(**INLINE_NRT_JIT)
def _new_rate(kind, n, fsal, finite, err, ynew, u1, ps1, fl1, p, fnew):
    """f(t + h, ynew) (the next step's first stage, the dense output) only if the step is
    accepted, unless the method's error estimate needs it (fsal: its stepper has filled it);
    returns (finite, rhs calls): the step's values and that rate all finite."""
    nfev = 0
    fresh = not fsal and finite and err <= 1.0
    if fresh:
        _rhs_for(kind, ynew, u1, ps1, fl1, p, fnew)
        nfev = 1
    if fresh or fsal:
        finite = _all_finite(n, fnew, finite)
    return finite, nfev


@njit(**SOLVER_JIT, **NO_REFCOUNT)
def _march(kind, method, t_out, p, sg, tol, work, loop):
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
    Y, y, f0, fnew, ft, yt, ynew, yerr, dfdt, U, _J, W, piv, stats = work
    ctl, _cst, _ref, _dref, log = loop
    n = n_states(kind)
    n_err = n_norm(kind, p)  # n, less a kind's absent trailing states (registry row)
    n_out = t_out.shape[0]
    closed = _closed(ctl)
    n_smp = _n_samples(log)
    dt_smp = _sample_time(ctl)
    gamma, reuse, order, fsal, jac_err = _method_constants(method, jac_reuse, exact_jac)
    t = t_out[0]
    t_end = t_out[n_out - 1]
    for i in range(n):
        Y[0, i] = y[i]
    k_out = 1
    k_smp, t_stop = _first_sample(kind, t, t_out, t_end, y, p, sg, loop, closed, n_smp, dt_smp)
    u, ps, fl = _inputs(t, sg)
    _rhs_for(kind, y, u, ps, fl, p, f0)
    h = min(h0, hmax)
    nfev, n_jac, n_acc, n_rej, jac_age = 1, 0, 0, 0, 0
    status, need_jac, last_rejected = OK, True, False
    h_fact, h_acc, cb_acc = -1.0, -1.0, 1.0
    while k_out < n_out:
        status, hmin = _budget_status(n_acc, n_rej, max_steps, t, h)
        if status != OK:
            break
        h = _step_to_stop(t, h, t_stop, closed, hmin)
        if need_jac:
            jac_age = 0
        n_jrhs, n_new, need_jac, h_fact = _matrices(
            kind, t, h, y, f0, u, ps, fl, p, sg, scale, work, exact_jac, need_jac, h_fact, gamma
        )
        nfev += n_jrhs
        n_jac += n_new
        n_rhs, u1, ps1, fl1 = _step_for(
            method, kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg
        )
        nfev += n_rhs
        err, finite = _error_norm(n, n_err, y, ynew, yerr, atol, rtol)
        finite, n_new = _new_rate(kind, n, fsal, finite, err, ynew, u1, ps1, fl1, p, fnew)
        nfev += n_new
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
            _accept_state(n, y, f0, ynew, fnew)
            n_acc += 1
            jac_age += 1
            need_jac = not reuse or jac_age >= 8 or err > jac_err
            t, k_smp, t_stop, u, ps, fl, n_smp_rhs, need_jac = _sample_if_due(
                kind, k_smp, t, t_stop, t_out, t_end, y, f0, p, sg, loop, closed, n_smp,
                dt_smp, u, ps, fl, need_jac,
            )  # fmt: skip
            nfev += n_smp_rhs
            h, h_acc, cb_acc = _grown_step(
                err, h, h_acc, cb_acc, gustafsson, last_rejected, need_jac, order, hmax
            )
            last_rejected = False
        else:
            n_rej += 1
            h *= _rejected_factor(err, order)
            need_jac = reuse and jac_age > 0
            last_rejected = True
    _write_stats(stats, n_acc, n_rej, nfev, n_jac)
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
