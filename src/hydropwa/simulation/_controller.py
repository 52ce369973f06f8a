"""Compiled discrete controllers evaluated inside the integrator loop (no Python per sample).

The integrator (:func:`hydropwa.simulation._kernel._march`) stops at every sample
instant t_k = t_0 + k·T_s, calls :func:`controller_sample` with the state there and
writes the new valve command into the packed input vector (the command is a constant
signal, held between samples: zero-order hold). Every controller of
:mod:`hydropwa.control` packs into one float vector ``ctl``:

========  ================================================================
ctl[0]    sample time T_s [s]
ctl[1]    one-sample computation delay (1) or none (0)
ctl[2:4]  valve command limits u_min, u_max [1]
ctl[4]    anti-windup: 0 none, 1 clamping (conditional integration),
          2 back-calculation with gain ctl[5] [1/s]
ctl[6]    dead-zone inverse on (1) / off (0); ctl[7] outer offset [1];
          ctl[8] blend width z_w [1] (see :func:`dead_zone_inverse`)
ctl[9]    pressure-rate filter coefficient a = exp(−T_s/T_f) (0: no filter)
ctl[10]   number of gain rows (1 for a fixed-gain controller)
ctl[11]   pressure washout coefficient a_w = exp(−T_s/T_w) (0: none); with it
          the gains k_pl act on P_L − P̄_L, P̄_L the low-pass of P_L (time
          constant T_w), so a static load pressure is left to the integral
ctl[12]   load pressure of the design model: 0 asymmetric (P_L = P_A − α P_B = F/A_A),
          1 the paper's mean-area form (P_L = F/Ā)
ctl[13:17] scales [Pa, m/s, m, 1] of the box distance used to pick a row
ctl[17:]  rows of ``ROW`` values: box lower [P_L, ẋ, x, c_prev] (4), upper (4),
          then k_p [1/m], k_i [1/(m·s)], k_ff [s/m], k_v [s/m], k_pl [1/Pa],
          k_dpl [s/Pa], u_ff [1]
========  ================================================================

Control law at sample k (e = r − x, I the integral of e, c the command before the
dead-zone inverse, row chosen by the box that holds [P_L, ẋ, x, c_{k−1}])::

    c = u_ff + k_p e + k_i I + k_ff ṙ − k_v ẋ − k_pl P_L − k_dpl Ṗ_L   (P_L washed out if ctl[11] > 0)
    u = sat(DZ⁻¹(c))  (or sat(c) without the inverse)

State feedback with integral action (LQR per PWA cell) is the same law with the gains
of the row: u = −k_pl P_L − k_v ẋ + k_p (r − x) + k_i ∫(r − x).
"""

from __future__ import annotations

import math

from numba import njit

from .. import _jitcache  # noqa: F401  (one cache stamp for all compiled modules)
from .._layout import Y_FULL, Y_LOAD
from ._signals import NO_REFCOUNT, eval_signal_rate

_X, _V, _PA, _PB = (Y_FULL[k] for k in ("x", "v", "p_a", "p_b"))
_LPL, _LV, _LX = (Y_LOAD[k] for k in ("p_l", "v", "x"))

(
    C_TS,
    C_DELAY,
    C_UMIN,
    C_UMAX,
    C_AW,
    C_KT,
    C_DZINV,
    C_DZOFF,
    C_DZW,
    C_FILT,
    C_NROWS,
    C_WASH,
    C_PLMEAN,
) = range(13)
C_SCALE = 13
C_ROWS = 17
ROW = 15
R_LO, R_HI, R_KP, R_KI, R_KFF, R_KV, R_KPL, R_KDPL, R_UFF = 0, 4, 8, 9, 10, 11, 12, 13, 14
AW_NONE, AW_CLAMP, AW_BACK = 0, 1, 2
#: controller memory ``cst``: integral, previous P_L, filtered Ṗ_L, pending command, previous c, row,
#: low-passed P_L (washout)
S_INT, S_PL, S_DPL, S_PEND, S_CPREV, S_ROW, S_PLBAR = range(7)
N_CST = 7
#: per-sample log rows (log has shape (N_LOG, samples))
L_T, L_U, L_R, L_E, L_C, L_ROW, L_INT, L_UNEW = range(8)
N_LOG = 8


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def dead_zone_inverse(c, offset, width):
    """Valve command u [1] that opens the orifice by c [1] through the dead zone of Eq. (2).

    Outside the band the inverse of z = u − offset·sign(u) (Table IV outer cells) is
    u = c + offset·sign(c). For |c| < width it is the straight line through zero
    u = c·(width + offset)/width that meets it, so the inverse is continuous and a
    command near zero does not switch between ±offset every sample (chattering).
    """
    if width <= 0.0:
        if c == 0.0:
            return 0.0
        return c + offset if c > 0.0 else c - offset
    a = abs(c)
    if a >= width:
        return c + offset if c > 0.0 else c - offset
    return c * (width + offset) / width


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def measure(kind, y, a_a, a_b, mean_area):
    """Measured channels (x [m], ẋ [m/s], P_L [Pa]) from the state of model ``kind``.

    For the full model P_L is the force-equivalent load pressure of the model the
    controller was designed on: (P_A·A_A − P_B·A_B)/A_A = P_A − α P_B for the asymmetric
    reduced/PWA models (``mean_area`` 0), /Ā for the paper's mean-area form (1). Plain
    P_A − P_B differs from it at rest by about P_S(1 − α) on a single-rod cylinder, which
    a state feedback would read as a load.
    """
    if kind == 0 or kind == 3:  # full and chamber PWA models (hydropwa._layout.FULL_STATES)
        area = 0.5 * (a_a + a_b) if mean_area != 0.0 else a_a
        return y[_X], y[_V], (y[_PA] * a_a - y[_PB] * a_b) / area
    return y[_LX], y[_LV], y[_LPL]  # reduced, PWA (LOAD_STATES)


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def _box_distance(ctl, r, pl, v, x, c):
    """Scaled distance of [P_L, ẋ, x, c] from the box of row r (0 inside)."""
    b = C_ROWS + ROW * r
    d = 0.0
    for j in range(4):
        m = pl if j == 0 else (v if j == 1 else (x if j == 2 else c))
        lo = ctl[b + R_LO + j]
        hi = ctl[b + R_HI + j]
        if m < lo:
            d += (lo - m) / ctl[C_SCALE + j]
        elif m > hi:
            d += (m - hi) / ctl[C_SCALE + j]
    return d


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def select_row(ctl, pl, v, x, c, last):
    """Gain row whose box holds [P_L, ẋ, x, c]; outside all boxes the nearest (scaled distance).

    The row of the last sample is tried first: the state rarely leaves its cell between
    two samples, and the search over all rows (70 on the paper rig) then costs nothing.
    """
    n = int(ctl[C_NROWS])
    if n <= 1:
        return 0
    if 0 <= last < n and _box_distance(ctl, last, pl, v, x, c) == 0.0:
        return last
    best = 0
    best_d = math.inf
    for r in range(n):
        d = _box_distance(ctl, r, pl, v, x, c)
        if d == 0.0:
            return r
        if d < best_d:
            best_d = d
            best = r
    return best


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def controller_sample(kind, k, t, y, a_a, a_b, ctl, cst, ref, dref, sg, log):
    """Evaluate the controller at sample k (time t [s], state y) and hold its command in ``sg``.

    ``a_a``, ``a_b``: piston areas [m²] (for the full model's load pressure, :func:`measure`).
    Writes the command applied from t on into the packed valve-command slot sg[16] (a
    constant signal, see :func:`hydropwa.simulation.pack_signals`), updates the memory
    ``cst`` and fills column k of ``log`` (one contiguous row per quantity). ``ref[k]``, ``dref[k]``: reference position [m]
    and its rate [m/s] at t.
    """
    x, v, pl = measure(kind, y, a_a, a_b, ctl[C_PLMEAN])
    ts = ctl[C_TS]
    r = ref[k]
    e = r - x
    if k == 0:
        cst[S_PL] = pl
        cst[S_DPL] = 0.0
        cst[S_PLBAR] = pl
    a = ctl[C_FILT]
    dpl = a * cst[S_DPL] + (1.0 - a) * (pl - cst[S_PL]) / ts
    aw_ = ctl[C_WASH]
    if aw_ > 0.0:
        cst[S_PLBAR] = aw_ * cst[S_PLBAR] + (1.0 - aw_) * pl
        pl_fb = pl - cst[S_PLBAR]
    else:
        pl_fb = pl
    row = select_row(ctl, pl, v, x, cst[S_CPREV], int(cst[S_ROW]) if k > 0 else -1)
    b = C_ROWS + ROW * row
    ki = ctl[b + R_KI]
    c_raw = (
        ctl[b + R_UFF]
        + ctl[b + R_KP] * e
        + ki * cst[S_INT]
        + ctl[b + R_KFF] * dref[k]
        - ctl[b + R_KV] * v
        - ctl[b + R_KPL] * pl_fb
        - ctl[b + R_KDPL] * dpl
    )
    u_raw = dead_zone_inverse(c_raw, ctl[C_DZOFF], ctl[C_DZW]) if ctl[C_DZINV] > 0.5 else c_raw
    u = min(max(u_raw, ctl[C_UMIN]), ctl[C_UMAX])
    c_sat = c_raw - (u_raw - u)  # the inverse has slope 1 where the command saturates
    log[L_INT, k] = cst[S_INT]
    if ki != 0.0:
        aw = int(ctl[C_AW])
        if aw == AW_CLAMP:
            # integrate unless saturated and the error would drive further into the limit
            if u == u_raw or (u_raw > u and e * ki < 0.0) or (u_raw < u and e * ki > 0.0):
                cst[S_INT] += ts * e
        elif aw == AW_BACK:
            cst[S_INT] += ts * (e + ctl[C_KT] * (c_sat - c_raw) / ki)
        else:
            cst[S_INT] += ts * e
    if ctl[C_DELAY] > 0.5:
        u_apply = cst[S_PEND]
        cst[S_PEND] = u
    else:
        u_apply = u
    sg[16] = u_apply
    cst[S_PL] = pl
    cst[S_DPL] = dpl
    cst[S_CPREV] = c_sat
    cst[S_ROW] = row
    log[L_T, k] = t
    log[L_U, k] = u_apply
    log[L_R, k] = r
    log[L_E, k] = e
    log[L_C, k] = c_raw
    log[L_ROW, k] = row
    log[L_UNEW, k] = u


@njit(cache=True, nogil=True, error_model="numpy")
def eval_rates(sg, i, t):
    """Rate of packed signal ``i`` [unit/s] at every time of the array ``t`` (right derivative)."""
    out = t.copy()
    for k in range(t.shape[0]):
        out[k] = eval_signal_rate(sg, i, t[k])
    return out
