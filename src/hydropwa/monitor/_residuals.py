"""The residual generator: the chamber continuity and motion equations regressed on a logged run.

Every term is computed from the measured signals with the package's component functions
(:mod:`hydropwa.components`: the valve opening, the metering flows, the Stribeck curve), so
the monitor's physics is the model's. Three linear least-squares problems per run:

- **Continuity** (Eq. (9) with the external leakage), both chambers stacked, unknowns
  θ = (1/E, C_L, C_eA, C_eB, δ) with δ the valve null offset (the metering flows linearised in
  it)::

      Q_A(ν) − A_A ẋ   =  V_A(x) Ṗ_A/E + C_L (P_A − P_B) + C_eA P_A − ∂Q_A/∂ν · δ
     −Q_B(ν) + A_B ẋ   =  V_B(x) Ṗ_B/E − C_L (P_A − P_B) + C_eB P_B + ∂Q_B/∂ν · δ

- **Motion** (Eq. (10)): the friction force F = A_A P_A − A_B P_B − f_l − m ẍ regressed on the
  Stribeck basis of Eq. (11) (χ, δ_s and γ held): unknowns (F_c, F_s − F_c, σ).
- **Supply**: the pump's set pressure from the measured P_S and its steady droop,
  p_set = P_S + droop · Q_S/Q_max (the ideal supply: p_set = P_S).

Derivatives and smoothing are one Savitzky–Golay filter applied to every channel, so the
equations hold between filtered signals; rows are decimated to about one per filter window,
so their errors are close to independent.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from .. import _jitcache  # noqa: F401  (one cache stamp for all compiled modules)
from ..components import dead_zone, dead_zone_slope, orifice_flows, stribeck_friction
from ..params import SystemParams

__all__ = [
    "N_P",
    "N_S",
    "LinearFit",
    "Signals",
    "continuity_fit",
    "friction_fit",
    "friction_level_weights",
    "friction_scale_fit",
    "monitor_result",
    "monitor_row",
    "monitor_rows",
    "prepare",
    "sliding_speed",
    "spool_fit",
    "supply_fit",
    "valve_row",
]


@dataclass(frozen=True)
class Signals:
    """A run's filtered signals on the decimated rows, SI (see :func:`prepare`)."""

    t: np.ndarray
    u: np.ndarray
    nu: np.ndarray
    nu_model: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    p_a: np.ndarray
    p_b: np.ndarray
    dp_a: np.ndarray
    dp_b: np.ndarray
    p_s: np.ndarray | None
    f_l: np.ndarray | None
    measured_supply: bool
    measured_spool: bool
    speed_noise: float


@dataclass(frozen=True)
class LinearFit:
    """A weighted least-squares estimate of θ.

    Attributes
    ----------
    theta : ndarray
        The estimate (SI).
    cov : ndarray
        Its covariance, scaled by the residuals' autocorrelation (:func:`_correlation_factor`).
    rms : tuple of float
        Residual RMS per block (SI).
    rows : int
        Rows used.
    """

    theta: np.ndarray
    cov: np.ndarray
    rms: tuple[float, ...]
    rows: int

    @property
    def std(self) -> np.ndarray:
        """Standard errors of θ (SI)."""
        return np.sqrt(np.clip(np.diag(self.cov), 0.0, None))


def _correlation_factor(r: np.ndarray, lags: int = 20) -> float:
    """Variance inflation 1 + 2 Σ ρ_k (Bartlett window) of correlated residuals, at least 1.

    Least squares' covariance assumes independent rows; the equation errors of neighbouring
    rows share the filter and the model's slow errors, so the effective number of rows is
    smaller by this factor.
    """
    r = r - r.mean()
    d = float(r @ r)
    if d <= 0.0 or r.size <= 2 * lags:
        return 1.0
    rho = np.array([float(r[:-k] @ r[k:]) / d for k in range(1, lags + 1)])
    w = 1.0 - np.arange(1, lags + 1) / (lags + 1)
    return max(1.0, 1.0 + 2.0 * float(np.sum(w * rho)))


def _savgol(y: np.ndarray, window: int, deriv: int, dt: float) -> np.ndarray:
    from scipy.signal import savgol_filter  # deferred: scipy.signal costs ~0.2 s at import

    # edges: the rows within one window of either end are not used (see prepare)
    return savgol_filter(y, window, 3, deriv=deriv, delta=dt, mode="nearest")


def _spool(u: np.ndarray, dt: float, omega0: float, zeta: float) -> np.ndarray:
    """ν(t) of the servo valve, Eq. (3), driven by the logged command, settled at u(0).

    The first-order-hold discretisation is exact for a command linear between samples.
    """
    from scipy.signal import cont2discrete, lfilter, lfilter_zi  # deferred: scipy.signal

    w2 = omega0 * omega0
    num, den, _ = cont2discrete(([w2], [1.0, 2.0 * zeta * omega0, w2]), dt, method="foh")
    b, a = np.ravel(num), np.ravel(den)
    y, _ = lfilter(b, a, u, zi=lfilter_zi(b, a) * u[0])
    return np.asarray(y, dtype=float)


def prepare(
    channels: dict[str, np.ndarray], fs: float, params: SystemParams, window_s: float
) -> Signals:
    """Filter a run's channels and keep about one row per filter window.

    Parameters
    ----------
    channels : dict of arrays
        ``t`` [s], ``u`` [1], ``x`` [m], ``p_a``, ``p_b`` [Pa]; optional ``p_s`` [Pa],
        ``f_l`` [N], ``spool`` [1] (the valve's spool signal, else ν from Eq. (3)).
    fs : float
        Sampling rate [Hz].
    params : SystemParams
        The identified machine (the valve's ω0, ζ when the spool is not measured).
    window_s : float
        Savitzky–Golay window [s] (cubic; the smoothing and differentiating filter).
    """
    t = np.asarray(channels["t"], float)
    dt = 1.0 / fs
    w = max(7, int(round(window_s * fs)) | 1)
    u = np.asarray(channels["u"], float)
    spool = channels.get("spool")
    omega = params.valve.omega0_at(float(np.max(np.abs(u))))
    nu_model = _spool(u, dt, omega, params.valve.zeta)
    nu = nu_model if spool is None else np.asarray(spool, float)

    def f(name: str, deriv: int = 0) -> np.ndarray:
        return _savgol(np.asarray(channels[name], float), w, deriv, dt)

    sl = slice(w, t.size - w, max(1, w // 2))
    # the speed's noise: the position's high-frequency residual through the filter's gain
    x = np.asarray(channels["x"], float)
    impulse = np.zeros(w)
    impulse[w // 2] = 1.0
    gain = float(np.linalg.norm(_savgol(impulse, w, 1, dt)))
    x_noise = float(np.std(np.diff(x, 2))) / np.sqrt(6.0)
    p_s = f("p_s")[sl] if "p_s" in channels else None
    f_l = f("f_l")[sl] if "f_l" in channels else None
    return Signals(
        t=t[sl],
        u=u[sl],
        nu=_savgol(nu, w, 0, dt)[sl],
        nu_model=_savgol(nu_model, w, 0, dt)[sl],
        x=f("x")[sl],
        v=f("x", 1)[sl],
        a=f("x", 2)[sl],
        p_a=f("p_a")[sl],
        p_b=f("p_b")[sl],
        dp_a=f("p_a", 1)[sl],
        dp_b=f("p_b", 1)[sl],
        p_s=p_s,
        f_l=f_l,
        measured_supply=p_s is not None,
        measured_spool=spool is not None,
        speed_noise=x_noise * gain,
    )


@njit(cache=True)
def valve_row(s, pa, pb, ps, pt, K, ptr, alpha, beta, creep, outer):  # pragma: no cover
    """One row: Q_A, Q_B [m³/s] at the spool ``s`` and their slopes ∂Q/∂ν (dead zone's cells).

    Scalar, in the C emitter's subset (:mod:`hydropwa.simulation._emit_c`): the on-target
    generator (:func:`monitor_row`) and :func:`_valve_terms` share it.
    """
    z = dead_zone(s, alpha, beta, creep, outer)
    qa, qb = orifice_flows(z, pa, pb, ps, pt, K, ptr)
    dz = dead_zone_slope(s, alpha, beta, creep, outer)
    h = 1e-6
    qa1, qb1 = orifice_flows(z + h, pa, pb, ps, pt, K, ptr)
    qa0, qb0 = orifice_flows(z - h, pa, pb, ps, pt, K, ptr)
    return qa, qb, (qa1 - qa0) / (2 * h) * dz, (qb1 - qb0) / (2 * h) * dz


@njit(cache=True)
def _valve_terms(nu, pa, pb, ps, null, pt, K, ptr, alpha, beta, creep, outer):  # pragma: no cover
    """Per row: Q_A, Q_B [m³/s] at ν + δ and their slopes ∂Q/∂ν by the dead zone's cells."""
    n = nu.shape[0]
    qa = np.empty(n)
    qb = np.empty(n)
    ga = np.empty(n)
    gb = np.empty(n)
    for k in range(n):
        qa[k], qb[k], ga[k], gb[k] = valve_row(
            nu[k] + null, pa[k], pb[k], ps[k], pt, K, ptr, alpha, beta, creep, outer
        )
    return qa, qb, ga, gb


def _supply_pressure(sig: Signals, params: SystemParams) -> np.ndarray:
    return sig.p_s if sig.p_s is not None else np.full(sig.t.size, params.supply.pressure)


def _wls(blocks: list[tuple[np.ndarray, np.ndarray]], scale: np.ndarray) -> LinearFit:
    """Least squares of stacked blocks (A_i θ = y_i), each weighted by its residual RMS.

    Two passes: ordinary, then each block divided by its own residual RMS, so blocks of
    different noise count by their information. ``scale`` conditions the columns.
    """
    weights = [1.0] * len(blocks)
    for _ in range(2):
        A = np.vstack(
            [b[0] * (s / w) for b, w, s in zip(blocks, weights, [scale] * len(blocks), strict=True)]
        )
        y = np.concatenate([b[1] / w for b, w in zip(blocks, weights, strict=True)])
        sol, *_ = np.linalg.lstsq(A, y, rcond=None)
        theta = sol * scale
        rms = [float(np.sqrt(np.mean((b[1] - b[0] @ theta) ** 2))) + 1e-300 for b in blocks]
        weights = rms
    A = np.vstack([b[0] * (scale / w) for b, w in zip(blocks, weights, strict=True)])
    y = np.concatenate([b[1] / w for b, w in zip(blocks, weights, strict=True)])
    sol, *_ = np.linalg.lstsq(A, y, rcond=None)
    theta = sol * scale
    dof = max(1, A.shape[0] - A.shape[1])
    res = y - A @ sol
    s2 = float(res @ res) / dof * _correlation_factor(res)
    cov = s2 * np.linalg.pinv(A.T @ A) * np.outer(scale, scale)
    return LinearFit(theta=theta, cov=cov, rms=tuple(weights), rows=int(A.shape[0]))


#: Column scales of the continuity unknowns (1/E, C_L, C_eA, C_eB, δ): typical magnitudes.
CONTINUITY_SCALE = np.array([1e-9, 1e-12, 1e-12, 1e-12, 1e-2])


def continuity_fit(sig: Signals, params: SystemParams, mask: np.ndarray) -> LinearFit:
    """(1/E, C_L, C_eA, C_eB, δ) from both chambers' continuity (module docstring)."""
    c, fl, dz = params.cylinder, params.flow, params.dead_zone
    ps = _supply_pressure(sig, params)
    qa, qb, ga, gb = _valve_terms(
        sig.nu,
        sig.p_a,
        sig.p_b,
        ps,
        0.0,
        params.supply.tank_pressure,
        fl.K,
        fl.transition_pressure,
        dz.alpha,
        dz.beta,
        dz.creep_slope,
        dz.outer_offset,
    )
    xs = np.clip(sig.x, 0.0, c.stroke)
    va = c.dead_volume_a + c.area_a * xs
    vb = c.dead_volume_b + c.area_b * (c.stroke - xs)
    dp = sig.p_a - sig.p_b
    zero = np.zeros_like(dp)
    A_a = np.column_stack([va * sig.dp_a, dp, sig.p_a, zero, -ga])[mask]
    y_a = (qa - c.area_a * sig.v)[mask]
    A_b = np.column_stack([vb * sig.dp_b, -dp, zero, sig.p_b, gb])[mask]
    y_b = (-qb + c.area_b * sig.v)[mask]
    return _wls([(A_a, y_a), (A_b, y_b)], CONTINUITY_SCALE)


#: Column scales of the friction unknowns (F_c, F_s − F_c, σ).
FRICTION_SCALE = np.array([100.0, 100.0, 1000.0])


def sliding_speed(sig: Signals, params: SystemParams) -> float:
    """The speed [m/s] above which the rod slides clearly: 10× the filtered speed's noise and 3/γ.

    Near zero speed the Stribeck curve is steep (its tanh step is 1/γ wide) and the filtered
    speed's noise would attenuate the fitted forces (errors in the regressor).
    """
    return max(10.0 * sig.speed_noise, 3.0 / params.friction.smoothness)


def _sliding(sig: Signals, params: SystemParams, mask: np.ndarray) -> np.ndarray:
    """Rows where the rod slides clearly (|ẋ| above :func:`sliding_speed`)."""
    return mask & (np.abs(sig.v) > sliding_speed(sig, params))


def _friction_force(sig: Signals, params: SystemParams) -> np.ndarray:
    """F = A_A P_A − A_B P_B − f_l − m ẍ [N], the friction force by Newton's law, Eq. (10)."""
    c, ld = params.cylinder, params.load
    load = sig.f_l if sig.f_l is not None else ld.force + ld.damping * sig.v
    return c.area_a * sig.p_a - c.area_b * sig.p_b - load - ld.mass * sig.a


def friction_fit(sig: Signals, params: SystemParams, mask: np.ndarray) -> LinearFit:
    """(F_c, F_s − F_c, σ) from Newton's law, Eq. (10), on the Stribeck basis of Eq. (11)."""
    fr = params.friction
    force = _friction_force(sig, params)
    v = sig.v
    # the basis functions are Eq. (11) itself with unit forces: one component call each
    sign = stribeck_friction(v, 1.0, 1.0, 0.0, fr.stribeck_velocity, fr.shape, fr.smoothness)
    bump = stribeck_friction(v, 0.0, 1.0, 0.0, fr.stribeck_velocity, fr.shape, fr.smoothness)
    rows = _sliding(sig, params, mask)
    A = np.column_stack([sign, bump, v])[rows]
    return _wls([(A, force[rows])], FRICTION_SCALE)


def friction_scale_fit(sig: Signals, params: SystemParams, mask: np.ndarray) -> LinearFit:
    """The friction level s [1]: F = s · f(ẋ) with the identified Stribeck curve f, Eq. (11).

    One number that the run's velocities determine well, where F_c, F_s and σ apart are not
    (over a narrow speed range the Stribeck bump and the Coulomb step are nearly collinear).
    """
    fr = params.friction
    force = _friction_force(sig, params)
    curve = stribeck_friction(
        sig.v, fr.coulomb, fr.static, fr.viscous, fr.stribeck_velocity, fr.shape, fr.smoothness
    )
    rows = _sliding(sig, params, mask)
    return _wls([(curve[rows][:, None], force[rows])], np.array([1.0]))


def friction_level_weights(sig: Signals, params: SystemParams, mask: np.ndarray) -> np.ndarray:
    """g_j = ⟨f, b_j⟩ / ⟨f, f⟩ over the sliding rows, for θ = (F_c, F_s, σ) [1/N, 1/N, m/(N·s)].

    Eq. (11) is linear in θ: f = Σ_j θ_j b_j(ẋ) with b_Fc = tanh(γẋ)(1 − e), b_Fs = tanh(γẋ)·e,
    b_σ = ẋ (e = exp(−|ẋ/χ|^δ)). A machine with θ' and the identified χ, δ, γ has the friction
    level :func:`friction_scale_fit` reads, without noise, s = Σ_j θ'_j g_j exactly (Σ_j θ_j g_j
    = 1 at the identified θ), so θ's intervals bound the healthy level of *this* run's speeds.
    """
    fr = params.friction
    rows = _sliding(sig, params, mask)
    v = sig.v[rows]
    curve = stribeck_friction(
        v, fr.coulomb, fr.static, fr.viscous, fr.stribeck_velocity, fr.shape, fr.smoothness
    )
    basis = (
        stribeck_friction(v, 1.0, 0.0, 0.0, fr.stribeck_velocity, fr.shape, fr.smoothness),
        stribeck_friction(v, 0.0, 1.0, 0.0, fr.stribeck_velocity, fr.shape, fr.smoothness),
        v,
    )
    ff = float(curve @ curve)
    if ff <= 0.0:
        return np.full(3, np.nan)
    return np.array([float(curve @ b) / ff for b in basis])


def spool_fit(sig: Signals, mask: np.ndarray) -> LinearFit | None:
    """The valve null offset δ [1]: measured spool less the valve model's, Eq. (3) (None: no spool)."""
    if not sig.measured_spool:
        return None
    ones = np.ones((int(mask.sum()), 1))
    return _wls([(ones, (sig.nu - sig.nu_model)[mask])], np.array([1e-2]))


def supply_fit(sig: Signals, params: SystemParams, mask: np.ndarray) -> LinearFit | None:
    """The supply's set pressure [Pa] from P_S and the pump's droop (None: P_S not logged)."""
    if sig.p_s is None:
        return None
    sup, fl, dz = params.supply, params.flow, params.dead_zone
    p_set = sig.p_s.copy()
    if sup.model == "pump":
        qa, qb, _ga, _gb = _valve_terms(
            sig.nu,
            sig.p_a,
            sig.p_b,
            sig.p_s,
            0.0,
            sup.tank_pressure,
            fl.K,
            fl.transition_pressure,
            dz.alpha,
            dz.beta,
            dz.creep_slope,
            dz.outer_offset,
        )
        q_s = np.where(sig.nu >= 0.0, qa, -qb)  # dead_zone keeps the sign of ν
        p_set = p_set + sup.compensator_droop * np.clip(q_s, 0.0, None) / sup.pump_flow
    ones = np.ones((int(mask.sum()), 1))
    return _wls([(ones, p_set[mask])], np.array([1e7]))


# ---------------------------------------------------------------------------------------------
# The on-target generator: one filtered row at a time, in the C emitter's subset (scalars, the
# two arrays P and S indexed by the constants below), translated to C by monitor/_target.py.

#: Slots of the parameter vector ``P`` of :func:`monitor_row` (SI; :func:`pack_online`).
(MP_AA, MP_AB, MP_STROKE, MP_VA0, MP_VB0, MP_E, MP_CL, MP_CEA, MP_CEB) = range(9)
(MP_K, MP_PTR, MP_PT, MP_ALPHA, MP_BETA, MP_CREEP, MP_OUTER) = range(9, 16)
(MP_FC, MP_FS, MP_SIGMA, MP_CHI, MP_DELTA, MP_GAMMA, MP_MASS, MP_LOADF, MP_LOADD) = range(16, 25)
(MP_PUMP, MP_DROOP, MP_QMAX, MP_PS) = range(25, 29)
(MP_XLO, MP_XHI, MP_PMIN, MP_VMIN, MP_HAS_FL, MP_HAS_PS, MP_HAS_SPOOL) = range(29, 36)
(MP_FR_HI, MP_PS_LO, MP_NU_LO, MP_NU_HI) = range(36, 40)
#: the continuity unknowns' column scales (:data:`CONTINUITY_SCALE`) and the thresholds of the
#: continuity indicators (low, high: E, C_L, C_eA, C_eB; ∓HUGE where a side has no alarm)
MP_CS = 40
(MP_E_LO, MP_E_HI, MP_CL_LO, MP_CL_HI) = range(45, 49)
(MP_CEA_LO, MP_CEA_HI, MP_CEB_LO, MP_CEB_HI) = range(49, 53)
N_P = 53
#: Slots of the sums ``S`` (rows used, Σ r_A², Σ r_B², sliding rows, Σ r_F², Σ f², Σ f·F,
#: Σ p_set, Σ (ν − ν_model)).
(MS_N, MS_RA2, MS_RB2, MS_NF, MS_RF2, MS_FF, MS_FY, MS_PSET, MS_DNU) = range(9)
#: The continuity fit's sums per chamber (block A from MS_CA, B from MS_CB; GRAM_SLOTS each):
#: the Gram matrix Σ a aᵀ of the scaled regressor rows a (5 × 5, row-major), Σ a·y and Σ y²
#: (:func:`continuity_fit`'s blocks); MS_ROW: the current row's regressors (scratch).
GRAM_SLOTS = 31
MS_CA, MS_CB = 9, 9 + GRAM_SLOTS
MS_ROW = 9 + 2 * GRAM_SLOTS
N_S = MS_ROW + 5
#: The work array ``W`` of :func:`continuity_result`: the 5 × 6 augmented normal equations
#: (row-major) and the solution (scaled unknowns) from slot 30.
N_W = 35
#: +∞ (HUGE_VAL in C): NaN is 0·HUGE; a threshold side without an alarm is ±HUGE.
HUGE = math.inf


@njit(cache=True)
def monitor_row(S, P, nu, nu_model, x, v, a, pa, pb, dpa, dpb, ps, fl):  # pragma: no cover
    """One filtered row: the residuals (r_A, r_B [m³/s], r_F [N]) and the sums ``S`` updated.

    r_A, r_B are the chambers' continuity equations of :func:`continuity_fit` at the identified
    (1/E, C_L, C_eA, C_eB) and δ = 0; r_F is Newton's law less the identified Stribeck curve,
    Eq. (11). A row enters the sums under the monitor's mask (stroke margin, chamber
    pressures), and the friction sums only while the rod slides (:func:`_sliding`).
    (``S[i] = S[i] + ...``: the emitter takes an array assigned by ``=`` as written.)
    """
    p_s = ps if P[MP_HAS_PS] > 0.5 else P[MP_PS]
    qa, qb, ga, gb = valve_row(
        nu, pa, pb, p_s, P[MP_PT], P[MP_K], P[MP_PTR], P[MP_ALPHA], P[MP_BETA],
        P[MP_CREEP], P[MP_OUTER],
    )  # fmt: skip
    xs = x
    if xs < 0.0:
        xs = 0.0
    if xs > P[MP_STROKE]:
        xs = P[MP_STROKE]
    va = P[MP_VA0] + P[MP_AA] * xs
    vb = P[MP_VB0] + P[MP_AB] * (P[MP_STROKE] - xs)
    dp = pa - pb
    r_a = qa - P[MP_AA] * v - va * dpa / P[MP_E] - P[MP_CL] * dp - P[MP_CEA] * pa
    r_b = -qb + P[MP_AB] * v - vb * dpb / P[MP_E] + P[MP_CL] * dp - P[MP_CEB] * pb
    load = fl if P[MP_HAS_FL] > 0.5 else P[MP_LOADF] + P[MP_LOADD] * v
    force = P[MP_AA] * pa - P[MP_AB] * pb - load - P[MP_MASS] * a
    f = stribeck_friction(
        v, P[MP_FC], P[MP_FS], P[MP_SIGMA], P[MP_CHI], P[MP_DELTA], P[MP_GAMMA]
    )  # fmt: skip
    r_f = force - f
    used = (x > P[MP_XLO]) and (x < P[MP_XHI]) and (pa > P[MP_PMIN]) and (pb > P[MP_PMIN])
    if used:
        # the continuity fit's rows (continuity_fit): [V Ṗ, ±ΔP, P_A | P_B, ∓∂Q/∂ν], scaled
        gram_add(
            S, MS_CA, va * dpa * P[MP_CS], dp * P[MP_CS + 1], pa * P[MP_CS + 2], 0.0,
            -ga * P[MP_CS + 4], qa - P[MP_AA] * v,
        )  # fmt: skip
        gram_add(
            S, MS_CB, vb * dpb * P[MP_CS], -dp * P[MP_CS + 1], 0.0, pb * P[MP_CS + 3],
            gb * P[MP_CS + 4], -qb + P[MP_AB] * v,
        )  # fmt: skip
        q_s = qa if nu >= 0.0 else -qb
        if q_s < 0.0:
            q_s = 0.0
        S[MS_N] = S[MS_N] + 1.0
        S[MS_RA2] = S[MS_RA2] + r_a * r_a
        S[MS_RB2] = S[MS_RB2] + r_b * r_b
        S[MS_PSET] = S[MS_PSET] + p_s + P[MP_PUMP] * P[MP_DROOP] * q_s / P[MP_QMAX]
        S[MS_DNU] = S[MS_DNU] + nu - nu_model
        if abs(v) > P[MP_VMIN]:
            S[MS_NF] = S[MS_NF] + 1.0
            S[MS_RF2] = S[MS_RF2] + r_f * r_f
            S[MS_FF] = S[MS_FF] + f * f
            S[MS_FY] = S[MS_FY] + f * force
    return r_a, r_b, r_f


@njit(cache=True)
def monitor_result(S, P):  # pragma: no cover
    """From the sums: friction level [1], supply set pressure [Pa], valve null [1], their
    alarms (1.0 / 0.0) against the thresholds in ``P``, and the residuals' RMS (r_A, r_B
    [m³/s], r_F [N]); NaN where the run had no usable row (no alarm then)."""
    missing = 0.0 * HUGE
    n = S[MS_N]
    fr = S[MS_FY] / S[MS_FF] if S[MS_NF] > 0.5 else missing
    p_set = S[MS_PSET] / n if n > 0.5 else missing
    null = S[MS_DNU] / n if (n > 0.5 and P[MP_HAS_SPOOL] > 0.5) else missing
    a_fr = 1.0 if fr > P[MP_FR_HI] else 0.0
    a_ps = 1.0 if (P[MP_HAS_PS] > 0.5 and p_set < P[MP_PS_LO]) else 0.0
    a_nu = 1.0 if (null < P[MP_NU_LO] or null > P[MP_NU_HI]) else 0.0
    rms_a = math.sqrt(S[MS_RA2] / n) if n > 0.5 else missing
    rms_b = math.sqrt(S[MS_RB2] / n) if n > 0.5 else missing
    rms_f = math.sqrt(S[MS_RF2] / S[MS_NF]) if S[MS_NF] > 0.5 else missing
    return fr, p_set, null, a_fr, a_ps, a_nu, rms_a, rms_b, rms_f


@njit(cache=True)
def gram_add(S, o, c0, c1, c2, c3, c4, y):  # pragma: no cover
    """Add the row (c0..c4; y) to the block sums of ``S`` from slot ``o`` (Σ a aᵀ, Σ a y, Σ y²)."""
    S[MS_ROW] = c0
    S[MS_ROW + 1] = c1
    S[MS_ROW + 2] = c2
    S[MS_ROW + 3] = c3
    S[MS_ROW + 4] = c4
    for i in range(5):
        for j in range(5):
            S[o + 5 * i + j] = S[o + 5 * i + j] + S[MS_ROW + i] * S[MS_ROW + j]
        S[o + 25 + i] = S[o + 25 + i] + S[MS_ROW + i] * y
    S[o + 30] = S[o + 30] + y * y


@njit(cache=True)
def block_rms(S, o, W, n):  # pragma: no cover
    """RMS of one block's residual y − a·θ at the solution in W[30:35], from its sums."""
    ss = S[o + 30]
    for i in range(5):
        ss = ss - 2.0 * W[30 + i] * S[o + 25 + i]
        for j in range(5):
            ss = ss + W[30 + i] * S[o + 5 * i + j] * W[30 + j]
    if ss < 0.0:
        ss = 0.0
    return math.sqrt(ss / n) + 1e-300


@njit(cache=True)
def solve5(W):  # pragma: no cover
    """Gaussian elimination with partial pivoting of the 5 × 6 augmented system in W; the
    solution into W[30:35] (NaN where singular)."""
    for k in range(5):
        piv = k
        big = abs(W[6 * k + k])
        for i in range(k + 1, 5):
            if abs(W[6 * i + k]) > big:
                big = abs(W[6 * i + k])
                piv = i
        if piv != k:
            for j in range(6):
                t = W[6 * k + j]
                W[6 * k + j] = W[6 * piv + j]
                W[6 * piv + j] = t
        for i in range(k + 1, 5):
            f = W[6 * i + k] / W[6 * k + k]
            for j in range(k, 6):
                W[6 * i + j] = W[6 * i + j] - f * W[6 * k + j]
    for m in range(5):
        i = 4 - m
        acc = W[6 * i + 5]
        for j in range(i + 1, 5):
            acc = acc - W[6 * i + j] * W[30 + j]
        W[30 + i] = acc / W[6 * i + i]


@njit(cache=True)
def continuity_result(S, P, W):  # pragma: no cover
    """From the sums: the continuity fit's bulk modulus E [Pa], internal leakage C_L and the
    external leakages C_eA, C_eB [m³/(s·Pa)] and their alarms (1.0 / 0.0) against the thresholds
    in ``P``; NaN (no alarm) with fewer than 5 rows.

    :func:`continuity_fit`'s weighted least squares from running sums: the normal equations of
    the two blocks, each weighted by its residual RMS, solved three times (weights 1, then
    twice each block's RMS at the last solution), as :func:`_wls` does by SVD over the rows.
    ``W``: work array of :data:`N_W` values.
    """
    missing = 0.0 * HUGE
    n = S[MS_N]
    if n < 5.5:
        return missing, missing, missing, missing, 0.0, 0.0, 0.0, 0.0
    wa = 1.0
    wb = 1.0
    for _it in range(3):
        for i in range(5):
            for j in range(5):
                W[6 * i + j] = S[MS_CA + 5 * i + j] / (wa * wa) + S[MS_CB + 5 * i + j] / (wb * wb)
            W[6 * i + 5] = S[MS_CA + 25 + i] / (wa * wa) + S[MS_CB + 25 + i] / (wb * wb)
        solve5(W)
        wa = block_rms(S, MS_CA, W, n)
        wb = block_rms(S, MS_CB, W, n)
    e = 1.0 / (W[30] * P[MP_CS])
    cl = W[31] * P[MP_CS + 1]
    cea = W[32] * P[MP_CS + 2]
    ceb = W[33] * P[MP_CS + 3]
    a_e = 1.0 if (e < P[MP_E_LO] or e > P[MP_E_HI]) else 0.0
    a_cl = 1.0 if (cl < P[MP_CL_LO] or cl > P[MP_CL_HI]) else 0.0
    a_cea = 1.0 if (cea < P[MP_CEA_LO] or cea > P[MP_CEA_HI]) else 0.0
    a_ceb = 1.0 if (ceb < P[MP_CEB_LO] or ceb > P[MP_CEB_HI]) else 0.0
    return e, cl, cea, ceb, a_e, a_cl, a_cea, a_ceb


@njit(cache=True)
def monitor_rows(P, nu, nu_model, x, v, a, pa, pb, dpa, dpb, ps, fl):  # pragma: no cover
    """:func:`monitor_row` over a run's rows: the residuals (n × 3) and the sums."""
    S = np.zeros(N_S)
    n = nu.shape[0]
    r = np.empty((n, 3))
    for k in range(n):
        r[k, 0], r[k, 1], r[k, 2] = monitor_row(
            S, P, nu[k], nu_model[k], x[k], v[k], a[k], pa[k], pb[k], dpa[k], dpb[k], ps[k], fl[k]
        )
    return r, S
