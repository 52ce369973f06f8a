"""The independent checker of a loop certificate: pure NumPy, float64, no code shared with
:mod:`hydropwa.control._certify`.

It rebuilds every row's closed-loop matrix from the raw :class:`~hydropwa.control._certify.LoopData`
(its own matrix exponential, its own assembly of the law), and re-checks each inequality the
certificate rests on: P ≻ 0, MᵀPM ≼ λP for every row's integrate and leak modes, the
contraction left after the integral hold's share (1 − √λ − ρ₁ > 0), ē ≥ √(c_U (P⁻¹)ₓₓ) with
c_U from its own disturbance norms, c_U < c_R ≤ the saturation-free level, and the reported box's
start states inside {V ≤ c_R}. Its verdict decides.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["CheckResult", "check_certificate", "row_matrices"]

#: relative float64 tolerance of a matrix inequality (eigenvalue over the matrix's norm)
TOLERANCE = 1e-9


@dataclass(frozen=True)
class CheckResult:
    """The checker's verdict: ``passed`` and the failed inequalities, one line each."""

    passed: bool
    failures: tuple[str, ...] = ()
    checked: int = 0


def _expm(M: np.ndarray) -> np.ndarray:
    """exp(M) by scaling and squaring of an 18-term Taylor series (‖M/2^s‖ ≤ 0.5)."""
    norm = float(np.abs(M).sum(axis=1).max())
    s = max(0, int(math.ceil(math.log2(norm / 0.5))) if norm > 0.5 else 0)
    A = M / 2.0**s
    term = np.eye(M.shape[0])
    out = term.copy()
    for k in range(1, 19):
        term = term @ A / k
        out = out + term
    for _ in range(s):
        out = out @ out
    return out


def row_matrices(data, cell) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(M_integrate, M_leak, [E | a]) of one row, SI states, assembled from the law's text
    (docs/controller_target.md, steps 2, 5, 9, 10 and the position observer)."""
    nd = data.delay_samples
    n = 9 + nd
    ts = data.sample_time
    # continuous plant [P_L, v, x, ν, ν̇] with inputs [c, F, Ṗ error, 1]
    F = np.zeros((9, 9))
    F[:3, :3] = cell["A"]
    F[:3, 3] = cell["B"]
    F[3, 4] = 1.0
    F[4, 3] = -(data.omega0**2)
    F[4, 4] = -2.0 * data.zeta * data.omega0
    F[4, 5] = data.omega0**2
    F[1, 6] = 1.0 / data.mass
    F[0, 7] = 1.0
    F[0, 8] = cell["f0"][0]
    X = _expm(F * ts)
    Ad, Bd = X[:5, :5], X[:5, 5:]
    # the law over z = [ξ, F, n_x, n_p, δc, ė_p]
    m = n + 5
    lx, lv = data.observer
    xh, vh, pfb, pb = (np.zeros(m) for _ in range(4))
    i_i, i_pb, i_xh, i_vh = 5 + nd, 6 + nd, 7 + nd, 8 + nd
    innov = np.zeros(m)
    innov[[2, n + 1]] = 1.0
    innov[i_xh] -= 1.0
    innov[i_vh] -= ts
    xh[i_xh], xh[i_vh] = 1.0, ts
    xh = xh + lx * innov
    vh[i_vh] = 1.0
    vh = vh + lv * innov
    meas_p = np.zeros(m)
    meas_p[[0, n + 2]] = 1.0
    if data.washout > 0:
        pb[i_pb] = data.washout
        pb = pb + (1.0 - data.washout) * meas_p
        pfb = data.washout * (meas_p - np.eye(m)[i_pb])
    else:
        pfb = meas_p
    g = cell["gains"]
    c = g["k_i"] * np.eye(m)[i_i] - g["k_x"] * xh - g["k_v"] * vh - g["k_pl"] * pfb
    c = c - g["k_nu"] * np.eye(m)[3] - g["k_dnu"] * np.eye(m)[4] + np.eye(m)[n + 3]
    if nd:
        c = c - g["k_up"] * np.eye(m)[5]
    u = c if nd == 0 else np.eye(m)[5]
    Z = np.zeros((n + 1, m + 1))  # the last column the constant
    Z[:5, :5] = Ad
    Z[:5, :m] += np.outer(Bd[:, 0], u)
    Z[:5, n] += Bd[:, 1]
    Z[:5, n + 4] += Bd[:, 2]
    Z[:5, m] = Bd[:, 3]
    for k in range(1, nd):
        Z[4 + k, 5 + k] = 1.0
    if nd:
        Z[4 + nd, :m] = c
    Z[i_i, :m] = np.eye(m)[i_i] - ts * xh
    Z[i_pb, :m], Z[i_xh, :m], Z[i_vh, :m] = pb, xh, vh
    Mi = Z[:n, :n]
    Ml = Mi.copy()
    Ml[i_i] = 0.0
    Ml[i_i, i_i] = data.leak
    return Mi, Ml, np.hstack([Z[:n, n:m], Z[:n, m:]])


def _psd(M: np.ndarray) -> bool:
    Ms = 0.5 * (M + M.T)
    w = np.linalg.eigvalsh(Ms)
    return bool(w.min() >= -TOLERANCE * max(1.0, float(np.abs(w).max())))


def check_certificate(cert, data) -> CheckResult:
    """Re-check every inequality of ``cert`` (a :class:`~hydropwa.control._certify.Certificate`)
    on ``data`` in float64; the verdict is ``passed``."""
    S = np.asarray(cert.scales, float)
    P = np.asarray(cert.P, float)
    fails: list[str] = []
    n = P.shape[0]
    checked = 1
    if not (
        np.allclose(P, P.T, rtol=0, atol=1e-12 * np.abs(P).max()) and _psd(P - 1e-9 * np.eye(n))
    ):
        return CheckResult(False, ("P is not symmetric positive definite",), 1)
    Pinv = np.linalg.inv(P)
    lam = float(cert.lam)
    b = data.bounds
    i_i = 5 + data.delay_samples
    rho = []
    for cell in data.cells:
        Mi, Ml, EA = row_matrices(data, cell)
        for name, M in (("integrate", Mi), ("leak", Ml)):
            Ms = (M * S) / S[:, None]
            checked += 1
            if not _psd(lam * P - Ms.T @ P @ Ms):
                fails.append(f"row {cell['label']} ({name}): MᵀPM ≼ λP fails")
        mags = np.array(
            [b["friction"], b["x_noise"], b["p_noise"], b["command"], cell["error_bound"], 1.0]
        )
        W = (EA * mags) / S[:, None]
        rho.append(sum(math.sqrt(max(float(w @ P @ w), 0.0)) for w in W.T))
    # the integral hold: I⁺ = I instead of I − T_s·x̂⁺, x̂⁺ = h ξ
    h = _observer_row(data) * S
    e_i = np.zeros(n)
    e_i[i_i] = data.sample_time / S[i_i]
    rho1 = math.sqrt(float(e_i @ P @ e_i)) * math.sqrt(float(h @ Pinv @ h))
    kappa = 1.0 - math.sqrt(lam) - rho1
    checked += 1
    if not kappa > 0:
        fails.append(f"no contraction left: 1 − √λ − ρ₁ = {kappa:.3g}")
        return CheckResult(False, tuple(fails), checked)
    e_min = math.sqrt(max(cert.level_ultimate, 0.0) * Pinv[2, 2]) * S[2]
    checked += 3
    if cert.e_bar < e_min * (1 - 1e-9):
        fails.append(f"ē = {cert.e_bar:.6g} m is below √(c_U (P⁻¹)ₓₓ) = {e_min:.6g} m")
    if not cert.level_region > cert.level_ultimate >= _ultimate_level(data, Pinv, S, rho, kappa):
        fails.append("c_U is below the disturbances' level, or the region not above it")
    # the box's start states inside the region
    T = np.zeros((n, 3))
    T[2, 0] = T[7 + data.delay_samples, 0] = T[1, 1] = T[0, 2] = 1.0
    if data.washout > 0:
        T[6 + data.delay_samples, 2] = 1.0
    D = (T / S[:, None]) * np.asarray(cert.box, float)
    for sgn in np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T:
        checked += 1
        z = D @ sgn
        if float(z @ P @ z) > cert.level_region * (1 + 1e-9):
            fails.append(f"box corner {tuple(sgn)} lies outside the region")
            break
    return CheckResult(not fails, tuple(fails), checked)


def _ultimate_level(data, Pinv, S, rho, kappa) -> float:
    """c_U: (1.1)²·max (ρ_j/κ)² over the rows whose box may hold a state below (1.1)²(ρ_j/κ)²."""
    worst = 0.0
    for cell, r in zip(data.cells, rho, strict=True):
        need = (1.1 * r / kappa) ** 2
        low = 0.0
        for i, ref in ((0, data.hold_pressure), (1, 0.0)):
            a, b = cell["lower"][i] - ref, cell["upper"][i] - ref
            if a * b > 0:
                low = max(low, (min(abs(a), abs(b)) / S[i]) ** 2 / Pinv[i, i])
        if low < need:
            worst = max(worst, need)
    return worst * (1 - 1e-9)


def _observer_row(data) -> np.ndarray:
    """x̂⁺ over ξ (SI): x̂ + T_s v̂ + L_x (x − x̂ − T_s v̂)."""
    n = 9 + data.delay_samples
    h = np.zeros(n)
    lx = data.observer[0]
    h[7 + data.delay_samples] = 1.0 - lx
    h[8 + data.delay_samples] = data.sample_time * (1.0 - lx)
    h[2] = lx
    return h
