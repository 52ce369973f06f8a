"""Compiled right-hand sides of the three models and the stiff integrator.

Everything here runs in numba ``nopython`` mode: the time-stepping loop never
calls Python. The models are assemblies of :mod:`hydropwa.components`.

Model kinds and states
----------------------
``FULL`` (0), Eqs. (1)–(11): y = [ν, ν̇, P_A, P_B, x, ẋ, P_S, P_acc] (the order of
``hydropwa._layout.FULL_STATES``); P_S is a state only with the pump supply model,
otherwise its rate is zero and P_S(t) is the input signal; P_acc, the gas accumulator on
port A (not in the paper), is constant without one.
``REDUCED`` (1), Eqs. (12)–(15) generalised to the single-rod cylinder: y = [P_L, ẋ, x],
P_L = P_A − α P_B (α = 1 and the mean area in the paper form, p[I_RFORM] = 1; see
docs/reduced_asymmetric.md).
``PWA`` (2), Eqs. (16)–(23): y = [P_L, ẋ, x] with piecewise-affine cells.
``CHAMBER`` (3), the chamber-level PWA model (``pwa-chamber``): the full model's state vector,
PWA cells for the dead zone (over ν), the metering flows of Eqs. (5)–(6) (over each edge's
normalised drop), the chamber capacitances (over x) and friction (over ẋ); P_S is an input.

Parameter slots and output rows come from the one layout table, :mod:`hydropwa._layout`;
:func:`point_derivatives` gives every Python-side consumer (matrices, exports) this
assembly's right-hand side and exact derivatives.

Integrator
----------
Linearly implicit Rosenbrock methods with error control: ROS34PW2 (default), an
L-stable, stiffly accurate Rosenbrock-W method of order 3(2) that may reuse its
Jacobian, and Shampine & Reichelt's ROS2(3) (MATLAB's ``ode23s``). Exact Jacobians
and time derivatives for every model (:func:`jac_full`, :func:`jac_reduced`,
:func:`jac_pwa`; :func:`dfdt_full`, …), finite differences only for a full model with a
gas accumulator; Hermite dense output at the requested sample times.
They cope with the stiffness of the chambers (E/V), the tanh friction and the end
stops at a cost of a few right-hand-side calls per step.

Speed
-----
``integrate`` dispatches to one compiled entry point per model, in which the model
kind (and so the state count) is a compile-time constant; the input signals are one
packed vector (:func:`hydropwa.simulation.pack_signals`); the allocation-free helpers
skip numba's reference counting (``NO_REFCOUNT``); ``error_model="numpy"`` drops the
zero test numba puts before every division (non-finite results are caught per step);
the LU factors keep the reciprocals of their pivots, so the four solves of a step
multiply instead of divide. See docs/architecture_performance.md.
"""

from __future__ import annotations

import math
import os
import time
import warnings
from collections.abc import Callable
from contextlib import contextmanager
from typing import Any

import numpy as np
from numba import njit, types
from numba.core.errors import NumbaIRAssumptionWarning
from numba.extending import overload

from .. import _jitcache  # noqa: F401  (one cache stamp for all compiled modules)
from .._errors import interrupt_cause
from .._layout import (
    CHAMBER_OUTPUT_CHANNELS,
    I_CELLS,
    MODEL_KINDS,
    OUT,
    OUTPUT_CHANNELS,
    PWA_OUTPUT_CHANNELS,
    PWA_SLOT,
    PWA_SLOTS,
    SLOT,
    Y_FULL,
    Y_LOAD,
)
from ..components._physics import (
    accumulator_pressure_rate,
    asymmetric_load_pressure_rate,
    chamber_pressure_difference_slopes,
    chamber_pressure_rates,
    chamber_pressures_from_load,
    dead_zone,
    dead_zone_slope,
    effective_bulk_modulus,
    effective_bulk_modulus_slope,
    end_stop_force,
    end_stop_force_slope,
    hose_flow,
    load_capacitance,
    load_capacitance_slope,
    load_flow,
    load_flow_input_slopes,
    load_flow_slope,
    load_pressure_gain,
    orifice_flow_slopes,
    orifice_flows,
    piston_acceleration,
    pump_supply_rate,
    pump_supply_rate_slope,
    servo_valve_acceleration,
    stribeck_friction,
    stribeck_friction_slope,
    supply_flow,
)
from ._controller import N_CST, N_LOG, controller_sample
from ._signals import NO_REFCOUNT, eval_signal, eval_signal_rate

FULL, REDUCED, PWA, CHAMBER = (MODEL_KINDS[k][0] for k in ("full", "reduced", "pwa", "pwa-chamber"))
_CBRT_1E4 = 1e-4 ** (1.0 / 3.0)
N_STATES = tuple(len(states) for _kind, states, _what in MODEL_KINDS.values())
_N_FULL, _N_LOAD = N_STATES[FULL], N_STATES[REDUCED]
# State indices: generated from the state tables in hydropwa._layout.
Y_NU, Y_DNU, Y_PA, Y_PB, Y_X, Y_V, Y_PS = (
    Y_FULL[k] for k in ("spool", "spool_rate", "p_a", "p_b", "x", "v", "p_s")
)
Y_PACC = Y_FULL["p_acc"]
L_PL, L_V, L_X = (Y_LOAD[k] for k in ("p_l", "v", "x"))

# Packed parameter vector layout: generated from the one table in hydropwa._layout.
I_OMEGA0, I_ZETA, I_ALPHA, I_BETA, I_CREEP, I_OUTER = (
    SLOT[k] for k in ("omega0", "zeta", "alpha", "beta", "creep", "outer")
)
I_K, I_PTR, I_AA, I_AB, I_STROKE, I_VA, I_VB, I_CL = (
    SLOT[k] for k in ("K", "ptr", "aa", "ab", "stroke", "va", "vb", "cl")
)
I_KSTOP, I_CSTOP, I_E, I_PVAP, I_PREL = (SLOT[k] for k in ("kstop", "cstop", "e", "pvap", "prel"))
I_FC, I_FS, I_SIGMA, I_CHI, I_DELTA, I_GAMMA = (
    SLOT[k] for k in ("fc", "fs", "sigma", "chi", "delta", "gamma")
)
I_PT, I_PUMP, I_PSET, I_QMAX, I_DROOP, I_VLINE, I_PRELIEF, I_GRELIEF, I_MASS = (
    SLOT[k] for k in ("pt", "pump", "pset", "qmax", "droop", "vline", "prelief", "grelief", "mass")
)
I_CLOAD = SLOT["cload"]  # viscous damping of the attached load (counter cylinder) [N·s/m]
I_RFORM = SLOT["rform"]  # reduced/PWA form: 0 asymmetric single-rod, 1 paper (mean area)
I_XCAP = SLOT["xcap"]  # PWA: rod position of the chamber capacitances [m]; < 0: the state x
I_ACCV, I_ACCP0, I_ACCN, I_HOSEL, I_HOSED, I_HOSEVOL, I_VISC = (
    SLOT[k] for k in ("accv", "accp0", "accn", "hosel", "hosed", "hosevol", "visc")
)
# PWA section (written by hydropwa.linearization.pack_pwa)
I_SCHED, I_PSFIX, I_FORM, I_NG, I_NO, I_NN, I_NW = (PWA_SLOT[k] for k in PWA_SLOTS)
#: Output rows, named in the layout table.
O_U, O_SPOOL, O_Z, O_P_A, O_P_B, O_P_L, O_P_S, O_F_L, O_X, O_V, O_FRICTION = (
    OUT[k] for k in ("u", "spool", "z", "p_a", "p_b", "p_l", "p_s", "f_l", "x", "v", "friction")
)
#: Number of output rows of the full/reduced models and of the PWA model.
N_OUT, N_OUT_PWA = len(OUTPUT_CHANNELS), len(OUTPUT_CHANNELS) + len(PWA_OUTPUT_CHANNELS)
N_OUT_CHAMBER = len(OUTPUT_CHANNELS) + len(CHAMBER_OUTPUT_CHANNELS)

# Status codes of integrate()
OK, MAX_STEPS, STEP_COLLAPSE, NON_FINITE = 0, 1, 2, 3


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def n_states(kind):
    """Number of states of model ``kind``; a compile-time constant where ``kind`` is (small loops unroll)."""
    return _N_FULL if kind == FULL or kind == CHAMBER else _N_LOAD


# the input channels as int64 values, not literals: a literal argument would compile
# eval_signal once per channel
_CH0, _CH1, _CH2 = np.int64(0), np.int64(1), np.int64(2)


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _inputs(t, sg):
    """Evaluate the three packed input signals u, P_S, F_L at time t.

    Inlined into its callers; constant signals (kind 0, value at sg[16 + 8i]) are read
    here without a call to :func:`eval_signal`.
    """
    u = sg[16] if sg[0] == 0.0 else eval_signal(sg, _CH0, t)
    ps = sg[24] if sg[1] == 0.0 else eval_signal(sg, _CH1, t)
    fl = sg[32] if sg[2] == 0.0 else eval_signal(sg, _CH2, t)
    return u, ps, fl


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _input_rates(t, sg):
    """Time derivatives of the three packed inputs at t (:func:`~hydropwa.simulation.eval_signal_rate`)."""
    du = 0.0 if sg[0] == 0.0 else eval_signal_rate(sg, _CH0, t)
    dps = 0.0 if sg[1] == 0.0 else eval_signal_rate(sg, _CH1, t)
    dfl = 0.0 if sg[2] == 0.0 else eval_signal_rate(sg, _CH2, t)
    return du, dps, dfl


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _friction(v, p):
    return stribeck_friction(v, p[I_FC], p[I_FS], p[I_SIGMA], p[I_CHI], p[I_DELTA], p[I_GAMMA])


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _opening(nu, p):
    return dead_zone(nu, p[I_ALPHA], p[I_BETA], p[I_CREEP], p[I_OUTER])


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _mean_area(p):
    """Ā = (A_A + A_B)/2 [m²] of the reduced and PWA models, Eqs. (14)–(15)."""
    return 0.5 * (p[I_AA] + p[I_AB])


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _load_gain(p):
    """4E/V_t [Pa/m³] of Eq. (14) (:func:`~hydropwa.components.load_pressure_gain`)."""
    return load_pressure_gain(p[I_E], p[I_VA] + p[I_VB])


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def rhs_full(y, u, ps_in, fl, p, dy):
    """Full-order model, Eqs. (1)–(11), with the corrected sign of Q_B (docs/errata.md E1)."""
    nu, dnu, pa, pb, x, v = y[Y_NU], y[Y_DNU], y[Y_PA], y[Y_PB], y[Y_X], y[Y_V]
    pump = p[I_PUMP] > 0.5
    ps = y[Y_PS] if pump else ps_in
    z = _opening(nu, p)
    qa, qb = orifice_flows(z, pa, pb, ps, p[I_PT], p[I_K], p[I_PTR])
    q_acc = 0.0
    if p[I_ACCV] > 0.0:  # gas accumulator on port A, through its hose
        pacc = y[Y_PACC]
        q_acc = hose_flow(pa, pacc, p[I_HOSEL], p[I_HOSED], p[I_VISC])
        dy[Y_PACC] = accumulator_pressure_rate(
            q_acc,
            pacc,
            p[I_ACCV],
            p[I_ACCP0],
            p[I_ACCN],
            p[I_HOSEVOL],
            p[I_E],
            p[I_PVAP],
            p[I_PREL],
        )
    else:
        dy[Y_PACC] = 0.0
    dpa, dpb = chamber_pressure_rates(
        qa - q_acc,
        qb,
        x,
        v,
        pa,
        pb,
        p[I_AA],
        p[I_AB],
        p[I_STROKE],
        p[I_VA],
        p[I_VB],
        p[I_CL],
        p[I_E],
        p[I_PVAP],
        p[I_PREL],
    )
    stop = end_stop_force(x, v, p[I_STROKE], p[I_KSTOP], p[I_CSTOP])
    dy[Y_NU] = dnu
    dy[Y_DNU] = servo_valve_acceleration(nu, dnu, u, p[I_OMEGA0], p[I_ZETA])
    dy[Y_PA] = dpa
    dy[Y_PB] = dpb
    dy[Y_X] = v
    dy[Y_V] = piston_acceleration(
        pa * p[I_AA] - pb * p[I_AB], _friction(v, p), fl + p[I_CLOAD] * v, stop, p[I_MASS]
    )
    if pump:
        dy[Y_PS] = pump_supply_rate(
            ps,
            supply_flow(z, qa, qb),
            p[I_PSET],
            p[I_QMAX],
            p[I_DROOP],
            p[I_VLINE],
            p[I_E],
            p[I_PRELIEF],
            p[I_GRELIEF],
        )
    else:
        dy[Y_PS] = 0.0


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _chamber_row(dq, qx, net_c, p_c, vol, dvol, p, J, row, col_p, col_other):
    """Row ``row`` of ∂f/∂y for one chamber, Eq. (9): Ṗ = E_eff(P, net)/V(x) · net.

    ``dq`` holds ∂Q/∂(its own pressure), ``qx`` ∂net/∂v; the leakage couples the chamber's
    own pressure column ``col_p`` (−C_L) and the other chamber's ``col_other`` (+C_L);
    V(x) changes with x at the rate ``dvol``. Returns E_eff/V (the flow gain of the row).
    """
    e = effective_bulk_modulus(p_c, p[I_E], p[I_PVAP], p[I_PREL], net_c)
    de = effective_bulk_modulus_slope(p_c, p[I_E], p[I_PVAP], p[I_PREL], net_c)
    g = e / vol
    J[row, col_p] = g * (dq - p[I_CL]) + de / vol * net_c
    J[row, col_other] = g * p[I_CL]
    J[row, Y_X] = -e * net_c * dvol / (vol * vol)
    J[row, Y_V] = g * qx
    return g


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def jac_full(y, u, ps_in, fl, p, J):
    """Exact ∂f/∂y of :func:`rhs_full` without an accumulator; False (J untouched) with one.

    Assembled from the component slopes: the servo valve (3) is linear; the orifice flows
    (5)–(6) through :func:`~hydropwa.components.orifice_flow_slopes` and the dead zone's
    :func:`~hydropwa.components.dead_zone_slope`; continuity (9) with the effective bulk
    modulus's pressure slope and the volumes' dependence on x; Newton (10) with the Stribeck
    and end-stop slopes; the pump's supply line when it is a state. At a switching point (z = 0,
    a dead-zone corner, a chamber's cavitation floor) it is the slope of the branch the right-hand
    side takes there. The accumulator's gas law is left to the differences.
    """
    if p[I_ACCV] > 0.0:
        return False
    n = J.shape[0]
    for i in range(n):
        for j in range(n):
            J[i, j] = 0.0
    nu, pa, pb, x, v = y[Y_NU], y[Y_PA], y[Y_PB], y[Y_X], y[Y_V]
    pump = p[I_PUMP] > 0.5
    ps = y[Y_PS] if pump else ps_in
    z = _opening(nu, p)
    dz = dead_zone_slope(nu, p[I_ALPHA], p[I_BETA], p[I_CREEP], p[I_OUTER])
    qa, qb = orifice_flows(z, pa, pb, ps, p[I_PT], p[I_K], p[I_PTR])
    qa_z, qa_pa, qa_ps, qb_z, qb_pb, qb_ps = orifice_flow_slopes(
        z, pa, pb, ps, p[I_PT], p[I_K], p[I_PTR]
    )
    aa, ab, cl = p[I_AA], p[I_AB], p[I_CL]
    w0 = p[I_OMEGA0]
    J[Y_NU, Y_DNU] = 1.0
    J[Y_DNU, Y_NU] = -w0 * w0
    J[Y_DNU, Y_DNU] = -2.0 * p[I_ZETA] * w0
    net_a = qa - aa * v + cl * (pb - pa)
    net_b = -qb + ab * v + cl * (pa - pb)
    va = p[I_VA] + aa * x
    vb = p[I_VB] + ab * (p[I_STROKE] - x)
    ga = _chamber_row(qa_pa, -aa, net_a, pa, va, aa, p, J, Y_PA, Y_PA, Y_PB)
    gb = _chamber_row(-qb_pb, ab, net_b, pb, vb, -ab, p, J, Y_PB, Y_PB, Y_PA)
    J[Y_PA, Y_NU] = ga * qa_z * dz
    J[Y_PB, Y_NU] = -gb * qb_z * dz
    if pump:
        J[Y_PA, Y_PS] = ga * qa_ps
        J[Y_PB, Y_PS] = -gb * qb_ps
        dps_ps, dps_q = pump_supply_rate_slope(
            ps, p[I_VLINE], p[I_E], p[I_QMAX], p[I_PSET], p[I_DROOP], p[I_PRELIEF], p[I_GRELIEF]
        )
        if z >= 0.0:  # the draw is Q_A (supply feeds A)
            J[Y_PS, Y_NU] = dps_q * qa_z * dz
            J[Y_PS, Y_PA] = dps_q * qa_pa
            J[Y_PS, Y_PS] = dps_ps + dps_q * qa_ps
        else:  # the draw is −Q_B (supply feeds B)
            J[Y_PS, Y_NU] = -dps_q * qb_z * dz
            J[Y_PS, Y_PB] = -dps_q * qb_pb
            J[Y_PS, Y_PS] = dps_ps - dps_q * qb_ps
    J[Y_X, Y_V] = 1.0
    inv_m = 1.0 / p[I_MASS]
    kx, kv = end_stop_force_slope(x, v, p[I_STROKE], p[I_KSTOP], p[I_CSTOP])
    ff = stribeck_friction_slope(v, p[I_FC], p[I_FS], p[I_SIGMA], p[I_CHI], p[I_DELTA], p[I_GAMMA])
    J[Y_V, Y_PA] = aa * inv_m
    J[Y_V, Y_PB] = -ab * inv_m
    J[Y_V, Y_X] = kx * inv_m
    J[Y_V, Y_V] = (kv - ff - p[I_CLOAD]) * inv_m
    return True


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def dfdt_full(y, u, ps_in, fl, du, dps, dfl, p, dfdt):
    """Exact ∂f/∂t of :func:`rhs_full` from the inputs' rates (u̇, Ṗ_S, Ḟ_L).

    The command enters the valve (3) only (∂ν̈/∂u = ω0²); the supply pressure, when it is an
    input, the metering flows of the supply edges (5)–(6); the load force Newton's law (10).
    """
    n = dfdt.shape[0]
    for i in range(n):
        dfdt[i] = 0.0
    w0 = p[I_OMEGA0]
    dfdt[Y_DNU] = w0 * w0 * du
    dfdt[Y_V] = -dfl / p[I_MASS]
    if p[I_PUMP] > 0.5 or dps == 0.0:
        return
    nu, pa, pb, x, v = y[Y_NU], y[Y_PA], y[Y_PB], y[Y_X], y[Y_V]
    z = _opening(nu, p)
    qa, qb = orifice_flows(z, pa, pb, ps_in, p[I_PT], p[I_K], p[I_PTR])
    _qa_z, _qa_pa, qa_ps, _qb_z, _qb_pb, qb_ps = orifice_flow_slopes(
        z, pa, pb, ps_in, p[I_PT], p[I_K], p[I_PTR]
    )
    aa, ab, cl, E = p[I_AA], p[I_AB], p[I_CL], p[I_E]
    net_a = qa - aa * v + cl * (pb - pa)
    net_b = -qb + ab * v + cl * (pa - pb)
    va = p[I_VA] + aa * x
    vb = p[I_VB] + ab * (p[I_STROKE] - x)
    dfdt[Y_PA] = effective_bulk_modulus(pa, E, p[I_PVAP], p[I_PREL], net_a) / va * qa_ps * dps
    dfdt[Y_PB] = -effective_bulk_modulus(pb, E, p[I_PVAP], p[I_PREL], net_b) / vb * qb_ps * dps


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _reduced_terms(x, p):
    """Geometry of the load-pressure equation in the packed form (I_RFORM) at rod position x.

    Returns (α_f, P_T, A, c_q, c_l, ∂c_q/∂x, ∂c_l/∂x): the flow ratio and tank pressure of
    the edge drop (:func:`~hydropwa.components.load_flow_drop`), the force and flow area A,
    and the capacitances of :func:`~hydropwa.components.asymmetric_load_pressure_rate`.
    Asymmetric form: α = A_B/A_A, P_T, A_A, c_q, c_l of
    :func:`~hydropwa.components.load_capacitance` at x (the PWA model: at the fixed I_XCAP).
    Paper form, Eqs. (12)–(14): α = 1, P_T = 0, Ā, c_q = c_l = 4E/V_t.
    """
    if p[I_RFORM] != 0.0:
        c = _load_gain(p)
        return 1.0, 0.0, _mean_area(p), c, c, 0.0, 0.0
    fixed = p[I_XCAP] >= 0.0
    xc = p[I_XCAP] if fixed else x
    cq, cl = load_capacitance(xc, p[I_AA], p[I_AB], p[I_STROKE], p[I_VA], p[I_VB], p[I_E])
    dcq, dcl = 0.0, 0.0
    if not fixed:
        dcq, dcl = load_capacitance_slope(
            xc, p[I_AA], p[I_AB], p[I_STROKE], p[I_VA], p[I_VB], p[I_E]
        )
    return p[I_AB] / p[I_AA], p[I_PT], p[I_AA], cq, cl, dcq, dcl


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _load_and_mechanics(ql, ff, y, z, ps, fl, p, dy):
    """Ṗ_L, v̇, ẋ of the reduced and PWA models given the load flow Q_L and friction force.

    Ṗ_L = c_q (Q_L − A ẋ) − c_l C_L (P_A − P_B) (Eq. (14), generalised), v̇ from Eq. (15) with
    the force A·P_L (= A_A P_A − A_B P_B in the asymmetric form), the load F_L + c_load ẋ and
    the end stops.
    """
    pl, v, x = y[0], y[1], y[2]
    al, pt, area, cq, cl, _dcq, _dcl = _reduced_terms(x, p)
    pa, pb = chamber_pressures_from_load(z, pl, ps, al, pt)
    stop = end_stop_force(x, v, p[I_STROKE], p[I_KSTOP], p[I_CSTOP])
    dy[0] = asymmetric_load_pressure_rate(ql, v, pa - pb, area, cq, cl, p[I_CL])
    dy[1] = piston_acceleration(area * pl, ff, fl + p[I_CLOAD] * v, stop, p[I_MASS])
    dy[2] = v


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _load_jacobian(dql, ql, y, z, ps, ff_slope, p, J):
    """Exact ∂f/∂y of :func:`_load_and_mechanics` given ∂Q_L/∂P_L and the friction slope."""
    pl, v, x = y[0], y[1], y[2]
    al, pt, area, cq, cl, dcq, dcl = _reduced_terms(x, p)
    ddp_dpl, _ddp_dps = chamber_pressure_difference_slopes(z, al)
    J[0, 0] = cq * dql - cl * p[I_CL] * ddp_dpl
    J[0, 1] = -cq * area
    J[0, 2] = 0.0
    if dcq != 0.0 or dcl != 0.0:
        pa, pb = chamber_pressures_from_load(z, pl, ps, al, pt)
        J[0, 2] = dcq * (ql - area * v) - dcl * p[I_CL] * (pa - pb)
    _mechanics_jacobian(v, x, area, p, J)
    J[1, 1] -= ff_slope / p[I_MASS]


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _load_input_rates(dq_du, dq_dps, y, z, ps, du, dps, dfl, p, dfdt):
    """Exact ∂f/∂t of :func:`_load_and_mechanics` given ∂Q_L/∂u, ∂Q_L/∂P_S and the input rates."""
    al, _pt, _area, cq, cl, _dcq, _dcl = _reduced_terms(y[2], p)
    _ddp_dpl, ddp_dps = chamber_pressure_difference_slopes(z, al)
    dfdt[0] = cq * (dq_du * du + dq_dps * dps) - cl * p[I_CL] * ddp_dps * dps
    dfdt[1] = -dfl / p[I_MASS]
    dfdt[2] = 0.0


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def rhs_reduced(y, u, ps, fl, p, dy):
    """Reduced model: valve dynamics dropped (ν = u), load pressure P_L = P_A − α P_B.

    Asymmetric form (default): the single-rod load-pressure model (docs/reduced_asymmetric.md), flows
    from both orifice equations (5)–(6) under Q_B = α Q_A; paper form: Eqs. (12)–(15).
    """
    al, pt = (1.0, 0.0) if p[I_RFORM] != 0.0 else (p[I_AB] / p[I_AA], p[I_PT])
    z = _opening(u, p)
    ql = load_flow(z, y[0], ps, p[I_K], p[I_PTR], al, pt)
    _load_and_mechanics(ql, _friction(y[1], p), y, z, ps, fl, p, dy)


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def _cell(p, start, n, xv):
    """Index of the active cell among n cells whose n-1 breakpoints start at p[start]."""
    i = 0
    while i < n - 1 and xv >= p[start + i]:
        i += 1
    return i


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _edge_scale(z, ps, p):
    """Normalising pressure P_e [Pa] of the flow cells and the flow scale √(P_e/(1 + α³)) [√Pa].

    The edge drop of :func:`~hydropwa.components.load_flow_drop` is P_e/(1 + α³)·(1 − p̃),
    p̃ = sign(z) P_L/P_e, with P_e = P_S − α P_T (extension) or α P_S − P_T (retraction):
    one set of normalised cells √(1 − p̃) serves both flow directions. Paper form: P_e = P_S,
    scale √(P_S/2). Also returns ∂P_e/∂P_S.
    """
    if p[I_RFORM] != 0.0:
        return ps, math.sqrt(0.5 * ps), 1.0
    al = p[I_AB] / p[I_AA]
    a3 = 1.0 + al * al * al
    if z >= 0.0:
        pe, dpe = ps - al * p[I_PT], 1.0
    else:
        pe, dpe = al * ps - p[I_PT], al
    return pe, math.sqrt(pe / a3), dpe


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def pwa_cells(pl, v, u, ps_in, p):
    """Active cells (g, o, n, w), opening z, the scheduled P_S and p̃ = sign(z) P_L/P_e of the PWA model."""
    ng, no, nn, nw = int(p[I_NG]), int(p[I_NO]), int(p[I_NN]), int(p[I_NW])
    ps = ps_in if p[I_SCHED] > 0.5 else p[I_PSFIX]
    s_g = np.int64(I_CELLS)  # not a literal: one compiled _cell for all four sections
    g = _cell(p, s_g, ng, u)
    z = p[s_g + ng - 1 + g] * u + p[s_g + 2 * ng - 1 + g]
    s_o = s_g + 3 * ng - 1
    sgn = 1.0 if z >= 0.0 else -1.0
    pe, _root, _dpe = _edge_scale(z, ps, p)
    pn = sgn * pl / pe
    o = _cell(p, s_o, no, pn)
    s_n = s_o + 3 * no - 1
    n = _cell(p, s_n, nn, pn)
    s_w = s_n + 3 * nn - 1
    w = _cell(p, s_w, nw, v)
    return g, o, n, w, z, ps, pn


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _pwa_layout(p):
    """Cell counts (o, n, w) and where the o, n and w sections of the PWA cell table start in p.

    Each section holds n − 1 breakpoints, then n slopes, then n offsets (see ``pack_pwa``).
    """
    ng, no, nn, nw = int(p[I_NG]), int(p[I_NO]), int(p[I_NN]), int(p[I_NW])
    s_o = I_CELLS + 3 * ng - 1
    s_n = s_o + 3 * no - 1
    return no, nn, nw, s_o, s_n, s_n + 3 * nn - 1


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _pwa_flow_coeffs(p, o, n):
    """Slope and offset (k̂_o, d̂_o) of flow cell o and (k̂_n, d̂_n) of flow-pressure cell n."""
    no, nn, _nw, s_o, s_n, _s_w = _pwa_layout(p)
    return (
        p[s_o + no - 1 + o],
        p[s_o + 2 * no - 1 + o],
        p[s_n + nn - 1 + n],
        p[s_n + 2 * nn - 1 + n],
    )


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _pwa_friction_cell(p, w):
    """Slope [N·s/m] and offset [N] of friction cell w (Table V): f = slope·ẋ + offset."""
    _no, _nn, nw, _s_o, _s_n, s_w = _pwa_layout(p)
    return p[s_w + nw - 1 + w], p[s_w + 2 * nw - 1 + w]


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _pwa_load_flow(pl, z, ps, pn, o, n, p):
    """PWA load flow Q_L = z·C_q − c·C_qp·P_L and ∂Q_L/∂P_L inside cells o, n.

    C_q = K√(P_e/(1 + α³))(k̂_o p̃ + d̂_o); C_qp = |z| K/(4√(P_S/2)) (k̂_n p̃ + d̂_n) (paper
    form only, c = 1).
    """
    k_o, d_o, k_n, d_n = _pwa_flow_coeffs(p, o, n)
    pe, root, _dpe = _edge_scale(z, ps, p)
    K = p[I_K]
    dpn = (1.0 if z >= 0.0 else -1.0) / pe  # ∂p̃/∂P_L
    ql = z * (K * root * (k_o * pn + d_o))  # z·C_q
    dql = z * K * root * k_o * dpn
    if p[I_FORM] != 0.0:
        kz = abs(z) * K / (4.0 * root)
        cqp = kz * (k_n * pn + d_n)
        ql -= p[I_FORM] * cqp * pl  # -∂Q_L/∂P_L = C_qp for both signs of z
        dql -= p[I_FORM] * (cqp + pl * kz * k_n * dpn)
    return ql, dql


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def rhs_pwa(y, u, ps_in, fl, p, dy):
    """Linearized piecewise-affine model, Eqs. (16)–(23), cells scheduled on P_S.

    Q_L of :func:`_pwa_load_flow`, friction from cell w, the rest as the reduced model
    (:func:`_load_and_mechanics`) with the capacitances at the fixed position I_XCAP.
    """
    g, o, n, w, z, ps, pn = pwa_cells(y[0], y[1], u, ps_in, p)
    ql, _dql = _pwa_load_flow(y[0], z, ps, pn, o, n, p)
    f_slope, f_offset = _pwa_friction_cell(p, w)
    _load_and_mechanics(ql, f_slope * y[1] + f_offset, y, z, ps, fl, p, dy)


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def _mechanics_jacobian(v, x, area, p, J):
    """Rows ẍ and ẋ of the reduced and PWA Jacobians, apart from ∂ẍ/∂ẋ's friction slope.

    ∂ẍ/∂P_L = A/m, ∂ẍ/∂ẋ = (∂F_stop/∂ẋ − c_load)/m, ∂ẍ/∂x = ∂F_stop/∂x/m (Eqs. (15), (22));
    ẋ = v gives the row [0, 1, 0].
    """
    m = p[I_MASS]
    kx, kv = end_stop_force_slope(x, v, p[I_STROKE], p[I_KSTOP], p[I_CSTOP])
    J[1, 0] = area / m
    J[1, 1] = (kv - p[I_CLOAD]) / m
    J[1, 2] = kx / m
    J[2, 0] = 0.0
    J[2, 1] = 1.0
    J[2, 2] = 0.0


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def jac_reduced(y, u, ps, fl, p, J):
    """Exact Jacobian ∂f/∂y of :func:`rhs_reduced` (same inputs), written into J[:3, :3].

    Row Ṗ_L: [c_q ∂Q_L/∂P_L − c_l C_L ∂(P_A − P_B)/∂P_L, −c_q A, ∂c_q/∂x (Q_L − A ẋ) −
    ∂c_l/∂x C_L (P_A − P_B)]; row ẍ of Eq. (15) with the Stribeck slope df/dẋ.
    """
    al, pt = (1.0, 0.0) if p[I_RFORM] != 0.0 else (p[I_AB] / p[I_AA], p[I_PT])
    z = _opening(u, p)
    pl, v = y[0], y[1]
    ql = load_flow(z, pl, ps, p[I_K], p[I_PTR], al, pt)
    dql = load_flow_slope(z, pl, ps, p[I_K], p[I_PTR], al, pt)
    slope = stribeck_friction_slope(
        v, p[I_FC], p[I_FS], p[I_SIGMA], p[I_CHI], p[I_DELTA], p[I_GAMMA]
    )
    _load_jacobian(dql, ql, y, z, ps, slope, p, J)


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def jac_pwa(y, u, ps_in, fl, p, J):
    """Exact Jacobian ∂f/∂y of :func:`rhs_pwa` inside the active cells (the state matrix A(σ))."""
    g, o, n, w, z, ps, pn = pwa_cells(y[0], y[1], u, ps_in, p)
    ql, dql = _pwa_load_flow(y[0], z, ps, pn, o, n, p)
    _load_jacobian(dql, ql, y, z, ps, _pwa_friction_cell(p, w)[0], p, J)


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def dfdt_reduced(y, u, ps, fl, du, dps, dfl, p, dfdt):
    """Exact ∂f/∂t of :func:`rhs_reduced` given the input rates u̇, Ṗ_S, Ḟ_L, written into dfdt[:3].

    The model depends on time through its inputs only: Ṗ_L through Q_L(z(u), P_S) and the
    recovered P_A − P_B(P_S), ẍ through F_L, so
    ∂f/∂t = [c_q (∂Q_L/∂z · dz/du · u̇ + ∂Q_L/∂P_S · Ṗ_S) − c_l C_L ∂(P_A − P_B)/∂P_S · Ṗ_S, −Ḟ_L/m, 0].
    With (u̇, Ṗ_S, Ḟ_L) = (1, 0, 0) it is the input column ∂f/∂u.
    """
    al, pt = (1.0, 0.0) if p[I_RFORM] != 0.0 else (p[I_AB] / p[I_AA], p[I_PT])
    z = _opening(u, p)
    dq_dz, dq_dps = load_flow_input_slopes(z, y[0], ps, p[I_K], p[I_PTR], al, pt)
    dz_du = dead_zone_slope(u, p[I_ALPHA], p[I_BETA], p[I_CREEP], p[I_OUTER])
    _load_input_rates(dq_dz * dz_du, dq_dps, y, z, ps, du, dps, dfl, p, dfdt)


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def dfdt_pwa(y, u, ps_in, fl, du, dps, dfl, p, dfdt):
    """Exact ∂f/∂t of :func:`rhs_pwa` inside the active cells, given the input rates.

    z = k̂_g u + d̂_g, so ∂Q_L/∂u = k̂_g (C_q − c sign(z) P_L K/(4√(P_S/2)) (k̂_n p̃ + d̂_n));
    with the cells scheduled on P_S, ∂Q_L/∂P_S follows from √(P_e/(1 + α³)) and
    p̃ = sign(z) P_L/P_e. With (u̇, Ṗ_S, Ḟ_L) = (1, 0, 0) it is the input column B(σ).
    """
    pl = y[0]
    g, o, n, w, z, ps, pn = pwa_cells(pl, y[1], u, ps_in, p)
    k_g = p[I_CELLS + int(p[I_NG]) - 1 + g]
    k_o, d_o, k_n, d_n = _pwa_flow_coeffs(p, o, n)
    pe, root, dpe = _edge_scale(z, ps, p)
    K = p[I_K]
    form = p[I_FORM]
    dq_dz = K * root * (k_o * pn + d_o)  # C_q
    if form != 0.0:
        dq_dz -= form * (1.0 if z >= 0.0 else -1.0) * K / (4.0 * root) * (k_n * pn + d_n) * pl
    dq_dps = 0.0
    sched = p[I_SCHED] > 0.5
    if sched:  # P_S(t) enters C_q and C_qp
        d_root = 0.5 * dpe / (root * (pe / (root * root)))  # d√(P_e/(1+α³))/dP_S
        d_pn = -pn / pe * dpe
        dq_dps = z * K * (d_root * (k_o * pn + d_o) + root * k_o * d_pn)
        if form != 0.0:
            d_cqp = (
                abs(z) * K * 0.25 * (-d_root / (root * root) * (k_n * pn + d_n) + k_n * d_pn / root)
            )
            dq_dps -= form * d_cqp * pl
    _load_input_rates(dq_dz * k_g, dq_dps, y, z, ps, du, dps if sched else 0.0, dfl, p, dfdt)


# --- the chamber-level PWA model (kind CHAMBER, model name "pwa-chamber") -----------------
# Packed layout: the base block, the PWA slots (sched, psfix, form = 0, n_g, n_c, n_x, n_w), then
# four cell sections of n − 1 breakpoints, n slopes, n offsets each: dead zone over ν, metering
# flow over the normalised edge drop q = ΔP/P_S (√ of the orifice law), capacitance position over
# x (slopes 0, offsets = the x at which the cell evaluates V_A, V_B), friction over ẋ.


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def _cell_bisect(p, start, n, xv):
    """Index of the active cell among n cells (breakpoints from p[start]), by bisection."""
    lo, hi = 0, n - 1  # the answer lies in [lo, hi]
    while lo < hi:
        mid = (lo + hi) // 2
        if xv >= p[start + mid]:
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _edge_flow(z, drop, ddrop_dps, ps, root, p, s_c, nc):
    """One metering edge of the chamber PWA model: Q = z·K·√P_S·(k_c q + d_c), q = ΔP/P_S.

    The cells approximate :func:`~hydropwa.components.signed_sqrt` of Eqs. (5)–(6) in the
    normalised drop q (signed_sqrt(ΔP, p_tr)/√P_S = signed_sqrt(q, p_tr/P_S)), so P_S(t) scales
    them online. Returns (Q [m³/s], ∂Q/∂z, ∂Q/∂ΔP, ∂Q/∂P_S at fixed chamber pressure, cell c);
    ``ddrop_dps`` is ∂ΔP/∂P_S (1 on the supply edge, 0 on the tank edge).
    """
    q = drop / ps
    c = _cell_bisect(p, s_c, nc, q)
    k = p[s_c + nc - 1 + c]
    d = p[s_c + 2 * nc - 1 + c]
    kr = p[I_K] * root
    r = k * q + d
    dq_dz = kr * r
    dq_ddrop = z * kr * k / ps
    dq_dps = z * p[I_K] * (d * 0.5 + k * (ddrop_dps - 0.5 * q)) / root
    return z * dq_dz, dq_dz, dq_ddrop, dq_dps, c


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _chamber_layout(p):
    """Counts and starts of the chamber model's cell sections: (n_g, n_c, n_x, n_w, s_g, s_c, s_x, s_w)."""
    ng, nc, nx, nw = int(p[I_NG]), int(p[I_NO]), int(p[I_NN]), int(p[I_NW])
    s_g = np.int64(I_CELLS)
    s_c = s_g + 3 * ng - 1
    s_x = s_c + 3 * nc - 1
    return ng, nc, nx, nw, s_g, s_c, s_x, s_x + 3 * nx - 1


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def chamber_terms(y, ps_in, p):
    """Everything the chamber PWA model's rhs, Jacobian and ∂f/∂t share, at state y.

    Returns (z, dz/dν, P_S, Q_A, Q_B, ∂Q_A/∂z, ∂Q_B/∂z, ∂Q_A/∂P_A, ∂Q_B/∂P_B, ∂Q_A/∂P_S,
    ∂Q_B/∂P_S, x_cap, friction slope, friction offset, cells g, a, b, j, w). Flow directions
    as in :func:`~hydropwa.components.orifice_flows`: extension (z ≥ 0) drops P_S − P_A and
    P_B − P_T, retraction P_A − P_T and P_S − P_B; Q_B is the flow out of chamber B.
    """
    ng, nc, nx, nw, s_g, s_c, s_x, s_w = _chamber_layout(p)
    ps = ps_in if p[I_SCHED] > 0.5 else p[I_PSFIX]
    nu, pa, pb, x, v = y[Y_NU], y[Y_PA], y[Y_PB], y[Y_X], y[Y_V]
    g = _cell(p, s_g, ng, nu)
    k_g = p[s_g + ng - 1 + g]
    z = k_g * nu + p[s_g + 2 * ng - 1 + g]
    root = math.sqrt(ps)
    pt = p[I_PT]
    if z >= 0.0:
        qa, qa_z, qa_d, qa_s, ca = _edge_flow(z, ps - pa, 1.0, ps, root, p, s_c, nc)
        qb, qb_z, qb_d, qb_s, cb = _edge_flow(z, pb - pt, 0.0, ps, root, p, s_c, nc)
        qa_pa, qb_pb = -qa_d, qb_d
    else:
        qa, qa_z, qa_d, qa_s, ca = _edge_flow(z, pa - pt, 0.0, ps, root, p, s_c, nc)
        qb, qb_z, qb_d, qb_s, cb = _edge_flow(z, ps - pb, 1.0, ps, root, p, s_c, nc)
        qa_pa, qb_pb = qa_d, -qb_d
    j = _cell_bisect(p, s_x, nx, x)
    xcap = p[s_x + 2 * nx - 1 + j]
    w = _cell_bisect(p, s_w, nw, v)
    return (
        z,
        k_g,
        ps,
        qa,
        qb,
        qa_z,
        qb_z,
        qa_pa,
        qb_pb,
        qa_s,
        qb_s,
        xcap,
        p[s_w + nw - 1 + w],
        p[s_w + 2 * nw - 1 + w],
        g,
        ca,
        cb,
        j,
        w,
    )


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _chamber_capacitances(qa_net, qb, xcap, v, pa, pb, p):
    """E_eff/V_A and E_eff/V_B [Pa/m³] at the capacitance cell's position, as in Eq. (9)."""
    va = p[I_VA] + p[I_AA] * xcap
    vb = p[I_VB] + p[I_AB] * (p[I_STROKE] - xcap)
    net_a = qa_net - p[I_AA] * v + p[I_CL] * (pb - pa)
    net_b = -qb + p[I_AB] * v + p[I_CL] * (pa - pb)
    ea = effective_bulk_modulus(pa, p[I_E], p[I_PVAP], p[I_PREL], net_a)
    eb = effective_bulk_modulus(pb, p[I_E], p[I_PVAP], p[I_PREL], net_b)
    return ea / va, eb / vb


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def rhs_chamber(y, u, ps_in, fl, p, dy):
    """Chamber-level piecewise-affine model: the full model's states, PWA cells (kind CHAMBER).

    The spool (Eq. (3)) and the mechanics (Eq. (10)) as in :func:`rhs_full`; the opening from
    the dead-zone cells over ν (Eq. (16), exact); each metering flow of Eqs. (5)–(6) from the
    flow cells over its normalised pressure drop (scheduled on P_S); the chamber continuity
    Eq. (9) by :func:`~hydropwa.components.chamber_pressure_rates` with V_A, V_B at the
    capacitance cell's position; friction from cell w (Eq. (22)). P_S is the input (no pump
    state); the gas accumulator, where the machine has one, as in the full model.
    """
    (
        z,
        _kg,
        ps,
        qa,
        qb,
        _qaz,
        _qbz,
        _qapa,
        _qbpb,
        _qas,
        _qbs,
        xcap,
        fk,
        fd,
        _g,
        _ca,
        _cb,
        _j,
        _w,
    ) = chamber_terms(y, ps_in, p)
    nu, dnu, pa, pb, x, v = y[Y_NU], y[Y_DNU], y[Y_PA], y[Y_PB], y[Y_X], y[Y_V]
    q_acc = 0.0
    if p[I_ACCV] > 0.0:
        pacc = y[Y_PACC]
        q_acc = hose_flow(pa, pacc, p[I_HOSEL], p[I_HOSED], p[I_VISC])
        dy[Y_PACC] = accumulator_pressure_rate(
            q_acc,
            pacc,
            p[I_ACCV],
            p[I_ACCP0],
            p[I_ACCN],
            p[I_HOSEVOL],
            p[I_E],
            p[I_PVAP],
            p[I_PREL],
        )
    else:
        dy[Y_PACC] = 0.0
    dpa, dpb = chamber_pressure_rates(
        qa - q_acc,
        qb,
        xcap,
        v,
        pa,
        pb,
        p[I_AA],
        p[I_AB],
        p[I_STROKE],
        p[I_VA],
        p[I_VB],
        p[I_CL],
        p[I_E],
        p[I_PVAP],
        p[I_PREL],
    )
    stop = end_stop_force(x, v, p[I_STROKE], p[I_KSTOP], p[I_CSTOP])
    dy[Y_NU] = dnu
    dy[Y_DNU] = servo_valve_acceleration(nu, dnu, u, p[I_OMEGA0], p[I_ZETA])
    dy[Y_PA] = dpa
    dy[Y_PB] = dpb
    dy[Y_X] = v
    dy[Y_V] = piston_acceleration(
        pa * p[I_AA] - pb * p[I_AB], fk * v + fd, fl + p[I_CLOAD] * v, stop, p[I_MASS]
    )
    dy[Y_PS] = 0.0


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def jac_chamber(y, u, ps_in, fl, p, J):
    """Exact Jacobian ∂f/∂y of :func:`rhs_chamber` inside the active cells; False if not filled.

    Exact where both chambers are above the air-release pressure (constant bulk modulus).
    With a gas accumulator it returns False and the integrator takes differences.
    """
    if p[I_ACCV] > 0.0:
        return False
    (
        z,
        kg,
        ps,
        qa,
        qb,
        qaz,
        qbz,
        qapa,
        qbpb,
        _qas,
        _qbs,
        xcap,
        fk,
        _fd,
        _g,
        _ca,
        _cb,
        _j,
        _w,
    ) = chamber_terms(y, ps_in, p)
    pa, pb, x, v = y[Y_PA], y[Y_PB], y[Y_X], y[Y_V]
    ca, cb = _chamber_capacitances(qa, qb, xcap, v, pa, pb, p)
    n = _N_FULL
    for i in range(n):
        for k in range(n):
            J[i, k] = 0.0
    w0 = p[I_OMEGA0]
    J[Y_NU, Y_DNU] = 1.0
    J[Y_DNU, Y_NU] = -w0 * w0
    J[Y_DNU, Y_DNU] = -2.0 * p[I_ZETA] * w0
    cl = p[I_CL]
    J[Y_PA, Y_NU] = ca * qaz * kg
    J[Y_PA, Y_PA] = ca * (qapa - cl)
    J[Y_PA, Y_PB] = ca * cl
    J[Y_PA, Y_V] = -ca * p[I_AA]
    J[Y_PB, Y_NU] = -cb * qbz * kg
    J[Y_PB, Y_PB] = cb * (-qbpb - cl)
    J[Y_PB, Y_PA] = cb * cl
    J[Y_PB, Y_V] = cb * p[I_AB]
    J[Y_X, Y_V] = 1.0
    m = p[I_MASS]
    kx, kv = end_stop_force_slope(x, v, p[I_STROKE], p[I_KSTOP], p[I_CSTOP])
    J[Y_V, Y_PA] = p[I_AA] / m
    J[Y_V, Y_PB] = -p[I_AB] / m
    J[Y_V, Y_X] = kx / m
    J[Y_V, Y_V] = (kv - fk - p[I_CLOAD]) / m
    return True


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def dfdt_chamber(y, u, ps_in, fl, du, dps, dfl, p, dfdt):
    """Exact ∂f/∂t of :func:`rhs_chamber` inside the active cells, given the input rates.

    u enters the spool equation alone (ω0² u̇); P_S(t) the metering flows through the
    scheduled cells (zero when the cells are fixed); F_L the piston (−Ḟ_L/m). With
    (u̇, Ṗ_S, Ḟ_L) = (1, 0, 0) it is the input column B.
    """
    (
        _z,
        _kg,
        ps,
        qa,
        qb,
        _qaz,
        _qbz,
        _qapa,
        _qbpb,
        qas,
        qbs,
        xcap,
        _fk,
        _fd,
        _g,
        _ca,
        _cb,
        _j,
        _w,
    ) = chamber_terms(y, ps_in, p)
    for i in range(_N_FULL):
        dfdt[i] = 0.0
    ca, cb = _chamber_capacitances(qa, qb, xcap, y[Y_V], y[Y_PA], y[Y_PB], p)
    w0 = p[I_OMEGA0]
    dfdt[Y_DNU] = w0 * w0 * du
    if p[I_SCHED] > 0.5:
        dfdt[Y_PA] = ca * qas * dps
        dfdt[Y_PB] = -cb * qbs * dps
    dfdt[Y_V] = -dfl / p[I_MASS]


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def rhs_at(kind, y, u, ps, fl, p, dy):
    """Right-hand side of model ``kind`` with the inputs u, P_S, F_L already evaluated."""
    if kind == FULL:
        rhs_full(y, u, ps, fl, p, dy)
    elif kind == REDUCED:
        rhs_reduced(y, u, ps, fl, p, dy)
    elif kind == PWA:
        rhs_pwa(y, u, ps, fl, p, dy)
    else:
        rhs_chamber(y, u, ps, fl, p, dy)


def _literal_kind(kind):
    """The value of a literal integer type (a model kind or a method), or None if not literal."""
    return kind.literal_value if isinstance(kind, types.IntegerLiteral) else None


def _rhs_for(kind, y, u, ps, fl, p, dy):
    """:func:`rhs_at` resolved at compile time; callable from compiled code only.

    Inside the integrator the model kind is a literal (one entry point per model). numba
    inlines ``inline="always"`` functions before it types them, so the branches of an
    inlined :func:`rhs_at` on ``kind`` survive and all three right-hand sides (with their
    Jacobians) would be typed and compiled into every model's kernel. This overload picks
    the model's own right-hand side while typing, so each kernel compiles only its model.
    """


# The reduced and PWA right-hand sides are inlined into their kernels through the _rhs_for
# overload. Called through the two wrappers below instead, they compile faster (PWA 16.8 against
# 24.7 CPU-s, reduced 13.7 against 14.6 s, measured on the mean-area models) but the asymmetric
# models then run at 3.2 / 4.3 ms per 10 s of the paper rig instead of 3.0 / 3.3 ms (3300x and
# 3000x real time, the speed the asymmetric model had to keep): the warm speed won. The
# wrappers stay for a build that prefers a fast first run: return them from _ol_rhs_for.
@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def _rhs_reduced_call(y, u, ps, fl, p, dy):
    rhs_reduced(y, u, ps, fl, p, dy)


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def _rhs_pwa_call(y, u, ps, fl, p, dy):
    rhs_pwa(y, u, ps, fl, p, dy)


@overload(_rhs_for, prefer_literal=True)
def _ol_rhs_for(kind, y, u, ps, fl, p, dy):
    k = _literal_kind(kind)
    if k == FULL:
        return lambda kind, y, u, ps, fl, p, dy: rhs_full(y, u, ps, fl, p, dy)
    if k == REDUCED:
        return lambda kind, y, u, ps, fl, p, dy: rhs_reduced(y, u, ps, fl, p, dy)
    if k == PWA:
        return lambda kind, y, u, ps, fl, p, dy: rhs_pwa(y, u, ps, fl, p, dy)
    if k == CHAMBER:
        return lambda kind, y, u, ps, fl, p, dy: rhs_chamber(y, u, ps, fl, p, dy)
    return lambda kind, y, u, ps, fl, p, dy: rhs_at(kind, y, u, ps, fl, p, dy)


def _rhs_fd(kind, y, u, ps, fl, p, dy):
    """The right-hand side for the finite-difference Jacobian; compiled code only.

    The full model's Jacobian is always by differences: its right-hand side is called as in
    :func:`_rhs_for`. The reduced and PWA models have exact Jacobians, so differences serve
    only ``exact_jac=False`` (comparisons): there the right-hand side is called through a
    wrapper instead of inlined, which keeps two more copies of it out of their kernels
    (compile time) without costing the default path anything.
    """


@overload(_rhs_fd, prefer_literal=True)
def _ol_rhs_fd(kind, y, u, ps, fl, p, dy):
    k = _literal_kind(kind)
    if k == REDUCED:
        return lambda kind, y, u, ps, fl, p, dy: _rhs_reduced_call(y, u, ps, fl, p, dy)
    if k == PWA:
        return lambda kind, y, u, ps, fl, p, dy: _rhs_pwa_call(y, u, ps, fl, p, dy)
    return lambda kind, y, u, ps, fl, p, dy: _rhs_for(kind, y, u, ps, fl, p, dy)


def _exact_derivatives(kind, t, y, u, ps, fl, p, sg, J, dfdt):
    """Exact ∂f/∂y into J and ∂f/∂t into dfdt where model ``kind`` has them; True if filled.

    Compiled code only; resolved at compile time like :func:`_rhs_for`, so the full
    model's kernel holds no reduced or PWA Jacobian.
    """


def _exact_reduced(kind, t, y, u, ps, fl, p, sg, J, dfdt):
    jac_reduced(y, u, ps, fl, p, J)
    du, dps, dfl = _input_rates(t, sg)
    dfdt_reduced(y, u, ps, fl, du, dps, dfl, p, dfdt)
    return True


def _exact_pwa(kind, t, y, u, ps, fl, p, sg, J, dfdt):
    jac_pwa(y, u, ps, fl, p, J)
    du, dps, dfl = _input_rates(t, sg)
    dfdt_pwa(y, u, ps, fl, du, dps, dfl, p, dfdt)
    return True


def _exact_full(kind, t, y, u, ps, fl, p, sg, J, dfdt):
    if not jac_full(y, u, ps, fl, p, J):
        return False
    du, dps, dfl = _input_rates(t, sg)
    dfdt_full(y, u, ps, fl, du, dps, dfl, p, dfdt)
    return True


def _exact_chamber(kind, t, y, u, ps, fl, p, sg, J, dfdt):
    if not jac_chamber(y, u, ps, fl, p, J):
        return False
    du, dps, dfl = _input_rates(t, sg)
    dfdt_chamber(y, u, ps, fl, du, dps, dfl, p, dfdt)
    return True


def _exact_any(kind, t, y, u, ps, fl, p, sg, J, dfdt):
    if kind == FULL:
        if not jac_full(y, u, ps, fl, p, J):
            return False
        du, dps, dfl = _input_rates(t, sg)
        dfdt_full(y, u, ps, fl, du, dps, dfl, p, dfdt)
        return True
    if kind == REDUCED:
        jac_reduced(y, u, ps, fl, p, J)
        du, dps, dfl = _input_rates(t, sg)
        dfdt_reduced(y, u, ps, fl, du, dps, dfl, p, dfdt)
        return True
    if kind == PWA:
        jac_pwa(y, u, ps, fl, p, J)
        du, dps, dfl = _input_rates(t, sg)
        dfdt_pwa(y, u, ps, fl, du, dps, dfl, p, dfdt)
        return True
    if kind == CHAMBER:
        if not jac_chamber(y, u, ps, fl, p, J):
            return False
        du, dps, dfl = _input_rates(t, sg)
        dfdt_chamber(y, u, ps, fl, du, dps, dfl, p, dfdt)
        return True
    return False


@overload(_exact_derivatives, prefer_literal=True)
def _ol_exact_derivatives(kind, t, y, u, ps, fl, p, sg, J, dfdt):
    k = _literal_kind(kind)
    if k == FULL:
        return _exact_full
    if k == REDUCED:
        return _exact_reduced
    if k == PWA:
        return _exact_pwa
    if k == CHAMBER:
        return _exact_chamber
    return _exact_any


@njit(cache=True, nogil=True, error_model="numpy")
def pwa_load_flow_at(pl, u, ps_in, p):
    """PWA load flow Q_L [m³/s] at P_L [Pa], command u [1] and P_S [Pa] (:func:`_pwa_load_flow`)."""
    g, o, n, w, z, ps, pn = pwa_cells(pl, 0.0, u, ps_in, p)
    return _pwa_load_flow(pl, z, ps, pn, o, n, p)[0]


@njit(cache=True, nogil=True, error_model="numpy")
def _point_reduced(y, u, ps, fl, p, f, J, G):
    """f, ∂f/∂y and ∂f/∂(u, P_S, F_L) of the reduced model at one point (into f, J, G)."""
    rhs_reduced(y, u, ps, fl, p, f)
    jac_reduced(y, u, ps, fl, p, J)
    dfdt_reduced(y, u, ps, fl, 1.0, 0.0, 0.0, p, G[:, 0])
    dfdt_reduced(y, u, ps, fl, 0.0, 1.0, 0.0, p, G[:, 1])
    dfdt_reduced(y, u, ps, fl, 0.0, 0.0, 1.0, p, G[:, 2])


@njit(cache=True, nogil=True, error_model="numpy")
def _point_pwa(y, u, ps, fl, p, f, J, G):
    """f, ∂f/∂y and ∂f/∂(u, P_S, F_L) of the PWA model at one point (into f, J, G)."""
    rhs_pwa(y, u, ps, fl, p, f)
    jac_pwa(y, u, ps, fl, p, J)
    dfdt_pwa(y, u, ps, fl, 1.0, 0.0, 0.0, p, G[:, 0])
    dfdt_pwa(y, u, ps, fl, 0.0, 1.0, 0.0, p, G[:, 1])
    dfdt_pwa(y, u, ps, fl, 0.0, 0.0, 1.0, p, G[:, 2])


@njit(cache=True, nogil=True, error_model="numpy")
def _point_chamber(y, u, ps, fl, p, f, J, G):
    """f, ∂f/∂y and ∂f/∂(u, P_S, F_L) of the chamber PWA model at one point (into f, J, G).

    Without an exact Jacobian (a gas accumulator) J is by central differences.
    """
    rhs_chamber(y, u, ps, fl, p, f)
    if not jac_chamber(y, u, ps, fl, p, J):
        n = y.shape[0]
        yp, ym, fp, fm = y.copy(), y.copy(), np.empty(n), np.empty(n)
        for j in range(n):
            d = 1e-6 * max(abs(y[j]), 1e-3 if j == Y_X else 1.0)
            yp[j] = y[j] + d
            ym[j] = y[j] - d
            rhs_chamber(yp, u, ps, fl, p, fp)
            rhs_chamber(ym, u, ps, fl, p, fm)
            for i in range(n):
                J[i, j] = (fp[i] - fm[i]) / (2.0 * d)
            yp[j] = y[j]
            ym[j] = y[j]
    dfdt_chamber(y, u, ps, fl, 1.0, 0.0, 0.0, p, G[:, 0])
    dfdt_chamber(y, u, ps, fl, 0.0, 1.0, 0.0, p, G[:, 1])
    dfdt_chamber(y, u, ps, fl, 0.0, 0.0, 1.0, p, G[:, 2])


#: One point-derivative kernel per model: a command compiles only the one it uses.
_POINT = {REDUCED: _point_reduced, PWA: _point_pwa, CHAMBER: _point_chamber}


def point_derivatives(kind, y, u, ps, fl, p):
    """Right-hand side and exact derivatives of the reduced, PWA or chamber PWA model at one point.

    The one assembly used by every Python-side consumer (matrices, exports, identification
    helpers): nothing outside this kernel re-derives the reduced or PWA dynamics.

    Parameters
    ----------
    kind : {REDUCED, PWA, CHAMBER}
    y : array_like, shape (n,)
        State: [P_L (Pa), v (m/s), x (m)] (reduced, PWA) or the full model's eight states
        (chamber PWA, ``hydropwa._layout.FULL_STATES``).
    u, ps, fl : float
        Valve command [1], supply pressure [Pa], load force [N].
    p : ndarray
        Packed parameters (``model.pack()``).

    Returns
    -------
    f : ndarray, shape (n,)
        The state rates.
    J : ndarray, shape (n, n)
        ∂f/∂y (exact; inside the active cells for the PWA models).
    G : ndarray, shape (n, 3)
        ∂f/∂(u, P_S, F_L) (columns); G[:, 0] is the input matrix B.
    """
    if int(kind) not in _POINT:
        raise ValueError("point_derivatives serves the reduced and the PWA models")
    point = _POINT[int(kind)]
    args = _point_args(y, u, ps, fl, p)
    prepare(point, args, "linearization")
    point(*args)
    f, J, G = args[-3:]
    return f, J, np.ascontiguousarray(G)


@njit(cache=True, nogil=True, error_model="numpy")
def rhs(kind, t, y, p, sg, dy):
    """Right-hand side of model ``kind`` at time t (inputs evaluated from the packed signals)."""
    u, ps, fl = _inputs(t, sg)
    rhs_at(kind, y, u, ps, fl, p, dy)


@njit(
    cache=True,
    nogil=True,
    error_model="numpy",
    fastmath={"contract", "arcp", "nsz"},
    inline="always",
    **NO_REFCOUNT,
)
def _lu(a, piv, n):
    """In-place LU factorisation with partial pivoting of the leading n×n block of ``a``."""
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
        a[k, k] = inv  # the diagonal of U is stored inverted: _solve multiplies
        for i in range(k + 1, n):
            a[i, k] *= inv
            f = a[i, k]
            if f != 0.0:
                for j in range(k + 1, n):
                    a[i, j] -= f * a[k, j]


@njit(
    cache=True,
    nogil=True,
    error_model="numpy",
    fastmath={"contract", "arcp", "nsz"},
    inline="always",
    **NO_REFCOUNT,
)
def _solve(a, piv, B, r, n):
    """Solve LU x = B[r] in place (row r of B overwritten with x; no array views in the hot loop)."""
    for k in range(n):
        m = piv[k]
        if m != k:
            tmp = B[r, k]
            B[r, k] = B[r, m]
            B[r, m] = tmp
    for i in range(1, n):
        s = B[r, i]
        for j in range(i):
            s -= a[i, j] * B[r, j]
        B[r, i] = s
    for i in range(n - 1, -1, -1):
        s = B[r, i]
        for j in range(i + 1, n):
            s -= a[i, j] * B[r, j]
        B[r, i] = s * a[i, i]


# --- Rosenbrock tableaus -----------------------------------------------------
# Solvers of integrate(): ROS23 is Shampine & Reichelt's ROS2(3) (MATLAB's ode23s);
# ROS34PW2 is the L-stable, stiffly accurate Rosenbrock-W method of order 3 with
# an embedded order-2 estimate (Rang & Angermann 2005). Being a W-method it keeps
# its order with an approximate Jacobian, which is why a Jacobian may be reused.
ROS23, ROS34PW2 = 0, 1
SOLVERS = {"ros23": ROS23, "ros34pw2": ROS34PW2}


def _transformed_tableau(alpha, gamma, b, b_hat):
    """Coefficients of the form (I − hγJ) U_i = hγ (f(t + α_i h, y + Σ A_ij U_j) + Σ C_ij U_j / h + γ_i h f_t).

    With U = Γ K (Hairer & Wanner, Sect. IV.7): A = αΓ⁻¹, C = −Γ⁻¹ (strictly lower
    part), m = bΓ⁻¹ for the solution and e = (b − b̂)Γ⁻¹ for the error estimate.
    """
    g_inv = np.linalg.inv(gamma)
    a_t = alpha @ g_inv
    c_t = -np.tril(g_inv, -1)
    return (
        tuple(float(v) for v in a_t.ravel()),
        tuple(float(v) for v in c_t.ravel()),
        tuple(float(v) for v in alpha.sum(axis=1)),
        tuple(float(v) for v in gamma.sum(axis=1)),
        tuple(float(v) for v in b @ g_inv),
        tuple(float(v) for v in (b - b_hat) @ g_inv),
    )


_G = 4.3586652150845900e-01
_PW2 = _transformed_tableau(
    np.array(
        [
            [0.0, 0.0, 0.0, 0.0],
            [8.7173304301691801e-01, 0.0, 0.0, 0.0],
            [8.4457060015369423e-01, -1.1299064236484185e-01, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
        ]
    ),
    np.array(
        [
            [_G, 0.0, 0.0, 0.0],
            [-8.7173304301691801e-01, _G, 0.0, 0.0],
            [-9.0338057013044082e-01, 5.4180672388095326e-02, _G, 0.0],
            [2.4212380706095346e-01, -1.2232505839045147e00, 5.4526025533510214e-01, _G],
        ]
    ),
    np.array([2.4212380706095346e-01, -1.2232505839045147e00, 1.5452602553351020e00, _G]),
    np.array([3.7810903145819369e-01, -9.6042292212423178e-02, 0.5, 2.1793326075422950e-01]),
)
PW2_A, PW2_C, PW2_ALPHA, PW2_GSUM, PW2_M, PW2_E = (np.array(v) for v in _PW2)
PW2_GAMMA = _G
_D23 = 1.0 / (2.0 + math.sqrt(2.0))
_E32 = 6.0 + math.sqrt(2.0)


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _inert_column(kind, j, p):
    """Full and chamber models: state j is constant for these parameters (zero Jacobian column)."""
    if j == Y_PS:  # P_S is an input without the pump model (always in the chamber model)
        return kind == CHAMBER or p[I_PUMP] <= 0.5
    return j == Y_PACC and p[I_ACCV] <= 0.0  # no accumulator


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def _jacobian(kind, t, y, f0, u, ps, fl, p, sg, scale, J, dfdt, yt, ft, exact):
    """Jacobian ∂f/∂y and time derivative ∂f/∂t at (t, y); returns rhs calls.

    Both are exact for the reduced and PWA models when ``exact`` (:func:`jac_reduced`,
    :func:`jac_pwa`; :func:`dfdt_reduced`, :func:`dfdt_pwa` with the inputs' rates), so
    a refresh costs no right-hand side. Otherwise ∂f/∂y is by forward differences with
    the inputs evaluated once for the n state columns (columns known to vanish, P_S of
    the full model without the pump, are skipped) and ∂f/∂t a forward difference,
    skipped when every input is constant.
    """
    n = n_states(kind)
    sqrt_eps = 1.4901161193847656e-08
    nfev = 0
    if exact and _exact_derivatives(kind, t, y, u, ps, fl, p, sg, J, dfdt):
        return 0
    for j in range(n):
        if (kind == FULL or kind == CHAMBER) and _inert_column(kind, j, p):
            for i in range(n):
                J[i, j] = 0.0
            continue
        nfev += 1
        for i in range(n):
            yt[i] = y[i]
        dj = sqrt_eps * max(abs(y[j]), scale[j])
        yt[j] = y[j] + dj
        _rhs_fd(kind, yt, u, ps, fl, p, ft)
        for i in range(n):
            J[i, j] = (ft[i] - f0[i]) / dj
    if sg[0] == 0.0 and sg[1] == 0.0 and sg[2] == 0.0:  # all inputs constant
        for i in range(n):
            dfdt[i] = 0.0
    else:
        dt = sqrt_eps * max(abs(t), 1e-3)
        u2, ps2, fl2 = _inputs(t + dt, sg)
        _rhs_fd(kind, y, u2, ps2, fl2, p, ft)
        for i in range(n):
            dfdt[i] = (ft[i] - f0[i]) / dt
        nfev += 1
    return nfev


@njit(
    cache=True,
    nogil=True,
    error_model="numpy",
    fastmath={"contract", "arcp", "nsz"},
    inline="always",
    **NO_REFCOUNT,
)
def _factor(kind, J, W, piv, hg):
    """W = I − hγ J, LU-factorised in place."""
    n = n_states(kind)
    for i in range(n):
        for j in range(n):
            W[i, j] = -hg * J[i, j]
        W[i, i] += 1.0
    _lu(W, piv, n)


@njit(
    cache=True,
    nogil=True,
    error_model="numpy",
    fastmath={"contract", "arcp", "nsz"},
    **NO_REFCOUNT,
)
def _step_ros34pw2(kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg):
    """One ROS34PW2 step from (t, y): fills ynew and the error yerr.

    Returns (rhs calls, u, P_S, F_L at t + h). f(t + h, ynew) is left to the caller, which
    evaluates it only for an accepted step (``fnew`` is untouched here).
    """
    n = n_states(kind)
    hg = h * PW2_GAMMA
    # defined before the loop: a variable numba sees as possibly undefined cannot be
    # inlined through an overload (_step_for)
    u = ps = fl = 0.0
    for i in range(4):
        if i == 0:
            for k in range(n):
                ft[k] = f0[k]
        else:
            for k in range(n):
                s = y[k]
                for j in range(i):
                    s += PW2_A[4 * i + j] * U[j, k]
                yt[k] = s
            u, ps, fl = _inputs(t + PW2_ALPHA[i] * h, sg)  # α_4 = 1: reused for f(t + h)
            _rhs_for(kind, yt, u, ps, fl, p, ft)
        for k in range(n):
            s = ft[k] + PW2_GSUM[i] * h * dfdt[k]
            for j in range(i):
                s += PW2_C[4 * i + j] / h * U[j, k]
            U[i, k] = hg * s
        _solve(W, piv, U, i, n)
    for k in range(n):
        s = y[k]
        e = 0.0
        for j in range(4):
            s += PW2_M[j] * U[j, k]
            e += PW2_E[j] * U[j, k]
        ynew[k] = s
        yerr[k] = e
    return 3, u, ps, fl


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def _step_ros23(kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg):
    """One ROS2(3) step (ode23s) from (t, y); W must hold I − h d J with d = 1/(2 + √2).

    Fills ynew, fnew = f(t + h, ynew) (its error estimate needs it) and yerr; returns
    (rhs calls, u, P_S, F_L at t + h) like :func:`_step_ros34pw2`.
    """
    n = n_states(kind)
    hd = h * _D23
    for i in range(n):
        U[0, i] = f0[i] + hd * dfdt[i]
    _solve(W, piv, U, 0, n)
    for i in range(n):
        yt[i] = y[i] + 0.5 * h * U[0, i]
    u, ps, fl = _inputs(t + 0.5 * h, sg)
    _rhs_for(kind, yt, u, ps, fl, p, ft)
    for i in range(n):
        U[1, i] = ft[i] - U[0, i]
    _solve(W, piv, U, 1, n)
    for i in range(n):
        U[1, i] += U[0, i]
        ynew[i] = y[i] + h * U[1, i]
    u, ps, fl = _inputs(t + h, sg)
    _rhs_for(kind, ynew, u, ps, fl, p, fnew)
    for i in range(n):
        U[2, i] = fnew[i] - _E32 * (U[1, i] - ft[i]) - 2.0 * (U[0, i] - f0[i]) + hd * dfdt[i]
    _solve(W, piv, U, 2, n)
    for i in range(n):
        yerr[i] = h / 6.0 * (U[0, i] - 2.0 * U[1, i] + U[2, i])
    return 2, u, ps, fl


def _step_for(method, kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg):
    """One step of ``method`` (:func:`_step_ros34pw2` or :func:`_step_ros23`), chosen while typing.

    Compiled code only. With a literal ``method`` (one entry point per model and method)
    the kernel holds only the stepper it uses; otherwise both, chosen at run time.
    """


def _step_with_ros34pw2(
    method, kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg
):
    return _step_ros34pw2(kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg)


def _step_with_ros23(method, kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg):
    return _step_ros23(kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg)


def _step_with_either(method, kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg):
    if method == ROS34PW2:
        return _step_ros34pw2(kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg)
    return _step_ros23(kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg)


@overload(_step_for, prefer_literal=True)
def _ol_step_for(method, kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg):
    m = _literal_kind(method)
    if m == ROS34PW2:
        return _step_with_ros34pw2
    if m == ROS23:
        return _step_with_ros23
    return _step_with_either


@njit(
    cache=True,
    nogil=True,
    error_model="numpy",
    fastmath={"contract", "arcp", "nsz"},
    inline="always",
    **NO_REFCOUNT,
)
def _dense_output(kind, Y, k_out, t_out, t, h, y, f0, ynew, fnew):
    """Fill output rows with t_out in (t, t + h] by cubic Hermite interpolation; returns the next row.

    The interpolant matches y and f at both ends, so it is third-order accurate
    and needs no extra right-hand-side calls.
    """
    n = n_states(kind)
    n_out = t_out.shape[0]
    t_new = t + h
    while k_out < n_out and t_out[k_out] <= t_new + 1e-12 * max(1.0, abs(t_new)):
        th = (t_out[k_out] - t) / h
        th2 = th * th
        h00 = 1.0 - 3.0 * th2 + 2.0 * th2 * th
        h10 = th - 2.0 * th2 + th2 * th
        h01 = 3.0 * th2 - 2.0 * th2 * th
        h11 = th2 * th - th2
        for i in range(n):
            Y[k_out, i] = h00 * y[i] + h01 * ynew[i] + h * (h10 * f0[i] + h11 * fnew[i])
        k_out += 1
    return k_out


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
        np.zeros(4, dtype=np.int64),
    )


@njit(
    cache=True,
    nogil=True,
    error_model="numpy",
    fastmath={"contract", "arcp", "nsz"},
    inline="always",
)
def _integrate(
    kind,
    y0,
    t_out,
    p,
    sg,
    rtol,
    scale,
    h0,
    hmax,
    max_steps,
    method=ROS34PW2,
    jac_reuse=True,
    gustafsson=True,
    exact_jac=True,
):
    """Integrate model ``kind`` from t_out[0] with a Rosenbrock method, dense output at ``t_out``.

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
    sg : ndarray
        Packed input signals (kinds, parameters, sample times, values, offsets).
    rtol : float
        Relative tolerance; the absolute tolerance of state i is rtol·scale[i].
    scale : ndarray
        Typical magnitude of each state (SI).
    h0, hmax : float
        Initial and largest step [s].
    max_steps : int
        Step budget.
    method : int
        ROS34PW2 (default) or ROS23.
    jac_reuse : bool
        ROS34PW2 only: keep the Jacobian of the last evaluation after an accepted
        step whose error was small (below 0.2 of the tolerance with exact Jacobians,
        0.5 with differences; the W-method keeps its order); recomputed after every
        rejection and at least every 8 steps.
    gustafsson : bool
        Use Gustafsson's predictive step-size controller after accepted steps.
    exact_jac : bool
        Reduced and PWA models: exact ∂f/∂y (:func:`jac_reduced`, :func:`jac_pwa`)
        instead of finite differences; the full model always uses differences.

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
    Y, y, f0, fnew, ft, yt, ynew, yerr, dfdt, U, J, W, piv, stats = _work_arrays(
        n_states(kind), t_out.shape[0], y0
    )
    atol = rtol * scale
    k_out, status, t = _march(
        kind,
        Y,
        t_out,
        p,
        sg,
        rtol,
        scale,
        atol,
        h0,
        hmax,
        max_steps,
        method,
        jac_reuse,
        gustafsson,
        exact_jac,
        y,
        f0,
        fnew,
        ft,
        yt,
        ynew,
        yerr,
        dfdt,
        U,
        J,
        W,
        piv,
        stats,
        None,
        None,
        None,
        None,
        None,
    )
    return Y, k_out, status, t, y, stats


# Closed-loop hooks of the step loop, resolved while typing: in open loop (``ctl`` None) they
# compile to constants and no-ops, so an open-loop kernel holds none of the controller's code.
def _closed(ctl):
    """True in closed loop (compiled code only)."""


def _n_samples(log):
    """Number of controller samples of the run (compiled code only)."""


def _sample_time(ctl):
    """Controller sample time [s] (compiled code only)."""


def _sample(kind, k, t, y, p, ctl, cst, ref, dref, sg, log):
    """Controller sample k at time t (compiled code only)."""


@overload(_closed)
def _ol_closed(ctl):
    if isinstance(ctl, types.NoneType):
        return lambda ctl: False
    return lambda ctl: ctl.shape[0] > 0


@overload(_n_samples)
def _ol_n_samples(log):
    if isinstance(log, types.NoneType):
        return lambda log: 0
    return lambda log: log.shape[1]


@overload(_sample_time)
def _ol_sample_time(ctl):
    if isinstance(ctl, types.NoneType):
        return lambda ctl: 1.0
    return lambda ctl: ctl[0]


@overload(_sample)
def _ol_sample(kind, k, t, y, p, ctl, cst, ref, dref, sg, log):
    if isinstance(ctl, types.NoneType):
        return lambda kind, k, t, y, p, ctl, cst, ref, dref, sg, log: None

    def sample(kind, k, t, y, p, ctl, cst, ref, dref, sg, log):
        controller_sample(kind, k, t, y, p[I_AA], p[I_AB], ctl, cst, ref, dref, sg, log)

    return sample


@njit(
    cache=True, nogil=True, error_model="numpy", fastmath={"contract", "arcp", "nsz"}, **NO_REFCOUNT
)
def _march(  # noqa: C901 (compiled step loop (numba): split only with a measured speed check)
    kind,
    Y,
    t_out,
    p,
    sg,
    rtol,
    scale,
    atol,
    h0,
    hmax,
    max_steps,
    method,
    jac_reuse,
    gustafsson,
    exact_jac,
    y,
    f0,
    fnew,
    ft,
    yt,
    ynew,
    yerr,
    dfdt,
    U,
    J,
    W,
    piv,
    stats,
    ctl,
    cst,
    ref,
    dref,
    log,
):
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
    n = n_states(kind)
    n_out = t_out.shape[0]
    closed = _closed(ctl)
    n_smp = _n_samples(log)
    dt_smp = _sample_time(ctl)
    gamma = PW2_GAMMA if method == ROS34PW2 else _D23
    reuse = jac_reuse and method == ROS34PW2
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
        if need_jac:
            u, ps, fl = _inputs(t, sg)
            nfev += _jacobian(kind, t, y, f0, u, ps, fl, p, sg, scale, J, dfdt, yt, ft, exact_jac)
            n_jac += 1
            need_jac = False
            jac_age = 0
            h_fact = -1.0
        if h != h_fact:
            _factor(kind, J, W, piv, h * gamma)
            h_fact = h
        n_rhs, u1, ps1, fl1 = _step_for(
            method, kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg
        )
        nfev += n_rhs
        err = 0.0
        finite = True
        for i in range(n):
            sc = atol[i] + rtol * max(abs(y[i]), abs(ynew[i]))
            err += (yerr[i] / sc) ** 2
            if not math.isfinite(ynew[i]):
                finite = False
        err = math.sqrt(err / n)
        # ROS34PW2: f(t + h, ynew) (next step's first stage, dense output) only if accepted
        fresh = method == ROS34PW2 and finite and err <= 1.0
        if fresh:
            _rhs_for(kind, ynew, u1, ps1, fl1, p, fnew)
            nfev += 1
        if fresh or method != ROS34PW2:
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
                if kind != FULL and kind != CHAMBER:  # reduced, PWA: their ∂f/∂y depends on u
                    need_jac = True
            cb = np.cbrt(err) if err > 0.0 else 0.0
            fac = 0.9 / cb if err > 0.0 else 5.0
            if gustafsson and h_acc > 0.0 and err > 0.0:
                # predictive controller (Gustafsson 1994): fewer rejections in a row;
                # cbrt(err_acc / err²) from the cube roots already taken
                fac = min(fac, 0.9 * (h / h_acc) * cb_acc / (cb * cb))
            h_acc = h
            cb_acc = cb if err > 1e-4 else _CBRT_1E4  # cbrt(max(err, 1e-4))
            fac = min(5.0, max(0.2, fac))
            if last_rejected and fac > 1.0:
                fac = 1.0
            # keep the factorisation when the step would barely change
            if not (need_jac or fac < 1.0 or fac > 1.2):
                fac = 1.0
            h *= fac
            if h > hmax:
                h = hmax
            last_rejected = False
        else:
            n_rej += 1
            h *= max(0.2, 0.9 / np.cbrt(err))
            need_jac = reuse and jac_age > 0
            last_rejected = True
    stats[0] = n_acc
    stats[1] = n_rej
    stats[2] = nfev
    stats[3] = n_jac
    return k_out, status, t


# One compiled entry point per model and method: the model kind and the method are literals
# inside, so each kernel holds only its own right-hand side, Jacobian and stepper (see
# _rhs_for, _exact_derivatives, _step_for), and a command compiles only the one it runs.
@njit(cache=True, nogil=True, error_model="numpy")
def _integrate_full(
    y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, jac_reuse, gustafsson, exact_jac
):
    return _integrate(
        FULL,
        y0,
        t_out,
        p,
        sg,
        rtol,
        scale,
        h0,
        hmax,
        max_steps,
        ROS34PW2,
        jac_reuse,
        gustafsson,
        exact_jac,
    )


@njit(cache=True, nogil=True, error_model="numpy")
def _integrate_reduced(
    y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, jac_reuse, gustafsson, exact_jac
):
    return _integrate(
        REDUCED,
        y0,
        t_out,
        p,
        sg,
        rtol,
        scale,
        h0,
        hmax,
        max_steps,
        ROS34PW2,
        jac_reuse,
        gustafsson,
        exact_jac,
    )


@njit(cache=True, nogil=True, error_model="numpy")
def _integrate_pwa(
    y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, jac_reuse, gustafsson, exact_jac
):
    return _integrate(
        PWA,
        y0,
        t_out,
        p,
        sg,
        rtol,
        scale,
        h0,
        hmax,
        max_steps,
        ROS34PW2,
        jac_reuse,
        gustafsson,
        exact_jac,
    )


@njit(cache=True, nogil=True, error_model="numpy")
def _integrate_full_ros23(
    y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, jac_reuse, gustafsson, exact_jac
):
    return _integrate(
        FULL,
        y0,
        t_out,
        p,
        sg,
        rtol,
        scale,
        h0,
        hmax,
        max_steps,
        ROS23,
        jac_reuse,
        gustafsson,
        exact_jac,
    )


@njit(cache=True, nogil=True, error_model="numpy")
def _integrate_reduced_ros23(
    y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, jac_reuse, gustafsson, exact_jac
):
    return _integrate(
        REDUCED,
        y0,
        t_out,
        p,
        sg,
        rtol,
        scale,
        h0,
        hmax,
        max_steps,
        ROS23,
        jac_reuse,
        gustafsson,
        exact_jac,
    )


@njit(cache=True, nogil=True, error_model="numpy")
def _integrate_pwa_ros23(
    y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, jac_reuse, gustafsson, exact_jac
):
    return _integrate(
        PWA,
        y0,
        t_out,
        p,
        sg,
        rtol,
        scale,
        h0,
        hmax,
        max_steps,
        ROS23,
        jac_reuse,
        gustafsson,
        exact_jac,
    )


@njit(cache=True, nogil=True, error_model="numpy")
def _integrate_chamber(
    y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, jac_reuse, gustafsson, exact_jac
):
    return _integrate(
        CHAMBER,
        y0,
        t_out,
        p,
        sg,
        rtol,
        scale,
        h0,
        hmax,
        max_steps,
        ROS34PW2,
        jac_reuse,
        gustafsson,
        exact_jac,
    )


@njit(cache=True, nogil=True, error_model="numpy")
def _integrate_chamber_ros23(
    y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, jac_reuse, gustafsson, exact_jac
):
    return _integrate(
        CHAMBER,
        y0,
        t_out,
        p,
        sg,
        rtol,
        scale,
        h0,
        hmax,
        max_steps,
        ROS23,
        jac_reuse,
        gustafsson,
        exact_jac,
    )


_ENTRY = {
    FULL: _integrate_full,
    REDUCED: _integrate_reduced,
    PWA: _integrate_pwa,
    CHAMBER: _integrate_chamber,
}
_ENTRY_ROS23 = {
    FULL: _integrate_full_ros23,
    REDUCED: _integrate_reduced_ros23,
    PWA: _integrate_pwa_ros23,
    CHAMBER: _integrate_chamber_ros23,
}


@njit(cache=True, nogil=True, error_model="numpy", fastmath={"contract", "arcp", "nsz"})
def _integrate_closed(
    kind, y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, method, ctl, ref, dref
):
    """:func:`_integrate` with the discrete controller ``ctl`` in the loop (see :mod:`._controller`).

    ``sg`` must hold the valve command as a constant signal; its value slot is the
    controller's output. ``ref``, ``dref``: reference position [m] and rate [m/s] at the
    sample instants t_0 + k·ctl[0], k < len(ref). Returns :func:`_integrate`'s tuple and
    the per-sample log, shape (N_LOG, len(ref)) (rows in :mod:`._controller`).
    """
    Y, y, f0, fnew, ft, yt, ynew, yerr, dfdt, U, J, W, piv, stats = _work_arrays(
        n_states(kind), t_out.shape[0], y0
    )
    atol = rtol * scale
    cst = np.zeros(N_CST)
    log = np.full((N_LOG, ref.shape[0]), np.nan)
    k_out, status, t = _march(
        kind,
        Y,
        t_out,
        p,
        sg,
        rtol,
        scale,
        atol,
        h0,
        hmax,
        max_steps,
        method,
        True,
        True,
        True,
        y,
        f0,
        fnew,
        ft,
        yt,
        ynew,
        yerr,
        dfdt,
        U,
        J,
        W,
        piv,
        stats,
        ctl,
        cst,
        ref,
        dref,
        log,
    )
    return Y, k_out, status, t, y, stats, log


@njit(cache=True, nogil=True, error_model="numpy")
def _closed_full(y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, ctl, ref, dref):
    return _integrate_closed(
        FULL, y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, ROS34PW2, ctl, ref, dref
    )


@njit(cache=True, nogil=True, error_model="numpy")
def _closed_full_ros23(y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, ctl, ref, dref):
    return _integrate_closed(
        FULL, y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, ROS23, ctl, ref, dref
    )


@njit(cache=True, nogil=True, error_model="numpy")
def _closed_reduced(y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, ctl, ref, dref):
    return _integrate_closed(
        REDUCED, y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, ROS34PW2, ctl, ref, dref
    )


@njit(cache=True, nogil=True, error_model="numpy")
def _closed_reduced_ros23(y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, ctl, ref, dref):
    return _integrate_closed(
        REDUCED, y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, ROS23, ctl, ref, dref
    )


@njit(cache=True, nogil=True, error_model="numpy")
def _closed_pwa(y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, ctl, ref, dref):
    return _integrate_closed(
        PWA, y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, ROS34PW2, ctl, ref, dref
    )


@njit(cache=True, nogil=True, error_model="numpy")
def _closed_pwa_ros23(y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, ctl, ref, dref):
    return _integrate_closed(
        PWA, y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, ROS23, ctl, ref, dref
    )


@njit(cache=True, nogil=True, error_model="numpy")
def _closed_chamber(y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, ctl, ref, dref):
    return _integrate_closed(
        CHAMBER, y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, ROS34PW2, ctl, ref, dref
    )


@njit(cache=True, nogil=True, error_model="numpy")
def _closed_chamber_ros23(y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, ctl, ref, dref):
    return _integrate_closed(
        CHAMBER, y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, ROS23, ctl, ref, dref
    )


# one closed-loop entry point per model and method (both compile-time constants): a command
# compiles only the stepper it uses
_CLOSED = {
    FULL: _closed_full,
    REDUCED: _closed_reduced,
    PWA: _closed_pwa,
    CHAMBER: _closed_chamber,
}
_CLOSED_ROS23 = {
    FULL: _closed_full_ros23,
    REDUCED: _closed_reduced_ros23,
    PWA: _closed_pwa_ros23,
    CHAMBER: _closed_chamber_ros23,
}


def _owned(a):
    """``a`` as a writable, C-contiguous float64 array (a copy only where it is not one).

    The kernels are compiled for exactly these arrays; a read-only array (a frozen
    parameter vector, a slice of a stored run) would otherwise be a new signature and
    compile the whole solver a second time.
    """
    a = np.ascontiguousarray(a, dtype=np.float64)
    return a if a.flags.writeable else a.copy()


def _open_args(
    y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, jac_reuse, gustafsson, exact_jac
):
    """The open-loop entry points' arguments, of exactly the types they are compiled for."""
    return (
        _owned(y0),
        _owned(t_out),
        _owned(p),
        _owned(sg),
        float(rtol),
        _owned(scale),
        float(h0),
        float(hmax),
        int(max_steps),
        bool(jac_reuse),
        bool(gustafsson),
        bool(exact_jac),
    )


def _closed_args(y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, ctl, ref, dref):
    """The closed-loop entry points' arguments, of exactly the types they are compiled for."""
    return (
        _owned(y0),
        _owned(t_out),
        _owned(p),
        _owned(sg),
        float(rtol),
        _owned(scale),
        float(h0),
        float(hmax),
        int(max_steps),
        _owned(ctl),
        _owned(ref),
        _owned(dref),
    )


def _output_args(t_out, Y, n_done, p, sg):
    """The output passes' arguments, of exactly the types they are compiled for."""
    return (_owned(t_out), _owned(Y), int(n_done), _owned(p), _owned(sg))


def _point_args(y, u, ps, fl, p):
    """The point-derivative kernels' arguments and result arrays f, J, G (G column-major)."""
    n = len(y)
    f, J, G = np.zeros(n), np.zeros((n, n)), np.asfortranarray(np.zeros((n, 3)))
    return (_owned(y), float(u), float(ps), float(fl), _owned(p), f, J, G)


def integrate_closed_loop(
    kind, y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, method, ctl, ref, dref
):
    """Closed-loop :func:`integrate`: the compiled controller ``ctl`` sets the valve command.

    Returns (Y, rows filled, status, t, y, stats, log); see :func:`_integrate_closed`.
    """
    if len(y0) != N_STATES[int(kind)] or len(scale) != len(y0):
        raise ValueError(
            f"model kind {kind} has {N_STATES[int(kind)]} states; got y0 of {len(y0)}, scale of {len(scale)}"
        )
    if sg[0] != 0.0:
        raise ValueError("closed loop: the valve command must be packed as a constant signal")
    entry = (_CLOSED if int(method) == ROS34PW2 else _CLOSED_ROS23)[int(kind)]
    args = _closed_args(y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, ctl, ref, dref)
    # compile (or load) apart from the timed call, with numba's pedantic IR warning silenced as
    # for the open loop (pytest turns a stray compiler warning into a failure)
    prepare(entry, args, f"closed-loop {_KIND_NAMES[int(kind)]} model")
    with _interruptible():
        return entry(*args)


@contextmanager
def _interruptible():
    """Re-raise a Ctrl-C that a compiled call reported as ``SystemError`` as what it is.

    The signal handler may run while numba boxes a result; the dispatcher then returns
    a result with the ``KeyboardInterrupt`` set, which Python turns into a
    ``SystemError`` caused by it. Callers (and the CLI) expect a ``KeyboardInterrupt``.
    """
    try:
        yield
    except SystemError as exc:
        cause = interrupt_cause(exc)
        if cause is None:
            raise
        raise cause.with_traceback(None) from None


def integrate(
    kind,
    y0,
    t_out,
    p,
    sg,
    rtol,
    scale,
    h0,
    hmax,
    max_steps,
    method=ROS34PW2,
    jac_reuse=True,
    gustafsson=True,
    exact_jac=True,
):
    """Integrate model ``kind``: :func:`_integrate` compiled for that model alone.

    Each model has its own entry point in which ``kind`` is a compile-time
    constant, so its machine code holds only its own right-hand side (compiled on
    first use, cached on disk). Releases the GIL.
    """
    if len(y0) != N_STATES[int(kind)] or len(scale) != len(y0):
        raise ValueError(
            f"model kind {kind} has {N_STATES[int(kind)]} states; got y0 of {len(y0)}, scale of {len(scale)}"
        )
    entry = (_ENTRY if int(method) == ROS34PW2 else _ENTRY_ROS23)[int(kind)]
    args = _open_args(
        y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, jac_reuse, gustafsson, exact_jac
    )
    prepare(entry, args, f"{_KIND_NAMES[int(kind)]} model")
    with _interruptible():
        return entry(*args)


_KIND_NAMES = ("full", "reduced", "PWA", "chamber PWA")
_compile_notice = None
_noticed = False
#: Seconds this process spent loading or compiling kernels (read by ``simulate``).
compile_seconds = 0.0


#: Kernels in a warm-up's queue: dispatcher -> the :class:`~._warmup.WarmUp` whose
#: ``acquire(dispatcher)`` returns once this process may load or compile it.
_warming: dict = {}
#: Longest wait [s] for a warm-up process's kernel before compiling it here.
WARMUP_WAIT = 600.0
#: ``callback(dispatcher)`` run before a kernel missing from the disk cache compiles here
#: (:mod:`._warmup` starts compiling the other models' kernels in the background).
_cold_hook: Callable[[Any], None] | None = None


def warmup_calls(name):
    """The compiled kernels a warm-up of ``name`` compiles, as (dispatcher, args, what).

    ``name``: ``"full"``, ``"reduced"``, ``"pwa"`` (the open-loop solver with the default
    method and the model's output pass), ``"closed-<model>"`` (the closed-loop solver) or
    ``"point"`` (the linearization's point derivatives and the PWA load flow) or
    ``"output-<model>"`` (the output pass alone: a first ``simulate`` compiles the solver
    while the background process compiles the output pass it needs next). The
    arguments are placeholders of exactly the types :func:`integrate`,
    :func:`integrate_closed_loop`, :func:`outputs` and :func:`point_derivatives` pass, so
    the compiled code is what they load.
    """
    z, zz = np.zeros(1), np.zeros((1, 1))
    kinds = {name: kind for name, (kind, _s, _w) in MODEL_KINDS.items()}
    if name == "point":
        args = _point_args(np.zeros(3), 0.0, 0.0, 0.0, z)
        return [
            (_point_pwa, args, "linearization"),
            (pwa_load_flow_at, (0.0, 0.0, 0.0, z), "linearization"),
            (_point_reduced, args, "linearization"),
        ]
    model = name.removeprefix("closed-").removeprefix("output-")
    if model not in kinds:
        raise ValueError(f"unknown kernel {name!r}; choose from {', '.join(WARMUP_NAMES)}")
    kind = kinds[model]
    if name.startswith("closed-"):
        args = _closed_args(z, z, z, z, 0.0, z, 0.0, 0.0, 0, z, z, zz)
        return [(_CLOSED[kind], args, f"closed-loop {_KIND_NAMES[kind]} model")]
    output = (OUTPUTS[kind], _output_args(z, zz, 0, z, z), "output")
    if name.startswith("output-"):
        return [output]
    args = _open_args(z, z, z, z, 0.0, z, 0.0, 0.0, 0, True, True, True)
    return [(_ENTRY[kind], args, f"{_KIND_NAMES[kind]} model"), output]


#: The names :func:`warmup_calls` takes.
WARMUP_NAMES = (
    *MODEL_KINDS,
    "point",
    *(f"closed-{m}" for m in MODEL_KINDS),
    *(f"output-{m}" for m in MODEL_KINDS),
)


#: A compilation (or a wait for a warm-up) longer than this [s] ends with a "ready" notice.
NOTICE_AFTER_S = 2.0


def set_compile_notice(callback):
    """Call ``callback(message)`` before the first kernel is compiled, and after each wait.

    Once per process before the first compilation ("compiling the … solver"), then once for
    every kernel whose compilation (or wait for a background warm-up) took over 2 s ("… solver
    ready (8.1 s)"). The CLI passes a printer to stderr, so a user waiting on a fresh install
    is told why and sees each solver arrive. ``None`` (the library's default) stays silent;
    ``set_compile_notice(print)`` shows the same lines in Python. Returns the previous callback.
    """
    global _compile_notice, _noticed
    previous, _compile_notice, _noticed = _compile_notice, callback, False
    return previous


def _cached_on_disk(dispatcher) -> bool:
    """Whether numba's on-disk cache holds ``dispatcher`` compiled from the current sources."""
    try:
        cache_file = dispatcher._cache._cache_file
        if not os.path.exists(cache_file._index_path):
            return False
        return bool(cache_file._load_index())  # {} where the index's stamp is stale
    except Exception:  # pragma: no cover - numba internals differ: assume compiled
        return True


def prepare(dispatcher, args, what="solver"):
    """Load ``dispatcher`` from the cache or compile it for ``args`` before the timed call.

    A no-op once it is ready in this process. The seconds spent are added to
    :data:`compile_seconds`, so ``simulate`` reports compilation apart from simulation.
    """
    global compile_seconds, _noticed
    if not hasattr(dispatcher, "typeof_pyval"):  # not a numba dispatcher (a test's stand-in)
        return 0.0
    sig = tuple(dispatcher.typeof_pyval(a) for a in args)
    if sig in dispatcher.signatures:  # ready for exactly these argument types
        return 0.0
    # (a read-only or differently laid-out array is a new signature: compile it here too, with
    # the warning filter below, not at the call)

    t0 = time.perf_counter()
    cold = False
    warming = _warming.get(dispatcher)
    if warming is not None:
        # a warm-up (see ._warmup) has this kernel in its queue: load it once that process has
        # cached it (meanwhile compiling its later kernels here), or compile it here if that
        # process has not started it
        warming.acquire(dispatcher)
    elif not _cached_on_disk(dispatcher):
        cold = True
        if _compile_notice is not None and not _noticed:
            _noticed = True
            _compile_notice(
                f"compiling the {what} solver (once per installation, ~5–10 s per model;"
                " later runs load it from the cache)"
            )
        if _cold_hook is not None:
            _cold_hook(dispatcher)

    with warnings.catch_warnings():
        # numba's pedantic scope check after inlining the PWA model's code through an overload
        # (a variable set on both branches of an if); the IR is valid and the results are tested.
        warnings.simplefilter("ignore", NumbaIRAssumptionWarning)
        dispatcher.compile(sig)
    dt = time.perf_counter() - t0
    compile_seconds += dt
    if _compile_notice is not None and dt > NOTICE_AFTER_S and (cold or warming is not None):
        # each long wait ends with a line, so a user sees the compiler progress, not silence
        _compile_notice(f"  {what} solver ready ({dt:.1f} s)")
    return dt


def outputs(kind, t_out, Y, n_done, p, sg):
    """Derived channels per output sample (see :func:`_outputs`).

    The Stribeck friction channel of the full and reduced models is evaluated here, on the
    whole velocity row at once, by the same :func:`~hydropwa.components.stribeck_friction`
    run as NumPy (its SIMD exp/tanh/power take ~7 ns per sample against ~26 ns compiled
    scalar code), and written into the row the compiled pass leaves empty.
    """
    args = _output_args(t_out, Y, n_done, p, sg)
    prepare(OUTPUTS[kind], args, "output")  # load or compile (a no-op once ready), timed apart
    with _interruptible():
        out = OUTPUTS[kind](*args)
    if kind == FULL or kind == REDUCED:
        out[O_FRICTION] = stribeck_friction.py_func(
            out[O_V], p[I_FC], p[I_FS], p[I_SIGMA], p[I_CHI], p[I_DELTA], p[I_GAMMA]
        )
    return out


# One compiled output pass per model: each holds only its own model's code, and a command
# compiles only the one it runs. Rows: the layout table's OUTPUT_CHANNELS (11), and for the PWA
# model the active cells g, o, n, w (PWA_OUTPUT_CHANNELS). The friction row of the full and
# reduced models is left at zero for :func:`outputs` to fill.
@njit(cache=True, nogil=True, error_model="numpy")
def _outputs_full(t_out, Y, n_done, p, sg):
    out = np.empty((N_OUT, n_done))
    _fill_full(t_out, Y, n_done, p, sg, out)
    return out


@njit(cache=True, nogil=True, error_model="numpy")
def _outputs_reduced(t_out, Y, n_done, p, sg):
    out = np.empty((N_OUT, n_done))
    _fill_reduced(t_out, Y, n_done, p, sg, out)
    return out


@njit(cache=True, nogil=True, error_model="numpy")
def _outputs_pwa(t_out, Y, n_done, p, sg):
    out = np.empty((N_OUT_PWA, n_done))
    _fill_pwa(t_out, Y, n_done, p, sg, out)
    return out


@njit(cache=True, nogil=True, error_model="numpy")
def _outputs_chamber(t_out, Y, n_done, p, sg):
    out = np.empty((N_OUT_CHAMBER, n_done))
    _fill_chamber(t_out, Y, n_done, p, sg, out)
    return out


#: The output pass of each model kind: ``OUTPUTS[kind](t_out, Y, n_done, p, sg)``.
OUTPUTS = {
    FULL: _outputs_full,
    REDUCED: _outputs_reduced,
    PWA: _outputs_pwa,
    CHAMBER: _outputs_chamber,
}


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _write_outputs(out, k, u, spool, z, pa, pb, pl, ps, fl, x, v, fr, p):
    """Output column k (rows from the layout table's OUTPUT_CHANNELS)."""
    out[O_U, k] = u
    out[O_SPOOL, k] = spool
    out[O_Z, k] = z
    out[O_P_A, k] = pa
    out[O_P_B, k] = pb
    out[O_P_L, k] = pl  # the model's load pressure: P_A − P_B (full, paper form), P_A − α P_B
    out[O_P_S, k] = ps
    out[O_F_L, k] = fl + p[I_CLOAD] * v  # the force sensor measures F_L(t) + c·ẋ
    out[O_X, k] = x
    out[O_V, k] = v
    out[O_FRICTION, k] = fr


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def _fill_full(t_out, Y, n_done, p, sg, out):
    """Output pass of the full model (allocation-free); friction is filled by :func:`outputs`."""
    for k in range(n_done):
        u, ps, fl = _inputs(t_out[k], sg)
        spool = Y[k, Y_NU]
        pa, pb = Y[k, Y_PA], Y[k, Y_PB]
        if p[I_PUMP] > 0.5:
            ps = Y[k, Y_PS]
        _write_outputs(
            out,
            k,
            u,
            spool,
            _opening(spool, p),
            pa,
            pb,
            pa - pb,
            ps,
            fl,
            Y[k, Y_X],
            Y[k, Y_V],
            0.0,
            p,
        )


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def _fill_reduced(t_out, Y, n_done, p, sg, out):
    """Output pass of the reduced model: P_A, P_B from P_L by Eq. (13), generalised."""
    for k in range(n_done):
        u, ps, fl = _inputs(t_out[k], sg)
        pl, v, x = Y[k, L_PL], Y[k, L_V], Y[k, L_X]
        z = _opening(u, p)
        al, pt, _a, _cq, _cl, _dcq, _dcl = _reduced_terms(x, p)
        pa, pb = chamber_pressures_from_load(z, pl, ps, al, pt)
        _write_outputs(out, k, u, u, z, pa, pb, pl, ps, fl, x, v, 0.0, p)


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def _fill_pwa(t_out, Y, n_done, p, sg, out):
    """Output pass of the PWA model, with its active cells g, o, n, w in the extra rows."""
    for k in range(n_done):
        u, ps, fl = _inputs(t_out[k], sg)
        pl, v, x = Y[k, L_PL], Y[k, L_V], Y[k, L_X]
        g, o, nn, w, z, ps, _pn = pwa_cells(pl, v, u, ps, p)
        f_slope, f_offset = _pwa_friction_cell(p, w)
        out[N_OUT, k] = g
        out[N_OUT + 1, k] = o
        out[N_OUT + 2, k] = nn
        out[N_OUT + 3, k] = w
        al, pt, _a, _cq, _cl, _dcq, _dcl = _reduced_terms(x, p)
        pa, pb = chamber_pressures_from_load(z, pl, ps, al, pt)
        _write_outputs(out, k, u, u, z, pa, pb, pl, ps, fl, x, v, f_slope * v + f_offset, p)


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def _fill_chamber(t_out, Y, n_done, p, sg, out):
    """Output pass of the chamber PWA model, with its active cells g, a, b, x, w in the extra rows."""
    for k in range(n_done):
        u, ps_in, fl = _inputs(t_out[k], sg)
        y = Y[k]
        (
            z,
            _kg,
            ps,
            _qa,
            _qb,
            _qaz,
            _qbz,
            _qapa,
            _qbpb,
            _qas,
            _qbs,
            _xcap,
            fk,
            fd,
            g,
            ca,
            cb,
            j,
            w,
        ) = chamber_terms(y, ps_in, p)
        out[N_OUT, k] = g
        out[N_OUT + 1, k] = ca
        out[N_OUT + 2, k] = cb
        out[N_OUT + 3, k] = j
        out[N_OUT + 4, k] = w
        pa, pb, v = y[Y_PA], y[Y_PB], y[Y_V]
        _write_outputs(out, k, u, y[Y_NU], z, pa, pb, pa - pb, ps, fl, y[Y_X], v, fk * v + fd, p)
