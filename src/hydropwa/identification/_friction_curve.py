"""The Stribeck curve of Eq. (11) fitted to friction points: bounded robust least squares.

    f(ẋ) = tanh(γẋ)·(F_c + (F_s − F_c)·exp(−|ẋ/χ|^δ)) + σẋ,

in (F_c, F_s − F_c, σ, log10 χ, δ, log10 γ) with many starts; for fixed (χ, δ, γ) the model
is linear in (F_c, F_s, σ), which gives each start its linear part exactly.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from .._errors import IdentificationError
from ..components import stribeck_friction
from ..params import Friction
from ._common import (
    FitResult,
    OptimizerStatus,
    ParameterEstimate,
    correlation,
    sandwich_covariance,
    t_quantile,
    within_physical_bounds,
)

#: Friction field names in the order of the fit vector.
STRIBECK_NAMES = ("coulomb", "static", "viscous", "stribeck_velocity", "shape", "smoothness")
_UNITS = {
    "coulomb": "N",
    "static": "N",
    "viscous": "N·s/m",
    "stribeck_velocity": "m/s",
    "shape": "1",
    "smoothness": "s/m",
}


def _default_bounds(vmin: float) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of θ for data whose slowest speed is ``vmin`` [m/s] (see :func:`fit_stribeck`)."""
    lb = np.array([0.0, 0.0, 0.0, np.log10(vmin / 10.0), 0.5, np.log10(3.0 / vmin)])
    ub = np.array([1e5, 1e5, 1e7, 0.0, 5.0, 7.0])
    lb[5] = min(lb[5], 6.0)
    return lb, ub


def curve_maximum(friction: Friction, v_max: float = 1.0) -> tuple[float, float]:
    """Largest friction force of Eq. (11) over 0 < ẋ ≤ ``v_max`` and where it lies.

    Returns
    -------
    f_max, v_at : float
        The maximum [N] (the break-away force of the curve; below F_s by the tanh rounding,
        e.g. 0.83·F_s for the paper's set) and its velocity [m/s]. The first local maximum
        (the Stribeck peak) is returned when σ·ẋ makes the curve rise again at high speed.
    """
    return _curve_max(_theta_of(friction), v_max)


def _curve_max(th: np.ndarray, v_max: float = 1.0) -> tuple[float, float]:
    from scipy.optimize import (
        minimize_scalar,  # deferred: scipy submodule, loaded only when fitting
    )

    vg = np.logspace(-7, np.log10(v_max), 400)
    fg = _eval(vg, th)
    # first local maximum (Stribeck peak), else the global one
    loc = np.flatnonzero((fg[1:-1] >= fg[:-2]) & (fg[1:-1] >= fg[2:])) + 1
    k = int(loc[0]) if loc.size else int(np.argmax(fg))
    lo, hi = np.log(vg[max(k - 1, 0)]), np.log(vg[min(k + 1, vg.size - 1)])
    res = minimize_scalar(
        lambda z: -float(_eval(np.array([np.exp(z)]), th)[0]),
        bounds=(lo, hi),
        method="bounded",
        options={"xatol": 1e-6},
    )
    z = float(res.x) if -res.fun >= fg[k] else float(np.log(vg[k]))
    return float(_eval(np.array([np.exp(z)]), th)[0]), float(np.exp(z))


def _velocity_bins(
    v: np.ndarray, f: np.ndarray, rel: float, width: float, min_count: int
) -> np.ndarray:
    """(median v, median f) per velocity bin of width max(rel·|v|, width), per direction; shape (K, 3) with count."""
    out = []
    for s in (1.0, -1.0):
        sel = np.sign(v) == s
        if not sel.any():
            continue
        vs, fs = s * v[sel], f[sel]
        edges = [float(vs.min())]
        while edges[-1] <= vs.max():
            edges.append(edges[-1] + max(rel * edges[-1], width))
        idx = np.digitize(vs, edges)
        for k in np.unique(idx):
            m = idx == k
            if m.sum() >= min_count:
                out.append((s * float(np.median(vs[m])), float(np.median(fs[m])), int(m.sum())))
    return np.array(out, dtype=float).reshape(-1, 3)


@dataclasses.dataclass(frozen=True)
class StribeckFit(FitResult):
    """Eq. (11) fitted to velocity–force points.

    Attributes
    ----------
    friction : Friction
        The fitted curve as parameters (PWA code turns it into 7 cells).
    estimates : dict[str, ParameterEstimate]
        Per Friction field; χ and γ intervals come from the log10 scale (asymmetric).
    correlation : ndarray, shape (p, p)
        Correlation of the free fit parameters, in ``free`` order (log10 for χ, γ;
        F_s − F_c for the static entry).
    free : tuple of str
        Names of the free parameters.
    weak : tuple of str
        Parameters the data barely determine (CI wider than ±50 %, a factor 2 on
        the log scale, or at a bound).
    unidentified : tuple of str
        Parameters the data do not determine: the estimate sits at a bound of the fit with
        a confidence interval wider than half its value, or the interval covers the whole
        bounded range. Not written as values (:meth:`StribeckIdentifier.apply` keeps the
        given parameters' value) and reported as not identified.
    velocity, force, residuals : ndarray
        Data [m/s], [N] and residuals f_data − f_model [N].
    band : (ndarray, ndarray, ndarray)
        The curve's pointwise confidence band over the speeds the data excite: speeds [m/s]
        (25, log-spaced from the slowest to the fastest point; the curve is odd) and the
        band's low and high force [N] there, the envelope over every shape the data do not
        reject (:func:`_profile_shape`). The curve is determined there where single
        parameters (F_s against δ and χ) are not.
    rms_residual : float
        RMS residual [N].
    loss : str
        Loss function used.
    n_starts : int
        Number of starting points tried.
    status : OptimizerStatus
        How the final (robust) ``least_squares`` run ended; ``nfev`` counts the residual
        evaluations of every start and stage.
    """

    friction: Friction
    estimates: dict[str, ParameterEstimate]
    correlation: np.ndarray
    free: tuple[str, ...]
    weak: tuple[str, ...]
    velocity: np.ndarray
    force: np.ndarray
    residuals: np.ndarray
    rms_residual: float
    loss: str
    n_starts: int
    status: OptimizerStatus
    unidentified: tuple[str, ...] = ()
    band: tuple[np.ndarray, np.ndarray, np.ndarray] = dataclasses.field(
        default=(np.zeros(0), np.zeros(0), np.zeros(0)), repr=False
    )

    def _estimates(self) -> dict[str, ParameterEstimate]:
        return self.estimates

    def plot(self, *, ax: Any = None) -> Any:
        """The friction points, the fitted curve (11) and the residuals (Fig. 8)."""
        from ..plotting import plot_stribeck  # deferred: matplotlib loads only when plotting

        return plot_stribeck(self, self, ax=ax)

    def force_at(self, v) -> np.ndarray:
        """Fitted friction force [N] at velocity ``v`` [m/s]."""
        return _eval(np.asarray(v, dtype=float), _theta_of(self.friction))


def _theta_of(fr: Friction) -> np.ndarray:
    return np.array(
        [
            fr.coulomb,
            fr.static - fr.coulomb,
            fr.viscous,
            np.log10(fr.stribeck_velocity),
            fr.shape,
            np.log10(fr.smoothness),
        ]
    )


def _eval(v: np.ndarray, th: np.ndarray) -> np.ndarray:
    fc, dfs, sigma, lchi, delta, lgam = th
    return stribeck_friction(v, fc, fc + dfs, sigma, 10.0**lchi, delta, 10.0**lgam)


def _jac_theta(v: np.ndarray, th: np.ndarray) -> np.ndarray:
    """Analytic Jacobian of Eq. (11) in θ = (F_c, F_s − F_c, σ, log10 χ, δ, log10 γ), shape (K, 6)."""
    fc, dfs, _, lchi, delta, lgam = th
    chi, gam = 10.0**lchi, 10.0**lgam
    sgn = np.tanh(gam * v)
    ratio = np.abs(v) / chi
    with np.errstate(divide="ignore"):
        logr = np.where(ratio > 0, np.log(np.where(ratio > 0, ratio, 1.0)), 0.0)
    a = ratio**delta
    e = np.exp(-a)
    ln10 = np.log(10.0)
    return np.column_stack(
        [
            sgn,
            sgn * e,
            v,
            sgn * dfs * e * delta * a * ln10,
            -sgn * dfs * e * a * logr,
            (fc + dfs * e) * v * (1.0 - sgn**2) * gam * ln10,
        ]
    )


def _linear_part(
    v: np.ndarray, f: np.ndarray, lchi: float, delta: float, lgam: float
) -> np.ndarray:
    """(F_c, F_s − F_c, σ) ≥ 0 by linear least squares for fixed χ, δ, γ."""
    s = np.tanh(10.0**lgam * v)
    e = np.exp(-(np.abs(v / 10.0**lchi) ** delta))
    X = np.column_stack([s * (1.0 - e), s * e, v])
    coef, *_ = np.linalg.lstsq(X, f, rcond=None)
    fc, fs, sigma = np.clip(coef, 0.0, None)
    return np.array([fc, max(fs - fc, 0.0), sigma])


def fit_stribeck(
    v,
    f,
    fixed: dict[str, float] | None = None,
    loss: str = "soft_l1",
    f_scale: float | None = None,
    n_starts: int = 24,
    level: float = 0.95,
    seed: int = 0,
    bounds: dict[str, tuple[float, float]] | None = None,
    breakaway: tuple[float, float] | None = None,
) -> StribeckFit:
    """Fit the Stribeck curve, Eq. (11), to velocity–force points (Fig. 8).

    Unless γ is fixed or bounded by the caller, the fit is done twice: with γ ≥ 3/v_min
    (the zero crossing sharper than the slowest point: tanh(γ·v_min) > 0.995) and with
    γ ≥ 0.3/v_min (the slowest points may lie on the tanh corner). The wider family is
    taken only when it lowers the sum of squared residuals significantly (F-test at 95 %
    for one extra degree of freedom): with creeping runs at ~1 mm/s the data do show the
    corner, and forcing tanh ≈ 1 there biased F_s by −13 … −16 % on the virtual rig; with
    all points at several mm/s the wide family only trades γ against F_s and is rejected.

    Parameters
    ----------
    v : array_like, shape (K,)
        Steady velocities [m/s], both directions.
    f : array_like, shape (K,)
        Friction forces [N] from Eq. (10).
    fixed : dict, optional
        Friction fields held fixed, e.g. ``{"shape": 1.0}`` (SI values).
    loss : str
        ``least_squares`` loss (``"soft_l1"`` keeps a stray point from dragging the curve).
    f_scale : float, optional
        Residual scale [N] of the robust loss; default 1.4826·MAD of a first linear-loss fit.
    n_starts : int
        Number of starting points over (log χ, δ, log γ); a grid plus random draws.
    level : float
        Confidence level [1].
    seed : int
        Seed of the random starts.
    bounds : dict, optional
        (low, high) per Friction field in SI units, replacing the defaults (see
        :func:`_fit_stribeck_bounded`).
    breakaway : (float, float), optional
        Measured break-away force F_b [N] and its standard error: adds the residual
        (max_{ẋ>0} f(ẋ) − F_b)/std, scaled like a point of the fit's robust residual scale
        (its gradient is ∂f/∂θ at the maximising ẋ, by the envelope theorem). The maximum
        lies below F_s by the tanh rounding, so γ should be fixed when this is used.

    Returns
    -------
    StribeckFit

    Raises
    ------
    IdentificationError
        With fewer points than free parameters + 2, or points in one direction only.
    """
    s = _Settings(fixed, loss, f_scale, n_starts, level, seed, bounds, breakaway)
    if "smoothness" in (fixed or {}) or "smoothness" in (bounds or {}):
        fit = _fit_stribeck_bounded(v, f, s)
        return _profile_shape(v, f, fit, None, max(fit.velocity.size - len(fit.free), 1), s)
    va = np.abs(np.asarray(v, dtype=float))
    vmin = max(float(np.min(va[va != 0])) if np.any(va != 0) else 1e-6, 1e-6)
    strict, wide = (
        _fit_stribeck_bounded(
            v, f, dataclasses.replace(s, bounds={**(bounds or {}), "smoothness": (g / vmin, 1e7)})
        )
        for g in (3.0, 0.3)
    )
    ssr_s = float(np.sum(strict.residuals**2))
    ssr_w = float(np.sum(wide.residuals**2))
    dof = max(strict.velocity.size - len(wide.free), 1)
    chosen = wide if ssr_s - ssr_w > 3.84 * ssr_w / dof else strict
    total = strict.status.nfev + wide.status.nfev
    chosen = dataclasses.replace(chosen, status=dataclasses.replace(chosen.status, nfev=total))
    return _profile_shape(v, f, chosen, 0.3 / vmin, dof, s)


#: the curve's shape parameters (θ index, name): constant-speed data trade each of them
#: against F_s and F_c along valleys the covariance at the optimum does not see
_SHAPE = ((3, "stribeck_velocity"), (4, "shape"), (5, "smoothness"))


def _profile_shape(
    v, f, best: StribeckFit, g_low: float | None, dof: int, s: _Settings
) -> StribeckFit:
    """Intervals that carry the weak directions: a profile over each shape parameter.

    The covariance at the optimum is the one *at that shape*, as if χ, δ and γ were known
    where the data barely pin them. On the paper rig (issue 18, seed 20 of the coverage
    study) one point at 1.5 mm/s gave F_s = 161.0 ± 0.7 N at γ = 3·10⁴ (truth 174.8 N:
    19σ), while γ = 1325 (the truth) fits nearly as well (ΔSSR/s² = 3.2 < 3.84) with
    F_s = 172.2 N; a campaign with δ 1.6 and χ 11 mm/s (issue 49) trades δ and χ against F_s
    the same way. So, per shape parameter not held by the caller, the fit is repeated with
    that parameter held at points walked outward from the optimum in steps of a fifth of
    its bounded range (log χ, δ, log γ; γ from ``g_low`` [s/m] unless the caller bounds
    it), each started from its neighbour's fit, until a fit is significantly worse or the
    bound is reached; that edge is found by false position (:func:`_edge`), and each parameter's interval
    becomes the envelope of the intervals of every held value whose fit is not
    significantly worse (ΔSSR/s² ≤ χ²₁(95 %) = 3.84), the held parameter's own interval
    the accepted range; std = half-width / q. The curve's band (:attr:`StribeckFit.band`)
    is the envelope of theirs. A parameter whose interval then exceeds ±50 % (a factor 2
    for χ, γ) is flagged weak; one whose accepted range reaches both ends of its bounds
    is not identified.
    """
    ssr0 = float(np.sum(best.residuals**2))
    s2 = ssr0 / max(dof, 1)
    fixed = dict(s.fixed or {})
    # the profile's fits keep the caller's fixed values and bounds; each starts from its
    # neighbour's fit and from a few of the usual starts (a warm start alone stalled on the
    # tanh corner: seed 20 of the coverage study accepted no other γ)
    s = dataclasses.replace(s, n_starts=4)
    pr = _problem(np.asarray(v, float), np.asarray(f, float), s)
    lb, ub = pr.lb_all.copy(), pr.ub_all.copy()
    if g_low is not None and "smoothness" not in (s.bounds or {}):
        lb[5] = min(lb[5], np.log10(g_low))
        s = dataclasses.replace(
            s, bounds={**(s.bounds or {}), "smoothness": (float(10.0 ** lb[5]), 1e7)}
        )
    th0 = _theta_of(best.friction)
    est = dict(best.estimates)
    band = best.band
    nfev, used = best.status.nfev, 0
    unidentified = best.unidentified
    q = t_quantile(next(iter(est.values())).level if est else 0.95, dof)

    # a held shape whose least-squares fit already misses by twice the test's margin is
    # rejected without its robust refits (they cannot lower the sum of squares below the
    # least-squares optimum of the same starts)
    cap = ssr0 + 2.0 * 3.84 * s2

    limit = 3.84 * s2  # ΔSSR of a held shape that fits as well (χ²₁ 95 %)

    def trial(i: int, name: str, x: float, near: StribeckFit) -> tuple[StribeckFit | None, float]:
        """The fit with the shape held at x (None where it is significantly worse) and its
        ΔSSR − limit (≤ 0: accepted; a capped fit's is an upper bound)."""
        nonlocal nfev
        val = 10.0**x if i in (3, 5) else x
        at = dataclasses.replace(
            s, fixed={**fixed, name: val}, start=_theta_of(near.friction), ssr_cap=cap
        )
        fit = _fit_stribeck_bounded(v, f, at)
        nfev += fit.status.nfev
        g = float(np.sum(fit.residuals**2)) - ssr0 - limit
        return (None if g > 0.0 else fit), g

    for i, name in _SHAPE:
        if name in fixed:
            continue
        tried: list[tuple[float, StribeckFit | None]] = [(float(th0[i]), best)]
        h = (ub[i] - lb[i]) / 5.0
        for side, end in ((-1.0, lb[i]), (1.0, ub[i])):
            # walked outward from the optimum, each point started from its neighbour's fit
            x_in, near, g_in = float(th0[i]), best, -limit
            while side * (end - x_in) > 1e-9:
                x = float(np.clip(x_in + side * h, min(lb[i], ub[i]), max(lb[i], ub[i])))
                fit, g = trial(i, name, x, near)
                tried.append((x, fit))
                if fit is None:
                    at_held = functools.partial(trial, i, name)
                    _edge(at_held, x_in, g_in, near, x, g, tried)
                    break
                x_in, near, g_in = x, fit, g
        ok = [(x, fit) for x, fit in tried if fit is not None]
        used += len(ok) - 1
        for _x, fit in ok:
            est = _envelope(est, fit.estimates, q, skip=name)
            band = _band_envelope(band, fit.band)
        xs = [x for x, _ in ok]
        held = est[name]
        lo_x, hi_x = min(xs), max(xs)
        lo, hi = (10.0**lo_x, 10.0**hi_x) if i in (3, 5) else (lo_x, hi_x)
        lo, hi = min(lo, held.ci[0]), max(hi, held.ci[1])
        if (lo, hi) != held.ci:
            est[name] = _widened(held, lo, hi, q, log=i in (3, 5))
        if lo_x <= lb[i] + 1e-9 and hi_x >= ub[i] - 1e-9 and name not in unidentified:
            unidentified += (name,)  # every shape in its bounds fits as well
    weak = tuple(n for n in best.free if n in best.weak or _too_wide(n, est[n], q))
    status = dataclasses.replace(
        best.status,
        nfev=nfev,
        message=best.status.message + f" (shape profiled: {used} other shapes fit as well)",
    )
    est = {n: within_physical_bounds(n, e) for n, e in est.items()}
    return dataclasses.replace(
        best, estimates=est, status=status, weak=weak, band=band, unidentified=unidentified
    )


#: fits that locate each profile edge (regula falsi, Illinois variant, on ΔSSR − 3.84 s²)
EDGE_TRIALS = 3


def _edge(trial, x_in, g_in, near, x_out, g_out, tried) -> None:
    """Locate the edge of the accepted shapes between ``x_in`` (accepted, ΔSSR − limit
    ``g_in`` ≤ 0) and ``x_out`` (rejected, ``g_out`` > 0) in :data:`EDGE_TRIALS` fits, each
    appended to ``tried``.

    Near an edge the other parameters move fast with the held one (the paper rig's seed 20:
    F_s's upper end is 175.0 N at γ = 1325, the edge at ≈ 1290, and ~169 N a sixteenth of a
    walking step inside), so the envelope needs a fit close to the edge. ΔSSR is smooth in
    the held value: false position on it lands there in a few fits where bisection (four
    halvings, 1/16 of a step) stopped short and left the truth 174.8 N outside the envelope
    on one CPU and inside on another. The Illinois variant halves a retained end's value so
    that neither end stalls; a step is kept a tenth of the bracket inside either end.
    """
    side_kept = 0
    for _ in range(EDGE_TRIALS):
        frac = g_in / (g_in - g_out) if g_out > g_in else 0.5
        mid = x_in + float(np.clip(frac, 0.1, 0.9)) * (x_out - x_in)
        got, g = trial(mid, near)
        tried.append((mid, got))
        if got is None:
            x_out, g_out = mid, g
            g_in = 0.5 * g_in if side_kept == -1 else g_in
            side_kept = -1
        else:
            x_in, g_in, near = mid, g, got
            g_out = 0.5 * g_out if side_kept == 1 else g_out
            side_kept = 1


def _widened(
    old: ParameterEstimate, lo: float, hi: float, q: float, log: bool
) -> ParameterEstimate:
    """``old`` with the interval (lo, hi) and the standard error its half-width implies
    (on the log scale for χ and γ)."""
    if log:  # an interval reaching 0 on the log scale: not determined on that side
        half = float(np.log(hi / lo)) / 2 if lo > 0 and np.isfinite(hi) else np.inf
        std = max(old.std, old.value * half / q)
    else:
        std = max(old.std, 0.5 * (hi - lo) / q)
    return dataclasses.replace(old, std=float(std), ci=(lo, hi))  # a clipped end stays named


def _envelope(
    est: dict[str, ParameterEstimate], other: dict[str, ParameterEstimate], q: float, skip: str
) -> dict[str, ParameterEstimate]:
    """Each interval of ``est`` widened to hold ``other``'s (the held parameter ``skip`` left)."""
    out = dict(est)
    for name, e in other.items():
        if name not in out or name == skip:
            continue
        old = out[name]
        lo, hi = min(old.ci[0], e.ci[0]), max(old.ci[1], e.ci[1])
        if (lo, hi) != old.ci:
            out[name] = _widened(old, lo, hi, q, log=name in ("stribeck_velocity", "smoothness"))
    return out


_Band = tuple[np.ndarray, np.ndarray, np.ndarray]


def _band_envelope(a: _Band, b: _Band) -> _Band:
    """The envelope of two curve bands (velocity, low, high) on the same velocities."""
    if a[0].shape != b[0].shape:
        return a
    return (a[0], np.minimum(a[1], b[1]), np.maximum(a[2], b[2]))


def _too_wide(name: str, e: ParameterEstimate, q: float) -> bool:
    """An interval wider than ±50 % of the value (a factor 2 on the log scale for χ, γ)."""
    lo, hi = e.ci
    if name in ("stribeck_velocity", "smoothness"):
        return bool(lo <= 0 or hi / e.value > 2.0 or e.value / lo > 2.0)
    return bool(0.5 * (hi - lo) > 0.5 * abs(e.value))


def _curve_band(v: np.ndarray, th: np.ndarray, cov: np.ndarray, free_idx: list[int], q: float):
    """The fitted curve's pointwise interval over the speeds the data excite: (velocity [m/s],
    low [N], high [N]) on 25 speeds log-spaced from the slowest to the fastest |ẋ| (the
    curve is odd), f ± q·√(J·Cov·Jᵀ) with J the curve's Jacobian at each speed."""
    va = np.abs(v[v != 0])
    if va.size == 0 or cov.size == 0:
        z = np.zeros(0)
        return (z, z, z)
    vb = np.geomspace(float(va.min()), float(va.max()), 25)
    Jb = _jac_theta(vb, th)[:, free_idx]
    # a direction without a variance (not determined) that does not move the curve at these
    # speeds (a saturated tanh's γ) leaves the band alone; one that does makes it unbounded
    bad = ~np.isfinite(np.diag(cov))
    moves = np.max(np.abs(Jb), axis=0) > 1e-9 * max(float(np.max(np.abs(Jb))), 1e-300)
    keep = ~bad
    c = np.nan_to_num(cov[np.ix_(keep, keep)], nan=0.0, posinf=0.0, neginf=0.0)
    Jk = Jb[:, keep]
    var = np.einsum("ij,jk,ik->i", Jk, c, Jk)
    if np.any(bad & moves):
        var = np.full(vb.size, np.inf)
    var = np.where(np.isnan(var), np.inf, var)  # a covariance that is not a number bounds nothing
    sd = np.sqrt(np.clip(var, 0.0, None))
    fb = _eval(vb, th)
    return (vb, fb - q * sd, fb + q * sd)


@dataclasses.dataclass(frozen=True)
class _Settings:
    """The settings of one Stribeck fit (the keywords of :func:`fit_stribeck`), passed as one."""

    fixed: dict[str, float] | None = None
    loss: str = "soft_l1"
    f_scale: float | None = None
    n_starts: int = 24
    level: float = 0.95
    seed: int = 0
    bounds: dict[str, tuple[float, float]] | None = None
    breakaway: tuple[float, float] | None = None
    #: θ to start from first (a profile's neighbouring point), before the multistart
    start: np.ndarray | None = None
    #: a sum of squared residuals [N²] above which the least-squares stage's best ends the
    #: fit (no robust refits): a profile's held shape that is rejected anyway
    ssr_cap: float | None = None


@dataclasses.dataclass
class _Problem:
    """The bounded least-squares problem in θ = (F_c, F_s − F_c, σ, log10 χ, δ, log10 γ)."""

    v: np.ndarray
    f: np.ndarray
    fixed_th: dict[int, float]
    free_idx: list[int]
    lb_all: np.ndarray
    ub_all: np.ndarray
    vmin: float
    fscale: float

    @property
    def lb(self) -> np.ndarray:
        return self.lb_all[self.free_idx]

    @property
    def ub(self) -> np.ndarray:
        return self.ub_all[self.free_idx]

    def full(self, p: np.ndarray) -> np.ndarray:
        th = np.empty(6)
        th[self.free_idx] = p
        for i, val in self.fixed_th.items():
            th[i] = val
        return th

    def resid(self, p: np.ndarray) -> np.ndarray:
        return (_eval(self.v, self.full(p)) - self.f) / self.fscale

    def jac(self, p: np.ndarray) -> np.ndarray:
        return _jac_theta(self.v, self.full(p))[:, self.free_idx] / self.fscale

    def x_scale(self, p: np.ndarray) -> np.ndarray:
        # forces and σ scale with their start, log10 χ, δ, log10 γ with O(0.3); every stage
        # needs it: without it the robust refits ran out of evaluations (600) before converging
        xs = np.array([0.1, 0.1, 0.1, 0.3, 0.3, 0.5])[self.free_idx]
        forces = np.isin(self.free_idx, [0, 1, 2])
        return np.where(forces, np.maximum(np.abs(p), self.fscale * 0.05), xs)

    def solve(self, p0: np.ndarray, resid=None, jac=None, **kw: Any) -> Any:
        """One ``least_squares`` run from ``p0`` within the bounds (trust-region reflective)."""
        return least_squares(
            resid or self.resid,
            p0,
            jac=jac or self.jac,
            bounds=(self.lb, self.ub),
            x_scale=self.x_scale(p0),
            method="trf",
            **kw,
        )


def _problem(v: np.ndarray, f: np.ndarray, s: _Settings) -> _Problem:
    """Check the points and settings and set up θ's fixed values and bounds."""
    fixed = dict(s.fixed or {})
    unknown = set(fixed) - set(STRIBECK_NAMES)
    if unknown:
        raise IdentificationError(
            f"cannot fix {sorted(unknown)}; Friction fields are {', '.join(STRIBECK_NAMES)}"
        )
    fixed_th = {}
    for key, val in fixed.items():
        i = STRIBECK_NAMES.index(key)
        fixed_th[i] = np.log10(val) if key in ("stribeck_velocity", "smoothness") else float(val)
    if "static" in fixed:
        fixed_th[1] = float(fixed["static"]) - float(fixed.get("coulomb", 0.0))
    free_idx = [i for i in range(6) if i not in fixed_th]
    if v.size < len(free_idx) + 2:
        raise IdentificationError(
            f"Stribeck fit needs at least {len(free_idx) + 2} points, have {v.size}"
        )
    if not (np.any(v > 0) and np.any(v < 0)):
        raise IdentificationError("Stribeck fit needs points in both directions of motion")
    vmin = max(float(np.min(np.abs(v[v != 0]))), 1e-6)
    lb_all, ub_all = _default_bounds(vmin)
    for key, (lo, hi) in (s.bounds or {}).items():
        if key not in STRIBECK_NAMES:
            raise IdentificationError(
                f"no bound for {key!r}; Friction fields are {', '.join(STRIBECK_NAMES)}"
            )
        i = STRIBECK_NAMES.index(key)
        tr = np.log10 if i in (3, 5) else float
        lb_all[i], ub_all[i] = tr(lo), tr(hi)
    for i in free_idx:
        if not lb_all[i] < ub_all[i]:
            raise IdentificationError(f"empty bounds for {STRIBECK_NAMES[i]}")
    fscale = max(float(np.max(np.abs(f))), 1.0)
    return _Problem(v, f, fixed_th, free_idx, lb_all, ub_all, vmin, fscale)


def _starts(pr: _Problem, s: _Settings) -> list[np.ndarray]:
    """Starting points in the free θ: a grid over (log χ, δ, log γ) plus random draws, the
    forces from the linear fit at each; ``s.start`` first where given."""
    first = []
    if s.start is not None:
        th0 = np.asarray(s.start, dtype=float).copy()
        for i, val in pr.fixed_th.items():
            th0[i] = val
        first = [np.clip(th0[pr.free_idx], pr.lb + 1e-9, pr.ub - 1e-9)]
    rng = np.random.default_rng(s.seed)
    lo_s, hi_s = pr.lb_all[3:], pr.ub_all[3:]
    v = pr.v
    grid = [
        (lc, d, lg)
        for lc in np.linspace(
            max(np.log10(pr.vmin / 3), lo_s[0]), np.log10(max(np.max(np.abs(v)), pr.vmin)), 4
        )
        for d in (0.7, 1.5)
        for lg in (lo_s[2] + 0.3, lo_s[2] + 2.0)
    ]
    while len(grid) < s.n_starts:
        grid.append(tuple(rng.uniform(lo_s, hi_s)))
    grid = [tuple(np.clip(g, lo_s + 1e-6, hi_s - 1e-6)) for g in grid]
    starts = []
    for lc, d, lg in grid[: max(s.n_starts, 1)]:
        th0 = np.empty(6)
        th0[3:] = (lc, d, lg)
        for i, val in pr.fixed_th.items():
            th0[i] = val
        th0[:3] = _linear_part(v, pr.f, th0[3], th0[4], th0[5])
        for i, val in pr.fixed_th.items():
            th0[i] = val
        starts.append(np.clip(th0[pr.free_idx], pr.lb + 1e-9, pr.ub - 1e-9))
    return first + starts


def _solve(pr: _Problem, s: _Settings) -> tuple[Any, int, int]:
    """Multistart least squares, then the break-away constraint and the robust refits.

    Returns the best ``least_squares`` result, the evaluations of all runs and the number
    of starts.
    """
    results = [pr.solve(p0) for p0 in _starts(pr, s)]
    n_starts = len(results)
    best = min(results, key=lambda r: r.cost)
    nfev = sum(int(r.nfev) for r in results)
    scale_n = (
        s.f_scale / pr.fscale
        if s.f_scale
        else max(1.4826 * float(np.median(np.abs(best.fun))), 1e-6)
    )
    resid, jac = pr.resid, pr.jac
    if s.ssr_cap is not None and 2.0 * best.cost * pr.fscale**2 > s.ssr_cap:
        return best, nfev, n_starts
    if s.breakaway is not None:
        resid, jac = _with_breakaway(pr, s.breakaway, scale_n)
        ranked = sorted(results, key=lambda r: r.cost)[:4]
        results = [pr.solve(r.x, resid, jac) for r in ranked]
        best = min(results, key=lambda r: r.cost)
        nfev += sum(int(r.nfev) for r in results)
    if s.loss != "linear":
        ranked = _distinct(pr, sorted(results, key=lambda r: r.cost)[:4])
        robust = [pr.solve(r.x, resid, jac, loss=s.loss, f_scale=scale_n) for r in ranked]
        best = min(robust, key=lambda r: r.cost)
        nfev += sum(int(r.nfev) for r in robust)
    return best, nfev, n_starts


def _distinct(pr: _Problem, ranked: list[Any]) -> list[Any]:
    """``ranked`` without the results that repeat an earlier one (the same optimum reached
    from several starts, to 1e-3 of its ``x_scale``): a robust refit from each would repeat
    the same run."""
    kept: list[Any] = []
    for r in ranked:
        if not any(np.all(np.abs(r.x - k.x) <= 1e-3 * pr.x_scale(k.x)) for k in kept):
            kept.append(r)
    return kept


def _with_breakaway(pr: _Problem, breakaway: tuple[float, float], scale_n: float):
    """Residual and Jacobian with the break-away residual (max_{ẋ>0} f(ẋ) − F_b)/std appended,
    weighted like one point at the robust residual scale (gradient by the envelope theorem)."""
    f_b, sd_b = float(breakaway[0]), max(float(breakaway[1]), 1e-9)
    w_b = scale_n / sd_b
    vcap = float(np.max(np.abs(pr.v)))

    def resid(p):
        return np.append(pr.resid(p), w_b * (_curve_max(pr.full(p), vcap)[0] - f_b))

    def jac(p):
        th_ = pr.full(p)
        row = _jac_theta(np.array([_curve_max(th_, vcap)[1]]), th_)[:, pr.free_idx]
        return np.vstack([pr.jac(p), w_b * row])

    return resid, jac


def _estimate(
    pr: _Problem, th: np.ndarray, cov: np.ndarray, k: int, q: float
) -> tuple[float, float, float, float, bool, bool]:
    """Value, std, interval of free parameter ``k`` (θ index ``free_idx[k]``) in Friction
    units, whether it is weak and whether it sits at a bound of the fit."""
    i, free_idx, lb_all, ub_all = pr.free_idx[k], pr.free_idx, pr.lb_all, pr.ub_all
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    at_bound = th[i] <= lb_all[i] + 1e-6 * (1 + abs(lb_all[i])) or th[i] >= ub_all[i] - 1e-6 * (
        1 + abs(ub_all[i])
    )
    if i in (3, 5):
        with np.errstate(over="ignore"):  # an undetermined log-scale CI reaches inf
            lo, hi = 10.0 ** (th[i] - q * sd[k]), 10.0 ** (th[i] + q * sd[k])
        val = 10.0 ** th[i]
        std = val * np.log(10.0) * sd[k]
        is_weak = sd[k] * q > np.log10(2.0) or at_bound
    elif i == 1:  # static = F_c + ΔF: propagate with the F_c covariance when F_c is free
        val = th[0] + th[1]
        var = sd[k] ** 2
        if 0 in free_idx:
            j = free_idx.index(0)
            var += cov[j, j] + 2 * cov[j, k]
        std = float(np.sqrt(max(var, 0.0))) if np.isfinite(var) else float("inf")
        lo, hi = val - q * std, val + q * std
        is_weak = q * std > 0.5 * abs(val)
    else:
        val, std = th[i], sd[k]
        lo, hi = val - q * std, val + q * std
        is_weak = q * std > 0.5 * abs(val) or (at_bound and i != 0)
    return float(val), float(std), float(lo), float(hi), bool(is_weak), bool(at_bound)


def _unidentified(pr: _Problem, th: np.ndarray, i: int, e: ParameterEstimate, at_bound: bool):
    """Not identified: at (or, on the scale of its interval, next to) a bound of the fit with
    an interval wider than half the value, or an interval covering the bounded range (e.g.
    F_c = 9.6e-11 N, CI ±1209 N); then no value is written."""
    lb_all, ub_all = pr.lb_all, pr.ub_all
    lo_b, hi_b = (10.0 ** lb_all[i], 10.0 ** ub_all[i]) if i in (3, 5) else (lb_all[i], ub_all[i])
    if i == 1:  # the bound is on F_s − F_c; at it F_s = F_c
        lo_b, hi_b = lo_b + th[0], hi_b + th[0]
    (lo, hi), val = e.ci, e.value
    half = 0.5 * (hi - lo)
    near = at_bound or min(val - lo_b, hi_b - val) < 0.01 * half
    return bool((near and half > 0.5 * abs(val)) or (lo <= lo_b and hi >= hi_b))


def _fit_stribeck_bounded(v, f, s: _Settings) -> StribeckFit:
    """Fit the Stribeck curve, Eq. (11), within given bounds (the work of :func:`fit_stribeck`,
    whose keywords ``s`` holds).

    Notes
    -----
    Fit vector θ = (F_c, F_s − F_c, σ, log10 χ, δ, log10 γ). Default bounds, with
    v_min the slowest measured |ẋ|: F_c, F_s − F_c ∈ [0, 1e5] N, σ ∈ [0, 1e7] N·s/m,
    χ ∈ [v_min/10, 1] m/s, δ ∈ [0.5, 5], γ ∈ [3/v_min, 1e7] s/m. The last three
    encode what constant-input data can say: a Stribeck decay finished well below the
    slowest run, or a tanh transition wider than the slowest speed, trade off
    against F_s without limit (F_s → ∞ with χ → 0 fits as well), so such optima are
    excluded rather than reported as estimates. Covariance from
    the Jacobian at the optimum; intervals on θ are mapped to Friction fields
    (χ, γ: 10^(θ ± q·sd)). With |ẋ| ≥ a few mm/s and γ large, tanh(γẋ) = 1 for all
    data: γ is then not identifiable and is reported so (``weak``).
    """
    v = np.asarray(v, dtype=float)
    f = np.asarray(f, dtype=float)
    pr = _problem(v, f, s)
    best, nfev, n_starts = _solve(pr, s)
    th = pr.full(best.x)
    r = best.fun[: v.size] * pr.fscale
    # run-level robust (sandwich) covariance: one point per run, and the points differ in
    # quality (slow runs creep, fast ones do not), which s²(JᵀJ)⁻¹ ignores (issue 18)
    cov = (
        sandwich_covariance(best.jac * pr.fscale, best.fun * pr.fscale)
        if best.jac.size
        else np.zeros((0, 0))
    )
    q = t_quantile(s.level, v.size - len(pr.free_idx))
    est: dict[str, ParameterEstimate] = {}
    weak, unidentified = [], []
    for k, i in enumerate(pr.free_idx):
        name = STRIBECK_NAMES[i]
        val, std, lo, hi, is_weak, at_bound = _estimate(pr, th, cov, k, q)
        e = ParameterEstimate(val, std, (lo, hi), _UNITS[name], s.level)
        est[name] = within_physical_bounds(name, e)
        if is_weak:
            weak.append(name)
        if _unidentified(pr, th, i, est[name], at_bound):
            unidentified.append(name)
    return StribeckFit(
        _friction_of(th),
        est,
        correlation(cov),
        tuple(STRIBECK_NAMES[i] for i in pr.free_idx),
        tuple(weak),
        v,
        f,
        f - _eval(v, th),
        float(np.sqrt(np.mean(r**2))),
        s.loss,
        n_starts,
        OptimizerStatus(bool(best.success), str(best.message), nfev, None),
        tuple(unidentified),
        _curve_band(v, th, cov, pr.free_idx, q),
    )


def _friction_of(th: np.ndarray) -> Friction:
    """The Friction fields of θ."""
    return Friction(
        coulomb=float(th[0]),
        static=float(th[0] + th[1]),
        viscous=float(th[2]),
        stribeck_velocity=float(10.0 ** th[3]),
        shape=float(th[4]),
        smoothness=float(10.0 ** th[5]),
    )
