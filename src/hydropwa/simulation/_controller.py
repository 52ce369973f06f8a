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

Extension block (schema ``hydropwa.controller/2`` elements; absent in schema-1 controllers,
whose vector ends after the rows, so their law is unchanged bit for bit). It starts at
e0 = C_ROWS + ROW·ctl[C_NROWS] and holds ``N_EXT`` header values, then ``XROW`` values per
gain row (declared in :data:`hydropwa._layout_law.CTL_EXT`)::

    e0+X_FF      flow feed-forward on (1) / off (0): c_ff = A_A ṙ_ff / (K √Δp), Δp the
                 metering-edge drop of Eqs. (5)/(6) at the measured load pressure for the
                 flow direction sign(ṙ_ff) (:func:`~hydropwa.components._physics.load_flow_drop`,
                 at least e0+X_DPMIN)
    e0+X_K       valve flow coefficient K [m³/(s·√Pa)] per metering edge (Eq. (5))
    e0+X_PTR     transition pressure of the root [Pa]
    e0+X_AA      piston area A_A [m²];  e0+X_ALPHA  α = A_B/A_A [1]
    e0+X_PS      supply pressure P_S [Pa] of the design;  e0+X_PT  tank pressure [Pa]
    e0+X_DPMIN   smallest drop used in the inversion [Pa]
    e0+X_REFST   reference state (1): the gains k_v, k_pl act on ẋ − ṙ and on
                 (P_L − P̄_L) − (P_ref − P̄_ref), P_ref = (m r̈ + b ṙ)/A_A (P̄_ref the
                 washout's low-pass of P_ref, 0 at k = 0); with the spool model the row's
                 k_nu and k_up act on ν̂ − c_flow and c_pend − c_flow (c_flow the flow term)
    e0+X_MASS    moving mass m [kg];  e0+X_BV  viscous slope b [N·s/m] of P_ref
    e0+X_LEAD    look-ahead τ [s] of ṙ_ff (applied where the reference is sampled)
    e0+X_VEST    velocity from position (a_v = exp(−T_s/T_v) > 0): v̂ = a_v v̂ + (1 − a_v)(x_k − x_{k−1})/T_s,
                 v̂ = 0 and x_{−1} = x_0 at k = 0; 0: the measured ẋ
    e0+X_SPOOL   spool-state feedback: 0 off, 1 measured (the full model's spool state, mapped
                 to the opening through the inverse of the dead-zone inverse,
                 :func:`spool_opening`; the load-state models have none and use the
                 estimate), 2 estimated by the discrete valve model
                 [ν̂, ν̂̇]⁺ = Φ [ν̂, ν̂̇] + Γ c_apply (Φ row-major at e0+X_PHI, Γ at e0+X_GAM;
                 ν̂ = ν̂̇ = 0 at k = 0), c_apply the saturated command before the
                 dead-zone inverse that the valve holds from t_k on (with the delay the
                 previous sample's, kept in cst[S_CPEND]); with 1 the measured spool has
                 the sensor noise of ``RC_NNU`` (:func:`spool_feedback`)
    e0+X_KF      position observer on (1): steady-state Kalman filter of [x, v] with the
                 reference acceleration as its input, x̂⁻ = x̂ + T_s v̂ + T_s²/2 r̈_{k−1},
                 v̂⁻ = v̂ + T_s r̈_{k−1}, x̂ = x̂⁻ + L_x (x − x̂⁻), v̂ = v̂⁻ + L_v (x − x̂⁻) (gains at
                 e0+X_KFX, e0+X_KFV; x̂ = x, v̂ = ṙ at k = 0); the law then uses x̂ and v̂
    e0+X_DZH     dead-zone hysteresis h [1] (0: none): the inverse keeps the side s of the
                 last command until c crosses −s·h, u = 0 on the other side inside the band
                 (:func:`dead_zone_hysteresis`), so sensor noise on a small command does not
                 throw the spool across the dead zone
    e0+X_DZQ     quiet band q [1] of the command (0: none; :func:`quiet_band`): the opening
                 asked for is 0 for |c| ≤ q, sign(c)·2(|c| − q) up to |c| = 2q, c beyond; it
                 goes through the dead-zone inverse, is the c_sat of the saturation memory,
                 the spool model and the delay, and the integral holds while the opening is
                 0 and |k_x e| < QUIET_HOLD·q
    e0+X_DZQR    quiet band only at rest (1; 0: always): the band acts only while the
                 reference is at rest, |ṙ(t_k)|, |ṙ_ff| ≤ REST_RATE, |r̈(t_k)| ≤
                 REST_ACCELERATION (:func:`quiet_acts`)
    e0+X_DZPO    pre-opening look-ahead τ_o [s] (0: none; :func:`pre_open`): while ṙ(t_k) = 0
                 and ṙ_o = ṙ(t_k + τ_o) ≠ 0 (reference channel ``RC_DRPO``, sampled where the
                 reference is) the opening asked for is at least z_w (ctl[8]) toward sign ṙ_o,
                 so the spool waits at the dead zone's edge when the reference starts
    e0+X_ILEAK   integral leak a_l = exp(−T_s/T_l) (0: none): wherever the quiet band parks
                 the valve (opening 0) the integral decays, I = a_l I, instead of holding or
                 running, so a hold ends with I → 0 and no standing offset k_i I/k_x
    e0+X_IBAND   integral band e_I [m] (0: none): the integral runs only while |e| ≤ e_I, so
                 the approach to a step's target does not wind it (held, or leaking, beyond)
    e0+X_DZPV    pressure vent at rest a_p = exp(−T_s/T_p) (0: none; :func:`pressure_vent`):
                 p̃ = a_p p̃ + (1 − a_p) p_dev every sample (p̃ = p_dev at k = 0), p_dev =
                 (P_L − P̄_L) − (P_ref − P̄_ref) the deviation the gains k_pl act on; where the
                 quiet band acts, the opening asked for inside it (|c| ≤ q) is the vent
                 v = :func:`quiet_vent` of −k_pl p̃ (0 within QUIET_VENT·q), blended out over
                 the ramp q < |c| < 2q; the integral leaks (e0+X_ILEAK) wherever |c| < 2q
    e0+X_DZQO    the quiet band's opening delay n [samples] (0: none; :func:`quiet_open`): where
                 the band acts it opens the valve only on the n-th consecutive sample beyond q
                 on one side (at once where |e| > e_I, e0+X_IBAND); before, it reads c limited
                 to ±q (parked, or the pressure vent's opening); the run restarts whenever c is
                 within ±q or changes side, and is 0 while the band does not act; with it the
                 vent's share is 0 where it points away from the target while |k_x e| > q
                 (:func:`vent_toward_target`)
    e0+X_OUT     the controlled output (:func:`output_stage`): 0 the position x [m], 1 the
                 cylinder force A_A·P_A − A_B·P_B [N] (from P_L, or a load cell's force
                 where it is fed in as P_L·A), 2 the load pressure P_L [Pa]; r and e are then
                 in that output's unit
    e0+X_FCOMP   the compliance [m per output unit] of the force/pressure feed-forward
                 (:func:`feedforward_rate`): the flow feed-forward passes the velocity
                 X_FCOMP·ṙ_ff, ṙ_ff the output reference's look-ahead rate
    e0+X_XFER    start from a transfer (1; :func:`transfer_start`): at k = 0 the integral is
                 e0+X_INTZ, the pending command and opening e0+X_UZ, e0+X_CZ (bumpless
                 position ↔ force switching, :func:`hydropwa.control.press_cycle`)
    e0+X_EST     per-cell Kalman filter on (1) (:func:`cell_kalman_filter`): the law then uses
                 the estimates P̂_L, x̂, v̂ (and ν̂, ν̂̇ of its valve states) instead of the
                 measured P_L, x, ẋ and of the valve model's spool estimate
    e0+X_SPLN    spool filter gains L_ν [1], L_ν̇ [1/s] at e0+X_SPLN, e0+X_SPLD: with
                 the spool measured (e0+X_SPOOL = 1) the valve model's prediction is corrected by
                 the measured spool, a steady-state Kalman filter
                 (:func:`~hydropwa.control.spool_filter_gain`); an exact sensor packs its limit
                 (1, Γ₂/Γ₁) (:attr:`~hydropwa.control.SpoolModel.exact_gain`)
    e0+X_ESTNU   the per-cell Kalman filter measures the spool too (1): y = [P_L, x, ν_m], its
                 spool gain columns (NZ values per row) after the filters' rows
    e0+N_EXT+XROW·r   row r's k_nu [1], k_dnu [s] (c −= k_nu ν̂ + k_dnu ν̂̇) and k_up [1]
                 (c −= k_up · pending command, with the one-sample delay)
    e0+N_EXT+XROW·n+EROW·r   with the Kalman filter: row r's Φ (49, row-major), Γ (7),
                 φ₀ (7), L (14, row-major 7 × 2) and (a_vp, a_pp, f_a, f_p)
                 (:mod:`hydropwa.control._estimator`); with e0+X_ESTNU then NZ values per
                 row, the column L_ν of the spool's innovation

Reference channels ``rch`` (shape (N_RCH, samples), one column per sample): ṙ(t_k) [m/s],
ṙ_ff = ṙ(t_k + τ) [m/s], r̈(t_k) [m/s²], the sensor noise added to the measured x [m],
P_A [Pa] and P_B [Pa] (P_L on the load-state models) at t_k (zeros: exact sensors),
ṙ_o = ṙ(t_k + τ_o) [m/s] of the pre-opening (zeros without it), and the sensor noise added to
the measured spool position [1] (read only where the controller measures the spool).

The law is a sequence of small compiled stages, composed by :func:`law_step` (which
:func:`controller_sample` calls after :func:`measure`; the C export translates the same
functions, :mod:`hydropwa.control._target`). Each stage reads its own slots of the layout
(:mod:`hydropwa._layout_law`) and returns its input unchanged where its slot is 0 (schema 1:
every schema-2 stage off). In the order of one sample (docs/controller_target.md states it
for a target): measure (with the noise), :func:`law_start` and :func:`transfer_start` (k = 0),
:func:`estimate_stage` (per-cell Kalman filter), :func:`observer_stage`, :func:`velocity_stage`,
the error e = r − :func:`output_stage` (the position, the cylinder force or P_L),
:func:`pressure_stage` (Ṗ_L filter, washout), :func:`select_row`, :func:`feedback_command`
(the schema-1 terms), :func:`feedforward_stage` (flow feed-forward, :func:`reference_state`,
the spool terms of :func:`spool_feedback`), :func:`opening_stage` (:func:`quiet_stage` with
its opening delay, the pressure vent and its low-pass; the pre-opening;
:func:`dead_zone_stage`), the saturation, :func:`integral_stage` (its leak and band),
:func:`delay_stage`, :func:`valve_model_stage` (the spool estimate update), :func:`law_log`.

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
from .._layout import SG_VALUE, Y_FULL, Y_LOAD
from .._layout_law import CST, CTL, EROW_SLOT, EXT, LOG_ROW, RCH, ROW_SLOT, XROW_SLOT
from .._layout_law import SIZES as LAW_SIZES
from ..components._physics import load_flow_drop, signed_sqrt
from ._kcommon import carries_spool
from ._signals import NO_REFCOUNT, eval_signal_rate

#: the packed valve-command slot of the signal vector (the layout's one table)
_S_U = SG_VALUE["u"]

_X, _V, _PA, _PB = (Y_FULL[k] for k in ("x", "v", "p_a", "p_b"))
_NU = Y_FULL["spool"]
_LPL, _LV, _LX = (Y_LOAD[k] for k in ("p_l", "v", "x"))
# the model kinds whose state holds the spool (ν, ν̇ and the chambers of the full state: the
# full, full-lines and chamber models) are their registry rows' carries_spool (_kcommon)

#: the law's packed vectors, declared once in the layout layer (hydropwa/_layout_law.py); the
#: index constants below are read from its tables (numba compiles them in as integers)
C_ROWS, ROW, N_EXT, XROW, EROW, NZ = (
    LAW_SIZES[k] for k in ("C_ROWS", "ROW", "N_EXT", "XROW", "EROW", "NZ")
)
N_CST, N_LOG, N_RCH = LAW_SIZES["N_CST"], LAW_SIZES["N_LOG"], LAW_SIZES["N_RCH"]
# fmt: off
(
    C_TS, C_DELAY, C_UMIN, C_UMAX, C_AW, C_KT, C_DZINV, C_DZOFF, C_DZW, C_FILT, C_NROWS, C_WASH,
    C_PLMEAN, C_SCALE,
) = (CTL[k] for k in (
    "ts", "delay", "umin", "umax", "aw", "kt", "dzinv", "dzoff", "dzw", "filt", "nrows", "wash",
    "plmean", "scale",
))
R_LO, R_HI, R_KP, R_KI, R_KFF, R_KV, R_KPL, R_KDPL, R_UFF = (
    ROW_SLOT[k] for k in ("lo", "hi", "kp", "ki", "kff", "kv", "kpl", "kdpl", "uff")
)
AW_NONE, AW_CLAMP, AW_BACK = 0, 1, 2
(
    X_FF, X_K, X_PTR, X_AA, X_ALPHA, X_PS, X_PT, X_DPMIN, X_REFST, X_MASS, X_BV, X_LEAD, X_VEST,
    X_SPOOL, X_PHI, X_GAM, X_KF, X_KFX, X_KFV, X_DZH, X_EST, X_DZQ, X_ILEAK, X_IBAND, X_DZQR,
    X_DZPO, X_SPLN, X_SPLD, X_ESTNU, X_DZPV, X_DZQO, X_OUT, X_FCOMP, X_XFER, X_INTZ, X_UZ, X_CZ,
) = (EXT[k] for k in (
    "ff", "k", "ptr", "aa", "alpha", "ps", "pt", "dpmin", "refst", "mass", "bv", "lead", "vest",
    "spool", "phi", "gam", "kf", "kf_x", "kf_v", "dz_hyst", "est", "dz_quiet", "int_leak",
    "int_band", "dz_quiet_rest", "dz_pre_open", "spool_l_nu", "spool_l_dnu", "est_spool",
    "dz_vent", "dz_quiet_open", "output", "ff_compliance", "transfer", "int0", "u0", "c0",
))
XR_KNU, XR_KDNU, XR_KUP = (XROW_SLOT[k] for k in ("k_nu", "k_dnu", "k_up"))
E_PHI, E_GAM, E_AFF, E_L, E_INIT = (EROW_SLOT[k] for k in ("phi", "gam", "aff", "l", "init"))
RC_DR, RC_DRFF, RC_DDR, RC_NX, RC_NPA, RC_NPB, RC_DRPO, RC_NNU = (
    RCH[k] for k in ("dr", "drff", "ddr", "nx", "npa", "npb", "drpo", "nnu")
)
(
    S_INT, S_PL, S_DPL, S_PEND, S_CPREV, S_ROW, S_PLBAR, S_XPREV, S_VHAT, S_PRBAR, S_NU, S_DNU,
    S_CPEND, S_XKF, S_VKF, S_DZS, S_Z, S_CAPP, S_ZP, S_PDEV, S_DZQN, S_DDR,
) = (CST[k] for k in (
    "int", "pl", "dpl", "pend", "cprev", "row", "plbar", "xprev", "vhat", "prbar", "nu", "dnu",
    "cpend", "xkf", "vkf", "dzs", "z", "capp", "zp", "pdev", "dzqn", "ddr",
))
L_T, L_U, L_R, L_E, L_C, L_ROW, L_INT, L_UNEW, L_UFF = (
    LOG_ROW[k] for k in ("t", "u", "r", "e", "c", "row", "int", "unew", "uff")
)
# fmt: on
SPOOL_OFF, SPOOL_MEASURED, SPOOL_ESTIMATED = 0, 1, 2
#: the controlled output (e0+X_OUT): the position, the cylinder force, the load pressure
OUT_POSITION, OUT_FORCE, OUT_PRESSURE = 0, 1, 2
#: inside the quiet band (e0+X_DZQ) the integral holds while |k_x e| < QUIET_HOLD·q, so a
#: hold's offset stays below about QUIET_HOLD·q/k_x. Measured on the heavy axis's verification
#: task set (4 draws, 20 µm / 0.1 bar, 1 m/s² observer, q = 0.0071): 4 → worst hold 0.113 mm (the
#: integral re-winds and hunts), 8 → 0.067 mm with offsets ≤ 0.10 mm, never released →
#: 0.068 mm but offsets up to 0.57 mm (the integral keeps the load share of the move)
QUIET_HOLD = 8.0
#: "at rest" (the quiet band at rest, e0+X_DZQR, and the pre-opening, e0+X_DZPO): |ṙ(t_k)| and
#: |ṙ_ff| at most REST_RATE [m/s] and |r̈(t_k)| at most REST_ACCELERATION [m/s²], not exactly 0:
#: a real reference generator leaves 1e-12 m/s at rest (rounding, a decaying filter), and the
#: exact test then never engaged the band (paper rig, issue 49: holds of 0.081 mm at 260-780
#: command sign changes/s). 1 µm/s moves the reference 0.5 nm per 0.5 ms sample and 1 µm in a
#: whole second of hold, 1/20 of the default position noise (20 µm), while any move a profile
#: makes is mm/s or faster; 1e-3 m/s² changes the rate by 0.5 nm/s per sample, so an
#: acceleration below it cannot carry the rate past REST_RATE before the next test.
REST_RATE = 1e-6
REST_ACCELERATION = 1e-3
#: pressure vent at rest (e0+X_DZPV): the low-passed pressure share −k_pl p̃ opens the valve
#: inside the quiet band only beyond QUIET_VENT·q, and by at most q. Measured on the paper rig
#: (noise seeds 1-10, T_p = 40 T_s), trapezoid hold / the +6.5 kN step hold's sign changes:
#: 0.5 → up to 125/s on the trapezoid; 0.6 → ≤ 0.029 mm / up to 200/s; 0.7 → 0.031 mm / 132/s;
#: 0.8 → 0.032 mm / ≤ 40/s (8/s without the vent) (docs/control.md)
QUIET_VENT = 0.8


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
def dead_zone_hysteresis(c, offset, width, hyst, side):
    """Dead-zone inverse that changes side only when c leaves the band ±h; returns (u, side).

    The side s (±1) becomes sign(c) where |c| ≥ h and is kept inside the band. On the
    kept side (s·c ≥ 0), and before the first |c| ≥ h (s = 0), u is
    :func:`dead_zone_inverse` with its blend (the orifice opens by c); on the other side
    within the band u = 0, the middle of the dead zone (closed). The spool so crosses the
    dead zone only when c crosses −s·h, and sensor noise on a command near zero leaves
    it on one side instead of throwing it across every few samples.
    """
    s = side
    if c >= hyst:
        s = 1.0
    elif c <= -hyst:
        s = -1.0
    if s == 0.0 or c * s >= 0.0:
        return dead_zone_inverse(c, offset, width), s
    return 0.0, s


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def quiet_acts(ctl, e0, rc):
    """Whether the quiet band (e0+X_DZQ > 0) acts at sample k: always, or with
    e0+X_DZQR = 1 only while the reference is at rest (|ṙ(t_k)|, |ṙ_ff| ≤ ``REST_RATE`` and
    |r̈(t_k)| ≤ ``REST_ACCELERATION``).

    While the reference moves the command is far above the sensor noise's share, and a
    band there only delays the breakaway out of static friction at a profile's start
    (measured on the paper rig's trapezoid, docs/control.md).
    """
    if ctl[e0 + X_DZQR] < 0.5:
        return True
    return (
        abs(rc[RC_DR]) <= REST_RATE
        and abs(rc[RC_DRFF]) <= REST_RATE
        and abs(rc[RC_DDR]) <= REST_ACCELERATION
    )


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def pre_open(c, width, rate_now, rate_ahead):
    """Opening [1] asked for with the pre-opening: at least z_w = ``width`` toward the coming move.

    While the reference is at rest now (|``rate_now``| = |ṙ(t_k)| ≤ ``REST_RATE``) but moves
    τ_o ahead (|``rate_ahead``| = |ṙ(t_k + τ_o)| > ``REST_RATE``), the opening c becomes max(c, z_w) for a coming
    extension (min(c, −z_w) for a retraction): the dead-zone inverse then sends the spool
    to the dead zone's edge, where no flow opens yet, and the valve's lag of crossing the
    dead zone (~4 ms on the paper rig) is spent before the reference starts. Elsewhere c.
    """
    if abs(rate_now) > REST_RATE or abs(rate_ahead) <= REST_RATE:
        return c
    if rate_ahead > 0.0:
        return max(c, width)
    return min(c, -width)


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def quiet_band(c, band, ex):
    """Opening [1] asked for by the command c [1] through the quiet band q = ``band`` [1]; (opening, hold).

    Inside |c| ≤ q the opening is 0 (the spool stays in the middle of the dead zone: no
    flow, so the command's sensor noise moves nothing); for q < |c| < 2q it rises
    linearly, sign(c)·2(|c| − q), to meet the opening c at |c| = 2q; beyond 2q it is c.
    Continuous, so no command jumps the flow. ``hold`` is true where the opening is 0
    and the position error's share of the command |ex| = |k_x e| is below
    ``QUIET_HOLD``·q: the integral then holds its value (an integral that kept running
    inside the band would wind until the valve opens and hunt about the target).
    """
    a = abs(c)
    if a >= 2.0 * band:
        return c, False
    if a <= band:
        return 0.0, abs(ex) < QUIET_HOLD * band
    return (2.0 * (c - band) if c > 0.0 else 2.0 * (c + band)), False


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def quiet_open(c, band, count, samples, far):
    """Command [1] the quiet band q = ``band`` reads with its opening delay n = ``samples``; (c, count).

    ``count``: the signed run of samples before this one beyond the band on one side (+k: the
    last k had c > q, −k: c < −q, 0: the last was within ±q); this sample extends the run on
    its side or starts one. The band opens the valve only on the n-th sample of a run: before,
    it reads c limited to ±q, the band's edge (parked, or the pressure vent's opening); from
    the n-th on c itself, until c returns within ±q or crosses to the other side. n ≤ 1 leaves
    c unchanged (the band as without the delay). The command's sensor noise, correlated over a
    few samples by the position observer, stays beyond q on n samples in a row far more rarely
    than on one, and the valve-aware terms' sign-alternating swings at the dead zone's edge
    never make a run, while a position error beyond the band still opens the valve n − 1
    samples later. ``far``: the position error is beyond the integral band e_I (a step's
    approach or a disturbance, not noise): c unchanged, the run counted all the same (so an
    approach that enters e_I with the valve open keeps it open).
    """
    if c > band:
        count = count + 1.0 if count > 0.0 else 1.0
    elif c < -band:
        count = count - 1.0 if count < 0.0 else -1.0
    else:
        count = 0.0
    if abs(count) < samples and not far:
        return min(max(c, -band), band), count
    return c, count


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def vent_toward_target(share, band, ex):
    """The pressure vent's share [1] with the opening delay: 0 where it would push the rod away
    from the target while the position share |ex| = |k_x e| is beyond the band q = ``band``.

    Such a share (a washout residue after a stick-slip jump past the target) would hold the rod
    outside the band against the correction the delayed band is about to open, and alternate
    with it in sign. Elsewhere ``share`` unchanged.
    """
    if share * ex < 0.0 and abs(ex) > band:
        return 0.0
    return share


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def quiet_vent(share, band):
    """Opening [1] of the low-passed pressure share ``share`` = −k_pl p̃ [1] inside the quiet band q = ``band``.

    sign(s)·(|s| − QUIET_VENT·q) beyond the dead band QUIET_VENT·q, 0 inside, limited to ±q.
    With it the pressure feedback keeps venting the load pressure that a stop left in the
    closed chambers (it would otherwise relax through the friction law's creep, tens of µm on
    the paper rig), while its sensor noise, low-passed and inside the dead band, leaves the
    valve parked.
    """
    w = QUIET_VENT * band
    if share > w:
        return min(share - w, band)
    if share < -w:
        return max(share + w, -band)
    return 0.0


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def pressure_lowpass(ctl, e0, cst, k, p_dev):
    """Update and return the pressure vent's low-pass p̃ [Pa] (cst[S_PDEV]; p̃ = p_dev at k = 0)."""
    ap = ctl[e0 + X_DZPV]
    cst[S_PDEV] = p_dev if k == 0 else ap * cst[S_PDEV] + (1.0 - ap) * p_dev
    return cst[S_PDEV]


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def pressure_vent(c, band, share, ex):
    """The quiet band q = ``band`` with the pressure vent (e0+X_DZPV > 0); returns (opening, hold, leak).

    ``share`` = −k_pl p̃ [1], the low-passed pressure share of the command c. For |c| ≤ q the
    opening is v = :func:`quiet_vent` (share, q) instead of 0; for q < |c| < 2q it is
    sign(c)·2(|c| − q) + (2 − |c|/q) v; from 2q on c (continuous at both edges). ``hold`` as
    in :func:`quiet_band` (``ex`` = k_x e); ``leak``: |c| < 2q, where the integral leaks
    instead of running (the band's ramp included, so a slow correction out of the band does
    not wind it into an overshoot).
    """
    a = abs(c)
    if a >= 2.0 * band:
        return c, False, False
    vent = quiet_vent(share, band)
    if a <= band:
        return vent, abs(ex) < QUIET_HOLD * band, True
    ramp = 2.0 * (c - band) if c > 0.0 else 2.0 * (c + band)
    return ramp + (2.0 - a / band) * vent, False, True


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def load_pressure(p_a, p_b, a_a, a_b, mean_area):
    """Load pressure [Pa] of the design's form from the chamber pressures [Pa] and areas [m²].

    (P_A·A_A − P_B·A_B)/A_A = P_A − α P_B (asymmetric, ``mean_area`` 0), /Ā with the
    paper's mean area Ā = (A_A + A_B)/2 (``mean_area`` 1).
    """
    area = 0.5 * (a_a + a_b) if mean_area != 0.0 else a_a
    return (p_a * a_a - p_b * a_b) / area


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def measure(kind, y, a_a, a_b, mean_area, nx=0.0, npa=0.0, npb=0.0):
    """Measured channels (x [m], ẋ [m/s], P_L [Pa]) from the state of model ``kind``.

    For the full model P_L is the force-equivalent load pressure of the model the
    controller was designed on: (P_A·A_A − P_B·A_B)/A_A = P_A − α P_B for the asymmetric
    reduced/PWA models (``mean_area`` 0), /Ā for the paper's mean-area form (1). Plain
    P_A − P_B differs from it at rest by about P_S(1 − α) on a single-rod cylinder, which
    a state feedback would read as a load. ``nx`` [m], ``npa``, ``npb`` [Pa]: sensor noise
    added to x, P_A and P_B (the load-state models: ``npa`` onto P_L).
    """
    if carries_spool(kind):  # full, full-lines and chamber PWA models (the full state's head)
        return y[_X] + nx, y[_V], load_pressure(y[_PA] + npa, y[_PB] + npb, a_a, a_b, mean_area)
    return y[_LX] + nx, y[_LV], y[_LPL] + npa  # reduced, PWA (LOAD_STATES)


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def output_stage(ctl, n_ctl, x, pl, areas):
    """Stage *controlled output* (e0+X_OUT): the quantity the reference r is for.

    0 (and schema 1): the position x [m]; 1: the cylinder force A_A·P_A − A_B·P_B [N], which is
    P_L times A_A (asymmetric form) or Ā (mean-area form); 2: the load pressure P_L [Pa].
    """
    out = ext_value(ctl, n_ctl, X_OUT)
    if out < 0.5:
        return x
    if out < 1.5:
        area = 0.5 * (areas[0] + areas[1]) if ctl[C_PLMEAN] != 0.0 else areas[0]
        return pl * area
    return pl


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def feedforward_rate(ctl, e0, rate):
    """Piston velocity [m/s] the flow feed-forward passes for the look-ahead rate ``rate``.

    The position law: ``rate`` itself. A force or pressure output (e0+X_OUT > 0): the
    compliance e0+X_FCOMP [m per output unit] times the output reference's rate, for a force
    (1/k_s + 1/k_h)·Ḟ_ref, k_s the specimen's and k_h the oil columns' stiffness [N/m].
    """
    if ctl[e0 + X_OUT] > 0.5:
        return ctl[e0 + X_FCOMP] * rate
    return rate


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def spool_opening(nu, dnu, ctl):
    """Opening-equivalent spool position [1] and rate [1/s] of a measured spool (ν, ν̇).

    The inverse of :func:`dead_zone_inverse` with the controller's offset β_o and width
    z_w: c = ν − β_o sign(ν) for |ν| ≥ z_w + β_o, c = ν z_w/(z_w + β_o) inside (0 with
    z_w = 0); the rate scaled by the local slope. Without the inverse c = ν.
    """
    if ctl[C_DZINV] < 0.5:
        return nu, dnu
    off, w = ctl[C_DZOFF], ctl[C_DZW]
    if abs(nu) >= w + off:
        return (nu - off if nu > 0.0 else nu + off), dnu
    if w <= 0.0:
        return 0.0, 0.0
    g = w / (w + off)
    return nu * g, dnu * g


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def flow_feedforward(ctl, e0, v_ff, pl, mean_area, a_a, a_b):
    """Opening c_ff [1] that passes the flow A_A·v_ff at the load pressure pl, Eqs. (5)/(6) inverted.

    Quasi-steady flow through both metering edges of a single-rod cylinder
    (:func:`~hydropwa.components._physics.load_flow_drop`): Q_A = c K √Δp(sign(c), P_L, P_S)
    = A_A v_ff, so c_ff = A_A v_ff/(K √Δp); P_L the asymmetric load pressure P_A − α P_B
    (converted from the mean-area form if the controller measures that), Δp at least
    ctl[e0 + X_DPMIN] (a load that stalls the axis leaves the feed-forward finite).
    """
    if v_ff == 0.0:
        return 0.0
    pla = pl * (0.5 * (a_a + a_b)) / a_a if mean_area != 0.0 else pl
    s = 1.0 if v_ff > 0.0 else -1.0
    drop = load_flow_drop(s, pla, ctl[e0 + X_PS], ctl[e0 + X_ALPHA], ctl[e0 + X_PT])
    drop = max(drop, ctl[e0 + X_DPMIN])
    return ctl[e0 + X_AA] * v_ff / (ctl[e0 + X_K] * signed_sqrt(drop, ctl[e0 + X_PTR]))


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
def cell_kalman_filter(ctl, cst, eb, k, pl, v0, x, row, sb=-1, nu_m=0.0):
    """Per-cell steady-state Kalman filter; returns the estimates (P̂_L, v̂, x̂) at sample k.

    ``eb``: start of the filters' rows in ``ctl``; ``row``: the gain row of the last sample
    (the cell the plant was in while the valve held cst[S_CAPP]); ``pl`` [Pa], ``x`` [m]: the
    measured channels. Prediction ẑ⁻ = Φ ẑ + Γ c_apply + φ₀, update
    ẑ = ẑ⁻ + L ([P_L, x] − [ẑ⁻₀, ẑ⁻₂]). At k = 0 (``row`` is then the row of the measurement)
    ẑ = [P_L, v0, x, 0, 0, −a_vp P_L − f_a, −a_pp P_L − f_p]: the measured rest is an
    equilibrium of the cell's model. With the spool measured (``sb`` ≥ 0, the start of the
    per-row spool gain columns L_ν, NZ values a row): y = [P_L, x, ν_m], ``nu_m`` the measured
    spool mapped to the opening, the update adds L_ν (ν_m − ẑ⁻₃), and ẑ₃ = ν_m at k = 0.
    """
    b = eb + EROW * row
    if k == 0:
        cst[S_Z] = pl
        cst[S_Z + 1] = v0
        cst[S_Z + 2] = x
        cst[S_Z + 3] = nu_m if sb >= 0 else 0.0
        cst[S_Z + 4] = 0.0
        cst[S_Z + 5] = -ctl[b + E_INIT] * pl - ctl[b + E_INIT + 2]
        cst[S_Z + 6] = -ctl[b + E_INIT + 1] * pl - ctl[b + E_INIT + 3]
        cst[S_CAPP] = 0.0
        return pl, v0, x
    cin = cst[S_CAPP]
    for i in range(NZ):
        acc = ctl[b + E_GAM + i] * cin + ctl[b + E_AFF + i]
        for j in range(NZ):
            acc += ctl[b + E_PHI + NZ * i + j] * cst[S_Z + j]
        cst[S_ZP + i] = acc
    i_p = pl - cst[S_ZP]
    i_x = x - cst[S_ZP + 2]
    for i in range(NZ):
        cst[S_Z + i] = cst[S_ZP + i] + ctl[b + E_L + 2 * i] * i_p + ctl[b + E_L + 2 * i + 1] * i_x
    if sb >= 0:  # the measured spool's innovation
        i_n = nu_m - cst[S_ZP + 3]
        for i in range(NZ):
            cst[S_Z + i] += ctl[sb + NZ * row + i] * i_n
    return cst[S_Z], cst[S_Z + 1], cst[S_Z + 2]


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def ext_start(ctl):
    """Start e0 of the extension block (schema 2) in ``ctl``: after the header and the gain rows."""
    return C_ROWS + ROW * int(ctl[C_NROWS])


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def ext_value(ctl, n_ctl, slot):
    """ctl[e0 + slot] of a schema-2 controller (``n_ctl`` values); 0 (the element off) for schema 1."""
    e0 = ext_start(ctl)
    return ctl[e0 + slot] if n_ctl >= e0 + N_EXT else 0.0


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def spool_feedback(ctl, e0, cst, nu_m, has_spool, kal):
    """Spool position [1] and rate [1/s] (in units of the opening) that the spool terms feed back.

    e0+X_SPOOL = 2 (or a model without a spool state, ``has_spool`` 0): the valve model's
    estimate ν̂, ν̂̇ (the per-cell Kalman filter's ẑ₃, ẑ₄ with ``kal``). e0+X_SPOOL = 1, the
    spool measured: ``nu_m`` [1], the measured spool with its sensor noise, mapped to the
    opening by :func:`spool_opening`, corrects the valve model's prediction ν̂⁻ with the
    filter gain (:func:`~hydropwa.control.spool_filter_gain`; (1, Γ₂/Γ₁) for an exact
    sensor, so ν̂ = ν_m), ν̂ = ν̂⁻ + L_ν (ν_m − ν̂⁻), ν̂̇ = ν̂̇⁻ + L_ν̇ (ν_m − ν̂⁻), in
    cst[S_NU], cst[S_DNU] (the model's update at the end of the sample then predicts the
    next): only the measured position is read, as on a target.
    """
    if kal:
        return cst[S_Z + 3], cst[S_Z + 4]
    nu, dnu = cst[S_NU], cst[S_DNU]
    if ctl[e0 + X_SPOOL] > 1.5 or has_spool < 0.5:
        return nu, dnu
    nu_o, _rate = spool_opening(nu_m, 0.0, ctl)
    inn = nu_o - nu
    cst[S_NU] = nu + ctl[e0 + X_SPLN] * inn
    cst[S_DNU] = dnu + ctl[e0 + X_SPLD] * inn
    return cst[S_NU], cst[S_DNU]


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def law_start(cst, x, pl):
    """Stage *start* (k = 0): the filters' memories start at the measured x [m] and P_L [Pa]."""
    cst[S_PL] = pl
    cst[S_DPL] = 0.0
    cst[S_PLBAR] = pl
    cst[S_XPREV] = x
    cst[S_VHAT] = 0.0
    cst[S_PRBAR] = 0.0
    cst[S_NU] = 0.0
    cst[S_DNU] = 0.0
    cst[S_DZS] = 0.0
    cst[S_DZQN] = 0.0


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def transfer_start(ctl, n_ctl, cst):
    """Stage *transfer* (k = 0, e0+X_XFER = 1): the law takes over from another one without a bump.

    The integral starts at e0+X_INTZ, the pending command and opening (the delay's, the
    saturation memory's) at e0+X_UZ, e0+X_CZ: the other law's last command, so the valve
    command is continuous (the integral chosen so that this law's first command is it).
    """
    if ext_value(ctl, n_ctl, X_XFER) <= 0.5:
        return
    e0 = ext_start(ctl)
    cst[S_INT] = ctl[e0 + X_INTZ]
    cst[S_PEND] = ctl[e0 + X_UZ]
    cst[S_CPEND] = ctl[e0 + X_CZ]
    cst[S_CPREV] = ctl[e0 + X_CZ]


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def estimate_stage(ctl, n_ctl, cst, k, pl, v, x, nu_m, has_spool, rc):
    """Stage *per-cell Kalman filter* (e0+X_EST): the estimates replace (P_L, v, x); returns them.

    The filter of the last sample's row (at k = 0 the row of the measurement); with
    e0+X_ESTNU and a model that has the spool (``has_spool``) it measures ``nu_m`` too.
    """
    if ext_value(ctl, n_ctl, X_EST) <= 0.5:
        return pl, v, x
    nrows = int(ctl[C_NROWS])
    e0 = ext_start(ctl)
    r0 = select_row(ctl, pl, rc[RC_DR], x, 0.0, -1) if k == 0 else int(cst[S_ROW])
    eb = e0 + N_EXT + XROW * nrows
    sb = -1
    nu_o = 0.0
    if ctl[e0 + X_ESTNU] > 0.5 and has_spool > 0.5:  # y = [P_L, x, ν_m]
        sb = eb + EROW * nrows
        nu_o, _rate = spool_opening(nu_m, 0.0, ctl)
    pl, v, x = cell_kalman_filter(ctl, cst, eb, k, pl, rc[RC_DR], x, r0, sb, nu_o)
    return pl, v, x


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def observer_stage(ctl, n_ctl, cst, k, x, v, rc):
    """Stage *position observer* (e0+X_KF): the steady-state Kalman filter's (x̂, v̂) for (x, v).

    Driven by the last sample's reference acceleration (cst[S_DDR]); x̂ = x, v̂ = ṙ at k = 0.
    """
    if ext_value(ctl, n_ctl, X_KF) <= 0.5:
        return x, v
    e0 = ext_start(ctl)
    if k == 0:
        cst[S_XKF] = x
        cst[S_VKF] = rc[RC_DR]
    else:
        ts = ctl[C_TS]
        acc = cst[S_DDR]
        xp = cst[S_XKF] + ts * cst[S_VKF] + 0.5 * ts * ts * acc
        vp = cst[S_VKF] + ts * acc
        inn = x - xp
        cst[S_XKF] = xp + ctl[e0 + X_KFX] * inn
        cst[S_VKF] = vp + ctl[e0 + X_KFV] * inn
    return cst[S_XKF], cst[S_VKF]


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def velocity_stage(ctl, n_ctl, cst, x, v):
    """Stage *velocity filter* (e0+X_VEST = a_v > 0): v̂ from the position samples, else ``v``."""
    av = ext_value(ctl, n_ctl, X_VEST)
    if av <= 0.0:
        return v
    cst[S_VHAT] = av * cst[S_VHAT] + (1.0 - av) * (x - cst[S_XPREV]) / ctl[C_TS]
    cst[S_XPREV] = x
    return cst[S_VHAT]


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def pressure_stage(ctl, cst, pl):
    """Stage *pressure filters*: the filtered Ṗ_L [Pa/s] and the P_L [Pa] the gains act on.

    Ṗ_L: the first-order filter (ctl[C_FILT]) of the backward difference; P_L − P̄_L with the
    washout (ctl[C_WASH] > 0, updates P̄_L), else P_L. Returns (Ṗ_L, P_L fed back).
    """
    a = ctl[C_FILT]
    dpl = a * cst[S_DPL] + (1.0 - a) * (pl - cst[S_PL]) / ctl[C_TS]
    aw = ctl[C_WASH]
    if aw > 0.0:
        cst[S_PLBAR] = aw * cst[S_PLBAR] + (1.0 - aw) * pl
        return dpl, pl - cst[S_PLBAR]
    return dpl, pl


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def feedback_command(ctl, b, e, cst, dr, v, pl_fb, dpl):
    """Stage *schema-1 terms*: c = u_ff + k_p e + k_i I + k_ff ṙ − k_v v − k_pl P_L − k_dpl Ṗ_L [1].

    ``b``: the gain row's start in ``ctl``; ``dr`` = ṙ(t_k) [m/s].
    """
    return (
        ctl[b + R_UFF]
        + ctl[b + R_KP] * e
        + ctl[b + R_KI] * cst[S_INT]
        + ctl[b + R_KFF] * dr
        - ctl[b + R_KV] * v
        - ctl[b + R_KPL] * pl_fb
        - ctl[b + R_KDPL] * dpl
    )


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def reference_state(ctl, e0, b, cst, rc, pl_fb):
    """Stage *reference state* (e0+X_REFST): its share k_v ṙ + k_pl P_ref of c and p_dev.

    P_ref = (m r̈ + b ṙ)/A_A, washed out like P_L (P̄_ref in cst[S_PRBAR]); p_dev =
    ``pl_fb`` − P_ref the deviation the gains k_pl act on. Returns (share [1], p_dev [Pa]).
    """
    dr = rc[RC_DR]
    p_ref = (ctl[e0 + X_MASS] * rc[RC_DDR] + ctl[e0 + X_BV] * dr) / ctl[e0 + X_AA]
    aw = ctl[C_WASH]
    if aw > 0.0:
        cst[S_PRBAR] = aw * cst[S_PRBAR] + (1.0 - aw) * p_ref
        p_ref -= cst[S_PRBAR]
    return ctl[b + R_KV] * dr + ctl[b + R_KPL] * p_ref, pl_fb - p_ref


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def feedforward_stage(ctl, n_ctl, b, row, cst, rc, pl, pl_fb, areas, nu_m, has_spool, kal):
    """Stage *feed-forward* (schema 2): flow feed-forward, reference state and spool terms of c.

    Returns (c_ff [1], p_dev [Pa]): the schema-2 part of the command and the load-pressure
    deviation the pressure vent low-passes (``pl_fb`` without the reference state).
    ``areas`` = (A_A, A_B) [m²] of the measured load pressure's form.
    """
    e0 = ext_start(ctl)
    if n_ctl < e0 + N_EXT:
        return 0.0, pl_fb
    c_fl = 0.0
    if ctl[e0 + X_FF] > 0.5:
        v_ff = feedforward_rate(ctl, e0, rc[RC_DRFF])
        c_fl = flow_feedforward(ctl, e0, v_ff, pl, ctl[C_PLMEAN], areas[0], areas[1])
    c_ff = c_fl
    p_dev = pl_fb
    xb = e0 + N_EXT + XROW * row
    if ctl[e0 + X_REFST] > 0.5:  # the gains act on the deviation from the reference state
        c_ref, p_dev = reference_state(ctl, e0, b, cst, rc, pl_fb)
        c_ff += c_ref
        if ctl[e0 + X_SPOOL] > 0.5:  # the spool and the pending command follow c_fl
            kup = ctl[xb + XR_KUP] if ctl[C_DELAY] > 0.5 else 0.0
            c_ff += (ctl[xb + XR_KNU] + kup) * c_fl
    if ctl[e0 + X_SPOOL] > 0.5:  # spool-state feedback: measured, or the valve model's estimate
        nu, dnu = spool_feedback(ctl, e0, cst, nu_m, has_spool, kal)
        c_ff -= ctl[xb + XR_KNU] * nu + ctl[xb + XR_KDNU] * dnu
        if ctl[C_DELAY] > 0.5:
            c_ff -= ctl[xb + XR_KUP] * cst[S_CPEND]
    return c_ff, p_dev


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def quiet_stage(ctl, e0, cst, k, rc, b, e, c_raw, p_dev):
    """Stage *quiet band* (e0+X_DZQ = q > 0): the opening asked for; returns (c_open, held, leak).

    Where the band acts (:func:`quiet_acts`): its opening delay (:func:`quiet_open`), then
    the pressure vent (:func:`pressure_vent`, the low-pass of ``p_dev`` running every
    sample) or the plain band (:func:`quiet_band`); elsewhere the delay's run restarts.
    """
    q = ctl[e0 + X_DZQ]
    c_open, held, leak = c_raw, False, False
    vented = q > 0.0 and ctl[e0 + X_DZPV] > 0.0
    p_low = pressure_lowpass(ctl, e0, cst, k, p_dev) if vented else 0.0
    if q > 0.0 and quiet_acts(ctl, e0, rc):
        c_band = c_raw
        ex = ctl[b + R_KP] * e
        if ctl[e0 + X_DZQO] > 0.0:  # the band opens only after n samples beyond q
            far = ctl[e0 + X_IBAND] > 0.0 and abs(e) > ctl[e0 + X_IBAND]
            c_band, cst[S_DZQN] = quiet_open(c_raw, q, cst[S_DZQN], ctl[e0 + X_DZQO], far)
        if vented:
            share = -ctl[b + R_KPL] * p_low
            if ctl[e0 + X_DZQO] > 0.0:  # with the delay the vent does not push outward
                share = vent_toward_target(share, q, ex)
            c_open, held, leak = pressure_vent(c_band, q, share, ex)
        else:
            c_open, held = quiet_band(c_band, q, ex)
    else:
        cst[S_DZQN] = 0.0
    return c_open, held, leak


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def dead_zone_stage(ctl, n_ctl, cst, c_open):
    """Stage *dead-zone inverse*: the valve command u [1] for the opening ``c_open`` [1].

    With the hysteresis (e0+X_DZH > 0) :func:`dead_zone_hysteresis` (its side in
    cst[S_DZS]), else :func:`dead_zone_inverse`.
    """
    h = ext_value(ctl, n_ctl, X_DZH)
    if h > 0.0:
        u_raw, cst[S_DZS] = dead_zone_hysteresis(c_open, ctl[C_DZOFF], ctl[C_DZW], h, cst[S_DZS])
        return u_raw
    return dead_zone_inverse(c_open, ctl[C_DZOFF], ctl[C_DZW])


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def opening_stage(ctl, n_ctl, cst, k, rc, b, e, c_raw, p_dev):
    """Stages *quiet band*, *pre-opening* and *dead-zone inverse*: (c_open, u_raw, held, leak).

    Without the dead-zone inverse (ctl[C_DZINV] = 0) the command itself; the quiet band and
    the pre-opening (e0+X_DZPO > 0, :func:`pre_open`) only on a schema-2 controller.
    """
    if ctl[C_DZINV] < 0.5:
        return c_raw, c_raw, False, False
    c_open, held, leak = c_raw, False, False
    e0 = ext_start(ctl)
    if n_ctl >= e0 + N_EXT:
        c_open, held, leak = quiet_stage(ctl, e0, cst, k, rc, b, e, c_raw, p_dev)
        if ctl[e0 + X_DZPO] > 0.0:
            c_open = pre_open(c_open, ctl[C_DZW], rc[RC_DR], rc[RC_DRPO])
    u_raw = dead_zone_stage(ctl, n_ctl, cst, c_open)
    return c_open, u_raw, held, leak


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def clamp_integrates(e, ki, u, u_raw):
    """Clamping anti-windup: integrate unless saturated and e would drive further into the limit."""
    return u == u_raw or (u_raw > u and e * ki < 0.0) or (u_raw < u and e * ki > 0.0)


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def integral_stage(ctl, n_ctl, cst, e, ki, u, u_raw, c_open, c_sat, held, leak):
    """Stage *integral rules*: the update of I (cst[S_INT]) after the saturation.

    Where the valve is parked (the quiet band's opening 0, or the pressure vent's ``leak``)
    it decays by the leak a_l (e0+X_ILEAK > 0); else it holds while ``held``, beyond the
    integral band |e| > e_I (e0+X_IBAND) and with k_i = 0, and otherwise integrates e with
    the anti-windup of ctl[C_AW] (none, clamping, back-calculation with ctl[C_KT]).
    """
    band = ext_value(ctl, n_ctl, X_IBAND)
    far = band > 0.0 and abs(e) > band
    quiet = ext_value(ctl, n_ctl, X_DZQ) > 0.0
    parked = leak or (quiet and c_open == 0.0 and ctl[C_DZINV] > 0.5)
    if parked and ext_value(ctl, n_ctl, X_ILEAK) > 0.0:  # the integral decays toward 0
        cst[S_INT] *= ext_value(ctl, n_ctl, X_ILEAK)
    elif ki != 0.0 and not held and not far:
        aw = int(ctl[C_AW])
        ts = ctl[C_TS]
        if aw == AW_CLAMP:
            if clamp_integrates(e, ki, u, u_raw):
                cst[S_INT] += ts * e
        elif aw == AW_BACK:
            cst[S_INT] += ts * (e + ctl[C_KT] * (c_sat - c_open) / ki)
        else:
            cst[S_INT] += ts * e


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def delay_stage(ctl, cst, u, c_sat):
    """Stage *delay*: the command and opening applied from t_k on; returns (u_apply, c_apply).

    With the one-sample delay (ctl[C_DELAY]) the previous sample's (cst[S_PEND],
    cst[S_CPEND]), which then hold this sample's; else ``u`` and ``c_sat``.
    """
    if ctl[C_DELAY] > 0.5:
        u_apply = cst[S_PEND]
        cst[S_PEND] = u
        c_apply = cst[S_CPEND]
        cst[S_CPEND] = c_sat
        return u_apply, c_apply
    return u, c_sat


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def valve_model_stage(ctl, n_ctl, cst, c_apply):
    """Stage *valve model* (e0+X_SPOOL > 0): [ν̂, ν̂̇]⁺ = Φ [ν̂, ν̂̇] + Γ c_apply (ZOH of Eq. (1))."""
    if ext_value(ctl, n_ctl, X_SPOOL) <= 0.5:
        return
    nu, dnu = cst[S_NU], cst[S_DNU]
    g = ext_start(ctl) + X_GAM
    f = ext_start(ctl) + X_PHI
    cst[S_NU] = ctl[f] * nu + ctl[f + 1] * dnu + ctl[g] * c_apply
    cst[S_DNU] = ctl[f + 2] * nu + ctl[f + 3] * dnu + ctl[g + 1] * c_apply


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def law_log(lg, t, u_apply, r, e, c_raw, row, u, c_ff):
    """Stage *log*: the sample's column of the log (rows ``L_*``; L_INT written before the update)."""
    lg[L_T] = t
    lg[L_U] = u_apply
    lg[L_R] = r
    lg[L_E] = e
    lg[L_C] = c_raw
    lg[L_ROW] = row
    lg[L_UNEW] = u
    lg[L_UFF] = c_ff


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def law_step(k, t, meas, r, ctl, n_ctl, areas, cst, rc, lg):
    """One sample of the control law, composed of its stages; the command [1] applied from t on.

    ``meas`` = (x [m], v [m/s], P_L [Pa], ν_m [1], has_spool): the measured channels with their
    noise (ν_m the measured spool, read where ``has_spool`` is 1); ``r`` [m] the reference;
    ``ctl`` the packed controller of ``n_ctl`` values; ``areas`` (A_A, A_B) [m²]; ``cst`` the
    memory; ``rc`` the reference channels at t (``RC_*``); ``lg`` the sample's log column.
    The C export translates this function and its stages (:mod:`hydropwa.control._target`).
    """
    x, v, pl, nu_m, has_spool = meas[0], meas[1], meas[2], meas[3], meas[4]
    if k == 0:
        law_start(cst, x, pl)
        transfer_start(ctl, n_ctl, cst)
    kal = ext_value(ctl, n_ctl, X_EST) > 0.5
    pl, v, x = estimate_stage(ctl, n_ctl, cst, k, pl, v, x, nu_m, has_spool, rc)
    x, v = observer_stage(ctl, n_ctl, cst, k, x, v, rc)
    v = velocity_stage(ctl, n_ctl, cst, x, v)
    e = r - output_stage(ctl, n_ctl, x, pl, areas)
    dpl, pl_fb = pressure_stage(ctl, cst, pl)
    row = select_row(ctl, pl, v, x, cst[S_CPREV], int(cst[S_ROW]) if k > 0 else -1)
    b = C_ROWS + ROW * row
    c_raw = feedback_command(ctl, b, e, cst, rc[RC_DR], v, pl_fb, dpl)
    c_ff, p_dev = feedforward_stage(
        ctl, n_ctl, b, row, cst, rc, pl, pl_fb, areas, nu_m, has_spool, kal
    )
    if n_ctl >= ext_start(ctl) + N_EXT:
        c_raw += c_ff
    c_open, u_raw, held, leak = opening_stage(ctl, n_ctl, cst, k, rc, b, e, c_raw, p_dev)
    u = min(max(u_raw, ctl[C_UMIN]), ctl[C_UMAX])
    c_sat = c_open - (u_raw - u)  # the inverse has slope 1 where the command saturates
    lg[L_INT] = cst[S_INT]
    integral_stage(ctl, n_ctl, cst, e, ctl[b + R_KI], u, u_raw, c_open, c_sat, held, leak)
    u_apply, c_apply = delay_stage(ctl, cst, u, c_sat)
    valve_model_stage(ctl, n_ctl, cst, c_apply)
    if kal:
        cst[S_CAPP] = c_apply
    cst[S_PL] = pl
    cst[S_DPL] = dpl
    cst[S_CPREV] = c_sat
    cst[S_ROW] = row
    cst[S_DDR] = rc[RC_DDR]
    law_log(lg, t, u_apply, r, e, c_raw, row, u, c_ff)
    return u_apply


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def controller_sample(kind, k, t, y, a_a, a_b, ctl, cst, ref, rch, sg, log):
    """Evaluate the controller at sample k (time t [s], state y) and hold its command in ``sg``.

    ``a_a``, ``a_b``: piston areas [m²] (for the full model's load pressure, :func:`measure`).
    Writes the command applied from t on into the packed valve-command slot sg[_S_U] (a
    constant signal, see :func:`hydropwa.simulation.pack_signals`), updates the memory
    ``cst`` and fills column k of ``log`` (one row per quantity). ``ref[k]``: reference
    position [m] at t; ``rch[:, k]``: the reference channels and sensor noise at t (rows
    ``RC_*``). The law itself is :func:`law_step` on the measured channels.
    """
    rc = rch[:, k]
    x, v, pl = measure(kind, y, a_a, a_b, ctl[C_PLMEAN], rc[RC_NX], rc[RC_NPA], rc[RC_NPB])
    spool = carries_spool(kind)
    meas = (x, v, pl, y[_NU] + rc[RC_NNU] if spool else 0.0, 1.0 if spool else 0.0)
    sg[_S_U] = law_step(k, t, meas, ref[k], ctl, ctl.shape[0], (a_a, a_b), cst, rc, log[:, k])


@njit(cache=True, nogil=True, error_model="numpy")
def eval_rates(sg, i, t):
    """Rate of packed signal ``i`` [unit/s] at every time of the array ``t`` (right derivative)."""
    out = t.copy()
    for k in range(t.shape[0]):
        out[k] = eval_signal_rate(sg, i, t[k])
    return out
