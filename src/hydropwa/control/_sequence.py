"""Position ↔ force switching without a bump, and the press cycle (issue 52, item 3).

A press approaches in position, touches the part, presses in force and retracts in position.
:func:`press_cycle` runs that sequence on the full model as segments of one trajectory, each
under its law, the state carried over at every transfer:

1. **approach** (position law): a trapezoid from the start to 5 mm past the contact at the
   approach speed; the transfer is *on contact force*: the first sample whose measured
   cylinder force exceeds ``contact_force`` (the run is repeated up to that sample);
2. **press** (force law): the reference starts at the force measured at the transfer, ramps to
   ``force`` in ``ramp_time``, holds ``hold_time``, and ramps back to the contact force; the
   transfer back is *on command* at the end of that release ramp;
3. **retract** (position law): a trapezoid from the position there back to the start.

At each transfer the new law starts from the old one's last command (the delay's pending
command and the saturation memory, the law's ``transfer_start`` stage) and its integral is set
so that its first command is that command (:func:`transfer_integral`, one sample of the law
replayed with the integral at 0: the command is affine in it): the valve command is continuous.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._layout import Y_FULL
from ..simulation import Sampled, simulate
from ..simulation import _controller as C
from ._controllers import ControlError
from ._reference import MotionProfile

__all__ = ["PressCycle", "press_cycle", "transfer_integral"]


def transfer_integral(controller, y, r: float, rates: tuple[float, float, float], areas, u0, c0):
    """The integral [output unit·s] with which ``controller``'s first command at state ``y``
    (full model), reference ``r`` and reference rates (ṙ, ṙ_ff, r̈) is the opening ``c0``."""
    probe = dataclasses.replace(controller, transfer=(0.0, u0, c0))
    ctl = probe.pack()
    cst = np.zeros(C.N_CST)
    log = np.zeros((C.N_LOG, 1))
    rch = np.zeros((C.N_RCH, 1))
    rch[C.RC_DR, 0], rch[C.RC_DRFF, 0], rch[C.RC_DDR, 0] = rates
    sg = np.zeros(32)
    C.controller_sample(
        0, 0, 0.0, np.asarray(y, float), areas[0], areas[1], ctl, cst, np.array([r]), rch, sg, log
    )
    row = int(log[C.L_ROW, 0])
    ki = float(ctl[C.C_ROWS + C.ROW * row + C.R_KI])
    if ki == 0.0:
        return 0.0
    return (c0 - float(log[C.L_C, 0])) / ki


@dataclass(frozen=True)
class PressCycle:
    """The segments' results, the transfer times [s] and the cycle's metrics (SI)."""

    segments: list[Any]
    transfers: list[float]
    metrics: dict[str, float] = field(default_factory=dict)


def _cylinder_force(res, cyl) -> np.ndarray:
    return cyl.area_a * res["p_a"] - cyl.area_b * res["p_b"]


def _opening(ctrl, u: float) -> float:
    return float(C.spool_opening(u, 0.0, ctrl.pack())[0])


def _handover(prev, ctrl, r0: float, rates, cyl):
    """``ctrl`` set to take over from the run ``prev``: its last command, the matching integral."""
    u0 = float(prev.control["u"][-1])
    c0 = _opening(ctrl, u0)
    y = prev.states[-1]
    i0 = transfer_integral(ctrl, y, r0, rates, (cyl.area_a, cyl.area_b), u0, c0)
    return dataclasses.replace(ctrl, transfer=(i0, u0, c0)), y


def _run(prm, ctrl, ref, duration, y0, noise, seed, x0=None):
    kw = {"initial_state": y0} if y0 is not None else {"initial_position": x0}
    res = simulate(
        "full",
        params=prm,
        controller=ctrl,
        reference=ref,
        duration=duration,
        sensor_noise=noise,
        seed=seed,
        **kw,
    )
    if not res.success:
        raise ControlError(f"press cycle: {res.message}")
    return res


def _approach(prm, position, x_start, speed, contact_force, noise, seed):
    ld, cyl = prm.load, prm.cylinder
    prof = MotionProfile(
        start_position=x_start,
        end_position=ld.contact_position + 5e-3,
        start_time=0.02,
        max_velocity=speed,
        max_acceleration=2.0,
    )
    t_end = prof.start_time + prof.duration + 0.2
    res = _run(prm, position, prof, t_end, None, noise, seed, x0=x_start)
    above = np.flatnonzero(_cylinder_force(res, cyl) - ld.force > contact_force)
    if above.size == 0:
        raise ControlError("press cycle: the rod never reached the contact force")
    ts = position.sample_time
    t_sw = ts * np.ceil(res["t"][above[0]] / ts)
    return _run(prm, position, prof, t_sw, None, noise, seed, x0=x_start), prof


def press_cycle(
    params,
    position,
    force_law,
    *,
    approach: float = 0.1,
    speed: float = 0.1,
    force: float = 20e3,
    ramp_time: float = 0.05,
    hold_time: float = 0.5,
    contact_force: float = 1e3,
    sensor_noise: dict[str, float] | None = None,
    seed: int = 1,
) -> PressCycle:
    """Approach ``approach`` [m] at ``speed`` [m/s], press to ``force`` [N] in ``ramp_time`` [s],
    hold ``hold_time`` [s], release, retract (module docstring); returns a :class:`PressCycle`.

    ``position``: a position controller; ``force_law``: a force controller (``output="force"``).
    """
    if getattr(force_law, "output", "position") != "force" or position.output != "position":
        raise ControlError("press_cycle needs a position controller and a force controller")
    cyl = params.cylinder
    x_start = params.load.contact_position - approach
    a, prof = _approach(params, position, x_start, speed, contact_force, sensor_noise, seed)
    f0 = float(_cylinder_force(a, cyl)[-1])
    t_up, t_hold = ramp_time, ramp_time + hold_time
    times = np.array([0.0, t_up, t_hold, t_hold + ramp_time, t_hold + ramp_time + 0.01])
    forces = np.array([f0, force, force, contact_force, contact_force])
    ref_f = Sampled(times, forces)
    fl, y = _handover(a, force_law, f0, (force / ramp_time, force / ramp_time, 0.0), cyl)
    b = _run(params, fl, ref_f, float(times[-1]), y, sensor_noise, seed + 1)
    x_b = float(b.states[-1][Y_FULL["x"]])
    back = MotionProfile(
        start_position=x_b,
        end_position=x_start,
        start_time=0.0,
        max_velocity=speed,
        max_acceleration=2.0,
    )
    pos, y = _handover(b, position, x_b, (0.0, 0.0, 0.0), cyl)
    c = _run(params, pos, back, back.duration + 0.2, y, sensor_noise, seed + 2)
    t_a = float(a["t"][-1])
    return PressCycle(
        [a, b, c], [t_a, t_a + float(times[-1])], _metrics(a, b, c, force, t_up, t_hold, cyl)
    )


def _metrics(a, b, c, force, t_up, t_hold, cyl) -> dict[str, float]:
    f = _cylinder_force(b, cyl)
    t = b["t"]
    hold = (t >= t_up + 0.1 * (t_hold - t_up)) & (t <= t_hold)
    # the new law's first two commands (the pending one and its own first) against the old
    # law's last
    jumps = [
        float(np.max(np.abs(b.control["u"][:2] - a.control["u"][-1]))),
        float(np.max(np.abs(c.control["u"][:2] - b.control["u"][-1]))),
    ]
    steps = np.abs(np.diff(np.concatenate([a.control["u"], b.control["u"], c.control["u"]])))
    return {
        "hold_error": float(np.max(np.abs(f[hold] - force))) if hold.any() else float("nan"),
        "hold_mean_error": float(np.mean(f[hold] - force)) if hold.any() else float("nan"),
        "overshoot": max(float(np.max(f[t <= t_hold]) - force), 0.0) / force,
        "jump_contact": jumps[0],
        "jump_release": jumps[1],
        "largest_command_step": float(np.max(steps)),
        "p_min": float(min(min(r["p_a"].min(), r["p_b"].min()) for r in (a, b, c))),
    }
