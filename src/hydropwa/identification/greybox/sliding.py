"""The sliding stage: every free parameter but the breakaway ones refitted on the stretches
where the rod slides faster than twice the Stribeck velocity (see :func:`sliding_stage`)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import numpy as np

from ...params import SystemParams
from .data import RunData, Shooting, prepare_again
from .intervals import scan_widen
from .jacobian import FiniteDifferenceJacobian
from .objective import OutputErrorObjective, loss_cost
from .optimize import LeastSquares
from .problem import GreyBoxProblem
from .result import StageResult
from .selection import restrict
from .uncertainty import covariance, join_held, kappa, remaining_step

__all__ = ["BREAKAWAY", "Sliding", "SlidingSettings", "sliding_runs", "sliding_stage"]

#: stick parameters held at the full fit's values in the sliding stage: they act at and
#: around zero speed, where the sliding stretches carry no information on them
BREAKAWAY = frozenset(
    ("friction.static", "friction.stribeck_velocity", "friction.shape", "friction.smoothness")
)


@dataclasses.dataclass(frozen=True)
class SlidingSettings:
    """The fit's settings the sliding stage uses (the optimiser's, the simulation's, the
    covariance's)."""

    rtol: float
    jobs: int | None
    fd_step: float
    optimizer: LeastSquares
    nuisance_draws: int
    rng: np.random.Generator


@dataclasses.dataclass
class Sliding:
    """Result of the sliding stage (see :func:`sliding_stage`)."""

    index: list[int]  # positions of its parameters among the fit's
    prob: Any
    theta: np.ndarray
    tlo: np.ndarray
    thi: np.ndarray
    cost: float
    cov: np.ndarray  # over all of the fit's parameters (the held ones propagated)
    naive: np.ndarray  # s²(H⁻¹)_ii of its own parameters
    kappa: np.ndarray
    half_lo: np.ndarray
    half_hi: np.ndarray
    scan: dict[int, tuple[float, float]]
    widened: list[int]
    left_sd: np.ndarray  # the Gauss–Newton step still left, in standard deviations
    info: dict[str, Any]
    stage: StageResult


def sliding_runs(
    pairs: list[tuple[Any, RunData]],
    work_model: Any,
    base: SystemParams,
    n_free: int,
    channels: tuple[str, ...],
    shooting: Shooting,
    input_cutoff: float | None,
    keep: dict[str, list[tuple[float, float]]] | None = None,
    feedback: float | Callable[[Any], float] = 0.0,
) -> tuple[Any, float, list[RunData]] | dict[str, Any]:
    """The sliding stage's data: the model at the full fit's values, v_min = 2 v_s and each
    single-shot run's stretches above it; or a dict with the reason the stage does not apply
    (no falling branch, too few stretches for ``n_free`` parameters, no reversals)."""
    v_min = 2.0 * float(base.friction.stribeck_velocity)
    if not (v_min > 0.0):
        return {"skipped": "the Stribeck velocity is zero (no falling branch to leave out)"}
    model = type(work_model)(base)
    runs = []
    low_share = [0.0]
    for r, rd in pairs:
        if rd.method != "single":
            continue
        fb = feedback(r) if callable(feedback) else feedback
        sl = prepare_again(
            r, model, channels, shooting, [], input_cutoff, sliding_above=v_min, feedback=fb
        )
        if sl is not None and keep is not None:  # a campaign's selection: its spans alone
            sl = restrict(sl, keep.get(sl.name, []))
        if sl is None or not sl.segments:
            continue
        covered = sum(s.i1 - s.i0 for s in rd.segments)
        low_share.append(1.0 - sum(s.i1 - s.i0 for s in sl.segments) / max(covered, 1))
        runs.append(sl)
    n_str = sum(len(rd.segments) for rd in runs)
    if n_str < 2 * n_free:
        return {"skipped": f"{n_str} sliding stretches above {1e3 * v_min:.3g} mm/s (too few)"}
    if max(low_share) < 0.02:
        return {"skipped": "the single-shot runs hardly pass through the falling branch"}
    return model, v_min, runs


def sliding_stage(
    sliding: tuple[Any, float, list[RunData]],
    problem: GreyBoxProblem,
    values: np.ndarray,
    cov: np.ndarray,
    channels: tuple[str, ...],
    sigma: dict[str, float],
    settings: SlidingSettings,
    z: float,
    scan_intervals: bool,
) -> Sliding:
    """Refit every free parameter but the breakaway ones on the sliding stretches alone.

    Around a velocity reversal the rod decelerates into the falling branch of the Stribeck
    curve, sticks, breaks away and accelerates through that branch again: a negative damping
    on which the simulated motion runs away from the measured one for a small change of
    state or parameter. In single shooting that error persists over the rest of the segment
    and dominates the cost's dependence on the Coulomb friction, whose 21 N (paper rig) are a
    small part of the force while sliding. Measured on the rig's 5 s sine runs at the true
    parameters: mean square residuals 4–11 (noise units) below 32 mm/s against 1.0–1.5 above
    128 mm/s, and F_c's sandwich variance 2.5·10⁴ times its white-noise value; the full fit's
    F_c −11 … +6 % over seeds 1–6.

    Here each run's stretches with |v| > 2 v_s (v_s the Stribeck velocity; at least one
    window long, cut into ``shooting.segment`` pieces) are simulated from the measured state
    at their start, with the breakaway parameters (F_s, v_s, shape, smoothness) held at the
    full fit's values. Their covariance is propagated: with G = −H⁻¹JᵀJ_b the estimate's
    sensitivity to the held parameters, Cov = Cov_sliding + G·Cov_b·Gᵀ (cross terms G·Cov_b).
    ``sliding`` is :func:`sliding_runs`'s model, v_min and stretches.
    """
    names = problem.names
    i_held = problem.index(BREAKAWAY)
    i_free = [i for i in range(len(names)) if i not in i_held]
    model, v_min, runs = sliding
    sub = problem.fix(BREAKAWAY, values)
    prob = OutputErrorObjective(
        model,
        runs,
        sub.names,
        channels,
        settings.rtol,
        settings.jobs,
        sigma,
        ref=sub.ref,
        fd_step=settings.fd_step,
    )
    tlo, thi = sub.theta_bounds
    opt = settings.optimizer
    if not isinstance(opt.x_scale, str) and np.ndim(opt.x_scale) > 0:
        # per parameter: the refitted ones
        opt = dataclasses.replace(opt, x_scale=np.asarray(opt.x_scale, dtype=float)[i_free])
    # forward differences: the walk from the full fit's values is short and smooth (no
    # stick events), and the covariance below takes central ones at the result
    # (benchmark seed 1: 44 against 76 simulations, F_c 20.962 against 20.956 N)
    jac = FiniteDifferenceJacobian(prob, settings.fd_step, differences="forward")
    sol = dataclasses.replace(opt, ftol=1e-6, gtol=1e-8, verbose=0).solve(
        prob.fun, sub.clip(np.zeros(len(i_free))), jac, (tlo, thi)
    )
    theta = sol.x
    cv, c2, left_sd, s2, kap, half_lo, half_hi, scan, widened = _uncertainty(
        prob, theta, opt, settings, z, scan_intervals, (tlo, thi)
    )
    G = _held_sensitivity(prob, theta, problem, values, i_held, runs, cv, settings)
    info = {
        "parameters": list(sub.names),
        "held": [names[i] for i in i_held],
        "v_min": v_min,
        "stretches": sum(len(rd.segments) for rd in runs),
        "runs": [rd.name for rd in runs],
        "cost": float(sol.cost),
        "nfev": int(sol.nfev),
        "njev": int(sol.njev or 0),
        "status": int(sol.status),
        "remaining_std": float(left_sd.max(initial=0.0)),
    }
    return Sliding(
        i_free,
        prob,
        theta,
        tlo,
        thi,
        float(sol.cost),
        join_held(cov, c2, G, i_free, i_held),
        np.diag(cv.Hinv) * s2,
        kap,
        half_lo,
        half_hi,
        scan,
        widened,
        left_sd,
        info,
        StageResult.from_scipy("sliding", sol),
    )


def _uncertainty(
    prob: OutputErrorObjective,
    theta: np.ndarray,
    opt: LeastSquares,
    settings: SlidingSettings,
    z: float,
    scan_intervals: bool,
    bounds: tuple[np.ndarray, np.ndarray],
) -> tuple:
    """The refit's covariance (central differences at its result, the remaining step added),
    its naive scale, κ and the interval scan: (cv, cov, left_sd, s², κ, half_lo, half_hi,
    scan, widened)."""
    r = prob.fun(theta)
    J = prob.jac(theta, settings.fd_step, central=True)
    cv = covariance(prob, theta, r, J, opt.loss, opt.f_scale, settings.nuisance_draws, settings.rng)
    # the Gauss–Newton step still left (a bias² term, as in the full fit)
    left = remaining_step(cv.H, cv.Jw, cv.rw)
    with np.errstate(invalid="ignore", divide="ignore"):
        left_sd = np.nan_to_num(np.abs(left) / np.sqrt(np.diag(cv.cov)))
    c2 = cv.cov + np.outer(left, left)
    s2 = float(cv.rw @ cv.rw) / max(r.size - theta.size, 1)
    kap = kappa(c2, cv.Hinv)
    sd = np.sqrt(np.clip(np.diag(c2), 0.0, None))
    half_lo = half_hi = z * sd
    scan: dict[int, tuple[float, float]] = {}
    widened: list[int] = []
    if scan_intervals:
        c2, half_lo, half_hi, scan = scan_widen(
            prob, theta, cv.Hinv, c2, z, *bounds, lambda rr: _cost(rr, opt)
        )
        widened = [k for k in range(theta.size) if max(half_lo[k], half_hi[k]) > z * sd[k]]
    return cv, c2, left_sd, s2, kap, half_lo, half_hi, scan, widened


def _cost(r: np.ndarray, opt: LeastSquares) -> float:
    return loss_cost(r, opt.loss, opt.f_scale)


def _held_sensitivity(
    prob: OutputErrorObjective,
    theta: np.ndarray,
    problem: GreyBoxProblem,
    values: np.ndarray,
    i_held: list[int],
    runs: list[RunData],
    cv: Any,
    settings: SlidingSettings,
) -> np.ndarray:
    """G = −H⁻¹JᵀJ_b: how the refit's estimate moves with the held parameters."""
    if not i_held:
        return np.zeros((theta.size, 0))
    held = OutputErrorObjective(
        type(prob.base_model)(prob.params_at(prob.values(theta))),
        runs,
        tuple(problem.names[i] for i in i_held),
        prob.channels,
        settings.rtol,
        settings.jobs,
        prob.sigma,
        ref=values[i_held].copy(),
    )
    Jb = held.jac(np.zeros(len(i_held)), settings.fd_step, central=True) * cv.w[:, None]
    return -cv.Hinv @ (cv.Jw.T @ Jb)
