"""Plain Python/NumPy right-hand sides of the full and reduced models (the scipy baseline).

These restate Eqs. (1)–(15) of the paper without numba so that
``scipy.integrate.solve_ivp`` can be timed on the kind of code a user would
write by hand. They read the same packed parameter vector as the compiled
kernel (layout in :mod:`hydropwa.simulation._kernel`) so both integrate the
same vector field; :func:`check_against_kernel` verifies that.
"""

from __future__ import annotations

import math

import numpy as np

from hydropwa.simulation import _kernel as K


def _signed_sqrt(dp, p_tr):
    if abs(dp) >= p_tr:
        return math.copysign(math.sqrt(abs(dp)), dp)
    s = dp / p_tr
    return math.sqrt(p_tr) * (1.25 * s - 0.25 * s**3)


def _dead_zone(nu, p):
    a = abs(nu)
    if a < p[K.I_BETA]:
        return p[K.I_CREEP] * nu
    s = 1.0 if nu > 0 else -1.0
    if a >= p[K.I_ALPHA] + p[K.I_OUTER]:
        return s * p[K.I_ALPHA]
    return nu - s * p[K.I_OUTER]


def _friction(v, p):
    fc, fs, chi = p[K.I_FC], p[K.I_FS], p[K.I_CHI]
    stribeck = np.exp(-(np.abs(v / chi) ** p[K.I_DELTA]))
    return np.tanh(p[K.I_GAMMA] * v) * (fc + (fs - fc) * stribeck) + p[K.I_SIGMA] * v


def _end_stop(x, v, p):
    k, c, stroke = p[K.I_KSTOP], p[K.I_CSTOP], p[K.I_STROKE]
    if x < 0.0:
        return max(-k * x - c * v, 0.0)
    if x > stroke:
        return min(-k * (x - stroke) - c * v, 0.0)
    return 0.0


def _bulk(pr, p):
    if pr >= p[K.I_PREL]:
        return p[K.I_E]
    frac = max((pr - p[K.I_PVAP]) / (p[K.I_PREL] - p[K.I_PVAP]), 1e-3)
    return p[K.I_E] * frac


def full_rhs(t, y, p, u_of_t, ps_of_t, fl_of_t):
    """Full-order model, Eqs. (1)–(11) (ideal supply), as a plain Python function."""
    nu, dnu, pa, pb, x, v = y[0], y[1], y[2], y[3], y[4], y[5]
    u, ps, fl = u_of_t(t), ps_of_t(t), fl_of_t(t)
    z = _dead_zone(nu, p)
    kk, ptr, pt = p[K.I_K], p[K.I_PTR], p[K.I_PT]
    if z >= 0:
        qa = z * kk * _signed_sqrt(ps - pa, ptr)
        qb = z * kk * _signed_sqrt(pb - pt, ptr)
    else:
        qa = z * kk * _signed_sqrt(pa - pt, ptr)
        qb = z * kk * _signed_sqrt(ps - pb, ptr)
    aa, ab, cl = p[K.I_AA], p[K.I_AB], p[K.I_CL]
    va = p[K.I_VA] + aa * x
    vb = p[K.I_VB] + ab * (p[K.I_STROKE] - x)
    w0, zeta = p[K.I_OMEGA0], p[K.I_ZETA]
    force = pa * aa - pb * ab - _friction(v, p) - fl + _end_stop(x, v, p)
    dy = np.zeros(len(K.Y_FULL))  # the pump's P_S and the accumulator's gas stay constant here
    dy[K.Y_FULL["spool"]] = dnu
    dy[K.Y_FULL["spool_rate"]] = w0 * w0 * (u - nu) - 2.0 * zeta * w0 * dnu
    dy[K.Y_FULL["p_a"]] = _bulk(pa, p) / va * (qa - aa * v + cl * (pb - pa))
    dy[K.Y_FULL["p_b"]] = _bulk(pb, p) / vb * (-qb + ab * v + cl * (pa - pb))
    dy[K.Y_FULL["x"]] = v
    dy[K.Y_FULL["v"]] = force / p[K.I_MASS]
    return dy


def reduced_rhs(t, y, p, u_of_t, ps_of_t, fl_of_t):
    """Reduced model, Eqs. (12)–(15), as a plain Python function."""
    pl, v, x = y[0], y[1], y[2]
    u, ps, fl = u_of_t(t), ps_of_t(t), fl_of_t(t)
    z = _dead_zone(u, p)
    kk, ptr = p[K.I_K], p[K.I_PTR]
    if z >= 0:
        ql = z * kk * _signed_sqrt(0.5 * (ps - pl), ptr)
    else:
        ql = z * kk * _signed_sqrt(0.5 * (ps + pl), ptr)
    abar = 0.5 * (p[K.I_AA] + p[K.I_AB])
    dpl = 4.0 * p[K.I_E] / (p[K.I_VA] + p[K.I_VB]) * (ql - abar * v - p[K.I_CL] * pl)
    force = abar * pl - _friction(v, p) - fl + _end_stop(x, v, p)
    return np.array([dpl, force / p[K.I_MASS], v])


def reduced_rhs_asymmetric(t, y, p, u_of_t, ps_of_t, fl_of_t):
    """The single-rod reduced model (docs/reduced_asymmetric.md) as a plain Python function."""
    pl, v, x = y[0], y[1], y[2]
    u, ps, fl = u_of_t(t), ps_of_t(t), fl_of_t(t)
    z = _dead_zone(u, p)
    kk, ptr, pt = p[K.I_K], p[K.I_PTR], p[K.I_PT]
    aa, ab = p[K.I_AA], p[K.I_AB]
    al = ab / aa
    a3 = 1.0 + al**3
    if z >= 0:
        drop = (ps - al * pt - pl) / a3
        pa, pb = ps - drop, pt + al * al * drop
    else:
        drop = (al * ps - pt + pl) / a3
        pa, pb = pt + drop, ps - al * al * drop
    ql = z * kk * _signed_sqrt(drop, ptr)
    xs = min(max(x, 0.0), p[K.I_STROKE])
    ia = 1.0 / (p[K.I_VA] + aa * xs)
    ib = 1.0 / (p[K.I_VB] + ab * (p[K.I_STROKE] - xs))
    e = p[K.I_E]
    dpl = e * (ia + al * al * ib) * (ql - aa * v) - e * (ia + al * ib) * p[K.I_CL] * (pa - pb)
    force = aa * pl - _friction(v, p) - fl - p[K.I_CLOAD] * v + _end_stop(x, v, p)
    return np.array([dpl, force / p[K.I_MASS], v])


RHS = {K.FULL: full_rhs, K.REDUCED: reduced_rhs_asymmetric}
#: The reduced model's right-hand side by form (the kernel reads p[K.I_RFORM]).
REDUCED_RHS = {"asymmetric": reduced_rhs_asymmetric, "paper": reduced_rhs}


def check_against_kernel(kind, p, signals, y, t=0.123):
    """Largest relative difference between this RHS and the compiled one at (t, y)."""
    from hydropwa.simulation import pack_signals

    sg = pack_signals(signals)
    dy = np.empty_like(y)
    K.rhs(kind, t, y, p, sg, dy)
    f = RHS[kind] if kind != K.REDUCED or p[K.I_RFORM] == 0.0 else REDUCED_RHS["paper"]
    mine = f(t, y, p, *signals)
    return float(
        np.max(np.abs(mine - dy)) / (np.max(np.abs(dy)) + 1e-300)
    )  # relative to the vector's size
