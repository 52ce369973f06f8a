"""Force and pressure control designed on the chamber-level PWA model (issue 52).

The controlled output is the cylinder force F = A_A·P_A − A_B·P_B [N] from the pressure
sensors (``output="force"``) or the load pressure P_L [Pa] (``output="pressure"``); the law is
the position law of :mod:`hydropwa.simulation._controller` with the reference and the error in
that output (its stage ``output_stage``), so the C and the FMU are generated from it unchanged.

Design (:func:`design_force`):

1. the plant of each cell is the chamber PWA model (:class:`~hydropwa.linearization.ChamberPwaModel`,
   the spool, both chamber pressures, x and v: the valve is in it) linearized at a force hold
   against the specimen, y = F, input the opening c the dead-zone inverse delivers (B/k_g);
   the cells are :data:`FORCE_LEVELS` of the force range × the flow direction (the sign of the
   last opening), the rows' boxes over P_L and c;
2. per cell the highest crossover ω_c with a gain margin of ``gain_margin_db`` and a phase
   margin of ``phase_margin`` on the sampled plant (ZOH, the delay), the integral corner at
   ``integral_ratio``·ω_c (the rule of :func:`~hydropwa.control.design_pi`); k_p = ω_c/G,
   G = |jω P(jω)| at :data:`GAIN_FREQUENCY` the cell's integrating gain [N/s per unit opening];
3. feed-forward: the flow feed-forward (:class:`~hydropwa.control.FlowFeedForward`, the valve's
   orifice inverted at the measured load pressure) of the velocity (1/k_s + 1/k_h)·Ḟ_ref(t + τ)
   (k_s the estimated specimen stiffness, k_h = A_A²β/V_A + A_B²β/V_B the oil columns', τ the
   valve's lag, the ZOH and the delay); the dead-zone inverse and the quiet band at rest
   (``quiet_band``) as in position.

The baseline (:func:`design_force_pi`) is the commercial controllers' practice: one PI row
tuned by the same margin rule at the middle force cell and a flow feed-forward of the
specimen's compliance only, 1/k_s·Ḟ_ref(t) (no look-ahead, no oil compliance), the dead-zone
inverse on.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..components import effective_bulk_modulus
from ..linearization import linearize
from ._controllers import (
    ControlError,
    DeadZoneInverse,
    FlowFeedForward,
    GainRow,
    PIController,
    StateFeedbackController,
    machine_of,
)
from ._design import _pi_crossover

__all__ = [
    "FORCE_LEVELS",
    "GAIN_FREQUENCY",
    "ForceDesign",
    "force_plant",
    "hydraulic_stiffness",
    "design_force",
    "design_force_pi",
]

#: force cells over the range [−A_B·P_S, A_A·P_S] (equal widths of P_L), each × 2 flow directions
FORCE_LEVELS = 5
#: frequency [Hz] at which a cell's integrating gain G = |jω P(jω)| is read (above the
#: flow-pressure pole, below the valve's and the specimen's resonances)
GAIN_FREQUENCY = 20.0
#: the opening [1] of the linearization point beyond the dead zone (the flow gain there)
_OPENING = 0.02


@dataclass(frozen=True)
class ForceDesign:
    """A force/pressure design: the controller, its per-cell table and the design settings."""

    controller: Any
    table: Any
    info: dict


def _area(params, output: str) -> float:
    """Output per Pa of load pressure: A_A for the force (P_L = P_A − α P_B), 1 for P_L."""
    return float(params.cylinder.area_a) if output == "force" else 1.0


def hydraulic_stiffness(params, x: float, supply_pressure: float | None = None) -> float:
    """Oil columns' stiffness k_h = A_A²β/V_A + A_B²β/V_B [N/m] at x [m] (β at the rest pressures)."""
    c = params.cylinder
    ps = params.supply.pressure if supply_pressure is None else float(supply_pressure)
    va = c.dead_volume_a + c.area_a * x
    vb = c.dead_volume_b + c.area_b * (c.stroke - x)
    oil = params.oil
    beta = float(
        effective_bulk_modulus.py_func(
            0.5 * ps, oil.bulk_modulus, oil.vapour_pressure, oil.release_pressure
        )
    )
    return beta * (c.area_a**2 / va + c.area_b**2 / vb)


def _hold_point(params, chamber, force: float, s: int) -> tuple[dict[str, float], float]:
    """State (by name) and u of a force hold at ``force`` [N] on the specimen, opening side s."""
    ld, c = params.load, params.cylinder
    ps = chamber.supply_pressure
    k = ld.specimen_stiffness
    x = ld.contact_position + (force - ld.force - ld.preload) / k if k > 0 else 0.5 * c.stroke
    x = min(max(x, 0.02 * c.stroke), 0.98 * c.stroke)
    pa = min(max((force + ps * c.area_b) / (c.area_a + c.area_b), 0.02 * ps), 0.98 * ps)
    y = chamber.state_from_measurement({"x": x, "p_a": pa, "p_b": ps - pa})
    beta = DeadZoneInverse.from_params(params.dead_zone).offset
    u = s * (beta + _OPENING)
    pt = dict(zip(chamber.state_names, (float(v) for v in y), strict=True))
    pt.update(spool=u, spool_rate=0.0, v=0.0, u=u)
    return pt, x


def force_plant(params, chamber, force: float, s: int, output: str = "force"):
    """Continuous plant c → output of the chamber PWA model at a force hold (see the module).

    Returns (python-control ``StateSpace`` over spool, spool rate, P_A, P_B, x, v;
    the working point; its cells).
    """
    import control  # deferred: python-control loads scipy.signal and matplotlib

    pt, _x = _hold_point(params, chamber, force, s)
    dyn = chamber.state_space(point=pt)
    k_g = float(chamber.dead_zone.slopes[dyn.cells.g])
    if k_g == 0.0:
        raise ControlError(f"force {force:g} N: the spool's cell is saturated (k_g = 0)")
    n = 6  # without P_S and the accumulator (constant here)
    cyl = params.cylinder
    cout = np.zeros((1, n))
    cout[0, 2], cout[0, 3] = 1.0, -cyl.area_b / cyl.area_a
    cout *= _area(params, output)
    plant = control.ss(dyn.A[:n, :n], dyn.B[:n, :] / k_g, cout, np.zeros((1, 1)))
    return plant, pt, dyn.cells


def _cell_gains(plant, ts: float, delay: bool, margins: dict[str, float]):
    """(G, the kept loop of :func:`~hydropwa.control._design._pi_crossover`) of one cell."""
    import control  # deferred: python-control loads scipy.signal and matplotlib

    w = 2 * math.pi * GAIN_FREQUENCY
    g = float(abs(1j * w * complex(plant(1j * w))))
    pd_ = control.sample_system(plant, ts, method="zoh")
    if delay:
        pd_ = control.series(control.tf([1.0], [1.0, 0.0], ts), pd_)
    loop = _pi_crossover(
        pd_,
        g,
        ts,
        True,
        margins["integral_ratio"],
        phase_margin=margins["phase_margin"],
        gain_margin_db=margins["gain_margin_db"],
    )
    return g, loop


def _feedforward(params, chamber, ts, delay, lead: bool) -> FlowFeedForward:
    ff = FlowFeedForward.from_params(
        params,
        sample_time=ts,
        delay=delay,
        supply_pressure=chamber.supply_pressure,
        reference_state=False,
    )
    return ff if lead else dataclasses.replace(ff, lead=0.0)


def _compliance(params, output: str, stiffness: float, with_oil: bool, x: float, ps) -> float:
    """Feed-forward compliance [m per output unit]: (1/k_s [+ 1/k_h]) per N, × A_A per Pa."""
    if not stiffness > 0:
        raise ControlError(
            "force control needs the specimen's stiffness: set load.specimen_stiffness [N/m] "
            "in the parameters or give specimen_stiffness"
        )
    comp = 1.0 / stiffness + (1.0 / hydraulic_stiffness(params, x, ps) if with_oil else 0.0)
    return comp * (1.0 if output == "force" else float(params.cylinder.area_a))


def _options(params, chamber, kw: dict[str, Any]) -> dict[str, Any]:
    ts, delay = float(kw["sample_time"]), bool(kw["delay"])
    dzi = DeadZoneInverse.from_params(params.dead_zone)
    if kw.get("quiet_band", 0.0) > 0.0:
        dzi = dataclasses.replace(dzi, quiet_band=float(kw["quiet_band"]), quiet_at_rest=1.0)
    return {
        "sample_time": ts,
        "delay": delay,
        "dead_zone_inverse": dzi,
        "output": kw["output"],
        "machine": machine_of(params, chamber.supply_pressure),
    }


def _setup(params, output, specimen_stiffness):
    if output not in ("force", "pressure"):
        raise ControlError(f"output {output!r}: choose force or pressure")
    if specimen_stiffness is not None:
        params = params.replace(**{"load.specimen_stiffness": float(specimen_stiffness)})
    return params, linearize(params, form="chamber")


def _force_range(params, chamber) -> np.ndarray:
    """Cell edges over the cylinder force [N], ``FORCE_LEVELS`` cells: from −A_B P_S (an attached
    spring, which pulls too) or the contact's force F_L + F_0 (a contact only pushes) to A_A P_S."""
    c, ps, ld = params.cylinder, chamber.supply_pressure, params.load
    lo = ld.force + ld.preload if ld.contact_position > 0.0 else -c.area_b * ps
    return np.linspace(lo, c.area_a * ps, FORCE_LEVELS + 1)


def design_force(
    params,
    *,
    output: str = "force",
    specimen_stiffness: float | None = None,
    sample_time: float = 5e-4,
    delay: bool = True,
    phase_margin: float = 60.0,
    gain_margin_db: float = 10.0,
    integral_ratio: float = 0.2,
    quiet_band: float = 0.0,
) -> ForceDesign:
    """Per-cell force (or load-pressure) law on the chamber PWA model (module docstring).

    ``params``: the (identified) parameters with the specimen; ``specimen_stiffness`` [N/m]
    overrides the estimate in ``params.load``; ``quiet_band`` [1] the band at rest (0: none).
    Returns a :class:`ForceDesign` whose controller is a :class:`StateFeedbackController`
    with ``output`` set, one row per force cell and flow direction.
    """
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    params, chamber = _setup(params, output, specimen_stiffness)
    kw = dict(sample_time=sample_time, delay=delay, output=output, quiet_band=quiet_band)
    margins = dict(
        phase_margin=phase_margin, gain_margin_db=gain_margin_db, integral_ratio=integral_ratio
    )
    edges = _force_range(params, chamber)
    area_l = float(params.cylinder.area_a)  # F = A_A·P_L (asymmetric P_L)
    rows, recs = [], []
    for j in range(FORCE_LEVELS):
        f_mid = 0.5 * (edges[j] + edges[j + 1])
        for s in (1, -1):
            plant, pt, cells = force_plant(params, chamber, f_mid, s, output)
            g, loop = _cell_gains(plant, sample_time, delay, margins)
            lo = [edges[j] / area_l, -np.inf, -np.inf, 0.0 if s > 0 else -np.inf]
            hi = [edges[j + 1] / area_l, np.inf, np.inf, np.inf if s > 0 else 0.0]
            lo[0] = -np.inf if j == 0 else lo[0]
            hi[0] = np.inf if j == FORCE_LEVELS - 1 else hi[0]
            label = f"F{j} s={s:+d}"
            rows.append(
                GainRow(
                    tuple(lo), tuple(hi), k_pl=0.0, k_v=0.0, k_x=loop.kp, k_i=loop.ki, label=label
                )
            )
            recs.append(
                {
                    "cell": label,
                    "force_kn": f_mid / 1e3,
                    "gain_n_s": g,
                    "crossover_hz": loop.wc / (2 * math.pi),
                    "kp_per_kn": loop.kp * 1e3,
                    "ki_per_kn_s": loop.ki * 1e3,
                    "gain_margin_db": loop.gain_margin_db,
                    "phase_margin_deg": loop.phase_margin,
                }
            )
    x_mid = _hold_point(params, chamber, 0.5 * (edges[0] + edges[-1]), 1)[1]
    ctrl = StateFeedbackController(
        rows=tuple(rows),
        feedforward=_feedforward(params, chamber, sample_time, delay, lead=True),
        feedforward_compliance=_compliance(
            params, output, params.load.specimen_stiffness, True, x_mid, chamber.supply_pressure
        ),
        design={
            "method": "force-pwa-chamber",
            "output": output,
            "stiffness": params.load.specimen_stiffness,
        },
        **_options(params, chamber, kw),
    )
    info = {
        "method": "force",
        **kw,
        **margins,
        "specimen_stiffness": params.load.specimen_stiffness,
    }
    return ForceDesign(ctrl, pd.DataFrame.from_records(recs), info)


def design_force_pi(
    params,
    *,
    output: str = "force",
    specimen_stiffness: float | None = None,
    sample_time: float = 5e-4,
    delay: bool = True,
    phase_margin: float = 60.0,
    gain_margin_db: float = 10.0,
    integral_ratio: float = 0.2,
) -> ForceDesign:
    """The baseline: a force/pressure PI with the valve's flow feed-forward (module docstring).

    Tuned by the margin rule of :func:`design_force` at the middle force cell, opening
    positive; feed-forward 1/k_s·Ḟ_ref(t) through the flow inversion (no look-ahead).
    """
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    params, chamber = _setup(params, output, specimen_stiffness)
    margins = dict(
        phase_margin=phase_margin, gain_margin_db=gain_margin_db, integral_ratio=integral_ratio
    )
    edges = _force_range(params, chamber)
    f_mid = 0.5 * (edges[FORCE_LEVELS // 2] + edges[FORCE_LEVELS // 2 + 1])
    plant, pt, _cells = force_plant(params, chamber, f_mid, 1, output)
    g, loop = _cell_gains(plant, sample_time, delay, margins)
    kw = dict(sample_time=sample_time, delay=delay, output=output)
    ctrl = PIController(
        kp=loop.kp,
        ki=loop.ki,
        feedforward=_feedforward(params, chamber, sample_time, delay, lead=False),
        feedforward_compliance=_compliance(
            params, output, params.load.specimen_stiffness, False, pt["x"], chamber.supply_pressure
        ),
        **_options(params, chamber, kw),
    )
    rec = {
        "cell": "PI",
        "force_kn": f_mid / 1e3,
        "gain_n_s": g,
        "crossover_hz": loop.wc / (2 * math.pi),
        "kp_per_kn": loop.kp * 1e3,
        "ki_per_kn_s": loop.ki * 1e3,
        "gain_margin_db": loop.gain_margin_db,
        "phase_margin_deg": loop.phase_margin,
    }
    info = {
        "method": "force-pi",
        **kw,
        **margins,
        "specimen_stiffness": params.load.specimen_stiffness,
    }
    return ForceDesign(ctrl, pd.DataFrame.from_records([rec]), info)
