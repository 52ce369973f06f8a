"""Position ↔ force switching without a bump, and the press cycle (issue 52, item 3).

A press approaches in position, touches the part, presses in force and retracts in position.
:func:`press_cycle` runs that sequence on the full model as segments of one trajectory, each
under its law, the state carried over at every transfer:

1. **approach** (position law): a trapezoid from the start at the approach speed to
   :data:`CREEP_GAP` before the contact, then on at the creep speed F/(T_ramp·k_s) (a stiff part
   turns the speed into a force rate k_s·v: 5 MN/s at 5e7 N/m and 0.1 m/s); the transfer is *on contact force*: the first sample whose measured
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

from .._layout import FULL_KIND, Y_FULL
from ..simulation import Sampled, law_inputs, simulate
from ..simulation import _controller as C
from ._controllers import ControlError
from ._reference import MotionProfile

__all__ = [
    "AFTER_TRANSFER",
    "CREEP_GAP",
    "HOLD_SETTLE",
    "PressCycle",
    "PressSpec",
    "press_cycle",
    "transfer_integral",
]

#: the approach slows to the creep speed this far [m] before the contact position
CREEP_GAP = 1e-3
#: the hold's metrics are read from this long [s] after the end of the ramp on
HOLD_SETTLE = 0.1
#: the metrics ``step_after_*``: the largest command step over this many samples after a transfer
AFTER_TRANSFER = 10


def transfer_integral(
    controller, y, r: float, rates: tuple[float, float, float], areas, u0, c0, *, channels=None
):
    """The integral [output unit·s] with which ``controller``'s first command at state ``y``
    (full model), reference ``r`` and reference rates (ṙ, ṙ_ff, r̈) is the opening ``c0``.

    ``channels``: the run's whole first column of reference channels instead of ``rates`` (the
    look-ahead rates and the first sample's sensor noise as the run will draw them, from
    :func:`hydropwa.simulation.law_inputs`); with it the first command is ``c0`` in the run
    itself, not only in a noise-free replay without look-ahead.
    """
    probe = dataclasses.replace(controller, transfer=(0.0, u0, c0))
    ctl = probe.pack()
    cst = np.zeros(C.N_CST)
    log = np.zeros((C.N_LOG, 1))
    rch = np.zeros((C.N_RCH, 1))
    if channels is None:
        rch[C.RC_DR, 0], rch[C.RC_DRFF, 0], rch[C.RC_DDR, 0] = rates
    else:
        rch[:, 0] = np.asarray(channels, dtype=float)
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


def _handover(prev, ctrl, ref, duration: float, noise, seed, cyl):
    """``ctrl`` set to take over from the run ``prev`` for a run of ``duration`` [s] on ``ref``:
    its last command, and the integral that makes its first command that command as the run's
    law will see it (the reference's look-ahead rates and the first sample's noise included)."""
    u0 = float(prev.control["u"][-1])
    c0 = _opening(ctrl, u0)
    y = prev.states[-1]
    r, rch = law_inputs(ctrl, ref, duration, sensor_noise=noise, seed=seed)
    areas = (cyl.area_a, cyl.area_b)
    i0 = transfer_integral(ctrl, y, float(r[0]), (0.0, 0.0, 0.0), areas, u0, c0, channels=rch[:, 0])
    return dataclasses.replace(ctrl, transfer=(i0, u0, c0)), y


def _run(prm, ctrl, ref, duration, y0, noise, seed, x0=None):
    kw = {"initial_state": y0} if y0 is not None else {"initial_position": x0}
    res = simulate(
        FULL_KIND.name,
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


def _approach_reference(prm, x_start, speed, creep):
    """The approach: a trapezoid at ``speed`` to :data:`CREEP_GAP` before the contact, then on at
    the creep speed [m/s] (the rod meets the part no faster than the force ramp asks for);
    returns (reference, duration [s])."""
    x_c = prm.load.contact_position
    prof = MotionProfile(
        start_position=x_start,
        end_position=x_c - CREEP_GAP,
        start_time=0.02,
        max_velocity=speed,
        max_acceleration=2.0,
    )
    t1 = prof.start_time + prof.duration
    tt = np.concatenate([np.linspace(0.0, t1, 2000), [t1 + (CREEP_GAP + 2e-3) / creep]])
    xx = np.concatenate([np.asarray(prof(tt[:-1]), dtype=float), [x_c + 2e-3]])
    return Sampled(tt, xx), float(tt[-1]), t1


def _approach(prm, position, x_start, speed, creep, contact_force, noise, seed):
    ld, cyl = prm.load, prm.cylinder
    ref, t_end, t_creep = _approach_reference(prm, x_start, speed, creep)
    res = _run(prm, position, ref, t_end, None, noise, seed, x0=x_start)
    # armed in the creep only: starting the move takes breakaway and acceleration force too
    pressed = _cylinder_force(res, cyl) - ld.force > contact_force
    above = np.flatnonzero(pressed & (res["t"] >= t_creep))
    if above.size == 0:
        raise ControlError("press cycle: the rod never reached the contact force")
    ts = position.sample_time
    t_sw = ts * np.ceil(res["t"][above[0]] / ts)
    return _run(prm, position, ref, t_sw, None, noise, seed, x0=x_start)


@dataclass(frozen=True)
class PressSpec:
    """The press cycle: approach [m] at ``speed`` [m/s], ``force`` [N] reached in ``ramp_time``
    [s] and held ``hold_time`` [s], the contact transfer at ``contact_force`` [N]."""

    approach: float = 0.1
    speed: float = 0.1
    force: float = 20e3
    ramp_time: float = 0.05
    hold_time: float = 0.5
    contact_force: float = 2e3


def press_cycle(
    params,
    position,
    force_law,
    spec: PressSpec | None = None,
    *,
    sensor_noise: dict[str, float] | None = None,
    seed: int = 1,
) -> PressCycle:
    """Approach, press, hold, release, retract (module docstring; the numbers in ``spec``, a
    :class:`PressSpec`, default the issue's press); returns a :class:`PressCycle`.

    ``position``: a position controller; ``force_law``: a force controller (``output="force"``).
    """
    sp = PressSpec() if spec is None else spec
    approach, speed, force = sp.approach, sp.speed, sp.force
    ramp_time, hold_time, contact_force = sp.ramp_time, sp.hold_time, sp.contact_force
    if getattr(force_law, "output", "position") != "force" or position.output != "position":
        raise ControlError("press_cycle needs a position controller and a force controller")
    cyl = params.cylinder
    x_start = params.load.contact_position - approach
    # a stiff part turns the approach speed into a force rate k_s·v (5 MN/s at 5e7 N/m and
    # 0.1 m/s): the rod meets it no faster than the ramp's rate asks for
    creep = min(speed, force / ramp_time / params.load.specimen_stiffness)
    a = _approach(params, position, x_start, speed, creep, contact_force, sensor_noise, seed)
    f0 = float(_cylinder_force(a, cyl)[-1])
    t_up, t_hold = ramp_time, ramp_time + hold_time
    times = np.array([0.0, t_up, t_hold, t_hold + ramp_time, t_hold + ramp_time + 0.01])
    forces = np.array([f0, force, force, contact_force, contact_force])
    ref_f = Sampled(times, forces)
    fl, y = _handover(a, force_law, ref_f, float(times[-1]), sensor_noise, seed + 1, cyl)
    b = _run(params, fl, ref_f, float(times[-1]), y, sensor_noise, seed + 1)
    x_b = float(b.states[-1][Y_FULL["x"]])
    back = MotionProfile(
        start_position=x_b,
        end_position=x_start,
        start_time=0.0,
        max_velocity=speed,
        max_acceleration=2.0,
    )
    t_c = back.duration + 0.2
    pos, y = _handover(b, position, back, t_c, sensor_noise, seed + 2, cyl)
    c = _run(params, pos, back, t_c, y, sensor_noise, seed + 2)
    t_a = float(a["t"][-1])
    return PressCycle(
        [a, b, c], [t_a, t_a + float(times[-1])], _metrics(a, b, c, force, t_up, t_hold, cyl)
    )


def _metrics(a, b, c, force, t_up, t_hold, cyl) -> dict[str, float]:
    f = _cylinder_force(b, cyl)
    t = b["t"]
    hold = (t >= t_up + HOLD_SETTLE) & (t <= t_hold)  # the hold after its settling time
    # the new law's first two commands (the pending one and its own first) against the old
    # law's last
    jumps = [
        float(np.max(np.abs(b.control["u"][:2] - a.control["u"][-1]))),
        float(np.max(np.abs(c.control["u"][:2] - b.control["u"][-1]))),
    ]
    steps = np.abs(np.diff(np.concatenate([a.control["u"], b.control["u"], c.control["u"]])))
    # the new law's own steps over its first AFTER_TRANSFER samples (its response to the state
    # and the noise it takes over, beyond the bumpless first command)
    after = [float(np.max(np.abs(np.diff(r.control["u"][: AFTER_TRANSFER + 1])))) for r in (b, c)]
    return {
        "hold_error": float(np.max(np.abs(f[hold] - force))) if hold.any() else float("nan"),
        "hold_mean_error": float(np.mean(f[hold] - force)) if hold.any() else float("nan"),
        "overshoot": max(float(np.max(f[t <= t_hold]) - force), 0.0) / force,
        "jump_contact": jumps[0],
        "jump_release": jumps[1],
        "step_after_contact": after[0],
        "step_after_release": after[1],
        "largest_command_step": float(np.max(steps)),
        "p_min": float(min(min(r["p_a"].min(), r["p_b"].min()) for r in (a, b, c))),
    }
