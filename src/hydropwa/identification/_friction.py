"""Stribeck friction from constant-input runs against a counter force (Sec. VI-C, Fig. 8).

Per run: the steady part (moving-window velocity and net force inside a band
around their medians, away from both end stops) gives averaged P_A, P_B, F_L and
the friction force of Eq. (10) at steady state,

    f = P_A A_A − P_B A_B − F_L,

and the velocity from a least-squares line through the position. The points
(ẋ, f) are fitted with Eq. (11),

    f(ẋ) = tanh(γẋ)·(F_c + (F_s − F_c)·exp(−|ẋ/χ|^δ)) + σẋ,

by bounded nonlinear least squares in (F_c, F_s − F_c, σ, log10 χ, δ, log10 γ)
with a robust loss and many starts. For fixed (χ, δ, γ) the model is linear in
(F_c, F_s, σ), which gives each start its linear part exactly.
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

import numpy as np

from .._errors import IdentificationError, ParameterError
from ..params import Friction, SystemParams
from ._common import (
    ParameterEstimate,
    RigGeometry,
    SkippedRun,
    as_runs,
    channels_of,
    estimate,
    not_fitted,
    require_usable,
    resolve_geometry,
    skip,
    t_quantile,
    within_physical_bounds,
)
from ._deadzone import command_level
from ._friction_curve import (
    _UNITS,
    STRIBECK_NAMES,
    StribeckFit,
    _velocity_bins,
    curve_maximum,
    fit_stribeck,
)
from ._friction_points import (
    BreakawayRun,
    FrictionPoint,
    breakaway_peaks,
    friction_point,
    friction_samples,
    steady_window,
)

__all__ = [
    "FrictionPoint",
    "steady_window",
    "friction_point",
    "friction_samples",
    "StribeckFit",
    "BreakawayRun",
    "breakaway_peaks",
    "curve_maximum",
    "fit_stribeck",
    "StribeckIdentifier",
    "SteadyStateAverage",
    "InstantaneousBins",
    "BreakawayConstrained",
    "FrictionMethod",
    "STRIBECK_NAMES",
]


@dataclasses.dataclass(frozen=True)
class SteadyStateAverage:
    """Friction points by the paper's method: one point per run from its steady part (Sec. VI-C).

    Steady-part means of P_A, P_B, F_L give f of Eq. (10), the position slope gives ẋ
    (:func:`friction_point`).

    Attributes
    ----------
    window : float
        Moving window [s] of the steady-state detection.
    band : float
        Relative velocity band of the steady part [1].
    abs_band : float
        Absolute velocity band [m/s] (for slow runs).
    force_band, force_abs_band : float
        Relative [1] and absolute [N] band of the net force.
    min_duration : float
        Shortest steady stretch [s] a run must have.
    oscillation_factor : float
        A run whose net-force std exceeds this multiple of the quietest runs' is marked
        ``oscillating`` (kept in the fit, reported in ``notes_``) [1].
    """

    name: ClassVar[str] = "average"
    window: float = 0.1
    band: float = 0.15
    abs_band: float = 5e-4
    force_band: float = 0.25
    force_abs_band: float = 20.0
    min_duration: float = 0.2
    oscillation_factor: float = 3.0

    def __post_init__(self) -> None:
        _positive(self, "window", "band", "abs_band", "force_band", "force_abs_band")
        _positive(self, "min_duration", "oscillation_factor")


@dataclasses.dataclass(frozen=True)
class InstantaneousBins:
    """Friction points per velocity bin of per-sample forces (needs the moving mass).

    Per sample f = P_A A_A − P_B A_B − F_L − m·ẍ (:func:`friction_samples`) over the moving
    part of each run, reduced to per-run velocity-bin medians (``points_`` has one row per
    bin), so oscillating runs contribute their whole velocity range.

    Attributes
    ----------
    cutoff : float
        Low-pass cutoff [Hz] of velocity, acceleration and force.
    taps : int
        Filter length [samples].
    min_speed : float
        Slowest |ẋ| [m/s] of a sample that is used.
    guard : float
        Time [s] dropped after each command change.
    bin_rel, bin_width : float
        Bin width max(bin_rel·|v|, bin_width) [1], [m/s].
    bin_min_count : int
        Fewest samples in a bin that is used.
    """

    name: ClassVar[str] = "instantaneous"
    cutoff: float = 300.0
    taps: int = 41
    min_speed: float = 3e-3
    guard: float = 0.0
    bin_rel: float = 0.1
    bin_width: float = 1e-3
    bin_min_count: int = 5

    def __post_init__(self) -> None:
        _positive(self, "cutoff", "taps", "min_speed", "bin_rel", "bin_width", "bin_min_count")


@dataclasses.dataclass(frozen=True)
class BreakawayConstrained:
    """Friction points of ``points`` plus "maximum of Eq. (11) = break-away force F_b".

    F_b is the median per-cycle net-force peak of the slowest stick-slip runs per direction
    (mean speed ≤ ``speed_ratio`` × the slowest one's; faster runs overshoot), the mean of
    both directions, with a standard error that includes the direction difference
    (:func:`breakaway_peaks`, ``fit_stribeck(breakaway=...)``). Constant-input data do not
    identify γ and the curve's maximum lies below F_s by the tanh rounding, so γ is held at
    ``smoothness`` (or at the ``params``' γ) unless ``fixed`` says otherwise.

    Attributes
    ----------
    points : SteadyStateAverage or InstantaneousBins
        How the (ẋ, f) points are made (default: per-sample bins).
    speed_ratio : float
        Runs used for F_b: mean speed ≤ this × the slowest stick-slip run's, per direction [1].
    min_cycles : int
        Fewest stick-slip cycles for a run to count [1].
    min_slip : float
        Smallest slip speed [m/s] that marks a stick-slip cycle.
    cutoff : float
        Low-pass cutoff [Hz] of the peak detection.
    taps : int
        Filter length [samples] of the peak detection.
    smoothness : float, optional
        γ [s/m] held in the fit; default the ``params``' ``friction.smoothness``.
    """

    name: ClassVar[str] = "breakaway"
    points: SteadyStateAverage | InstantaneousBins = dataclasses.field(
        default_factory=InstantaneousBins
    )
    speed_ratio: float = 2.0
    min_cycles: int = 10
    min_slip: float = 5e-3
    cutoff: float = 300.0
    taps: int = 41
    smoothness: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.points, SteadyStateAverage | InstantaneousBins):
            raise ParameterError(
                f"BreakawayConstrained.points = {self.points!r}; give SteadyStateAverage() or "
                "InstantaneousBins()"
            )
        _positive(self, "speed_ratio", "min_cycles", "min_slip", "cutoff", "taps")
        if self.smoothness is not None:
            _positive(self, "smoothness")


#: The point strategies of :class:`StribeckIdentifier`.
FrictionMethod = SteadyStateAverage | InstantaneousBins | BreakawayConstrained


def _positive(obj: Any, *names: str) -> None:
    for name in names:
        val = getattr(obj, name)
        if not (isinstance(val, int | float) and np.isfinite(val) and val > 0):
            raise ParameterError(f"{type(obj).__name__}.{name} = {val!r} must be a positive number")


class StribeckIdentifier:
    """Identify the Stribeck friction curve from constant-input runs (Sec. VI-C, Eqs. (10)–(11)).

    Parameters
    ----------
    params : SystemParams, optional
        Gives the areas A_A, A_B [m²], the stroke [m] and the moving mass [kg] (and γ for
        :class:`BreakawayConstrained`). Either this or ``geometry`` is required: there is
        no default rig.
    geometry : RigGeometry, optional
        The same without a full parameter set (``mass`` only for :class:`InstantaneousBins`).
    method : SteadyStateAverage, InstantaneousBins or BreakawayConstrained
        How runs become (ẋ, f) points; default the paper's steady-state average.
    fixed : dict, optional
        Friction fields held fixed in the fit (SI values), e.g. ``{"shape": 1.0}``.
    loss : str
        Robust ``least_squares`` loss of the fit.
    n_starts : int
        Starting points of the fit.
    level : float
        Confidence level [1].
    stop_margin : float
        Distance [m] from an end stop treated as contact.

    Attributes
    ----------
    points_ : pandas.DataFrame
        One row per used run (``SteadyStateAverage``: ``run``, ``u`` [1], ``v`` [m/s],
        ``v_std``, ``f`` [N], ``f_std``, ``p_a``, ``p_b`` [Pa], ``f_l`` [N], ``t0``, ``t1`` [s],
        ``force_fluctuation`` [N], ``oscillating``) or per velocity bin (``InstantaneousBins``).
    fit_ : StribeckFit
        The fit, with its intervals and the optimiser's ``status``.
    friction_ : Friction
        The fitted curve as parameters.
    coulomb_, static_, viscous_, stribeck_velocity_, shape_, smoothness_ : ParameterEstimate
        The fitted Eq. (11) parameters with their intervals (a fixed one with std 0).
    status_ : OptimizerStatus
        How the optimiser ended (``fit_.status``).
    notes_ : list[str]
        Caveats found in the data (oscillating runs), and the break-away estimate.
    breakaway_ : ParameterEstimate or None
        Break-away force F_b [N] with its CI (:class:`BreakawayConstrained`), else None.
    breakaway_runs_ : pandas.DataFrame or None
        Per stick-slip run: ``run``, ``direction``, ``mean_speed`` [m/s], ``n_cycles``,
        ``peak`` (median) and ``peak_std`` [N], ``used``.
    skipped_ : list[SkippedRun]
    """

    #: The experiment kind this estimator reads and the parameter field it sets.
    part: ClassVar[str] = "friction"
    field: ClassVar[str] = "friction"

    def __init__(
        self,
        params: SystemParams | None = None,
        *,
        geometry: RigGeometry | None = None,
        method: FrictionMethod | None = None,
        fixed: dict[str, float] | None = None,
        loss: str = "soft_l1",
        n_starts: int = 24,
        level: float = 0.95,
        stop_margin: float = 2e-3,
    ) -> None:
        method = SteadyStateAverage() if method is None else method
        if not isinstance(method, SteadyStateAverage | InstantaneousBins | BreakawayConstrained):
            raise ParameterError(
                f"StribeckIdentifier method={method!r}; give SteadyStateAverage(), "
                "InstantaneousBins() or BreakawayConstrained()"
            )
        points = method.points if isinstance(method, BreakawayConstrained) else method
        needs = ("stroke", "area_a", "area_b") + (
            ("mass",) if isinstance(points, InstantaneousBins) else ()
        )
        self.geometry = resolve_geometry("StribeckIdentifier", params, geometry, needs)
        self.params = params
        self.method = method
        self.fixed = dict(fixed or {})
        self.loss = loss
        self.n_starts = n_starts
        self.level = level
        self.stop_margin = stop_margin
        if isinstance(method, BreakawayConstrained) and "smoothness" not in self.fixed:
            if method.smoothness is None and params is None:
                raise ParameterError(
                    "BreakawayConstrained holds γ fixed: give BreakawayConstrained(smoothness=...) "
                    "[s/m], fixed={'smoothness': ...} or params=SystemParams"
                )

    def fit(self, data) -> StribeckIdentifier:
        """Reduce each run to a friction point and fit Eq. (11).

        Returns
        -------
        StribeckIdentifier
            ``self`` with ``points_``, ``fit_``, ``friction_`` and ``skipped_`` set.

        Raises
        ------
        IdentificationError
            If too few runs are usable.
        """
        import pandas as pd  # deferred: pandas loads only for tables

        geo = self.geometry
        assert geo.area_a is not None and geo.area_b is not None
        runs = as_runs(data, "friction")
        skipped: list[SkippedRun] = []
        self.breakaway_: ParameterEstimate | None = None
        self.breakaway_runs_: Any = None
        points = self._points
        if isinstance(points, InstantaneousBins):
            return self._fit_instantaneous(runs, points, skipped)
        rows = []
        kw = dict(
            stop_margin=self.stop_margin,
            window=points.window,
            band=points.band,
            abs_band=points.abs_band,
            force_band=points.force_band,
            force_abs_band=points.force_abs_band,
            min_duration=points.min_duration,
        )
        for run in runs:
            ch = channels_of(run, ("t", "x", "p_a", "p_b", "f_l"), skipped)
            if ch is None:
                continue
            try:
                pt = friction_point(
                    ch["t"],
                    ch["x"],
                    ch["p_a"],
                    ch["p_b"],
                    ch["f_l"],
                    geo.area_a,
                    geo.area_b,
                    geo.stroke,
                    **kw,
                )
            except IdentificationError as exc:
                skip(skipped, run.name, str(exc))
                continue
            lv = command_level(run)
            rows.append(
                {
                    "run": run.name,
                    "u": float("nan") if lv is None else lv,
                    "v": pt.velocity,
                    "v_std": pt.velocity_std,
                    "f": pt.force,
                    "f_std": pt.force_std,
                    "p_a": pt.p_a,
                    "p_b": pt.p_b,
                    "f_l": pt.f_l,
                    "t0": pt.window[0],
                    "t1": pt.window[1],
                    "rms_position_residual": pt.rms_position_residual,
                    "force_fluctuation": pt.force_fluctuation,
                }
            )
        n_free = 6 - len(self.fixed or {})
        require_usable(rows, skipped, "Stribeck identification", minimum=n_free + 2)
        pts = pd.DataFrame(rows).sort_values("v", ignore_index=True)
        # runs whose force fluctuates far above the quietest runs (sensor noise) oscillate
        floor = float(
            np.median(np.sort(pts["force_fluctuation"].to_numpy())[: max(3, len(pts) // 4)])
        )
        pts["oscillating"] = pts["force_fluctuation"] > points.oscillation_factor * floor
        self.points_ = pts
        self.notes_: list[str] = []
        if pts["oscillating"].any():
            osc = pts[pts["oscillating"]]
            self.notes_.append(
                f"{len(osc)} run(s) oscillate (net-force std > {points.oscillation_factor:g}× the quietest runs' "
                f"{floor:.3g} N), at |v| up to {1e3 * osc['v'].abs().max():.3g} mm/s: their mean force is not "
                "the static friction there, so F_s, χ and δ that rest on them may be biased beyond their CI"
            )
        self._final_fit(pts, runs)
        self.skipped_ = skipped
        return self

    @property
    def _points(self) -> SteadyStateAverage | InstantaneousBins:
        m = self.method
        return m.points if isinstance(m, BreakawayConstrained) else m

    def _fit_instantaneous(
        self, runs, opts: InstantaneousBins, skipped: list[SkippedRun]
    ) -> StribeckIdentifier:
        import pandas as pd  # deferred: pandas loads only for tables

        geo = self.geometry
        assert geo.area_a is not None and geo.area_b is not None and geo.mass is not None
        rows = []
        for run in runs:
            ch = channels_of(run, ("t", "x", "p_a", "p_b", "f_l"), skipped)
            if ch is None:
                continue
            u = run["u"] if "u" in run.channels else None
            try:
                v, f = friction_samples(
                    ch["t"],
                    ch["x"],
                    ch["p_a"],
                    ch["p_b"],
                    ch["f_l"],
                    geo.area_a,
                    geo.area_b,
                    geo.mass,
                    u=u,
                    stroke=geo.stroke,
                    stop_margin=self.stop_margin,
                    cutoff=opts.cutoff,
                    taps=opts.taps,
                    min_speed=opts.min_speed,
                    guard=opts.guard,
                )
            except IdentificationError as exc:
                skip(skipped, run.name, str(exc))
                continue
            bins = _velocity_bins(v, f, opts.bin_rel, opts.bin_width, opts.bin_min_count)
            if bins.size == 0:
                skip(skipped, run.name, "no velocity bin with enough moving samples")
                continue
            lv = command_level(run)
            spread = float(np.percentile(np.abs(v), 95) - np.percentile(np.abs(v), 5))
            for bv, bf, n in bins:
                rows.append(
                    {
                        "run": run.name,
                        "u": float("nan") if lv is None else lv,
                        "v": bv,
                        "f": bf,
                        "n_samples": int(n),
                        "v_spread": spread,
                    }
                )
        n_free = 6 - len(self.fixed or {})
        require_usable(rows, skipped, "Stribeck identification", minimum=n_free + 2)
        pts = pd.DataFrame(rows).sort_values("v", ignore_index=True)
        # a run whose velocity swings over more than half its median speed + 10 mm/s oscillates
        med = pts.groupby("run")["v"].transform(lambda s: float(np.median(np.abs(s))))
        pts["oscillating"] = pts["v_spread"] > 0.5 * med + 0.01
        self.points_ = pts
        self.notes_ = []
        osc = pts.loc[pts["oscillating"], "run"].unique()
        if osc.size:
            self.notes_.append(
                f"{osc.size} run(s) oscillate (stick-slip); their samples are used per velocity bin, but the "
                "speeds crossed within a sample or two (the low-speed Stribeck peak) are not resolved at "
                "this sampling rate, so F_s, χ and δ rest on an extrapolation"
            )
        self._final_fit(pts, runs)
        self.skipped_ = skipped
        return self

    def _final_fit(self, pts, runs) -> None:
        fixed = dict(self.fixed)
        constraint = None
        m = self.method
        if isinstance(m, BreakawayConstrained):
            constraint = self._breakaway(runs, m)
            if constraint is not None and "smoothness" not in fixed:
                if m.smoothness is not None:
                    gamma, src = m.smoothness, "BreakawayConstrained.smoothness"
                else:
                    assert self.params is not None  # checked in __init__
                    gamma, src = self.params.friction.smoothness, "the given params"
                fixed["smoothness"] = gamma
                self.notes_.append(
                    f"γ held at {gamma:.4g} s/m ({src}): constant-input data do not "
                    "identify it, and it sets how far the curve's maximum (the break-away force) lies below F_s"
                )
        self.fit_ = fit_stribeck(
            pts["v"].to_numpy(),
            pts["f"].to_numpy(),
            fixed,
            self.loss,
            None,
            self.n_starts,
            self.level,
            breakaway=constraint,
        )
        if constraint is not None:
            fm, vm = curve_maximum(self.fit_.friction, float(np.max(np.abs(pts["v"]))))
            self.notes_.append(
                f"fitted curve maximum {fm:.4g} N at {1e3 * vm:.3g} mm/s (F_s = "
                f"{self.fit_.friction.static:.4g} N)"
            )
        self.friction_ = self.fit_.friction
        self.status_ = self.fit_.status
        for name in STRIBECK_NAMES:
            val = getattr(self.friction_, name)
            est = self.fit_.estimates.get(
                name, ParameterEstimate(val, 0.0, (val, val), _UNITS[name], self.level)
            )
            setattr(self, name + "_", est)

    def _breakaway(self, runs, opts: BreakawayConstrained) -> tuple[float, float] | None:
        """F_b and its standard error from the slowest stick-slip runs (sets ``breakaway_``)."""
        import pandas as pd  # deferred: pandas loads only for tables

        geo = self.geometry
        assert geo.area_a is not None and geo.area_b is not None
        rows, peaks = [], {}
        for run in runs:
            if not all(c in run.channels for c in ("t", "x", "p_a", "p_b", "f_l")):
                continue
            try:
                br = breakaway_peaks(
                    run["t"],
                    run["x"],
                    run["p_a"],
                    run["p_b"],
                    run["f_l"],
                    geo.area_a,
                    geo.area_b,
                    u=run["u"] if "u" in run.channels else None,
                    stroke=geo.stroke,
                    stop_margin=self.stop_margin,
                    cutoff=opts.cutoff,
                    taps=opts.taps,
                    min_slip=opts.min_slip,
                )
            except IdentificationError:
                continue
            if br.peaks.size < opts.min_cycles:
                continue
            pk = br.peaks
            sem = 1.2533 * 1.4826 * float(np.median(np.abs(pk - np.median(pk)))) / np.sqrt(pk.size)
            rows.append(
                {
                    "run": run.name,
                    "direction": br.direction,
                    "mean_speed": br.mean_speed,
                    "n_cycles": int(pk.size),
                    "peak": br.force,
                    "peak_std": sem,
                }
            )
            peaks[run.name] = pk
        if not rows:
            self.notes_.append(
                "breakaway: no stick-slip run with enough cycles; F_s rests on the points alone"
            )
            return None
        tab = pd.DataFrame(rows)
        tab["used"] = False
        per_dir = []
        for d in (1.0, -1.0):
            sel = tab["direction"] == d
            if not sel.any():
                continue
            vmin = float(tab.loc[sel, "mean_speed"].min())
            use = sel & (tab["mean_speed"] <= opts.speed_ratio * vmin)
            tab.loc[use, "used"] = True
            pooled = np.concatenate([peaks[n] for n in tab.loc[use, "run"]])
            val = float(np.median(pooled))
            sem = 1.2533 * 1.4826 * float(np.median(np.abs(pooled - val))) / np.sqrt(pooled.size)
            meds = tab.loc[use, "peak"].to_numpy()
            if meds.size > 1:
                sem = max(sem, float(np.std(meds, ddof=1)) / np.sqrt(meds.size))
            per_dir.append((d, val, sem, int(use.sum())))
        vals = np.array([p[1] for p in per_dir])
        sems = np.array([p[2] for p in per_dir])
        f_b = float(np.mean(vals))
        sd = float(np.sqrt(np.sum(sems**2)) / vals.size)
        if vals.size == 2:
            sd = float(np.hypot(sd, 0.5 * (vals[0] - vals[1])))
        q = t_quantile(self.level, max(int(tab["used"].sum()) - 1, 1))
        self.breakaway_ = within_physical_bounds("breakaway", estimate(f_b, sd, q, "N", self.level))
        self.breakaway_runs_ = tab
        txt = ", ".join(
            f"{'+' if d > 0 else '−'}: {val:.4g} ± {s_:.2g} N ({n} run(s))"
            for d, val, s_, n in per_dir
        )
        self.notes_.append(
            f"break-away force F_b = {f_b:.4g} N, {100 * self.level:g} % CI [{f_b - q * sd:.4g}, {f_b + q * sd:.4g}] "
            f"(median stick-slip net-force peak of the slowest stick-slip runs; {txt}); fitted as the curve's maximum"
        )
        return f_b, sd

    def uncertainty(self) -> dict:
        """Per-field estimates and the weakly identified names (``[uncertainty]`` table)."""
        out: dict[str, Any] = {k: e.to_dict() for k, e in self.fit_.estimates.items()}
        out["weakly_identified"] = list(self.fit_.weak)
        out["not_identified"] = list(self.fit_.unidentified)
        out["notes"] = list(self.notes_)
        out["rms_residual_N"] = self.fit_.rms_residual
        out["method"] = self.method.name
        out["optimizer"] = dataclasses.asdict(self.fit_.status)
        return out

    def apply(self, params: SystemParams) -> SystemParams:
        """``params`` with the fitted friction curve in place of its ``friction``."""
        if not hasattr(self, "friction_"):
            raise not_fitted("StribeckIdentifier")
        keep = self.fit_.unidentified
        if not keep:
            return dataclasses.replace(params, friction=self.friction_)
        # a value the data do not determine is not written: the given parameters' stays
        fitted = {
            f.name: getattr(self.friction_, f.name)
            for f in dataclasses.fields(Friction)
            if f.name not in keep
        }
        try:
            friction = dataclasses.replace(params.friction, **fitted)
        except ParameterError as exc:
            raise IdentificationError(
                f"friction: {', '.join(keep)} not identified by the data, and the given "
                f"value(s) do not fit the identified ones ({exc}); give runs that determine "
                "them (slower and faster steady speeds) or fix them with StribeckIdentifier("
                "fixed=...)"
            ) from None
        return dataclasses.replace(params, friction=friction)

    def provenance(self) -> str:
        """One line on how the curve was found (``[meta.identification]`` of a parameter file)."""
        if not hasattr(self, "fit_"):
            raise not_fitted("StribeckIdentifier")
        points = self._points
        kind = (
            "steady-state" if isinstance(points, SteadyStateAverage) else "per-sample velocity-bin"
        )
        brk = self.breakaway_
        return (
            f"Sec. VI-C: {len(self.points_)} {kind} points (method {self.method.name}), Eq. (10) "
            f"with areas from the given geometry; Eq. (11) by bounded {self.loss} least squares"
            + (
                f", constrained to the stick-slip break-away force {brk.value:.4g} N as its "
                "maximum with γ held"
                if brk is not None
                else ""
            )
            + (f"; weakly identified: {', '.join(self.fit_.weak)}" if self.fit_.weak else "")
            + (
                f"; not identified (given value kept): {', '.join(self.fit_.unidentified)}"
                if self.fit_.unidentified
                else ""
            )
            + f"; optimiser: {self.fit_.status}"
        )
