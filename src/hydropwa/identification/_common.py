"""Shared pieces of the identification layer: warnings, skipped runs, run access, statistics.

Nothing here knows about a particular experiment. The estimators in ``_frf``,
``_deadzone`` and ``_friction`` use these helpers to read runs, to skip bad
runs loudly (a :class:`IdentificationWarning` *and* an entry in ``skipped_``)
and to turn a least-squares Jacobian into standard errors and confidence
intervals.
"""

from __future__ import annotations

import dataclasses
import math
import os
import warnings
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
from scipy import stats

from .._errors import DataError, HydropwaError, IdentificationError, ParameterError
from .._result import ResultMixin, ResultStatus, estimate_rows

__all__ = [
    "IdentificationWarning",
    "OptimizerStatus",
    "RigGeometry",
    "SkippedRun",
    "ParameterEstimate",
    "PHYSICAL_BOUNDS",
    "within_physical_bounds",
    "TRUTH_OUTSIDE",
    "truth_in_interval",
    "covariance_from_jacobian",
    "sandwich_covariance",
    "as_runs",
    "experiment_of",
    "signal_value",
    "EXPERIMENT_ALIASES",
    "ESTIMATOR_CHANNELS",
    "estimator_view",
    "screen_for_estimator",
]


class IdentificationWarning(UserWarning):
    """A run was skipped or a result is weakly determined; the message says which and why."""


@dataclasses.dataclass(frozen=True)
class OptimizerStatus:
    """How the optimiser behind a fit ended (as scipy's ``OptimizeResult`` says it).

    Attributes
    ----------
    success : bool
        Whether the optimiser reports convergence (for a closed-form or linear fit: ``True``).
    message : str
        The optimiser's own one-line reason for stopping.
    nfev : int
        Number of evaluations of the objective (residual) function [1].
    nit : int or None
        Number of iterations [1] where the optimiser counts them (``None`` for
        ``least_squares``, which reports only evaluations).
    """

    success: bool
    message: str
    nfev: int
    nit: int | None = None

    @classmethod
    def from_scipy(cls, res: Any) -> OptimizerStatus:
        """The status of a scipy ``OptimizeResult`` (``least_squares``, ``minimize``, ...)."""
        nit = getattr(res, "nit", None)
        return cls(
            success=bool(getattr(res, "success", True)),
            message=str(getattr(res, "message", "")),
            nfev=int(getattr(res, "nfev", 0) or 0),
            nit=None if nit is None else int(nit),
        )

    @classmethod
    def closed_form(cls, what: str = "closed-form (linear) solution") -> OptimizerStatus:
        """The status of a fit solved in one step (linear least squares, a formula)."""
        return cls(success=True, message=what, nfev=1, nit=None)

    @property
    def name(self) -> str:
        """``SUCCESS`` or ``NOT_CONVERGED`` (the :class:`~hydropwa._result.ResultStatus` names),
        so this is a :class:`~hydropwa._result.Status` like every result's ``status``."""
        return ResultStatus.SUCCESS.name if self.success else ResultStatus.NOT_CONVERGED.name

    def __str__(self) -> str:
        it = "" if self.nit is None else f", {self.nit} iterations"
        ok = "converged" if self.success else "NOT converged"
        return f"{ok}: {self.message} ({self.nfev} evaluations{it})"


class FitResult(ResultMixin):
    """The result protocol (:class:`hydropwa._result.Result`) for a fit whose ``status`` is an
    :class:`OptimizerStatus` and whose values are :class:`ParameterEstimate` s.

    A fit names its estimates in ``_estimates()``; ``success``, ``message``, ``summary()``,
    ``to_pandas()``, ``plot()`` and ``_repr_html_()`` follow from them.
    """

    status: OptimizerStatus

    def _estimates(self) -> dict[str, ParameterEstimate]:
        raise NotImplementedError

    @property
    def success(self) -> bool:
        """Whether the optimiser converged."""
        return self.status.success

    @property
    def message(self) -> str:
        """The optimiser's reason for stopping and, where it did not converge, what to do."""
        if self.status.success:
            return self.status.message
        return f"{self.status.message}; {ResultStatus.NOT_CONVERGED.message}"

    def _summary_rows(self) -> list[tuple[str, Any, str]]:
        return estimate_rows(self._estimates())

    def to_pandas(self) -> Any:
        """One row per estimate: ``value``, ``std``, ``ci_low``, ``ci_high`` (SI) and ``unit``."""
        import pandas as pd  # deferred: pandas costs ~0.3 s at import

        est = self._estimates()
        df = pd.DataFrame(
            [
                {
                    "value": e.value,
                    "std": e.std,
                    "ci_low": e.ci[0],
                    "ci_high": e.ci[1],
                    "unit": e.unit,
                }
                for e in est.values()
            ],
            index=pd.Index(list(est), name="parameter"),
        )
        df.attrs["units"] = {k: e.unit for k, e in est.items()}
        return df

    def plot(self, *, ax: Any = None) -> Any:
        """Each estimate with its confidence interval (:func:`hydropwa.plotting.plot_estimates`)."""
        from ..plotting import plot_estimates  # deferred: matplotlib loads only when plotting

        return plot_estimates(self._estimates(), title=type(self).__name__, ax=ax)


@dataclasses.dataclass(frozen=True)
class RigGeometry:
    """What an estimator must know of the rig to turn measurements into valve or friction values.

    Give it to an estimator as ``geometry=`` when no full :class:`~hydropwa.params.SystemParams`
    is at hand; :meth:`of` takes it from one. An estimator says which fields it needs and
    raises :class:`~hydropwa.ParameterError` when one of them is missing.

    Attributes
    ----------
    stroke : float
        Cylinder stroke [m] (end-stop detection).
    area_a, area_b : float, optional
        Piston areas [m²] of chambers A and B (net force, Eq. (10)).
    mass : float, optional
        Moving mass [kg] (the m·ẍ term of the instantaneous friction samples).
    """

    stroke: float
    area_a: float | None = None
    area_b: float | None = None
    mass: float | None = None

    def __post_init__(self) -> None:
        for name, unit in (("stroke", "m"), ("area_a", "m²"), ("area_b", "m²"), ("mass", "kg")):
            val = getattr(self, name)
            if val is None:
                continue
            if not (isinstance(val, int | float) and np.isfinite(val) and val > 0):
                raise ParameterError(
                    f"RigGeometry.{name} = {val!r} {unit} must be a positive number"
                )

    @classmethod
    def of(cls, params: Any) -> RigGeometry:
        """Stroke, areas and moving mass of a :class:`~hydropwa.params.SystemParams`."""
        cyl = params.cylinder
        return cls(
            stroke=float(cyl.stroke),
            area_a=float(cyl.area_a),
            area_b=float(cyl.area_b),
            mass=float(params.load.mass),
        )


def resolve_geometry(
    who: str, params: Any, geometry: RigGeometry | None, needs: tuple[str, ...]
) -> RigGeometry:
    """The rig geometry an estimator works with: ``geometry`` if given, else from ``params``.

    There is no default rig: without either, a :class:`~hydropwa.ParameterError` says how to
    give one (identifying the paper rig's values from another rig's data would be silently wrong).
    """
    if geometry is None and params is not None:
        geometry = RigGeometry.of(params)
    if geometry is None:
        raise ParameterError(
            f"{who} needs the rig's {', '.join(needs)}: pass params=SystemParams "
            "(e.g. get_preset('paper') or load_params('rig.toml')) or "
            f"geometry=RigGeometry({', '.join(f'{n}=...' for n in needs)})"
        )
    missing = [n for n in needs if getattr(geometry, n) is None]
    if missing:
        raise ParameterError(
            f"{who} needs RigGeometry.{', '.join(missing)}; give "
            f"{', '.join(f'{n}=...' for n in missing)} or pass params=SystemParams instead"
        )
    return geometry


def not_fitted(who: str) -> IdentificationError:
    """The error for using a learned value before ``fit``."""
    return IdentificationError(f"{who} is not fitted yet; call .fit(data) first")


@dataclasses.dataclass(frozen=True)
class SkippedRun:
    """A run (or part of one) left out of an identification, and why.

    Attributes
    ----------
    run : str
        Run name (with a segment suffix such as ``"@12Hz"`` where only part was dropped).
    reason : str
        One line saying what was wrong (missing channel, too short, end stop, ...).
    """

    run: str
    reason: str

    def __str__(self) -> str:
        return f"{self.run}: {self.reason}"


def skip(skipped: list[SkippedRun], run: str, reason: str, stacklevel: int = 3) -> None:
    """Record a skipped run and warn about it (never a silent drop)."""
    skipped.append(SkippedRun(run, reason))
    warnings.warn(f"run {run!r} skipped: {reason}", IdentificationWarning, stacklevel=stacklevel)


@dataclasses.dataclass(frozen=True)
class ParameterEstimate:
    """One identified parameter with its uncertainty.

    Attributes
    ----------
    value : float
        Estimate [unit].
    std : float
        Standard error [unit] (from the Jacobian; NaN when not determined).
    ci : tuple of float
        Confidence interval (low, high) [unit] at ``level``.
    unit : str
        Unit of value, std and ci.
    level : float
        Confidence level of ``ci`` [1].
    clipped : str
        ``""``, or which end of ``ci`` was cut at the parameter's physical bound
        (:data:`PHYSICAL_BOUNDS`, :func:`within_physical_bounds`): ``"low"``, ``"high"`` or
        ``"low, high"``. The interval before the cut reached where the parameter has no
        meaning (a Coulomb force below 0 N); the cut one is what the data allow.
    """

    value: float
    std: float
    ci: tuple[float, float]
    unit: str = ""
    level: float = 0.95
    clipped: str = ""

    @property
    def relative_ci_halfwidth(self) -> float:
        """Half the CI width over |value| [1]; ``inf`` for a zero estimate."""
        half = 0.5 * (self.ci[1] - self.ci[0])
        return float(half / abs(self.value)) if self.value != 0 else float("inf")

    def to_dict(self) -> dict[str, Any]:
        """Plain dict for the ``[uncertainty]`` table of a parameter file."""
        return {
            "value": float(self.value),
            "std": float(self.std),
            "ci_low": float(self.ci[0]),
            "ci_high": float(self.ci[1]),
            "level": float(self.level),
            "unit": self.unit,
        } | ({"clipped": self.clipped} if self.clipped else {})

    def __str__(self) -> str:
        cut = f", clipped at its physical bound ({self.clipped})" if self.clipped else ""
        return f"{self.value:.5g} {self.unit} (±{self.std:.2g}, CI [{self.ci[0]:.5g}, {self.ci[1]:.5g}]{cut})".strip()

    def within(self, low: float, high: float) -> ParameterEstimate:
        """The estimate with its interval cut to [``low``, ``high``] (in its unit) and the cut ends
        named in ``clipped`` (itself where nothing is cut)."""
        lo, hi = self.ci
        cut = [end for end, out in (("low", lo < low), ("high", hi > high)) if out]
        if not cut:
            return self
        done = [e for e in self.clipped.split(", ") if e]
        return dataclasses.replace(
            self,
            ci=(max(lo, low), min(hi, high)),
            clipped=", ".join(dict.fromkeys(done + cut)),
        )


#: Physical bounds [SI] of identified quantities, by the name's last dotted part (``coulomb``
#: and ``friction.coulomb`` alike): outside them the parameter has no meaning, so an interval
#: is cut there (:func:`within_physical_bounds`). Forces and coefficients of a dissipation
#: (friction, leakage) and rates (ω0, a Stribeck velocity, a shape exponent) are not negative;
#: the mass, the bulk modulus and the flow gain are positive; a dead-zone offset is a share of
#: the opening, 0 … 1.
PHYSICAL_BOUNDS: dict[str, tuple[float, float]] = {
    **dict.fromkeys(
        (
            "coulomb",
            "static",
            "viscous",
            "stribeck_velocity",
            "shape",
            "smoothness",
            "breakaway",
            "omega0",
            "zeta",
            "mass",
            "bulk_modulus",
            "K",
            "leakage",
            "gain_pos",
            "gain_neg",
        ),
        (0.0, math.inf),
    ),
    **dict.fromkeys(("beta", "beta_pos", "beta_neg", "inner_offset", "outer_offset"), (0.0, 1.0)),
}


def within_physical_bounds(name: str, est: ParameterEstimate) -> ParameterEstimate:
    """``est`` with its interval cut to ``name``'s :data:`PHYSICAL_BOUNDS` (flagged in
    ``clipped``); unchanged for a name without bounds."""
    bounds = PHYSICAL_BOUNDS.get(name.rsplit(".", 1)[-1])
    return est if bounds is None else est.within(*bounds)


#: the verdict of :func:`truth_in_interval` on an interval that misses a known truth
TRUTH_OUTSIDE = "no: outside"


def truth_in_interval(low: float, high: float, true: float | None) -> str:
    """Whether a known true value (a virtual rig's ``true_params.toml``) lies in an interval.

    The one rule every table that shows an interval beside a truth applies: ``"yes"``,
    :data:`TRUTH_OUTSIDE` (``"no: outside"``), or ``""`` where the truth or an end of the
    interval is unknown (NaN, None); an infinite end (a parameter not determined on that
    side) holds every truth beyond it.

    Parameters
    ----------
    low, high : float
        The interval's ends [unit of the parameter].
    true : float or None
        The true value [same unit].
    """
    if true is None or any(math.isnan(float(x)) for x in (low, high, true)):
        return ""
    return "yes" if float(low) <= float(true) <= float(high) else TRUTH_OUTSIDE


def covariance_from_jacobian(
    jac: np.ndarray, residuals: np.ndarray, n_params: int | None = None
) -> np.ndarray:
    """Parameter covariance s²·(JᵀJ)⁻¹ of a least-squares fit.

    Parameters
    ----------
    jac : ndarray, shape (n, p)
        Jacobian of the residuals at the optimum.
    residuals : ndarray, shape (n,)
        Residuals at the optimum (their variance s² = ‖r‖²/(n − p) scales the result).
    n_params : int, optional
        Number of free parameters p (default ``jac.shape[1]``).

    Returns
    -------
    ndarray, shape (p, p)
        Covariance from the SVD of J; parameters in a direction the data do not
        determine (singular value below 1e-10 of the largest) get an infinite
        variance and NaN covariances.
    """
    jac = np.asarray(jac, dtype=float)
    r = np.asarray(residuals, dtype=float)
    n, p = jac.shape
    p = n_params or p
    dof = max(n - p, 1)
    s2 = float(r @ r) / dof
    _, sv, vt = np.linalg.svd(jac, full_matrices=False)
    tol = sv.max() * max(jac.shape) * 1e-10 if sv.size and sv.max() > 0 else 0.0
    good = sv > tol
    cov = (vt[good].T / sv[good] ** 2) @ vt[good] * s2
    # directions the data do not see at all get an infinite variance, not a zero one
    unseen = (
        np.any(np.abs(vt[~good]) > 1e-6, axis=0) if (~good).any() else np.zeros(vt.shape[1], bool)
    )
    if unseen.any():
        cov[unseen, :] = np.nan
        cov[:, unseen] = np.nan
        cov[unseen, unseen] = np.inf
    return cov


def sandwich_covariance(jac: np.ndarray, residuals: np.ndarray) -> np.ndarray:
    """Heteroskedasticity-robust (sandwich, HC3) covariance of a least-squares fit.

    Parameters
    ----------
    jac : ndarray, shape (n, p)
        Jacobian of the residuals at the optimum.
    residuals : ndarray, shape (n,)
        Residuals at the optimum.

    Returns
    -------
    ndarray, shape (p, p)
        (JᵀJ)⁻¹ Jᵀ diag(r²/(1 − h)²) J (JᵀJ)⁻¹ with the leverages h of the points (HC3,
        MacKinnon & White 1985: the small-sample form; HC1's n/(n − p) covers 92 % instead of
        95 % with 40 points, tested), from the SVD of J; a direction the data do not
        determine gets an infinite variance (as :func:`covariance_from_jacobian`). Never
        narrower, per parameter, than s²(JᵀJ)⁻¹.

    Notes
    -----
    s²(JᵀJ)⁻¹ assumes every residual has the same variance and that the model is exact.
    Where points differ in quality (slow runs, bins of low coherence) or the model misses
    the data by more at some points than at others, it is too narrow; the sandwich form
    takes each point's own squared residual, so its intervals hold under both (White 1980).
    Each residual here is one run (or one frequency), so it is a run-level estimate.
    """
    jac = np.asarray(jac, dtype=float)
    r = np.asarray(residuals, dtype=float)
    n, p = jac.shape
    _, sv, vt = np.linalg.svd(jac, full_matrices=False)
    tol = sv.max() * max(jac.shape) * 1e-10 if sv.size and sv.max() > 0 else 0.0
    good = sv > tol
    pinv_t = (vt[good].T / sv[good] ** 2) @ vt[good]  # (JᵀJ)⁻¹ on the seen subspace
    lev = np.clip(np.einsum("ij,jk,ik->i", jac, pinv_t, jac), 0.0, 0.99)  # leverages h_ii
    meat = (jac * (r / (1.0 - lev))[:, None] ** 2).T @ jac
    cov = pinv_t @ meat @ pinv_t
    # never narrower than the homoskedastic estimate: with few points the sandwich's own
    # spread can make it smaller by chance
    cov_h = covariance_from_jacobian(jac, r)
    fin = np.isfinite(np.diag(cov_h))
    if fin.all():
        if np.all(np.diag(cov_h) > np.diag(cov)):
            cov = cov_h
        else:
            scale = np.sqrt(
                np.maximum(np.diag(cov_h), np.diag(cov)) / np.maximum(np.diag(cov), 1e-300)
            )
            cov = cov * np.outer(scale, scale)
    else:
        cov = cov_h
    return cov


def combination_std(cov: np.ndarray, grad: np.ndarray) -> float:
    """Standard deviation of the linear combination ``grad @ θ`` under covariance ``cov``.

    Parameters
    ----------
    cov : ndarray, shape (p, p)
        Covariance of the estimates; an undetermined parameter has an infinite variance and
        NaN covariances (:func:`covariance_from_jacobian`).
    grad : ndarray, shape (p,)
        Weights of the combination (the gradient of a derived quantity, delta method).

    Returns
    -------
    float
        ``sqrt(gradᵀ·cov·grad)`` over the parameters with a non-zero weight; ``inf`` where one
        of them is undetermined (never NaN), and never negative from round-off.
    """
    g = np.asarray(grad, dtype=float)
    used = np.flatnonzero(g)
    sub = np.asarray(cov, dtype=float)[np.ix_(used, used)]
    if not np.all(np.isfinite(sub)):
        return float("inf")
    return float(np.sqrt(max(float(g[used] @ sub @ g[used]), 0.0)))


def t_quantile(level: float, dof: int) -> float:
    """Two-sided Student-t quantile for a confidence ``level`` with ``dof`` degrees of freedom."""
    return float(stats.t.ppf(0.5 + 0.5 * level, max(int(dof), 1)))


def estimate(
    value: float, std: float, q: float, unit: str = "", level: float = 0.95
) -> ParameterEstimate:
    """A :class:`ParameterEstimate` with the symmetric interval value ± q·std."""
    std = float(std)  # inf stays inf: a parameter the data do not determine
    return ParameterEstimate(
        float(value), std, (float(value - q * std), float(value + q * std)), unit, level
    )


def correlation(cov: np.ndarray) -> np.ndarray:
    """Correlation matrix of a covariance (NaN where a variance is zero)."""
    d = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        return cov / np.outer(d, d)


# --------------------------------------------------------------------------- runs

#: Experiment names in run metadata and what the identification calls them.
EXPERIMENT_ALIASES: dict[str, str] = {
    "frf": "frf",
    "stepped_sine": "frf",
    "valve_frf": "frf",
    "sine_sweep": "frf",
    "chirp": "frf",
    "noise": "frf",
    "broadband": "frf",
    "deadzone": "deadzone",
    "dead_zone": "deadzone",
    "dead-zone": "deadzone",
    "friction": "friction",
    "stribeck": "friction",
    "sine": "sine",
    "motion": "sine",
    "closed_loop": "closed_loop",
}


def experiment_of(run) -> str | None:
    """Experiment kind of a run: ``meta["experiment"]`` or ``meta["kind"]``, normalised.

    Returns ``"frf"``, ``"deadzone"``, ``"friction"``, ``"sine"``, another raw
    name, or ``None`` when the run says nothing.
    """
    meta = getattr(run, "meta", {}) or {}
    raw = meta.get("experiment", meta.get("kind"))
    if raw is None:
        return None
    raw = str(raw).lower()
    return EXPERIMENT_ALIASES.get(raw, raw)


def signal_value(run, *keys: str, default: Any = None) -> Any:
    """First of ``keys`` found in ``run.meta``, ``run.meta["signal"]`` or ``run.meta["command"]``.

    Lets the estimators read commanded signal parameters (``frequency`` [Hz],
    ``amplitude`` [1], ``level`` [1], ``type``) wherever a writer put them.
    """
    meta = getattr(run, "meta", {}) or {}
    places = [meta]
    for sub in ("signal", "command", "input"):
        if isinstance(meta.get(sub), Mapping):
            places.append(meta[sub])
    for key in keys:
        for place in places:
            if key in place and place[key] is not None:
                return place[key]
    return default


def as_runs(data, experiment: str | None = None) -> list:
    """Turn the argument of ``fit`` into a list of runs.

    Parameters
    ----------
    data : Dataset, Run, path or iterable of Run
        A :class:`hydropwa.data.Dataset`, a dataset folder, one run, or runs.
    experiment : str, optional
        Keep only runs of this experiment kind (see :func:`experiment_of`) when the
        runs say what they are; runs without a kind are kept.

    Raises
    ------
    IdentificationError
        If nothing is left.
    """
    if isinstance(data, str | os.PathLike):
        from ..data import read_dataset  # deferred: hydropwa.data loads pint

        data = read_dataset(data)
    if hasattr(data, "channels") and hasattr(data, "name"):
        runs = [data]
    elif hasattr(data, "names") and hasattr(data, "__getitem__") and not isinstance(data, Mapping):
        runs = [data[n] for n in data.names]
    elif isinstance(data, Mapping):
        runs = list(data.values())
    elif isinstance(data, Iterable):
        runs = list(data)
    else:
        raise IdentificationError(
            f"cannot identify from {type(data).__name__}; give a Dataset, a Run or runs"
        )
    if experiment is not None:
        runs = [r for r in runs if experiment_of(r) in (None, experiment)]
    if not runs:
        what = f" of kind {experiment!r} (meta 'experiment' or 'kind')" if experiment else ""
        raise IdentificationError(f"no runs{what} to identify from")
    return runs


def channels_of(
    run, names: Iterable[str], skipped: list[SkippedRun]
) -> dict[str, np.ndarray] | None:
    """The named channels of a run as float arrays, or ``None`` (and a skip) if one is missing."""
    missing = [c for c in names if c not in run.channels]
    if missing:
        skip(
            skipped,
            run.name,
            f"missing channel(s) {', '.join(missing)} (has {', '.join(sorted(run.channels))})",
            4,
        )
        return None
    out = {}
    for c in names:
        a = np.asarray(run.channels[c], dtype=float)
        if not np.all(np.isfinite(a)):
            skip(skipped, run.name, f"channel {c!r} holds non-finite samples", 4)
            return None
        out[c] = a
    return out


def require_usable(items: list, skipped: list[SkippedRun], what: str, minimum: int = 1) -> None:
    """Raise a one-line :class:`IdentificationError` when fewer than ``minimum`` items are usable."""
    if len(items) < minimum:
        why = "; ".join(str(s) for s in skipped[:5]) or "no runs given"
        more = f" (and {len(skipped) - 5} more)" if len(skipped) > 5 else ""
        raise IdentificationError(
            f"{what}: {len(items)} usable run(s), need at least {minimum}; skipped: {why}{more}"
        )


def is_hydropwa_error(exc: BaseException) -> bool:
    """Whether ``exc`` is a user error of the package (to be reported, not raised as a bug)."""
    return isinstance(exc, HydropwaError | DataError)


# --------------------------------------------------------------------------- screening

#: Channels each estimator reads (besides ``t``). Screening judges only these, so a chamber
#: at 0 bar in an FRF run (whose estimator reads the spool) does not cost the run.
ESTIMATOR_CHANNELS: dict[str, tuple[str, ...]] = {
    "frf": ("u", "spool"),
    "deadzone": ("u", "x"),
    "friction": ("u", "x", "p_a", "p_b", "f_l"),
}


def estimator_view(run, kind: str | None, stroke: float | None = None, stop_margin: float = 2e-3):
    """The part of a run that the estimator of ``kind`` reads: its channels over its time span.

    Parameters
    ----------
    run : Run
    kind : str or None
        ``"frf"``, ``"deadzone"``, ``"friction"``; any other kind (``"sine"``, ``None``) gives
        the whole run (the evaluation reads every channel).
    stroke : float, optional
        Stroke [m]; for friction runs the samples within ``stop_margin`` [m] of either stop and
        those before ``meta["valve_delay"]`` are outside the span (Eq. (10) is evaluated on the
        steady stretch away from the stops, where a chamber emptied at the stop does not matter).

    Returns
    -------
    Run
        A run with ``t`` and the estimator's channels present in ``run``, cut to the first–last
        sample of the span (contiguous, so the time-base checks still apply).
    """
    from ..data import Run  # deferred: hydropwa.data loads pint

    used = ESTIMATOR_CHANNELS.get(kind or "")
    if used is None:
        return run
    names = ["t"] + [c for c in used if c in run.channels]
    ch = {c: np.asarray(run.channels[c]) for c in names}
    t = ch["t"]
    keep = np.ones(t.size, dtype=bool)
    if kind == "friction" and t.size:
        delay = signal_value(run, "valve_delay", default=0.0)
        try:
            keep &= t >= t[0] + float(delay)
        except (TypeError, ValueError):
            pass
        if stroke is not None and "x" in ch:
            x = np.asarray(ch["x"], dtype=float)
            with np.errstate(invalid="ignore"):
                keep &= (x > stop_margin) & (x < stroke - stop_margin)
    idx = np.flatnonzero(keep)
    if idx.size >= 16 and idx.size < t.size:
        sl = slice(int(idx[0]), int(idx[-1]) + 1)
        ch = {c: v[sl] for c, v in ch.items()}
    units = {c: u for c, u in run.units.items() if c in ch}
    return Run(name=run.name, channels=ch, units=units, fs=run.fs, meta=run.meta)


def screen_for_estimator(
    run,
    kind: str | None,
    stroke: float | None = None,
    limits: Mapping[str, tuple[float, float]] | None = None,
) -> str | None:
    """Why a run is unusable for the estimator of its kind, or ``None`` when it is sound.

    The run's view (:func:`estimator_view`) goes through :func:`hydropwa.data.check_run`
    with the converter limits (``limits``, else the run's ``meta["converter_limits"]``);
    the first error-severity finding is the reason.
    """
    from ..data import check_run, unusable  # deferred: hydropwa.data loads pint

    view = estimator_view(run, kind, stroke)
    lim = run.meta.get("converter_limits") or limits or None
    # a chamber at a gauge sensor's floor is a physical fact for `data check` (a note), but
    # its pressure is unknown there (up to 1 bar under the reading): unusable where read
    errors = [i for i in check_run(view, limits=lim) if unusable(i)]
    if not errors:
        return None
    if view is not run and view.t.size < run.t.size:
        # the span decides whether a channel is bad; the whole record names the fault best
        # (a dropout cut by the span's start looks like a plateau at the channel's extreme)
        cols = {c: run.channels[c] for c in view.channels}
        whole = run.replace(channels=cols, units={c: u for c, u in run.units.items() if c in cols})
        by_channel = {i.channel: i for i in check_run(whole, limits=lim) if unusable(i)}
        errors = [by_channel.get(i.channel, i) for i in errors]
    more = f" (+{len(errors) - 1} more)" if len(errors) > 1 else ""
    return f"bad data: {errors[0]}{more}"
