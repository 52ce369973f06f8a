"""The full-order model with hose lines (``full-lines``): right-hand side, Jacobian and ∂f/∂t.

The full model of :mod:`._rhs_full` with a line volume between each valve port and its chamber
(:class:`~hydropwa.params.Lines`): the valve's metering edges (5)–(6) see the line pressures
P_line,A and P_line,B, each line feeds its chamber through its resistance
(:func:`~hydropwa.components.line_flow`), and continuity (9) holds on each line with the oil's
effective modulus in series with the hose wall's
(:func:`~hydropwa.components.series_bulk_modulus`):

    Ṗ_line,A = E_line / V_line,A · (Q_A − Q_lA),   Q_lA = flow(P_line,A − P_A)
    Ṗ_line,B = E_line / V_line,B · (Q_lB − Q_B),   Q_lB = flow(P_B − P_line,B)

and the chambers take Q_lA and Q_lB where the full model has Q_A and Q_B. A port whose line
has zero volume connects straight to its chamber (its line state is held and left out of the
solves and the error norm, registry row ``full-lines``): with both volumes zero every rate,
the Jacobian and ∂f/∂t are the full model's, bit for bit.
"""

from __future__ import annotations

from numba import njit

from .. import _jitcache  # noqa: F401  (one cache stamp for all compiled modules)
from .._layout import LINE_STATES, Y_FULL
from ..components._physics import (
    dead_zone_slope,
    effective_bulk_modulus,
    effective_bulk_modulus_slope,
    external_leakage_flow,
    line_flow,
    line_flow_slope,
    orifice_flow_slopes,
    orifice_flows,
    pump_supply_rate,
    pump_supply_rate_slope,
    series_bulk_modulus,
    series_bulk_modulus_slope,
    supply_flow,
)
from ._kcommon import (
    I_AA,
    I_AB,
    I_ALPHA,
    I_BETA,
    I_CEA,
    I_CEB,
    I_CL,
    I_CREEP,
    I_DROOP,
    I_E,
    I_EHOSE,
    I_GLA,
    I_GLB,
    I_GRELIEF,
    I_K,
    I_LORIF,
    I_OUTER,
    I_PREL,
    I_PRELIEF,
    I_PSET,
    I_PT,
    I_PTR,
    I_PUMP,
    I_PVAP,
    I_QMAX,
    I_STROKE,
    I_VA,
    I_VB,
    I_VLA,
    I_VLB,
    I_VLINE,
    Y_NU,
    Y_PA,
    Y_PB,
    Y_PS,
    Y_V,
    Y_X,
    _friction,
    _opening,
)
from ._rhs_full import _chamber_row, _chambers_and_mechanics, dfdt_full, jac_full
from ._signals import NO_REFCOUNT

Y_PLA, Y_PLB = (len(Y_FULL), len(Y_FULL) + 1)
assert tuple(name for name, _u, _s in LINE_STATES[Y_PLA:]) == ("p_line_a", "p_line_b")

_JIT = {"cache": True, "nogil": True, "error_model": "numpy", **NO_REFCOUNT}


@njit(**_JIT, inline="always")
def _port_pressures(y, p):
    """The pressures the valve's ports see: each line's, or its chamber's where it has none."""
    pla = y[Y_PLA] if p[I_VLA] > 0.0 else y[Y_PA]
    plb = y[Y_PLB] if p[I_VLB] > 0.0 else y[Y_PB]
    return pla, plb


@njit(**_JIT, inline="always")
def _line_gain(pl, net, vol, p):
    """E_line/V_line [Pa/m³] of a line at pressure ``pl`` with net inflow ``net`` [m³/s]."""
    e = effective_bulk_modulus(pl, p[I_E], p[I_PVAP], p[I_PREL], net)
    return series_bulk_modulus(e, p[I_EHOSE]) / vol


@njit(**_JIT, inline="always")
def _line_flows(y, qa, qb, pla, plb, p):
    """Flows into chamber A and out of chamber B through the lines (the valve's, without one)."""
    qla = qa
    if p[I_VLA] > 0.0:
        qla = line_flow(pla - y[Y_PA], p[I_GLA], p[I_LORIF], p[I_PTR])
    qlb = qb
    if p[I_VLB] > 0.0:
        qlb = line_flow(y[Y_PB] - plb, p[I_GLB], p[I_LORIF], p[I_PTR])
    return qla, qlb


@njit(**_JIT)
def rhs_lines(y, u, ps_in, fl, p, dy):
    """Full-order model with hose lines: Eqs. (1)–(11) with continuity on each line (module doc)."""
    pump = p[I_PUMP] > 0.5
    ps = y[Y_PS] if pump else ps_in
    z = _opening(y[Y_NU], p)
    pla, plb = _port_pressures(y, p)
    qa, qb = orifice_flows(z, pla, plb, ps, p[I_PT], p[I_K], p[I_PTR])
    qla, qlb = _line_flows(y, qa, qb, pla, plb, p)
    _chambers_and_mechanics(y, u, fl, qla, qlb, y[Y_X], _friction(y[Y_V], p), p, dy)
    dy[Y_PLA] = _line_gain(pla, qa - qla, p[I_VLA], p) * (qa - qla) if p[I_VLA] > 0.0 else 0.0
    dy[Y_PLB] = _line_gain(plb, qlb - qb, p[I_VLB], p) * (qlb - qb) if p[I_VLB] > 0.0 else 0.0
    if pump:
        draw = supply_flow(z, qa, qb)
        dy[Y_PS] = pump_supply_rate(
            ps, draw, p[I_PSET], p[I_QMAX], p[I_DROOP], p[I_VLINE], p[I_E], p[I_PRELIEF],
            p[I_GRELIEF],
        )  # fmt: skip
    else:
        dy[Y_PS] = 0.0


@njit(**_JIT, inline="always")
def _line_row(J, row, col_l, col_c, pl, net, dnet_l, s, vol, p):
    """Row ``row`` of ∂f/∂y for a line, Ṗ_l = g(P_l, net)·net with g = E_line/V_l.

    ``dnet_l`` = ∂net/∂P_l; the chamber's pressure enters net through the line flow with the
    slope ``s`` (:func:`~hydropwa.components.line_flow_slope`) for both lines. Returns g.
    """
    e = effective_bulk_modulus(pl, p[I_E], p[I_PVAP], p[I_PREL], net)
    de = effective_bulk_modulus_slope(pl, p[I_E], p[I_PVAP], p[I_PREL], net)
    g = series_bulk_modulus(e, p[I_EHOSE]) / vol
    dg = series_bulk_modulus_slope(e, p[I_EHOSE]) * de / vol
    J[row, col_l] = g * dnet_l + dg * net
    J[row, col_c] = g * s
    return g


@njit(**_JIT, inline="always")
def _pump_row(J, z, dz, qa_z, qa_pa, qa_ps, qb_z, qb_pb, qb_ps, col_a, col_b, ps, p):
    """The pump supply's row (P_S a state): its draw Q_A or −Q_B through the port pressures."""
    dps_ps, dps_q = pump_supply_rate_slope(
        ps, p[I_VLINE], p[I_E], p[I_QMAX], p[I_PSET], p[I_DROOP], p[I_PRELIEF], p[I_GRELIEF]
    )
    if z >= 0.0:  # the draw is Q_A (supply feeds A)
        J[Y_PS, Y_NU] = dps_q * qa_z * dz
        J[Y_PS, col_a] = dps_q * qa_pa
        J[Y_PS, Y_PS] = dps_ps + dps_q * qa_ps
    else:  # the draw is −Q_B (supply feeds B)
        J[Y_PS, Y_NU] = -dps_q * qb_z * dz
        J[Y_PS, col_b] = -dps_q * qb_pb
        J[Y_PS, Y_PS] = dps_ps - dps_q * qb_ps


@njit(**_JIT)
def jac_lines(y, u, ps_in, fl, p, J):
    """Exact ∂f/∂y of :func:`rhs_lines` without an accumulator; False (J untouched) with one.

    The full model's (:func:`~._rhs_full.jac_full`), which it is without lines (called alone
    there: with the line code in the same function the trajectory without lines moved, 728 →
    730 steps on a paper-rig sine; not traced); with a line see :func:`_jac_through_lines`.
    """
    if p[I_VLA] <= 0.0 and p[I_VLB] <= 0.0:
        return jac_full(y, u, ps_in, fl, p, J)
    return _jac_through_lines(y, u, ps_in, fl, p, J)


@njit(**_JIT)
def _jac_through_lines(y, u, ps_in, fl, p, J):
    """∂f/∂y with a line: the full model's, its chamber rows taking the line flow's slopes
    instead of the metering edge's, the line's row the edge's (orifice, dead zone, supply) and
    the line flow's, with the series modulus."""
    if not jac_full(y, u, ps_in, fl, p, J):
        return False
    la, lb = p[I_VLA] > 0.0, p[I_VLB] > 0.0
    pa, pb, x, v = y[Y_PA], y[Y_PB], y[Y_X], y[Y_V]
    pump = p[I_PUMP] > 0.5
    ps = y[Y_PS] if pump else ps_in
    nu = y[Y_NU]
    z = _opening(nu, p)
    dz = dead_zone_slope(nu, p[I_ALPHA], p[I_BETA], p[I_CREEP], p[I_OUTER])
    pla, plb = _port_pressures(y, p)
    qa, qb = orifice_flows(z, pla, plb, ps, p[I_PT], p[I_K], p[I_PTR])
    qa_z, qa_pa, qa_ps, qb_z, qb_pb, qb_ps = orifice_flow_slopes(
        z, pla, plb, ps, p[I_PT], p[I_K], p[I_PTR]
    )
    qla, qlb = _line_flows(y, qa, qb, pla, plb, p)
    sa = line_flow_slope(pla - pa, p[I_GLA], p[I_LORIF], p[I_PTR])
    sb = line_flow_slope(pb - plb, p[I_GLB], p[I_LORIF], p[I_PTR])
    aa, ab, cl = p[I_AA], p[I_AB], p[I_CL]
    for j in range(J.shape[1]):  # the chamber rows and the pump's again, through the lines
        J[Y_PA, j] = J[Y_PB, j] = J[Y_PS, j] = 0.0
    net_a = qla - aa * v + cl * (pb - pa) - external_leakage_flow(pa, p[I_CEA])
    net_b = -qlb + ab * v + cl * (pa - pb) - external_leakage_flow(pb, p[I_CEB])
    va = p[I_VA] + aa * x
    vb = p[I_VB] + ab * (p[I_STROKE] - x)
    dqa = -sa if la else qa_pa
    dqb = -sb if lb else -qb_pb
    ga = _chamber_row(dqa - p[I_CEA], -aa, net_a, pa, va, aa, p, J, Y_PA, Y_PA, Y_PB)
    gb = _chamber_row(dqb - p[I_CEB], ab, net_b, pb, vb, -ab, p, J, Y_PB, Y_PB, Y_PA)
    if la:  # the edge feeds the line; the line feeds the chamber
        J[Y_PA, Y_PLA] = ga * sa
        g = _line_row(J, Y_PLA, Y_PLA, Y_PA, pla, qa - qla, qa_pa - sa, sa, p[I_VLA], p)
        ga = g  # the node the edge A feeds (for its spool and supply columns)
    if lb:
        J[Y_PB, Y_PLB] = gb * sb
        g = _line_row(J, Y_PLB, Y_PLB, Y_PB, plb, qlb - qb, -sb - qb_pb, sb, p[I_VLB], p)
        gb = g
    ra, rb = (Y_PLA if la else Y_PA), (Y_PLB if lb else Y_PB)
    J[ra, Y_NU] = ga * qa_z * dz
    J[rb, Y_NU] = -gb * qb_z * dz
    if pump:
        J[ra, Y_PS] = ga * qa_ps
        J[rb, Y_PS] = -gb * qb_ps
        _pump_row(J, z, dz, qa_z, qa_pa, qa_ps, qb_z, qb_pb, qb_ps, ra, rb, ps, p)
    return True


@njit(**_JIT)
def dfdt_lines(y, u, ps_in, fl, du, dps, dfl, p, dfdt):
    """Exact ∂f/∂t of :func:`rhs_lines` from the inputs' rates (u̇, Ṗ_S, Ḟ_L).

    The full model's (:func:`~._rhs_full.dfdt_full`), whose supply-pressure term of a port
    without a line is the same here; on a port with a line the supply pressure feeds the line
    (its metering edge sees the line pressure), not the chamber.
    """
    dfdt_full(y, u, ps_in, fl, du, dps, dfl, p, dfdt)
    la, lb = p[I_VLA] > 0.0, p[I_VLB] > 0.0
    if not (la or lb) or p[I_PUMP] > 0.5 or dps == 0.0:
        return
    z = _opening(y[Y_NU], p)
    pla, plb = _port_pressures(y, p)
    qa, qb = orifice_flows(z, pla, plb, ps_in, p[I_PT], p[I_K], p[I_PTR])
    _qa_z, _qa_pa, qa_ps, _qb_z, _qb_pb, qb_ps = orifice_flow_slopes(
        z, pla, plb, ps_in, p[I_PT], p[I_K], p[I_PTR]
    )
    qla, qlb = _line_flows(y, qa, qb, pla, plb, p)
    if la:
        dfdt[Y_PA] = 0.0
        dfdt[Y_PLA] = _line_gain(pla, qa - qla, p[I_VLA], p) * qa_ps * dps
    if lb:
        dfdt[Y_PB] = 0.0
        dfdt[Y_PLB] = -_line_gain(plb, qlb - qb, p[I_VLB], p) * qb_ps * dps
