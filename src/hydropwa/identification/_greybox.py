"""Grey-box identification from transients: fit the model itself to measured runs.

:func:`fit_model` simulates a model (full or reduced, any model kind of
:mod:`hydropwa.models`) with each run's measured inputs — the command u(t), the
supply pressure P_S(t) and the load force F_L(t), all as
:class:`~hydropwa.simulation.Sampled` signals — from initial states taken from
the data, and minimises the noise-scaled output error of chosen channels
(position, chamber pressures, velocity if logged) over the free parameters with
:func:`scipy.optimize.least_squares`. This is the output-error method of
MATLAB's ``nlgreyest``, for the equations of the paper.

Two ways to simulate a run (:class:`Shooting`):

* **single shooting** – one simulation over each valid stretch of the run. Right
  for smooth runs (sines, steps, steady motion).
* **multiple shooting** – short windows (default 20 ms), each started from the
  measured pressures, position, spool and a smoothed velocity. Needed for
  stick-slip runs: the 150–200 Hz oscillation drifts in phase, and the output
  error of one long simulation is then smallest at a wrong F_s (≈ 80 N for a
  true 118 N, issue 19), while short windows keep the phase.

``method="auto"`` picks per run from its content: a run whose load pressure has
high-frequency content (around a 10 ms moving mean) well above its noise floor
is oscillating, and gets multiple shooting.

Gradients are finite differences of the compiled simulation, all columns at once
on a thread pool (the kernel releases the GIL); see
``docs/architecture_identification.md`` for why not forward sensitivities.

Uncertainty: the output-error residuals are strongly autocorrelated (a model
error in x persists for many samples), so the covariance is the sandwich
H⁻¹ S H⁻¹ with H = JᵀJ and S a Newey–West (Bartlett) long-run covariance of
the score g_i = J_iᵀ r_i per residual stream, with a bandwidth from that stream's
residual autocorrelation time. Parameters that come out weak (wide interval or at
a bound) get a profile of the cost.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time as _time
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
from scipy import optimize, stats
from scipy.signal import butter, savgol_coeffs, savgol_filter, sosfiltfilt

from .._errors import IdentificationError, ParameterError
from ..models import as_model
from ..params import FIELD_UNITS, SystemParams, save_params
from ..simulation import Sampled
from ..simulation._simulate import PackedInputs, simulate_packed
from ._common import (
    IdentificationWarning,
    OptimizerStatus,
    ParameterEstimate,
    SkippedRun,
    as_runs,
    experiment_of,
    skip,
)

__all__ = [
    "PARAMETER_GROUPS",
    "Shooting",
    "RunFit",
    "Profile",
    "Identifiability",
    "GreyBoxFit",
    "fit_model",
    "expand_free",
]

#: Names that stand for several parameters in ``free``.
PARAMETER_GROUPS: dict[str, tuple[str, ...]] = {
    "friction": tuple(
        f"friction.{f}"
        for f in ("coulomb", "static", "viscous", "stribeck_velocity", "shape", "smoothness")
    ),
    "valve": ("valve.omega0", "valve.zeta"),
    "dead_volumes": ("cylinder.dead_volume_a", "cylinder.dead_volume_b"),
}

#: (lower, upper, start) for parameters whose base value may be zero: a log scale needs a
#: positive start. Leakage 1e-13 m³/(s·Pa) is 0.03 L/min at 50 bar.
_ZERO_BASE: dict[str, tuple[float, float, float]] = {
    "cylinder.leakage": (1e-16, 1e-9, 1e-13),
    "friction.coulomb": (1e-2, 1e4, 10.0),
    "friction.static": (1e-2, 1e4, 10.0),
    "friction.viscous": (1e-1, 1e5, 100.0),
    "load.damping": (1e-1, 1e6, 100.0),
    "dead_zone.creep_slope": (1e-5, 1.0, 1e-2),
}

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

_CONVERGENCE = {
    -1: "improper input parameters status returned from MINPACK",
    0: "the maximum number of function evaluations was exceeded; raise max_nfev",
    1: "gtol termination condition is satisfied",
    2: "ftol termination condition is satisfied",
    3: "xtol termination condition is satisfied",
    4: "both ftol and xtol termination conditions are satisfied",
}


def expand_free(free: Iterable[str] | str, params: SystemParams) -> tuple[str, ...]:
    """Dotted parameter names from ``free`` with groups expanded, checked against ``params``.

    Parameters
    ----------
    free : str or iterable of str
        Names as in the parameter TOML (``"friction.static"``, ``"oil.bulk_modulus"``,
        ``"flow.K"``), group names (``"friction"`` = all six Stribeck parameters, see
        :data:`PARAMETER_GROUPS`), or a comma-separated string of them.
    params : SystemParams

    Returns
    -------
    tuple of str
        Unique names in the given order.

    Raises
    ------
    IdentificationError
        For an unknown or non-numeric name (the message lists the known ones).
    """
    if isinstance(free, str):
        free = [f for f in free.split(",")]
    out: list[str] = []
    for raw in free:
        name = raw.strip()
        if not name:
            continue
        names = PARAMETER_GROUPS.get(name, (name,))
        for n in names:
            comp, _, fld = n.partition(".")
            obj = getattr(params, comp, None)
            if obj is None or not dataclasses.is_dataclass(obj) or comp == "meta":
                groups = ", ".join(sorted(PARAMETER_GROUPS))
                raise IdentificationError(
                    f"unknown free parameter {n!r}; give component.field as in the parameter file "
                    f"(e.g. friction.static, oil.bulk_modulus, flow.K) or a group ({groups})"
                )
            known = {f.name for f in dataclasses.fields(obj)}
            if fld not in known:
                raise IdentificationError(
                    f"unknown free parameter {n!r}; {comp} has {', '.join(sorted(known))}"
                )
            val = getattr(obj, fld)
            if isinstance(val, bool) or not isinstance(val, int | float):
                raise IdentificationError(
                    f"free parameter {n!r} is not a number ({val!r}) and cannot be fitted"
                )
            if n not in out:
                out.append(n)
    if not out:
        raise IdentificationError(
            "no free parameters given; name at least one, e.g. friction.static"
        )
    return tuple(out)


def _get(params: SystemParams, name: str) -> float:
    comp, fld = name.split(".", 1)
    return float(getattr(getattr(params, comp), fld))


# ----------------------------------------------------------------------------- settings
@dataclasses.dataclass(frozen=True)
class Shooting:
    """How each run is simulated during the fit.

    Attributes
    ----------
    method : {"auto", "single", "multiple"}
        ``auto`` chooses per run: multiple shooting when the run oscillates (stick-slip,
        see :func:`fit_model`), single shooting otherwise.
    window : float
        Multiple shooting window length [s] (20 ms: 3–4 stick-slip periods at 150–200 Hz).
    segment : float or None
        Single shooting restarts from the measured state every ``segment`` seconds (None:
        one simulation per valid stretch). The position integrates every velocity error,
        so over a 5 s sine run a 10 % error in K drifts the rod by centimetres (thousands
        of noise levels): the cost is then dominated by the drift and its valleys are
        curved. Half-second stretches keep the drift, and the fit, well-conditioned.
    max_windows : int or None
        At most this many windows per run, evenly spaced over its valid part (None: all).
        Windows of a steady oscillation repeat each other; 40 per run keep the fit fast.
    velocity_window : float
        Length [s] of the Savitzky–Golay filter (quadratic) that gives the initial
        velocity of each window from the measured position.
    oscillation_ratio : float
        ``auto`` calls a run oscillating when the robust spread (1.4826·median |·|) of its
        load pressure around a 10 ms moving mean exceeds this many times its noise level.
        Measured on the virtual rig: 1.0–1.3 on smooth runs, 2.4–2.8 on 20 % sines (brief
        stick at the reversals), 4.5–7.5 on stick-slip runs.
    """

    method: str = "auto"
    window: float = 0.02
    segment: float | None = 0.5
    max_windows: int | None = 40
    velocity_window: float = 0.004
    oscillation_ratio: float = 3.5

    def __post_init__(self) -> None:
        if self.method not in ("auto", "single", "multiple"):
            raise IdentificationError(
                f"Shooting.method = {self.method!r}; choose auto, single or multiple"
            )
        if not (math.isfinite(self.window) and 1e-3 <= self.window <= 10.0):
            raise IdentificationError(
                f"Shooting.window = {self.window!r} s must lie in [1 ms, 10 s]"
            )
        if self.segment is not None and not (self.segment >= self.window):
            raise IdentificationError(
                f"Shooting.segment = {self.segment!r} s must be >= the window or None"
            )
        if self.max_windows is not None and self.max_windows < 1:
            raise IdentificationError(
                f"Shooting.max_windows = {self.max_windows!r} must be >= 1 or None"
            )
        if not (self.velocity_window > 0):
            raise IdentificationError(
                f"Shooting.velocity_window = {self.velocity_window!r} s must be > 0"
            )


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
    """

    name: str
    values: np.ndarray
    cost: np.ndarray
    ci: tuple[float, float]


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
    """

    condition: float
    directions: list[tuple[float, dict[str, float]]]
    correlated: list[tuple[str, str, float]]
    weak: list[str]
    advice: list[str]
    unconverged: list[str] = dataclasses.field(default_factory=list)


@dataclasses.dataclass
class GreyBoxFit:
    """Result of :func:`fit_model`.

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
    status : int
        ``scipy.optimize.least_squares`` status.
    message : str
    nfev, njev : int
        Residual and Jacobian evaluations of the best start.
    cost, initial_cost : float
        ½Σρ(r²) at the full fit's optimum and at the start (r noise-scaled, ρ the loss;
        the sliding stage's own cost is in ``sliding_``).
    runs_ : list of RunFit
    profiles_ : dict[str, Profile]
    identifiability_ : Identifiability
    starts_ : list of dict
        Every start: its values, final cost, status, the evaluations of the locating
        (multiple-shooting) and coarse stages, and the full stage's ``restarts`` from a
        lower difference point.
    optimizer_ : OptimizerStatus
        How ``least_squares`` ended for the best start: success, its stopping reason,
        residual evaluations (``nit``: Jacobian evaluations, one per accepted or rejected
        trust-region iteration).
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
    sliding_ : dict
        The sliding stage (``sliding`` of :func:`fit_model`): ``parameters`` refitted on
        the sliding stretches, ``held`` breakaway parameters, ``v_min`` [m/s], number of
        ``stretches``, their ``runs``, the stage's own ``cost``, ``nfev``, ``njev`` and
        ``status``, and ``remaining_std`` (the largest Gauss–Newton step still left, in
        standard deviations; above 1 the parameter is listed as unconverged); or
        ``skipped`` with the reason it did not apply; empty when not asked for (F_c fixed
        or ``sliding=False``).
    """

    params_: SystemParams
    free: tuple[str, ...]
    estimates_: dict[str, ParameterEstimate]
    covariance_: np.ndarray
    correlation_: np.ndarray
    inflation_: np.ndarray
    success: bool
    status: int
    message: str
    nfev: int
    njev: int
    cost: float
    initial_cost: float
    runs_: list[RunFit]
    profiles_: dict[str, Profile]
    identifiability_: Identifiability
    starts_: list[dict[str, Any]]
    model: str
    optimizer_: OptimizerStatus
    skipped_: list[SkippedRun] = dataclasses.field(default_factory=list)
    wall_time: float = 0.0
    level: float = 0.95
    interval_scan_: dict[str, tuple[float, float]] = dataclasses.field(default_factory=dict)
    widened_: list[str] = dataclasses.field(default_factory=list)
    sliding_: dict[str, Any] = dataclasses.field(default_factory=dict)

    def __repr__(self) -> str:
        vals = ", ".join(f"{n}={e.value:.4g}" for n, e in self.estimates_.items())
        return f"GreyBoxFit({self.model}, {vals}, cost={self.cost:.4g}, success={self.success})"

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
                    "stage": "sliding" if n in self.sliding_.get("parameters", ()) else "full",
                }
            )
        return pd.DataFrame(rows).set_index("parameter")

    def summary_markdown(self) -> str:
        """A Markdown summary: values and intervals, runs, identifiability."""
        lines = [
            f"# Grey-box fit ({self.model} model)",
            "",
            f"{self.optimizer_} — cost {self.initial_cost:.4g} → {self.cost:.4g}, "
            f"{self.wall_time:.1f} s",
            "",
            f"| parameter | value | std | {100 * self.level:.0f} % interval | inflation | weak |",
            "| --- | --- | --- | --- | --- | --- |",
        ]
        for i, (n, e) in enumerate(self.estimates_.items()):
            lines.append(
                f"| {n} | {e.value:.5g} {e.unit} | {e.std:.3g} | [{e.ci[0]:.4g}, {e.ci[1]:.4g}] | "
                f"{self.inflation_[i]:.1f} | {'yes' if n in self.identifiability_.weak else ''} |"
            )
        lines += [
            "",
            "| run | method | segments | excluded | RMS error |",
            "| --- | --- | --- | --- | --- |",
        ]
        for r in self.runs_:
            rms = ", ".join(f"{c} {_fmt_si(c, v)}" for c, v in r.rms.items())
            exc = "; ".join(f"{a:.3g}–{b:.3g} s {why}" for a, b, why in r.excluded[:3]) or "—"
            lines.append(f"| {r.name} | {r.method} | {len(r.segments)} | {exc} | {rms} |")
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
        sl = self.sliding_
        if sl.get("parameters"):
            lines.append(
                f"Sliding stage: {', '.join(sl['parameters'])} refitted on {sl['stretches']} "
                f"stretches above {1e3 * sl['v_min']:.3g} mm/s"
                + (
                    f", {', '.join(sl['held'])} held at the full fit's values."
                    if sl["held"]
                    else "."
                )
            )
        elif sl.get("skipped"):
            lines.append(f"Sliding stage not applied: {sl['skipped']}.")
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


# ----------------------------------------------------------------------------- run preparation
@dataclasses.dataclass
class _Segment:
    i0: int
    i1: int  # exclusive
    y0: np.ndarray
    #: the smoothed measurements y0 was built from (x, v, p_a, p_b, p_s, spool, spool_rate)
    meas: dict[str, float]


@dataclasses.dataclass
class _RunData:
    name: str
    t: np.ndarray
    u: np.ndarray
    p_s: np.ndarray | None
    f_l: np.ndarray | None
    y: dict[str, np.ndarray]
    sigma: dict[str, float]
    method: str
    reason: str
    segments: list[_Segment]
    excluded: list[tuple[float, float, str]]
    #: builds an initial state from measurements (the segment's ``meas``, perturbed)
    make_state: Callable[[dict[str, float]], np.ndarray]
    #: standard deviation of each smoothed initial measurement (its sensor noise through the
    #: Savitzky–Golay filter)
    meas_sd: dict[str, float]
    #: per driving input (p_s, f_l): its noise level [SI] and the low-pass it went through
    input_noise: dict[str, tuple[float, Any]]


def noise_level(y: np.ndarray) -> float:
    """Standard deviation of white noise on a signal from its second differences (robust).

    σ = 1.4826·MAD(Δ²y)/√6: the second difference removes smooth motion, white noise
    of variance σ² gives Δ²y a variance 6σ², and the MAD ignores sharp events. Never
    below one quantization step/√12 (the smallest change in the record).
    """
    y = np.asarray(y, dtype=float)
    d2 = np.diff(y, 2)
    s = 1.4826 * float(np.median(np.abs(d2 - np.median(d2)))) / math.sqrt(6.0) if d2.size else 0.0
    steps = np.abs(np.diff(y))
    steps = steps[steps > 0]
    q = float(steps.min()) / math.sqrt(12.0) if steps.size else 0.0
    return max(s, q, 1e-300)


def _mask_runs(mask: np.ndarray) -> list[tuple[int, int]]:
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return list(
        zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist(), strict=True)
    )


def _clipped(v: np.ndarray, min_samples: int = 5) -> np.ndarray:
    """Samples stuck at the record's extreme for ``min_samples`` or more (a converter limit)."""
    out = np.zeros(v.size, bool)
    if v.size < 2 * min_samples or v.min() == v.max():
        return out
    for level in (v.max(), v.min()):
        for s, e in _mask_runs(v == level):
            if e - s >= min_samples:
                out[s:e] = True
    rest = np.diff(v[~out])
    if out.any() and rest.size and np.mean(rest == 0) > 0.5:  # quantised slow signal, not a rail
        return np.zeros(v.size, bool)
    return out


def _dilate(mask: np.ndarray, n: int) -> np.ndarray:
    if n <= 0 or not mask.any():
        return mask
    k = np.convolve(mask.astype(float), np.ones(2 * n + 1), mode="same")
    return k > 0.5


def _smoothed_velocity(t: np.ndarray, x: np.ndarray, window: float) -> np.ndarray:
    dt = float(np.median(np.diff(t)))
    n = max(5, int(round(window / dt)) | 1)
    if n >= x.size:
        return np.gradient(x, t)
    return savgol_filter(x, n, 2, deriv=1, delta=dt)


def _smoothed(t: np.ndarray, y: np.ndarray, window: float) -> np.ndarray:
    dt = float(np.median(np.diff(t)))
    n = max(5, int(round(window / dt)) | 1)
    return y if n >= y.size else savgol_filter(y, n, 2)


def _prepare_run(
    run,
    mdl,
    channels: Sequence[str],
    shooting: Shooting,
    skipped: list[SkippedRun],
    input_cutoff: float | None = 50.0,
    sliding_above: float | None = None,
) -> _RunData | None:
    """A run's data for the fit: fitted channels, noise levels, valid stretches, segments.

    ``sliding_above`` [m/s]: instead of the shooting's segments, single-shooting segments
    over the stretches where the smoothed measured speed exceeds it (each started from
    the measured state there; see the sliding stage of :func:`fit_model`).
    """
    ch = run.channels
    needed = ["t", "u", "x", "p_a", "p_b"]
    missing = [c for c in needed if c not in ch]
    if missing:
        skip(
            skipped,
            run.name,
            f"missing channel(s) {', '.join(missing)} (grey-box fit needs t, u, x, p_a, p_b)",
            4,
        )
        return None
    arrays = {
        k: np.asarray(v, dtype=float)
        for k, v in ch.items()
        if k in (*needed, "p_s", "f_l", "spool", "v")
    }
    bad = [k for k, v in arrays.items() if not np.all(np.isfinite(v))]
    if bad:
        skip(skipped, run.name, f"channel(s) {', '.join(bad)} hold non-finite samples", 4)
        return None
    t = arrays["t"]
    n = t.size
    if n < 20:
        skip(skipped, run.name, f"only {n} samples", 4)
        return None
    dt = float(np.median(np.diff(t)))
    y = {}
    for c in channels:
        if c == "p_l":
            y[c] = arrays["p_a"] - arrays["p_b"]
        elif c in arrays:
            y[c] = arrays[c]
    if not y:
        skip(skipped, run.name, f"none of the fitted channels {', '.join(channels)} is logged", 4)
        return None
    sigma = {c: noise_level(v) for c, v in y.items()}

    # validity: converter limits and end-stop contact, widened by 10 ms (their transients)
    stroke = mdl.params.cylinder.stroke
    margin = max(5e-4, 1e-3 * stroke)
    excluded: list[tuple[float, float, str]] = []
    bad_mask = np.zeros(n, bool)
    widen = int(round(0.01 / dt))
    for c in ("x", "p_a", "p_b", "p_s", "f_l"):
        if c in arrays:
            m = _clipped(arrays[c])
            if m.any():
                m = _dilate(m, widen)
                for s, e in _mask_runs(m):
                    excluded.append((float(t[s]), float(t[e - 1]), f"{c} at a converter limit"))
                bad_mask |= m
    x = arrays["x"]
    stop = (x < margin) | (x > stroke - margin)
    if stop.any():
        stop = _dilate(stop, widen)
        for s, e in _mask_runs(stop & ~bad_mask):
            excluded.append((float(t[s]), float(t[e - 1]), "rod at an end stop"))
        bad_mask |= stop
    valid = _mask_runs(~bad_mask)

    # method from the content: the load pressure's fast content against its noise
    pl = arrays["p_a"] - arrays["p_b"]
    k = max(3, int(round(0.01 / dt)) | 1)
    hp = pl - np.convolve(pl, np.ones(k) / k, mode="same")
    good = ~bad_mask
    good[:k] = False
    good[-k:] = False
    # median-based: brief events (reversals of a sine, a step) do not count, a sustained oscillation does
    ratio = (
        float(1.4826 * np.median(np.abs(hp[good])) / noise_level(pl)) if good.sum() > 10 else 0.0
    )
    if sliding_above is not None:
        method = "single"
        reason = f"sliding stretches (|v| > {1e3 * sliding_above:.3g} mm/s)"
    elif shooting.method == "auto":
        method = "multiple" if ratio > shooting.oscillation_ratio else "single"
        reason = f"auto: load-pressure fast content {ratio:.1f}× noise (threshold {shooting.oscillation_ratio:g})"
    else:
        method, reason = shooting.method, "forced"

    # initial states from smoothed measurements: a raw sample's noise would persist through
    # the whole segment (a 5 µm position error stays a 5 µm offset)
    v_est = _smoothed_velocity(t, x, shooting.velocity_window)
    sm = {
        c: _smoothed(t, arrays[c], shooting.velocity_window)
        for c in ("x", "p_a", "p_b", "p_s", "spool")
        if c in arrays
    }

    spool_rate = (
        _smoothed_velocity(t, arrays["spool"], shooting.velocity_window)
        if "spool" in arrays
        else None
    )

    def make_state(m: dict[str, float]) -> np.ndarray:
        y0 = np.asarray(
            mdl.state_from_measurement(m["x"], m["v"], m["p_a"], m["p_b"], m["p_s"], m["spool"]),
            dtype=float,
        )
        if "spool_rate" in m and "spool_rate" in mdl.state_names:
            y0[mdl.state_names.index("spool_rate")] = m["spool_rate"]
        return y0

    def measured_at(i: int) -> dict[str, float]:
        m = {
            "x": float(sm["x"][i]),
            "v": float(v_est[i]),
            "p_a": float(sm["p_a"][i]),
            "p_b": float(sm["p_b"][i]),
            "p_s": float(sm["p_s"][i]) if "p_s" in sm else float(mdl.params.supply.pressure),
            "spool": float(sm["spool"][i]) if "spool" in sm else float(arrays["u"][i]),
        }
        if spool_rate is not None:
            m["spool_rate"] = float(spool_rate[i])
        return m

    def segment(a: int, b: int) -> _Segment:
        m = measured_at(a)
        return _Segment(a, b, make_state(m), m)

    # the initial measurements' errors: each channel's noise through the quadratic
    # Savitzky–Golay filter (value: √Σh₀², derivative: √Σh₁²; the two are uncorrelated)
    n_sg = max(5, int(round(shooting.velocity_window / dt)) | 1)
    g0 = math.sqrt(float(np.sum(savgol_coeffs(n_sg, 2) ** 2)))
    g1 = math.sqrt(float(np.sum(savgol_coeffs(n_sg, 2, deriv=1, delta=dt) ** 2)))
    meas_sd = {
        c: noise_level(arrays[c]) * g0 for c in ("x", "p_a", "p_b", "p_s", "spool") if c in arrays
    }
    meas_sd["v"] = noise_level(x) * g1
    if spool_rate is not None:
        meas_sd["spool_rate"] = noise_level(arrays["spool"]) * g1

    segments: list[_Segment] = []
    min_len = max(10, int(round(0.25 * shooting.window / dt)))
    if method == "single":
        stretches, shortest = valid, min_len
        if sliding_above is not None:
            # the sliding stretches, at least one window long, selected on the same smoothed
            # velocity as the initial states: each starts at the crossing (see the sliding
            # stage in docs/architecture_identification.md for the delayed and the separately
            # smoothed starts that were measured and not kept)
            stretches = _mask_runs((np.abs(v_est) > sliding_above) & ~bad_mask)
            shortest = max(min_len, int(round(shooting.window / dt)))
        step = e_max = max(min_len, int(round(shooting.segment / dt))) if shooting.segment else n
        for s, e in stretches:
            for a in range(s, e, step):
                b = min(a + e_max, e)
                if b - a >= shortest:
                    segments.append(segment(a, b))
    else:
        w = max(4, int(round(shooting.window / dt)))
        starts = [s0 for s, e in valid for s0 in range(s, e - w, w)]
        if shooting.max_windows is not None and len(starts) > shooting.max_windows:
            pick = np.unique(
                np.round(np.linspace(0, len(starts) - 1, shooting.max_windows)).astype(int)
            )
            starts = [starts[i] for i in pick]
        segments = [segment(s0, s0 + w + 1) for s0 in starts]
    if not segments:
        skip(
            skipped,
            run.name,
            "no valid stretch long enough to simulate (end stops or converter limits everywhere)",
            4,
        )
        return None
    # measured inputs carry sensor noise that the simulation would integrate (errors in
    # variables: 5 N of force noise becomes a random walk of the rod); a zero-phase low-pass
    # keeps the supply sag and the counter-force ripple and drops the noise
    inputs = {}
    input_noise = {}
    for c in ("p_s", "f_l"):
        if c in arrays:
            v = arrays[c]
            sos = None
            if input_cutoff and input_cutoff < 0.45 / dt and v.size > 30:
                sos = butter(2, input_cutoff, fs=1.0 / dt, output="sos")
                v = sosfiltfilt(sos, v)
            inputs[c] = v
            input_noise[c] = (noise_level(arrays[c]), sos)
    return _RunData(
        run.name,
        t,
        arrays["u"],
        inputs.get("p_s"),
        inputs.get("f_l"),
        y,
        sigma,
        method,
        reason,
        segments,
        excluded,
        make_state,
        meas_sd,
        input_noise,
    )


def _perturbed_run(rd: _RunData, rng: np.random.Generator) -> _RunData:
    """``rd`` with one draw of its initial-state and input errors added.

    Each segment's initial measurements move by their smoothed noise (``meas_sd``) and each
    driving input by white noise of its level through the same low-pass; the measured
    outputs stay. What the fit's estimate would be with these data instead is one draw
    of what the data's initial states and inputs (errors in variables) do to it.
    """
    segs = []
    for seg in rd.segments:
        # P_S from the parameters or the spool from the command (not logged) carry no noise
        m = {k: v + rng.normal(0.0, rd.meas_sd.get(k, 0.0)) for k, v in seg.meas.items()}
        segs.append(_Segment(seg.i0, seg.i1, rd.make_state(m), m))
    extra = {}
    for c in ("p_s", "f_l"):
        arr = getattr(rd, c)
        if arr is None or c not in rd.input_noise:
            continue
        sd, sos = rd.input_noise[c]
        e = rng.normal(0.0, sd, arr.size)
        extra[c] = arr + (sosfiltfilt(sos, e) if sos is not None else e)
    return dataclasses.replace(rd, segments=segs, **extra)


def _nuisance_covariance(
    prob: Any,
    prepared: list[_RunData],
    theta: np.ndarray,
    r: np.ndarray,
    Jw: np.ndarray,
    w: np.ndarray,
    Hinv: np.ndarray,
    draws: int,
    rng: np.random.Generator,
) -> np.ndarray:
    """Covariance of the log parameters from the initial-state and input errors.

    Draw k perturbs the data (:func:`_perturbed_run`) and simulates every ``s``-th segment
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
            runs.append(_perturbed_run(dataclasses.replace(rd, segments=keep), rng))
        rows = [
            np.arange(pos, pos + length)
            for ri, si, _c, pos, length in prob.streams
            if (ri, si) in chosen
        ]
        if not rows:
            continue
        idx = np.concatenate(rows)
        pert = _Problem(
            prob.base_model, runs, prob.free, prob.channels, prob.rtol, prob.jobs, prob.sigma
        )
        pert.ref = prob.ref
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


# ----------------------------------------------------------------------------- evaluation
class _Problem:
    """Residuals of all runs for a parameter vector in log coordinates."""

    def __init__(
        self, base_model, runs: list[_RunData], free: tuple[str, ...], channels, rtol, jobs, sigma
    ):
        self.base_model = base_model
        self.runs = runs
        self.free = free
        self.channels = channels
        self.rtol = rtol
        self.jobs = max(1, int(jobs or os.cpu_count() or 1))
        self.sigma = sigma
        self.nfev = 0
        self.failures = 0
        #: the last ``jac`` call's difference points: (θ, the points, their residuals)
        self.probes: tuple[np.ndarray, list[np.ndarray], list[np.ndarray]] | None = None
        # fixed layout of the residual vector: (run, segment, channel) streams
        self.streams: list[tuple[int, int, str, int, int]] = []  # run, seg, channel, start, length
        pos = 0
        for ri, rd in enumerate(runs):
            for si, seg in enumerate(rd.segments):
                for c in channels:
                    if c in rd.y:
                        n = seg.i1 - seg.i0 - 1
                        self.streams.append((ri, si, c, pos, n))
                        pos += n
        self.size = pos
        self._cache: dict[bytes, np.ndarray] = {}
        self._packed: dict[tuple, Any] = {}
        self.ref = np.ones(len(free))
        self.fd_step = 1e-2

    # parameters ----------------------------------------------------------------
    def params_at(self, values: np.ndarray) -> SystemParams:
        changes = {n: float(v) for n, v in zip(self.free, values, strict=True)}
        base = self.base_model.params
        fc = changes.get("friction.coulomb", base.friction.coulomb)
        if "friction.static" in changes and changes["friction.static"] < fc:
            changes["friction.static"] = fc  # Eq. (11) needs F_s >= F_c; the fit may probe below
        elif (
            "friction.coulomb" in changes
            and "friction.static" not in changes
            and fc > base.friction.static
        ):
            changes["friction.coulomb"] = base.friction.static
        return base.replace(**changes)

    # simulation ---------------------------------------------------------------------
    def _simulate_segment(
        self, mdl, rd: _RunData, seg: _Segment, rtol: float
    ) -> dict[str, np.ndarray]:
        a, b = seg.i0, seg.i1
        # the segment's inputs are packed once for all parameter sets (simulate_packed: the
        # same kernel call as simulate, without its per-call checks, which cost twice the
        # integration of a 20 ms window); a constant P_S or F_L comes from the parameters
        ps = None if rd.p_s is not None else float(mdl.params.supply.pressure)
        fl = None if rd.f_l is not None else float(mdl.params.load.force)
        key = (id(rd), a, b, ps, fl)
        inputs = self._packed.get(key)
        if inputs is None:
            lo, hi = max(a - 1, 0), min(b + 1, rd.t.size)
            ts = rd.t[lo:hi]
            inputs = PackedInputs.from_signals(
                Sampled(ts, rd.u[lo:hi]),
                Sampled(ts, rd.p_s[lo:hi]) if rd.p_s is not None else ps,
                Sampled(ts, rd.f_l[lo:hi]) if rd.f_l is not None else fl,
                rd.t[a:b],
            )
            self._packed[key] = inputs
        channels, n_done, status = simulate_packed(
            mdl, inputs, rd.t[a:b], seg.y0, rtol=rtol, max_steps=1_000_000
        )
        out = {}
        for c in rd.y:
            v = np.asarray(channels[c], dtype=float)
            if n_done < b - a:
                # a failed integration holds its last value: a large but finite error
                v = np.concatenate([v, np.full(b - a - n_done, v[-1] if n_done else rd.y[c][a])])
            out[c] = v
        if status != 0:
            self.failures += 1
        return out

    def simulate_all(self, values: np.ndarray) -> list[list[dict[str, np.ndarray]]]:
        """Simulated channels per run and segment."""
        return self.simulate_many([values])[0]

    def simulate_many(
        self, value_sets: list[np.ndarray], rtol: float | None = None
    ) -> list[list[list[dict[str, np.ndarray]]]]:
        """Simulated channels per parameter set, run and segment (threads over all of them);
        ``rtol`` instead of the problem's tolerance."""
        tol = self.rtol if rtol is None else rtol
        mdls = [self._model(v) for v in value_sets]
        tasks = [
            (k, ri, si)
            for k in range(len(mdls))
            for ri, rd in enumerate(self.runs)
            for si in range(len(rd.segments))
        ]
        out: list[list[list]] = [[[None] * len(rd.segments) for rd in self.runs] for _ in mdls]

        def one(task):
            k, ri, si = task
            rd = self.runs[ri]
            return self._simulate_segment(mdls[k], rd, rd.segments[si], tol)

        if self.jobs == 1 or len(tasks) == 1:
            results = [one(tk) for tk in tasks]
        else:
            # long segments first: better balance between the threads
            order = sorted(
                range(len(tasks)),
                key=lambda i: (
                    -(
                        self.runs[tasks[i][1]].segments[tasks[i][2]].i1
                        - self.runs[tasks[i][1]].segments[tasks[i][2]].i0
                    )
                ),
            )
            with ThreadPoolExecutor(max_workers=self.jobs) as pool:
                got = list(
                    pool.map(
                        one,
                        [tasks[i] for i in order],
                        chunksize=max(1, len(tasks) // (8 * self.jobs)),
                    )
                )
            results = [None] * len(tasks)
            for i, r in zip(order, got, strict=True):
                results[i] = r
        for (k, ri, si), r in zip(tasks, results, strict=True):
            out[k][ri][si] = r
        self.nfev += len(mdls)
        return out

    def values(self, theta: np.ndarray) -> np.ndarray:
        """Parameter values [SI] at θ = ln(p/p_start)."""
        return self.ref * np.exp(theta)

    def _model(self, values: np.ndarray):
        return type(self.base_model)(self.params_at(values))

    def residual_vector(self, sims) -> np.ndarray:
        r = np.empty(self.size)
        for ri, si, c, pos, n in self.streams:
            rd = self.runs[ri]
            seg = rd.segments[si]
            r[pos : pos + n] = (sims[ri][si][c][1:] - rd.y[c][seg.i0 + 1 : seg.i1]) / self.sigma[c]
        return r

    def costs(
        self, thetas: list[np.ndarray], cost: Callable[[np.ndarray], float], rtol=None
    ) -> list[float]:
        """The cost of the residuals at each θ, simulated in one batch."""
        sims = self.simulate_many([self.values(t) for t in thetas], rtol)
        return [cost(self.residual_vector(sm)) for sm in sims]

    # least_squares callbacks (in log coordinates) ---------------------------------
    def fun(self, theta: np.ndarray) -> np.ndarray:
        key = theta.tobytes()
        if key not in self._cache:
            self._cache = {key: self.residual_vector(self.simulate_all(self.values(theta)))}
        return self._cache[key]

    def jac(
        self, theta: np.ndarray, step: float, r0: np.ndarray | None = None, central: bool = False
    ) -> np.ndarray:
        p = theta.size
        sets, thetas = [], []
        for j in range(p):
            e = np.zeros(p)
            e[j] = step
            thetas.append(theta + e)
            if central:
                thetas.append(theta - e)
        sets = [self.values(th) for th in thetas]
        if r0 is None and not central:
            sets.append(self.values(theta))
        sims = self.simulate_many(sets)
        cols = [self.residual_vector(s) for s in sims]
        # the difference points are neighbours of θ: fit_model restarts from one that is lower
        self.probes = (theta.copy(), thetas, cols[: len(thetas)])
        J = np.empty((self.size, p))
        if central:
            for j in range(p):
                J[:, j] = (cols[2 * j] - cols[2 * j + 1]) / (2 * step)
        else:
            base = r0 if r0 is not None else cols[-1]
            for j in range(p):
                J[:, j] = (cols[j] - base) / step
        return J


def _valley(Hinv: np.ndarray, i: int) -> np.ndarray:
    """Parameter i's valley: i moves by one, the others by their regression on it
    (H⁻¹e_i/(H⁻¹)_ii), the direction in which the linearised cost rises least."""
    return Hinv[:, i] / Hinv[i, i]


def _valley_scan(
    prob: Any,
    theta: np.ndarray,
    J: np.ndarray,
    idx: list[int],
    tlo: np.ndarray,
    thi: np.ndarray,
    cost: Callable[[np.ndarray], float],
    steps: tuple[float, ...] = (-0.2, -0.1, 0.1, 0.2),
) -> tuple[np.ndarray, int]:
    """Scan the single-shooting cost along each stick parameter's valley from the located point.

    The direction moves parameter i by one and the others by their regression on it
    (H⁻¹e_i / (H⁻¹)_ii, from the locating stage's Jacobian): along it the linearised cost is
    least. Returns the lowest of the point and the scanned ones, and the evaluations spent.
    """
    if not idx:
        return theta, 0
    Hinv = np.linalg.pinv(J.T @ J)
    cands = [theta]
    for i in idx:
        if not Hinv[i, i] > 0:
            continue
        d = _valley(Hinv, i)
        cands += [np.clip(theta + s * d, tlo + 1e-9, thi - 1e-9) for s in steps]
    return cands[int(np.argmin(prob.costs(cands, cost)))], len(cands)


def _restart_from_probes(
    prob: Any,
    sol: Any,
    solve: Callable[[np.ndarray], Any],
    cost: Callable[[np.ndarray], float],
    n: int = 2,
) -> tuple[Any, int]:
    """Restart the solver from a difference point that is lower than where it stopped.

    On runs with stick events the cost is rough on the scale of the solver's last steps (the
    timing of a stick moves with the integrator's step choice): the trust region shrinks on a
    ridge and the solver stops there with ``xtol``, though the central-difference points
    around it, a few per cent away, lie lower (measured on the 5 s sine runs: stops at F_c
    +15 … +19 %, costs above the truth's). Those points are computed anyway (the Jacobian at
    the optimum, for the covariance): when the lowest is lower than the stop by more than
    one part in 10⁶, the solver starts again from it, at most ``n`` times.

    Returns the best solution and the number of restarts taken.
    """
    taken, nfev = 0, int(sol.nfev)
    for _ in range(n):
        at = prob.probes
        if at is None or not np.array_equal(at[0], sol.x):
            prob.jac(sol.x, prob.fd_step, central=True)
            at = prob.probes
        _x, thetas, cols = at
        costs = [cost(c) for c in cols]
        k = int(np.argmin(costs))
        if not costs[k] < sol.cost * (1.0 - 1e-6):
            break
        new = solve(thetas[k])
        taken, nfev = taken + 1, nfev + int(new.nfev)
        if not new.cost < sol.cost:
            break
        sol = new
    sol.nfev = nfev  # every restart's evaluations, kept or not
    return sol, taken


def _interval_scan(
    prob: Any,
    theta: np.ndarray,
    Hinv: np.ndarray,
    sd: np.ndarray,
    kappa: np.ndarray,
    z: float,
    tlo: np.ndarray,
    thi: np.ndarray,
    cost: Callable[[np.ndarray], float],
    min_half_width: float = 0.002,
    only: Iterable[int] | None = None,
) -> tuple[np.ndarray, np.ndarray, dict[int, tuple[float, float]]]:
    """Check intervals against the cost itself: widen one where the cost rises slower.

    The Wald interval θ_i ± z·σ_i assumes the cost is the Gauss–Newton quadratic. Along
    parameter i's valley (direction H⁻¹e_i/(H⁻¹)_ii: the others follow their regression on
    it, the linearised profile) the cost is evaluated at ±2z·σ_i and expressed as the
    profile's statistic q = 2Δcost/κ_i (κ_i = σ_i²/(H⁻¹)_ii, so the quadratic gives
    q = (s/σ_i)², 4z² ≈ 15.4 there). A side whose q stays below z² ends beyond the scan, at
    2z·σ + σ·√(z² − max(q, 0)) (the quadratic's curvature from there on); a side with
    z² ≤ q < 4z² ends where the quadratic through the origin and the scanned point reaches
    z², 2z·σ·z/√q; a steeper side keeps z·σ (the scan never narrows).

    The scan and its reference point are simulated at a tenth of the fit's tolerance: at
    the fit's own the step sequence's jitter moved q at F_c's and σ's points by 5–14 for a
    shift of 4e-5 of the step (rig sine runs, rtol 1e-5); at a tenth by < 0.4, and q agreed
    with rtol 1e-7 within 0.3. Parameters whose interval is narrower than
    ±``min_half_width`` (in ln p) are not scanned: there even that cost is the integrator's
    jitter (E at ±0.05 %: q from −4 to 64 for the same shift at rtol 1e-6).

    Measured on the rig's 5 s sine runs with stick events (seed 1, six parameters free, at
    rtol 1e-7): q = 5.0 and 1.4 for the Coulomb friction, 1.5 and 13.7 for the viscous
    friction (the quadratic: 15.4): the Jacobian's 3 % differences see the stick pattern's
    steep local slope, the cost over ±9 % a flat floor; the truth lay 2.3 and 3.1 σ away.

    Each scanned point also moves the other parameters (by their regression on i): where its
    statistic on parameter j's scale, 2Δcost/κ_j, is within z², the point lies in j's profile
    region, and j's interval is widened to reach it. Measured on the same runs: K's truth
    lay 2.4 σ from the estimate on seeds 1 and 4, along the valleys of σ and F_c, whose
    scanned points moved K by 4.3 and 2.5 σ at costs within K's threshold.

    ``only``: scan these parameters' valleys alone (their points still widen the others).

    Returns the lower and upper half-widths in θ (each at least z·σ_i) and, per scanned
    parameter, q at the lower and upper point (NaN: that point is outside the bounds).
    """
    p = theta.size
    chosen = set(range(p) if only is None else only)
    lo = z * sd.copy()
    hi = z * sd.copy()
    sets, where = [theta], []
    for i in range(p):
        if i not in chosen or not (
            Hinv[i, i] > 0 and np.isfinite(sd[i]) and z * sd[i] >= min_half_width and kappa[i] > 0
        ):
            continue
        d = _valley(Hinv, i)
        for side in (-1.0, 1.0):
            t = theta + side * 2.0 * z * sd[i] * d
            where.append((i, side, bool(np.all(t > tlo) and np.all(t < thi))))
            if where[-1][2]:
                sets.append(t)
    scan: dict[int, tuple[float, float]] = {}
    if not where:
        return lo, hi, scan
    costs = iter(prob.costs(sets, cost, rtol=prob.rtol / 10.0))
    c0 = next(costs)
    q_at: dict[tuple[int, float], float] = {}
    k = 1
    for i, side, inside in where:
        if not inside:
            q_at[(i, side)] = math.nan
            continue
        q = 2.0 * (next(costs) - c0) / kappa[i]
        q_at[(i, side)] = q
        off = sets[k] - theta  # this point's offset (sets[0] is θ itself)
        k += 1
        if not np.isfinite(q):
            continue
        # the point is inside every other parameter j's profile region where its statistic on
        # j's scale, 2Δcost/κ_j, is within z²: j's interval must reach the point's offset
        within = q * kappa[i] / kappa <= z * z
        within[i] = False
        lo = np.where(within & (off < 0), np.maximum(lo, -off), lo)
        hi = np.where(within & (off > 0), np.maximum(hi, off), hi)
        if q < z * z:
            half = 2.0 * z * sd[i] + sd[i] * math.sqrt(z * z - max(q, 0.0))
        else:
            half = max(z * sd[i], 2.0 * z * sd[i] * z / math.sqrt(q))
        if side < 0:
            lo[i] = half
        else:
            hi[i] = half
    for i, _side, _in in where:
        scan[i] = (q_at[(i, -1.0)], q_at[(i, 1.0)])
    return lo, hi, scan


# ----------------------------------------------------------------------------- statistics
@dataclasses.dataclass
class _Cov:
    """The uncertainty pieces at an optimum (see :func:`_covariance`)."""

    w: np.ndarray
    Jw: np.ndarray
    rw: np.ndarray
    H: np.ndarray
    Hinv: np.ndarray
    cov: np.ndarray
    taus: list[float]


def _covariance(
    prob: Any,
    theta: np.ndarray,
    r: np.ndarray,
    J: np.ndarray,
    loss: str,
    f_scale: float,
    nuisance_draws: int,
    rng: np.random.Generator,
) -> _Cov:
    """Covariance of the log parameters at an optimum: the Newey–West sandwich per residual
    stream, at least the segment-block (cluster-robust) estimate, plus the propagated
    initial-state and input errors (see the Notes of :func:`fit_model`)."""
    w = _loss_weights(r, loss, f_scale)
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
    return _Cov(w, Jw, rw, H, Hinv, cov, taus)


def _kappa(cov: np.ndarray, Hinv: np.ndarray) -> np.ndarray:
    """The profile statistic's scale per parameter: sandwich variance over (H⁻¹)_ii."""
    return np.maximum(np.diag(cov) / np.maximum(np.diag(Hinv), 1e-300), 1e-12)


def _scan_widen(
    prob: Any,
    theta: np.ndarray,
    Hinv: np.ndarray,
    cov: np.ndarray,
    z: float,
    tlo: np.ndarray,
    thi: np.ndarray,
    cost: Callable[[np.ndarray], float],
    only: Iterable[int] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[int, tuple[float, float]]]:
    """:func:`_interval_scan` at an optimum and the covariance scaled to its half-widths.

    Returns the scaled covariance (correlations unchanged, each σ the larger of its own and
    the interval's mean half-width over z), the half-widths below and above θ in ln p, and
    the scan's q per scanned parameter.
    """
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    half_lo, half_hi, scan_i = _interval_scan(
        prob, theta, Hinv, sd, _kappa(cov, Hinv), z, tlo, thi, cost, only=only
    )
    wider = np.maximum(sd, (half_lo + half_hi) / (2.0 * z))
    with np.errstate(invalid="ignore", divide="ignore"):
        f = np.where(sd > 0, wider / sd, 1.0)
    if np.any(f > 1.0):
        cov = cov * np.outer(f, f)
    return cov, half_lo, half_hi, scan_i


#: stick parameters held at the full fit's values in the sliding stage: they act at and
#: around zero speed, where the sliding stretches carry no information on them
_BREAKAWAY = frozenset(
    ("friction.static", "friction.stribeck_velocity", "friction.shape", "friction.smoothness")
)


@dataclasses.dataclass
class _Sliding:
    """Result of the sliding stage (see :func:`_sliding_stage`)."""

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


def _sliding_runs(
    pairs: list[tuple[Any, _RunData]],
    work_model: Any,
    base: SystemParams,
    n_free: int,
    channels: tuple[str, ...],
    shooting: Shooting,
    input_cutoff: float | None,
) -> tuple[Any, float, list[_RunData]] | dict[str, Any]:
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
        sl = _prepare_run(r, model, channels, shooting, [], input_cutoff, sliding_above=v_min)
        if sl is None:
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


def _join_held(
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


def _sliding_stage(
    sliding: tuple[Any, float, list[_RunData]],
    names: tuple[str, ...],
    values: np.ndarray,
    cov: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    channels: tuple[str, ...],
    sigma: dict[str, float],
    settings: dict[str, Any],
    z: float,
    scan_intervals: bool,
    cost: Callable[[np.ndarray], float],
) -> _Sliding:
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
    ``sliding`` is :func:`_sliding_runs`'s model, v_min and stretches.
    """
    i_held = [i for i, n in enumerate(names) if n in _BREAKAWAY]
    i_free = [i for i, n in enumerate(names) if n not in _BREAKAWAY]
    model, v_min, runs = sliding
    n_str = sum(len(rd.segments) for rd in runs)
    free2 = tuple(names[i] for i in i_free)
    prob = _Problem(model, runs, free2, channels, settings["rtol"], settings["jobs"], sigma)
    prob.fd_step = settings["fd_step"]
    prob.ref = values[i_free].copy()
    tlo, thi = np.log(lo[i_free] / prob.ref), np.log(hi[i_free] / prob.ref)
    step = settings["fd_step"]
    loss, f_scale = settings["loss"], settings["f_scale"]
    x_scale = settings["x_scale"]
    if not isinstance(x_scale, str) and np.ndim(x_scale) > 0:
        x_scale = np.asarray(x_scale, dtype=float)[i_free]  # per parameter: the refitted ones

    def jac(th: np.ndarray) -> np.ndarray:
        # forward differences: the walk from the full fit's values is short and smooth (no
        # stick events), and the covariance below takes central ones at the result
        # (benchmark seed 1: 44 against 76 simulations, F_c 20.962 against 20.956 N)
        return prob.jac(th, step, r0=prob.fun(th))

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        sol = optimize.least_squares(
            prob.fun,
            np.clip(np.zeros(len(i_free)), tlo + 1e-9, thi - 1e-9),
            jac=jac,
            bounds=(tlo, thi),
            loss=loss,
            f_scale=f_scale,
            x_scale=x_scale,
            max_nfev=settings["max_nfev"],
            xtol=settings["xtol"],
            ftol=1e-6,
            gtol=1e-8,
        )
    theta = sol.x
    r = prob.fun(theta)
    J = prob.jac(theta, step, central=True)
    cv = _covariance(prob, theta, r, J, loss, f_scale, settings["nuisance_draws"], settings["rng"])
    c2 = cv.cov
    # the Gauss–Newton step still left (a bias² term, as in the full fit)
    left = -cv.Hinv @ (cv.Jw.T @ cv.rw)
    with np.errstate(invalid="ignore", divide="ignore"):
        left_sd = np.nan_to_num(np.abs(left) / np.sqrt(np.diag(c2)))
    c2 = c2 + np.outer(left, left)
    s2 = float(cv.rw @ cv.rw) / max(r.size - theta.size, 1)
    naive = np.diag(cv.Hinv) * s2
    kappa = _kappa(c2, cv.Hinv)
    sd = np.sqrt(np.clip(np.diag(c2), 0.0, None))
    half_lo = half_hi = z * sd
    scan: dict[int, tuple[float, float]] = {}
    widened: list[int] = []
    if scan_intervals:
        c2, half_lo, half_hi, scan = _scan_widen(prob, theta, cv.Hinv, c2, z, tlo, thi, cost)
        widened = [k for k in range(theta.size) if max(half_lo[k], half_hi[k]) > z * sd[k]]
    # the held parameters' uncertainty through the refit: G = −H⁻¹JᵀJ_b
    G = np.zeros((len(i_free), len(i_held)))
    if i_held:
        held = _Problem(
            type(model)(prob.params_at(prob.values(theta))),
            runs,
            tuple(names[i] for i in i_held),
            channels,
            settings["rtol"],
            settings["jobs"],
            sigma,
        )
        held.ref = values[i_held].copy()
        Jb = held.jac(np.zeros(len(i_held)), step, central=True) * cv.w[:, None]
        G = -cv.Hinv @ (cv.Jw.T @ Jb)
    out = _join_held(cov, c2, G, i_free, i_held)
    info = {
        "parameters": list(free2),
        "held": [names[i] for i in i_held],
        "v_min": v_min,
        "stretches": n_str,
        "runs": [rd.name for rd in runs],
        "cost": float(sol.cost),
        "nfev": int(sol.nfev),
        "njev": int(sol.njev or 0),
        "status": int(sol.status),
        "remaining_std": float(left_sd.max(initial=0.0)),
    }
    return _Sliding(
        i_free,
        prob,
        theta,
        tlo,
        thi,
        float(sol.cost),
        out,
        naive,
        kappa,
        half_lo,
        half_hi,
        scan,
        widened,
        left_sd,
        info,
    )


def _estimate(
    e: ParameterEstimate, value: float, sd: float, half_lo: float, half_hi: float
) -> ParameterEstimate:
    """``e`` at ``value`` [SI] with standard error ``sd`` and interval half-widths
    ``half_lo``/``half_hi`` below and above, all in ln p (the fit's coordinates)."""
    v = float(value)
    return dataclasses.replace(
        e,
        value=v,
        std=v * float(sd),
        ci=(v * math.exp(-float(half_lo)), v * math.exp(float(half_hi))),
    )


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


def _loss_weights(r: np.ndarray, loss: str, f_scale: float) -> np.ndarray:
    """√ρ'(z) of scipy's losses, z = (r/f_scale)²: the IRLS weights of a robust fit."""
    z = (r / f_scale) ** 2
    if loss == "linear":
        return np.ones_like(r)
    if loss == "soft_l1":
        rho1 = 1.0 / np.sqrt(1.0 + z)
    elif loss == "huber":
        rho1 = np.where(z <= 1.0, 1.0, 1.0 / np.sqrt(np.maximum(z, 1e-300)))
    elif loss == "cauchy":
        rho1 = 1.0 / (1.0 + z)
    elif loss == "arctan":
        rho1 = 1.0 / (1.0 + z**2)
    else:  # pragma: no cover - validated earlier
        raise IdentificationError(f"unknown loss {loss!r}")
    return np.sqrt(rho1)


def _loss_cost(r: np.ndarray, loss: str, f_scale: float) -> float:
    z = (r / f_scale) ** 2
    if loss == "linear":
        rho = z
    elif loss == "soft_l1":
        rho = 2.0 * (np.sqrt(1.0 + z) - 1.0)
    elif loss == "huber":
        rho = np.where(z <= 1.0, z, 2.0 * np.sqrt(z) - 1.0)
    elif loss == "cauchy":
        rho = np.log1p(z)
    else:
        rho = np.arctan(z)
    return 0.5 * f_scale**2 * float(np.sum(rho))


# ----------------------------------------------------------------------------- the fit
_LOSSES = ("linear", "soft_l1", "huber", "cauchy", "arctan")


#: Friction parameters that decide whether and when the rod sticks (the locating stage).
_STICK = frozenset(
    ("friction.coulomb", "friction.static", "friction.stribeck_velocity", "friction.shape")
)


def fit_model(
    model,
    runs,
    free: Iterable[str] | str,
    *,
    params: SystemParams | None = None,
    channels: Sequence[str] | None = None,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    initial: Mapping[str, float] | None = None,
    shooting: Shooting | None = None,
    loss: str = "linear",
    f_scale: float = 3.0,
    starts: int = 1,
    seed: int = 0,
    rtol: float = 1e-5,
    fd_step: float = 3e-2,
    differences: str = "central",
    coarse: int = 4,
    refresh: int = 1,
    x_scale: Any = 1.0,
    verbose: int = 0,
    input_cutoff: float | None = 50.0,
    xtol: float = 1e-4,
    jobs: int | None = None,
    max_nfev: int = 40,
    profile: str | Sequence[str] = "weak",
    level: float = 0.95,
    nuisance_draws: int = 32,
    scan_intervals: bool = True,
    sliding: bool = True,
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
    level : float
        Confidence level of the intervals.
    nuisance_draws : int
        Draws of the initial-state and input errors propagated into the covariance (0: none;
        see :func:`_nuisance_covariance`). Each simulates a quarter of the segments, so 32
        draws cost eight simulations of all runs. The fit starts every segment from
        smoothed measurements and drives the model with measured (filtered) inputs; their
        noise moves the estimate by what no residual covariance holds. Measured on the rig's
        sine runs (seeds 1–3): with the true initial states the bulk modulus moved from
        +0.030 … +0.061 % (1.2–2.4 std of the residual-based interval) to −0.001 … +0.029 %;
        with the propagation the truth is inside 20 of 20 intervals over seeds 1–5 (16 of 20
        without).
    scan_intervals : bool
        Check every interval against the cost (:func:`_interval_scan`: two simulations of
        all runs per parameter wider than ±0.2 %, at a tenth of ``rtol``) and widen it
        where the cost rises slower than the Gauss–Newton quadratic. On runs with stick events the Coulomb friction's cost is a
        flat floor under a rough surface: measured on the rig's 5 s sine runs (seeds 1–6,
        six parameters free), the truth inside 27 of 36 intervals without the scan and
        34 of 36 with it (F_c's intervals widened up to 2.8×, K's reached along σ's and F_c's
        valleys; the misses: C_L at 1.98 std, F_s at 4.7 std on one seed). Costs 52–54
        against 44 s on one thread for the benchmark's fit.
    sliding : bool
        With the Coulomb friction free and single-shot runs that pass through velocity
        reversals: refit every free parameter except the breakaway ones (F_s, Stribeck
        velocity, shape, smoothness: held at the full fit's values, their uncertainty
        propagated) on the stretches where the rod slides faster than twice the Stribeck
        velocity, each simulated from the measured state at its start
        (:func:`_sliding_stage`); those parameters' estimates and intervals are the
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
    parameter's valley (:func:`_valley_scan`); then the coarse stage (every ``coarse``-th
    segment, every 2·``coarse``-th after locating) and the full data. Where the full stage
    stops beside a lower point of its last central differences (a ridge of a cost made rough
    by stick events), it starts again from that point, at most twice. ``starts_`` records
    each stage's evaluations (the scan's with the locating stage's).
    """

    t_start = _time.perf_counter()
    if loss not in _LOSSES:
        raise IdentificationError(f"unknown loss {loss!r}; choose {', '.join(_LOSSES)}")
    if not (0 < level < 1):
        raise IdentificationError(f"level = {level!r} must lie in (0, 1)")
    if isinstance(coarse, bool) or not isinstance(coarse, int) or coarse < 1:
        raise IdentificationError(
            f"coarse = {coarse!r} must be an integer >= 1 (1: no coarse stage)"
        )
    if (
        isinstance(nuisance_draws, bool)
        or not isinstance(nuisance_draws, int)
        or nuisance_draws < 0
    ):
        raise IdentificationError(
            f"nuisance_draws = {nuisance_draws!r} must be an integer >= 0 (0: none)"
        )
    if differences not in ("central", "forward"):
        raise IdentificationError(f"differences = {differences!r}; choose central or forward")
    if isinstance(model, str) and model.strip().lower() == "pwa":
        raise IdentificationError(
            "the PWA model is fitted from its parameters; fit 'full' or 'reduced' and linearize"
        )
    try:
        base_model = as_model(model, params)
    except ParameterError as exc:
        raise IdentificationError(str(exc)) from None
    if not hasattr(type(base_model), "state_from_measurement"):
        raise IdentificationError(
            f"the {base_model.name} model cannot start from measurements; fit 'full' or 'reduced'"
        )
    shooting = shooting or Shooting()
    run_list = as_runs(runs)
    names = expand_free(free, base_model.params)
    skipped: list[SkippedRun] = []

    # the fit's own model: measured P_S drives it, and the force sensor already holds c·ẋ
    sim_params = base_model.params
    logged = set.intersection(*[set(r.channels) for r in run_list])
    if "p_s" in logged and sim_params.supply.model != "ideal":
        sim_params = sim_params.replace(**{"supply.model": "ideal"})
    if "f_l" in logged and sim_params.load.damping > 0 and "load.damping" not in names:
        sim_params = sim_params.replace(**{"load.damping": 0.0})
    model_class: Any = type(base_model)  # a FullOrderModel or ReducedModel (checked above)
    work_model = model_class(sim_params)

    chans = (
        tuple(channels)
        if channels
        else tuple(c for c in ("x", "p_a", "p_b", "v") if c in logged or c != "v")
    )
    pairs: list[tuple[Any, _RunData]] = []
    for r in run_list:
        rd = _prepare_run(r, work_model, chans, shooting, skipped, input_cutoff)
        if rd is not None:
            pairs.append((r, rd))
    if shooting.method == "auto":
        # an experiment with stick-slip runs is fitted in windows throughout: its smooth runs'
        # long segments would otherwise dominate the cost and F_s stalls (measured −22 % on the
        # undamped friction campaign against +0.3 % in windows)

        shaky = {
            experiment_of(r) for r, rd in pairs if rd.method == "multiple" and experiment_of(r)
        }
        forced = dataclasses.replace(shooting, method="multiple")
        for k, (r, rd) in enumerate(pairs):
            if rd.method == "single" and experiment_of(r) in shaky:
                again = _prepare_run(r, work_model, chans, forced, skipped, input_cutoff)
                if again is not None:
                    again.reason = f"auto: other {experiment_of(r)} runs oscillate ({rd.reason.split(': ', 1)[1]})"
                    pairs[k] = (r, again)
    prepared = [rd for _r, rd in pairs]
    if not prepared:
        why = "; ".join(str(s) for s in skipped[:3])
        raise IdentificationError(f"no run can be used for the grey-box fit: {why}")
    used_ch = tuple(c for c in chans if any(c in rd.y for rd in prepared))
    sigma = {c: float(np.median([rd.sigma[c] for rd in prepared if c in rd.y])) for c in used_ch}

    # start values, bounds, log coordinates
    start = np.empty(len(names))
    lo = np.empty(len(names))
    hi = np.empty(len(names))
    for i, n in enumerate(names):
        v = float(initial[n]) if initial and n in initial else _get(base_model.params, n)
        if v > 0:
            b = (v / 10.0, v * 10.0)
        elif n in _ZERO_BASE:
            b = _ZERO_BASE[n][:2]
            v = _ZERO_BASE[n][2]
        else:
            raise IdentificationError(
                f"{n} starts at {v:g}; give a positive start with initial={{'{n}': ...}}"
            )
        if bounds and n in bounds:
            pair = tuple(bounds[n])
            if len(pair) != 2:
                raise IdentificationError(f"bounds of {n} must be a (low, high) pair, got {pair!r}")
            b = (float(pair[0]), float(pair[1]))
        if not (0 < b[0] < b[1] and math.isfinite(b[1])):
            raise IdentificationError(
                f"bounds of {n} {b} must be positive and increasing (the fit uses log scales)"
            )
        lo[i], hi[i] = b
        start[i] = min(max(v, b[0]), b[1])
    # coordinates θ = ln(p/p_start): every parameter starts at 0 and moves in relative terms
    ref = start.copy()
    tlo, thi = np.log(lo / ref), np.log(hi / ref)
    prob = _Problem(work_model, prepared, names, used_ch, rtol, jobs, sigma)
    prob.fd_step = fd_step
    prob.ref = ref

    state: dict[str, Any] = {}
    # locating stage: with friction free, the single-shooting cost of smooth runs is a narrow
    # well in F_s on a plateau (each stick at a reversal shifts the phase of the rest of the
    # segment; measured on the sine runs: cost ×3.4 at F_s −10 %, flat beyond), so a start
    # 15 % off ends on the plateau. Windows of multiple shooting re-start from the measured
    # state every 20 ms: their cost is smooth in the friction and finds the well, then the
    # single-shooting stages (coarse, then full) refine from there (the windows' noisy
    # initial states bias E by ~1 %, so they only locate).
    locate_prob = None
    if (
        shooting.method == "auto"
        and any(n in _STICK for n in names)
        and any(rd.method == "single" for rd in prepared)
    ):
        windowed = dataclasses.replace(shooting, method="multiple")
        located = [
            rd
            for r, _rd in pairs
            if (rd := _prepare_run(r, work_model, used_ch, windowed, [], input_cutoff)) is not None
        ]
        if located:
            locate_prob = _Problem(work_model, located, names, used_ch, rtol, jobs, sigma)
            locate_prob.fd_step, locate_prob.ref = fd_step, ref
    # coarse stage: every ``coarse``-th segment of each run (offset per run, so that the
    # subset covers every phase of the inputs); it does the long walk from the start at a
    # fraction of the simulations, and the full data only refine. After a locating stage the
    # walk is short and every 2·coarse-th segment does it (benchmark: 54 s against 78 s, the
    # same optimum)
    coarse_prob = None
    n_seg = sum(len(rd.segments) for rd in prepared)
    stride = 2 * coarse if locate_prob is not None else coarse
    if coarse > 1 and n_seg >= 4 * stride:
        sub = [
            dataclasses.replace(rd, segments=rd.segments[(k % stride) % len(rd.segments) :: stride])
            for k, rd in enumerate(prepared)
        ]
        coarse_prob = _Problem(work_model, sub, names, used_ch, rtol, jobs, sigma)
        coarse_prob.fd_step, coarse_prob.ref = fd_step, ref
    current = [prob]

    def jac(theta):
        # Broyden between finite-difference refreshes: an update costs no simulation
        prob = current[0]
        r_new = prob.fun(theta)
        calls = state.get("calls", 0)
        state["calls"] = calls + 1
        if calls % max(refresh, 1) == 0 or "J" not in state:
            if differences == "central":
                J = prob.jac(theta, fd_step, central=True)
                state["central"] = (theta.copy(), J)
            else:
                J = prob.jac(theta, fd_step, r0=r_new)
        else:
            J = state["J"].copy()
            d = theta - state["theta"]
            dd = float(d @ d)
            if dd > 0:
                J += np.outer(r_new - state["r"] - J @ d, d) / dd
        state.update(J=J, theta=theta.copy(), r=r_new.copy())
        return J

    rng = np.random.default_rng(seed)
    theta_starts = [np.clip(np.zeros(len(names)), tlo + 1e-9, thi - 1e-9)]
    for _ in range(max(0, starts - 1)):  # within ×/÷ 3 of the start and inside the bounds
        theta_starts.append(
            rng.uniform(np.maximum(tlo, -math.log(3.0)), np.minimum(thi, math.log(3.0)))
        )
    best = None
    best_state: dict[str, Any] | None = None

    def _solve(problem: Any, theta0: Any, tol: float | None = None) -> Any:
        """One least-squares stage with the fit's settings (``tol``: a locating stage's
        relative step and cost tolerance, instead of ``xtol`` and 1e-6)."""
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            return optimize.least_squares(
                problem.fun,
                theta0,
                jac=jac,
                bounds=(tlo, thi),
                loss=loss,
                f_scale=f_scale,
                x_scale=x_scale,
                max_nfev=max_nfev,
                xtol=xtol if tol is None else tol,
                ftol=1e-6 if tol is None else tol,
                gtol=1e-8,
                verbose=verbose,
            )

    def restart(theta0: np.ndarray) -> Any:
        state.clear()
        return _solve(prob, np.clip(theta0, tlo + 1e-9, thi - 1e-9))

    def loss_cost(r: np.ndarray) -> float:
        return _loss_cost(r, loss, f_scale)

    starts_log = []
    for th0 in theta_starts:
        th, coarse_nfev, locate_nfev = th0, 0, 0
        if locate_prob is not None:
            state.clear()
            current[0] = locate_prob
            sol_l = _solve(locate_prob, th0, tol=1e-2)  # 1 %: it only locates the well
            th, locate_nfev = sol_l.x, int(sol_l.nfev + (sol_l.njev or 0))
            # the windows' F_c follows their smoothed initial velocity (±10–20 %), and the
            # single-shooting cost has a minimum per stick pattern: from a located point in
            # the wrong one the fit stopped at F_c +12 … +19 %, costs above the truth's.
            # The single-shooting cost along each stick parameter's valley picks the basin
            th, n_scan = _valley_scan(
                coarse_prob or prob,
                th,
                sol_l.jac,
                [i for i, n in enumerate(names) if n in _STICK],
                tlo,
                thi,
                loss_cost,
            )
            locate_nfev += n_scan
        if coarse_prob is not None:
            state.clear()
            current[0] = coarse_prob
            sol0 = _solve(coarse_prob, th)
            th, coarse_nfev = sol0.x, int(sol0.nfev + (sol0.njev or 0))
        state.clear()
        current[0] = prob
        sol = _solve(prob, th)
        sol, restarts = _restart_from_probes(prob, sol, restart, loss_cost)
        starts_log.append(
            {
                "start": dict(zip(names, prob.values(th0).tolist(), strict=True)),
                "value": dict(zip(names, prob.values(sol.x).tolist(), strict=True)),
                "cost": float(sol.cost),
                "status": int(sol.status),
                "nfev": int(sol.nfev),
                "coarse_evaluations": coarse_nfev,
                "locate_evaluations": locate_nfev,
                "restarts": restarts,
            }
        )
        if best is None or sol.cost < best[0].cost:
            best = (sol, _loss_cost(prob.fun(th0), loss, f_scale))
            best_state = dict(state)
    assert best is not None  # theta_starts holds at least the base start
    sol, initial_cost = best
    theta = sol.x

    # uncertainty at the optimum: central differences, loss weights, Newey–West per stream
    r = prob.fun(theta)
    # the last iteration's central Jacobian is the one wanted here when it was taken at θ
    last = (best_state or {}).get("central")
    if last is not None and np.array_equal(last[0], theta):
        J = last[1]
    else:
        J = prob.jac(theta, fd_step, central=True)
    cv = _covariance(
        prob, theta, r, J, loss, f_scale, nuisance_draws, np.random.default_rng([seed, 19])
    )
    Jw, rw, H, Hinv, cov, taus = cv.Jw, cv.rw, cv.H, cv.Hinv, cv.cov, cv.taus
    n_res = r.size
    s2 = float(rw @ rw) / max(n_res - len(names), 1)
    naive = np.diag(Hinv) * s2
    with np.errstate(invalid="ignore", divide="ignore"):
        inflation = np.diag(cov) / naive
        sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        corr = cov / np.outer(sd, sd)
    z = float(stats.norm.ppf(0.5 + 0.5 * level))
    values = prob.values(theta)

    estimates: dict[str, ParameterEstimate] = {}
    at_bound = []
    for i, n in enumerate(names):
        comp, fld = n.split(".", 1)
        unit = (FIELD_UNITS.get(comp, {}).get(fld) or "").replace("**", "^")
        estimates[n] = ParameterEstimate(
            float(values[i]),
            float(values[i] * sd[i]),
            (float(values[i] * np.exp(-z * sd[i])), float(values[i] * np.exp(z * sd[i]))),
            unit,
            level,
        )
        if theta[i] - tlo[i] < 1e-3 or thi[i] - theta[i] < 1e-3:
            at_bound.append(n)
    # the Gauss–Newton step still left at the end, in standard errors: an optimiser that
    # stopped on its step tolerance in a narrow valley (integrator jitter, curvature) is not
    # at the optimum, and no covariance of the residuals shows how far it is; a parameter
    # that the remaining step would move by more than one standard error is not converged
    free_i = np.array([n not in at_bound for n in names])
    remaining = np.zeros(len(names))
    if free_i.any():
        Hf = H[np.ix_(free_i, free_i)]
        remaining[free_i] = -np.linalg.pinv(Hf) @ (Jw[:, free_i].T @ rw)
    with np.errstate(invalid="ignore", divide="ignore"):
        remaining_sd = np.abs(remaining) / sd
    unconverged = [n for i, n in enumerate(names) if remaining_sd[i] > 1.0]
    # the distance still to go is part of the estimate's error, and no residual covariance
    # holds it: add the remaining step to the covariance (rank one, a bias²-term), so that
    # the interval reaches where the optimiser would still go (negligible once converged)
    if np.any(remaining != 0.0):
        cov = cov + np.outer(remaining, remaining)
        with np.errstate(invalid="ignore", divide="ignore"):
            inflation = np.diag(cov) / naive
            sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
            corr = cov / np.outer(sd, sd)
        for i, n in enumerate(names):
            estimates[n] = _estimate(estimates[n], values[i], sd[i], z * sd[i], z * sd[i])
    # the profile statistic's scale: the sandwich variance over the unit-noise one (H⁻¹),
    # before the scan widens the covariance (the profiles' threshold)
    kappa = _kappa(cov, Hinv)
    # the intervals against the cost itself: where it rises slower along a parameter's valley
    # than the quadratic, the interval widens to where it reaches the threshold
    scan: dict[str, tuple[float, float]] = {}
    widened: list[str] = []
    # the sliding stage refits all but the breakaway parameters (see ``sliding``)
    stretches: tuple[Any, float, list[_RunData]] | dict[str, Any] = {}
    if sliding and "friction.coulomb" in names:
        stretches = _sliding_runs(
            pairs,
            work_model,
            prob.params_at(values),
            sum(n not in _BREAKAWAY for n in names),
            used_ch,
            shooting,
            input_cutoff,
        )
    if scan_intervals:
        # parameters the sliding stage refits are scanned there, on its own cost
        only = (
            [i for i, n in enumerate(names) if n in _BREAKAWAY]
            if isinstance(stretches, tuple)
            else None
        )
        cov, half_lo, half_hi, scan_i = _scan_widen(
            prob, theta, Hinv, cov, z, tlo, thi, loss_cost, only=only
        )
        scan = {names[i]: q for i, q in scan_i.items()}
        widened = [n for i, n in enumerate(names) if max(half_lo[i], half_hi[i]) > z * sd[i]]
        sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        with np.errstate(invalid="ignore", divide="ignore"):
            inflation = np.diag(cov) / naive
        for i, n in enumerate(names):
            if n in widened:
                estimates[n] = _estimate(estimates[n], values[i], sd[i], half_lo[i], half_hi[i])
    # the sliding stage: everything but the breakaway parameters again, from the sliding
    # stretches alone (the stick events' runaway dominates the full cost's F_c)
    sliding_info: dict[str, Any] = {}
    stage2: _Sliding | None = None
    if isinstance(stretches, dict):
        sliding_info = stretches
    else:
        got = _sliding_stage(
            stretches,
            names,
            values,
            cov,
            lo,
            hi,
            used_ch,
            sigma,
            {
                "rtol": rtol,
                "jobs": jobs,
                "fd_step": fd_step,
                "loss": loss,
                "f_scale": f_scale,
                "x_scale": x_scale,
                "max_nfev": max_nfev,
                "xtol": xtol,
                "nuisance_draws": nuisance_draws,
                "rng": np.random.default_rng([seed, 20]),
            },
            z,
            scan_intervals,
            loss_cost,
        )
        stage2 = got
        sliding_info = got.info
        idx = got.index
        values = values.copy()
        values[idx] = got.prob.values(got.theta)
        cov = got.cov
        sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        with np.errstate(invalid="ignore", divide="ignore"):
            inflation = np.diag(cov) / naive
            inflation[idx] = np.diag(cov)[idx] / got.naive
            corr = cov / np.outer(sd, sd)
        moved = {names[i] for i in idx}
        scan = {n: q for n, q in scan.items() if n not in moved}
        scan.update({names[idx[k]]: q for k, q in got.scan.items()})
        widened = [n for n in widened if n not in moved]
        for k, i in enumerate(idx):
            n = names[i]
            h_lo = max(float(got.half_lo[k]), z * sd[i])
            h_hi = max(float(got.half_hi[k]), z * sd[i])
            estimates[n] = _estimate(estimates[n], values[i], sd[i], h_lo, h_hi)
        widened += [names[idx[k]] for k in got.widened]
        # convergence of the refitted parameters is the sliding stage's
        unconverged = [n for n in unconverged if n not in moved]
        for k, i in enumerate(idx):
            remaining_sd[i] = got.left_sd[k]
            if got.left_sd[k] > 1.0:
                unconverged.append(names[i])
        unconverged = [n for n in names if n in unconverged]
    if unconverged:
        warnings.warn(
            "the fit stopped before its optimum along "
            + ", ".join(
                f"{n} (a further {remaining_sd[names.index(n)]:.3g} std)" for n in unconverged
            )
            + "; their intervals are not trustworthy: refit from the result, with more starts, "
            "or free fewer parameters",
            IdentificationWarning,
            stacklevel=2,
        )
    weak = [
        n
        for i, n in enumerate(names)
        if n in at_bound or n in unconverged or z * sd[i] > math.log(1.5)
    ]

    # identifiability: eigen-directions of H (scaled to the covariance), correlated pairs, advice
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
    ident = Identifiability(cond, directions, correlated, weak, advice, unconverged)

    # profiles of weak parameters
    if profile == "weak":
        to_profile = weak
    elif profile == "all":
        to_profile = list(names)
    elif profile in ("none", None):
        to_profile = []
    else:
        to_profile = [n for n in expand_free(profile, base_model.params) if n in names]
    # the profile's χ² threshold scaled by κ (before the scan widened the covariance)
    profiles = {}
    for n in to_profile:
        i = names.index(n)
        if stage2 is not None and i in stage2.index:
            # a parameter of the sliding stage: its profile on the sliding stretches
            k = stage2.index.index(i)
            profiles[n] = _profile(
                stage2.prob,
                stage2.theta,
                k,
                stage2.tlo,
                stage2.thi,
                loss,
                f_scale,
                stage2.cost,
                float(stage2.kappa[k]),
                z,
                float(sd[i]),
            )
        else:
            profiles[n] = _profile(
                prob, theta, i, tlo, thi, loss, f_scale, sol.cost, float(kappa[i]), z, float(sd[i])
            )

    # per-run diagnostics and channels for the figures
    sims = prob.simulate_all(values)
    run_fits = []
    for ri, rd in enumerate(prepared):
        tt = np.full(rd.t.size, np.nan)
        meas = {c: np.full(rd.t.size, np.nan) for c in rd.y}
        simd = {c: np.full(rd.t.size, np.nan) for c in rd.y}
        for si, seg in enumerate(rd.segments):
            # keep one NaN between windows so that plots break the line
            sl = slice(seg.i0, seg.i1 - 1 if rd.method == "multiple" else seg.i1)
            tt[sl] = rd.t[sl]
            for c in rd.y:
                meas[c][sl] = rd.y[c][sl]
                simd[c][sl] = sims[ri][si][c][: sl.stop - sl.start]
        rms = {c: float(np.sqrt(np.nanmean((simd[c] - meas[c]) ** 2))) for c in rd.y}
        neff = {}
        for c in rd.y:
            ns = [
                (n, tau)
                for (r_i, _s, cc, _p, n), tau in zip(prob.streams, taus, strict=True)
                if r_i == ri and cc == c
            ]
            neff[c] = float(sum(n / tau for n, tau in ns))
        run_fits.append(
            RunFit(
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
        )

    # the fitted values in the base parameters (the supply and load damping as the user gave them)
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
    meta["greybox"] = {
        "model": base_model.name,
        "free": list(names),
        "runs": [rd.name for rd in prepared],
        "cost": float(sol.cost),
        "status": int(sol.status),
        **(
            {"sliding": {k: v for k, v in sliding_info.items() if k != "runs"}}
            if sliding_info
            else {}
        ),
    }
    fitted = dataclasses.replace(fitted, meta=meta)
    if prob.failures:
        warnings.warn(
            f"{prob.failures} simulation(s) failed during the fit (held at their last value); "
            "check the bounds",
            IdentificationWarning,
            stacklevel=2,
        )
    return GreyBoxFit(
        params_=fitted,
        free=names,
        estimates_=estimates,
        covariance_=cov,
        correlation_=corr,
        inflation_=inflation,
        success=bool(sol.success),
        status=int(sol.status),
        message=_CONVERGENCE.get(int(sol.status), sol.message),
        nfev=int(sol.nfev),
        njev=int(sol.njev or 0),
        cost=float(sol.cost),
        initial_cost=float(initial_cost),
        runs_=run_fits,
        profiles_=profiles,
        identifiability_=ident,
        starts_=starts_log,
        model=base_model.name,
        optimizer_=OptimizerStatus(
            success=bool(sol.success),
            message=_CONVERGENCE.get(int(sol.status), str(sol.message)),
            nfev=int(sol.nfev),
            nit=int(sol.njev or 0),
        ),
        skipped_=skipped,
        wall_time=_time.perf_counter() - t_start,
        level=level,
        interval_scan_=scan,
        widened_=widened,
        sliding_=sliding_info,
    )


def _profile(
    prob: _Problem,
    theta: np.ndarray,
    i: int,
    tlo,
    thi,
    loss,
    f_scale,
    cost0,
    kappa,
    z,
    sd,
    n_points: int = 9,
) -> Profile:
    """Cost along parameter i, the others refitted (few iterations) from the optimum.

    The grid spans ±2z standard deviations of ln p (at least ±0.1 %, at most ×/÷ 20, inside
    the bounds), so a well-determined parameter's interval is resolved by a few points and a
    weak one's profile reaches its bounds.
    """
    span = min(max(2.0 * z * sd, 1e-3), 3.0) if math.isfinite(sd) else 3.0
    grid = np.linspace(max(tlo[i], theta[i] - span), min(thi[i], theta[i] + span), n_points)
    others = [k for k in range(theta.size) if k != i]
    vals = []
    for g in grid:
        th = theta.copy()
        th[i] = g
        if others:

            def f(sub, th=th):
                full = th.copy()
                full[others] = sub
                return prob.fun(full)

            def jsub(sub, th=th):
                full = th.copy()
                full[others] = sub
                return prob.jac(full, prob.fd_step, r0=prob.fun(full))[:, others]

            sol = optimize.least_squares(
                f,
                theta[others],
                jac=jsub,
                bounds=(tlo[others], thi[others]),
                loss=loss,
                f_scale=f_scale,
                max_nfev=8,
                xtol=1e-3,
                ftol=1e-4,
            )
            c = float(sol.cost)
        else:
            c = _loss_cost(prob.fun(th), loss, f_scale)
        vals.append(2.0 * (c - cost0) / kappa)
    vals_a = np.maximum(np.asarray(vals), 0.0)
    ok = vals_a <= z**2
    pv = prob.ref[i] * np.exp(grid)
    ci = (float(pv[ok][0]), float(pv[ok][-1])) if ok.any() else (math.nan, math.nan)
    return Profile(prob.free[i], pv, vals_a, ci)
