"""Physics of the components, written once.

Each function is a small pure function of floats, compiled with numba so the
solver loop calls it without Python overhead; it is equally callable from
Python (tests, identification, plots). The full, reduced and PWA models are
assemblies of these functions (see :mod:`hydropwa.simulation._kernel`).

All quantities are SI: pressures in Pa (gauge, tank = 0 unless set), flows in
m³/s, positions in m, forces in N. The valve command ``u``, the spool position
``nu`` and the orifice opening ``z`` are fractions of the full opening [1].
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit, types
from numba.extending import overload

from .. import _jitcache  # noqa: F401  (one cache stamp for all compiled modules)

__all__ = [
    "servo_valve_acceleration",
    "dead_zone",
    "dead_zone_slope",
    "signed_sqrt",
    "signed_sqrt_slope",
    "orifice_flows",
    "orifice_flow_slopes",
    "load_flow_drop",
    "load_flow",
    "load_flow_slope",
    "load_flow_input_slopes",
    "effective_bulk_modulus",
    "effective_bulk_modulus_slope",
    "chamber_pressure_rates",
    "external_leakage_flow",
    "load_pressure_gain",
    "load_pressure_rate",
    "asymmetric_load_pressure_rate",
    "chamber_pressures_from_load",
    "load_pressure_range",
    "chamber_pressure_difference_slopes",
    "load_capacitance",
    "load_capacitance_slope",
    "stribeck_friction",
    "stribeck_friction_slope",
    "end_stop_force",
    "end_stop_force_slope",
    "specimen_force",
    "specimen_force_slope",
    "piston_acceleration",
    "net_piston_force",
    "pump_supply_rate",
    "pump_supply_rate_slope",
    "supply_flow",
    "hose_flow",
    "accumulator_pressure_rate",
    "line_flow",
    "line_flow_slope",
    "series_bulk_modulus",
    "series_bulk_modulus_slope",
]

#: numba options of the compiled components. ``error_model="numpy"``: a division by zero gives
#: inf or NaN, as in NumPy, instead of a test-and-raise on every division (parameters are
#: validated positive, and the solver rejects non-finite steps).
_JIT: dict[str, Any] = {"cache": True, "nogil": True, "fastmath": False, "error_model": "numpy"}


def smooth_sign(x):
    """tanh(x), the smooth sign of the friction law, Eq. (11); elementwise on arrays.

    Called from Python (arrays) this is NumPy's SIMD ``np.tanh``. Compiled code gets the
    scalar form expm1(2|x|)/(expm1(2|x|) + 2) with the sign of x, and ±1 for |x| ≥ 20 where
    tanh rounds to 1 anyway (see the overload below): within 2 ulp of libm's tanh, exactly
    odd, and about 1 ns instead of 11 ns in the sliding regime that dominates a simulation.
    """
    return np.tanh(x)


@overload(smooth_sign, jit_options={"nogil": True, "fastmath": False, "error_model": "numpy"})
def _smooth_sign_compiled(x):
    if isinstance(x, types.Float):

        def scalar(x):
            ax = abs(x)
            if ax >= 20.0:  # also ±inf; the common case in sliding friction (|γẋ| ≥ 20)
                return math.copysign(1.0, x)
            e = math.expm1(2.0 * ax)
            return math.copysign(e / (e + 2.0), x)

        return scalar
    return lambda x: np.tanh(x)


def abs_power(x, delta):
    """|x|^δ for δ > 0, elementwise on arrays (the Stribeck decay of Eq. (11)).

    Called from Python this is NumPy's power; compiled code gets exp(δ·ln|x|), 0 at x = 0
    (about 2 ns cheaper than libm's pow, within a few ulp of it).
    """
    return np.abs(x) ** delta


@overload(abs_power, jit_options={"nogil": True, "fastmath": False, "error_model": "numpy"})
def _abs_power_compiled(x, delta):
    if isinstance(x, types.Float):

        def scalar(x, delta):
            ax = abs(x)
            return math.exp(delta * math.log(ax)) if ax > 0.0 else 0.0

        return scalar
    return lambda x, delta: np.abs(x) ** delta


@njit(**_JIT)
def servo_valve_acceleration(nu: float, dnu: float, u: float, omega0: float, zeta: float) -> float:
    """Spool acceleration ν̈ [1/s²] of the second-order servo valve, Eq. (3).

    ν̈ = ω0² (u − ν) − 2 ζ ω0 ν̇, i.e. G(s) = ω0² / (s² + 2ζω0 s + ω0²), Eq. (1).
    """
    return omega0 * omega0 * (u - nu) - 2.0 * zeta * omega0 * dnu


@njit(**_JIT)
def dead_zone(nu: float, alpha: float, beta: float, creep: float, outer_offset: float) -> float:
    """Orifice opening z = h(ν) [1]: dead band with creep and saturation, Eqs. (2), (4), Table IV.

    Parameters
    ----------
    nu : float
        Spool position ν [1].
    alpha : float
        Saturation α [1].
    beta : float
        Dead-band half width β [1].
    creep : float
        Slope inside the band [1] (Table IV cell III; 0 gives Eq. (2) exactly).
    outer_offset : float
        Offset of the outer cells [1]: β as in Table IV, or β(1 − creep) for a
        continuous characteristic.

    Notes
    -----
    z = creep·ν for |ν| < β, α·sign(ν) for |ν| ≥ α + offset, ν − offset·sign(ν) otherwise.
    """
    a = abs(nu)
    if a < beta:
        return creep * nu
    s = 1.0 if nu > 0.0 else -1.0
    if a >= alpha + outer_offset:
        return s * alpha
    return nu - s * outer_offset


@njit(**_JIT)
def dead_zone_slope(
    nu: float, alpha: float, beta: float, creep: float, outer_offset: float
) -> float:
    """Slope dz/dν [1] of :func:`dead_zone` (same cells): creep in the band, 1 in the open cells, 0 saturated."""
    a = abs(nu)
    if a < beta:
        return creep
    if a >= alpha + outer_offset:
        return 0.0
    return 1.0


@njit(**_JIT)
def signed_sqrt(dp: float, p_tr: float) -> float:
    """Regularised signed square root sign(Δp)·√|Δp| [√Pa] (docs/errata.md E3).

    Below the transition pressure p_tr the turbulent law is replaced by the odd
    cubic √p_tr·(1.25 s − 0.25 s³), s = Δp/p_tr, which matches value and slope
    at |Δp| = p_tr and has the finite slope 1.25/√p_tr at zero (laminar flow).
    """
    a = abs(dp)
    if a >= p_tr:
        r = math.sqrt(a)
        return r if dp > 0.0 else -r
    s = dp / p_tr
    return math.sqrt(p_tr) * (1.25 * s - 0.25 * s * s * s)


@njit(**_JIT)
def signed_sqrt_slope(dp: float, p_tr: float) -> float:
    """Slope d/dΔp of :func:`signed_sqrt` [1/√Pa]: 1/(2√|Δp|) outside the laminar band.

    Inside, the derivative of the cubic, (1.25 − 0.75 s²)/√p_tr with s = Δp/p_tr;
    both branches give 1/(2√p_tr) at |Δp| = p_tr (continuous, finite everywhere).
    """
    a = abs(dp)
    if a >= p_tr:
        return 0.5 / math.sqrt(a)
    s = dp / p_tr
    return (1.25 - 0.75 * s * s) / math.sqrt(p_tr)


@njit(**_JIT)
def orifice_flows(z: float, p_a: float, p_b: float, p_s: float, p_t: float, K: float, p_tr: float):
    """Flows through the valve's metering edges, Eqs. (5)–(6), signed.

    Returns
    -------
    q_a : float
        Flow into chamber A [m³/s] (from supply for z > 0, to tank for z < 0).
    q_b : float
        Flow *out of* chamber B [m³/s] (to tank for z > 0, from supply for z < 0);
        Eq. (9) therefore uses −Q_B (docs/errata.md E1).

    Notes
    -----
    Reversed pressure drops reverse the flow through the signed root.
    """
    if z >= 0.0:
        q_a = z * K * signed_sqrt(p_s - p_a, p_tr)
        q_b = z * K * signed_sqrt(p_b - p_t, p_tr)
    else:
        q_a = z * K * signed_sqrt(p_a - p_t, p_tr)
        q_b = z * K * signed_sqrt(p_s - p_b, p_tr)
    return q_a, q_b


@njit(**_JIT)
def orifice_flow_slopes(
    z: float, p_a: float, p_b: float, p_s: float, p_t: float, K: float, p_tr: float
):
    """Partial derivatives of :func:`orifice_flows`, Eqs. (5)–(6), for the exact Jacobian.

    Returns
    -------
    tuple of float
        (∂Q_A/∂z, ∂Q_A/∂P_A, ∂Q_A/∂P_S, ∂Q_B/∂z, ∂Q_B/∂P_B, ∂Q_B/∂P_S) in [m³/s],
        [m³/(s·Pa)]. Q_A = z K r(Δp_A) depends on z linearly within a flow direction (the
        edge switches at z = 0, where Q = 0 on both sides), on P_A and P_S through the root
        r of :func:`signed_sqrt` (slope :func:`signed_sqrt_slope`); likewise Q_B.
    """
    zk = z * K
    if z >= 0.0:
        da, db = p_s - p_a, p_b - p_t
        ga = zk * signed_sqrt_slope(da, p_tr)
        gb = zk * signed_sqrt_slope(db, p_tr)
        return K * signed_sqrt(da, p_tr), -ga, ga, K * signed_sqrt(db, p_tr), gb, 0.0
    da, db = p_a - p_t, p_s - p_b
    ga = zk * signed_sqrt_slope(da, p_tr)
    gb = zk * signed_sqrt_slope(db, p_tr)
    return K * signed_sqrt(da, p_tr), ga, 0.0, K * signed_sqrt(db, p_tr), -gb, gb


@njit(**_JIT)
def supply_flow(z: float, q_a: float, q_b: float) -> float:
    """Flow drawn from the supply port [m³/s] given the edge flows of :func:`orifice_flows`."""
    return q_a if z >= 0.0 else -q_b


@njit(**_JIT)
def load_flow_drop(z: float, p_l: float, p_s: float, alpha: float = 1.0, p_t: float = 0.0) -> float:
    """Pressure drop [Pa] across each metering edge of a single-rod cylinder under the
    quasi-steady flow ratio Q_B = α·Q_A (α = A_B/A_A), the load pressure being P_L = P_A − α P_B.

    Extension (z ≥ 0): P_S − P_A = (P_B − P_T)/α² = (P_S − α P_T − P_L)/(1 + α³).
    Retraction (z < 0): P_A − P_T = (P_S − P_B)/α² = (α P_S − P_T + P_L)/(1 + α³).
    With α = 1 and P_T = 0 this is ½(P_S ∓ P_L), the drop of Eq. (12).
    See docs/reduced_asymmetric.md ("Asymmetric reduced model") for the derivation.
    """
    if z >= 0.0:
        return (p_s - alpha * p_t - p_l) / (1.0 + alpha * alpha * alpha)
    return (alpha * p_s - p_t + p_l) / (1.0 + alpha * alpha * alpha)


@njit(**_JIT)
def load_flow(
    z: float, p_l: float, p_s: float, K: float, p_tr: float, alpha: float = 1.0, p_t: float = 0.0
) -> float:
    """Load flow Q_L = Q_A [m³/s] into chamber A, Eq. (12) generalised to a single-rod cylinder.

    Q_L = z K √Δp with the edge drop Δp of :func:`load_flow_drop` (signed, regularised
    root). α = 1, P_T = 0 give the paper's Q_L = z K √(½ (P_S − sign(z) P_L)).
    """
    return z * K * signed_sqrt(load_flow_drop(z, p_l, p_s, alpha, p_t), p_tr)


@njit(**_JIT)
def load_flow_slope(
    z: float, p_l: float, p_s: float, K: float, p_tr: float, alpha: float = 1.0, p_t: float = 0.0
) -> float:
    """∂Q_L/∂P_L [m³/(s·Pa)] of :func:`load_flow` (≤ 0: the flow-pressure coefficient −K_c).

    ∂Δp/∂P_L = ∓1/(1 + α³) for z ≷ 0, so ∂Q_L/∂P_L = −|z| K (d√/dΔp)/(1 + α³).
    """
    a3 = 1.0 + alpha * alpha * alpha
    d = signed_sqrt_slope(load_flow_drop(z, p_l, p_s, alpha, p_t), p_tr) / a3
    return -z * K * d if z >= 0.0 else z * K * d


@njit(**_JIT)
def load_flow_input_slopes(
    z: float, p_l: float, p_s: float, K: float, p_tr: float, alpha: float = 1.0, p_t: float = 0.0
):
    """How :func:`load_flow` follows its inputs: (∂Q_L/∂z [m³/s], ∂Q_L/∂P_S [m³/(s·Pa)]).

    ∂Q_L/∂z = K·√Δp is the flow gain K_q of Eq. (12); ∂Q_L/∂P_S = z K (d√/dΔp)·∂Δp/∂P_S
    with ∂Δp/∂P_S = 1/(1 + α³) (extension) or α/(1 + α³) (retraction). Used for the exact
    time derivative ∂f/∂t and the input matrix B of the reduced and PWA models.
    """
    drop = load_flow_drop(z, p_l, p_s, alpha, p_t)
    a3 = 1.0 + alpha * alpha * alpha
    dd = 1.0 / a3 if z >= 0.0 else alpha / a3
    return K * signed_sqrt(drop, p_tr), z * K * signed_sqrt_slope(drop, p_tr) * dd


@njit(**_JIT)
def chamber_pressures_from_load(
    z: float, p_l: float, p_s: float, alpha: float = 1.0, p_t: float = 0.0
):
    """Chamber pressures (P_A, P_B) [Pa] recovered from P_L = P_A − α P_B in quasi-steady flow.

    Extension: P_A = P_S − Δp, P_B = P_T + α² Δp; retraction: P_A = P_T + Δp,
    P_B = P_S − α² Δp, Δp from :func:`load_flow_drop`. α = 1, P_T = 0 give Eq. (13),
    P_A,B = ½ (P_S ± P_L), in both directions. Both satisfy P_A − α P_B = P_L exactly.
    """
    drop = load_flow_drop(z, p_l, p_s, alpha, p_t)
    if z >= 0.0:
        return p_s - drop, p_t + alpha * alpha * drop
    return p_t + drop, p_s - alpha * alpha * drop


def load_pressure_range(
    direction: int, p_s: float, alpha: float = 1.0, p_t: float = 0.0
) -> tuple[float, float]:
    """Load pressures P_L = P_A − α P_B [Pa] at which the valve meters steadily in one direction
    with both chambers between tank and supply pressure.

    Along :func:`chamber_pressures_from_load` the edge drop Δp runs from 0 (the cylinder
    stalls: P_L = P_S − α P_T extending, P_T − α P_S retracting) to the drop at which one
    chamber reaches tank or supply pressure, Δp_max = (P_S − P_T)·min(1, 1/α²):

    - extension (``direction`` > 0): [P_S − α P_T − (1 + α³) Δp_max, P_S − α P_T];
    - retraction (``direction`` < 0): [P_T − α P_S, P_T − α P_S + (1 + α³) Δp_max].

    With P_T = 0 and α ≤ 1: [−α³ P_S, P_S] and [−α P_S, (1 − α + α³) P_S]; α = 1 gives the
    paper's |P_L| ≤ P_S (Eq. (13)) in both directions. Beyond the lower end extending (upper
    end retracting) the chamber that is filled cavitates (exceeds the supply pressure).
    """
    a3 = 1.0 + alpha * alpha * alpha
    span = a3 * (p_s - p_t) * min(1.0, 1.0 / (alpha * alpha))
    if direction > 0:
        return p_s - alpha * p_t - span, p_s - alpha * p_t
    return p_t - alpha * p_s, p_t - alpha * p_s + span


@njit(**_JIT)
def chamber_pressure_difference_slopes(z: float, alpha: float = 1.0):
    """(∂(P_A − P_B)/∂P_L, ∂(P_A − P_B)/∂P_S) [1] of :func:`chamber_pressures_from_load`.

    P_A − P_B = P_L + (α − 1) P_B is affine in P_L and P_S: ∂/∂P_L = (1 + α²)/(1 + α³) in both
    directions; ∂/∂P_S = 1 − (1 + α²)/(1 + α³) (extension) or (1 + α²)α/(1 + α³) − 1
    (retraction). Both are 1 and 0 for α = 1 (Eq. (13): P_A − P_B = P_L).
    """
    a3 = 1.0 + alpha * alpha * alpha
    r = (1.0 + alpha * alpha) / a3
    if z >= 0.0:
        return r, 1.0 - r
    return r, r * alpha - 1.0


@njit(**_JIT)
def load_capacitance(
    x: float, area_a: float, area_b: float, stroke: float, vol_a: float, vol_b: float, E: float
):
    """Hydraulic capacitances of the asymmetric load-pressure equation at rod position x [m].

    Returns (c_q, c_l) [Pa/m³]: c_q = E (1/V_A(x) + α²/V_B(x)) multiplies the net load flow
    Q_L − A_A ẋ, c_l = E (1/V_A(x) + α/V_B(x)) the leakage C_L (P_A − P_B), with
    V_A = V_A0 + A_A x, V_B = V_B0 + A_B (l − x), x clipped to the stroke. From
    Ṗ_L = Ṗ_A − α Ṗ_B with Eq. (9) and Q_B = α Q_A; α = 1 at mid-stroke gives 4E/V_t of Eq. (14).
    """
    xs = min(max(x, 0.0), stroke)
    alpha = area_b / area_a
    ia = 1.0 / (vol_a + area_a * xs)
    ib = 1.0 / (vol_b + area_b * (stroke - xs))
    return E * (ia + alpha * alpha * ib), E * (ia + alpha * ib)


@njit(**_JIT)
def load_capacitance_slope(
    x: float, area_a: float, area_b: float, stroke: float, vol_a: float, vol_b: float, E: float
):
    """∂(c_q, c_l)/∂x [Pa/m⁴] of :func:`load_capacitance` (zero outside the stroke, where x is clipped)."""
    if x <= 0.0 or x >= stroke:
        return 0.0, 0.0
    alpha = area_b / area_a
    va = vol_a + area_a * x
    vb = vol_b + area_b * (stroke - x)
    da = -area_a / (va * va)
    db = area_b / (vb * vb)
    return E * (da + alpha * alpha * db), E * (da + alpha * db)


@njit(**_JIT)
def effective_bulk_modulus(
    p: float, E: float, p_vap: float, p_rel: float, net_flow: float = 1.0
) -> float:
    """Effective bulk modulus [Pa] that keeps a chamber pressure physical.

    Between the air-release pressure p_rel and the vapour pressure p_vap the modulus
    falls linearly with the pressure. While the chamber is being emptied (net inflow
    ``net_flow`` [m³/s] < 0) it reaches zero at p_vap: the pressure approaches p_vap
    (≈ absolute zero) exponentially and stays there while vapour fills the deficit
    (cavitation). Below p_vap, which only an integration step can overshoot into, the
    modulus turns negative, so the rate pulls the pressure back up to p_vap. While the
    chamber is being filled the modulus keeps a floor of 0.1 % E, so a cavitated chamber
    recovers as soon as oil flows in again.
    """
    if p >= p_rel:
        return E
    frac = (p - p_vap) / (p_rel - p_vap)
    if net_flow >= 0.0 and frac < 1e-3:
        frac = 1e-3
    return E * frac


@njit(**_JIT)
def effective_bulk_modulus_slope(
    p: float, E: float, p_vap: float, p_rel: float, net_flow: float = 1.0
) -> float:
    """∂E_eff/∂p [1] of :func:`effective_bulk_modulus` at fixed net flow (same branches).

    E/(p_rel − p_vap) on the falling branch below the release pressure, zero above it and on
    the 0.1 % floor of a chamber being filled.
    """
    if p >= p_rel:
        return 0.0
    frac = (p - p_vap) / (p_rel - p_vap)
    if net_flow >= 0.0 and frac < 1e-3:
        return 0.0
    return E / (p_rel - p_vap)


@njit(**_JIT)
def external_leakage_flow(p: float, leak: float) -> float:
    """External leakage Q_e = C_e · P [m³/s] out of a chamber at gauge pressure P [Pa].

    Laminar flow past a worn rod or port seal to the ambient (gauge 0 Pa), linear in the
    pressure like the piston leakage of Eq. (9); C_e [m³/(s·Pa)]. Its pressure slope is C_e.
    """
    return leak * p


@njit(**_JIT)
def chamber_pressure_rates(
    q_a: float,
    q_b: float,
    x: float,
    v: float,
    p_a: float,
    p_b: float,
    area_a: float,
    area_b: float,
    stroke: float,
    vol_a: float,
    vol_b: float,
    leak: float,
    E: float,
    p_vap: float,
    p_rel: float,
    leak_a: float = 0.0,
    leak_b: float = 0.0,
):
    """Pressure rates Ṗ_A, Ṗ_B [Pa/s] from continuity, Eq. (9) with the corrected sign of Q_B.

    Ṗ_A = E/(V_A + A_A x) · (Q_A − A_A ẋ + C_L (P_B − P_A) − C_eA P_A)
    Ṗ_B = E/(V_B + A_B (l − x)) · (−Q_B + A_B ẋ + C_L (P_A − P_B) − C_eB P_B)

    ``leak_a``, ``leak_b`` are the external leakage coefficients C_eA, C_eB [m³/(s·Pa)] of
    each chamber to the ambient (gauge 0 Pa; :func:`external_leakage_flow`); 0 in the paper.
    """
    va = vol_a + area_a * x
    vb = vol_b + area_b * (stroke - x)
    net_a = q_a - area_a * v + leak * (p_b - p_a) - external_leakage_flow(p_a, leak_a)
    net_b = -q_b + area_b * v + leak * (p_a - p_b) - external_leakage_flow(p_b, leak_b)
    dpa = effective_bulk_modulus(p_a, E, p_vap, p_rel, net_a) / va * net_a
    dpb = effective_bulk_modulus(p_b, E, p_vap, p_rel, net_b) / vb * net_b
    return dpa, dpb


@njit(**_JIT)
def load_pressure_gain(E: float, total_volume: float) -> float:
    """4E/V_t [Pa/m³]: the load-pressure rise per unit of net load flow, the factor of Eq. (14)."""
    return 4.0 * E / total_volume


@njit(**_JIT)
def load_pressure_rate(
    q_l: float, v: float, p_l: float, mean_area: float, total_volume: float, leak: float, E: float
):
    """Load-pressure rate Ṗ_L [Pa/s] of the paper's reduced model, Eq. (14) (mean area Ā)."""
    return load_pressure_gain(E, total_volume) * (q_l - mean_area * v - leak * p_l)


@njit(**_JIT)
def asymmetric_load_pressure_rate(
    q_l: float, v: float, dp_ab: float, area_a: float, c_q: float, c_l: float, leak: float
):
    """Load-pressure rate Ṗ_L [Pa/s] of the single-rod reduced model, P_L = P_A − α P_B.

    Ṗ_L = c_q (Q_L − A_A ẋ) − c_l C_L (P_A − P_B), the capacitances c_q, c_l of
    :func:`load_capacitance`; Ṗ_A − α Ṗ_B from Eq. (9) under Q_B = α Q_A.
    """
    return c_q * (q_l - area_a * v) - c_l * leak * dp_ab


@njit(**_JIT)
def stribeck_friction(v, f_c, f_s, sigma, chi, delta, gamma):
    """Stribeck friction force f(ẋ) [N], Eq. (11).

    f = tanh(γ ẋ) (F_c + (F_s − F_c) exp(−|ẋ/χ|^δ)) + σ ẋ. Works on floats and
    on numpy arrays of velocities [m/s]; odd in ẋ by construction.
    """
    # v·(1/χ) rather than v/χ: the division then depends on χ alone, off the solver's critical path
    return (
        smooth_sign(gamma * v) * (f_c + (f_s - f_c) * np.exp(-abs_power(v * (1.0 / chi), delta)))
        + sigma * v
    )


@njit(**_JIT)
def stribeck_friction_slope(
    v: float, f_c: float, f_s: float, sigma: float, chi: float, delta: float, gamma: float
) -> float:
    """Slope df/dẋ [N·s/m] of the Stribeck friction of Eq. (11), for one velocity [m/s].

    With B = F_c + (F_s − F_c) e^(−a^δ), a = |ẋ/χ|, and T = tanh(γẋ):
    df/dẋ = γ(1 − T²) B − (T/ẋ)(F_s − F_c) δ a^δ e^(−a^δ) + σ,
    where T/ẋ → γ at ẋ = 0, so the slope is finite for any shape δ > 0 (the singular
    a^(δ−1) of the Stribeck term is cancelled by tanh); at rest it is γF_s + σ.
    Used by the solver's Jacobians and by the tangent friction cells.
    """
    T = smooth_sign(gamma * v)
    ad = abs_power(v * (1.0 / chi), delta)
    e = math.exp(-ad)
    b = f_c + (f_s - f_c) * e
    t_over_v = T / v if v != 0.0 else gamma
    return gamma * (1.0 - T * T) * b - t_over_v * (f_s - f_c) * delta * ad * e + sigma


@njit(**_JIT)
def end_stop_force(x: float, v: float, stroke: float, k: float, c: float) -> float:
    """Contact force of the end stops on the piston [N], positive towards +x.

    A stiff spring–damper acts only while the piston is outside 0 ≤ x ≤ l, and
    it only pushes (never pulls), so the piston leaves a stop freely.
    """
    if x < 0.0:
        f = -k * x - c * v
        return f if f > 0.0 else 0.0
    if x > stroke:
        f = -k * (x - stroke) - c * v
        return f if f < 0.0 else 0.0
    return 0.0


def net_piston_force(p_a, p_b, f_l, area_a, area_b):
    """Hydraulic force minus load, P_A·A_A − P_B·A_B − F_L [N], Eq. (10).

    With the rod at steady speed this is the friction force f(ẋ) (docs/errata.md E11); minus
    m·ẍ it is the friction force at any instant. Floats or numpy arrays.
    """
    return (
        np.asarray(p_a, dtype=float) * area_a
        - np.asarray(p_b, dtype=float) * area_b
        - np.asarray(f_l, dtype=float)
    )


@njit(**_JIT)
def end_stop_force_slope(x: float, v: float, stroke: float, k: float, c: float):
    """Partial derivatives (∂F/∂x [N/m], ∂F/∂ẋ [N·s/m]) of :func:`end_stop_force`."""
    if x < 0.0:
        if -k * x - c * v > 0.0:
            return -k, -c
    elif x > stroke:
        if -k * (x - stroke) - c * v < 0.0:
            return -k, -c
    return 0.0, 0.0


@njit(**_JIT)
def specimen_force(x: float, v: float, k: float, c: float, x_c: float, f_0: float) -> float:
    """Force of an elastic specimen or tool on the rod [N], positive opposing extension.

    A spring–damper the rod meets at the contact position x_c (a test specimen, a press tool,
    a spring return; a rigid wall is a stiff one): F = F_0 + k (x − x_c) + c ẋ while x > x_c,
    0 before. A contact only pushes: the force is clipped at 0, so the rod leaves it freely.
    With x_c ≤ 0 (at or below the stroke start) the spring is attached: it acts at every x and
    pulls as well as pushes (F_0 < 0 puts its rest position at x_c − F_0/k inside the stroke).

    Parameters
    ----------
    x, v : float
        Rod position [m] and velocity [m/s].
    k, c : float
        Specimen stiffness [N/m] and damping [N·s/m].
    x_c : float
        Contact position [m].
    f_0 : float
        Preload at contact [N].
    """
    if x_c > 0.0:
        if x <= x_c:
            return 0.0
        f = f_0 + k * (x - x_c) + c * v
        return f if f > 0.0 else 0.0
    return f_0 + k * (x - x_c) + c * v


@njit(**_JIT)
def specimen_force_slope(x: float, v: float, k: float, c: float, x_c: float, f_0: float):
    """Partial derivatives (∂F/∂x [N/m], ∂F/∂ẋ [N·s/m]) of :func:`specimen_force`."""
    if x_c > 0.0 and (x <= x_c or f_0 + k * (x - x_c) + c * v <= 0.0):
        return 0.0, 0.0
    return k, c


@njit(**_JIT)
def piston_acceleration(
    hydraulic_force: float, friction: float, load: float, stop: float, mass: float
) -> float:
    """Piston acceleration ẍ [m/s²] from Newton's law, Eqs. (10) and (15)."""
    # times the reciprocal: the division depends on the mass alone and runs alongside the forces
    return (hydraulic_force - friction - load + stop) * (1.0 / mass)


@njit(**_JIT)
def pump_supply_rate(
    p_s: float,
    q_draw: float,
    p_set: float,
    q_max: float,
    droop: float,
    v_line: float,
    E: float,
    p_relief: float,
    relief_gain: float,
) -> float:
    """Supply-pressure rate Ṗ_S [Pa/s] of a pressure-compensated pump (virtual rig, Fig. 9).

    The pump delivers q_max·clip((p_set − P_S)/droop, 0, 1) into the line volume;
    the valve draws ``q_draw``; a relief valve opens above ``p_relief``.
    At steady state P_S sags below p_set by droop·q_draw/q_max.
    """
    r = (p_set - p_s) / droop
    if r < 0.0:
        r = 0.0
    elif r > 1.0:
        r = 1.0
    q_relief = relief_gain * (p_s - p_relief) if p_s > p_relief else 0.0
    return E / v_line * (q_max * r - q_draw - q_relief)


@njit(**_JIT)
def pump_supply_rate_slope(
    p_s: float,
    v_line: float,
    E: float,
    q_max: float,
    p_set: float,
    droop: float,
    p_relief: float,
    relief_gain: float,
) -> tuple[float, float]:
    """Partial derivatives of :func:`pump_supply_rate`: (∂Ṗ_S/∂P_S [1/s], ∂Ṗ_S/∂q_draw [Pa/m³]).

    The pump's delivery falls with slope −q_max/droop inside its droop band, the relief valve
    adds −relief_gain above its pressure; the valve's draw enters with −E/V_line.
    """
    r = (p_set - p_s) / droop
    dr = -1.0 / droop if 0.0 < r < 1.0 else 0.0
    drel = relief_gain if p_s > p_relief else 0.0
    g = E / v_line
    return g * (q_max * dr - drel), -g


@njit(**_JIT)
def hose_flow(
    p_from: float, p_to: float, length: float, diameter: float, viscosity: float
) -> float:
    """Laminar flow [m³/s] through a hose, Hagen–Poiseuille: Q = π d⁴ (p_from − p_to) / (128 μ L).

    Not in the paper (its rig has no accumulator). Valid while the hose flow is laminar
    (Re = 4ρQ/(πμd) below about 2300); the hose's inertance is neglected.
    """
    return math.pi * diameter**4 / (128.0 * viscosity * length) * (p_from - p_to)


@njit(**_JIT)
def accumulator_pressure_rate(
    q: float,
    p: float,
    gas_volume: float,
    precharge: float,
    index: float,
    hose_volume: float,
    E: float,
    p_vap: float,
    p_rel: float,
) -> float:
    """Pressure rate Ṗ [Pa/s] of a gas accumulator with its hose, filled by the flow q [m³/s].

    Continuity on the node: q = C(P) Ṗ with the capacitance C = dV_oil/dP of the hose oil,
    V_h/E (Eq. (9)'s compressibility, with the cavitation model of
    :func:`effective_bulk_modulus`), plus, above the precharge pressure P_0, that of the gas
    (polytropic, P V_g^n = P_0 V_0^n): V_g = V_0 (P_0/P)^(1/n), so dV_oil/dP = V_g / (n P).
    Below P_0 the bladder lies on the poppet and only the hose oil is compliant. The precharge
    must be above the oil's release pressure (validated in :class:`~hydropwa.params.Accumulator`).
    Pressures are gauge (as everywhere in the package) and the gas law needs absolute ones:
    P + 1 bar.

    Parameters
    ----------
    q : float
        Flow into the accumulator node [m³/s].
    p : float
        Its pressure [Pa].
    gas_volume : float
        Gas volume V_0 at the precharge [m³] (the accumulator's nominal size).
    precharge : float
        Precharge pressure P_0 [Pa] (gauge).
    index : float
        Polytropic index n [1]: 1 isothermal (slow), 1.4 adiabatic (fast).
    hose_volume : float
        Oil volume of the hose [m³].
    E, p_vap, p_rel : float
        Bulk modulus [Pa], vapour and release pressures [Pa] of the oil.
    """
    if p <= precharge:  # only the hose oil (and, near p_vap, its cavitation)
        return effective_bulk_modulus(p, E, p_vap, p_rel, q) / hose_volume * q
    pa_abs = p + 1e5
    gas = gas_volume * (((precharge + 1e5) / pa_abs) ** (1.0 / index))
    return q / (hose_volume / E + gas / (index * pa_abs))


@njit(**_JIT)
def line_flow(dp: float, conductance: float, orifice: float, p_tr: float) -> float:
    """Flow [m³/s] through a hose line's resistance at the pressure drop ``dp`` [Pa] across it.

    Laminar (``orifice`` ≤ 0.5): Q = G ΔP. Orifice (``orifice`` > 0.5): the regularised
    square-root law of the valve's edges (:func:`signed_sqrt`, laminar below the transition
    pressure p_tr) scaled to the same conductance G at small drops,
    Q = G √p_tr / 1.25 · signed_sqrt(ΔP, p_tr), i.e. G p_tr/1.25 · √(ΔP/p_tr) above p_tr.
    Not in the paper (its valve sits on the cylinder). G [m³/(s·Pa)], p_tr [Pa].
    """
    if orifice > 0.5:
        return conductance * math.sqrt(p_tr) / 1.25 * signed_sqrt(dp, p_tr)
    return conductance * dp


@njit(**_JIT)
def series_bulk_modulus(E: float, wall: float) -> float:
    """Effective bulk modulus [Pa] of oil of modulus E in a hose whose wall has modulus ``wall``.

    Compliances in series: 1/E_eff = 1/E + 1/E_wall (Merritt 1967, Sec. 2.7); ``wall`` ≤ 0 is a
    rigid wall (E_eff = E). E is the oil's effective modulus at the line pressure
    (:func:`effective_bulk_modulus`, with its cavitation branch).
    """
    if wall <= 0.0:
        return E
    return E * wall / (E + wall)


@njit(**_JIT)
def line_flow_slope(dp: float, conductance: float, orifice: float, p_tr: float) -> float:
    """∂Q/∂ΔP [m³/(s·Pa)] of :func:`line_flow`: G laminar; G √p_tr/1.25 · signed_sqrt' for an orifice."""
    if orifice > 0.5:
        return conductance * math.sqrt(p_tr) / 1.25 * signed_sqrt_slope(dp, p_tr)
    return conductance


@njit(**_JIT)
def series_bulk_modulus_slope(E: float, wall: float) -> float:
    """∂E_eff/∂E [1] of :func:`series_bulk_modulus`: E_wall²/(E + E_wall)², 1 for a rigid wall."""
    if wall <= 0.0:
        return 1.0
    return wall * wall / ((E + wall) * (E + wall))
