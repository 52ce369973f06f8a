"""Runs of each experiment: what is commanded, where the rod starts, how long it lasts.

:func:`plan` expands an experiment definition into :class:`RunSpec` objects (one per
setting); :func:`execute` simulates one of them on a :class:`~hydropwa.rig.Rig` and
measures it. Each run draws its noise from its own seed (:func:`run_seed`), so results
do not depend on the order or the process in which runs are executed.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..components import load_pressure_range
from ..models import machine_model
from ..simulation import Chirp, Constant, Sampled, Signal, Sine, Step, simulate
from ._campaign import (
    DeadZoneExperiment,
    Experiment,
    FrfExperiment,
    FrictionExperiment,
    LoadRuns,
    SineExperiment,
)
from ._faults import shift_command
from ._rig import Rig
from ._sensors import measure

__all__ = [
    "RunSpec",
    "plan",
    "execute",
    "run_seed",
    "counter_force_signal",
    "load_profile",
    "multisine",
]

_DIRNAME = {1: "extend", -1: "retract"}


@dataclass(frozen=True)
class RunSpec:
    """One run of an experiment.

    Attributes
    ----------
    name : str
        Run name (file stem), unique in the experiment.
    experiment : str
        ``frf``, ``deadzone``, ``friction`` or ``sine``.
    command : Signal
        Valve command u(t) [1].
    duration : float
        Simulated time [s].
    start_position : float
        Initial rod position [m].
    stop_at : float or None
        End the run once the rod has travelled this distance [m] (dead-zone, friction).
    min_duration : float
        Shortest run when ``stop_at`` is reached early [s].
    stop_margin : float or None
        End the run once the rod comes within this distance [m] of either end stop (sine
        runs: a chamber emptied against the stop reads below the pressure converter's range).
    counter_force : dict or None
        Counter-force settings (friction runs); the signal is drawn per run.
    load_profile : (tuple of float, tuple of float) or None
        Load force F_L [N] at times [s], linearly interpolated (the sine experiment's load runs).
    meta : dict
        Setting of the run for the metadata (``level``, ``frequency``, ``direction``, ...).
    command_offset : float
        Valve null fault [1]: added to the command inside the valve
        (:func:`~hydropwa.rig.shift_command`); the run records the command as sent.
    """

    name: str
    experiment: str
    command: Signal
    duration: float
    start_position: float
    stop_at: float | None = None
    min_duration: float = 0.0
    stop_margin: float | None = None
    counter_force: dict[str, float] | None = None
    load_profile: tuple[tuple[float, ...], tuple[float, ...]] | None = None
    meta: dict[str, Any] = field(default_factory=dict)
    command_offset: float = 0.0


def _pct(value: float) -> str:
    """``0.015 -> '01p5'``: a percentage for run names, without dots."""
    text = f"{100 * value:05.2f}".rstrip("0").rstrip(".")
    return text.replace(".", "p")


def run_seed(campaign_seed: int, experiment: str, run_name: str) -> np.random.SeedSequence:
    """Seed of one run: the campaign seed and a stable hash of the run's name.

    Parameters
    ----------
    campaign_seed : int
        Seed of the campaign (``--seed``).
    experiment, run_name : str
        Identify the run.

    Returns
    -------
    numpy.random.SeedSequence
        Independent of run order and process, so ``--jobs`` does not change results.
    """
    digest = hashlib.sha256(f"{experiment}/{run_name}".encode()).digest()
    key = tuple(int.from_bytes(digest[i : i + 4], "little") for i in range(0, 16, 4))
    return np.random.SeedSequence(entropy=int(campaign_seed), spawn_key=key)


# --------------------------------------------------------------------- planning
def _plan_frf(exp: FrfExperiment, rig: Rig) -> list[RunSpec]:
    runs = []
    x0 = exp.start_position * rig.params.cylinder.stroke
    for sweep in exp.sweeps:
        for f in sweep.frequencies:
            dur = exp.settle + (exp.periods + exp.margin_periods) / f
            cmd = Sine(amplitude=sweep.opening, frequency=f)
            runs.append(
                RunSpec(
                    name=f"frf_a{_pct(sweep.opening)}_f{f:06.2f}".replace(".", "p"),
                    experiment="frf",
                    command=cmd,
                    duration=dur,
                    start_position=x0,
                    meta={
                        "opening": sweep.opening,
                        "amplitude": sweep.opening,
                        "frequency": f,
                        "settle": exp.settle,
                        "periods": exp.periods,
                        "fit_window": [exp.settle, exp.settle + exp.periods / f],
                    },
                )
            )
    for bb in exp.broadband:
        runs.append(_broadband_run(bb, x0))
    return runs


def multisine(
    opening: float, f0: float, f1: float, period: float, duration: float, rate: float
) -> Sampled:
    """Schroeder-phased multisine: equal sines at k/period in [f0, f1], peak ``opening``.

    Parameters
    ----------
    opening : float
        Peak |u| [1].
    f0, f1 : float
        Band [Hz].
    period : float
        Period [s]; the lines lie on the grid k/period.
    duration : float
        Length [s] (whole periods are repeated).
    rate : float
        Rate [Hz] of the samples (linear interpolation between them).

    Returns
    -------
    Sampled
        u(t) [1]. Schroeder phases φ_k = −πk(k−1)/K keep the crest factor low, so the band
        gets more power at the same peak opening than with random phases.
    """
    k = np.arange(math.ceil(f0 * period - 1e-9), math.floor(f1 * period + 1e-9) + 1)
    freqs = k / period
    phases = -np.pi * np.arange(k.size) * (np.arange(k.size) - 1) / k.size
    t = np.arange(int(math.ceil(duration * rate)) + 1) / rate
    u = np.sum(np.sin(2 * np.pi * freqs[:, None] * t[None, :] + phases[:, None]), axis=0)
    one = np.sum(
        np.sin(2 * np.pi * freqs[:, None] * (t[t < period])[None, :] + phases[:, None]), axis=0
    )
    return Sampled(t, opening * u / np.max(np.abs(one)))


def _broadband_run(bb, x0: float) -> RunSpec:
    if bb.signal == "chirp":
        cmd: Signal = Chirp(amplitude=bb.opening, f0=bb.f0, f1=bb.f1, duration=bb.duration)
    else:
        cmd = multisine(
            bb.opening, bb.f0, bb.f1, bb.period, bb.duration, 8.0 * max(2000.0, 10 * bb.f1)
        )
    return RunSpec(
        name=f"frf_{bb.signal}_a{_pct(bb.opening)}",
        experiment="frf",
        command=cmd,
        duration=bb.duration,
        start_position=x0,
        meta={
            "opening": bb.opening,
            "amplitude": bb.opening,
            "band": [bb.f0, bb.f1],
            "excitation": bb.signal,
            **({"period": bb.period} if bb.signal == "multisine" else {}),
        },
    )


def _constant_runs(
    exp: DeadZoneExperiment | FrictionExperiment, rig: Rig, kind: str
) -> list[RunSpec]:
    stroke = rig.params.cylinder.stroke
    delay = exp.valve_delay if isinstance(exp, FrictionExperiment) else 0.0
    runs = []
    for d in exp.directions:
        for u in exp.inputs:
            level = d * u
            cmd: Signal = (
                Step(time=delay, before=0.0, after=level) if delay > 0 else Constant(level)
            )
            force = None
            if isinstance(exp, FrictionExperiment):
                force = {
                    "force": d * exp.counter_force,
                    "ramp": exp.force_ramp,
                    "ripple": exp.ripple,
                    "ripple_frequency": exp.ripple_frequency,
                    "noise": exp.force_noise,
                    "rate": exp.force_rate,
                    "damping": exp.counter_damping,
                }
            runs.append(
                RunSpec(
                    name=f"{kind}_{_DIRNAME[d]}_u{_pct(u)}",
                    experiment=kind,
                    command=cmd,
                    duration=exp.duration,
                    start_position=0.0 if d > 0 else stroke,
                    stop_at=exp.stop_at * stroke,
                    min_duration=delay + exp.min_duration,
                    counter_force=force,
                    meta={
                        "level": level,
                        "direction": _DIRNAME[d],
                        "valve_delay": delay,
                        **({"counter_force": force["force"]} if force else {}),
                    },
                )
            )
    return runs


def load_profile(
    runs: LoadRuns, params, direction: int
) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Load force F_L(t) of one load run: ramp-up, then the levels joined by ramps and steps.

    Parameters
    ----------
    runs : LoadRuns
        The campaign's ``[sine.load]`` settings.
    params : SystemParams
        The machine: areas, supply and tank pressure, static load F_0.
    direction : int
        +1 extend, −1 retract: the levels are fractions of this direction's load-pressure range
        (:func:`hydropwa.components.load_pressure_range`).

    Returns
    -------
    (times, forces) : tuple of tuple of float
        Breakpoints [s], [N] of a piecewise-linear F_L = A_A·P_L (positive opposes extension),
        starting at F_0 with a raised-cosine ramp (``force_ramp``) to the first level; after
        ``valve_delay`` each level is held ``hold`` and reached from the previous one by a
        ramp of ``ramp`` (odd transitions) or a step (even transitions).
    """
    cyl, sup = params.cylinder, params.supply
    lo, hi = load_pressure_range(
        direction, sup.pressure, cyl.area_b / cyl.area_a, sup.tank_pressure
    )
    force = [cyl.area_a * (lo + lev * (hi - lo)) for lev in runs.levels]
    f0 = params.load.force
    s = np.linspace(0.0, 1.0, 17)
    t = list(runs.force_ramp * s)
    f = list(f0 + (force[0] - f0) * 0.5 * (1.0 - np.cos(np.pi * s)))
    now = runs.valve_delay + runs.hold
    t.append(now)
    f.append(force[0])
    step = 1e-3  # a step: 1 ms, the rig's force loop
    for k, level in enumerate(force[1:]):
        now += runs.ramp if k % 2 == 0 else step
        t += [now, now + runs.hold]
        f += [level, level]
        now += runs.hold
    return tuple(float(v) for v in t), tuple(float(v) for v in f)


def _plan_load(runs: LoadRuns, rig: Rig) -> list[RunSpec]:
    stroke = rig.params.cylinder.stroke
    out = []
    for d in runs.directions:
        times, forces = load_profile(runs, rig.params, d)
        for u in runs.inputs:
            out.append(
                RunSpec(
                    name=f"sine_load_{_DIRNAME[d]}_u{_pct(u)}",
                    experiment="sine",
                    command=Step(time=runs.valve_delay, before=0.0, after=d * u),
                    duration=times[-1],
                    start_position=(runs.start_margin if d > 0 else 1.0 - runs.start_margin)
                    * stroke,
                    stop_margin=runs.stop_margin * stroke,
                    min_duration=runs.valve_delay + runs.hold,
                    load_profile=(times, forces),
                    meta={
                        "level": d * u,
                        "direction": _DIRNAME[d],
                        "valve_delay": runs.valve_delay,
                        "load_levels": list(runs.levels),
                    },
                )
            )
    return out


def _plan_sine(exp: SineExperiment, rig: Rig) -> list[RunSpec]:
    x0 = exp.start_position * rig.params.cylinder.stroke
    load = [] if exp.load is None else _plan_load(exp.load, rig)
    return [
        RunSpec(
            name=f"sine_f{f:g}_a{_pct(a)}".replace(".", "p"),
            experiment="sine",
            command=Sine(amplitude=a, frequency=f),
            duration=exp.periods / f,
            start_position=x0,
            stop_margin=exp.stop_margin * rig.params.cylinder.stroke,
            min_duration=1.0 / f,
            meta={"amplitude": a, "frequency": f, "periods": exp.periods},
        )
        for f in exp.frequencies
        for a in exp.amplitudes
    ] + load


def plan(experiment: Experiment, rig: Rig) -> list[RunSpec]:
    """Expand an experiment into its runs, one per setting, in campaign order."""
    if isinstance(experiment, FrfExperiment):
        return _plan_frf(experiment, rig)
    if isinstance(experiment, DeadZoneExperiment):
        return _constant_runs(experiment, rig, "deadzone")
    if isinstance(experiment, FrictionExperiment):
        return _constant_runs(experiment, rig, "friction")
    if isinstance(experiment, SineExperiment):
        return _plan_sine(experiment, rig)
    raise TypeError(f"unknown experiment {type(experiment).__name__}")


# --------------------------------------------------------------------- execution
def counter_force_signal(
    settings: dict[str, float], duration: float, rng: np.random.Generator, static: float = 0.0
) -> Sampled:
    """Load force F_L(t) of the second cylinder: smooth ramp-up, ripple and control noise.

    Parameters
    ----------
    settings : dict
        ``force`` [N] (signed, positive opposes extension), ``ramp`` [s], ``ripple`` [1],
        ``ripple_frequency`` [Hz], ``noise`` [N], ``rate`` [Hz].
    duration : float
        Length of the signal [s].
    rng : numpy.random.Generator
        Source of the control noise.
    static : float
        The machine's own constant load F_0 [N] (``Load.force``); the counter force adds to it.

    Returns
    -------
    Sampled
        F_L [N] sampled at ``rate``, linearly interpolated by the solver.

    Notes
    -----
    F_L(t) = F_0 + F·s(t)·(1 + r·sin 2πf_r t) + s(t)·n(t), with the raised-cosine ramp
    s(t) = (1 − cos(π t/T))/2 for t < T, 1 after, and white noise n of the given std.
    """
    rate = settings["rate"]
    n = int(math.ceil(duration * rate)) + 2
    t = np.arange(n) / rate
    s = np.where(t < settings["ramp"], 0.5 * (1.0 - np.cos(np.pi * t / settings["ramp"])), 1.0)
    ripple = 1.0 + settings["ripple"] * np.sin(2 * np.pi * settings["ripple_frequency"] * t)
    noise = rng.normal(0.0, settings["noise"], size=n) if settings["noise"] > 0 else np.zeros(n)
    return Sampled(t, static + settings["force"] * s * ripple + s * noise)


def _stop_index(x: np.ndarray, t: np.ndarray, spec: RunSpec, stroke: float = np.inf) -> int:
    """Number of samples to keep: up to where the rod has used ``stop_at`` of travel
    (or come within ``stop_margin`` of an end stop)."""
    if spec.stop_at is None and spec.stop_margin is None:
        return x.size
    if spec.stop_at is not None:
        hit = np.flatnonzero(np.abs(x - spec.start_position) >= spec.stop_at)
    else:
        margin = float(spec.stop_margin or 0.0)  # not None here: checked above
        hit = np.flatnonzero((x <= margin) | (x >= stroke - margin))
    if hit.size == 0:
        return x.size
    keep_until = max(t[hit[0]], spec.min_duration)
    return int(np.searchsorted(t, keep_until, side="right"))


def _load_meta(spec: RunSpec) -> dict[str, Any]:
    if spec.counter_force:
        return {"type": "counter_force", **spec.counter_force}
    if spec.load_profile is not None:
        return {
            "type": "profile",
            "times": list(spec.load_profile[0]),
            "forces": list(spec.load_profile[1]),
        }
    return {"type": "none"}


def execute(
    rig: Rig, spec: RunSpec, seed: np.random.SeedSequence, base_meta: dict[str, Any] | None = None
):
    """Simulate one run on the rig and measure it.

    Parameters
    ----------
    rig : Rig
    spec : RunSpec
    seed : numpy.random.SeedSequence
        Seed of this run (:func:`run_seed`).
    base_meta : dict, optional
        Metadata merged into the run's (campaign name, seed).

    Returns
    -------
    hydropwa.data.Run
        Measured channels; ``meta`` holds ``experiment``/``kind``, ``signal`` (commanded
        signal and parameters), the setting, ``load`` and ``start_position`` [m].
    """
    force_rng, sensor_rng = (np.random.default_rng(s) for s in seed.spawn(2))
    load = None
    if spec.counter_force is not None:
        load = counter_force_signal(
            spec.counter_force, spec.duration, force_rng, rig.params.load.force
        )
    elif spec.load_profile is not None:
        load = Sampled(np.asarray(spec.load_profile[0]), np.asarray(spec.load_profile[1]))
    params = rig.params
    if spec.counter_force is not None and spec.counter_force.get("damping", 0.0) > 0.0:
        params = params.replace(**{"load.damping": spec.counter_force["damping"]})
    model = machine_model(params)
    command = spec.command
    if spec.command_offset:
        command = shift_command(command, spec.command_offset)
    result = simulate(
        model,
        command,
        duration=spec.duration,
        load_force=load,
        initial_position=spec.start_position,
        fs=rig.fs,
        rtol=rig.rtol,
    )
    if spec.command_offset:  # the rig records the command as sent, not as the valve sees it
        result.channels = {**result.channels, "u": result.channels["u"] - spec.command_offset}
    n = _stop_index(result.channels["x"], result.t, spec, rig.params.cylinder.stroke)
    if n < result.t.size:
        result.channels = {k: v[:n] for k, v in result.channels.items()}
        result.t = result.channels["t"]
    signal = {"type": spec.command.describe()["kind"], **spec.command.describe()}
    signal.pop("kind")
    meta = {
        **(base_meta or {}),
        "experiment": spec.experiment,
        "kind": spec.experiment,
        "signal": signal,
        **spec.meta,
        "start_position": spec.start_position,
        "load": _load_meta(spec),
        "stopped_early": bool(n < round(spec.duration * rig.fs) + 1),
        "solver": {"steps": result.stats.steps, "rtol": rig.rtol},
    }
    return measure(result, rig.sensors or {}, sensor_rng, name=spec.name, meta=meta, fs=rig.fs)
