"""The independent checker of a loop certificate: pure NumPy, float64, no code shared with
:mod:`hydropwa.control._certify`.

It rebuilds every row's closed-loop matrix from the raw :class:`~hydropwa.control._certify.LoopData`
(its own matrix exponential, its own assembly of the law), and re-checks each inequality the
certificate rests on: P ≻ 0, the invariant ellipsoid's S-procedure inequality for every row,
pressure vertex and integral mode with its multipliers, ē against the ellipsoid's extent,
c_U < c_R ≤ the saturation-free level (from its own command rows), and the reported box's
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
    # the law over z = [ξ, F, n_x, n_p, δc, ė_p, δ_band]
    m = n + 6
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
    c = c - g["k_nu"] * np.eye(m)[3] - g["k_dnu"] * np.eye(m)[4]
    c = c + np.eye(m)[n + 3] + np.eye(m)[n + 5]  # the blend and vent; the band's dead zone
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
    on ``data`` in float64; the verdict is ``passed``.

    Per row, pressure vertex and integral mode (integrate, leak):
    [M W]ᵀP[M W] − diag(λP, diag μ) ≼ 0 and Σμ ≤ 1 − λ (μ ≥ 0); then ē ≥ √(c_U (P⁻¹)ₓₓ),
    c_U = (1.1)² > 1, c_R above c_U and at most the saturation-free level, and the box's start
    states inside {V ≤ c_R}.
    """
    S = np.asarray(cert.scales, float)
    P = np.asarray(cert.P, float)
    n = P.shape[0]
    if not (
        np.allclose(P, P.T, rtol=0, atol=1e-12 * np.abs(P).max())
        and _psd(P - 1e-12 * np.abs(P).max() * np.eye(n))
    ):
        return CheckResult(False, ("P is not symmetric positive definite",), 1)
    lam = float(cert.lam)
    fails: list[str] = []
    checked = 1
    mus = iter(cert.mu)
    taus = iter(getattr(cert, "tau", ()) or ())
    sigmas = iter(getattr(cert, "sigma", ()) or ())
    forms = []
    for cell in data.cells:
        Mi, Ml, EA, c_form = _row(data, cell)
        W = (EA * _magnitudes(data, cell)) / S[:, None]
        acting = np.abs(W).max(axis=0) > 1e-12
        W = W[:, acting]
        forms.append(c_form)
        for name, M in (("integrate", Mi), ("leak", Ml)):
            Ms = (M * S) / S[:, None]
            mu = np.asarray(next(mus, np.zeros(0)), float)
            checked += 2
            if mu.shape != (W.shape[1],) or (mu < 0).any():
                fails.append(f"row {cell['label']} ({name}): multipliers missing or negative")
                continue
            MW = np.hstack([Ms, W])
            D = np.zeros((n + mu.size, n + mu.size))
            D[:n, :n] = lam * P
            D[n:, n:] = np.diag(mu)
            tau = float(next(taus, 0.0))
            if tau < 0:
                fails.append(f"row {cell['label']} ({name}): a negative sector multiplier")
            elif tau > 0 and acting[0]:
                # friction beyond its viscous slope is a force against the motion: the force
                # on the mass (disturbance 0) times ẋ (state 1) is ≤ 0, so τ·F·ẋ may be added
                D[1, n] += 0.5 * tau
                D[n, 1] += 0.5 * tau
            sigma = float(next(sigmas, 0.0))
            if sigma < 0:
                fails.append(f"row {cell['label']} ({name}): a negative band multiplier")
            elif sigma > 0 and acting[5]:
                D += sigma * _band_term(data, cell, acting, n, S)
            if not _psd(D - MW.T @ P @ MW):
                fails.append(f"row {cell['label']} ({name}): [M W]ᵀP[M W] ≼ diag(λP, μ) fails")
            if mu.sum() > (1.0 - lam) * (1 + 1e-9):
                fails.append(f"row {cell['label']} ({name}): Σμ > 1 − λ")
    Pinv = np.linalg.inv(P)
    c_u = 1.1**2
    checked += 3
    if cert.e_bar < math.sqrt(c_u * Pinv[2, 2]) * S[2] * (1 - 1e-9):
        fails.append(f"ē = {cert.e_bar:.6g} m is below the ellipsoid's extent")
    if not (cert.level_ultimate >= c_u * (1 - 1e-12) and cert.level_region > cert.level_ultimate):
        fails.append("the region's level is not above the ultimate set's")
    if cert.level_region > _saturation_level(data, forms, Pinv, S) * (1 + 1e-9):
        fails.append("the region reaches saturation, the velocity limit or other cells")
    fails += _box_failures(cert, data, P, S)
    return CheckResult(not fails, tuple(fails), checked + 8)


def _band_term(data, cell, acting, n: int, S) -> np.ndarray:
    """q·d² + d·c over [ξ (scaled); acting d (scaled)]: the quiet band outputs c − δ with
    δ = q·d between 0 and c (its dead zone, |δ| ≤ q), so δ(δ + c) ≤ 0 ⇔ q d² + d c ≤ 0."""
    z = _command_form(data, cell)  # c over [ξ SI, n_x, n_p]
    mag = _magnitudes(data, cell)
    cols = np.flatnonzero(acting)
    ell = np.zeros(n + cols.size)
    ell[:n] = z[:n] * S
    for j, col in enumerate(cols):
        if col in (1, 2):  # the noises enter the command (through x̂, v̂ and the pressure)
            ell[n + j] = z[n + col - 1] * mag[col]
    b = n + int(np.flatnonzero(cols == 5)[0])
    T = np.zeros((ell.size, ell.size))
    T[b] += 0.5 * ell
    T[:, b] += 0.5 * ell
    T[b, b] += mag[5]
    return T


def _magnitudes(data, cell) -> np.ndarray:
    b = data.bounds
    return np.array(
        [
            b["friction"],
            b["x_noise"],
            b["p_noise"],
            b["command"],
            cell["error_bound"],
            b.get("band", 0.0),
            1.0,
        ]
    )


def _row(data, cell):
    Mi, Ml, EA = row_matrices(data, cell)
    return Mi, Ml, EA, _command_form(data, cell)


def _command_form(data, cell) -> np.ndarray:
    """c over [ξ, n_x, n_p] (SI), noise the last two entries."""
    nd = data.delay_samples
    n = 9 + nd
    lx, lv = data.observer
    ts = data.sample_time
    g = cell["gains"]
    z = np.zeros(n + 2)
    innov = np.zeros(n + 2)
    innov[2] = innov[n] = 1.0
    innov[7 + nd] -= 1.0
    innov[8 + nd] -= ts
    xh = np.zeros(n + 2)
    xh[7 + nd], xh[8 + nd] = 1.0, ts
    xh += lx * innov
    vh = np.zeros(n + 2)
    vh[8 + nd] = 1.0
    vh += lv * innov
    pm = np.zeros(n + 2)
    pm[0] = pm[n + 1] = 1.0
    pfb = pm.copy()
    if data.washout > 0:
        pfb[6 + nd] -= 1.0
        pfb *= data.washout
    z += -g["k_x"] * xh - g["k_v"] * vh - g["k_pl"] * pfb
    z[5 + nd] += g["k_i"]
    z[3] -= g["k_nu"]
    z[4] -= g["k_dnu"]
    if nd:
        z[5] -= g["k_up"]
    return z


def _saturation_level(data, forms, Pinv, S) -> float:
    """The largest level of V free of saturation, inside the friction fit and the cells."""
    n = Pinv.shape[0]
    b = data.bounds
    out = []
    for z in forms:
        k = z[:n] * S
        room = data.command_limit - abs(z[n]) * b["x_noise"] - abs(z[n + 1]) * b["p_noise"]
        out.append(max(room, 0.0) ** 2 / float(k @ Pinv @ k))
    out.append((data.velocity_limit / S[1]) ** 2 / Pinv[1, 1])
    lo = max(c["lower"][0] for c in data.cells) - data.hold_pressure
    hi = min(c["upper"][0] for c in data.cells) - data.hold_pressure
    out.append((min(-lo, hi) / S[0]) ** 2 / Pinv[0, 0])
    return min(out)


def _box_failures(cert, data, P, S) -> list[str]:
    n = P.shape[0]
    nd = data.delay_samples
    T = np.zeros((n, 3))
    T[2, 0] = T[7 + nd, 0] = T[1, 1] = T[0, 2] = 1.0
    if data.washout > 0:
        T[6 + nd, 2] = 1.0
    D = (T / S[:, None]) * np.asarray(cert.box, float)
    for sgn in np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T:
        z = D @ sgn
        if float(z @ P @ z) > cert.level_region * (1 + 1e-9):
            return [f"box corner {tuple(int(v) for v in sgn)} lies outside the region"]
    return []
