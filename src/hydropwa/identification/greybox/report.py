"""What the grey-box fit reports beside the estimates: identifiability, per-run fits, and the
fitted parameter set."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from .data import RunData
from .result import Identifiability, RunFit

__all__ = ["fitted_params", "identifiability", "run_fits"]

#: Experiments that would separate parameters the data cannot (identifiability advice).
_ADVICE: dict[frozenset, str] = {
    frozenset(
        {"oil.bulk_modulus", "cylinder.dead_volume_a"}
    ): "a locked-rod pressure step (V/E enters alone)",
    frozenset(
        {"oil.bulk_modulus", "cylinder.dead_volume_b"}
    ): "a locked-rod pressure step (V/E enters alone)",
    frozenset(
        {"flow.K", "cylinder.leakage"}
    ): "runs with the valve closed under load (leakage alone moves the rod)",
    frozenset(
        {"friction.coulomb", "friction.static"}
    ): "slow constant-speed runs below the Stribeck velocity",
    frozenset(
        {"friction.static", "friction.stribeck_velocity"}
    ): "constant-input runs at 1–20 mm/s (the Stribeck dip)",
    frozenset(
        {"friction.static", "friction.shape"}
    ): "constant-input runs at 1–20 mm/s (the Stribeck dip)",
    frozenset(
        {"friction.stribeck_velocity", "friction.shape"}
    ): "constant-input runs at 1–20 mm/s (the Stribeck dip)",
    frozenset(
        {"friction.viscous", "flow.K"}
    ): "constant-input runs at several openings (force against speed)",
    frozenset(
        {"load.mass", "friction.viscous"}
    ): "fast sine or step runs (inertia shows at high frequency)",
}


def identifiability(
    names: tuple[str, ...],
    H: np.ndarray,
    s2: float,
    inflation: np.ndarray,
    corr: np.ndarray,
    weak: list[str],
    unconverged: list[str],
) -> Identifiability:
    """Eigen-directions of H = JᵀJ (scaled to the covariance), correlated pairs, advice."""
    ev, vec = np.linalg.eigh(H)
    cond = float(ev.max() / ev.min()) if ev.min() > 0 else math.inf
    infl_mean = float(np.nanmean(inflation)) if np.isfinite(inflation).any() else 1.0
    directions = []
    for k in range(len(names)):
        std_dir = math.sqrt(s2 * infl_mean / ev[k]) if ev[k] > 0 else math.inf
        comb = {
            names[i]: float(vec[i, k])
            for i in np.argsort(-np.abs(vec[:, k]))
            if abs(vec[i, k]) > 0.2
        }
        directions.append((std_dir, comb))
    correlated = [
        (names[i], names[j], float(corr[i, j]))
        for i in range(len(names))
        for j in range(i + 1, len(names))
        if abs(corr[i, j]) > 0.9
    ]
    advice = sorted(
        {
            f"{a}/{b}: {_ADVICE[frozenset({a, b})]}"
            for a, b, _ in correlated
            if frozenset({a, b}) in _ADVICE
        }
    )
    return Identifiability(cond, directions, correlated, weak, advice, unconverged)


def _run_fit(rd: RunData, sims: list, ri: int, streams: list, taus: list[float]) -> RunFit:
    tt = np.full(rd.t.size, np.nan)
    meas = {c: np.full(rd.t.size, np.nan) for c in rd.y}
    simd = {c: np.full(rd.t.size, np.nan) for c in rd.y}
    for si, seg in enumerate(rd.segments):
        # keep one NaN between windows so that plots break the line
        sl = slice(seg.i0, seg.i1 - 1 if rd.method == "multiple" else seg.i1)
        tt[sl] = rd.t[sl]
        for c in rd.y:
            meas[c][sl] = rd.y[c][sl]
            simd[c][sl] = sims[si][c][: sl.stop - sl.start]
    rms = {c: float(np.sqrt(np.nanmean((simd[c] - meas[c]) ** 2))) for c in rd.y}
    neff = {}
    for c in rd.y:
        ns = [
            (n, tau)
            for (r_i, _s, cc, _p, n), tau in zip(streams, taus, strict=True)
            if r_i == ri and cc == c
        ]
        neff[c] = float(sum(n / tau for n, tau in ns))
    return RunFit(
        rd.name,
        rd.method,
        rd.reason,
        [(float(rd.t[s.i0]), float(rd.t[s.i1 - 1])) for s in rd.segments],
        rd.excluded,
        {c: rd.sigma[c] for c in rd.y},
        rms,
        neff,
        tt,
        meas,
        simd,
    )


def run_fits(prob: Any, values: np.ndarray, taus: list[float]) -> list[RunFit]:
    """Per-run diagnostics and channels for the figures, simulated at ``values``."""
    sims = prob.simulate_all(values)
    return [_run_fit(rd, sims[ri], ri, prob.streams, taus) for ri, rd in enumerate(prob.runs)]


def fitted_params(
    prob: Any, values: np.ndarray, base_model: Any, estimates: dict, info: dict[str, Any]
) -> Any:
    """The fitted values in the base parameters (the supply and load damping as the user gave
    them), with ``meta['uncertainty']`` per parameter and ``meta['greybox']`` = ``info``."""
    names = prob.free
    fitted = prob.params_at(values)
    restore: dict[str, Any] = {"supply": base_model.params.supply}
    if "load.damping" not in names:
        restore["load.damping"] = base_model.params.load.damping
    fitted = fitted.replace(**restore)
    meta = dict(base_model.params.meta)
    unc = dict(meta.get("uncertainty", {}))
    for n, e in estimates.items():
        unc[n.replace(".", "_")] = {**e.to_dict(), "method": "grey-box output error"}
    meta["uncertainty"] = unc
    meta["greybox"] = info
    return dataclasses.replace(fitted, meta=meta)
