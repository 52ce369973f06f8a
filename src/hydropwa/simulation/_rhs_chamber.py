"""The chamber-level PWA model (kind CHAMBER, ``pwa-chamber``): rhs, Jacobian, ∂f/∂t."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .. import _jitcache  # noqa: F401  (one cache stamp for all compiled modules)
from .._layout import (
    I_CELLS,
)
from ..components._physics import (
    effective_bulk_modulus,
    external_leakage_flow,
)
from ._kcommon import (
    _N_FULL,
    I_AA,
    I_AB,
    I_ACCV,
    I_CEA,
    I_CEB,
    I_CL,
    I_CLOAD,
    I_E,
    I_K,
    I_MASS,
    I_NG,
    I_NN,
    I_NO,
    I_NW,
    I_OMEGA0,
    I_PREL,
    I_PSFIX,
    I_PT,
    I_PVAP,
    I_SCHED,
    I_STROKE,
    I_VA,
    I_VB,
    I_ZETA,
    Y_DNU,
    Y_NU,
    Y_PA,
    Y_PB,
    Y_PS,
    Y_V,
    Y_X,
    _contact_force_slope,
)
from ._rhs_full import _chambers_and_mechanics
from ._rhs_load import _cell
from ._signals import NO_REFCOUNT

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


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
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
    net_a = qa_net - p[I_AA] * v + p[I_CL] * (pb - pa) - external_leakage_flow(pa, p[I_CEA])
    net_b = -qb + p[I_AB] * v + p[I_CL] * (pa - pb) - external_leakage_flow(pb, p[I_CEB])
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
    _chambers_and_mechanics(y, u, fl, qa, qb, xcap, fk * y[Y_V] + fd, p, dy)
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
    J[Y_PA, Y_PA] = ca * (qapa - cl - p[I_CEA])
    J[Y_PA, Y_PB] = ca * cl
    J[Y_PA, Y_V] = -ca * p[I_AA]
    J[Y_PB, Y_NU] = -cb * qbz * kg
    J[Y_PB, Y_PB] = cb * (-qbpb - cl - p[I_CEB])
    J[Y_PB, Y_PA] = cb * cl
    J[Y_PB, Y_V] = cb * p[I_AB]
    J[Y_X, Y_V] = 1.0
    m = p[I_MASS]
    kx, kv = _contact_force_slope(x, v, p)
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
