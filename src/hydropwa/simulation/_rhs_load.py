"""The reduced (Eqs. (12)–(15)) and PWA (Eqs. (16)–(23)) load-pressure models.

Right-hand sides, exact Jacobians and ∂f/∂t; the PWA cell lookup and edge scaling.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .. import _jitcache  # noqa: F401  (one cache stamp for all compiled modules)
from .._layout import (
    I_CELLS,
)
from ..components._physics import (
    asymmetric_load_pressure_rate,
    chamber_pressure_difference_slopes,
    chamber_pressures_from_load,
    dead_zone_slope,
    load_capacitance,
    load_capacitance_slope,
    load_flow,
    load_flow_input_slopes,
    load_flow_slope,
    piston_acceleration,
    stribeck_friction_slope,
)
from ._kcommon import (
    I_AA,
    I_AB,
    I_ALPHA,
    I_BETA,
    I_CHI,
    I_CL,
    I_CLOAD,
    I_CREEP,
    I_DELTA,
    I_E,
    I_FC,
    I_FORM,
    I_FS,
    I_GAMMA,
    I_K,
    I_MASS,
    I_NG,
    I_NN,
    I_NO,
    I_NW,
    I_OUTER,
    I_PSFIX,
    I_PT,
    I_PTR,
    I_RFORM,
    I_SCHED,
    I_SIGMA,
    I_STROKE,
    I_VA,
    I_VB,
    I_XCAP,
    _contact_force,
    _contact_force_slope,
    _friction,
    _load_gain,
    _mean_area,
    _opening,
)
from ._signals import NO_REFCOUNT


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
    stop = _contact_force(x, v, p)
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
    kx, kv = _contact_force_slope(x, v, p)
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
