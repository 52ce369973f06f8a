"""The grey-box fit as a composition: options → data → problem → stage plan → minimize →
uncertainty → sliding stage → result (:func:`fit_model`)."""

from __future__ import annotations

import contextlib
import dataclasses
import math
import time
import warnings
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from typing import Any

import numpy as np
from scipy import stats

from ..._dask import dask_client
from ..._errors import IdentificationError, ParameterError
from ..._layout import LINEARIZED_MODELS, MEASURABLE_MODELS
from ...models import as_model
from .._common import (
    IdentificationWarning,
    ParameterEstimate,
    SkippedRun,
    as_runs,
    experiment_of,
    within_physical_bounds,
)
from .curve import friction_curve, widen_by_curve
from .data import RunData, Shooting, prepare_again, prepare_run
from .intervals import estimate, log_interval, scan_widen
from .jacobian import DIFFERENCES
from .objective import LOSSES, OutputErrorObjective
from .optimize import LeastSquares
from .problem import PARAMETER_GROUPS, GreyBoxProblem, expand_free
from .profile import ProfileTask, carry
from .profile import profile as _profile
from .report import fitted_params, identifiability, run_fits
from .result import GreyBoxFit, Profile, SlidingSummary
from .selection import Selection, restrict, spans
from .sliding import BREAKAWAY, Sliding, SlidingSettings, sliding_runs, sliding_stage
from .stages import STICK, FitProgress, StagePlan, StartResult, theta_starts
from .steady import steady_runs
from .uncertainty import Covariance, covariance, kappa, remaining_step
from .validation import split_runs, validate

__all__ = ["FitOptions", "fit_model"]


def _int_at_least(name: str, value: Any, low: int, what: str) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise IdentificationError(f"{name} = {value!r} must be an integer >= {low} ({what})")


@dataclasses.dataclass(frozen=True)
class FitOptions:
    """Settings of :func:`fit_model` (each documented there), validated on construction."""

    channels: Sequence[str] | None = None
    bounds: Mapping[str, tuple[float, float]] | None = None
    initial: Mapping[str, float] | None = None
    shooting: Shooting | None = None
    loss: str = "linear"
    f_scale: float = 3.0
    starts: int = 1
    seed: int = 0
    rtol: float = 1e-5
    fd_step: float = 3e-2
    differences: str = "central"
    coarse: int = 4
    refresh: int = 1
    x_scale: Any = 1.0
    verbose: int = 0
    input_cutoff: float | None = 50.0
    xtol: float = 1e-4
    jobs: int | None = None
    max_nfev: int = 40
    profile: str | Sequence[str] = "weak"
    level: float = 0.95
    nuisance_draws: int = 32
    scan_intervals: bool = True
    sliding: bool = True
    selection: Selection | None = None
    validate: float = 0.0
    scheduler: str | None = None
    curve_check: bool = True

    def __post_init__(self) -> None:
        if self.loss not in LOSSES:
            raise IdentificationError(f"unknown loss {self.loss!r}; choose {', '.join(LOSSES)}")
        if not (0 < self.level < 1):
            raise IdentificationError(f"level = {self.level!r} must lie in (0, 1)")
        _int_at_least("coarse", self.coarse, 1, "1: no coarse stage")
        _int_at_least("nuisance_draws", self.nuisance_draws, 0, "0: none")
        if self.differences not in DIFFERENCES:
            raise IdentificationError(
                f"differences = {self.differences!r}; choose central or forward"
            )

    @classmethod
    def merged(cls, options: FitOptions | None, settings: Mapping[str, Any]) -> FitOptions:
        """``options`` (default all defaults) with the keyword ``settings`` replacing fields."""
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(settings) - known)
        if unknown:
            raise TypeError(f"fit_model() got unexpected keyword argument(s) {', '.join(unknown)}")
        return dataclasses.replace(options or cls(), **settings)

    @property
    def optimizer(self) -> LeastSquares:
        """The least-squares settings of the fit's stages."""
        return LeastSquares(
            loss=self.loss,
            f_scale=self.f_scale,
            x_scale=self.x_scale,
            max_nfev=self.max_nfev,
            xtol=self.xtol,
            verbose=self.verbose,
        )


@dataclasses.dataclass
class FitData:
    """The prepared data of one fit.

    Attributes
    ----------
    base_model : the user's model (its parameters are the base and the start)
    work_model : the fit's own model (measured P_S drives it; the force sensor holds c·ẋ)
    names : the free parameters
    pairs : (run, prepared run) of every usable run
    channels : the fitted channels that some run logs
    sigma : per channel, the median of the runs' noise levels [SI]
    skipped : runs left out and why
    notes : which data were used and why (one sentence each)
    """

    base_model: Any
    work_model: Any
    names: tuple[str, ...]
    pairs: list[tuple[Any, RunData]]
    channels: tuple[str, ...]
    sigma: dict[str, float]
    skipped: list[SkippedRun]
    notes: list[str] = dataclasses.field(default_factory=list)
    #: per run, the spans [s] a campaign selection kept (None: all data)
    selected: dict[str, list[tuple[float, float]]] | None = None
    #: whether the runs keep their departures from the end stops (a selection for friction)
    departures: bool = False
    #: runs held out of the fit for validation
    held: list = dataclasses.field(default_factory=list)
    #: the load's damping [N·s/m] estimated from the runs and put back into the model
    feedback: float = 0.0
    #: the steady stretches' means as pseudo-runs (a selected campaign, ``greybox.steady``)
    steady: list[RunData] = dataclasses.field(default_factory=list)
    #: the experiment whose runs carry ``feedback`` (None: every run)
    feedback_from: str | None = None

    def feedback_of(self, run: Any) -> float:
        """The load damping [N·s/m] taken out of ``run``'s measured force (see ``feedback``)."""
        if self.feedback_from is None or experiment_of(run) == self.feedback_from:
            return self.feedback
        return 0.0

    def restricted(self, pairs: list[tuple[Any, RunData | None]]) -> list[RunData]:
        """Other preparations of the runs (windows, sliding stretches) cut to the selection."""
        out = []
        for _r, rd in pairs:
            if rd is None:
                continue
            if self.selected is not None:
                rd = restrict(rd, self.selected.get(rd.name, []))
            if rd.segments:
                out.append(rd)
        return out

    @property
    def prepared(self) -> list[RunData]:
        return [rd for _r, rd in self.pairs]


#: The kinds a fit can start from measurements, for messages ("'full' or 'reduced'").
_MEASURABLE = " or ".join(repr(name) for name in MEASURABLE_MODELS)


def _base_model(model: Any, params: Any) -> Any:
    if isinstance(model, str) and model.strip().lower() in LINEARIZED_MODELS:
        raise IdentificationError(
            f"the {model.strip()} model is fitted from its parameters; fit {_MEASURABLE} and "
            "linearize"
        )
    try:
        base_model = as_model(model, params)
    except ParameterError as exc:
        raise IdentificationError(str(exc)) from None
    if not hasattr(type(base_model), "state_from_measurement"):
        raise IdentificationError(
            f"the {base_model.name} model cannot start from measurements; fit {_MEASURABLE}"
        )
    return base_model


def _work_model(base_model: Any, run_list: list, names: tuple[str, ...]) -> Any:
    """The fit's own model: measured P_S drives it, and the force sensor already holds c·ẋ."""
    sim_params = base_model.params
    logged = set.intersection(*[set(r.channels) for r in run_list]) if run_list else set()
    if "p_s" in logged and sim_params.supply.model != "ideal":
        sim_params = sim_params.replace(**{"supply.model": "ideal"})
    if "f_l" in logged and sim_params.load.damping > 0 and "load.damping" not in names:
        sim_params = sim_params.replace(**{"load.damping": 0.0})
    return type(base_model)(sim_params)


def _windowed_experiments(
    pairs: list[tuple[Any, RunData]], work_model: Any, chans: tuple, opts: FitOptions, skipped: list
) -> None:
    """An experiment with stick-slip runs is fitted in windows throughout: its smooth runs'
    long segments would otherwise dominate the cost and F_s stalls (measured −22 % on the
    undamped friction campaign against +0.3 % in windows)."""
    shooting = opts.shooting or Shooting()
    shaky = {experiment_of(r) for r, rd in pairs if rd.method == "multiple" and experiment_of(r)}
    forced = dataclasses.replace(shooting, method="multiple")
    for k, (r, rd) in enumerate(pairs):
        if rd.method == "single" and experiment_of(r) in shaky:
            again = prepare_run(r, work_model, chans, forced, skipped, opts.input_cutoff)
            if again is not None:
                again.reason = (
                    f"auto: other {experiment_of(r)} runs oscillate ({rd.reason.split(': ', 1)[1]})"
                )
                pairs[k] = (r, again)


#: The least peak-to-peak valve command [1] (a share of the full opening) a run must have to
#: excite the axis: 0.1 %, a hundredth of the paper rig's 10 % dead zone.
MIN_EXCITATION = 1e-3
#: The least peak-to-peak rod travel [m] that excites the axis under a constant command (a
#: constant-speed run): 0.1 mm, five times a position sensor's 20 µm noise.
MIN_TRAVEL = 1e-4


def _span(run: Any, channel: str) -> float:
    """Peak-to-peak of a channel over its finite samples (0 when it has none)."""
    y = np.asarray(run[channel], dtype=float)
    y = y[np.isfinite(y)]
    return float(y.max() - y.min()) if y.size else 0.0


def check_excitation(runs: list) -> None:
    """Refuse runs none of which excites the axis: the valve command varies by less than
    :data:`MIN_EXCITATION` and the rod travels less than :data:`MIN_TRAVEL` in every run.

    With a constant command and a resting rod the outputs carry no information on any
    parameter: the fit's Jacobian is zero and the cost flat (it ended in NaN steps or an
    infinite cost). A constant command that moves the rod (a constant-speed run) excites it.
    """
    if not runs or any(
        not r.has("u")
        or _span(r, "u") >= MIN_EXCITATION
        or (r.has("x") and _span(r, "x") >= MIN_TRAVEL)
        for r in runs
    ):
        return
    ptp = max(_span(r, "u") for r in runs)
    raise IdentificationError(
        f"no run excites the axis: the valve command u varies by at most {ptp:.3g} (less "
        f"than {MIN_EXCITATION:g}) and the rod travels less than {MIN_TRAVEL * 1e3:g} mm in "
        f"all {len(runs)} runs; give runs with steps, sines or chirps"
    )


def prepare_data(
    base_model: Any, runs: Any, free: Iterable[str] | str, opts: FitOptions
) -> FitData:
    """The runs prepared for the fit (segments, noise levels, shooting per run)."""
    shooting = opts.shooting or Shooting()
    run_list, held = split_runs(as_runs(runs), opts.validate)
    check_excitation(run_list)
    names = expand_free(free, base_model.params)
    skipped: list[SkippedRun] = []
    work_model = _work_model(base_model, run_list, names)
    logged = set.intersection(*[set(r.channels) for r in run_list]) if run_list else set()
    chans = (
        tuple(opts.channels)
        if opts.channels
        else tuple(c for c in ("x", "p_a", "p_b", "v") if c in logged or c != "v")
    )
    pairs = []
    for r in run_list:
        rd = prepare_run(r, work_model, chans, shooting, skipped, opts.input_cutoff)
        if rd is not None:
            pairs.append((r, rd))
    if shooting.method == "auto":
        _windowed_experiments(pairs, work_model, chans, opts, skipped)
    if not pairs:
        why = "; ".join(str(s) for s in skipped[:3])
        raise IdentificationError(f"no run can be used for the grey-box fit: {why}")
    prepared = [rd for _r, rd in pairs]
    used = tuple(c for c in chans if any(c in rd.y for rd in prepared))
    sigma = {c: float(np.median([rd.sigma[c] for rd in prepared if c in rd.y])) for c in used}
    data = FitData(base_model, work_model, names, pairs, used, sigma, skipped, held=held)
    selection = opts.selection or Selection()
    seconds = sum(float(rd.t[s.i1 - 1] - rd.t[s.i0]) for rd in prepared for s in rd.segments)
    if selection.applies(seconds):
        _select(data, selection, opts)
    return data


def _v_move(params: Any) -> float:
    """The speed [m/s] above which the rod counts as moving: a fifth of the Stribeck velocity
    (the falling branch starts well below it), at least 1 mm/s."""
    return max(1e-3, 0.2 * float(params.friction.stribeck_velocity))


def load_feedback(prepared: list[RunData]) -> float:
    """The load's velocity-proportional part c [N·s/m] from the runs' steady parts, or 0.

    Per run the median measured F_L and smoothed speed over its prepared segments; per
    direction of motion a line F_L = F_0 + c·v through them (one intercept each, the counter
    force opposes the motion). Kept when at least three runs per direction cover a speed
    range, c > 0, and the lines explain 90 % of the variance: a constant-counter-force
    campaign against a damped counter cylinder (the virtual rig's: 1e4 N·s/m).
    """
    pts: dict[bool, list[tuple[float, float]]] = {True: [], False: []}
    for rd in prepared:
        if rd.f_l is None or rd.speed is None or not rd.segments:
            continue
        idx = np.concatenate([np.arange(s.i0, s.i1) for s in rd.segments])
        v = float(np.median(rd.speed[idx]))
        if v != 0.0:
            pts[v > 0].append((v, float(np.median(rd.f_l[idx]))))
    groups = [np.array(p) for p in pts.values() if len(p) >= 3]
    if not groups:
        return 0.0
    vc = np.concatenate([g[:, 0] - g[:, 0].mean() for g in groups])
    fc = np.concatenate([g[:, 1] - g[:, 1].mean() for g in groups])
    if not float(vc @ vc) > 0:
        return 0.0
    c = float(vc @ fc) / float(vc @ vc)
    r2 = 1.0 - float(np.sum((fc - c * vc) ** 2)) / max(float(fc @ fc), 1e-300)
    return c if c > 0 and r2 >= 0.9 else 0.0


def _campaign_feedback(
    pairs: list[tuple[Any, RunData]], by_experiment: bool
) -> tuple[float, str | None]:
    """:func:`load_feedback` over the runs (and None: it applies to all), or per experiment
    (the largest found, and that experiment: only its runs get it). In a whole campaign only
    the friction experiment's counter cylinder loads the rod with c·ẋ: the other
    experiments' unloaded runs hide its line (c = 0: the steady means on the falling Stribeck
    branch then run away, an open loop), and c applied to their fast motion turns the
    smoothed velocity's lag into a force error (paper rig: FRF cost ×10 at the truth)."""
    if not by_experiment:
        return load_feedback([rd for _r, rd in pairs]), None
    groups: dict[Any, list[RunData]] = {}
    for r, rd in pairs:
        groups.setdefault(experiment_of(r), []).append(rd)
    if "friction" in groups:
        # the constant-counter-force experiment (Sec. VI-C) the line is meant for: the load
        # runs of the evaluation ramp their force with the motion and mimic a line
        # (paper rig: 4.6e4 N·s/m from them)
        c = load_feedback(groups["friction"])
        return c, ("friction" if c > 0 else None)
    found = [(load_feedback(g), k) for k, g in groups.items()]
    c, k = max(found, key=lambda f: f[0], default=(0.0, None))
    return c, (str(k) if c > 0 else None)


def _select(data: FitData, selection: Selection, opts: FitOptions) -> None:
    """Replace the prepared runs by their segments that excite the free parameters.

    Each run is prepared again with every window (no ``max_windows``) and with its
    departures from the end stops kept where the rod's motion events matter (friction
    free: the breakaway), each in the shooting the fit chose for it; :class:`Selection` then
    picks the segments.
    """
    shooting = opts.shooting or Shooting()
    departures = selection.departures and "motion" in selection.wanted(data.names)
    c, source = (
        _campaign_feedback(data.pairs, selection.by_experiment) if selection.feedback else (0, None)
    )
    if c > 0 and source is None:
        data.work_model = type(data.work_model)(
            data.work_model.params.replace(**{"load.damping": c})
        )
    if c > 0:
        data.notes.append(
            f"The measured load force rises with the speed by {c:.4g} N·s/m over the "
            f"{'runs' if source is None else source + ' runs'}' steady parts: that part is "
            "applied by the model (load.damping) from the simulated velocity, the rest drives "
            "it (as a measured input it would be an open loop)."
        )
    data.feedback, data.feedback_from = c, source
    again = []
    for r, rd in data.pairs:
        sh = dataclasses.replace(shooting, method=rd.method, max_windows=None)
        if rd.method == "single":
            sh = dataclasses.replace(sh, segment=max(selection.segment, sh.window))
        full = prepare_again(
            r, data.work_model, data.channels, sh, [], opts.input_cutoff,
            departures=departures, feedback=data.feedback_of(r),
        )  # fmt: skip
        if full is not None:
            full.reason = rd.reason
            again.append((r, full))
    v_move = _v_move(data.work_model.params)
    steady_note = ""
    if selection.steady_means:
        data.steady, steady_note = steady_runs(
            [rd for _r, rd in again], data.channels, data.sigma, v_move,
            selection.transient, selection.segment,
        )  # fmt: skip
    transients = selection.transients
    if transients is None:
        friction_only = all(n.startswith("friction.") for n in data.names)
        transients = not (c > 0 and data.steady and friction_only)
    groups = [experiment_of(r) for r, _rd in again] if selection.by_experiment else None
    picked, note = selection.select(
        [rd for _r, rd in again], data.names, v_move, transients, groups
    )
    if source is not None and data.steady and selection.transients is None:
        # the damped experiment's runs by their steady means alone (see ``transients``)
        picked = [
            dataclasses.replace(rd, segments=[]) if experiment_of(r) == source else rd
            for (r, _), rd in zip(again, picked, strict=True)
        ]
        note += (
            f" The {source} runs enter by their steady means alone: their measured load force "
            "holds the counter cylinder's c·ẋ, which the smoothed velocity misses by tens of "
            "newtons around every motion event."
        )
    data.pairs = [(r, rd) for (r, _), rd in zip(again, picked, strict=True) if rd.segments]
    data.notes.append(note)
    if steady_note:
        data.notes.append(steady_note)
    if not transients:
        data.notes.append(
            "The steady means alone are fitted (no segment): the measured load force holds "
            "the load's damping c·ẋ, and within milliseconds of a motion event the smoothed "
            "velocity taken out of it misses c·(ẋ − ẋ̂), an input error of tens of newtons, "
            "while the means pin the friction curve; the smoothness, which acts only around "
            "standstill, is not determined by them."
        )
    data.selected = {rd.name: spans(rd) for _r, rd in data.pairs}
    data.departures = departures


def _plan(
    data: FitData,
    problem: GreyBoxProblem,
    opts: FitOptions,
    progress: Callable[[FitProgress], None] | None,
    t0: float,
) -> StagePlan:
    """The stage plan: the full objective, and the locating and coarse ones where they apply.

    Locating: with friction free, the single-shooting cost of smooth runs is a narrow well in
    F_s on a plateau (each stick at a reversal shifts the phase of the rest of the segment;
    measured on the sine runs: cost ×3.4 at F_s −10 %, flat beyond), so a start 15 % off ends
    on the plateau. Windows of multiple shooting re-start from the measured state every
    20 ms: their cost is smooth in the friction and finds the well, then the single-shooting
    stages refine from there (the windows' noisy initial states bias E by ~1 %, so they only
    locate). Coarse: every ``coarse``-th segment of each run (offset per run, so that the
    subset covers every phase of the inputs); after a locating stage the walk is short and
    every 2·``coarse``-th segment does it (benchmark: 54 s against 78 s, the same optimum).
    """
    shooting = opts.shooting or Shooting()
    prepared = data.prepared + data.steady

    def objective(runs: list[RunData]) -> OutputErrorObjective:
        return OutputErrorObjective(
            data.work_model, runs, data.names, data.channels, opts.rtol, opts.jobs,
            data.sigma, ref=problem.ref, fd_step=opts.fd_step,
        )  # fmt: skip

    locate = None
    if (
        shooting.method == "auto"
        and any(n in STICK for n in data.names)
        and any(rd.method == "single" for rd in prepared)
    ):
        windowed = dataclasses.replace(shooting, method="multiple")
        if data.selected is not None:  # every window, then those of the selected spans
            windowed = dataclasses.replace(windowed, max_windows=None)
        located = data.restricted(
            [
                (r, prepare_again(r, data.work_model, data.channels, windowed, [], opts.input_cutoff,
                                departures=data.departures, feedback=data.feedback_of(r)))
                for r, _rd in data.pairs
            ]
        )  # fmt: skip
        locate = objective(located) if located else None
    coarse = None
    n_seg = sum(len(rd.segments) for rd in prepared)
    stride = 2 * opts.coarse if locate is not None else opts.coarse
    if opts.coarse > 1 and n_seg >= 4 * stride:
        sub = [
            dataclasses.replace(rd, segments=rd.segments[(k % stride) % len(rd.segments) :: stride])
            for k, rd in enumerate(prepared)
        ]
        coarse = objective(sub)
    return StagePlan(
        problem, objective(prepared), locate, coarse, opts.optimizer, opts.differences,
        opts.refresh, opts.fd_step, progress, t0,
    )  # fmt: skip


@dataclasses.dataclass
class _Estimate:
    """The estimate and its uncertainty as the fit refines them (full fit, scan, sliding)."""

    problem: GreyBoxProblem
    theta: np.ndarray
    values: np.ndarray
    cv: Covariance
    cov: np.ndarray
    naive: np.ndarray
    s2: float
    z: float
    level: float
    inflation: np.ndarray = dataclasses.field(init=False)
    sd: np.ndarray = dataclasses.field(init=False)
    corr: np.ndarray = dataclasses.field(init=False)
    estimates: dict = dataclasses.field(default_factory=dict)
    at_bound: list[str] = dataclasses.field(default_factory=list)
    unconverged: list[str] = dataclasses.field(default_factory=list)
    remaining_sd: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))
    scan: dict[str, tuple[float, float]] = dataclasses.field(default_factory=dict)
    widened: list[str] = dataclasses.field(default_factory=list)
    #: the covariance before the interval scan widened it (the profiles' κ)
    cov_before_scan: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 0)))

    def __post_init__(self) -> None:
        self.refresh(corr=True)

    def refresh(self, corr: bool) -> None:
        """Standard deviations and inflation (and correlations) from ``cov``."""
        with np.errstate(invalid="ignore", divide="ignore"):
            self.inflation = np.diag(self.cov) / self.naive
            self.sd = np.sqrt(np.clip(np.diag(self.cov), 0.0, None))
            if corr:
                self.corr = self.cov / np.outer(self.sd, self.sd)

    def set_estimate(self, i: int, half_lo: float | None = None, half_hi: float | None = None):
        n = self.problem.names[i]
        hw = self.z * self.sd[i]
        got = estimate(
            self.estimates[n],
            self.values[i],
            self.sd[i],
            hw if half_lo is None else half_lo,
            hw if half_hi is None else half_hi,
        )
        self.estimates[n] = within_physical_bounds(n, got)


def _at_optimum(plan: StagePlan, best: StartResult, opts: FitOptions) -> _Estimate:
    """Wald estimates at the best start's optimum: the sandwich covariance (central
    differences, loss weights, Newey–West per stream) plus the Gauss–Newton step still left."""
    prob, problem = plan.full, plan.problem
    theta = best.sol.x
    r = prob.fun(theta)
    # the last iteration's central Jacobian is the one wanted here when it was taken at θ
    if best.central is not None and np.array_equal(best.central[0], theta):
        J = best.central[1]
    else:
        J = prob.jac(theta, opts.fd_step, central=True)
    rng = np.random.default_rng([opts.seed, 19])
    cv = covariance(prob, theta, r, J, opts.loss, opts.f_scale, opts.nuisance_draws, rng)
    s2 = float(cv.rw @ cv.rw) / max(r.size - len(problem.names), 1)
    z = float(stats.norm.ppf(0.5 + 0.5 * opts.level))
    est = _Estimate(
        problem, theta, prob.values(theta), cv, cv.cov, np.diag(cv.Hinv) * s2, s2, z, opts.level
    )
    tlo, thi = problem.theta_bounds
    for i, n in enumerate(problem.names):
        v, sd = float(est.values[i]), est.sd[i]
        est.estimates[n] = within_physical_bounds(
            n,
            ParameterEstimate(
                v, float(v * sd), log_interval(v, z * sd, z * sd), problem.unit(n), opts.level
            ),
        )
        if theta[i] - tlo[i] < 1e-3 or thi[i] - theta[i] < 1e-3:
            est.at_bound.append(n)
    # the Gauss–Newton step still left at the end, in standard errors: an optimiser that
    # stopped on its step tolerance in a narrow valley (integrator jitter, curvature) is not
    # at the optimum, and no covariance of the residuals shows how far it is; a parameter
    # that the remaining step would move by more than one standard error is not converged
    free_i = np.array([n not in est.at_bound for n in problem.names])
    remaining = remaining_step(cv.H, cv.Jw, cv.rw, free_i)
    with np.errstate(invalid="ignore", divide="ignore"):
        est.remaining_sd = np.abs(remaining) / est.sd
    est.unconverged = [n for i, n in enumerate(problem.names) if est.remaining_sd[i] > 1.0]
    # the distance still to go is part of the estimate's error: add the remaining step to the
    # covariance (rank one, a bias² term), so that the interval reaches where the optimiser
    # would still go (negligible once converged)
    if np.any(remaining != 0.0):
        est.cov = est.cov + np.outer(remaining, remaining)
        est.refresh(corr=True)
        for i in range(len(problem.names)):
            est.set_estimate(i)
    est.cov_before_scan = est.cov
    return est


def _scan(est: _Estimate, plan: StagePlan, only: list[int] | None) -> None:
    """Widen intervals where the cost along a parameter's valley rises slower than the
    quadratic (correlations kept from before the scan)."""
    names = est.problem.names
    tlo, thi = est.problem.theta_bounds
    sd0 = est.sd
    cov, half_lo, half_hi, scan_i = scan_widen(
        plan.full, est.theta, est.cv.Hinv, est.cov, est.z, tlo, thi, plan.cost, only=only
    )
    est.cov = cov
    est.scan = {names[i]: q for i, q in scan_i.items()}
    est.widened = [n for i, n in enumerate(names) if max(half_lo[i], half_hi[i]) > est.z * sd0[i]]
    est.refresh(corr=False)
    for i, n in enumerate(names):
        if n in est.widened:
            est.set_estimate(i, half_lo[i], half_hi[i])


def _apply_sliding(est: _Estimate, got: Sliding) -> None:
    """The sliding stage's values, covariance, intervals and convergence for its parameters."""
    names, idx, z = est.problem.names, got.index, est.z
    est.values = est.values.copy()
    est.values[idx] = got.prob.values(got.theta)
    est.cov = got.cov
    est.refresh(corr=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        est.inflation[idx] = np.diag(est.cov)[idx] / got.naive
    moved = {names[i] for i in idx}
    est.scan = {n: q for n, q in est.scan.items() if n not in moved}
    est.scan.update({names[idx[k]]: q for k, q in got.scan.items()})
    est.widened = [n for n in est.widened if n not in moved]
    for k, i in enumerate(idx):
        h_lo = max(float(got.half_lo[k]), z * est.sd[i])
        h_hi = max(float(got.half_hi[k]), z * est.sd[i])
        est.set_estimate(i, h_lo, h_hi)
    est.widened += [names[idx[k]] for k in got.widened]
    # convergence of the refitted parameters is the sliding stage's
    unconverged = [n for n in est.unconverged if n not in moved]
    for k, i in enumerate(idx):
        est.remaining_sd[i] = got.left_sd[k]
        if got.left_sd[k] > 1.0:
            unconverged.append(names[i])
    est.unconverged = [n for n in names if n in unconverged]


def _sliding_shooting(data: FitData, opts: FitOptions) -> Shooting:
    """The sliding stretches' shooting: a selected campaign's shorter segments."""
    shooting = opts.shooting or Shooting()
    if data.selected is None:
        return shooting
    sel = opts.selection or Selection()
    return dataclasses.replace(shooting, segment=max(sel.segment, shooting.window))


def _sliding(
    est: _Estimate, plan: StagePlan, data: FitData, opts: FitOptions
) -> Sliding | dict[str, Any] | None:
    """The scan and the sliding stage (with F_c free and sliding stretches to fit)."""
    names = est.problem.names
    stretches: Any = {}
    if opts.sliding and "friction.coulomb" in names:
        stretches = sliding_runs(
            data.pairs,
            data.work_model,
            plan.full.params_at(est.values),
            sum(n not in BREAKAWAY for n in names),
            data.channels,
            _sliding_shooting(data, opts),
            opts.input_cutoff,
            keep=data.selected,
            feedback=data.feedback_of,
        )
    if opts.scan_intervals:
        # parameters the sliding stage refits are scanned there, on its own cost
        only = est.problem.index(BREAKAWAY) if isinstance(stretches, tuple) else None
        _scan(est, plan, only)
    if isinstance(stretches, dict):
        return stretches
    settings = SlidingSettings(
        opts.rtol, opts.jobs, opts.fd_step, opts.optimizer, opts.nuisance_draws,
        np.random.default_rng([opts.seed, 20]),
    )  # fmt: skip
    plan.report("sliding", 0, 0)
    got = sliding_stage(
        stretches, est.problem, est.values, est.cov, data.channels, data.sigma, settings,
        est.z, opts.scan_intervals,
    )  # fmt: skip
    plan.report("sliding", 0, 0, cost=got.cost, nfev=got.stage.nfev)
    _apply_sliding(est, got)
    return got


def fit_model(
    model: Any,
    runs: Any,
    free: Iterable[str] | str,
    *,
    params: Any = None,
    options: FitOptions | None = None,
    progress: Callable[[FitProgress], None] | None = None,
    **settings: Any,
) -> GreyBoxFit:
    """Fit free model parameters to measured runs by output error (grey-box identification).

    Parameters
    ----------
    model : FullOrderModel, ReducedModel or str
        The model to fit; its parameters are the base (fixed values and start). A name
        (``"full"``, ``"reduced"``) takes ``params`` (default the ``paper`` preset).
    runs : Dataset, Run, path or iterable of Run
        Measured runs with channels t, u, x, p_a, p_b, and if logged p_s, f_l, spool, v.
    free : str or iterable of str
        Parameters to fit by their dotted names in the parameter file (``friction.static``,
        ``oil.bulk_modulus``, ``cylinder.leakage``, ``flow.K``) or groups (``friction``).
    params : SystemParams, optional
        Base parameters when ``model`` is a name.
    options : FitOptions, optional
        All the settings below in one object (keywords given as well replace its fields).
    progress : callable, optional
        Called with a :class:`FitProgress` at each stage's beginning and end (per start), and
        for the uncertainty, sliding and profile steps: ``progress=print`` shows them.
    **settings
        Fields of :class:`FitOptions`, given as keywords (the keyword API of earlier
        releases); each is listed under Other Parameters.

    Other Parameters
    ----------------
    channels : sequence of str, optional
        Output channels in the residual (default x, p_a, p_b and v where logged; p_l = p_a − p_b
        on request). Each is divided by its noise level, estimated from the data
        (:func:`noise_level`, pooled over the runs by the median).
    bounds : dict name → (low, high), optional
        Bounds [SI]; default a decade either side of the start (the ``_ZERO_BASE`` range for
        parameters whose base value is 0, such as the leakage).
    initial : dict name → value, optional
        Start values [SI] instead of the base parameters'.
    shooting : Shooting, optional
        Single or multiple shooting (default ``Shooting()``: chosen per run by its content).
    loss, f_scale : str, float
        Loss of :func:`scipy.optimize.least_squares` and its scale [noise σ]. Default
        ``linear`` (plain least squares); ``soft_l1``/``huber``/``cauchy`` weigh residuals
        beyond ``f_scale`` σ less (sharp events the model misses, outliers).
    x_scale : float, "jac" or array
        Passed to least_squares. Default 1: the coordinates are already relative
        (θ = ln p/p_start), so the trust region is a ball of relative changes and its first
        radius (1 in θ, a factor e) is a sensible first step. ``"jac"`` (scale by column
        norms) makes that first radius 1/‖J_j‖ ≈ 1e-3 for the strong parameters and costs
        six doubling iterations before the first full Gauss–Newton step (measured on the
        sine runs: 14 against 8 Jacobians to the same optimum).
    verbose : int
        least_squares verbosity (0, 1, 2).
    input_cutoff : float or None
        Corner [Hz] of the zero-phase low-pass (2nd-order Butterworth) applied to the measured
        P_S(t) and F_L(t) before they drive the model (None: raw). On simulated sines the
        raw inputs' sensor noise doubles the output error at the true parameters; at 50 Hz
        it is back within 10 % of that with exact inputs.
    xtol : float
        Step tolerance of least_squares (relative, in log parameters).
    starts : int
        Number of starts: the base values and ``starts − 1`` log-uniform random points
        within ×/÷ 3 of them and inside the bounds (``seed``); the best optimum is kept.
    rtol : float
        Simulation tolerance. 1e-5: the adaptive step sequence changes with the parameters,
        which puts a jitter on the residuals; at 1e-5 it is ~5 % of a 1 % parameter change's
        effect on the paper rig's sine runs (at 1e-4 it is as large as that effect).
    fd_step : float
        Difference step in log parameter (3e-2 = 3 %, well above the integrator's jitter).
    differences : {"central", "forward"}
        Jacobian by central (2p simulations, error O(h²)) or forward (p simulations,
        error O(h)) differences. Central by default: at a 3 % step the forward Jacobian's
        O(h) error tilts the Gauss–Newton direction across the narrow flow-coefficient /
        viscous-friction valley and the fit stalls there (measured on the rig's sine runs:
        σ +10 … +12 %, cost 2.4× the cost at the truth, truth outside 10 of 12 intervals;
        central: σ within its interval, cost within 1 % of the truth's).
    coarse : int
        Fit first to every ``coarse``-th simulated segment of each run (1: no coarse stage),
        then to all of them from there. The walk from a start 10–30 % off takes most of the
        iterations and needs no more data than identifies the parameters; the full data
        then take 2–4 iterations to the same optimum (the objective is unchanged).
    refresh : int
        Finite-difference Jacobian every ``refresh``-th Jacobian call, Broyden rank-one
        updates from the accepted steps in between (1: always differences).
    jobs : int, optional
        Threads for the simulations (default all cores).
    max_nfev : int
        Iteration budget per start (least_squares ``max_nfev``).
    profile : "weak", "all", "none" or names
        Parameters to profile (``weak``: those flagged weak after the fit).
    scheduler : str, optional
        Run the starts and the profiles as Dask tasks: ``"local"`` (a local cluster of
        ``jobs`` single-threaded worker processes) or a scheduler's address. Each task
        runs what the in-process fit runs, so the estimates are the same (the test
        compares them); without it (default) everything runs in this process.
    level : float
        Confidence level of the intervals.
    nuisance_draws : int
        Draws of the initial-state and input errors propagated into the covariance (0: none;
        see :func:`~hydropwa.identification.greybox.uncertainty.covariance`). Each simulates a quarter of the segments, so 32
        draws cost eight simulations of all runs. The fit starts every segment from
        smoothed measurements and drives the model with measured (filtered) inputs; their
        noise moves the estimate by what no residual covariance holds. Measured on the rig's
        sine runs (seeds 1–3): with the true initial states the bulk modulus moved from
        +0.030 … +0.061 % (1.2–2.4 std of the residual-based interval) to −0.001 … +0.029 %;
        with the propagation the truth is inside 20 of 20 intervals over seeds 1–5 (16 of 20
        without).
    scan_intervals : bool
        Check every interval against the cost (:func:`~hydropwa.identification.greybox.intervals.interval_scan`: two simulations of
        all runs per parameter wider than ±0.2 %, at a tenth of ``rtol``) and widen it
        where the cost rises slower than the Gauss–Newton quadratic. On runs with stick events the Coulomb friction's cost is a
        flat floor under a rough surface: measured on the rig's 5 s sine runs (seeds 1–6,
        six parameters free), the truth inside 27 of 36 intervals without the scan and
        34 of 36 with it (F_c's intervals widened up to 2.8×, K's reached along σ's and F_c's
        valleys; the misses: C_L at 1.98 std, F_s at 4.7 std on one seed). Costs 52–54
        against 44 s on one thread for the benchmark's fit.
    curve_check : bool
        With a Stribeck shape parameter (F_s, Stribeck velocity, shape) free and at least
        four constant-input friction runs: fit the friction curve to their steady points
        with its shape profiled (:class:`~hydropwa.identification.StribeckIdentifier`) and
        widen each free friction parameter's interval to hold the curve's; a parameter the
        curve does not identify is reported not identified, and the curve's band over the
        excited speeds is given in ``data_``
        (:mod:`~hydropwa.identification.greybox.curve`). Those parameters are then not
        profiled on the output-error cost (``profile="weak"``): on stick-slip runs it
        follows the stick pattern's phase and rejects the truth (issue 49: the truth's cost
        137 232 against the fit's 117 193). Measured on 12 friction runs of the paper rig
        with a hidden curve: F_s, χ and δ missed the truth unflagged without it.
    sliding : bool
        With the Coulomb friction free and single-shot runs that pass through velocity
        reversals: refit every free parameter except the breakaway ones (F_s, Stribeck
        velocity, shape, smoothness: held at the full fit's values, their uncertainty
        propagated) on the stretches where the rod slides faster than twice the Stribeck
        velocity, each simulated from the measured state at its start
        (:func:`~hydropwa.identification.greybox.sliding.sliding_stage`); those parameters' estimates and intervals are the
        refit's. Around a reversal the falling branch of the Stribeck curve makes the
        simulated motion run away from the measured one, and in the full data that error
        decides F_c. Measured on the rig's 5 s sine runs (seeds 1–6, six parameters free):
        F_c −11.1 … +6.2 % without, −1.5 … +3.2 % with (σ −2.2 … +1.8 % against within
        ±0.6 %), every F_c interval holding the truth. It adds 4–6 s to the benchmark's
        fit on one thread (56–58 s in all).

    Returns
    -------
    GreyBoxFit

    Raises
    ------
    IdentificationError
        For unknown parameters, bad bounds or no usable run.

    Notes
    -----
    The objective is ½Σρ(r_i²) with r = (y_sim − y_meas)/σ_channel over every simulated
    sample (Eqs. (1)–(11) of the paper for the full model, (12)–(15) for the reduced one),
    in log parameters θ = ln p so that parameters from 1e-13 to 1e9 are scaled alike.
    With J the Jacobian of the (loss-weighted) residuals at the optimum, H = JᵀJ and
    S = Σ_streams Newey–West(g = J_i r_i), Cov θ = H⁻¹ S H⁻¹; with at least 2p segments each
    standard deviation is the larger of that and the segment-block (cluster-robust) estimate;
    the errors of the initial states and driving inputs add the mean square of the steps
    −H⁻¹Jᵀ(w·Δr) they cause (``nuisance_draws``); the remaining Gauss–Newton step
    δ = −H⁻¹Jᵀr at the result adds δδᵀ (the distance the optimiser left). The interval is
    exp(θ ± z·σ_θ), widened on a side where the cost along the parameter's valley rises
    slower than that quadratic (``scan_intervals``; the standard error then is the
    interval's half-width in θ over z, and the covariance is scaled to it).

    Stages per start: with ``shooting.method == "auto"``, a free stick parameter (F_c, F_s,
    Stribeck velocity, shape) and single-shot runs, a locating stage in multiple shooting
    first (its cost is smooth in the friction, the single-shooting cost a narrow well on a
    plateau), and from its result a scan of the single-shooting cost along each stick
    parameter's valley (:func:`~hydropwa.identification.greybox.stages.valley_scan`); then the coarse stage (every ``coarse``-th
    segment, every 2·``coarse``-th after locating) and the full data. Where the full stage
    stops beside a lower point of its last central differences (a ridge of a cost made rough
    by stick events), it starts again from that point, at most twice. ``starts_`` records
    each stage's evaluations (the scan's with the locating stage's).
    """
    t0 = time.perf_counter()
    opts = FitOptions.merged(options, settings)
    data = prepare_data(_base_model(model, params), runs, free, opts)
    problem = GreyBoxProblem.build(data.names, data.base_model.params, opts.initial, opts.bounds)
    plan = _plan(data, problem, opts, progress, t0)
    with _client(opts) as client:
        best, logs = plan.minimize(
            theta_starts(problem, opts.starts, np.random.default_rng(opts.seed)), client
        )
        plan.report("uncertainty", 0, 0)
        est = _at_optimum(plan, best, opts)
        got = _sliding(est, plan, data, opts)
        stages = best.stages + ([got.stage] if isinstance(got, Sliding) else [])
        sliding = SlidingSummary.from_info(got.info if isinstance(got, Sliding) else got)
        _warn_unconverged(est)
        names = problem.names
        undetermined = _undetermined(est)
        undetermined += _bounded(est, undetermined)
        weak = _weak(est, undetermined)
        ident = identifiability(
            names, est.cv.H, est.s2, est.inflation, est.corr, weak, est.unconverged
        )
        ident.undetermined = undetermined
        curve = _curve(opts, data, names)
        # the cost is not quadratic; the curve's profile carries the friction's shape
        to_profile = [
            n for n in dict.fromkeys(weak + est.widened) if curve is None or n not in BY_CURVE
        ]
        profiles = _profiles(opts, data, to_profile, est, plan, best, got, client)
    ident.undetermined += _profile_intervals(est, profiles, ident.undetermined)
    _carry_weak(est, profiles, ident.undetermined, data.notes)
    _curve_intervals(est, curve, ident, data.notes)
    sol = best.sol
    info = {
        "model": data.base_model.name,
        "free": list(names),
        "runs": [rd.name for rd in data.prepared],
        "cost": float(sol.cost),
        "status": int(sol.status),
        **({"sliding": sliding.to_dict()} if sliding.applied or sliding.skipped else {}),
    }
    fitted = fitted_params(plan.full, est.values, data.base_model, est.estimates, info)
    fits = run_fits(plan.full, est.values, est.cv.taus)
    if plan.full.failures:
        warnings.warn(
            f"{plan.full.failures} simulation(s) failed during the fit (held at their last "
            "value); check the bounds",
            IdentificationWarning,
            stacklevel=2,
        )
    checked = _validate(data, est, opts, plan)
    plan.report("done", 0, 0, cost=float(sol.cost), nfev=int(sol.nfev))
    return GreyBoxFit(
        params_=fitted, free=names, estimates_=est.estimates, covariance_=est.cov,
        correlation_=est.corr, inflation_=est.inflation,
        cost=float(sol.cost), initial_cost=float(best.initial_cost), runs_=fits,
        profiles_=profiles, identifiability_=ident, starts_=logs, model=data.base_model.name,
        skipped_=data.skipped, wall_time=time.perf_counter() - t0, level=opts.level,
        interval_scan_=est.scan, widened_=est.widened, sliding_=sliding, stages_=stages,
        data_=data.notes, validation_=checked,
    )  # fmt: skip


@contextlib.contextmanager
def _client(opts: FitOptions) -> Iterator[Any]:
    """A Dask client on ``opts.scheduler`` (``"local"``: a local cluster of ``jobs`` worker
    processes) for the starts and profiles, or None (in-process)."""
    if not opts.scheduler:
        yield None
        return
    with dask_client(
        opts.scheduler, opts.jobs, timeout_s=10.0, error=IdentificationError,
        option="scheduler", hint="fit in-process (no scheduler)",
    ) as client:  # fmt: skip
        yield client


def _validate(data: FitData, est: _Estimate, opts: FitOptions, plan: StagePlan) -> Any:
    """The fitted model on the held-out runs (None when none was held out)."""
    if not data.held:
        return None
    plan.report("validation", 0, 0)
    got = validate(
        data.held, data.work_model, est.values, est.problem.names, data.channels, data.sigma,
        opts.rtol, opts.jobs, opts.input_cutoff, data.feedback_of,
    )  # fmt: skip
    if got is not None:
        data.notes.append(
            f"Held out for validation: {', '.join(got.runs)} ({100 * opts.validate:.0f} % "
            "of the runs, evenly spread)."
        )
    return got


def _profile_intervals(
    est: _Estimate, profiles: dict[str, Profile], undetermined: list[str]
) -> list[str]:
    """The profiles' intervals in place of the quadratic ones (as pyPESTO reports them):
    per side the wider of the two (a profile refitted in few iterations can only rise too
    early). A profile that stays below the threshold to a bound of the parameter, or to
    the end of its grid (×/÷ 20), leaves the parameter undetermined on that side: its
    interval reaches the bound there and its standard error is infinite. Returns the
    parameters newly found undetermined."""
    names, out = est.problem.names, []
    for n, p in profiles.items():
        if n in undetermined or not all(math.isfinite(c) for c in p.ci):
            continue
        i = names.index(n)
        e = est.estimates[n]
        lo, hi = min(e.ci[0], p.ci[0]), max(e.ci[1], p.ci[1])
        level = est.z**2
        # the profile walked to the bound or ×/÷ 20 (REACH) without rising above z²
        open_lo = bool(p.cost[0] <= level)
        open_hi = bool(p.cost[-1] <= level)
        if open_lo or open_hi:
            lo = float(est.problem.lower[i]) if open_lo else lo
            hi = float(est.problem.upper[i]) if open_hi else hi
            est.estimates[n] = dataclasses.replace(e, std=math.inf, ci=(lo, hi))
            out.append(n)
        else:
            est.estimates[n] = dataclasses.replace(e, ci=(lo, hi))
    return out


def _carry_weak(
    est: _Estimate, profiles: dict[str, Profile], undetermined: list[str], notes: list[str]
) -> None:
    """Every interval widened to the values the others' profiles refitted within their
    threshold (:func:`~hydropwa.identification.greybox.profile.carry`): the weak directions
    carried into the intervals of the parameters they trade against; a note names them."""
    keep = {n: e for n, e in est.estimates.items() if n not in undetermined}
    got, widened = carry(keep, profiles, est.z**2)
    est.estimates.update(got)
    if widened:
        est.widened += [n for n in widened if n not in est.widened]
        notes.append(
            "Intervals widened along the profiles of "
            + ", ".join(profiles)
            + f" (values the data do not reject): {', '.join(widened)}."
        )


#: the friction parameters the friction curve's check covers (:mod:`.curve`)
BY_CURVE = frozenset(PARAMETER_GROUPS["friction"])


def _curve(opts: FitOptions, data: FitData, names: tuple[str, ...]) -> Any:
    """The friction curve of the fit's friction runs (:func:`.curve.friction_curve`), or None."""
    if not opts.curve_check:
        return None
    return friction_curve([r for r, _ in data.pairs], data.base_model.params, names)


def _curve_intervals(est: _Estimate, curve: Any, ident: Any, notes: list[str]) -> None:
    """The friction intervals widened to the friction curve's (:func:`.curve.widen_by_curve`);
    what it does not identify joins the undetermined and the weak, with a note."""
    if curve is None:
        return
    est.estimates, check = widen_by_curve(est.estimates, curve)
    flagged = check.unidentified + check.disagree + check.weak
    ident.undetermined += [n for n in check.unidentified if n not in ident.undetermined]
    ident.weak += [n for n in flagged if n not in ident.weak]
    est.widened += [n for n in check.widened if n not in est.widened]
    notes.extend(check.notes())


def _weak(est: _Estimate, undetermined: list[str]) -> list[str]:
    """Parameters at a bound, unconverged, undetermined or known to worse than ×/÷ 1.5."""
    return [
        n
        for i, n in enumerate(est.problem.names)
        if n in est.at_bound
        or n in est.unconverged
        or n in undetermined
        or est.z * est.sd[i] > math.log(1.5)
    ]


def _undetermined(est: _Estimate) -> list[str]:
    """Parameters the data do not determine: a Jacobian column of nothing (JᵀJ's diagonal
    below 1e-10 of the largest) or no variance at all. Their estimate keeps its value with an
    infinite standard error and its bounds as the interval, never a zero-width interval."""
    d = np.diag(est.cv.H)
    out = []
    for i, n in enumerate(est.problem.names):
        if not (d[i] > 1e-10 * d.max()) or not (est.sd[i] > 0):
            e = est.estimates[n]
            est.estimates[n] = dataclasses.replace(
                e, std=math.inf, ci=(float(est.problem.lower[i]), float(est.problem.upper[i]))
            )
            out.append(n)
    return out


def _bounded(est: _Estimate, undetermined: list[str]) -> list[str]:
    """Parameters whose optimum lies at a bound (a leakage of nothing at its lower one): the
    data only say that they lie beyond the rest of their interval, so it reaches the bound
    on that side and the standard error is infinite (issue 36: never a number with a tiny
    interval). Returns them."""
    tlo = est.problem.theta_bounds[0]
    out = []
    for i, n in enumerate(est.problem.names):
        if n not in est.at_bound or n in undetermined:
            continue
        e = est.estimates[n]
        if est.theta[i] - tlo[i] < 1e-3:
            ci = (float(est.problem.lower[i]), max(e.ci[1], e.value))
        else:
            ci = (min(e.ci[0], e.value), float(est.problem.upper[i]))
        est.estimates[n] = dataclasses.replace(e, std=math.inf, ci=ci)
        out.append(n)
    return out


def _warn_unconverged(est: _Estimate) -> None:
    if not est.unconverged:
        return
    names = est.problem.names
    warnings.warn(
        "the fit stopped before its optimum along "
        + ", ".join(
            f"{n} (a further {est.remaining_sd[names.index(n)]:.3g} std)" for n in est.unconverged
        )
        + "; their intervals are not trustworthy: refit from the result, with more starts, "
        "or free fewer parameters",
        IdentificationWarning,
        stacklevel=3,
    )


def _profiles(
    opts: FitOptions,
    data: FitData,
    weak: list[str],
    est: _Estimate,
    plan: StagePlan,
    best: StartResult,
    got: Any,
    client: Any = None,
) -> dict[str, Profile]:
    """Profiles of the parameters ``opts.profile`` names (``weak``: those flagged weak); the
    χ² threshold is scaled by κ from before the scan widened the covariance. ``client``: a
    Dask client that computes them as one task per parameter."""
    names = est.problem.names
    if opts.profile == "weak":
        to_profile = weak
    elif opts.profile == "all":
        to_profile = list(names)
    elif opts.profile in ("none", None):
        to_profile = []
    else:
        to_profile = [n for n in expand_free(opts.profile, data.base_model.params) if n in names]
    if to_profile:
        plan.report("profiles", 0, 0)
    kap = kappa(est.cov_before_scan, est.cv.Hinv)
    tlo, thi = est.problem.theta_bounds
    calls: dict[str, ProfileTask] = {}
    for n in to_profile:
        i = names.index(n)
        sd = float(est.sd[i])
        if isinstance(got, Sliding) and i in got.index:
            # a parameter of the sliding stage: its profile on the sliding stretches
            k = got.index.index(i)
            calls[n] = ProfileTask(
                prob=got.prob, theta=got.theta, index=k, tlo=got.tlo, thi=got.thi,
                loss=opts.loss, f_scale=opts.f_scale, cost0=got.cost,
                kappa=float(got.kappa[k]), z=est.z, sd=sd,
            )  # fmt: skip
        else:
            calls[n] = ProfileTask(
                prob=plan.full, theta=est.theta, index=i, tlo=tlo, thi=thi, loss=opts.loss,
                f_scale=opts.f_scale, cost0=best.sol.cost, kappa=float(kap[i]), z=est.z, sd=sd,
            )  # fmt: skip
    if client is not None and len(calls) > 1:
        # one task per parameter (each refits the others along its grid)
        futures = {n: client.submit(_profile, task, pure=False) for n, task in calls.items()}
        return {n: fut.result() for n, fut in futures.items()}
    return {n: _profile(task) for n, task in calls.items()}
