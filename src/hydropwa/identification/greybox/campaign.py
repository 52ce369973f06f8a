"""The joint fit of a whole campaign: every experiment at once, started from ``identify all``.

:func:`fit_campaign` reads a campaign folder (one dataset per experiment, as ``hydropwa rig``
writes it: ``frf/``, ``deadzone/``, ``friction/``, ``sine/`` …), takes the per-experiment
estimates of :func:`~hydropwa.identification.identify` (Sec. VI of the paper: the valve's FRF,
the dead-zone hinge, the Stribeck points) as the start, and refits the free parameters
(default ``"all"``: valve ω0 and ζ, dead zone, flow coefficient, bulk modulus, leakage and
friction) by output error on all experiments together (:func:`~.estimator.fit_model`).

Each run contributes the channels it logs of x, p_a, p_b and the spool position: the FRF
runs' spool carries the valve's ω0 and ζ, the dead-zone runs' slow motion the band, the
friction runs' steady means the Stribeck curve and K, the pressure transients E and the
leakage. The campaign is selected by experiment (:class:`~.selection.Selection` with
``by_experiment``): the segment budget is shared equally between the experiments, so that
the many constant-input runs do not crowd out the FRF runs.
"""

from __future__ import annotations

import dataclasses
import math
import time
import warnings
from collections.abc import Callable, Iterable
from typing import Any

from scipy import stats

from ..._errors import IdentificationError
from ..._layout import DEFAULT_KIND
from ...params import SystemParams
from .._common import IdentificationWarning, experiment_of
from .estimator import FitOptions, fit_model
from .problem import get_value
from .result import GreyBoxFit
from .selection import Selection
from .stages import FitProgress

__all__ = [
    "CAMPAIGN_CHANNELS",
    "CampaignFit",
    "STRIBECK_POINTS",
    "campaign_options",
    "check_friction",
    "fit_campaign",
]

#: the channels the joint fit compares, where a run logs them
CAMPAIGN_CHANNELS: tuple[str, ...] = ("x", "p_a", "p_b", "spool")


@dataclasses.dataclass
class CampaignFit:
    """The joint fit and where it started.

    Attributes
    ----------
    fit : GreyBoxFit
        The joint grey-box fit (its ``params_`` is the machine's fitted parameter set).
    start : SystemParams
        The parameters it started from (``identify all``'s, or those given).
    identified : IdentificationReport or None
        The per-experiment identification run first (None when a start was given).
    start_time : float
        Wall time [s] of that identification.
    """

    fit: GreyBoxFit
    start: SystemParams
    identified: Any = None
    start_time: float = 0.0

    def table(self, truth: SystemParams | None = None) -> list[dict[str, Any]]:
        """Per free parameter: the start (``identify all``), the joint estimate and its
        interval, and with ``truth`` the true value and both relative errors."""
        rows = []
        for n, e in self.fit.estimates_.items():
            row: dict[str, Any] = {
                "parameter": n,
                "start": get_value(self.start, n),
                "joint": e.value,
                "ci_low": e.ci[0],
                "ci_high": e.ci[1],
            }
            if truth is not None:
                t = get_value(truth, n)
                row["truth"] = t
                row["start_error"] = (row["start"] - t) / t if t else float("nan")
                row["joint_error"] = (e.value - t) / t if t else float("nan")
                row["covered"] = bool(e.ci[0] <= t <= e.ci[1])
            rows.append(row)
        return rows


def campaign_options(options: FitOptions | None = None, **settings: Any) -> FitOptions:
    """The joint fit's settings: ``options``/``settings`` as given, with the campaign's
    defaults where they say nothing: the channels of :data:`CAMPAIGN_CHANNELS`, a selection
    by experiment (always, not only above the threshold), no sliding stage (the friction
    experiment's steady means pin the sliding friction), and no profiles unless asked for
    (``profile="weak"``: each costs some 900 simulations; the interval scan still widens
    every interval where the cost along the parameter's valley rises slower than quadratic)."""
    opts = FitOptions.merged(options, settings)
    changes: dict[str, Any] = {}
    if options is None and "profile" not in settings:
        # a profile refits the other twelve parameters at every point: about 900
        # simulations of the selection each (15 min per parameter on two cores); the
        # interval scan along each parameter's valley widens the quadratic intervals instead
        changes["profile"] = "none"
    if options is None and "sliding" not in settings:
        # the sliding stage refits all but the breakaway parameters on stretches faster than
        # twice the Stribeck velocity, where the dead zone's creep does nothing (its interval
        # came out of zero width) and F_c rests on a few reversals (paper rig: −53 %); the
        # friction runs' steady means pin the sliding friction instead
        changes["sliding"] = False
    if opts.channels is None:
        changes["channels"] = CAMPAIGN_CHANNELS
    if opts.selection is None:
        changes["selection"] = Selection(method="events", by_experiment=True)
    elif not opts.selection.by_experiment:
        changes["selection"] = dataclasses.replace(opts.selection, by_experiment=True)
    return dataclasses.replace(opts, **changes)


def auto_start(params: SystemParams) -> SystemParams | str:
    """``start="auto"``: ``params`` themselves if ``identify all`` wrote them (their
    ``meta["identification"]``: they are its estimates already), else ``"identify"``."""
    return params if "identification" in (params.meta or {}) else "identify"


def _start(data: Any, machine: SystemParams, start: Any) -> tuple[SystemParams, Any, float]:
    """The fit's start: ``identify all`` on ``data`` (``start="identify"``), ``machine``
    (``"params"``) or the given parameter set (checked against the machine's geometry)."""
    from .._pipeline import identify  # deferred: the pipeline imports the estimators

    if isinstance(start, SystemParams):
        for n in ("cylinder.area_a", "cylinder.area_b", "cylinder.stroke"):
            a, b = get_value(start, n), get_value(machine, n)
            if abs(a - b) > 1e-6 * abs(b):
                raise IdentificationError(
                    f"the start's {n} = {a:g} is not the data's machine's {b:g}; give the "
                    "parameters `identify all` wrote for these data"
                )
        return start, None, 0.0
    if start == "params":
        return machine, None, 0.0
    if start != "identify":
        raise IdentificationError(
            f"start = {start!r}; choose 'identify' (run identify all first), 'params', 'auto' "
            "or give a parameter set"
        )
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentificationWarning)
        report = identify(data, params=machine)
    return report.params, report, time.perf_counter() - t0


def fit_campaign(
    data: Any,
    free: Iterable[str] | str = "all",
    *,
    params: SystemParams | None = None,
    start: SystemParams | str = "identify",
    model: str = DEFAULT_KIND.name,
    options: FitOptions | None = None,
    progress: Callable[[FitProgress], None] | None = None,
    **settings: Any,
) -> CampaignFit:
    """Fit the machine jointly to a whole campaign, started from the per-experiment estimates.

    Parameters
    ----------
    data : path-like or list of Run
        A campaign folder (one dataset per experiment), a dataset folder or runs, read and
        screened by :func:`~hydropwa.identification.load_runs`.
    free : str or iterable of str
        Free parameters or groups (:func:`~.problem.expand_free`); ``"all"``: valve,
        dead zone, flow coefficient, bulk modulus, leakage and friction.
    params : SystemParams, optional
        The machine (geometry, mass, everything not fitted); default the one the data record
        (:func:`~hydropwa.identification.machine_for`).
    start : "identify", "params", "auto" or SystemParams
        ``"identify"`` (default): run ``identify all`` on the data first (valve FRF, dead
        zone, Stribeck points, Sec. VI) and start from its parameter set; a parameter set
        (e.g. the file ``hydropwa identify all`` wrote): start from it; ``"params"``: start
        from ``params``; ``"auto"``: from ``params`` if ``identify all`` wrote them (their
        ``meta["identification"]``), else as ``"identify"``. Parameters that ``identify all`` does not estimate (K, E, C_L)
        start from ``params``' values.
    model : "full" or "reduced"
    options, **settings
        :class:`~.estimator.FitOptions` of :func:`~.estimator.fit_model`; the campaign's
        defaults fill what they leave open (:func:`campaign_options`).
    progress : callable, optional
        Receives :class:`~.stages.FitProgress` events (``identify`` first when it runs).

    Returns
    -------
    CampaignFit
        The fit (``.fit``: a :class:`~.result.GreyBoxFit`), its start and the identification.

    Raises
    ------
    IdentificationError
        For a start of another machine, unknown parameters or no usable run.
    """
    from .._machine import machine_for  # deferred: reads the data's records
    from .._pipeline import load_runs  # deferred: the pipeline imports the estimators

    opts = campaign_options(options, **settings)
    machine = machine_for(data, params)
    if start == "auto":
        start = auto_start(machine)
    t0 = time.perf_counter()
    if progress is not None and start == "identify":
        progress(FitProgress("identify", 0, 0, "begin", elapsed=0.0))
    first, report, t_start = _start(data, machine, start)
    if progress is not None and start == "identify":
        progress(FitProgress("identify", 0, 0, "end", elapsed=time.perf_counter() - t0))
    runs = load_runs(data, params=machine)
    fit = fit_model(model, runs, free, params=first, options=opts, progress=progress)
    if progress is not None:
        progress(FitProgress("friction check", 0, 0, "begin", elapsed=time.perf_counter() - t0))
    fit, ratio = check_friction(fit, model, runs, opts, first)
    if progress is not None:
        done = time.perf_counter() - t0
        progress(FitProgress("friction check", 0, 0, "end", cost=ratio or math.nan, elapsed=done))
    how = (
        f"identify all on the same data ({t_start:.3g} s)"
        if report is not None
        else ("the given parameters" if start == "params" else "the given start")
    )
    fit.data_.insert(
        0,
        f"Joint fit of {len(runs)} runs of the campaign, started from {how}; each run "
        f"contributes the channels it logs of {', '.join(opts.channels or ())}.",
    )
    return CampaignFit(fit, first, report, t_start)


#: the level of the friction experiment's consistency test (:func:`check_friction`)
FRICTION_TEST_LEVEL = 1e-3


def check_friction(
    fit: GreyBoxFit, model: Any, runs: list, opts: FitOptions, start: SystemParams
) -> tuple[GreyBoxFit, float | None]:
    """Test the joint friction against the friction experiment alone, and defer to the
    per-experiment estimate when they disagree; returns the fit (a new one where it deferred)
    and the test statistic (None: no test).

    The friction experiment (Sec. VI-C, constant counter force) is the one designed for the
    Stribeck curve: its steady means hold F_c + σ·v at each speed. The other experiments see
    friction as a small part of their forces (paper rig: F_c is 0.2 % of P_S·A_A) beside
    their own model and data errors (creep in the dead band, sticks at reversals, inputs
    filtered at 50 Hz), and their thousands of samples can outvote those means. Measured on
    the paper rig's joint campaign (``joint_campaign.toml``, seed 36): the cost at the true
    parameters was 7.4e4 against 6.1e4 at the joint estimate (the dead-zone runs 2.5e4
    against 1.1e4: a biased optimum, not a stalled optimiser), with F_s +19 %, the Stribeck
    velocity, shape and smoothness −20 … −30 %, and the friction runs' steady means missed
    by χ² = 850 on 10 runs. Reweighting the residuals (per experiment by their misfit, per
    stream by their autocorrelation time, by the spread the initial states' errors cause, a
    Cauchy loss) left F_c anywhere in −39 … +12 % over three seeds.

    Test: the friction parameters are refitted on the friction runs alone (their steady
    means with the load feedback, as ``--free friction`` fits them), started from the joint
    estimate; the likelihood ratio 2·(cost at the joint estimate − refitted cost), over the
    refit's residual variance s² (at least 1: the means are scaled by their standard
    errors), is χ² with as many degrees of freedom as friction parameters when both agree.
    Below its 1 − 0.1 % quantile the joint estimate stays.

    Above it the friction parameters are not determined by the joint data: with a start
    from ``identify all`` (its ``[uncertainty]`` of the friction), the Stribeck points
    (F_c, F_s, σ) are its estimates, each interval spanning its and the joint fit's; the
    curve's shape parameters and, without that start, every friction parameter are
    reported as not determined (the start's value, the interval their bounds).
    """
    names = [n for n in fit.free if n.startswith("friction.")]
    held = set(fit.validation_.runs) if fit.validation_ is not None else set()
    own_runs = [r for r in runs if experiment_of(r) == "friction" and r.name not in held]
    if not names or not own_runs or len(own_runs) == len(runs):
        return fit, None
    try:
        own = _friction_fit(model, own_runs, names, fit.params_, opts)
    except IdentificationError as exc:
        fit.data_.append(f"The joint friction was not checked against the friction runs: {exc}")
        return fit, None
    m = sum(len(rf.sigma) for rf in own.runs_)
    s2 = max(1.0, 2.0 * own.cost / max(m - len(names), 1))
    ratio = 2.0 * (own.initial_cost - own.cost) / s2
    limit = float(stats.chi2.ppf(1.0 - FRICTION_TEST_LEVEL, len(names)))
    test = (
        f"likelihood ratio {ratio:.3g} (s² = {s2:.3g}), χ² with {len(names)} degrees of "
        f"freedom: {limit:.3g} at 0.1 %"
    )
    if not ratio > limit:
        fit.data_.append(f"The friction runs alone agree with the joint friction ({test}).")
        return fit, ratio
    found = (start.meta or {}).get("uncertainty", {}).get("friction", {})
    points = [n for n in names if n in STRIBECK_POINTS and n.split(".")[1] in found]
    fit = _defer_friction(fit, names, points, found, start, opts)
    fit.data_.append(
        f"The friction runs alone disagree with the joint friction ({test}): the other "
        "experiments' model and data errors outweigh friction's small share of their forces."
        + (
            f" {', '.join(points)} are identify all's (the Stribeck fit, Sec. VI-C), each "
            "interval spanning its and the joint fit's;"
            if points
            else ""
        )
        + f" {', '.join(n for n in names if n not in points)} are not determined."
    )
    return fit, ratio


#: the friction parameters the friction experiment's steady means determine (Sec. VI-C)
STRIBECK_POINTS = ("friction.coulomb", "friction.static", "friction.viscous")


def _friction_fit(
    model: Any, runs: list, names: list[str], params: SystemParams, opts: FitOptions
) -> GreyBoxFit:
    """``names`` refitted on the friction runs alone from ``params`` (their steady means)."""
    fopts = dataclasses.replace(
        opts,
        # a selection (always): the steady means, alone where the load feedback applies
        selection=Selection(method="events"),
        validate=0.0,
        profile="none",
        sliding=False,
        starts=1,
        initial=None,
        bounds={n: b for n, b in (opts.bounds or {}).items() if n in names} or None,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentificationWarning)
        return fit_model(model, runs, names, params=params, options=fopts)


def _defer_friction(
    fit: GreyBoxFit,
    names: list[str],
    points: list[str],
    found: dict[str, Any],
    start: SystemParams,
    opts: FitOptions,
) -> GreyBoxFit:
    """The fit with ``points`` at identify all's estimates (``found``: its friction
    uncertainty), their intervals spanning both, and the other ``names`` at the start, not
    determined (bounds)."""
    z = float(stats.norm.ppf(0.5 + 0.5 * fit.level))
    meta = dict(fit.params_.meta)
    unc = dict(meta.get("uncertainty", {}))
    values = {}
    for n in names:
        e, v = fit.estimates_[n], get_value(start, n)
        if n in points:
            mine = found[n.split(".")[1]]
            lo = min(e.ci[0], max(float(mine["ci_low"]), 0.0))
            hi = max(e.ci[1], float(mine["ci_high"]))
            std = max(float(mine["std"]), (hi - lo) / (2.0 * z))
            how = "identify all (the joint data disagree)"
        else:
            lo, hi = (opts.bounds or {}).get(n, (v / 10.0, v * 10.0))
            std = math.inf
            how = "not determined (the joint data disagree)"
            if n not in fit.identifiability_.undetermined:
                fit.identifiability_.undetermined.append(n)
        fit.estimates_[n] = dataclasses.replace(e, value=v, std=std, ci=(float(lo), float(hi)))
        unc[n.replace(".", "_")] = {**fit.estimates_[n].to_dict(), "method": how}
        values[n] = v
    meta["uncertainty"] = unc
    return dataclasses.replace(
        fit, params_=dataclasses.replace(fit.params_.replace(**values), meta=meta)
    )
