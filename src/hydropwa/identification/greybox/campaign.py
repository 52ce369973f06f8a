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
import time
import warnings
from collections.abc import Callable, Iterable
from typing import Any

from ..._errors import IdentificationError
from ...params import SystemParams
from .._common import IdentificationWarning
from .estimator import FitOptions, fit_model
from .problem import get_value
from .result import GreyBoxFit
from .selection import Selection
from .stages import FitProgress

__all__ = ["CAMPAIGN_CHANNELS", "CampaignFit", "campaign_options", "fit_campaign"]

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
    model: str = "full",
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
