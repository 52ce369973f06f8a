"""The residual generator on the target: C99 generated from the package's numba source (issue 53).

:func:`c_sources` writes ``hydropwa_monitor.h``, ``hydropwa_monitor.c`` and a README. How the
C stays the package's generator:

- the **row** and **result** functions (:func:`~._residuals.monitor_row`,
  :func:`~._residuals.monitor_result`) and the component physics they call (the valve's dead
  zone and orifice flows, the Stribeck curve) are translated from their numba source by
  :func:`hydropwa.simulation._emit_c.emit_unit`, as the controller's physics and the axis FMU;
- the machine and the thresholds are one ``static const`` table, the vector ``P`` that the
  package's own generator (:func:`online_check`) reads, packed by :func:`pack_online`;
- the hand-written part (``_c/hydropwa_monitor_api.c``) only wraps them.

The thresholds are constants: the widest of the package's thresholds over the runs it checked
(:func:`target_thresholds`), see the README written beside the sources.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__
from .._errors import DataError, ParameterError
from .._io import write_text_files
from .._result import DerivedResult, ResultStatus
from ..components import _physics as PH
from ..simulation._emit_c import emit_unit
from . import _residuals as R
from ._indicators import INDICATORS
from ._monitor import REQUIRED, HealthMonitor, HealthReport

__all__ = [
    "C_FILES",
    "TARGET_INDICATORS",
    "OnlineHealth",
    "TargetIndicator",
    "c_sources",
    "export_c",
    "online_check",
    "pack_online",
    "target_thresholds",
]

#: Files written by :func:`export_c`.
C_FILES = ("hydropwa_monitor.h", "hydropwa_monitor.c", "README.md")


@dataclass(frozen=True)
class TargetIndicator:
    """An indicator the target computes: its place in :func:`~._residuals.monitor_result`'s
    outputs and its threshold slots in ``P`` (-1: no alarm on that side); its unit is the
    indicator table's."""

    name: str
    value: int
    alarm: int
    low: int
    high: int

    @property
    def unit(self) -> str:
        """SI unit (:data:`~._indicators.INDICATORS`' row of the same name)."""
        return next(ind.unit for ind in INDICATORS if ind.name == self.name)


#: The indicators on the target (one row each; the names are :data:`~._indicators.INDICATORS`').
#: ``value``/``alarm``: places in the outputs of :func:`~._residuals.monitor_result` (0-8)
#: followed by those of :func:`~._residuals.continuity_result` (9-16).
TARGET_INDICATORS = (
    TargetIndicator("friction_scale", 0, 3, -1, R.MP_FR_HI),
    TargetIndicator("supply_pressure", 1, 4, R.MP_PS_LO, -1),
    TargetIndicator("valve_null", 2, 5, R.MP_NU_LO, R.MP_NU_HI),
    TargetIndicator("bulk_modulus", 9, 13, R.MP_E_LO, R.MP_E_HI),
    TargetIndicator("internal_leakage", 10, 14, R.MP_CL_LO, R.MP_CL_HI),
    TargetIndicator("external_leakage_a", 11, 15, R.MP_CEA_LO, R.MP_CEA_HI),
    TargetIndicator("external_leakage_b", 12, 16, R.MP_CEB_LO, R.MP_CEB_HI),
)


def target_thresholds(report: HealthReport) -> dict[str, tuple[float, float]]:
    """Per target indicator, the widest (low, high) threshold of the report's runs (SI; ∓inf: none)."""
    if not report.runs:
        raise DataError(
            "no run was checked; give the commissioning runs the thresholds are sized on"
        )
    out: dict[str, tuple[float, float]] = {}
    for ti in TARGET_INDICATORS:
        lows = [r.indicators[ti.name].threshold[0] for r in report.runs]
        highs = [r.indicators[ti.name].threshold[1] for r in report.runs]
        lo = min((v for v in lows if v is not None and math.isfinite(v)), default=-math.inf)
        hi = max((v for v in highs if v is not None and math.isfinite(v)), default=math.inf)
        out[ti.name] = (lo, hi)
    return out


def pack_online(
    monitor: HealthMonitor,
    thresholds: Mapping[str, tuple[float, float]],
    sliding_speed: float,
    logged: tuple[str, ...],
) -> np.ndarray:
    """The vector ``P`` of :func:`~._residuals.monitor_row` (SI; slots ``MP_*``).

    Parameters
    ----------
    monitor : HealthMonitor
        Fitted: the identified machine and the rows' mask settings.
    thresholds : mapping
        ``{name: (low, high)}`` of :data:`TARGET_INDICATORS` (SI; ∓inf for no alarm).
    sliding_speed : float
        Speed [m/s] above which a row enters the friction sums.
    logged : tuple of str
        The optional channels the runs carry (of ``p_s``, ``f_l``, ``spool``).
    """
    if not hasattr(monitor, "params_"):
        raise ParameterError("HealthMonitor is not fitted; call .fit(identified_params) first")
    p = monitor.params_
    c, fl, dz, fr, ld, sup = p.cylinder, p.flow, p.dead_zone, p.friction, p.load, p.supply
    if sup.model == "pump" and not sup.pump_flow > 0.0:
        raise ParameterError("supply.pump_flow must be > 0 for the pump's droop in the monitor")
    P = np.zeros(R.N_P)
    slots = {
        R.MP_AA: c.area_a, R.MP_AB: c.area_b, R.MP_STROKE: c.stroke,
        R.MP_VA0: c.dead_volume_a, R.MP_VB0: c.dead_volume_b, R.MP_E: p.oil.bulk_modulus,
        R.MP_CL: c.leakage, R.MP_CEA: c.external_leakage_a, R.MP_CEB: c.external_leakage_b,
        R.MP_K: fl.K, R.MP_PTR: fl.transition_pressure, R.MP_PT: sup.tank_pressure,
        R.MP_ALPHA: dz.alpha, R.MP_BETA: dz.beta, R.MP_CREEP: dz.creep_slope,
        R.MP_OUTER: dz.outer_offset, R.MP_FC: fr.coulomb, R.MP_FS: fr.static,
        R.MP_SIGMA: fr.viscous, R.MP_CHI: fr.stribeck_velocity, R.MP_DELTA: fr.shape,
        R.MP_GAMMA: fr.smoothness, R.MP_MASS: ld.mass, R.MP_LOADF: ld.force,
        R.MP_LOADD: ld.damping, R.MP_PUMP: 1.0 if sup.model == "pump" else 0.0,
        R.MP_DROOP: sup.compensator_droop, R.MP_QMAX: sup.pump_flow if sup.model == "pump" else 1.0, R.MP_PS: sup.pressure,
        R.MP_XLO: monitor.stroke_margin * c.stroke,
        R.MP_XHI: c.stroke - monitor.stroke_margin * c.stroke,
        R.MP_PMIN: monitor.min_pressure, R.MP_VMIN: sliding_speed,
        R.MP_HAS_FL: "f_l" in logged, R.MP_HAS_PS: "p_s" in logged,
        R.MP_HAS_SPOOL: "spool" in logged,
    }  # fmt: skip
    for slot, value in slots.items():
        P[slot] = float(value)
    P[R.MP_CS : R.MP_CS + 5] = R.CONTINUITY_SCALE
    for ti in TARGET_INDICATORS:
        lo, hi = thresholds[ti.name]
        if ti.low >= 0:
            P[ti.low] = lo
        if ti.high >= 0:
            P[ti.high] = hi
    return P


@dataclass(frozen=True)
class OnlineHealth(DerivedResult):
    """The package's run of the on-target generator over one run (what the C computes).

    Attributes
    ----------
    run : str
    residuals : ndarray
        Per row: r_A, r_B [m³/s], r_F [N].
    sums : ndarray
        The running sums at the run's end (slots ``MS_*``).
    values : dict
        ``{name: value}`` of :data:`TARGET_INDICATORS` (SI; NaN where not available).
    alarms : dict
        ``{name: bool}``.
    rms : tuple of float
        RMS of r_A, r_B [m³/s] and r_F [N] over the rows used.
    """

    run: str
    residuals: np.ndarray
    sums: np.ndarray
    values: dict[str, float]
    alarms: dict[str, bool]
    rms: tuple[float, float, float]

    @property
    def status(self) -> ResultStatus:
        """SUCCESS, or PARTIAL when no row was usable."""
        return ResultStatus.SUCCESS if self.sums[R.MS_N] > 0 else ResultStatus.PARTIAL

    def _status_details(self) -> list[str]:
        return [] if self.sums[R.MS_N] > 0 else ["no usable row"]

    def _summary_rows(self) -> list[tuple[str, Any, str]]:
        units = {ti.name: ti.unit for ti in TARGET_INDICATORS}
        return [(n, v, units[n]) for n, v in self.values.items()]

    def to_pandas(self) -> Any:
        """The residuals per row (SI)."""
        import pandas as pd  # deferred: pandas costs ~0.3 s at import

        return pd.DataFrame(self.residuals, columns=["r_a", "r_b", "r_f"])

    def plot(self, *, ax: Any = None) -> Any:
        """Not drawn: see :meth:`to_pandas`."""
        raise NotImplementedError("plot the residuals from to_pandas()")


def online_check(monitor: HealthMonitor, run: Any, P: np.ndarray) -> OnlineHealth:
    """Run the on-target generator (:func:`~._residuals.monitor_rows`) over a logged run's rows."""
    missing = [c for c in REQUIRED if c not in run.channels]
    if missing:
        raise DataError(f"run {run.name!r} has no {', '.join(missing)}; the monitor needs them")
    sig = R.prepare(run.channels, float(run.fs), monitor.params_, monitor.window)
    zero = np.zeros(sig.t.size)
    ps = sig.p_s if sig.p_s is not None else zero
    fl = sig.f_l if sig.f_l is not None else zero
    r, S = R.monitor_rows(
        P, sig.nu, sig.nu_model, sig.x, sig.v, sig.a, sig.p_a, sig.p_b, sig.dp_a, sig.dp_b, ps, fl
    )
    out = R.monitor_result(S, P) + R.continuity_result(S, P, np.zeros(R.N_W))
    values = {ti.name: float(out[ti.value]) for ti in TARGET_INDICATORS}
    alarms = {ti.name: bool(out[ti.alarm] > 0.5) for ti in TARGET_INDICATORS}
    return OnlineHealth(run.name, r, S, values, alarms, (out[6], out[7], out[8]))


def _c_double(v: float) -> str:
    if math.isinf(v):
        return "HUGE_VAL" if v > 0 else "(-HUGE_VAL)"
    return repr(float(v))


def _template(name: str) -> str:
    return resources.files("hydropwa.monitor").joinpath("_c", name).read_text(encoding="utf-8")


def _savgol_rows(window: int, fs: float) -> np.ndarray:
    from scipy.signal import savgol_coeffs  # deferred: scipy.signal costs ~0.2 s at import

    dt = 1.0 / fs
    return np.array([savgol_coeffs(window, 3, deriv=d, delta=dt, use="dot") for d in range(3)])


def c_sources(monitor: HealthMonitor, P: np.ndarray, fs: float, n_runs: int = 1) -> dict[str, str]:
    """The texts of ``hydropwa_monitor.h``, ``hydropwa_monitor.c`` and ``README.md``.

    Parameters
    ----------
    monitor : HealthMonitor
        Fitted (its filter window).
    P : ndarray
        :func:`pack_online`'s vector.
    fs : float
        The runs' sampling rate [Hz] (the filter's coefficients).
    n_runs : int
        Runs the thresholds were sized on (for the README).
    """
    window = max(7, int(round(monitor.window * fs)) | 1)
    sg = _savgol_rows(window, fs)
    code, _names = emit_unit(
        [R.monitor_row, R.monitor_result, R.continuity_result],
        {"smooth_sign": PH._smooth_sign_compiled, "abs_power": PH._abs_power_compiled},
    )
    subs = {
        "@VERSION@": __version__,
        "@N_S@": str(R.N_S),
        "@N_W@": str(R.N_W),
        "@E_LO@": _c_double(P[R.MP_E_LO]),
        "@E_HI@": _c_double(P[R.MP_E_HI]),
        "@CL_HI@": _c_double(P[R.MP_CL_HI]),
        "@CEA_HI@": _c_double(P[R.MP_CEA_HI]),
        "@CEB_HI@": _c_double(P[R.MP_CEB_HI]),
        "@WINDOW@": str(window),
        "@STEP@": str(max(1, window // 2)),
        "@FS@": f"{fs:g}",
        "@FR_HI@": _c_double(P[R.MP_FR_HI]),
        "@PS_LO@": _c_double(P[R.MP_PS_LO]),
        "@NU_LO@": _c_double(P[R.MP_NU_LO]),
        "@NU_HI@": _c_double(P[R.MP_NU_HI]),
        "@N_RUNS@": str(n_runs),
        "@MARGIN@": f"{100 * monitor.stroke_margin:g}",
        "@PMIN@": f"{monitor.min_pressure / 1e5:g}",
        "@VMIN@": f"{P[R.MP_VMIN]:.4g}",
    }
    texts = {n: _template(n) for n in ("hydropwa_monitor.h", "README.md")}
    for k, v in subs.items():
        texts = {n: t.replace(k, v) for n, t in texts.items()}
    table = ",\n".join(f"    {_c_double(v)}" for v in P)
    sg_rows = ",\n".join("    {" + ", ".join(repr(float(c)) for c in row) + "}" for row in sg)
    texts["hydropwa_monitor.c"] = (
        f"/* hydropwa_monitor.c: generated by hydropwa {__version__}. Do not edit: regenerate with\n"
        " * `hydropwa monitor DATA --params P --c DIR`. C99, no heap, no I/O. */\n"
        '#include "hydropwa_monitor.h"\n\n'
        "#include <math.h> /* HUGE_VAL, exp, log, sqrt, tanh, fabs (link with -lm) */\n\n"
        "/* The machine and the thresholds (SI; slots MP_* of hydropwa/monitor/_residuals.py) */\n"
        f"static const double P[{R.N_P}] = {{\n{table}\n}};\n\n"
        f"const double hydropwa_monitor_sg[3][{window}] = {{\n{sg_rows}\n}};\n\n"
        "/* hydropwa/monitor/_residuals.py and the physics it calls, translated by\n"
        " * simulation/_emit_c.py */\n"
        f"{code}\n" + _template("hydropwa_monitor_api.c")
    )
    return texts


def export_c(
    monitor: HealthMonitor,
    report: HealthReport,
    fs: float,
    directory: str | os.PathLike,
    *,
    overwrite: bool = False,
) -> Path:
    """Write the on-target generator (:data:`C_FILES`) with the thresholds of ``report``'s runs.

    Parameters
    ----------
    monitor : HealthMonitor
        Fitted to the identified machine.
    report : HealthReport
        Its check of the commissioning runs: the thresholds are the widest of theirs
        (:func:`target_thresholds`), the friction rows' speed the largest.
    fs : float
        The runs' sampling rate [Hz].
    directory : path-like
        Folder to write; refused if it holds files, unless ``overwrite``.
    """
    if not (math.isfinite(fs) and fs > 0.0):
        raise DataError(f"sampling rate {fs!r} Hz must be a positive number")
    speed = max(r.sliding_speed for r in report.runs) if report.runs else math.nan
    logged = (
        tuple(sorted(set.intersection(*(set(r.logged) for r in report.runs))))
        if report.runs
        else ()
    )
    P = pack_online(monitor, target_thresholds(report), speed, logged)
    return write_text_files(
        directory, c_sources(monitor, P, fs, len(report.runs)), overwrite=overwrite
    )
