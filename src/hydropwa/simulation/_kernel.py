"""Compiled right-hand sides of the three models and the stiff integrator.

Everything here runs in numba ``nopython`` mode: the time-stepping loop never
calls Python. The models are assemblies of :mod:`hydropwa.components`.

Model kinds and states
----------------------
``FULL`` (0), Eqs. (1)–(11): y = [ν, ν̇, P_A, P_B, x, ẋ, P_S]; P_S is a state
only with the pump supply model, otherwise its rate is zero and P_S(t) is the
input signal.
``REDUCED`` (1), Eqs. (12)–(15): y = [P_L, ẋ, x].
``PWA`` (2), Eqs. (16)–(23): y = [P_L, ẋ, x] with piecewise-affine cells.

Integrator
----------
A linearly implicit Rosenbrock method of order 2 with an embedded order-3
error estimate (Shampine & Reichelt's ROS2(3), the method of MATLAB's
``ode23s``), L-stable, with a finite-difference Jacobian and time derivative
per step and its free continuous extension for dense output at the requested
sample times. It copes with the stiffness of the chambers (E/V), the tanh
friction and the end stops at a cost of a few right-hand-side calls per step.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..components._physics import (
    chamber_pressure_rates,
    dead_zone,
    end_stop_force,
    load_flow,
    load_pressure_rate,
    orifice_flows,
    piston_acceleration,
    pump_supply_rate,
    servo_valve_acceleration,
    stribeck_friction,
    supply_flow,
)
from ._signals import eval_signal

FULL, REDUCED, PWA = 0, 1, 2
N_STATES = (7, 3, 3)

# Packed parameter vector layout (see hydropwa.models.pack_params).
I_OMEGA0, I_ZETA, I_ALPHA, I_BETA, I_CREEP, I_OUTER = 0, 1, 2, 3, 4, 5
I_K, I_PTR, I_AA, I_AB, I_STROKE, I_VA, I_VB, I_CL = 6, 7, 8, 9, 10, 11, 12, 13
I_KSTOP, I_CSTOP, I_E, I_PVAP, I_PREL = 14, 15, 16, 17, 18
I_FC, I_FS, I_SIGMA, I_CHI, I_DELTA, I_GAMMA = 19, 20, 21, 22, 23, 24
I_PT, I_PUMP, I_PSET, I_QMAX, I_DROOP, I_VLINE, I_PRELIEF, I_GRELIEF, I_MASS = 25, 26, 27, 28, 29, 30, 31, 32, 33
N_BASE = 40
# PWA section (written by hydropwa.linearization.pack_pwa)
I_SCHED, I_PSFIX, I_FORM, I_NG, I_NO, I_NN, I_NW = 40, 41, 42, 43, 44, 45, 46
I_CELLS = 50

# Status codes of integrate()
OK, MAX_STEPS, STEP_COLLAPSE, NON_FINITE = 0, 1, 2, 3


@njit(cache=True, nogil=True)
def _inputs(t, sk, sp, st, sv, so):
    """Evaluate the three input signals u, P_S, F_L at time t."""
    u = eval_signal(sk[0], sp[0], st[so[0, 0] : so[0, 1]], sv[so[0, 0] : so[0, 1]], t)
    ps = eval_signal(sk[1], sp[1], st[so[1, 0] : so[1, 1]], sv[so[1, 0] : so[1, 1]], t)
    fl = eval_signal(sk[2], sp[2], st[so[2, 0] : so[2, 1]], sv[so[2, 0] : so[2, 1]], t)
    return u, ps, fl


@njit(cache=True, nogil=True)
def _friction(v, p):
    return stribeck_friction(v, p[I_FC], p[I_FS], p[I_SIGMA], p[I_CHI], p[I_DELTA], p[I_GAMMA])


@njit(cache=True, nogil=True)
def _opening(nu, p):
    return dead_zone(nu, p[I_ALPHA], p[I_BETA], p[I_CREEP], p[I_OUTER])


@njit(cache=True, nogil=True)
def rhs_full(y, u, ps_in, fl, p, dy):
    """Full-order model, Eqs. (1)–(11), with the corrected sign of Q_B (NOTES item 1)."""
    nu, dnu, pa, pb, x, v = y[0], y[1], y[2], y[3], y[4], y[5]
    pump = p[I_PUMP] > 0.5
    ps = y[6] if pump else ps_in
    z = _opening(nu, p)
    qa, qb = orifice_flows(z, pa, pb, ps, p[I_PT], p[I_K], p[I_PTR])
    dpa, dpb = chamber_pressure_rates(
        qa, qb, x, v, pa, pb, p[I_AA], p[I_AB], p[I_STROKE], p[I_VA], p[I_VB], p[I_CL], p[I_E], p[I_PVAP], p[I_PREL]
    )
    stop = end_stop_force(x, v, p[I_STROKE], p[I_KSTOP], p[I_CSTOP])
    dy[0] = dnu
    dy[1] = servo_valve_acceleration(nu, dnu, u, p[I_OMEGA0], p[I_ZETA])
    dy[2] = dpa
    dy[3] = dpb
    dy[4] = v
    dy[5] = piston_acceleration(pa * p[I_AA] - pb * p[I_AB], _friction(v, p), fl, stop, p[I_MASS])
    if pump:
        dy[6] = pump_supply_rate(
            ps, supply_flow(z, qa, qb), p[I_PSET], p[I_QMAX], p[I_DROOP], p[I_VLINE], p[I_E], p[I_PRELIEF], p[I_GRELIEF]
        )
    else:
        dy[6] = 0.0


@njit(cache=True, nogil=True)
def rhs_reduced(y, u, ps, fl, p, dy):
    """Reduced model, Eqs. (12)–(15): valve dynamics dropped (ν = u), load pressure P_L."""
    pl, v, x = y[0], y[1], y[2]
    abar = 0.5 * (p[I_AA] + p[I_AB])
    z = _opening(u, p)
    ql = load_flow(z, pl, ps, p[I_K], p[I_PTR])
    stop = end_stop_force(x, v, p[I_STROKE], p[I_KSTOP], p[I_CSTOP])
    dy[0] = load_pressure_rate(ql, v, pl, abar, p[I_VA] + p[I_VB], p[I_CL], p[I_E])
    dy[1] = piston_acceleration(abar * pl, _friction(v, p), fl, stop, p[I_MASS])
    dy[2] = v


@njit(cache=True, nogil=True)
def _cell(p, start, n, xv):
    """Index of the active cell among n cells whose n-1 breakpoints start at p[start]."""
    i = 0
    while i < n - 1 and xv >= p[start + i]:
        i += 1
    return i


@njit(cache=True, nogil=True)
def pwa_cells(y, u, ps_in, p):
    """Active cells (g, o, n, w), opening z and the scheduled P_S of the PWA model."""
    ng, no, nn, nw = int(p[I_NG]), int(p[I_NO]), int(p[I_NN]), int(p[I_NW])
    ps = ps_in if p[I_SCHED] > 0.5 else p[I_PSFIX]
    s_g = I_CELLS
    g = _cell(p, s_g, ng, u)
    z = p[s_g + ng - 1 + g] * u + p[s_g + 2 * ng - 1 + g]
    s_o = s_g + 3 * ng - 1
    sgn = 1.0 if z >= 0.0 else -1.0
    pn = sgn * y[0] / ps
    o = _cell(p, s_o, no, pn)
    s_n = s_o + 3 * no - 1
    n = _cell(p, s_n, nn, pn)
    s_w = s_n + 3 * nn - 1
    w = _cell(p, s_w, nw, y[1])
    return g, o, n, w, z, ps, pn


@njit(cache=True, nogil=True)
def rhs_pwa(y, u, ps_in, fl, p, dy):
    """Linearized piecewise-affine model, Eqs. (16)–(23), cells scheduled on P_S.

    Q_L = z·C_q(P_L) − c·sign(z)·C_qp(P_L, z)·P_L with C_q = K√(P_S/2)(k̂_o p̃ + d̂_o),
    C_qp = |z| K/(4√(P_S/2)) (k̂_n p̃ + d̂_n), p̃ = sign(z) P_L/P_S, c the paper-form flag.
    """
    pl, v, x = y[0], y[1], y[2]
    ng, no, nn, nw = int(p[I_NG]), int(p[I_NO]), int(p[I_NN]), int(p[I_NW])
    g, o, n, w, z, ps, pn = pwa_cells(y, u, ps_in, p)
    s_o = I_CELLS + 3 * ng - 1
    s_n = s_o + 3 * no - 1
    s_w = s_n + 3 * nn - 1
    root = math.sqrt(0.5 * ps)
    K = p[I_K]
    cq = K * root * (p[s_o + no - 1 + o] * pn + p[s_o + 2 * no - 1 + o])
    ql = z * cq
    if p[I_FORM] != 0.0:
        sgn = 1.0 if z >= 0.0 else -1.0
        cqp = abs(z) * K / (4.0 * root) * (p[s_n + nn - 1 + n] * pn + p[s_n + 2 * nn - 1 + n])
        ql -= p[I_FORM] * sgn * cqp * pl
    abar = 0.5 * (p[I_AA] + p[I_AB])
    ff = p[s_w + nw - 1 + w] * v + p[s_w + 2 * nw - 1 + w]
    stop = end_stop_force(x, v, p[I_STROKE], p[I_KSTOP], p[I_CSTOP])
    dy[0] = load_pressure_rate(ql, v, pl, abar, p[I_VA] + p[I_VB], p[I_CL], p[I_E])
    dy[1] = piston_acceleration(abar * pl, ff, fl, stop, p[I_MASS])
    dy[2] = v


@njit(cache=True, nogil=True)
def rhs(kind, t, y, p, sk, sp, st, sv, so, dy):
    """Right-hand side of model ``kind`` at time t (inputs evaluated from the packed signals)."""
    u, ps, fl = _inputs(t, sk, sp, st, sv, so)
    if kind == FULL:
        rhs_full(y, u, ps, fl, p, dy)
    elif kind == REDUCED:
        rhs_reduced(y, u, ps, fl, p, dy)
    else:
        rhs_pwa(y, u, ps, fl, p, dy)


@njit(cache=True, nogil=True)
def _lu(a, piv):
    """In-place LU factorisation with partial pivoting of a small dense matrix."""
    n = a.shape[0]
    for k in range(n):
        m = k
        big = abs(a[k, k])
        for i in range(k + 1, n):
            if abs(a[i, k]) > big:
                big = abs(a[i, k])
                m = i
        piv[k] = m
        if m != k:
            for j in range(n):
                tmp = a[k, j]
                a[k, j] = a[m, j]
                a[m, j] = tmp
        if a[k, k] == 0.0:
            a[k, k] = 1e-300
        inv = 1.0 / a[k, k]
        for i in range(k + 1, n):
            a[i, k] *= inv
            f = a[i, k]
            if f != 0.0:
                for j in range(k + 1, n):
                    a[i, j] -= f * a[k, j]


@njit(cache=True, nogil=True)
def _solve(a, piv, b):
    """Solve LU x = b in place (b overwritten with x)."""
    n = a.shape[0]
    for k in range(n):
        m = piv[k]
        if m != k:
            tmp = b[k]
            b[k] = b[m]
            b[m] = tmp
    for i in range(1, n):
        s = b[i]
        for j in range(i):
            s -= a[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= a[i, j] * b[j]
        b[i] = s / a[i, i]


@njit(cache=True, nogil=True)
def integrate(kind, y0, t_out, p, sk, sp, st, sv, so, rtol, scale, h0, hmax, max_steps):
    """Integrate model ``kind`` from t_out[0] with ROS2(3), dense output at ``t_out``.

    Parameters
    ----------
    kind : int
        FULL, REDUCED or PWA.
    y0 : ndarray
        Initial state.
    t_out : ndarray
        Increasing output times [s]; integration runs from t_out[0] to t_out[-1].
    p : ndarray
        Packed parameters.
    sk, sp, st, sv, so : ndarray
        Packed input signals (kinds, parameters, sample times, values, offsets).
    rtol : float
        Relative tolerance; the absolute tolerance of state i is rtol·scale[i].
    scale : ndarray
        Typical magnitude of each state (SI).
    h0, hmax : float
        Initial and largest step [s].
    max_steps : int
        Step budget.

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
        [accepted steps, rejected steps, rhs evaluations].
    """
    n = y0.shape[0]
    n_out = t_out.shape[0]
    Y = np.empty((n_out, n))
    d = 1.0 / (2.0 + math.sqrt(2.0))
    e32 = 6.0 + math.sqrt(2.0)
    sqrt_eps = math.sqrt(2.2e-16)
    y = y0.copy()
    t = t_out[0]
    t_end = t_out[n_out - 1]
    Y[0, :] = y
    k_out = 1
    f0 = np.empty(n)
    f1 = np.empty(n)
    f2 = np.empty(n)
    ft = np.empty(n)
    yt = np.empty(n)
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    ynew = np.empty(n)
    dfdt = np.empty(n)
    J = np.empty((n, n))
    W = np.empty((n, n))
    piv = np.empty(n, dtype=np.int64)
    atol = rtol * scale
    rhs(kind, t, y, p, sk, sp, st, sv, so, f0)
    nfev = 1
    h = min(h0, hmax)
    n_acc = 0
    n_rej = 0
    status = OK
    need_jac = True
    while k_out < n_out:
        if n_acc + n_rej >= max_steps:
            status = MAX_STEPS
            break
        hmin = 1e-14 * max(1.0, abs(t)) + 1e-15
        if h < hmin:
            status = STEP_COLLAPSE
            break
        if t + h > t_end:
            h = t_end - t
            if h < hmin:
                h = hmin
        if need_jac:
            # finite-difference Jacobian and time derivative at (t, y)
            for j in range(n):
                yt[:] = y
                dj = sqrt_eps * max(abs(y[j]), scale[j])
                yt[j] = y[j] + dj
                rhs(kind, t, yt, p, sk, sp, st, sv, so, ft)
                for i in range(n):
                    J[i, j] = (ft[i] - f0[i]) / dj
            dt = sqrt_eps * max(abs(t), 1e-3)
            rhs(kind, t + dt, y, p, sk, sp, st, sv, so, ft)
            for i in range(n):
                dfdt[i] = (ft[i] - f0[i]) / dt
            nfev += n + 1
            need_jac = False
        hd = h * d
        for i in range(n):
            for j in range(n):
                W[i, j] = -hd * J[i, j]
            W[i, i] += 1.0
        _lu(W, piv)
        for i in range(n):
            k1[i] = f0[i] + hd * dfdt[i]
        _solve(W, piv, k1)
        for i in range(n):
            yt[i] = y[i] + 0.5 * h * k1[i]
        rhs(kind, t + 0.5 * h, yt, p, sk, sp, st, sv, so, f1)
        for i in range(n):
            k2[i] = f1[i] - k1[i]
        _solve(W, piv, k2)
        for i in range(n):
            k2[i] += k1[i]
            ynew[i] = y[i] + h * k2[i]
        rhs(kind, t + h, ynew, p, sk, sp, st, sv, so, f2)
        for i in range(n):
            k3[i] = f2[i] - e32 * (k2[i] - f1[i]) - 2.0 * (k1[i] - f0[i]) + hd * dfdt[i]
        _solve(W, piv, k3)
        nfev += 2
        err = 0.0
        finite = True
        for i in range(n):
            e = h / 6.0 * (k1[i] - 2.0 * k2[i] + k3[i])
            sc = atol[i] + rtol * max(abs(y[i]), abs(ynew[i]))
            err += (e / sc) ** 2
            if not math.isfinite(ynew[i]) or not math.isfinite(f2[i]):
                finite = False
        err = math.sqrt(err / n)
        if not finite or not math.isfinite(err):
            n_rej += 1
            h *= 0.25
            if h < hmin:
                status = NON_FINITE
                break
            continue
        if err <= 1.0:
            t_new = t + h
            # dense output with the method's continuous extension
            while k_out < n_out and t_out[k_out] <= t_new + 1e-12 * max(1.0, abs(t_new)):
                th = (t_out[k_out] - t) / h
                c1 = th * (1.0 - th) / (1.0 - 2.0 * d)
                c2 = th * (th - 2.0 * d) / (1.0 - 2.0 * d)
                for i in range(n):
                    Y[k_out, i] = y[i] + h * (c1 * k1[i] + c2 * k2[i])
                k_out += 1
            t = t_new
            y[:] = ynew
            f0[:] = f2
            n_acc += 1
            need_jac = True
            fac = 0.8 * err ** (-1.0 / 3.0) if err > 0.0 else 5.0
            h *= min(5.0, max(0.2, fac))
            if h > hmax:
                h = hmax
        else:
            n_rej += 1
            h *= max(0.2, 0.8 * err ** (-1.0 / 3.0))
    stats = np.array([n_acc, n_rej, nfev], dtype=np.int64)
    return Y, k_out, status, t, y, stats


@njit(cache=True, nogil=True)
def outputs(kind, t_out, Y, n_done, p, sk, sp, st, sv, so):
    """Derived channels per output sample.

    Returns an array of shape (n_done, 12) with columns
    u, spool, z, p_a, p_b, p_l, p_s, f_l, x, v, friction, cells (packed g,o,n,w as g+8o+64n+512w; -1 if not PWA).
    """
    out = np.empty((n_done, 12))
    for k in range(n_done):
        t = t_out[k]
        y = Y[k]
        u, ps, fl = _inputs(t, sk, sp, st, sv, so)
        cells = -1.0
        if kind == FULL:
            spool = y[0]
            z = _opening(spool, p)
            pa, pb = y[2], y[3]
            if p[I_PUMP] > 0.5:
                ps = y[6]
            pl = pa - pb
            x, v = y[4], y[5]
            fr = _friction(v, p)
        else:
            pl, v, x = y[0], y[1], y[2]
            spool = u
            if kind == REDUCED:
                z = _opening(u, p)
                fr = _friction(v, p)
            else:
                g, o, nn, w, z, ps, _pn = pwa_cells(y, u, ps, p)
                ng, no, nnn, nw = int(p[I_NG]), int(p[I_NO]), int(p[I_NN]), int(p[I_NW])
                s_w = I_CELLS + 3 * ng - 1 + 3 * no - 1 + 3 * nnn - 1
                fr = p[s_w + nw - 1 + w] * v + p[s_w + 2 * nw - 1 + w]
                cells = g + 8.0 * o + 64.0 * nn + 512.0 * w
            pa = 0.5 * (ps + pl)
            pb = 0.5 * (ps - pl)
        out[k, 0] = u
        out[k, 1] = spool
        out[k, 2] = z
        out[k, 3] = pa
        out[k, 4] = pb
        out[k, 5] = pl
        out[k, 6] = ps
        out[k, 7] = fl
        out[k, 8] = x
        out[k, 9] = v
        out[k, 10] = fr
        out[k, 11] = cells
    return out
