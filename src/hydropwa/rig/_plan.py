"""A campaign a real rig can play: commands as files, each run checked on the full model.

:func:`plan_campaign` expands a campaign (by default sized to the machine,
:func:`~hydropwa.rig.size_campaign`) into the runs the rig's controller plays: each run's valve
command sampled at the rig's rate (and the counter-force reference of the second cylinder where
there is one), its start position and the closed-loop move that gets the rod there, and its
**predicted envelope** from the full-order model playing exactly that sampled command. A run that
breaks a :class:`PlanLimits` limit is shortened (stroke, run length: the command stops earlier)
or scaled (pressure, velocity, opening: the command is made smaller), and the change is said; a
run that cannot be adapted is refused, naming the limit. ``strict`` refuses instead of adapting.

:meth:`Plan.write` writes ``PLAN/manifest.json``, ``commands/<run>.csv`` (``t`` [s], ``u`` [1],
and ``f_l`` [N] where a counter force is commanded) and ``.mat``, ``positioning/<run>.csv``
(``t`` [s], ``r`` [m]: the position reference that brings the rod to the run's start),
``machine.toml`` and ``plan.html`` with ``plan.png``. ``hydropwa data import`` reads the
manifest back (:data:`PLAN_MANIFEST`).
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import __version__
from .._errors import ParameterError
from .._io import atomic_folder
from .._result import ResultStatus
from ..models import machine_model
from ..params import SystemParams, params_to_toml, parse_quantity
from ..simulation import Sampled, simulate
from ._campaign import EXPERIMENTS, Campaign
from ._experiments import RunSpec, _stop_index, counter_force_signal, plan
from ._rig import Rig
from ._sizing import size_campaign

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "LIMIT_FIELDS",
    "LOG_COLUMNS",
    "PLAN_MANIFEST",
    "Envelope",
    "Plan",
    "PlanLimits",
    "PlannedRun",
    "RefusedRun",
    "parse_limits",
    "plan_campaign",
]

#: File name of a plan's manifest.
PLAN_MANIFEST = "manifest.json"
#: Log channels the import expects (SI): per experiment, the channels its identification uses.
LOG_COLUMNS = {
    "frf": ("t", "u", "spool", "x"),
    "deadzone": ("t", "u", "x"),
    "friction": ("t", "u", "x", "p_a", "p_b", "f_l"),
    "sine": ("t", "u", "x", "p_a", "p_b", "p_s"),
}
#: Channels of the full model's prediction written with each run (``predicted/<run>.csv``).
PREDICTED = ("x", "v", "p_a", "p_b", "spool")
_RAMP_DOWN = 0.05  # [s] the command returns to 0 over this time where a run is cut short
_REST = 0.1  # [s] at u = 0 after a run (recorded: the rod comes to rest)
_TRIES = 5


@dataclass(frozen=True)
class PlanLimits:
    """What no run of a plan may do on the machine (SI).

    Attributes
    ----------
    stroke_margin : float
        Smallest distance to either end stop [m].
    min_pressure : float
        Lowest chamber pressure [Pa] (gauge; below 0 the chamber cavitates towards the oil's
        vapour pressure).
    max_pressure : float or None
        Highest chamber pressure [Pa]; None: the machine's relief pressure, else 1.2·P_S.
    max_velocity : float
        Highest rod speed [m/s].
    max_opening : float
        Largest |valve command| [1].
    max_duration : float
        Longest run [s].
    """

    stroke_margin: float = 0.005
    min_pressure: float = 0.0
    max_pressure: float | None = None
    max_velocity: float = 1.0
    max_opening: float = 1.0
    max_duration: float = 30.0

    def resolved(self, params: SystemParams) -> PlanLimits:
        """The limits with ``max_pressure`` filled in from the machine."""
        if self.max_pressure is not None:
            return self
        sup = params.supply
        top = sup.relief_pressure if sup.model == "pump" else 1.2 * sup.pressure
        return dataclasses.replace(self, max_pressure=max(top, 1.2 * sup.pressure))

    def to_dict(self) -> dict[str, float | None]:
        """The limits in SI, by field name."""
        return dataclasses.asdict(self)


#: Limit fields: unit and the range a value must lie in (checked where limits enter).
LIMIT_FIELDS: dict[str, tuple[str, float, float]] = {
    "stroke_margin": ("m", 0.0, 10.0),
    "min_pressure": ("Pa", -1.0e5, 1.0e8),
    "max_pressure": ("Pa", 1.0e5, 1.0e9),
    "max_velocity": ("m/s", 1e-4, 20.0),
    "max_opening": ("", 1e-3, 1.0),
    "max_duration": ("s", 0.01, 3600.0),
}


def parse_limits(table: Mapping[str, Any], where: str = "[limits]") -> PlanLimits:
    """Limits from a ``[limits]`` table or CLI options (numbers in SI or strings with units).

    Raises
    ------
    ParameterError
        An unknown key, or a value outside its field's range (``LIMIT_FIELDS``).
    """
    values: dict[str, float] = {}
    for key, raw in table.items():
        if raw is None:
            continue
        if key not in LIMIT_FIELDS:
            raise ParameterError(
                f"{where}: unknown limit {key!r}; known: {', '.join(LIMIT_FIELDS)}"
            )
        unit, lo, hi = LIMIT_FIELDS[key]
        v = parse_quantity(raw, unit, f"{where} {key}")
        if not (math.isfinite(v) and lo <= v <= hi):
            u = f" {unit}" if unit else ""
            raise ParameterError(
                f"{where} {key} = {v:g}{u} is implausible; give a value in [{lo:g}, {hi:g}]{u}"
            )
        values[key] = v
    lim = PlanLimits(**values)
    if lim.max_pressure is not None and lim.max_pressure <= lim.min_pressure:
        raise ParameterError(f"{where}: max_pressure must exceed min_pressure")
    return lim


def campaign_limits(name_or_path: str | os.PathLike) -> dict[str, Any]:
    """The ``[limits]`` table of a campaign file (empty for a built-in name or no table)."""
    import tomllib  # deferred: only campaign files with limits need it

    p = Path(name_or_path)
    if not p.is_file():
        return {}
    try:
        doc = tomllib.loads(p.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ParameterError(f"{p}: not a campaign TOML file ({exc})") from None
    table = doc.get("limits", {})
    if not isinstance(table, Mapping):
        raise ParameterError(f"{p}: [limits] must be a table")
    return dict(table)


@dataclass(frozen=True)
class Envelope:
    """What a run does to the machine, predicted by the full-order model.

    Attributes
    ----------
    p_max, p_min : float
        Highest and lowest chamber pressure [Pa] (over both chambers).
    cavitation_margin : float
        Lowest chamber pressure above the oil's vapour pressure [Pa].
    stroke_used : float
        max x − min x [m].
    to_retracted, to_extended : float
        Smallest distance to the retracted (x = 0) and the extended (x = stroke) end stop [m].
    v_peak : float
        Highest |ẋ| [m/s].
    saturation : float
        Share of the run with the spool at ≥ 98 % of its travel [1].
    end_position : float
        Predicted rod position at the end of the run [m].
    """

    p_max: float
    p_min: float
    cavitation_margin: float
    stroke_used: float
    to_retracted: float
    to_extended: float
    v_peak: float
    saturation: float
    end_position: float

    @classmethod
    def of(cls, ch: Mapping[str, np.ndarray], params: SystemParams) -> Envelope:
        """The envelope of a simulated run's channels (``x``, ``v``, ``p_a``, ``p_b``, ``spool``)."""
        p = np.concatenate([ch["p_a"], ch["p_b"]])
        x = ch["x"]
        return cls(
            p_max=float(p.max()),
            p_min=float(p.min()),
            cavitation_margin=float(p.min() - params.oil.vapour_pressure),
            stroke_used=float(np.ptp(x)),
            to_retracted=float(x.min()),
            to_extended=float(params.cylinder.stroke - x.max()),
            v_peak=float(np.max(np.abs(ch["v"]))),
            saturation=float(np.mean(np.abs(ch["spool"]) >= 0.98)),
            end_position=float(x[-1]),
        )

    def breaks(self, lim: PlanLimits) -> list[tuple[str, str]]:
        """The limits this envelope breaks: (limit name, what happened), worst first."""
        out = []
        if min(self.to_retracted, self.to_extended) < lim.stroke_margin:
            end = "retracted" if self.to_retracted < self.to_extended else "extended"
            d = min(self.to_retracted, self.to_extended)
            out.append(
                (
                    "stroke_margin",
                    f"comes {1e3 * d:.1f} mm from the {end} end stop "
                    f"(limit {1e3 * lim.stroke_margin:g} mm)",
                )
            )
        if self.p_min < lim.min_pressure:
            out.append(
                (
                    "min_pressure",
                    f"a chamber falls to {self.p_min / 1e5:.1f} bar "
                    f"(limit {lim.min_pressure / 1e5:g} bar)",
                )
            )
        if lim.max_pressure is not None and self.p_max > lim.max_pressure:
            out.append(
                (
                    "max_pressure",
                    f"a chamber reaches {self.p_max / 1e5:.1f} bar "
                    f"(limit {lim.max_pressure / 1e5:g} bar)",
                )
            )
        if self.v_peak > lim.max_velocity:
            out.append(
                (
                    "max_velocity",
                    f"the rod reaches {self.v_peak:.3g} m/s (limit {lim.max_velocity:g} m/s)",
                )
            )
        return out

    def to_dict(self) -> dict[str, float]:
        """The envelope in SI, by field name."""
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class PlannedRun:
    """One run of a plan: the sampled command and what it is predicted to do.

    Attributes
    ----------
    name, experiment : str
        As in :class:`~hydropwa.rig.RunSpec`.
    t : ndarray
        Sample times [s] at the plan's rate, from 0.
    u : ndarray
        Valve command [1] at ``t``.
    f_l : ndarray or None
        Counter-force reference of the second cylinder [N] at ``t`` (friction and load runs).
    start_position : float
        Rod position the run starts from [m].
    record_until : float
        End of the experiment proper [s]; after it the command ramps to 0 and rests (the
        import keeps only ``[0, record_until]``).
    envelope : Envelope
    adaptation : str
        ``""``, or what was changed to keep the limits and why.
    meta : dict
        The run's setting, as the virtual rig records it (``signal``, ``frequency``, ...).
    predicted : dict
        The full model's channels at ``t`` (``x``, ``v``, ``p_a``, ``p_b``, ``spool``) [SI].
    """

    name: str
    experiment: str
    t: np.ndarray
    u: np.ndarray
    f_l: np.ndarray | None
    start_position: float
    record_until: float
    envelope: Envelope
    adaptation: str = ""
    meta: dict[str, Any] = field(default_factory=dict)
    predicted: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def duration(self) -> float:
        """Length of the command [s]."""
        return float(self.t[-1])


@dataclass(frozen=True)
class RefusedRun:
    """A run left out of a plan: the limit it breaks and how."""

    name: str
    experiment: str
    limit: str
    message: str

    def __str__(self) -> str:
        return f"run {self.name!r} refused: {self.message} ({self.limit})"


# --------------------------------------------------------------------- one run
def _simulate(params: SystemParams, spec: RunSpec, t, u, f_l) -> dict[str, np.ndarray]:
    if spec.counter_force is not None and spec.counter_force.get("damping", 0.0) > 0.0:
        params = params.replace(**{"load.damping": spec.counter_force["damping"]})
    res = simulate(
        machine_model(params),
        Sampled(t, u),
        timepts=t,
        load_force=None if f_l is None else Sampled(t, f_l),
        initial_position=spec.start_position,
        rtol=1e-5,
        raise_on_failure=False,
    )
    return dict(res.channels)


def _force_reference(spec: RunSpec, t: np.ndarray, params: SystemParams) -> np.ndarray | None:
    """The counter force the second cylinder's controller is asked for (no ripple, no noise)."""
    if spec.counter_force is not None:
        ref = dict(spec.counter_force, ripple=0.0, noise=0.0)
        sig = counter_force_signal(ref, float(t[-1]), np.random.default_rng(0), params.load.force)
        return np.asarray(sig(t), dtype=float)
    if spec.load_profile is not None:
        return np.interp(t, spec.load_profile[0], spec.load_profile[1])
    return None


def _cut(t: np.ndarray, u: np.ndarray, t_end: float, rate: float) -> tuple[np.ndarray, np.ndarray]:
    """The command up to ``t_end``, then a ramp to 0 and a rest at 0 (sampled at ``rate``)."""
    n_end = int(np.searchsorted(t, t_end, side="right"))
    tail = np.arange(1, int(round((_RAMP_DOWN + _REST) * rate)) + 1) / rate
    u_end = u[n_end - 1]
    ramp = u_end * np.clip(1.0 - tail / _RAMP_DOWN, 0.0, 1.0)
    return np.concatenate([t[:n_end], t[n_end - 1] + tail]), np.concatenate([u[:n_end], ramp])


@dataclass
class _Attempt:
    """The changes made to one run so far: the command's scale, its end, and why."""

    scale: float = 1.0
    t_end: float = math.inf
    shortened: str = ""
    scaled: list[str] = field(default_factory=list)

    def describe(self, t_end: float) -> str:
        """One phrase per kind of change: ``"shortened to 1.2 s: ...; scaled by 0.64: ..."``."""
        parts = [f"shortened to {t_end:.3g} s: {self.shortened}"] if self.shortened else []
        if self.scale != 1.0:
            reasons = "; ".join(dict.fromkeys(self.scaled))
            parts.append(f"scaled by {self.scale:.3g}: {reasons}")
        return "; ".join(parts)


def _first_break(ch: Mapping[str, np.ndarray], t: np.ndarray, params, lim: PlanLimits) -> float:
    """Time [s] of the first sample at which the rod comes within the stroke margin of a stop."""
    x = ch["x"]
    bad = np.flatnonzero((x < lim.stroke_margin) | (x > params.cylinder.stroke - lim.stroke_margin))
    return float(t[bad[0]]) if bad.size else math.inf


def _adapt(spec: RunSpec, params: SystemParams, lim: PlanLimits, rate: float, strict: bool):
    """Sample, simulate and adapt one run; a PlannedRun or a RefusedRun."""
    duration = spec.duration
    t_full = np.arange(int(math.floor(duration * rate + 1e-9)) + 1) / rate
    u_full = np.asarray(spec.command(t_full), dtype=float)
    a = _Attempt()
    peak = float(np.max(np.abs(u_full)))
    if peak > lim.max_opening:
        if strict:
            return _refuse(spec, "max_opening", f"commands {100 * peak:.3g} % opening")
        a.scale = lim.max_opening / peak
        a.scaled.append(f"opening {100 * peak:.3g} % above max_opening")
    if duration > lim.max_duration:
        if strict:
            return _refuse(spec, "max_duration", f"lasts {duration:g} s")
        a.t_end = lim.max_duration - _RAMP_DOWN - _REST
        a.shortened = f"lasts {duration:g} s (max_duration)"
    f_full = _force_reference(spec, t_full, params)
    limit, what = "", ""
    for _ in range(_TRIES):
        ch = _simulate(params, spec, t_full, a.scale * u_full, f_full)
        n = _stop_index(ch["x"], t_full[: ch["x"].size], spec, params.cylinder.stroke)
        t_end = min(a.t_end, float(t_full[min(n, ch["x"].size) - 1]))
        t_break = _first_break(ch, t_full, params, lim) - _RAMP_DOWN
        if t_break < t_end:
            if strict:
                return _refuse_stroke(spec, ch, t_full, params, lim)
            if t_break < _needed(spec) - 1e-9:  # too short to use: a smaller command drifts less
                limit, what = "stroke_margin", _stroke_break(spec, ch, t_full, params, lim)
                a.scale *= 0.8
                a.scaled.append(f"reaches the stroke margin before {_needed(spec):.3g} s")
                continue
            t_end = t_break
            a.shortened = (
                f"would come within {1e3 * lim.stroke_margin:g} mm of an end stop (stroke_margin)"
            )
        t, u = _cut(t_full, a.scale * u_full, t_end, rate)
        f_l = None if f_full is None else np.interp(t, t_full, f_full)
        ch_cut = _simulate(params, spec, t, u, f_l)
        if ch_cut["x"].size < t.size:
            return _refuse(spec, "solver", "the full model failed on it")
        env = Envelope.of(ch_cut, params)
        broken = env.breaks(lim)
        if not broken:
            return _planned(spec, t, u, f_l, t_end, env, a, ch_cut)
        limit, what = broken[0]
        if strict:
            return _refuse(spec, limit, what)
        if limit == "stroke_margin":  # the ramp-down overshoots: stop earlier
            a.t_end = t_end - max(0.1 * t_end, 2 * _RAMP_DOWN)
            a.shortened = f"{what} while its command ramps down (stroke_margin)"
        else:
            a.scale *= 0.8
            a.scaled.append(f"{what} ({limit})")
    return _refuse(spec, limit, what)


def _needed(spec: RunSpec) -> float:
    """The shortest useful run [s]: its minimum duration, or the end of its fit window (FRF)."""
    window = spec.meta.get("fit_window") or (0.0, 0.0)
    return max(spec.min_duration, float(window[1]))


def _stroke_break(spec: RunSpec, ch, t, params, lim: PlanLimits) -> str:
    t_hit = _first_break(ch, t, params, lim)
    return f"comes within {1e3 * lim.stroke_margin:g} mm of an end stop at {t_hit:.3g} s" + (
        f", before {_needed(spec):.3g} s" if t_hit < _needed(spec) else ""
    )


def _refuse_stroke(spec: RunSpec, ch, t, params, lim: PlanLimits) -> RefusedRun:
    return _refuse(spec, "stroke_margin", _stroke_break(spec, ch, t, params, lim))


def _refuse(spec: RunSpec, limit: str, what: str) -> RefusedRun:
    return RefusedRun(spec.name, spec.experiment, limit, what)


def _planned(spec, t, u, f_l, t_end, env, a: _Attempt, ch) -> PlannedRun:
    meta = dict(spec.meta)
    if a.scale != 1.0:
        for key in ("amplitude", "opening", "level"):
            if key in meta:
                meta[key] = float(meta[key]) * a.scale
    cmd = spec.command.describe()
    signal = {"type": cmd.pop("kind"), **cmd, "scale": a.scale}
    meta.update(signal=signal, start_position=spec.start_position)
    return PlannedRun(
        name=spec.name,
        experiment=spec.experiment,
        t=t,
        u=u,
        f_l=f_l,
        start_position=spec.start_position,
        record_until=float(t_end),
        envelope=env,
        adaptation=a.describe(t_end),
        meta=meta,
        predicted={k: ch[k] for k in PREDICTED},
    )


def _clamped_start(spec: RunSpec, stroke: float, lim: PlanLimits) -> RunSpec:
    """A run that starts against an end stop starts twice the stroke margin from it."""
    lo, hi = 2 * lim.stroke_margin, stroke - 2 * lim.stroke_margin
    x0 = min(max(spec.start_position, lo), hi)
    if x0 == spec.start_position:
        return spec
    stop_at = (
        None if spec.stop_at is None else max(spec.stop_at - abs(x0 - spec.start_position), 0.0)
    )
    return dataclasses.replace(spec, start_position=x0, stop_at=stop_at)


# --------------------------------------------------------------------- the plan
@dataclass(frozen=True)
class Plan:
    """A campaign sized to a machine, every run sampled and checked on the full model.

    Attributes
    ----------
    params : SystemParams
        The machine.
    campaign : str
        Campaign name.
    rate : float
        Sample rate of the command files [Hz].
    limits : PlanLimits
        The limits every run keeps (``max_pressure`` resolved).
    runs : tuple of PlannedRun
    refused : tuple of RefusedRun
    strict : bool
        Refused instead of adapted.
    """

    params: SystemParams
    campaign: str
    rate: float
    limits: PlanLimits
    runs: tuple[PlannedRun, ...]
    refused: tuple[RefusedRun, ...] = ()
    strict: bool = False

    @property
    def status(self) -> ResultStatus:
        """``SUCCESS`` (every run planned, adapted ones included) or ``PARTIAL`` (runs refused)."""
        return ResultStatus.PARTIAL if self.refused else ResultStatus.SUCCESS

    @property
    def success(self) -> bool:
        """True when no run was refused."""
        return self.status.success

    def to_pandas(self) -> pd.DataFrame:
        """One row per planned run: duration [s], start [m], the envelope (SI), adaptation."""
        import pandas as pd  # deferred: pandas, only for the table

        rows = [
            {
                "run": r.name,
                "experiment": r.experiment,
                "duration": r.duration,
                "start_position": r.start_position,
                **r.envelope.to_dict(),
                "adaptation": r.adaptation,
            }
            for r in self.runs
        ]
        return pd.DataFrame(rows).set_index("run") if rows else pd.DataFrame()

    def plot(self, *, ax: Any = None) -> Any:
        """Each run's envelope against the limits (pressures, end stops, speed, saturation)."""
        from ._plan_files import envelope_figure  # deferred: matplotlib loads only here

        return envelope_figure(self, ax=ax)

    def _repr_html_(self) -> str:
        from ._plan_files import plan_html  # deferred: the page's writer, only here

        return plan_html(self, page=False)

    @property
    def message(self) -> str:
        """One line: how many runs, adapted, refused."""
        n_ad = sum(1 for r in self.runs if r.adaptation)
        return (
            f"{len(self.runs)} run(s) planned ({n_ad} adapted), {len(self.refused)} refused, "
            f"at {self.rate:g} Hz, {sum(r.duration for r in self.runs):.1f} s in all"
        )

    def summary(self) -> str:
        """The message, the adapted and refused runs and the worst envelope per experiment."""
        lines = [self.message]
        lines += [f"  {r.name}: {r.adaptation}" for r in self.runs if r.adaptation]
        lines += [f"  {r}" for r in self.refused]
        for exp in EXPERIMENTS:
            runs = [r for r in self.runs if r.experiment == exp]
            if runs:
                lines.append(f"  {exp}: {_worst(runs)}")
        return "\n".join(lines)

    def to_manifest(self) -> dict[str, Any]:
        """The plan's manifest (what ``manifest.json`` holds)."""
        return {
            "format": "hydropwa-plan/1",
            "generator": f"hydropwa {__version__} rig plan",
            "status": self.status.name.lower(),
            "message": self.message,
            "campaign": self.campaign,
            "rate": self.rate,
            "strict": self.strict,
            "limits": self.limits.to_dict(),
            "machine": self.params.to_dict(),
            "log_columns": {k: list(v) for k, v in LOG_COLUMNS.items()},
            "runs": [_run_entry(r, self.params) for r in self.runs],
            "refused": [dataclasses.asdict(r) for r in self.refused],
        }

    def write(
        self,
        out: str | os.PathLike,
        *,
        overwrite: bool = False,
        controller: str | os.PathLike | None = None,
        controller_design: Mapping[str, Any] | None = None,
    ) -> Path:
        """Write the plan folder (all files, or none: written to a temporary folder first).

        Parameters
        ----------
        out : path
            The plan folder.
        overwrite : bool
            Replace an existing folder.
        controller : path, optional
            The position controller file (``hydropwa control design``) that plays the
            positioning references; copied into the plan as ``controller.toml``/``.json``.
        controller_design : mapping, optional
            Where that controller came from and its verification verdict (``source``,
            ``verification``, ...), written as the manifest's ``controller_design``; where no
            controller is written, why (its ``reason``).
        """
        from ._plan_files import write_plan_files  # deferred: matplotlib and the MAT writer

        doc = self.to_manifest()
        doc["controller"] = (
            None if controller is None else f"controller{Path(controller).suffix.lower()}"
        )
        if controller_design is not None:
            doc["controller_design"] = dict(controller_design)
        if controller is None:
            doc["controller_hint"] = (
                "design the position controller with `hydropwa control design --params "
                "PLAN/machine.toml --out PLAN/controller.toml` (or give rig plan --controller)"
            )
        with atomic_folder(out, overwrite=overwrite) as tmp:
            if controller is not None:
                (tmp / doc["controller"]).write_bytes(Path(controller).read_bytes())
            write_plan_files(self, tmp)
            (tmp / "machine.toml").write_text(
                params_to_toml(self.params, "the machine this plan was sized for"),
                encoding="utf-8",
            )
            (tmp / PLAN_MANIFEST).write_text(
                json.dumps(_json_safe(doc), indent=1), encoding="utf-8"
            )
        return Path(out)


def _worst(runs: list[PlannedRun]) -> str:
    e = [r.envelope for r in runs]
    return (
        f"p {min(x.p_min for x in e) / 1e5:.1f}…{max(x.p_max for x in e) / 1e5:.1f} bar, "
        f"end stops ≥ {1e3 * min(min(x.to_retracted, x.to_extended) for x in e):.1f} mm, "
        f"|v| ≤ {max(x.v_peak for x in e):.3g} m/s, "
        f"saturated ≤ {100 * max(x.saturation for x in e):.0f} %"
    )


def _json_safe(obj: Any) -> Any:
    return json.loads(
        json.dumps(obj, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o))
    )


def _run_entry(r: PlannedRun, params: SystemParams) -> dict[str, Any]:
    return {
        "name": r.name,
        "experiment": r.experiment,
        "files": {
            "csv": f"commands/{r.name}.csv",
            "mat": f"commands/{r.name}.mat",
            "positioning": f"positioning/{r.name}.csv",
            "predicted": f"predicted/{r.name}.csv",
        },
        "duration": r.duration,
        "record_until": r.record_until,
        "rate": float(1.0 / (r.t[1] - r.t[0])) if r.t.size > 1 else None,
        "samples": int(r.t.size),
        "start_position": r.start_position,
        "positioning": {
            "to": r.start_position,
            "how": f"closed loop: follow positioning/{r.name}.csv (t [s], r [m]) with the "
            "plan's position controller (manifest 'controller'), hold 0.5 s, then play the "
            "command file open loop",
        },
        "counter_force": r.f_l is not None,
        "envelope": r.envelope.to_dict(),
        "adaptation": r.adaptation,
        "meta": r.meta,
    }


def plan_campaign(
    params: SystemParams,
    campaign: Campaign | None = None,
    limits: PlanLimits | None = None,
    *,
    rate: float = 1000.0,
    strict: bool = False,
    experiments: tuple[str, ...] | None = None,
) -> Plan:
    """Plan a campaign for a real rig: sample every run at ``rate`` and check it on the full model.

    Parameters
    ----------
    params : SystemParams
        The machine.
    campaign : Campaign, optional
        Default: the campaign sized to the machine (:func:`~hydropwa.rig.size_campaign`).
    limits : PlanLimits, optional
        Default: :class:`PlanLimits` (5 mm to the end stops, 0 bar … relief pressure, 1 m/s,
        full opening, 30 s).
    rate : float
        The rig controller's sample rate [Hz] (100 Hz … 100 kHz).
    strict : bool
        Refuse a run that breaks a limit instead of shortening or scaling it.
    experiments : tuple of str, optional
        Plan only these of the campaign's experiments.

    Returns
    -------
    Plan
        With ``strict``, the first refused run raises instead.

    Raises
    ------
    ParameterError
        A rate outside 100 Hz … 100 kHz, an unknown experiment, or (``strict``) a run that
        breaks a limit: one line naming the run and the limit.
    """
    if not (isinstance(rate, int | float) and math.isfinite(rate) and 100.0 <= rate <= 1e5):
        raise ParameterError(f"rate = {rate!r} Hz: give the rig's sample rate, 100 Hz … 100 kHz")
    campaign = campaign or size_campaign(params)
    lim = (limits or PlanLimits()).resolved(params)
    rig = Rig.from_params(params)
    names = tuple(campaign.experiments) if experiments is None else experiments
    runs: list[PlannedRun] = []
    refused: list[RefusedRun] = []
    for name in names:
        for spec in plan(campaign[name], rig):
            spec = _clamped_start(spec, params.cylinder.stroke, lim)
            out = _adapt(spec, params, lim, float(rate), strict)
            if isinstance(out, RefusedRun):
                if strict:
                    raise ParameterError(f"{out}; --strict refuses instead of adapting")
                refused.append(out)
            else:
                runs.append(out)
    return Plan(params, campaign.name, float(rate), lim, tuple(runs), tuple(refused), strict)
