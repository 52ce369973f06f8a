"""Full, reduced and PWA models against a measured sine run (Sec. VII of the paper).

``evaluate_run`` finds the start of the first full period in steady state, takes the initial
state from the measurement there, simulates each model over the rest of the run with the
measured inputs, and scores every channel. The full model gets the measured P_S(t) (with an
ideal supply, since P_S is measured). The reduced and PWA models get the run's average P_S
as the paper does (``reduced``, ``pwa``), or the measured P_S(t) with the PWA cells
rescheduled online (``pwa-scheduled``, and ``reduced-scheduled`` for the reduced model).
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Iterable, Mapping, Sequence
from types import MappingProxyType
from typing import Any, NamedTuple

import numpy as np

from .._channels import SCORED_CHANNELS, START_REQUIRED, STATE_CHANNELS
from .._errors import DataError
from .._layout import (
    CHAMBER_KIND,
    FULL_KIND,
    LINES_KIND,
    PWA_KIND,
    REDUCED_KIND,
    build_model,
    model_kind,
)
from .._result import DerivedResult, ResultStatus
from ..data import screen_runs
from ..simulation import CHANNEL_UNITS, Sampled, simulate
from ._metrics import channel_metrics, drift_per_period

__all__ = [
    "MODELS",
    "CHANNELS",
    "EvaluationWarning",
    "EvaluationResult",
    "EvaluationStart",
    "evaluation_start",
    "evaluate_run",
    "evaluate_dataset",
    "sound_runs",
]


class ModelVariant(NamedTuple):
    """One model variant of the evaluation: a model kind, its factory options and its P_S input."""

    what: str
    kind: str  # the registry's model kind (hydropwa._layout.MODEL_KINDS)
    options: tuple[tuple[str, Any], ...]  # keywords of the kind's factory (form, scheduled)
    supply: str  # the P_S input: "measured" P_S(t), its "mean", or "none" (cells at the mean)


_KINDS = (FULL_KIND, REDUCED_KIND, PWA_KIND, CHAMBER_KIND)
_FULL, _REDUCED, _PWA, _CHAMBER = (k.name for k in _KINDS)
_LINES = LINES_KIND.name
#: The model variants evaluate_run knows, one row each; a kind's plain variant has its name.
#: The PWA kinds are linearized at the run's average P_S.
VARIANTS: dict[str, ModelVariant] = {
    _FULL: ModelVariant("full-order model, measured P_S(t)", _FULL, (), "measured"),
    _LINES: ModelVariant(
        "full-order model with the machine's hose lines, measured P_S(t)", _LINES, (), "measured"
    ),
    _REDUCED: ModelVariant("asymmetric reduced model, average P_S", _REDUCED, (), "mean"),
    "reduced-scheduled": ModelVariant(
        "asymmetric reduced model, measured P_S(t)", _REDUCED, (), "measured"
    ),
    _PWA: ModelVariant("asymmetric PWA model, cells at the average P_S", _PWA, (), "none"),
    "pwa-scheduled": ModelVariant(
        "asymmetric PWA model, cells scheduled on the measured P_S(t)",
        _PWA,
        (("scheduled", True),),
        "measured",
    ),
    "reduced-paper": ModelVariant(
        "the paper's mean-area reduced model, average P_S (Sec. VII)",
        _REDUCED,
        (("form", "paper"),),
        "mean",
    ),
    "pwa-paper": ModelVariant(
        "the paper's mean-area PWA model (Q_L = z·C_q), cells at the average P_S (Sec. VII)",
        _PWA,
        (("form", "consistent"),),
        "none",
    ),
    _CHAMBER: ModelVariant(
        "chamber-level PWA model (spool, P_A, P_B), cells scheduled on the measured P_S(t)",
        _CHAMBER,
        (("scheduled", True),),
        "measured",
    ),
}
#: The variants evaluate_run scores unless told.
DEFAULT_VARIANTS: tuple[str, ...] = (_FULL, _REDUCED, _PWA, "pwa-scheduled")
#: Model variants evaluate_run knows: name → description.
MODELS: dict[str, str] = {name: v.what for name, v in VARIANTS.items()}
#: Channels scored per run (the channel table's scored rows, in its rank order).
CHANNELS = SCORED_CHANNELS
#: Active-cell channels: the load-pressure PWA models' (g, o, n, w), pwa-chamber's (g, qa, qb, x, w).
_CELL_SETS = ("cell_g", "cell_o", "cell_n", "cell_w", "cell_qa", "cell_qb", "cell_x")


class EvaluationWarning(UserWarning):
    """The evaluation had to assume something (e.g. a constant supply pressure); the message says what."""


@dataclasses.dataclass(frozen=True)
class EvaluationStart:
    """Where the simulations start and the measured state there.

    Attributes
    ----------
    index : int
        Sample index of the start in the run.
    t0 : float
        Start time [s].
    period : float or None
        Input period [s] (None for a non-periodic command).
    measured : Mapping[str, float]
        Measured channels at the start, name → value [SI] (the state channels of
        :data:`hydropwa._channels.STATE_CHANNELS` the run has; ``v`` from a local quadratic
        fit of x, ``spool`` = u, Sec. VII); read-only.
    """

    index: int
    t0: float
    period: float | None
    measured: Mapping[str, float]

    def __post_init__(self) -> None:
        object.__setattr__(self, "measured", MappingProxyType(dict(self.measured)))

    def __getitem__(self, channel: str) -> float:
        """The measured value of one channel at the start [SI]."""
        return self.measured[channel]


def _frequency(run) -> float | None:
    """Command frequency [Hz] from the metadata, else from the upward zero crossings of u."""
    meta = run.meta or {}
    for src in (meta, meta.get("signal") or {}):
        f = src.get("frequency") if isinstance(src, dict) else None
        if isinstance(f, int | float) and f > 0:
            return float(f)
    up = _upward_crossings(run.channels["t"], run.channels["u"])
    if up.size < 3:
        return None
    return 1.0 / float(np.median(np.diff(up)))


def _upward_crossings(t: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Times [s] where u crosses zero upwards (linear interpolation)."""
    s = np.signbit(u)
    idx = np.nonzero(s[:-1] & ~s[1:])[0]
    du = u[idx + 1] - u[idx]
    frac = np.where(du != 0, -u[idx] / np.where(du != 0, du, 1.0), 0.0)
    return t[idx] + frac * (t[idx + 1] - t[idx])


def _local_slope(t: np.ndarray, x: np.ndarray, i: int, half_width: float) -> float:
    """dx/dt at sample i from a least-squares quadratic over ±half_width [s]."""
    sel = np.abs(t - t[i]) <= half_width
    if np.count_nonzero(sel) < 5:
        sel = np.zeros_like(sel)
        sel[max(0, i - 3) : i + 4] = True
    tt = t[sel] - t[i]
    c = np.polyfit(tt, x[sel], 2 if tt.size >= 5 else 1)
    return float(c[-2])


def evaluation_start(
    run, settle_periods: float = 1.0, slope_window: float = 0.01
) -> EvaluationStart:
    """The start of the first full period in steady state, and the measured state there.

    Parameters
    ----------
    run : hydropwa.data.Run
        Needs t, u, x, p_a, p_b (p_s optional).
    settle_periods : float
        Periods [1] skipped as transient before looking for the start of a period.
    slope_window : float
        Half width [s] of the local fit that gives the velocity.

    Returns
    -------
    EvaluationStart

    Notes
    -----
    A period starts at an upward zero crossing of the command. Data that begins mid-stroke
    or mid-run works the same way: only the measurement at the start is used.
    """
    t = run.channels["t"]
    u = run.channels["u"]
    f = _frequency(run)
    period = None if f is None else 1.0 / f
    i = 0
    if period is not None:
        ups = _upward_crossings(t, u)
        late = ups[ups >= t[0] + settle_periods * period - 0.25 * period]
        # at least one full period must remain after the start
        late = late[late <= t[-1] - period + 1e-9]
        if late.size == 0:
            late = ups[ups <= t[-1] - period + 1e-9]
        if late.size:
            i = int(np.searchsorted(t, late[0]))
    i = min(i, t.size - 2)
    ch = run.channels
    measured = {c: float(ch[c][i]) for c in STATE_CHANNELS if c in ch}
    measured["v"] = _local_slope(t, ch["x"], i, slope_window)
    measured["spool"] = float(u[i])  # the valve at rest at its command (Sec. VII)
    return EvaluationStart(index=i, t0=float(t[i]), period=period, measured=measured)


def _area_ratio(params) -> float:
    """α = A_B/A_A: the evaluation's load pressure is P_L = P_A − α P_B for every model."""
    return params.cylinder.area_b / params.cylinder.area_a


def _measured(
    run, start: EvaluationStart, slope_window: float, alpha: float = 1.0
) -> dict[str, np.ndarray]:
    """Measured channels from the start on, with P_L = P_A − α P_B and a smoothed-derivative velocity."""
    from scipy.signal import savgol_filter  # deferred: scipy submodules cost 0.1-0.5 s at import

    i = start.index
    ch = {k: np.asarray(v[i:], dtype=float) for k, v in run.channels.items()}
    ch["p_l"] = ch["p_a"] - alpha * ch["p_b"]
    if "v" not in ch:
        dt = float(np.median(np.diff(ch["t"])))
        win = max(5, int(round(2 * slope_window / dt)) | 1)
        if win < ch["t"].size:
            ch["v"] = savgol_filter(ch["x"], win, 2, deriv=1, delta=dt)
        else:
            ch["v"] = np.gradient(ch["x"], ch["t"])
    return ch


@dataclasses.dataclass
class EvaluationResult(DerivedResult):
    """Models against one measured run.

    Attributes
    ----------
    run : str
        Run name.
    start : EvaluationStart
        Start of the comparison and the initial state taken from the measurement.
    measured : dict[str, ndarray]
        Measured channels from the start on (SI), with p_l = p_a − α p_b (α = A_B/A_A; the simulations' p_l is the same
        quantity from their chamber pressures) and v from x.
    simulations : dict[str, SimulationResult]
        Per model variant (see :data:`MODELS`).
    metrics : pandas.DataFrame
        One row per (model, channel): ``nrmse_fit`` [%], ``rmse``, ``peak_error`` [SI unit of
        the channel, in ``unit``], ``coverage`` [1]; for ``x`` also ``drift_measured`` and
        ``drift_model`` [m per period].
    cell_metrics : pandas.DataFrame
        PWA variants: per nonlinearity (``g``, ``o``, ``n``, ``w``; pwa-chamber: ``g``, ``qa``,
        ``qb``, ``x``, ``w``) and cell, the samples and fraction of time active and the RMSE of x [m] and
        p_l, p_a, p_b [Pa] while it is active (the cell coverage and the fit per cell).
    supply_pressure : float
        Average measured (or assumed) P_S [Pa] given to the paper-style variants.
    notes : list of str
        Assumptions made (missing P_S, failed integrations).
    meta : dict
        The run's metadata.
    """

    run: str
    start: EvaluationStart
    measured: dict[str, np.ndarray]
    simulations: dict[str, Any]
    metrics: Any
    cell_metrics: Any
    supply_pressure: float
    notes: list[str] = dataclasses.field(default_factory=list)
    meta: dict = dataclasses.field(default_factory=dict)

    def fit(self, model: str = _FULL, channel: str = "x") -> float:
        """NRMSE fit [%] of one model variant on one channel."""
        m = self.metrics
        row = m[(m["model"] == model) & (m["channel"] == channel)]
        if row.empty:
            raise KeyError(f"no metric for model {model!r}, channel {channel!r}")
        return float(row["nrmse_fit"].iloc[0])

    def plot(
        self,
        models: Sequence[str] | None = None,
        channels: Sequence[str] = ("u", "x", "p_l"),
        smooth: float = 0.01,
        *,
        ax: Any = None,
    ):
        """Measurement and models over time, like Figs. 10–13 (see
        :func:`hydropwa.plotting.plot_evaluation`)."""
        from ..plotting import plot_evaluation  # deferred: matplotlib loads only when plotting

        return plot_evaluation(self, models=models, channels=channels, smooth=smooth, ax=ax)

    # ---------------------------------------------------------------- result protocol
    @property
    def status(self) -> ResultStatus:
        """``FAILED`` when a model's integration stopped early (it is scored over the samples
        it reached), else ``SUCCESS`` (:class:`~hydropwa._result.ResultStatus`)."""
        ok = all(getattr(r, "success", True) for r in self.simulations.values())
        return ResultStatus.SUCCESS if ok else ResultStatus.FAILED

    def _status_details(self) -> list[str]:
        return [
            f"{m}: {r.message}"
            for m, r in self.simulations.items()
            if not getattr(r, "success", True)
        ]

    def to_pandas(self) -> Any:
        """The metrics table (one row per model and channel; see ``metrics``)."""
        return self.metrics

    def _summary_title(self) -> str:
        return f"EvaluationResult: run {self.run}, t0 = {self.start.t0:.3f} s"

    def _summary_rows(self) -> list[tuple[str, Any, str]]:
        m = self.metrics
        return [
            (f"{r.model} {r.channel} fit", f"{r.nrmse_fit:.1f}", "%") for r in m.itertuples()
        ] + [("P_S (average)", self.supply_pressure, "Pa")]

    def __repr__(self) -> str:
        fits = ", ".join(
            f"{m}: {self.fit(m, 'x'):.1f} %"
            for m in self.simulations
            if not self.metrics[(self.metrics["model"] == m)].empty
        )
        return f"EvaluationResult(run={self.run!r}, t0={self.start.t0:.3f} s, position fit {fits})"


def _check_models(models: Iterable[str]) -> tuple[str, ...]:
    out = tuple(models)
    bad = [m for m in out if m not in MODELS]
    if bad or not out:
        raise DataError(
            f"unknown model variant(s) {', '.join(map(repr, bad)) or '(none)'}; "
            f"choose from {', '.join(MODELS)}"
        )
    return out


def _check_run(run) -> None:
    missing = [c for c in ("t", "u", *START_REQUIRED) if c not in run.channels]
    if missing:
        raise DataError(
            f"run {run.name!r} lacks channel(s) {', '.join(missing)} needed for the evaluation"
        )
    if run.channels["t"].size < 10:
        raise DataError(f"run {run.name!r} has only {run.channels['t'].size} samples")


def _supply(run, params, start: EvaluationStart, notes: list[str]):
    """(P_S signal for the full model, average P_S [Pa]) — measured, or the assumed constant."""
    if "p_s" in run.channels and np.all(np.isfinite(run.channels["p_s"])):
        ps = run.channels["p_s"]
        return Sampled(run.channels["t"], ps), float(np.mean(ps[start.index :]))
    p = float(params.supply.pressure)
    msg = (
        f"run {run.name!r} has no supply pressure channel p_s; assuming a constant "
        f"P_S = {p / 1e5:g} bar (params.supply.pressure) for every model"
    )
    warnings.warn(msg, EvaluationWarning, stacklevel=3)
    notes.append(msg)
    return p, p


def _model_and_inputs(name: str, params, ps_signal, ps_mean: float):
    """(model object, supply-pressure input) of one variant (:data:`VARIANTS`)."""
    variant = VARIANTS[name]
    options = dict(variant.options)
    if model_kind(variant.kind).linearized:
        options["supply_pressure"] = ps_mean
    ps_in = {"measured": ps_signal, "mean": ps_mean, "none": None}[variant.supply]
    return build_model(variant.kind, params, **options), ps_in


def _initial_state(model, start: EvaluationStart, ps_mean: float) -> np.ndarray:
    measured = dict(start.measured)
    if not math.isfinite(measured.get("p_s", math.nan)):
        measured["p_s"] = ps_mean
    return model.state_from_measurement(measured)


def _simulate_variant(name, run, params, start, ps_signal, ps_mean, rtol, notes):
    model, ps_in = _model_and_inputs(name, params, ps_signal, ps_mean)
    t = run.channels["t"]
    fl = Sampled(t, run.channels["f_l"]) if "f_l" in run.channels else None
    res = simulate(
        model,
        u=Sampled(t, run.channels["u"]),
        timepts=t[start.index :],
        supply_pressure=ps_in,
        load_force=fl,
        initial_state=_initial_state(model, start, ps_mean),
        rtol=rtol,
        raise_on_failure=False,
    )
    # one load pressure for every model, P_A − α P_B = F_hyd/A_A: the state of the asymmetric
    # models, the force-equivalent pressure of the full and the paper-form models
    res.channels["p_l"] = res.channels["p_a"] - _area_ratio(params) * res.channels["p_b"]
    if not res.success:
        notes.append(
            f"{name}: {res.message}; scored over {res.t.size} of {t.size - start.index} samples"
        )
    return res


def _padded(res, key: str, n: int) -> np.ndarray:
    y = np.full(n, np.nan)
    if key in res.channels:
        y[: res.channels[key].size] = res.channels[key]
    return y


def _metric_rows(run_name, meas, sims, start) -> list[dict]:
    n = meas["t"].size
    rows = []
    for model, res in sims.items():
        for ch in CHANNELS:
            y_hat = _padded(res, ch, n)
            row = {
                "run": run_name,
                "model": model,
                "channel": ch,
                "unit": CHANNEL_UNITS.get(ch, "1"),
                **channel_metrics(meas[ch], y_hat),
            }
            if ch == "x" and start.period is not None:
                row["drift_measured"] = drift_per_period(meas["t"], meas["x"], start.period)
                row["drift_model"] = drift_per_period(meas["t"], y_hat, start.period)
            rows.append(row)
        # The paper's mean-area models cannot drift (Sec. VII); the position fit with each
        # signal's own linear trend removed scores the shape apart from the drift.
        y_hat = _padded(res, "x", n)
        rows.append(
            {
                "run": run_name,
                "model": model,
                "channel": "x_detrended",
                "unit": "m",
                **channel_metrics(_detrend(meas["t"], meas["x"]), _detrend(meas["t"], y_hat)),
            }
        )
    return rows


def _detrend(t, y):
    """``y`` minus its least-squares straight line over the finite samples."""
    y = np.asarray(y, dtype=float)
    ok = np.isfinite(y)
    if ok.sum() < 2:
        return y
    coef = np.polyfit(t[ok], y[ok], 1)
    return y - np.polyval(coef, t)


def _cell_rows(run_name, meas, sims) -> list[dict]:
    rows = []
    for model, res in sims.items():
        if "cell_g" not in res.channels:
            continue
        k = res.t.size
        ex = res.channels["x"] - meas["x"][:k]
        ep = res.channels["p_l"] - meas["p_l"][:k]
        eab = {c: res.channels[c] - meas[c][:k] for c in ("p_a", "p_b") if c in meas}
        for key in (name for name in _CELL_SETS if name in res.channels):
            cells = res.channels[key].astype(int)
            for c in np.unique(cells):
                sel = cells == c
                rows.append(
                    {
                        "run": run_name,
                        "model": model,
                        "set": key[5:],
                        "cell": int(c),
                        "samples": int(np.count_nonzero(sel)),
                        "fraction": float(np.mean(sel)),
                        "rmse_x": float(np.sqrt(np.mean(ex[sel] ** 2))),
                        "rmse_p_l": float(np.sqrt(np.mean(ep[sel] ** 2))),
                        **{
                            f"rmse_{c}": float(np.sqrt(np.mean(e[sel] ** 2)))
                            for c, e in eab.items()
                        },
                    }
                )
    return rows


def evaluation_params(params):
    """The parameters used for evaluation: the measured P_S is an input, so the supply is ideal."""
    if params.supply.model == "ideal":
        return params
    return params.replace(**{"supply.model": "ideal"})


def evaluate_run(
    run,
    params,
    *,
    models: Iterable[str] = DEFAULT_VARIANTS,
    settle_periods: float = 1.0,
    rtol: float = 1e-5,
    slope_window: float = 0.01,
) -> EvaluationResult:
    """Simulate model variants with the run's measured inputs and score them against it.

    Parameters
    ----------
    run : hydropwa.data.Run
        A measured (or virtual-rig) sine run with t, u, x, p_a, p_b and, ideally, p_s, f_l.
    params : SystemParams
        Model parameters (identified or true).
    models : iterable of str
        Variants from :data:`MODELS`.
    settle_periods : float
        Periods [1] treated as transient before the first compared period.
    rtol : float
        Relative tolerance of the simulations.
    slope_window : float
        Half width [s] of the local fits that give the measured velocity.

    Returns
    -------
    EvaluationResult

    Raises
    ------
    DataError
        A needed channel is missing or the model list is invalid.

    Warns
    -----
    EvaluationWarning
        When the run has no P_S: a constant ``params.supply.pressure`` is assumed (also
        written to ``result.notes``).
    """
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    names = _check_models(models)
    _check_run(run)
    params = evaluation_params(params)
    start = evaluation_start(run, settle_periods, slope_window)
    notes: list[str] = []
    ps_signal, ps_mean = _supply(run, params, start, notes)
    meas = _measured(run, start, slope_window, _area_ratio(params))
    sims = {
        name: _simulate_variant(name, run, params, start, ps_signal, ps_mean, rtol, notes)
        for name in names
    }
    return EvaluationResult(
        run=run.name,
        start=start,
        measured=meas,
        simulations=sims,
        metrics=pd.DataFrame(_metric_rows(run.name, meas, sims, start)),
        cell_metrics=pd.DataFrame(
            _cell_rows(run.name, meas, sims),
            columns=[
                "run",
                "model",
                "set",
                "cell",
                "samples",
                "fraction",
                "rmse_x",
                "rmse_p_l",
                "rmse_p_a",
                "rmse_p_b",
            ],
        ),
        supply_pressure=ps_mean,
        notes=notes,
        meta=dict(run.meta or {}),
    )


def sound_runs(dataset) -> list:
    """The runs of a dataset (or iterable) that pass :func:`hydropwa.data.screen_runs`.

    A run whose file cannot be read, or with a time-base error, NaN, a clipped converter, a
    dropout or a spike, is left out with an :class:`EvaluationWarning` that names it and says
    why; the evaluation never silently includes the bad part.
    """
    sound, rejected = screen_runs(dataset)
    for name, reason in rejected:
        warnings.warn(f"run {name!r} skipped: {reason}", EvaluationWarning, stacklevel=2)
    return sound


def evaluate_dataset(
    dataset,
    params,
    *,
    models: Iterable[str] = DEFAULT_VARIANTS,
    progress=None,
    **kwargs,
):
    """Metrics of :func:`evaluate_run` over every run of a dataset, as one DataFrame.

    Parameters
    ----------
    dataset : hydropwa.data.Dataset or iterable of Run
        The sine runs.
    params : SystemParams
    models : iterable of str
        Variants from :data:`MODELS`.
    progress : callable, optional
        Called as ``progress(done, total, run_name)`` after each run.
    **kwargs
        Passed to :func:`evaluate_run`.

    Returns
    -------
    pandas.DataFrame
        Rows of every run's ``metrics``; the column ``note`` holds the run's notes.
    """
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    runs = sound_runs(dataset)
    frames = []
    for k, run in enumerate(runs):
        res = evaluate_run(run, params, models=models, **kwargs)
        df = res.metrics.copy()
        df["note"] = "; ".join(res.notes)
        frames.append(df)
        if progress is not None:
            progress(k + 1, len(runs), run.name)
    if not frames:
        raise DataError("the dataset holds no runs to evaluate")
    return pd.concat(frames, ignore_index=True)
