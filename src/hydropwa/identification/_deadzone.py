"""Dead band, creep and gain of the valve from constant-input runs (Sec. VI-B, Fig. 6, Table IV).

Each constant-command run gives one rod velocity, the slope of a least-squares
line through the position away from the end stop the rod moves towards. The
velocity-against-command points are fitted with a hinge model per direction,

    v = g₊ (u − β₊)      for u > β₊,
    v = c u              for −β₋ ≤ u ≤ β₊   (creep inside the band),
    v = g₋ (u + β₋)      for u < −β₋,

(with ``continuous=True`` the outer lines are lifted by c β± so v is continuous),
and the symmetric dead band β = (β₊ + β₋)/2 is reported. The creep slope c is a
velocity per command; the opening slope of Table IV is k_g = c / ḡ with the
mean outer gain ḡ = (g₊ + g₋)/2, since v ≈ ḡ·z near the band.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import numpy as np

from .._errors import IdentificationError
from ..params import DeadZone, SystemParams
from ._common import (
    FitResult,
    OptimizerStatus,
    ParameterEstimate,
    RigGeometry,
    SkippedRun,
    as_runs,
    channels_of,
    combination_std,
    estimate,
    not_fitted,
    require_usable,
    resolve_geometry,
    sandwich_covariance,
    signal_value,
    skip,
    t_quantile,
    within_physical_bounds,
)

__all__ = [
    "VelocityEstimate",
    "velocity_from_position",
    "DeadZoneFit",
    "fit_dead_zone",
    "dead_zone_velocity",
    "DeadZoneIdentifier",
]


@dataclasses.dataclass(frozen=True)
class VelocityEstimate:
    """Rod velocity from a least-squares line through the position.

    Attributes
    ----------
    velocity : float
        Slope ẋ [m/s].
    std : float
        Standard error of the slope [m/s] (white-residual formula; the residuals of
        real runs are correlated, so treat it as a lower bound).
    rms_residual : float
        RMS deviation of the position from the line [m] (Sec. VI-C: not exactly linear).
    window : tuple of float
        (t0, t1) [s] of the samples used.
    hit_stop : bool
        Whether the run reached the end stop (samples from there on were dropped).
    """

    velocity: float
    std: float
    rms_residual: float
    window: tuple[float, float]
    hit_stop: bool = False


def _line(t: np.ndarray, x: np.ndarray) -> tuple[float, float, float]:
    tc = t - t.mean()
    sxx = float(tc @ tc)
    slope = float(tc @ (x - x.mean())) / sxx
    r = x - x.mean() - slope * tc
    dof = max(t.size - 2, 1)
    s2 = float(r @ r) / dof
    return slope, float(np.sqrt(s2 / sxx)), float(np.sqrt(np.mean(r**2)))


def velocity_from_position(
    t,
    x,
    direction: float = 0.0,
    stroke: float | None = None,
    stop_margin: float = 1e-3,
    settle: float = 0.0,
    min_duration: float = 0.1,
    min_samples: int = 20,
) -> VelocityEstimate:
    """Rod velocity of a constant-input run from the slope of the position (Sec. VI-B).

    Parameters
    ----------
    t, x : array_like, shape (N,)
        Time [s] and rod position [m].
    direction : float
        Sign of the command (> 0: extending towards x = ``stroke``; < 0: retracting towards 0).
    stroke : float, optional
        Stroke l [m]. With a direction, samples from the first one within
        ``stop_margin`` of the stop ahead are dropped.
    stop_margin : float
        Distance [m] from the stop ahead at which the run counts as having hit it.
    settle : float
        Time [s] at the start of the run left out (valve opening transient).
    min_duration : float
        Shortest usable stretch [s].
    min_samples : int
        Fewest usable samples.

    Returns
    -------
    VelocityEstimate

    Raises
    ------
    IdentificationError
        When the usable stretch is too short (e.g. the run started at, or soon hit, the stop).
    """
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    keep = t >= t[0] + settle
    hit = False
    if stroke is not None and direction != 0:
        at_stop = x >= stroke - stop_margin if direction > 0 else x <= stop_margin
        idx = np.flatnonzero(at_stop & keep)
        if idx.size:
            hit = True
            keep &= np.arange(t.size) < idx[0]
    n = int(keep.sum())
    dur = float(t[keep][-1] - t[keep][0]) if n > 1 else 0.0
    if n < min_samples or dur < min_duration:
        where = f"hit the end stop at t = {t[idx[0]]:.3g} s; " if hit else ""
        raise IdentificationError(
            f"{where}only {dur:.3g} s ({n} samples) usable, need {min_duration:g} s and {min_samples} samples"
        )
    slope, sd, rms = _line(t[keep], x[keep])
    return VelocityEstimate(slope, sd, rms, (float(t[keep][0]), float(t[keep][-1])), hit)


def dead_zone_velocity(
    u,
    gain_pos: float,
    gain_neg: float,
    beta_pos: float,
    beta_neg: float,
    creep: float,
    continuous: bool = False,
    drift_pos: float = 0.0,
    drift_neg: float = 0.0,
) -> np.ndarray:
    """Hinge model of rod velocity against command [m/s] (Fig. 6), with a drift per direction.

    Parameters
    ----------
    u : array_like
        Constant command [1].
    gain_pos, gain_neg : float
        Outer slopes g₊, g₋ [m/s per unit command].
    beta_pos, beta_neg : float
        Band edges β₊, β₋ [1] (both positive; the band is −β₋ ≤ u ≤ β₊).
    creep : float
        Slope c inside the band [m/s per unit command] (valve creep, Table IV's k_g).
    continuous : bool
        Lift the outer lines by c·β± so the curve is continuous.
    drift_pos, drift_neg : float
        Velocity [m/s] added to every run with u ≥ 0 / u < 0: motion that does not come
        from the valve opening, such as piston leakage under the load (a run with u > 0
        starts retracted and one with u < 0 extended, so the two differ).
    """
    u = np.asarray(u, dtype=float)
    lift_p = creep * beta_pos if continuous else 0.0
    lift_n = creep * beta_neg if continuous else 0.0
    core = np.where(
        u > beta_pos,
        gain_pos * (u - beta_pos) + lift_p,
        np.where(u < -beta_neg, gain_neg * (u + beta_neg) - lift_n, creep * u),
    )
    return core + np.where(u >= 0, drift_pos, drift_neg)


@dataclasses.dataclass(frozen=True)
class DeadZoneFit(FitResult):
    """Hinge fit of velocity against command.

    Attributes
    ----------
    beta : ParameterEstimate
        Symmetric dead band β = (β₊ + β₋)/2 [1].
    beta_pos, beta_neg : ParameterEstimate
        Band edge per direction [1].
    gain_pos, gain_neg : ParameterEstimate
        Outer slopes [m/s per unit command].
    creep_velocity_slope : ParameterEstimate
        Slope inside the band [m/s per unit command].
    creep_slope : ParameterEstimate
        Opening slope k_g = c/ḡ inside the band [1] (DeadZone.creep_slope).
    rms_residual : float
        RMS velocity residual [m/s].
    n_points : int
        Number of velocity points.
    continuous : bool
        Model variant fitted.
    covariance : ndarray, shape (8, 8)
        Covariance of (g₊, g₋, β₊, β₋, c, d₊, d₋, C_L); rows of a term that was not
        fitted are 0.
    drift_pos, drift_neg : ParameterEstimate
        Velocity not proportional to the opening [m/s] for u ≥ 0 and u < 0 (piston leakage
        under the load); exactly 0 with std 0 where it was not fitted.
    leakage : ParameterEstimate or None
        Piston leakage coefficient C_L [m³/(s·Pa)] when the fit was given the chamber
        pressures (``leakage_regressor``); ``None`` otherwise.
    status : OptimizerStatus
        The search: every split of the commands, each a linear least-squares solve
        (``nfev`` = splits tried); always converged, the optimum is global.
    """

    beta: ParameterEstimate
    beta_pos: ParameterEstimate
    beta_neg: ParameterEstimate
    gain_pos: ParameterEstimate
    gain_neg: ParameterEstimate
    creep_velocity_slope: ParameterEstimate
    creep_slope: ParameterEstimate
    rms_residual: float
    n_points: int
    continuous: bool
    covariance: np.ndarray
    drift_pos: ParameterEstimate | None = None
    drift_neg: ParameterEstimate | None = None
    leakage: ParameterEstimate | None = None
    status: OptimizerStatus = dataclasses.field(
        default_factory=lambda: OptimizerStatus.closed_form("given")
    )

    def velocity(self, u) -> np.ndarray:
        """Fitted velocity [m/s] at command ``u`` [1]: the hinge with its drift.

        The leakage term −C_L·r depends on each run's chamber pressures, not on ``u``, so
        it is not part of this curve (compare with ``points_["v_valve"]`` of the identifier).
        """
        dp = self.drift_pos.value if self.drift_pos is not None else 0.0
        dn = self.drift_neg.value if self.drift_neg is not None else 0.0
        return dead_zone_velocity(
            u,
            self.gain_pos.value,
            self.gain_neg.value,
            self.beta_pos.value,
            self.beta_neg.value,
            self.creep_velocity_slope.value,
            self.continuous,
            dp,
            dn,
        )

    def _estimates(self) -> dict[str, ParameterEstimate]:
        return {
            f.name: v
            for f in dataclasses.fields(self)
            if isinstance(v := getattr(self, f.name), ParameterEstimate)
        }

    def dead_zone(self, alpha: float = 1.0) -> DeadZone:
        """The fit as a :class:`~hydropwa.params.DeadZone` (symmetric β, k_g = c/ḡ).

        The drift is not part of the valve: it stays out of ``creep_slope``, so a model
        with the cylinder's leakage does not count it twice.
        """
        return DeadZone(
            alpha=alpha,
            beta=float(np.clip(self.beta.value, 0.0, 0.999)),
            creep_slope=float(np.clip(self.creep_slope.value, 0.0, 0.999)),
            continuous=self.continuous,
        )


def _design(u, bp, bn, continuous, sides, r=None):
    """Design matrix in (g₊, g₋, c, d₊, d₋, C_L) for fixed band edges; ``sides`` = (fit d₊, fit d₋).

    ``r`` is the leakage regressor (P_A − P_B)/A_in per point; without it the C_L column is 0.
    """
    pos, neg = u > bp, u < -bn
    inner = ~(pos | neg)
    X = np.zeros((u.size, 6))
    X[pos, 0] = u[pos] - bp
    X[neg, 1] = u[neg] + bn
    X[inner, 2] = u[inner]
    if continuous:
        X[pos, 2] = bp
        X[neg, 2] = -bn
    if sides[0]:
        X[u >= 0, 3] = 1.0
    if sides[1]:
        X[u < 0, 4] = 1.0
    if r is not None:
        X[:, 5] = -r
    return X


def _fixed_beta_fit(u, v, bp, bn, continuous, sides=(False, False), r=None):
    """Slopes, drifts and leakage by linear least squares for fixed band edges; returns θ and the cost.

    θ = (g₊, g₋, β₊, β₋, c, d₊, d₋, C_L).
    """
    X = _design(u, bp, bn, continuous, sides, r)
    coef, *_ = np.linalg.lstsq(X, v, rcond=None)
    theta = np.array([coef[0], coef[1], bp, bn, coef[2], coef[3], coef[4], coef[5]])
    return theta, float(np.sum((X @ coef - v) ** 2))


def _split_fit(u, v, k_pos, k_neg, up, un, continuous, drift, r=None):
    """Best hinge fit with the first ``k_pos`` positive and ``k_neg`` negative commands inside the band.

    For a fixed split the model is linear in (g₊, a₊, g₋, a₋, c, d₊, d₋) with the outer lines
    g·u + a and the inner c·u + d; β₊ = (d₊ − a₊)/g₊ (or (a₊ − d₊)/(c − g₊) when continuous).
    A side's drift is fitted only when ``drift`` and the side has a command inside the band
    (otherwise it cannot be told from the band edge). A β outside the split's interval is
    clamped to it and the slopes are solved again.
    """
    lo_p = up[k_pos - 1] if k_pos > 0 else 0.0
    hi_p = up[k_pos]
    lo_n = un[k_neg - 1] if k_neg > 0 else 0.0
    hi_n = un[k_neg]
    pos, neg = u >= hi_p, u <= -hi_n
    inner = ~(pos | neg)
    sides = (drift and bool(np.any(inner & (u >= 0))), drift and bool(np.any(inner & (u < 0))))
    X = np.zeros((u.size, 8))
    X[pos, 0], X[pos, 1] = u[pos], 1.0
    X[neg, 2], X[neg, 3] = u[neg], 1.0
    X[inner, 4] = u[inner]
    if sides[0]:
        X[inner & (u >= 0), 5] = 1.0
    if sides[1]:
        X[inner & (u < 0), 6] = 1.0
    if r is not None:
        X[:, 7] = -r
    coef, *_ = np.linalg.lstsq(X, v, rcond=None)
    gp, ap, gn, an, c, dp, dn, _ = coef
    with np.errstate(divide="ignore", invalid="ignore"):
        bp = (ap - dp) / (c - gp) if continuous else (dp - ap) / gp
        bn = -(an - dn) / (c - gn) if continuous else (an - dn) / gn
    bp = float(np.clip(np.nan_to_num(bp, nan=lo_p), lo_p, hi_p * (1 - 1e-9)))
    bn = float(np.clip(np.nan_to_num(bn, nan=lo_n), lo_n, hi_n * (1 - 1e-9)))
    theta, cost = _fixed_beta_fit(u, v, bp, bn, continuous, sides, r)
    return theta, cost, sides


def fit_dead_zone(
    u,
    v,
    continuous: bool = False,
    level: float = 0.95,
    drift: bool = True,
    leakage_regressor=None,
) -> DeadZoneFit:
    """Fit the hinge model to velocity-against-command points (Sec. VI-B, Fig. 6).

    Parameters
    ----------
    u : array_like, shape (K,)
        Constant commands [1], both signs.
    v : array_like, shape (K,)
        Rod velocities [m/s] (see :func:`velocity_from_position`).
    continuous : bool
        Fit the continuous variant (see :func:`dead_zone_velocity`).
    level : float
        Confidence level [1].
    drift : bool
        Fit a velocity per direction that does not depend on the opening (piston leakage
        under the load). Without it, leakage under load reads as valve creep and an
        asymmetric band (issue 18).
    leakage_regressor : array_like, shape (K,), optional
        r = (P̄_A − P̄_B)/A_in per point [Pa/m²]: the chamber pressures averaged over the
        velocity window and the meter-in area (A_A for u ≥ 0, A_B for u < 0). With it the
        piston leakage C_L [m³/(s·Pa)] is fitted as its own parameter, v = hinge(u) − C_L·r
        (Eq. (9): the leakage flow C_L·(P_A − P_B) leaves the meter-in chamber), so a
        leakage that changes with the load pressure of each run is not read as creep or
        as a shifted band edge. :class:`DeadZoneIdentifier` forms it from the runs.

    Returns
    -------
    DeadZoneFit

    Raises
    ------
    IdentificationError
        With fewer than 3 points per direction or fewer than 7 points in all.

    Notes
    -----
    Exhaustive search over the splits of the commands into inside/outside the band
    (per direction at least two points outside): for each split the model is linear
    (outer lines g·u + a, inner c·u + d±), β± follow from the intercepts and are kept inside
    the split's interval. The best split is the global least-squares optimum. The
    covariance of (g₊, g₋, β₊, β₋, c, d₊, d₋) comes from the Jacobian of the model there.
    The drift d± shifts the whole branch (inside and outside the band) of its direction:
    leakage flow under a steady load difference is nearly the same with the valve open.
    """
    u = np.asarray(u, dtype=float)
    v = np.asarray(v, dtype=float)
    npos, nneg = int(np.sum(u > 0)), int(np.sum(u < 0))
    if npos < 3 or nneg < 3 or u.size < 7:
        raise IdentificationError(
            f"dead-zone fit needs at least 3 runs per direction and 7 in all; have {npos} with u > 0, "
            f"{nneg} with u < 0"
        )
    up = np.unique(u[u > 0])
    un = np.unique(-u[u < 0])
    r, r_scale = _scaled_regressor(leakage_regressor, u)
    best, best_sides, n_splits = _search_splits(u, v, up, un, continuous, drift, r)
    if r is not None and best[7] < 0:
        # leakage cannot be negative: the constrained optimum has C_L = 0 (its interval, from
        # the Jacobian with the C_L column, still says how much leakage the data allow)
        best, best_sides, n_more = _search_splits(u, v, up, un, continuous, drift, None)
        n_splits += n_more
    leak_v = 0.0 if r is None else best[7] * r
    resid = (
        dead_zone_velocity(
            u,
            best[0],
            best[1],
            best[2],
            best[3],
            best[4],
            continuous=continuous,
            drift_pos=best[5],
            drift_neg=best[6],
        )
        - leak_v
        - v
    )
    jac = _hinge_jacobian(u, best, continuous, r)
    free = [0, 1, 2, 3, 4] + [5 + i for i, on in enumerate(best_sides) if on]
    if r is not None:
        free.append(7)
    cov = np.zeros((8, 8))
    cov[np.ix_(free, free)] = sandwich_covariance(jac[:, free], resid)
    q = t_quantile(level, u.size - len(free))
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    gp, gn, bp, bn, c, dp, dn, cl = best
    beta = 0.5 * (bp + bn)
    beta_sd = combination_std(cov, np.array([0.0, 0.0, 0.5, 0.5, 0.0, 0.0, 0.0, 0.0]))
    gbar = 0.5 * (gp + gn)
    kg = c / gbar
    grad = np.array([-0.5 * c / gbar**2, -0.5 * c / gbar**2, 0.0, 0.0, 1.0 / gbar, 0.0, 0.0, 0.0])
    kg_sd = combination_std(cov, grad)
    return DeadZoneFit(
        beta=within_physical_bounds("beta", estimate(beta, beta_sd, q, "1", level)),
        beta_pos=within_physical_bounds("beta_pos", estimate(bp, sd[2], q, "1", level)),
        beta_neg=within_physical_bounds("beta_neg", estimate(bn, sd[3], q, "1", level)),
        gain_pos=within_physical_bounds("gain_pos", estimate(gp, sd[0], q, "m/s", level)),
        gain_neg=within_physical_bounds("gain_neg", estimate(gn, sd[1], q, "m/s", level)),
        creep_velocity_slope=estimate(c, sd[4], q, "m/s", level),
        creep_slope=estimate(kg, kg_sd, q, "1", level),
        rms_residual=float(np.sqrt(np.mean(resid**2))),
        n_points=int(u.size),
        continuous=continuous,
        covariance=cov,
        drift_pos=estimate(dp, sd[5], q, "m/s", level),
        drift_neg=estimate(dn, sd[6], q, "m/s", level),
        leakage=None
        if r is None
        else within_physical_bounds(
            "leakage", estimate(cl / r_scale, sd[7] / r_scale, q, "m**3/(s*Pa)", level)
        ),
        status=OptimizerStatus(
            True,
            f"global optimum of {n_splits} band splits (linear least squares each)",
            n_splits,
            None,
        ),
    )


def _scaled_regressor(leakage_regressor, u: np.ndarray) -> tuple[np.ndarray | None, float]:
    """The leakage regressor r/r_scale and r_scale (None, 1 without one)."""
    if leakage_regressor is None:
        return None, 1.0
    r = np.asarray(leakage_regressor, dtype=float)
    if r.shape != u.shape or not np.all(np.isfinite(r)):
        raise IdentificationError(
            "leakage_regressor needs one finite value per point (chamber pressures over the "
            "velocity window); leave it out to fit without a leakage term"
        )
    # C_L·r is m/s while r is ~1e9 Pa/m²: fit C_L·r_scale against r/r_scale so that the
    # SVD of the Jacobian sees every column at the same scale
    r_scale = float(np.max(np.abs(r))) or 1.0
    return r / r_scale, r_scale


def _search_splits(u, v, up, un, continuous: bool, drift: bool, reg):
    """The least-squares best of every split of the commands into inside/outside the band:
    (θ, the drift sides fitted, the number of splits)."""
    best, best_cost, best_sides = None, np.inf, (False, False)
    n = 0
    for kp in range(up.size - 1):
        for kn in range(un.size - 1):
            n += 1
            theta, cost, sides = _split_fit(u, v, kp, kn, up, un, continuous, drift, reg)
            if cost < best_cost * (1 - 1e-12):
                best, best_cost, best_sides = theta, cost, sides
    if best is None:
        raise IdentificationError("dead-zone fit: no split of the commands to fit")
    return best, best_sides, n


def _hinge_jacobian(u: np.ndarray, th: np.ndarray, continuous: bool, r=None) -> np.ndarray:
    """Analytic Jacobian of v = hinge(u) − C_L·r in (g₊, g₋, β₊, β₋, c, d₊, d₋, C_L)."""
    gp, gn, bp, bn, c = th[:5]
    pos, neg = u > bp, u < -bn
    inner = ~(pos | neg)
    J = np.zeros((u.size, 8))
    J[pos, 0] = u[pos] - bp
    J[neg, 1] = u[neg] + bn
    J[pos, 2] = -gp + (c if continuous else 0.0)
    J[neg, 3] = gn - (c if continuous else 0.0)
    J[inner, 4] = u[inner]
    if continuous:
        J[pos, 4] = bp
        J[neg, 4] = -bn
    J[u >= 0, 5] = 1.0
    J[u < 0, 6] = 1.0
    if r is not None:
        J[:, 7] = -r
    return J


class DeadZoneIdentifier:
    """Identify β, the creep slope and the outer gain from constant-input runs (Sec. VI-B).

    Parameters
    ----------
    params : SystemParams, optional
        Gives the stroke [m] (end-stop detection) and the dead-zone form fitted. Either
        this or ``geometry`` is required: there is no default rig.
    geometry : RigGeometry, optional
        The stroke without a full parameter set.
    continuous : bool or None
        Fit the continuous dead-zone variant; ``None`` (default) keeps the form of
        ``params.dead_zone`` (Table IV's, with the jump, when only ``geometry`` is given).
    drift : bool
        Fit a velocity per direction that does not come from the valve (piston leakage
        under the load), so it does not read as valve creep (see :func:`fit_dead_zone`).
    leakage : bool or None
        Fit the piston leakage C_L as its own parameter from the chamber pressures over
        each run's velocity window (``leakage_regressor`` of :func:`fit_dead_zone`).
        ``None`` (default): whenever every used run logs ``p_a`` and ``p_b`` and the
        areas are known; ``True`` makes a missing pressure channel an error.
    level : float
        Confidence level [1].
    stop_margin : float
        Distance [m] from the stop ahead at which a run counts as having hit it.
    settle : float
        Time [s] dropped at the start of each run.
    min_duration : float
        Shortest usable stretch of a run [s].

    Attributes
    ----------
    points_ : pandas.DataFrame
        One row per used run: ``run``, ``u`` [1], ``v`` [m/s], ``v_std`` [m/s],
        ``rms_residual`` [m], ``hit_stop``, and ``p_a``, ``p_b`` [Pa] (means over the
        velocity window; NaN where not logged). With the leakage fitted also ``v_valve``
        [m/s]: v + C_L·r, the velocity with the fitted leakage flow removed, which is what
        ``fit_.velocity(u)`` describes.
    leakage_ : ParameterEstimate or None
        Piston leakage C_L [m³/(s·Pa)] seen by the fit (``None`` when not fitted). It is
        reported, not applied: the cylinder's leakage stays that of ``params``.
    fit_ : DeadZoneFit
        The hinge fit, with its intervals and ``status``.
    beta_ : ParameterEstimate
        Symmetric dead band β [1].
    creep_slope_ : ParameterEstimate
        Opening slope k_g inside the band [1].
    dead_zone_ : DeadZone
        The fit as parameters (symmetric β, k_g = c/ḡ; α from ``params``, else 1).
    status_ : OptimizerStatus
        How the fit ended (``fit_.status``).
    skipped_ : list[SkippedRun]
        Runs left out, with the reason.

    Notes
    -----
    The command of a run is ``meta["level"]`` (or ``amplitude``, ``u``) when given,
    else the median of its ``u`` channel.
    """

    #: The experiment kind this estimator reads and the parameter field it sets.
    part: ClassVar[str] = "deadzone"
    field: ClassVar[str] = "dead_zone"

    def __init__(
        self,
        params: SystemParams | None = None,
        *,
        geometry: RigGeometry | None = None,
        continuous: bool | None = None,
        drift: bool = True,
        leakage: bool | None = None,
        level: float = 0.95,
        stop_margin: float = 1e-3,
        settle: float = 0.05,
        min_duration: float = 0.1,
    ) -> None:
        needs = ("stroke", "area_a", "area_b") if leakage else ("stroke",)
        self.geometry = resolve_geometry("DeadZoneIdentifier", params, geometry, needs)
        self.params = params
        self.continuous = continuous
        self.drift = drift
        self.leakage = leakage
        self.level = level
        self.stop_margin = stop_margin
        self.settle = settle
        self.min_duration = min_duration

    def fit(self, data) -> DeadZoneIdentifier:
        """Estimate one velocity per run and fit the hinge model.

        Returns
        -------
        DeadZoneIdentifier
            ``self`` with ``points_``, ``fit_``, ``beta_``, ``creep_slope_``, ``dead_zone_``,
            ``status_`` and ``skipped_`` set.

        Raises
        ------
        IdentificationError
            If too few runs are usable.
        """
        import pandas as pd  # deferred: pandas loads only for tables

        runs = as_runs(data, "deadzone")
        skipped: list[SkippedRun] = []
        rows = []
        for run in runs:
            ch = channels_of(run, ("t", "x"), skipped)
            if ch is None:
                continue
            level = command_level(run)
            if level is None:
                skip(skipped, run.name, "no command level (meta 'level' or channel 'u')")
                continue
            try:
                est = velocity_from_position(
                    ch["t"],
                    ch["x"],
                    np.sign(level),
                    self.geometry.stroke,
                    self.stop_margin,
                    self.settle,
                    self.min_duration,
                )
            except IdentificationError as exc:
                skip(skipped, run.name, str(exc))
                continue
            rows.append(
                {
                    "run": run.name,
                    "u": level,
                    "v": est.velocity,
                    "v_std": est.std,
                    "rms_residual": est.rms_residual,
                    "hit_stop": est.hit_stop,
                    **_window_pressures(run, ch["t"], est.window),
                }
            )
        require_usable(rows, skipped, "dead-zone identification", minimum=7)
        pts = pd.DataFrame(rows).sort_values("u", ignore_index=True)
        self.points_ = pts
        if self.continuous is not None:
            continuous = bool(self.continuous)
        else:
            continuous = self.params.dead_zone.continuous if self.params is not None else False
        u = pts["u"].to_numpy()
        r = self._leakage_regressor(u, pts["p_a"].to_numpy(), pts["p_b"].to_numpy())
        self.fit_ = fit_dead_zone(u, pts["v"].to_numpy(), continuous, self.level, self.drift, r)
        self.leakage_ = self.fit_.leakage
        if r is not None and self.leakage_ is not None:
            # what the valve alone would give: the points the hinge curve (fit_.velocity) fits
            pts["v_valve"] = pts["v"] + self.leakage_.value * r
        alpha = self.params.dead_zone.alpha if self.params is not None else 1.0
        self.dead_zone_ = self.fit_.dead_zone(alpha)
        self.beta_ = self.fit_.beta
        self.creep_slope_ = self.fit_.creep_slope
        self.status_ = self.fit_.status
        self.skipped_ = skipped
        return self

    def _leakage_regressor(self, u, p_a, p_b) -> np.ndarray | None:
        """(P̄_A − P̄_B)/A_in per point, or ``None`` when the leakage is not fitted."""
        geo = self.geometry
        have = bool(np.all(np.isfinite(p_a) & np.isfinite(p_b)))
        if self.leakage is False or (
            self.leakage is None and (not have or geo.area_a is None or geo.area_b is None)
        ):
            return None
        if not have:
            raise IdentificationError(
                "DeadZoneIdentifier(leakage=True) needs p_a and p_b in every constant-input "
                "run; map the pressure channels or pass leakage=False"
            )
        assert geo.area_a is not None and geo.area_b is not None
        return (p_a - p_b) / np.where(u >= 0, geo.area_a, geo.area_b)

    def apply(self, params: SystemParams) -> SystemParams:
        """``params`` with the fitted β, k_g and form; α (saturation) stays that of ``params``."""
        if not hasattr(self, "fit_"):
            raise not_fitted("DeadZoneIdentifier")
        return dataclasses.replace(params, dead_zone=self.fit_.dead_zone(params.dead_zone.alpha))

    def provenance(self) -> str:
        """One line on how the dead zone was found (``[meta.identification]``)."""
        if not hasattr(self, "fit_"):
            raise not_fitted("DeadZoneIdentifier")
        fit = self.fit_
        drift = (
            ""
            if fit.drift_pos is None or fit.drift_neg is None
            else f"; drift (leakage, load) {1e3 * fit.drift_pos.value:.3g} / "
            f"{1e3 * fit.drift_neg.value:.3g} mm/s for u ≥ 0 / u < 0, kept out of the creep"
        )
        if fit.leakage is not None:
            drift += (
                f"; piston leakage {fit.leakage.value:.3g} m³/(s·Pa) fitted from the chamber "
                "pressures (reported, not applied)"
            )
        return (
            f"Sec. VI-B: {len(self.points_)} constant-input runs, "
            f"{'continuous' if fit.continuous else 'Table IV (discontinuous)'} hinge fit; "
            f"creep_slope = creep velocity slope / mean outer gain; alpha from base{drift}; "
            f"optimiser: {fit.status}"
        )

    def uncertainty(self) -> dict:
        """β, k_g and the per-direction values as a plain dict (``[uncertainty]`` table)."""
        f = self.fit_
        return {
            "beta": f.beta.to_dict(),
            "creep_slope": f.creep_slope.to_dict(),
            "beta_pos": f.beta_pos.to_dict(),
            "beta_neg": f.beta_neg.to_dict(),
            "gain_pos": f.gain_pos.to_dict(),
            "gain_neg": f.gain_neg.to_dict(),
            "creep_velocity_slope": f.creep_velocity_slope.to_dict(),
            **(
                {"drift_pos": f.drift_pos.to_dict(), "drift_neg": f.drift_neg.to_dict()}
                if f.drift_pos is not None and f.drift_neg is not None
                else {}
            ),
            **({"leakage": f.leakage.to_dict()} if f.leakage is not None else {}),
            "optimizer": dataclasses.asdict(f.status),
        }


def _window_pressures(run, t: np.ndarray, window: tuple[float, float]) -> dict[str, float]:
    """Chamber pressures [Pa] averaged over the velocity window (NaN where not logged)."""
    out = {}
    for name in ("p_a", "p_b"):
        val = np.nan
        if name in run.channels:
            y = np.asarray(run.channels[name], dtype=float)
            w = (t >= window[0]) & (t <= window[1]) & np.isfinite(y)
            if y.shape == t.shape and np.any(w):
                val = float(np.mean(y[w]))
        out[name] = val
    return out


def command_level(run) -> float | None:
    """Constant command of a run [1].

    ``meta["level"]`` (signed) first, then the median of the second half of the ``u``
    channel, then ``amplitude``/``opening`` (taken as given, sign included).
    """
    lv = signal_value(run, "level", "u")
    if lv is not None:
        try:
            return float(lv)
        except (TypeError, ValueError):
            pass
    if "u" in run.channels:
        u = np.asarray(run.channels["u"], dtype=float)
        u = u[np.isfinite(u)]
        if u.size:
            return float(np.median(u[u.size // 2 :]))
    lv = signal_value(run, "amplitude", "opening")
    try:
        return None if lv is None else float(lv)
    except (TypeError, ValueError):
        return None
