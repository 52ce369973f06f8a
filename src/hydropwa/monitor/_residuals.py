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

from ..components import dead_zone, dead_zone_slope, orifice_flows, stribeck_friction
from ..params import SystemParams

__all__ = ["Signals", "prepare", "continuity_fit", "friction_fit", "supply_fit", "LinearFit"]


@dataclass(frozen=True)
class Signals:
    """A run's filtered signals on the decimated rows, SI (see :func:`prepare`)."""

    t: np.ndarray
    u: np.ndarray
    nu: np.ndarray
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


@dataclass(frozen=True)
class LinearFit:
    """A weighted least-squares estimate: values, standard errors, residual RMS per block."""

    theta: np.ndarray
    std: np.ndarray
    rms: tuple[float, ...]
    rows: int


def _savgol(y: np.ndarray, window: int, deriv: int, dt: float) -> np.ndarray:
    from scipy.signal import savgol_filter  # deferred: scipy.signal costs ~0.2 s at import

    return savgol_filter(y, window, 3, deriv=deriv, delta=dt, mode="interp")


def _spool(u: np.ndarray, t: np.ndarray, omega0: float, zeta: float) -> np.ndarray:
    """ν(t) of the servo valve, Eq. (3), driven by the logged command (exact for linear u)."""
    from scipy.signal import lsim  # deferred: scipy.signal costs ~0.2 s at import

    w2 = omega0 * omega0
    _, y, _ = lsim(([w2], [1.0, 2.0 * zeta * omega0, w2]), u, t - t[0], X0=[0.0, u[0] / w2])
    return np.asarray(y, dtype=float)


def prepare(channels: dict[str, np.ndarray], fs: float, params: SystemParams, window_s: float) -> Signals:
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
    if spool is None:
        omega = params.valve.omega0_at(float(np.max(np.abs(u))))
        nu = _spool(u, t, omega, params.valve.zeta)
    else:
        nu = np.asarray(spool, float)

    def f(name: str, deriv: int = 0) -> np.ndarray:
        return _savgol(np.asarray(channels[name], float), w, deriv, dt)

    sl = slice(w, t.size - w, max(1, w // 2))
    p_s = f("p_s")[sl] if "p_s" in channels else None
    f_l = f("f_l")[sl] if "f_l" in channels else None
    return Signals(
        t=t[sl],
        u=u[sl],
        nu=_savgol(nu, w, 0, dt)[sl],
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
        A = np.vstack([b[0] * (s / w) for b, w, s in zip(blocks, weights, [scale] * len(blocks), strict=True)])
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
    s2 = float(np.sum((y - A @ sol) ** 2)) / dof
    cov = s2 * np.linalg.pinv(A.T @ A)
    std = np.sqrt(np.clip(np.diag(cov), 0.0, None)) * np.abs(scale)
    return LinearFit(theta=theta, std=std, rms=tuple(weights), rows=int(A.shape[0]))


#: Column scales of the continuity unknowns (1/E, C_L, C_eA, C_eB, δ): typical magnitudes.
CONTINUITY_SCALE = np.array([1e-9, 1e-12, 1e-12, 1e-12, 1e-2])


def continuity_fit(sig: Signals, params: SystemParams, mask: np.ndarray) -> LinearFit:
    """(1/E, C_L, C_eA, C_eB, δ) from both chambers' continuity (module docstring)."""
    c, fl, dz = params.cylinder, params.flow, params.dead_zone
    ps = _supply_pressure(sig, params)
    qa, qb, ga, gb = _valve_terms(
        sig.nu, sig.p_a, sig.p_b, ps, 0.0, params.supply.tank_pressure, fl.K,
        fl.transition_pressure, dz.alpha, dz.beta, dz.creep_slope, dz.outer_offset,
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


def friction_fit(sig: Signals, params: SystemParams, mask: np.ndarray) -> LinearFit:
    """(F_c, F_s − F_c, σ) from Newton's law, Eq. (10), on the Stribeck basis of Eq. (11)."""
    c, fr, ld = params.cylinder, params.friction, params.load
    load = sig.f_l if sig.f_l is not None else ld.force + ld.damping * sig.v
    force = c.area_a * sig.p_a - c.area_b * sig.p_b - load - ld.mass * sig.a
    v = sig.v
    # the basis functions are Eq. (11) itself with unit forces: one component call each
    sign = stribeck_friction(v, 1.0, 1.0, 0.0, fr.stribeck_velocity, fr.shape, fr.smoothness)
    bump = stribeck_friction(v, 0.0, 1.0, 0.0, fr.stribeck_velocity, fr.shape, fr.smoothness)
    A = np.column_stack([sign, bump, v])[mask]
    return _wls([(A, force[mask])], FRICTION_SCALE)


def supply_fit(sig: Signals, params: SystemParams, mask: np.ndarray) -> LinearFit | None:
    """The supply's set pressure [Pa] from P_S and the pump's droop (None: P_S not logged)."""
    if sig.p_s is None:
        return None
    sup, fl, dz = params.supply, params.flow, params.dead_zone
    p_set = sig.p_s.copy()
    if sup.model == "pump":
        qa, qb, _ga, _gb = _valve_terms(
            sig.nu, sig.p_a, sig.p_b, sig.p_s, 0.0, sup.tank_pressure, fl.K,
            fl.transition_pressure, dz.alpha, dz.beta, dz.creep_slope, dz.outer_offset,
        )
        z = np.array([dead_zone(n, dz.alpha, dz.beta, dz.creep_slope, dz.outer_offset) for n in sig.nu])
        q_s = np.where(z >= 0.0, qa, -qb)
        p_set = p_set + sup.compensator_droop * np.clip(q_s, 0.0, None) / sup.pump_flow
    ones = np.ones((int(mask.sum()), 1))
    return _wls([(ones, p_set[mask])], np.array([1e7]))
