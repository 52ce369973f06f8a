"""Inverse-dynamics identification (IDIM-LS) of a single-axis machine, and the EMPS benchmark.

The rigid-body model with Coulomb and viscous friction and a force offset,

    F = M q̈ + F_v q̇ + F_c sign(q̇) + offset,

is linear in its parameters, so closed-loop data identify it by linear least
squares once q̇ and q̈ are formed from the measured position: a zero-phase
Butterworth low-pass (``filtfilt``), central differences, and decimation of
every column of the observation matrix and of the force (the decimation filter
removes what the low-pass left above the new Nyquist frequency). This is the
IDIM-LS route of the EMPS benchmark (Janot, Gautier, Brunot 2019), written
generally: any machine whose force (or hydraulic force P_A A_A − P_B A_B − F_L)
and position are measured can use it.
"""

from __future__ import annotations

import dataclasses
import os

import numpy as np
from scipy import signal

from .._errors import IdentificationError
from ..params import Friction
from ._common import ParameterEstimate, correlation, estimate, t_quantile, within_physical_bounds

__all__ = [
    "InverseDynamicsResult",
    "identify_inverse_dynamics",
    "EmpsResult",
    "identify_emps",
    "EMPS_PUBLISHED",
]

#: EMPS_Description.pdf, IDIM-LS: M [kg], F_v [N·s/m], F_c [N], offset [N], relative error [1],
#: cross-test relative error on DATA_EMPS_PULSES.mat [1].
EMPS_PUBLISHED = {
    "mass": 95.1089,
    "viscous": 203.5034,
    "coulomb": 20.3935,
    "offset": -3.1648,
    "relative_error": 0.0408,
    "cross_test_error": 0.0598,
}

_UNITS = {
    "mass": "kg",
    "viscous": "N·s/m",
    "coulomb": "N",
    "offset": "N",
    "coulomb_pos": "N",
    "coulomb_neg": "N",
}


def _derivatives(t: np.ndarray, q: np.ndarray, cutoff: float, order: int):
    """Low-pass (zero phase) position, then central-difference velocity and acceleration."""
    dt = float(np.median(np.diff(t)))
    fs = 1.0 / dt
    if not 0 < cutoff < 0.5 * fs:
        raise IdentificationError(
            f"low-pass cutoff {cutoff:g} Hz must lie below the Nyquist frequency {0.5 * fs:g} Hz"
        )
    b, a = signal.butter(order, cutoff / (0.5 * fs))
    qf = signal.filtfilt(b, a, q)
    dq = np.gradient(qf, dt)  # central differences inside, one-sided at the two ends
    ddq = np.gradient(dq, dt)
    return qf, dq, ddq


def _regressors(
    dq: np.ndarray, ddq: np.ndarray, asymmetric: bool
) -> tuple[np.ndarray, tuple[str, ...]]:
    if asymmetric:
        # the offset is not separable from two Coulomb levels (1{q̇>0} + 1{q̇<0} = 1 almost everywhere)
        cols = [ddq, dq, (dq > 0).astype(float), -(dq < 0).astype(float)]
        return np.column_stack(cols), ("mass", "viscous", "coulomb_pos", "coulomb_neg")
    return np.column_stack([ddq, dq, np.sign(dq), np.ones_like(dq)]), (
        "mass",
        "viscous",
        "coulomb",
        "offset",
    )


@dataclasses.dataclass(frozen=True)
class InverseDynamicsResult:
    """Result of :func:`identify_inverse_dynamics`.

    Attributes
    ----------
    estimates : dict[str, ParameterEstimate]
        ``mass`` M [kg], ``viscous`` F_v [N·s/m], ``coulomb`` F_c [N] (or ``coulomb_pos``,
        ``coulomb_neg`` with ``asymmetric=True``), ``offset`` [N].
    relative_error : float
        ‖F − Wθ‖/‖F‖ on the decimated estimation data [1].
    residual_std : float
        Standard deviation of the decimated force residual [N].
    condition_number : float
        Condition number of the decimated observation matrix [1].
    correlation : ndarray
        Correlation of the estimates [1].
    time, force, predicted : ndarray
        Decimated time [s], measured and predicted force [N] (for plots).
    settings : dict
        Cutoff [Hz], filter order, decimation factor, border [samples], asymmetric.
    """

    estimates: dict[str, ParameterEstimate]
    relative_error: float
    residual_std: float
    condition_number: float
    correlation: np.ndarray
    time: np.ndarray
    force: np.ndarray
    predicted: np.ndarray
    settings: dict

    @property
    def theta(self) -> np.ndarray:
        """Parameter vector in regressor order."""
        return np.array([e.value for e in self.estimates.values()])

    def cross_test(self, t, position, force) -> float:
        """Relative force error [1] of these parameters on other data, processed the same way."""
        s = self.settings
        _, W, y = _observation(
            np.asarray(t, float),
            np.asarray(position, float),
            np.asarray(force, float),
            s["cutoff"],
            s["order"],
            s["decimation"],
            s["border"],
            s["asymmetric"],
        )
        r = y - W @ self.theta
        return float(np.linalg.norm(r) / np.linalg.norm(y))

    def friction(self) -> Friction:
        """Coulomb + viscous friction as a :class:`~hydropwa.params.Friction` (no Stribeck hump).

        With an asymmetric fit the mean of the two Coulomb levels is used.
        """
        e = self.estimates
        fc = (
            e["coulomb"].value
            if "coulomb" in e
            else 0.5 * (e["coulomb_pos"].value + e["coulomb_neg"].value)
        )
        fc = max(fc, 0.0)
        return Friction(
            coulomb=fc,
            static=fc,
            viscous=max(e["viscous"].value, 0.0),
            stribeck_velocity=1e-3,
            shape=1.0,
            smoothness=1e4,
        )


def _observation(t, q, force, cutoff, order, decimation, border, asymmetric):
    if not (t.size == q.size == force.size):
        raise IdentificationError(
            f"t, position and force differ in length ({t.size}, {q.size}, {force.size})"
        )
    if t.size < 2 * border + 30 * max(decimation, 1):
        raise IdentificationError(
            f"{t.size} samples are too few for inverse-dynamics identification"
        )
    for name, a in (("t", t), ("position", q), ("force", force)):
        if not np.all(np.isfinite(a)):
            raise IdentificationError(f"{name} holds non-finite samples")
    _, dq, ddq = _derivatives(t, q, cutoff, order)
    sl = slice(border, None)
    W, names = _regressors(dq[sl], ddq[sl], asymmetric)
    y, td = force[sl], t[sl]
    if decimation > 1:
        W = np.column_stack(
            [
                signal.decimate(W[:, j], decimation, ftype="iir", zero_phase=True)
                for j in range(W.shape[1])
            ]
        )
        y = signal.decimate(y, decimation, ftype="iir", zero_phase=True)
        td = td[::decimation][: y.size]
    return td, W, y


def identify_inverse_dynamics(
    t,
    position,
    force,
    cutoff: float = 100.0,
    order: int = 4,
    decimation: int = 10,
    border: int = 49,
    asymmetric: bool = False,
    level: float = 0.95,
) -> InverseDynamicsResult:
    """Identify M, F_v, F_c and an offset from position and force by IDIM-LS.

    Parameters
    ----------
    t : array_like, shape (N,)
        Uniform time [s].
    position : array_like, shape (N,)
        Position q [m].
    force : array_like, shape (N,)
        Driving force F [N] (motor force; for a cylinder P_A A_A − P_B A_B − F_L).
    cutoff : float
        Butterworth low-pass cutoff [Hz] applied forward and backward to q.
    order : int
        Butterworth order.
    decimation : int
        Decimation factor of the observation matrix and the force (1: none).
    border : int
        Samples dropped at the start (edge effects of filter and differences).
    asymmetric : bool
        Separate Coulomb levels for positive and negative velocity, F_c+ and F_c−
        (the offset is then absorbed in them: F = … + F_c+ for q̇ > 0, − F_c− for q̇ < 0).
    level : float
        Confidence level [1] of the intervals.

    Returns
    -------
    InverseDynamicsResult

    Notes
    -----
    F = M q̈ + F_v q̇ + F_c sign(q̇) + offset (Eq. (10) with Coulomb + viscous friction)
    solved by linear least squares; standard errors std(r)·√diag((WᵀW)⁻¹) as in the
    benchmark's script. Closed-loop data make the noise correlate with the regressors,
    so the intervals are optimistic.
    """
    t = np.asarray(t, dtype=float)
    q = np.asarray(position, dtype=float)
    f = np.asarray(force, dtype=float)
    td, W, y = _observation(t, q, f, cutoff, order, decimation, border, asymmetric)
    _, names = _regressors(np.zeros(1), np.zeros(1), asymmetric)
    theta, *_ = np.linalg.lstsq(W, y, rcond=None)
    r = y - W @ theta
    sd_r = float(np.std(r, ddof=1))
    cov = sd_r**2 * np.linalg.inv(W.T @ W)
    sd = np.sqrt(np.diag(cov))
    q_t = t_quantile(level, y.size - theta.size)
    est = {
        n: within_physical_bounds(n, estimate(theta[i], sd[i], q_t, _UNITS[n], level))
        for i, n in enumerate(names)
    }
    return InverseDynamicsResult(
        estimates=est,
        relative_error=float(np.linalg.norm(r) / np.linalg.norm(y)),
        residual_std=sd_r,
        condition_number=float(np.linalg.cond(W)),
        correlation=correlation(cov),
        time=td,
        force=y,
        predicted=W @ theta,
        settings={
            "cutoff": cutoff,
            "order": order,
            "decimation": decimation,
            "border": border,
            "asymmetric": asymmetric,
        },
    )


@dataclasses.dataclass(frozen=True)
class EmpsResult:
    """IDIM-LS on the EMPS benchmark, with the cross test and the published values.

    Attributes
    ----------
    fit : InverseDynamicsResult
        Estimation on ``DATA_EMPS.mat``.
    cross_test_error : float or None
        Relative force error [1] on the validation file (``DATA_EMPS_PULSES.mat``).
    published : dict
        :data:`EMPS_PUBLISHED`.
    source, validation : str
        File names used.
    """

    fit: InverseDynamicsResult
    cross_test_error: float | None
    published: dict
    source: str
    validation: str | None

    def deviations(self) -> dict[str, float]:
        """Relative deviation (estimate − published)/|published| [1] per parameter."""
        return {
            k: (self.fit.estimates[k].value - v) / abs(v)
            for k, v in self.published.items()
            if k in self.fit.estimates
        }

    def summary_markdown(self) -> str:
        """A short markdown table: estimate, CI, published value, deviation."""
        lines = [
            f"# EMPS inverse-dynamics identification ({self.source})",
            "",
            "| parameter | estimate | 95 % CI | published | deviation |",
            "|---|---|---|---|---|",
        ]
        dev = self.deviations()
        for k, e in self.fit.estimates.items():
            pub = self.published.get(k)
            lines.append(
                f"| {k} [{e.unit}] | {e.value:.4f} | [{e.ci[0]:.4f}, {e.ci[1]:.4f}] | "
                f"{'' if pub is None else f'{pub:.4f}'} | "
                f"{'' if k not in dev else f'{100 * dev[k]:+.2f} %'} |"
            )
        lines += [
            "",
            f"Relative error (estimation): {100 * self.fit.relative_error:.2f} % "
            f"(published {100 * self.published['relative_error']:.2f} %)",
        ]
        if self.cross_test_error is not None:
            lines.append(
                f"Cross-test relative error ({self.validation}): {100 * self.cross_test_error:.2f} % "
                f"(published {100 * self.published['cross_test_error']:.2f} %)"
            )
        s = self.fit.settings
        lines += [
            "",
            f"Processing: Butterworth order {s['order']} at {s['cutoff']:g} Hz (filtfilt), central "
            f"differences, first {s['border']} samples dropped, decimation by {s['decimation']}.",
        ]
        return "\n".join(lines) + "\n"


def _emps_arrays(path: str | os.PathLike):
    from ..data import load_emps  # deferred: hydropwa.data loads pint

    run = load_emps(path)
    return run["t"], run["x"], run["f_m"], run.name


def identify_emps(
    path: str | os.PathLike, validation: str | os.PathLike | None = None, **kwargs
) -> EmpsResult:
    """IDIM-LS on the EMPS benchmark file, with an optional cross test.

    Parameters
    ----------
    path : path-like
        ``DATA_EMPS.mat`` (estimation set).
    validation : path-like, optional
        ``DATA_EMPS_PULSES.mat`` (cross-test set).
    **kwargs
        Passed to :func:`identify_inverse_dynamics`.

    Returns
    -------
    EmpsResult
    """
    t, q, f, name = _emps_arrays(path)
    fit = identify_inverse_dynamics(t, q, f, **kwargs)
    err = None
    vname = None
    if validation is not None:
        tv, qv, fv, vname = _emps_arrays(validation)
        err = fit.cross_test(tv, qv, fv)
    return EmpsResult(fit, err, dict(EMPS_PUBLISHED), str(name), vname)
