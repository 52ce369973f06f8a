"""``control design --model pwa-chamber``: a valve-aware LQR tuned on the chamber-level PWA model.

The controllers of this package measure x, ẋ and P_L (P_A, P_B where the law asks) and estimate
the spool; their gain rows live on the load-pressure PWA cells. A law on all eight chamber-level
states (ν, ν̇, P_A, P_B, x, v) per chamber cell needs a new controller schema, so this design
keeps the valve-aware law of :func:`~hydropwa.control.design_state_feedback` and lets the
chamber-level model, which predicts the closed loop (hold oscillations within a factor 1.5 of the
full model's, docs/models.md), choose its tuning and check it:

1. the cells are those of the load-pressure PWA model linearized from the chamber model's
   parameters at its supply pressure;
2. each candidate integral maximum (strongest integral action first) is designed and run in
   closed loop on ``pwa-chamber`` over a step task scaled to the stroke; the first candidate whose
   every hold stays within ``hold_limit / HOLD_MARGIN`` is kept (else the one with the smallest
   hold): the chamber model predicts the full model's holds within that factor;
3. the kept design is verified on the full model (:func:`verify_controller`, as every design) and
   the step task is run on both the full and the chamber model; their holds side by side are in
   ``info["pwa_chamber"]`` and the controller's ``[verification.pwa_chamber]``.

Measured on the heavy axis (63/36 × 500 mm, 5 kN): the default integral maximum (1e-4 m·s) hunts
across the valve's overlap at 2 Hz, 0.057-0.063 mm on both models; 1e-3 m·s holds 0.018-0.031 mm
on the full model and 0.016-0.036 mm on pwa-chamber (tests/control/test_fidelity.py).
"""

from __future__ import annotations

import dataclasses
from typing import Any

from .._layout import CHAMBER_KIND, FULL_KIND
from ..linearization import ChamberPwaModel, linearize
from ._controllers import ControlError
from ._design import DEFAULT_WEIGHTS, design_state_feedback
from ._fidelity import closed_loop_fidelity
from ._reference import as_reference

__all__ = [
    "INTEGRAL_CANDIDATES",
    "HOLD_LIMIT",
    "HOLD_MARGIN",
    "chamber_step_task",
    "design_on_chamber",
]

#: Integral maxima [m·s] tried in turn (Bryson: larger = weaker integral action).
INTEGRAL_CANDIDATES = (DEFAULT_WEIGHTS["integral"], 1e-3, 1e-2)
#: Largest peak-to-peak [m] of a hold that the kept design may show on the full model.
HOLD_LIMIT = 0.05e-3
#: The chamber model predicts each hold within this factor of the full model's (issue 38's
#: bound; measured 0.55-1.2), so a candidate is kept where its chamber holds are at most
#: HOLD_LIMIT / HOLD_MARGIN. Measured on the heavy axis with the one-sample delay: the default
#: integral holds 0.044 mm on pwa-chamber and 0.053 mm on the full model.
HOLD_MARGIN = 1.5


def chamber_step_task(params) -> tuple[Any, float, float]:
    """The step task of the chamber check: (reference, duration [s], initial position [m]).

    Steps to 90 %, 10 % and 50 % of the stroke from 5 %, each held long enough for the move
    (0.3 s per tenth of the stroke) and 1 s of hold; the heavy axis's 25 → 450 → 50 →
    250 mm task of issue 38 has the same shape.
    """
    stroke = params.cylinder.stroke
    levels = (0.05, 0.9, 0.1, 0.5)
    t, parts = 0.0, []
    for k, lev in enumerate(levels):
        parts.append(f"{t:g} s={1e3 * lev * stroke:.6g} mm")
        if k + 1 < len(levels):
            t += 0.1 if k == 0 else 1.0 + 3.0 * abs(lev - levels[k - 1])
    last = 1.0 + 3.0 * abs(levels[-1] - levels[-2])
    return as_reference("steps:" + ",".join(parts)), t + last, levels[0] * stroke


def _holds(table, model: str) -> list[float]:
    cols = [c for c in table.columns if c.startswith("hold_")][1:]  # hold 1: before the move
    return [float(table.loc[model, c]) for c in cols]


def design_on_chamber(
    chamber,
    *,
    integral_candidates: tuple[float, ...] = INTEGRAL_CANDIDATES,
    hold_limit: float = HOLD_LIMIT,
    weights: dict[str, float] | None = None,
    verify: bool = True,
    verify_kwargs: dict[str, Any] | None = None,
    quiet: bool = False,
    **design_kwargs,
):
    """Design the valve-aware LQR with its tuning chosen and checked on the chamber-level model.

    Parameters
    ----------
    chamber : ChamberPwaModel
        ``linearize(params, form="chamber")``; its parameters and supply pressure are the design's.
    integral_candidates : tuple of float
        Integral maxima [m·s] tried in turn (:data:`INTEGRAL_CANDIDATES`).
    hold_limit : float
        Largest peak-to-peak [m] of a hold on the full model (:data:`HOLD_LIMIT`); a candidate
        is kept where its holds on the chamber model are at most ``hold_limit / HOLD_MARGIN``.
    weights : mapping, optional
        Bryson maxima (``x``, ``v``, ``p_l``, ``u``); an ``integral`` given here is the only
        candidate.
    verify : bool
        Verify the kept design on the full model (:func:`verify_controller`).
    verify_kwargs : dict, optional
        Passed to :func:`verify_controller` (``draws``, ``seed``, ``sensor_noise``, ``scheduler``).
    quiet : bool
        Answer the sensor noise as the default of :func:`~hydropwa.control.design_controller`
        does: each candidate gets the position observer for the position noise (unless
        ``position_noise`` is given; 1 m/s²) and the quiet band with the integral's band and
        leak for ``verify_kwargs["sensor_noise"]`` (default
        :data:`~hydropwa.control.DEFAULT_SENSOR_NOISE`). Off by default (opt-in:
        ``control design --model pwa-chamber --quiet-band``).
    **design_kwargs
        Passed to :func:`design_state_feedback` (``sample_time``, ``delay``, ``load_force``...).

    Returns
    -------
    ControlDesign
        ``info["pwa_chamber"]``: the candidates' chamber-model holds [mm], the kept integral
        maximum and the full and chamber holds [mm] of the kept design; a warning where a hold
        on the chamber model exceeds ``hold_limit`` or the two models disagree beyond ×1.5.
    """
    if not isinstance(chamber, ChamberPwaModel):
        raise ControlError(
            f"design_on_chamber needs a ChamberPwaModel (linearize(params, form='chamber')), "
            f"got {type(chamber).__name__}"
        )
    if weights and "integral" in weights:  # a given integral maximum is kept as it is
        integral_candidates = (float(weights["integral"]),)
    prm = chamber.params
    pwa = linearize(prm, supply_pressure=chamber.supply_pressure)
    ref, duration, x0 = chamber_step_task(prm)
    task = dict(params=prm, pwa=pwa, duration=duration, initial_position=x0)
    tried: list[tuple[float, float, Any]] = []
    noise = _quiet_noise(quiet, verify_kwargs, design_kwargs)
    for w_int in integral_candidates:
        d = design_state_feedback(
            pwa, weights={**(weights or {}), "integral": w_int}, **design_kwargs
        )
        if noise is not None:
            d = _with_quiet_band(d, noise, prm)
        _, table = closed_loop_fidelity(d.controller, ref, models=(CHAMBER_KIND.name,), **task)
        worst = max(_holds(table, CHAMBER_KIND.name), default=float("inf"))
        tried.append((w_int, worst, d))
        if worst <= 1e3 * hold_limit / HOLD_MARGIN:
            break
    w_int, _worst, d = next(
        (t for t in tried if t[1] <= 1e3 * hold_limit / HOLD_MARGIN),
        min(tried, key=lambda t: t[1]),
    )
    kept = (w_int, tried, hold_limit)
    return _check(d, prm, ref, kept, task, verify_kwargs if verify else None)


def _quiet_noise(quiet: bool, verify_kwargs, design_kwargs: dict):
    """The sensor noise the quiet band is sized for (None: no band); sets the observer's
    position noise in ``design_kwargs`` unless given."""
    from ._verify import DEFAULT_SENSOR_NOISE  # deferred: the verification loads the batch runner

    if not quiet or not design_kwargs.get("dead_zone_inverse", True):
        return None
    given = (verify_kwargs or {}).get("sensor_noise")
    noise = dict(DEFAULT_SENSOR_NOISE if given is None else given)
    if noise.get("x", 0.0) > 0.0:
        design_kwargs.setdefault("position_noise", float(noise["x"]))
    return noise


def _with_quiet_band(d, noise, prm):
    from ._verify import _with_quiet_band as with_band  # deferred: as in _quiet_noise

    # no pressure vent: measured on the PWA-cell design only; on this design (heavy axis, noisy
    # verification, 2 draws) it raised the holds' sign changes to 144/s, above the 100/s limit
    return with_band(d, noise, prm, vent=False)


def _check(d, prm, ref, kept, task, verify_kwargs):
    """Verify the kept design on the full model and compare the holds of full and pwa-chamber."""
    from ._verify import verify_controller  # deferred: the verification loads the batch runner

    w_int, tried, hold_limit = kept
    kinds = (FULL_KIND.name, CHAMBER_KIND.name)
    _, table = closed_loop_fidelity(d.controller, ref, models=kinds, **task)
    full, ch = (_holds(table, kind) for kind in kinds)
    info = {
        "candidates_mm": {f"{w:g}": h for w, h, _ in tried},
        "integral_max": w_int,
        "full_holds_mm": full,
        "chamber_holds_mm": ch,
    }
    d.info["pwa_chamber"] = info
    if max(full + ch, default=0.0) > 1e3 * hold_limit:
        d.warnings.append(
            f"a hold exceeds {1e6 * hold_limit:.0f} µm (full {max(full):.3f} mm, pwa-chamber "
            f"{max(ch):.3f} mm); lower the gains (weights u) or check the machine"
        )
    lim = 1e3 * hold_limit  # holds both within the limit agree whatever their ratio
    if any(max(f, c) > lim and not f / 1.5 <= c <= 1.5 * f for f, c in zip(full, ch, strict=True)):
        d.warnings.append(
            "pwa-chamber and the full model disagree on a hold by more than ×1.5: "
            f"full {full} mm, pwa-chamber {ch} mm"
        )
    if verify_kwargs is not None:  # the file's [verification] holds the verdict and this check
        v = verify_controller(d.controller, prm, **verify_kwargs)
        ver = v.to_dict()
        ver["pwa_chamber"] = info
        d.verification = v
        d.info["verification"] = ver["verdict"]
        d.controller = dataclasses.replace(d.controller, verification=ver)
    return d
