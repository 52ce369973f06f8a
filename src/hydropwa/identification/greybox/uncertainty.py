"""Uncertainty of the grey-box estimate: the autocorrelation-robust sandwich covariance.

Newey–West per residual stream, at least the segment-block (cluster-robust) estimate, plus
the propagated initial-state and input errors (errors in variables); the propagation of held
parameters into a refit (:func:`join_held`) and the Gauss–Newton step still left.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from .data import RunData, perturbed_run
from .objective import loss_weights

__all__ = ["Covariance", "autocorrelation_time", "covariance", "join_held", "kappa"]


def _nuisance_covariance(
    prob: Any,
    prepared: list[RunData],
    theta: np.ndarray,
    r: np.ndarray,
    Jw: np.ndarray,
    w: np.ndarray,
    Hinv: np.ndarray,
    draws: int,
    rng: np.random.Generator,
) -> np.ndarray:
    """Covariance of the log parameters from the initial-state and input errors.

    Draw k perturbs the data (:func:`perturbed_run`) and simulates every ``s``-th segment
    (offset k mod s, s = min(4, segments)); the step −H⁻¹Jᵀ(w·Δr) over those segments is how
    far the estimate would move. Segments are simulated independently, so each segment's
    errors act on its own residuals alone and the steps of the s offsets add up to the step
    of all segments: its mean is the sum of the offsets' mean steps, its covariance the sum
    of their covariances. Returned: that covariance plus the mean's outer product (the bias
    the errors cause through the model's nonlinearity), at 1/s of the cost of full draws.
    """
    seg_ids = [(ri, si) for ri, rd in enumerate(prepared) for si in range(len(rd.segments))]
    stride = max(1, min(4, len(seg_ids), draws // 2))
    steps = np.zeros((draws, theta.size))
    for k in range(draws):
        chosen = {sid for g, sid in enumerate(seg_ids) if g % stride == k % stride}
        runs = []
        for ri, rd in enumerate(prepared):
            keep = [seg for si, seg in enumerate(rd.segments) if (ri, si) in chosen]
            runs.append(perturbed_run(dataclasses.replace(rd, segments=keep), rng))
        rows = [
            np.arange(pos, pos + length)
            for ri, si, _c, pos, length in prob.streams
            if (ri, si) in chosen
        ]
        if not rows:
            continue
        idx = np.concatenate(rows)
        pert = prob.with_runs(runs)
        dr = pert.fun(theta) - r[idx]
        steps[k] = -Hinv @ (Jw[idx].T @ (w[idx] * dr))
    mean = np.zeros(theta.size)
    cov = np.zeros((theta.size, theta.size))
    for o in range(stride):
        sk = steps[o::stride]
        mean += sk.mean(axis=0)
        if len(sk) > 1:
            cov += np.cov(sk, rowvar=False).reshape(theta.size, theta.size)
    return cov + np.outer(mean, mean)


# ----------------------------------------------------------------------------- statistics
@dataclasses.dataclass
class Covariance:
    """The uncertainty pieces at an optimum (see :func:`covariance`)."""

    w: np.ndarray
    Jw: np.ndarray
    rw: np.ndarray
    H: np.ndarray
    Hinv: np.ndarray
    cov: np.ndarray
    taus: list[float]


def covariance(
    prob: Any,
    theta: np.ndarray,
    r: np.ndarray,
    J: np.ndarray,
    loss: str,
    f_scale: float,
    nuisance_draws: int,
    rng: np.random.Generator,
) -> Covariance:
    """Covariance of the log parameters at an optimum: the Newey–West sandwich per residual
    stream, at least the segment-block (cluster-robust) estimate, plus the propagated
    initial-state and input errors (see the Notes of :func:`fit_model`)."""
    w = loss_weights(r, loss, f_scale)
    Jw, rw = J * w[:, None], r * w
    H = Jw.T @ Jw
    S = np.zeros_like(H)
    taus = []
    for _ri, _si, _c, pos, length in prob.streams:
        sl = slice(pos, pos + length)
        tau = autocorrelation_time(rw[sl])
        taus.append(tau)
        S += _long_run_covariance(Jw[sl] * rw[sl, None], int(math.ceil(2.0 * tau)))
    Hinv = np.linalg.pinv(H)
    cov = Hinv @ S @ Hinv
    # block (cluster-robust) estimate over the simulated segments: catches what differs between
    # segments (input and initial-state errors, a stalled optimiser) that no within-stream
    # correlation shows; with at least two blocks per parameter, each standard deviation is the
    # larger of the two
    block_of = {
        key: k for k, key in enumerate(sorted({(ri, si) for ri, si, _c, _p, _n in prob.streams}))
    }
    n_blocks = len(block_of)
    if n_blocks >= 2 * theta.size:
        sums = np.zeros((n_blocks, theta.size))
        for ri, si, _c, pos, length in prob.streams:
            sl = slice(pos, pos + length)
            sums[block_of[(ri, si)]] += Jw[sl].T @ rw[sl]
        cov_block = Hinv @ (sums.T @ sums * n_blocks / (n_blocks - 1.0)) @ Hinv
        d_hac = np.sqrt(np.clip(np.diag(cov), 1e-300, None))
        d = np.maximum(d_hac, np.sqrt(np.clip(np.diag(cov_block), 0.0, None)))
        cov = cov * np.outer(d / d_hac, d / d_hac)
    # errors in the variables: the initial states and driving inputs come from noisy
    # measurements too, and their errors move the estimate by what no residual covariance
    # shows (the same in every sample of a segment, and biased through the model's
    # nonlinearity). Each draw perturbs them by their own noise (_perturbed_run) and the
    # Gauss–Newton step −H⁻¹Jᵀ(w·Δr) tells how far the estimate would go; the mean square
    # of those steps (their spread and mean, i.e. bias²) is added to the covariance.
    if nuisance_draws:
        cov = cov + _nuisance_covariance(
            prob, prob.runs, theta, r, Jw, w, Hinv, nuisance_draws, rng
        )
    return Covariance(w, Jw, rw, H, Hinv, cov, taus)


def kappa(cov: np.ndarray, Hinv: np.ndarray) -> np.ndarray:
    """The profile statistic's scale per parameter: sandwich variance over (H⁻¹)_ii."""
    return np.maximum(np.diag(cov) / np.maximum(np.diag(Hinv), 1e-300), 1e-12)


def join_held(
    cov: np.ndarray, c_free: np.ndarray, G: np.ndarray, i_free: list[int], i_held: list[int]
) -> np.ndarray:
    """The covariance over all parameters after a refit of ``i_free`` with ``i_held`` held.

    The refit's estimate is θ_f = θ̂_f + G·(θ_b − θ̂_b) to first order, θ̂_f with covariance
    ``c_free`` (its own data, independent of the held estimate θ_b, whose covariance is the
    ``i_held`` block of ``cov``): Cov θ_f = c_free + G·C_b·Gᵀ, Cov(θ_f, θ_b) = G·C_b.
    """
    out = np.array(cov, dtype=float)
    Cb = out[np.ix_(i_held, i_held)]
    out[np.ix_(i_free, i_free)] = c_free + G @ Cb @ G.T
    out[np.ix_(i_free, i_held)] = G @ Cb
    out[np.ix_(i_held, i_free)] = (G @ Cb).T
    return out


def _acf(r: np.ndarray, nlags: int) -> np.ndarray:
    r = r - r.mean()
    n = r.size
    f = np.fft.rfft(r, 2 * n)
    ac = np.fft.irfft(f * np.conj(f))[: min(nlags, n)]
    return ac / ac[0] if ac[0] > 0 else np.zeros_like(ac)


def autocorrelation_time(r: np.ndarray) -> float:
    """Integrated autocorrelation time τ = 1 + 2Σρ_k [samples], summed until ρ first drops below 0.

    ``n/τ`` is the effective number of independent samples of a stream of ``n``.
    """
    if r.size < 4:
        return 1.0
    ac = _acf(r, r.size)
    neg = np.flatnonzero(ac <= 0.0)
    k = int(neg[0]) if neg.size else ac.size
    return float(max(1.0, 1.0 + 2.0 * ac[1:k].sum()))


def _long_run_covariance(g: np.ndarray, bandwidth: int) -> np.ndarray:
    """Newey–West estimate Σ_|k|≤L (1 − |k|/(L+1)) Σ_i g_i g_{i+k}ᵀ of a score stream (n, p)."""
    n, p = g.shape
    L = int(min(max(bandwidth, 0), n - 1))
    if L == 0:
        return g.T @ g
    nfft = 1 << int(math.ceil(math.log2(2 * n)))
    G = np.fft.rfft(g, nfft, axis=0)
    C = np.fft.irfft(
        G[:, :, None] * np.conj(G[:, None, :]), nfft, axis=0
    )  # C[k] = Σ_i g_{i+k} g_iᵀ
    w = 1.0 - np.arange(L + 1) / (L + 1.0)
    S = C[0].copy()
    for k in range(1, L + 1):
        S += w[k] * (C[k] + C[k].T)
    return S


def remaining_step(
    H: np.ndarray, Jw: np.ndarray, rw: np.ndarray, keep: np.ndarray | None = None
) -> np.ndarray:
    """The Gauss–Newton step −H⁻¹Jᵀr still left at a result (over the parameters ``keep``,
    the others zero: a parameter at its bound does not move)."""
    p = H.shape[0]
    if keep is None:
        return -np.linalg.pinv(H) @ (Jw.T @ rw)
    out = np.zeros(p)
    if keep.any():
        out[keep] = -np.linalg.pinv(H[np.ix_(keep, keep)]) @ (Jw[:, keep].T @ rw)
    return out
