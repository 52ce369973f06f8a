"""Verification of a force (or pressure) controller on the full model before it leaves design (issue 52).

As position designs are (:func:`~hydropwa.control.verify_controller`): the full model with the
sensors' noise (20 µm, 0.1 bar per chamber by default) and the design's sample of delay, over
the nominal parameters and ``draws − 1`` draws of :func:`~hydropwa.control._verify.draw_parameters`,
each with the specimen's stiffness at the factors :data:`STIFFNESS_FACTORS` of the design's
(the controller keeps the stiffness it was designed with). Tasks (:func:`force_task_set`): a
force ramp to a hold and sines about a mean force; checks (:data:`FORCE_CRITERIA`): the hold's
mean error and its overshoot, the sines' RMS error, no chamber below 1 bar absolute, the run
completes. The verdict is ``pass`` when every run meets every check.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._layout import FULL_KIND
from ..simulation import Sampled, Sine, simulate
from ._controllers import ControlError
from ._verify import draw_parameters

__all__ = [
    "FORCE_CRITERIA",
    "STIFFNESS_FACTORS",
    "ForceTask",
    "ForceVerification",
    "force_task_set",
    "force_metrics",
    "verify_force",
]

#: the specimen's stiffness in the verification runs, times the design's (the issue's ±50 %)
STIFFNESS_FACTORS = (0.5, 1.0, 1.5)
#: limits of the checks: hold error and overshoot [fraction of the ramp's force step], the
#: sines' RMS error [fraction of the amplitude], the lowest chamber pressure [Pa absolute]
FORCE_CRITERIA = {"hold_error": 0.01, "overshoot": 0.05, "sine_rms": 0.10, "p_min": 1e5}
#: the default sensor noise (x [m], p_a, p_b [Pa]): the issue's 20 µm and 0.1 bar
DEFAULT_NOISE = {"x": 20e-6, "p_a": 0.1e5, "p_b": 0.1e5}


@dataclass(frozen=True)
class ForceTask:
    """One verification run: the force reference (a Signal, N), its length [s], the force at
    t = 0 [N], the window [s] its check reads, and which check (``hold`` or ``sine``)."""

    name: str
    reference: Any
    duration: float
    start_force: float
    window: tuple[float, float]
    check: str
    size: float


def force_task_set(params, per: float = 1.0) -> list[ForceTask]:
    """A 50 ms ramp from 10 % to 60 % of A_A·P_S held 0.4 s, and sines of ±15 % about 40 % at 1
    and 10 Hz; the references in the controller's unit, ``per`` of them per N (1/A_A for a
    pressure output), the sizes and start forces in N."""
    f_max = params.cylinder.area_a * params.supply.pressure
    f0, f1 = 0.1 * f_max, 0.6 * f_max
    ramp = Sampled(np.array([0.0, 0.05, 0.1, 0.6]), per * np.array([f0, f0, f1, f1]))
    tasks = [ForceTask("ramp and hold", ramp, 0.6, f0, (0.3, 0.6), "hold", f1 - f0)]
    for hz in (1.0, 10.0):
        sine = Sine(amplitude=per * 0.15 * f_max, frequency=hz, offset=per * 0.4 * f_max)
        tasks.append(
            ForceTask(f"sine {hz:g} Hz", sine, 0.6, 0.4 * f_max, (0.2, 0.6), "sine", 0.15 * f_max)
        )
    return tasks


def force_metrics(result, task: ForceTask) -> dict[str, float]:
    """Force tracking metrics of one run over the task's window: RMS and mean error [N],
    overshoot [fraction of the step], lowest chamber pressure [Pa]."""
    t = result["t"]
    keep = (t >= task.window[0]) & (t <= task.window[1])
    e = result["force_error"][keep]
    f = result["force"]
    ref_end = float(result["force_reference"][-1])
    over = float(np.max(f - ref_end)) / task.size if task.check == "hold" else 0.0
    return {
        "rms_error": float(np.sqrt(np.mean(e**2))),
        "mean_error": float(np.mean(e)),
        "overshoot": max(over, 0.0),
        "p_min": float(min(np.min(result["p_a"]), np.min(result["p_b"]))),
    }


def _failures(m: dict[str, float], task: ForceTask, crit: dict[str, float]) -> list[str]:
    out = []
    if task.check == "hold" and abs(m["mean_error"]) > crit["hold_error"] * task.size:
        out.append(f"hold error {m['mean_error']:.1f} N > {crit['hold_error']:.0%} of the step")
    if task.check == "hold" and m["overshoot"] > crit["overshoot"]:
        out.append(f"overshoot {m['overshoot']:.1%} > {crit['overshoot']:.0%}")
    if task.check == "sine" and m["rms_error"] > crit["sine_rms"] * task.size:
        out.append(f"RMS error {m['rms_error']:.1f} N > {crit['sine_rms']:.0%} of the amplitude")
    if m["p_min"] < crit["p_min"]:
        out.append(f"a chamber at {m['p_min'] / 1e5:.2f} bar < {crit['p_min'] / 1e5:g} bar")
    return out


@dataclass(frozen=True)
class ForceVerification:
    """Rows (one per run: draw, stiffness factor, task, metrics, failures) and the verdict."""

    rows: list[dict[str, Any]] = field(default_factory=list)

    @property
    def passed(self) -> bool:
        return all(not r["failures"] for r in self.rows)

    @property
    def verdict(self) -> str:
        return "pass" if self.passed else "fail"

    @property
    def failures(self) -> list[str]:
        return [
            f"draw {r['draw']}, k_s x{r['stiffness_factor']:g}, {r['task']}: {f}"
            for r in self.rows
            for f in r["failures"]
        ]

    def to_pandas(self):
        import pandas as pd  # deferred: pandas costs ~0.3 s at import

        return pd.DataFrame.from_records(
            [
                {k: v for k, v in r.items() if k != "failures"} | {"failed": len(r["failures"])}
                for r in self.rows
            ]
        )

    def record(self) -> dict[str, Any]:
        """The controller file's ``[verification]`` record."""
        worst = max((r["rms_error"] for r in self.rows), default=0.0)
        return {
            "verdict": self.verdict,
            "runs": len(self.rows),
            "worst_rms_error_n": worst,
            "failures": self.failures[:10],
        }


def _run(controller, params, task: ForceTask, noise, seed: int):
    ld = params.load
    k = ld.specimen_stiffness
    x0 = ld.contact_position + (task.start_force - ld.force - ld.preload) / k
    return simulate(
        FULL_KIND.name,
        params=params,
        controller=controller,
        reference=task.reference,
        duration=task.duration,
        initial_position=x0,
        sensor_noise=noise,
        seed=seed,
        raise_on_failure=False,
    )


def verify_force(
    controller,
    params,
    *,
    draws: int = 4,
    seed: int = 0,
    sensor_noise: dict[str, float] | None = None,
    stiffness_factors: tuple[float, ...] = STIFFNESS_FACTORS,
    criteria: dict[str, float] | None = None,
) -> ForceVerification:
    """Run the force task set on the full model over draws × stiffness factors (module docstring)."""
    if getattr(controller, "output", "position") == "position":
        raise ControlError(
            "verify_force needs a force or pressure controller (output force/pressure)"
        )
    k0 = params.load.specimen_stiffness
    if not k0 > 0:
        raise ControlError("verify_force needs the specimen: set load.specimen_stiffness [N/m]")
    crit = dict(FORCE_CRITERIA) | dict(criteria or {})
    noise = dict(DEFAULT_NOISE if sensor_noise is None else sensor_noise)
    rows: list[dict[str, Any]] = []
    for i, prm in enumerate(draw_parameters(params, draws, seed)):
        for fk in stiffness_factors:
            p = prm.replace(**{"load.specimen_stiffness": k0 * fk})
            per = 1.0 if controller.output == "force" else 1.0 / p.cylinder.area_a
            for task in force_task_set(p, per):
                res = _run(controller, p, task, noise, seed + i)
                row: dict[str, Any] = {"draw": i, "stiffness_factor": fk, "task": task.name}
                if not res.success:
                    rows.append(row | {"rms_error": math.inf, "failures": [res.message]})
                    continue
                m = force_metrics(res, task)
                rows.append(row | m | {"failures": _failures(m, task, crit)})
    return ForceVerification(rows)
