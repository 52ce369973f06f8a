"""The full-order model, Eqs. (1)–(11): right-hand side, exact Jacobian and ∂f/∂t.

Assembled from :mod:`hydropwa.components`; the C emitter (:mod:`._emit_c`) translates
:func:`rhs_full` and its callees for the axis FMU.
"""

from __future__ import annotations

from numba import njit

from .. import _jitcache  # noqa: F401  (one cache stamp for all compiled modules)
from ..components._physics import (
    accumulator_pressure_rate,
    chamber_pressure_rates,
    dead_zone_slope,
    effective_bulk_modulus,
    effective_bulk_modulus_slope,
    external_leakage_flow,
    hose_flow,
    orifice_flow_slopes,
    orifice_flows,
    piston_acceleration,
    pump_supply_rate,
    pump_supply_rate_slope,
    servo_valve_acceleration,
    stribeck_friction_slope,
    supply_flow,
)
from ._kcommon import (
    I_AA,
    I_AB,
    I_ACCN,
    I_ACCP0,
    I_ACCV,
    I_ALPHA,
    I_BETA,
    I_CEA,
    I_CEB,
    I_CHI,
    I_CL,
    I_CLOAD,
    I_CREEP,
    I_DELTA,
    I_DROOP,
    I_E,
    I_FC,
    I_FS,
    I_GAMMA,
    I_GRELIEF,
    I_HOSED,
    I_HOSEL,
    I_HOSEVOL,
    I_K,
    I_MASS,
    I_OMEGA0,
    I_OUTER,
    I_PREL,
    I_PRELIEF,
    I_PSET,
    I_PT,
    I_PTR,
    I_PUMP,
    I_PVAP,
    I_QMAX,
    I_SIGMA,
    I_STROKE,
    I_VA,
    I_VB,
    I_VISC,
    I_VLINE,
    I_ZETA,
    Y_DNU,
    Y_NU,
    Y_PA,
    Y_PACC,
    Y_PB,
    Y_PS,
    Y_V,
    Y_X,
    _contact_force,
    _contact_force_slope,
    _friction,
    _opening,
)
from ._signals import NO_REFCOUNT


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _chambers_and_mechanics(y, u, fl, qa, qb, xvol, friction, p, dy):
    """Rates of the spool, gas accumulator, chambers and mechanics given the metering flows.

    The one assembly of Eqs. (3), (9) and (10) (and the accumulator on port A) shared by the
    full model (:func:`rhs_full`) and the chamber PWA model (:func:`~._rhs_chamber.rhs_chamber`):
    ``qa``, ``qb`` are the metering flows Q_A, Q_B [m³/s], ``xvol`` the rod position [m] at which
    the chamber volumes are evaluated (the state x, or the chamber model's capacitance cell),
    ``friction`` the friction force [N]. Writes every rate but P_S's.
    """
    nu, dnu, pa, pb, x, v = y[Y_NU], y[Y_DNU], y[Y_PA], y[Y_PB], y[Y_X], y[Y_V]
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
        xvol,
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
        p[I_CEA],
        p[I_CEB],
    )
    stop = _contact_force(x, v, p)
    dy[Y_NU] = dnu
    dy[Y_DNU] = servo_valve_acceleration(nu, dnu, u, p[I_OMEGA0], p[I_ZETA])
    dy[Y_PA] = dpa
    dy[Y_PB] = dpb
    dy[Y_X] = v
    dy[Y_V] = piston_acceleration(
        pa * p[I_AA] - pb * p[I_AB], friction, fl + p[I_CLOAD] * v, stop, p[I_MASS]
    )


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def rhs_full(y, u, ps_in, fl, p, dy):
    """Full-order model, Eqs. (1)–(11), with the corrected sign of Q_B (docs/errata.md E1)."""
    nu, pa, pb, x, v = y[Y_NU], y[Y_PA], y[Y_PB], y[Y_X], y[Y_V]
    pump = p[I_PUMP] > 0.5
    ps = y[Y_PS] if pump else ps_in
    z = _opening(nu, p)
    qa, qb = orifice_flows(z, pa, pb, ps, p[I_PT], p[I_K], p[I_PTR])
    _chambers_and_mechanics(y, u, fl, qa, qb, x, _friction(v, p), p, dy)
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

    ``dq`` holds ∂Q/∂(its own pressure) less the chamber's external leakage C_e, ``qx``
    ∂net/∂v; the piston leakage couples the chamber's own pressure column ``col_p`` (−C_L) and
    the other chamber's ``col_other`` (+C_L);
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
    net_a = qa - aa * v + cl * (pb - pa) - external_leakage_flow(pa, p[I_CEA])
    net_b = -qb + ab * v + cl * (pa - pb) - external_leakage_flow(pb, p[I_CEB])
    va = p[I_VA] + aa * x
    vb = p[I_VB] + ab * (p[I_STROKE] - x)
    ga = _chamber_row(qa_pa - p[I_CEA], -aa, net_a, pa, va, aa, p, J, Y_PA, Y_PA, Y_PB)
    gb = _chamber_row(-qb_pb - p[I_CEB], ab, net_b, pb, vb, -ab, p, J, Y_PB, Y_PB, Y_PA)
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
    kx, kv = _contact_force_slope(x, v, p)
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
    net_a = qa - aa * v + cl * (pb - pa) - external_leakage_flow(pa, p[I_CEA])
    net_b = -qb + ab * v + cl * (pa - pb) - external_leakage_flow(pb, p[I_CEB])
    va = p[I_VA] + aa * x
    vb = p[I_VB] + ab * (p[I_STROKE] - x)
    dfdt[Y_PA] = effective_bulk_modulus(pa, E, p[I_PVAP], p[I_PREL], net_a) / va * qa_ps * dps
    dfdt[Y_PB] = -effective_bulk_modulus(pb, E, p[I_PVAP], p[I_PREL], net_b) / vb * qb_ps * dps
