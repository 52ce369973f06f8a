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

from dataclasses import dataclass

import numpy as np
from numba import njit

from .. import _jitcache  # noqa: F401  (one cache stamp for all compiled modules)
from ..components import dead_zone, dead_zone_slope, orifice_flows, stribeck_friction
from ..params import SystemParams

__all__ = [
    "LinearFit",
    "Signals",
    "continuity_fit",
    "friction_fit",
    "friction_scale_fit",
    "prepare",
    "spool_fit",
    "supply_fit",
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
def _valve_terms(nu, pa, pb, ps, null, pt, K, ptr, alpha, beta, creep, outer):  # pragma: no cover
    """Per row: Q_A, Q_B [m³/s] at ν + δ and their slopes ∂Q/∂ν by the dead zone's cells."""
    n = nu.shape[0]
    qa = np.empty(n)
    qb = np.empty(n)
    ga = np.empty(n)
    gb = np.empty(n)
    for k in range(n):
        s = nu[k] + null
        z = dead_zone(s, alpha, beta, creep, outer)
        qa[k], qb[k] = orifice_flows(z, pa[k], pb[k], ps[k], pt, K, ptr)
        dz = dead_zone_slope(s, alpha, beta, creep, outer)
        h = 1e-6
        qa1, qb1 = orifice_flows(z + h, pa[k], pb[k], ps[k], pt, K, ptr)
        qa0, qb0 = orifice_flows(z - h, pa[k], pb[k], ps[k], pt, K, ptr)
        ga[k] = (qa1 - qa0) / (2 * h) * dz
        gb[k] = (qb1 - qb0) / (2 * h) * dz
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


def _sliding(sig: Signals, params: SystemParams, mask: np.ndarray) -> np.ndarray:
    """Rows where the rod slides clearly: |ẋ| above 10× its noise and 3/γ.

    Near zero speed the Stribeck curve is steep (its tanh step is 1/γ wide) and the filtered
    speed's noise would attenuate the fitted forces (errors in the regressor).
    """
    v_min = max(10.0 * sig.speed_noise, 3.0 / params.friction.smoothness)
    return mask & (np.abs(sig.v) > v_min)


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
