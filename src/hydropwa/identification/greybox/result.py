"""Results of the grey-box fit: per-run fits, profiles, identifiability, the stages' and the
starts' outcomes (:class:`FitStatus`, :class:`StageResult`, :class:`StartRecord`) and
:class:`GreyBoxFit`."""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from ..._errors import IdentificationError
from ..._result import DerivedResult, StatusEnum, estimate_rows, status_messages
from ...params import SystemParams, save_params
from .._common import (
    TRUTH_OUTSIDE,
    OptimizerStatus,
    ParameterEstimate,
    SkippedRun,
    truth_in_interval,
)

__all__ = [
    "FitStatus",
    "GreyBoxFit",
    "Identifiability",
    "Profile",
    "RunFit",
    "SlidingSummary",
    "StageResult",
    "StartRecord",
]

#: The stage that fits every free parameter at once (a stage's name, not a model kind's).
FULL_STAGE = "full"


class FitStatus(StatusEnum):
    """How a least-squares stage ended (scipy's ``least_squares`` status codes).

    Each member's :attr:`message` says what happened and, where it did not converge, what to
    change; :attr:`success` is scipy's (any tolerance met).
    """

    IMPROPER_INPUT = -1
    MAX_EVALUATIONS = 0
    GTOL = 1
    FTOL = 2
    XTOL = 3
    FTOL_XTOL = 4

    @property
    def success(self) -> bool:
        """True when a tolerance was met (status > 0)."""
        return self > 0

    @classmethod
    def from_scipy(cls, res: Any) -> FitStatus:
        """The status of a ``least_squares`` result."""
        return cls(int(res.status))


status_messages(
    FitStatus,
    {
        FitStatus.IMPROPER_INPUT: "improper input parameters status returned from MINPACK",
        FitStatus.MAX_EVALUATIONS: (
            "the maximum number of function evaluations was exceeded; raise max_nfev"
        ),
        FitStatus.GTOL: "gtol termination condition is satisfied",
        FitStatus.FTOL: "ftol termination condition is satisfied",
        FitStatus.XTOL: "xtol termination condition is satisfied",
        FitStatus.FTOL_XTOL: "both ftol and xtol termination conditions are satisfied",
    },
)


@dataclasses.dataclass(frozen=True)
class StageResult:
    """One least-squares stage of the best start (``locate``, ``coarse``, ``full``,
    ``sliding``).

    Attributes
    ----------
    name : str
    status : FitStatus
    cost : float
        ½Σρ(r²) at the stage's end, on the stage's own data [1].
    nfev, njev : int
        Residual and Jacobian evaluations of the stage (a Jacobian is 2p simulations of the
        stage's data with central differences).
    """

    name: str
    status: FitStatus
    cost: float
    nfev: int
    njev: int

    @property
    def success(self) -> bool:
        """Whether the stage met a tolerance."""
        return self.status.success

    @property
    def message(self) -> str:
        """The status's message."""
        return self.status.message

    @classmethod
    def from_scipy(cls, name: str, res: Any) -> StageResult:
        """The outcome of a ``least_squares`` result."""
        return cls(
            name, FitStatus.from_scipy(res), float(res.cost), int(res.nfev), int(res.njev or 0)
        )


@dataclasses.dataclass(frozen=True, kw_only=True)
class StartRecord:
    """One start of the fit: where it began, where its full stage ended, and how.

    Attributes
    ----------
    start, value : dict[str, float]
        The free parameters [SI] at the start and at the end of its full stage.
    cost : float
        ½Σρ(r²) at the end of its full stage [1].
    status : FitStatus
        How its full stage's least squares ended (after its restarts).
    nfev, njev : int
        Residual and Jacobian evaluations of its full stage, restarts included.
    locate_evaluations, coarse_evaluations : int
        Evaluations of its locating stage (with the valley scan's) and its coarse stage
        (residuals plus Jacobians; 0: the stage did not run).
    restarts : int
        Restarts of the full stage from a lower point of its last central differences.
    """

    start: dict[str, float]
    value: dict[str, float]
    cost: float
    status: FitStatus
    nfev: int
    njev: int
    locate_evaluations: int = 0
    coarse_evaluations: int = 0
    restarts: int = 0

    @property
    def success(self) -> bool:
        """Whether its full stage met a tolerance."""
        return self.status.success

    @property
    def message(self) -> str:
        """The status's message."""
        return self.status.message


# ----------------------------------------------------------------------------- results
@dataclasses.dataclass
class RunFit:
    """How one run entered the fit and how well the fitted model reproduces it.

    Attributes
    ----------
    name : str
    method : str
        ``single`` or ``multiple`` shooting.
    reason : str
        Why that method (the oscillation ratio, or forced).
    segments : list of (float, float)
        Simulated stretches (windows) [s].
    excluded : list of (float, float, str)
        Stretches left out [s] and why (end stop, converter limit).
    sigma : dict[str, float]
        Noise level per channel, estimated from the data [SI].
    rms : dict[str, float]
        RMS output error per channel at the optimum [SI].
    n_eff : dict[str, float]
        Effective number of independent residuals per channel (from their autocorrelation).
    t, measured, simulated : ndarray / dict
        Time [s] and channels [SI] of the simulated samples (NaN between segments).
    """

    name: str
    method: str
    reason: str
    segments: list[tuple[float, float]]
    excluded: list[tuple[float, float, str]]
    sigma: dict[str, float]
    rms: dict[str, float] = dataclasses.field(default_factory=dict)
    n_eff: dict[str, float] = dataclasses.field(default_factory=dict)
    t: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0), repr=False)
    measured: dict[str, np.ndarray] = dataclasses.field(default_factory=dict, repr=False)
    simulated: dict[str, np.ndarray] = dataclasses.field(default_factory=dict, repr=False)


@dataclasses.dataclass
class Profile:
    """Profile of the cost along one parameter (the others refitted at each point).

    Attributes
    ----------
    name : str
    values : ndarray
        Parameter values [SI].
    cost : ndarray
        Cost at each value minus the optimum, in units of the variance-corrected
        χ² (2Δcost/κ, see :class:`GreyBoxFit`); 3.84 is the 95 % threshold.
    ci : tuple of float
        Profile interval (low, high) [SI]: where the curve stays below 3.84 (a bound
        of the grid when it never rises that far: the data do not limit it there).
    refitted : dict[str, ndarray]
        The other free parameters [SI] refitted at each of ``values``: where the profile
        stays below the threshold they are values the data do not reject either, so their
        intervals must reach them (:func:`~hydropwa.identification.greybox.profile.carry`).
    """

    name: str
    values: np.ndarray
    cost: np.ndarray
    ci: tuple[float, float]
    refitted: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)


@dataclasses.dataclass
class Identifiability:
    """Which parameters, or combinations, the data determine.

    Attributes
    ----------
    condition : float
        Condition number of the scaled Gauss–Newton matrix JᵀJ (log parameters).
    directions : list of (float, dict)
        Eigen-directions of JᵀJ from the weakest: relative standard deviation along
        the direction [1] and the participating parameters with their weights.
    correlated : list of (str, str, float)
        Parameter pairs with |correlation| > 0.9.
    weak : list of str
        Parameters with a relative interval half-width above 50 %, at a bound, or not
        converged.
    advice : list of str
        Experiments that would separate the correlated pairs.
    unconverged : list of str
        Parameters that the Gauss–Newton step left at the end (−H⁻¹Jᵀr from the central
        Jacobian at the result) would still move by more than one standard error: the
        optimiser stopped short (its step tolerance, in a narrow valley) and their
        intervals describe the local curvature, not the distance to the optimum.
    undetermined : list of str
        Parameters the data do not determine (the cost does not change with them, or their
        optimum lies at a bound): reported with an infinite standard error and an interval
        that reaches their bounds (at a bound: that one).
    """

    condition: float
    directions: list[tuple[float, dict[str, float]]]
    correlated: list[tuple[str, str, float]]
    weak: list[str]
    advice: list[str]
    unconverged: list[str] = dataclasses.field(default_factory=list)
    undetermined: list[str] = dataclasses.field(default_factory=list)


@dataclasses.dataclass(frozen=True, kw_only=True)
class SlidingSummary:
    """What the sliding stage did (``GreyBoxFit.sliding_``; ``sliding`` of :func:`fit_model`).

    Attributes
    ----------
    parameters : tuple of str
        Refitted on the sliding stretches (empty: the stage did not run).
    held : tuple of str
        Breakaway parameters held at the full fit's values.
    v_min : float
        Speed above which a stretch slides [m/s] (NaN: not run).
    stretches : int
        Sliding stretches fitted.
    runs : tuple of str
        The runs they come from.
    cost, nfev, njev, status
        The stage's own least-squares outcome (scipy's status code).
    remaining_std : float
        The largest Gauss–Newton step still left, in standard deviations (above 1 the
        parameter is listed as unconverged).
    skipped : str
        Why the stage did not apply ("" where it ran or was not asked for: F_c fixed or
        ``sliding=False``).
    """

    parameters: tuple[str, ...] = ()
    held: tuple[str, ...] = ()
    v_min: float = float("nan")
    stretches: int = 0
    runs: tuple[str, ...] = ()
    cost: float = float("nan")
    nfev: int = 0
    njev: int = 0
    status: int = 0
    remaining_std: float = float("nan")
    skipped: str = ""

    @property
    def applied(self) -> bool:
        """Whether the stage ran (it refitted parameters)."""
        return bool(self.parameters)

    @classmethod
    def from_info(cls, info: dict[str, Any] | None) -> SlidingSummary:
        """From the stage's plain record (:func:`~.sliding.sliding_stage`'s ``info``, or its
        ``{"skipped": reason}``; None or empty: not asked for)."""
        info = dict(info or {})
        for key in ("parameters", "held", "runs"):
            if key in info:
                info[key] = tuple(info[key])
        unknown = set(info) - {f.name for f in dataclasses.fields(cls)}
        if unknown:
            raise ValueError(f"unknown sliding-stage fields: {', '.join(sorted(unknown))}")
        return cls(**info)

    def to_dict(self) -> dict[str, Any]:
        """Plain values for metadata (``params_.meta["greybox"]["sliding"]``): the fields that
        apply (the run list left out); empty when the stage was not asked for."""
        if self.applied:
            out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
            del out["runs"], out["skipped"]
            return {k: list(v) if isinstance(v, tuple) else v for k, v in out.items()}
        return {"skipped": self.skipped} if self.skipped else {}


@dataclasses.dataclass(frozen=True, kw_only=True)
class GreyBoxFit(DerivedResult):
    """Result of :func:`fit_model` (keyword-only; its outcome is derived from ``stages_``).

    Attributes
    ----------
    params_ : SystemParams
        The base parameters with the fitted values (and ``meta['uncertainty']``); the
        models take it directly, :meth:`save` writes it as a parameter file.
    free : tuple of str
        Fitted parameter names.
    estimates_ : dict[str, ParameterEstimate]
        Value, standard error and interval (at ``level``) per free parameter [SI]. The
        interval is symmetric in log space (the fit's coordinates) unless the interval scan
        widened one side (``interval_scan_``).
    covariance_ : ndarray, shape (p, p)
        Covariance of the log parameters: the autocorrelation-corrected sandwich plus the
        propagated initial-state and input errors (``nuisance_draws``), scaled to the
        intervals the scan widened (correlations unchanged).
    correlation_ : ndarray, shape (p, p)
    inflation_ : ndarray, shape (p,)
        Variance of each log parameter over the naive s²(JᵀJ)⁻¹ value: how much the
        residuals' correlation and the initial-state and input errors widen the interval.
    success : bool
        Whether every stage that decides an estimate met a tolerance: the full fit and, where
        it ran, the sliding stage (``status.success``; a property from ``stages_``).
    status : FitStatus
        The first deciding stage (full, sliding) that did not converge, else the full stage's
        status (an ``IntEnum``: scipy's status code; a property from ``stages_``).
    message : str
        The stages that did not converge, then the status's message (a property).
    nfev, njev : int
        Residual and Jacobian evaluations of the best start's full stage (properties).
    cost, initial_cost : float
        ½Σρ(r²) at the full fit's optimum and at the start (r noise-scaled, ρ the loss;
        the sliding stage's own cost is in ``sliding_``).
    runs_ : list of RunFit
    profiles_ : dict[str, Profile]
    identifiability_ : Identifiability
    starts_ : list of StartRecord
        Every start, one record each: its values, final cost, status, evaluations, those of
        the locating (multiple-shooting) and coarse stages, and the full stage's
        ``restarts`` from a lower difference point.
    optimizer_ : OptimizerStatus
        The fit's outcome as the other fits report it (a property: ``success``, ``message``
        and ``nfev`` of the fit; ``nit`` None: ``least_squares`` counts no iterations, its
        Jacobian evaluations are ``njev``).
    model : str
        ``full`` or ``reduced``.
    wall_time : float
        Seconds for the whole fit.
    interval_scan_ : dict[str, tuple[float, float]]
        Per parameter, the profile statistic 2Δcost/κ at −2z·σ and +2z·σ along its valley
        (the Wald quadratic gives 4z² ≈ 15.4; below z² ≈ 3.84 that side was widened beyond
        the scan). NaN: that point is outside the bounds. Parameters whose interval is
        narrower than ±0.2 % (in ln p, below the integrator's jitter) are not scanned and
        absent; empty when ``scan_intervals`` is off.
    widened_ : list of str
        Parameters whose interval the scan widened: the cost along their own valley rose
        slower than the quadratic, or a point scanned along another's valley lay within
        their threshold further out.
    sliding_ : SlidingSummary
        The sliding stage (``sliding`` of :func:`fit_model`): the parameters refitted on the
        sliding stretches, the breakaway parameters held, its own optimiser outcome; or why
        it was skipped (:class:`SlidingSummary`; its defaults when not asked for).
    stages_ : list of StageResult
        The best start's stages in order (locating, coarse, full, sliding), each with its
        own status: ``status`` and ``success`` follow from the full and the sliding stage.
    data_ : list of str
        Which data the fit used and why (the segment selection of a campaign, the shooting
        per experiment), one sentence each; the summary lists them.
    validation_ : Validation or None
        The fitted model on the runs held out of the fit (``validate``): the normalised fit
        per run and channel [%] (None: no run held out).
    """

    params_: SystemParams
    free: tuple[str, ...]
    estimates_: dict[str, ParameterEstimate]
    covariance_: np.ndarray
    correlation_: np.ndarray
    inflation_: np.ndarray
    cost: float
    initial_cost: float
    runs_: list[RunFit]
    profiles_: dict[str, Profile]
    identifiability_: Identifiability
    starts_: list[StartRecord]
    stages_: list[StageResult]
    model: str
    skipped_: list[SkippedRun] = dataclasses.field(default_factory=list)
    wall_time: float = 0.0
    level: float = 0.95
    interval_scan_: dict[str, tuple[float, float]] = dataclasses.field(default_factory=dict)
    widened_: list[str] = dataclasses.field(default_factory=list)
    sliding_: SlidingSummary = dataclasses.field(default_factory=SlidingSummary)
    data_: list[str] = dataclasses.field(default_factory=list)
    validation_: Any = None

    #: Stages whose outcome decides an estimate (the others only lead to the full stage).
    DECIDING: ClassVar[tuple[str, ...]] = (FULL_STAGE, "sliding")

    def __post_init__(self) -> None:
        if [st.name for st in self.stages_].count(FULL_STAGE) != 1:
            raise IdentificationError(
                f"GreyBoxFit needs exactly one {FULL_STAGE!r} stage in stages_ (its outcome decides the "
                f"fit's status); got stages {[st.name for st in self.stages_]}"
            )
        if not self.starts_:
            raise IdentificationError("GreyBoxFit needs the record of at least one start")

    @property
    def _full(self) -> StageResult:
        return next(st for st in self.stages_ if st.name == FULL_STAGE)

    def _failed_stages(self) -> list[StageResult]:
        return [st for st in self.stages_ if st.name in self.DECIDING and not st.success]

    @property
    def status(self) -> FitStatus:
        """The first deciding stage that did not converge, else the full stage's status."""
        return (self._failed_stages() or [self._full])[0].status

    def _status_details(self) -> list[str]:
        return [f"the {st.name} stage did not converge" for st in self._failed_stages()]

    @property
    def nfev(self) -> int:
        """Residual evaluations of the best start's full stage (restarts included)."""
        return self._full.nfev

    @property
    def njev(self) -> int:
        """Jacobian evaluations of the best start's full stage."""
        return self._full.njev

    @property
    def optimizer_(self) -> OptimizerStatus:
        """The fit's outcome in the other fits' shape (``nit`` None: see ``njev``)."""
        return OptimizerStatus(success=self.success, message=self.message, nfev=self.nfev)

    def __repr__(self) -> str:
        vals = ", ".join(f"{n}={e.value:.4g}" for n, e in self.estimates_.items())
        return f"GreyBoxFit({self.model}, {vals}, cost={self.cost:.4g}, success={self.success})"

    def _summary_rows(self) -> list[tuple[str, Any, str]]:  # result protocol
        return estimate_rows(self.estimates_)

    def plot(self, run: str | None = None, *, ax: Any = None) -> Any:
        """Measured and fitted channels of one run (:func:`hydropwa.plotting.plot_greybox_fit`)."""
        from ...plotting import plot_greybox_fit  # deferred: matplotlib loads only when plotting

        return plot_greybox_fit(self, run, ax=ax)

    def to_pandas(self):
        """One row per free parameter: value, std, interval, inflation, weak and widened flags,
        and the stage it comes from (``full`` or ``sliding``)."""
        import pandas as pd  # deferred: pandas loads only for tables

        rows = []
        for i, (n, e) in enumerate(self.estimates_.items()):
            rows.append(
                {
                    "parameter": n,
                    "value": e.value,
                    "std": e.std,
                    "ci_low": e.ci[0],
                    "ci_high": e.ci[1],
                    "unit": e.unit,
                    "inflation": float(self.inflation_[i]),
                    "weak": n in self.identifiability_.weak,
                    "widened": n in self.widened_,
                    "stage": "sliding" if n in self.sliding_.parameters else FULL_STAGE,
                }
            )
        return pd.DataFrame(rows).set_index("parameter")

    def summary_markdown(self, truth: Mapping[str, float] | None = None) -> str:
        """A Markdown summary: values and intervals, runs, identifiability.

        ``truth``: known true values by parameter name (a virtual rig's
        ``true_params.toml``); the table then shows each beside its interval and flags an
        interval that misses it (:func:`~hydropwa.identification.truth_in_interval`).
        """
        lines = [
            f"# Grey-box fit ({self.model} model)",
            "",
            f"{self.optimizer_}, {self.njev} Jacobians — cost {self.initial_cost:.4g} → "
            f"{self.cost:.4g}, "
            f"{self.wall_time:.1f} s",
            "",
            *self._estimate_table(truth or {}),
        ]
        lines += [
            "",
            "| run | method | segments | excluded | RMS error |",
            "| --- | --- | --- | --- | --- |",
        ]
        for r in self.runs_:
            rms = ", ".join(f"{c} {_fmt_si(c, v)}" for c, v in r.rms.items())
            exc = "; ".join(f"{a:.3g}–{b:.3g} s {why}" for a, b, why in r.excluded[:3]) or "—"
            lines.append(f"| {r.name} | {r.method} | {len(r.segments)} | {exc} | {rms} |")
        lines += self._stages_data_validation()
        idf = self.identifiability_
        lines += ["", f"Condition number of JᵀJ: {idf.condition:.3g}."]
        if idf.correlated:
            lines.append(
                "Strongly correlated: "
                + "; ".join(f"{a}/{b} ({c:+.2f})" for a, b, c in idf.correlated)
                + "."
            )
        if idf.advice:
            lines += ["", "To separate them: " + "; ".join(idf.advice) + "."]
        if idf.undetermined:
            lines.append(
                "Not determined by these data (the cost does not change with them, or "
                "their optimum lies at a bound; the interval reaches the bounds): "
                + ", ".join(idf.undetermined)
                + "."
            )
        sl = self.sliding_
        if sl.applied:
            lines.append(
                f"Sliding stage: {', '.join(sl.parameters)} refitted on {sl.stretches} "
                f"stretches above {1e3 * sl.v_min:.3g} mm/s"
                + (f", {', '.join(sl.held)} held at the full fit's values." if sl.held else ".")
            )
        elif sl.skipped:
            lines.append(f"Sliding stage not applied: {sl.skipped}.")
        if self.widened_:
            lines.append(
                "Widened by the interval scan (the cost stays within the threshold beyond "
                "the quadratic interval): " + ", ".join(self.widened_) + "."
            )
        for p in self.profiles_.values():
            lines.append(f"Profile of {p.name}: interval [{p.ci[0]:.5g}, {p.ci[1]:.5g}].")
        if self.skipped_:
            lines += ["", "Skipped: " + "; ".join(str(s) for s in self.skipped_)]
        return "\n".join(lines) + "\n"

    def _estimate_table(self, truth: Mapping[str, float]) -> list[str]:
        """The summary's table of estimates (with the truth where known) and a line naming
        the intervals that miss it."""
        known = [n for n in self.estimates_ if n in truth]
        extra = " true | true in interval |" if known else ""
        lines = [
            f"| parameter | value | std | {100 * self.level:.0f} % interval | inflation | weak |"
            + extra,
            "| --- | --- | --- | --- | --- | --- |" + (" --- | --- |" if known else ""),
        ]
        idf, missed = self.identifiability_, []
        for i, (n, e) in enumerate(self.estimates_.items()):
            weak = "not identified" if n in idf.undetermined else "yes" if n in idf.weak else ""
            row = (
                f"| {n} | {e.value:.5g} {e.unit} | {e.std:.3g} | [{e.ci[0]:.4g}, {e.ci[1]:.4g}] | "
                f"{self.inflation_[i]:.1f} | {weak} |"
            )
            if known:
                verdict = truth_in_interval(*e.ci, truth.get(n))
                missed += [n] if verdict == TRUTH_OUTSIDE else []
                row += f" {truth[n]:.5g} | {verdict} |" if n in truth else " | |"
            lines.append(row)
        if missed:
            lines += [
                "",
                f"{len(missed)} true value(s) outside their interval: {', '.join(missed)}.",
            ]
        return lines

    def _stages_data_validation(self) -> list[str]:
        """The summary's lines on the stages, the data used and the held-out validation."""
        lines: list[str] = []
        if self.stages_:
            lines += [
                "",
                "Stages: "
                + "; ".join(
                    f"{st.name} {'converged' if st.success else 'NOT converged'} "
                    f"({st.status.name}, {st.nfev} evaluations)"
                    for st in self.stages_
                )
                + ".",
            ]
        if self.data_:
            lines += ["", "Data used: " + " ".join(self.data_)]
        if self.validation_ is not None:
            val = self.validation_
            chans = list(val.mean)
            lines += [
                "",
                val.summary(),
                "",
                "| held-out run | " + " | ".join(f"fit {c} [%]" for c in chans) + " |",
                "| --- |" + " --- |" * len(chans),
            ]
            for name, fits in val.runs.items():
                cells = " | ".join(f"{fits.get(c, float('nan')):.2f}" for c in chans)
                lines.append(f"| {name} | {cells} |")
        return lines

    def save(self, path: str | os.PathLike, *, overwrite: bool = False) -> os.PathLike:
        """Write :attr:`params_` as a parameter TOML (atomically).

        An existing file raises :class:`~hydropwa.OutputExistsError` unless ``overwrite``.
        """
        return save_params(
            self.params_,
            path,
            header=f"grey-box fit ({self.model} model) of {', '.join(self.free)}",
            overwrite=overwrite,
        )


def _fmt_si(channel: str, value: float) -> str:
    if channel.startswith("p"):
        return f"{value / 1e5:.3g} bar"
    if channel == "x":
        return f"{value * 1e3:.3g} mm"
    if channel == "v":
        return f"{value * 1e3:.3g} mm/s"
    return f"{value:.3g}"
