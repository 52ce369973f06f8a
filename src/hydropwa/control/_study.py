"""The closed-loop task of the paper study: designed on the identified PWA model, verified on the full model."""

from __future__ import annotations

from typing import Any

from .._layout import CHAMBER_KIND, FULL_KIND, PWA_KIND, REDUCED_KIND
from ..linearization import linearize
from ..simulation import simulate
from ._design import design_textbook_pi
from ._metrics import METRIC_UNITS, tracking_metrics
from ._reference import MotionProfile, MoveSequence
from ._verify import design_controller, verify_controller

__all__ = ["POSITIONING_TASK", "closed_loop_study", "closed_loop_verification"]

#: The positioning task: 50 → 150 mm (trapezoid, 0.2 m/s, 5 m/s²) at 0.05 s, back at 1.05 s.
POSITIONING_TASK = "50 → 150 mm at 0.05 s and back at 1.05 s, 0.2 m/s, 5 m/s², 2 kHz LQR"
_MOVE = {"max_velocity": 0.2, "max_acceleration": 5.0}
_DURATION = 2.0
#: Metrics of a step response that say nothing about a trapezoid: its 10 → 90 % time is the
#: reference's own ramp (about 0.4 s here), so the task's table leaves it out (issue 49).
STEP_ONLY_METRICS = ("rise_time",)
_X0 = 0.05


def _reference():
    return MoveSequence(
        (MotionProfile(0.05, 0.15, 0.05, **_MOVE), MotionProfile(0.15, 0.05, 1.05, **_MOVE))
    )


def closed_loop_study(pwa, verify_params=None) -> tuple[dict[str, Any], Any, Any]:
    """Design the default controller on ``pwa`` and run the positioning task on the full,
    reduced, PWA and chamber-level PWA (``pwa-chamber``) models.

    The design is the one of ``hydropwa control design`` (:func:`~hydropwa.control.
    design_controller` at :data:`~hydropwa.control.DEFAULT_DESIGN`: computation delay, position
    observer, quiet band, verified on the full model of ``pwa.params`` and re-tuned where it
    fails); its verdict is ``design.verification``.

    The table also holds the baseline, a textbook PI with velocity feed-forward designed from
    the same parameters (:func:`~hydropwa.control.design_textbook_pi`) on the full model, so a
    reader sees what the PWA design buys.

    Parameters
    ----------
    pwa : PwaModel
        The identified PWA model (the design sees nothing else).
    verify_params : SystemParams, optional
        Parameters of an extra full-model run, "full (true params)" (the virtual rig's
        truth); the other runs use ``pwa.params``.

    Returns
    -------
    results : dict of SimulationResult
    table : pandas.DataFrame
        Tracking metrics per model (:func:`~hydropwa.control.tracking_metrics`), index ``model``.
    design : ControlDesign
        With ``verification`` set.
    """
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    design = design_controller(pwa)
    ref = _reference()
    runs: dict[str, Any] = {}
    for name, mdl, prm in (
        (FULL_KIND.name, FULL_KIND.name, pwa.params),
        (REDUCED_KIND.name, REDUCED_KIND.name, pwa.params),
        (PWA_KIND.name, pwa, pwa.params),
        # the chamber-level model of the same parameters: keeps the valve and both chambers,
        # so it shows what the load-pressure models miss (docs/models.md, "Which model for what")
        (CHAMBER_KIND.name, linearize(pwa.params, form="chamber"), pwa.params),
    ):
        runs[name] = simulate(
            mdl,
            duration=_DURATION,
            params=prm,
            controller=design.controller,
            reference=ref,
            initial_position=_X0,
        )
    # the baseline: a textbook PI with velocity feed-forward from the same parameters
    runs["full, textbook PI + FF (baseline)"] = simulate(
        FULL_KIND.name,
        duration=_DURATION,
        params=pwa.params,
        controller=design_textbook_pi(
            pwa, sample_time=design.controller.sample_time, delay=design.controller.delay
        ).controller,
        reference=ref,
        initial_position=_X0,
    )
    if verify_params is not None:
        runs["full (true params)"] = simulate(
            FULL_KIND.name,
            duration=_DURATION,
            params=verify_params,
            controller=design.controller,
            reference=ref,
            initial_position=_X0,
        )
    rows = {}
    for name, res in runs.items():
        m = tracking_metrics(res, 0.05, 1.05).display()  # the move out, its settling and hold
        back = tracking_metrics(res, 1.05, _DURATION).display()
        m["max_following_error"] = max(m["max_following_error"], back["max_following_error"])
        m["iae"] += back["iae"]
        m["cell_switches"] += back["cell_switches"]
        m["overshoot_back"] = back["overshoot"]
        m["settling_time_back"] = back["settling_time"]
        rows[name] = {k: v for k, v in m.items() if k not in STEP_ONLY_METRICS}
    table = pd.DataFrame(rows).T
    table.index.name = "model"
    table.attrs["units"] = {**METRIC_UNITS, "overshoot_back": "%", "settling_time_back": "ms"}
    return runs, table, design


#: Columns of :func:`closed_loop_verification` (the worst values of :class:`Verification`).
VERIFICATION_COLUMNS = (
    "hold_peak_to_peak_mm",
    "hold_mean_error_mm",
    "following_error_mm",
    "saturation_percent",
    "sign_changes_per_s",
    "limit_cycles",
)


def closed_loop_verification(
    pwa,
    controller,
    *,
    draws: int = 1,
    seed: int = 0,
    sensor_noise=None,
    verification=None,
):
    """The verification verdict of a design beside the textbook PI + feed-forward baseline.

    Both controllers run the same :func:`~hydropwa.control.verify_controller` task set on the
    full model of ``pwa.params`` (steps 5 → 95 → 50 % of the stroke against ±50 % of the
    maximum force, their holds, a trapezoid at half the maximum velocity) with the same sensor
    noise (default 20 µm, 0.1 bar, 0.1 bar), parameter draws and computation delay; the
    baseline is :func:`~hydropwa.control.design_textbook_pi` at the design's sample time
    and delay.

    Parameters
    ----------
    pwa : PwaModel
        The model the design was made on (its parameters are the verification's machine).
    controller : StateFeedbackController or PIController
        The design.
    draws : int
        Parameter draws, see :func:`~hydropwa.control.verify_controller`.
    seed : int
        See :func:`~hydropwa.control.verify_controller`.
    sensor_noise : mapping of str to float, optional
        Noise standard deviations per sensor [m, Pa], see
        :func:`~hydropwa.control.verify_controller`.
    verification : Verification, optional
        The design's own verification (``design_controller``'s): shown as it is instead of
        verifying the design again; the baseline is then verified at the same draws, seed and
        noise as the design was.

    Returns
    -------
    pandas.DataFrame
        Index ``controller`` (``design``, ``textbook PI + FF (baseline)``); columns
        ``verdict`` (pass/fail), :data:`VERIFICATION_COLUMNS` and ``failed_checks`` (count),
        ``first_failure``.
    """
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    base = design_textbook_pi(
        pwa, sample_time=controller.sample_time, delay=controller.delay
    ).controller
    if verification is not None:
        st = verification.settings
        draws, seed = int(st.get("draws", draws)), int(st.get("seed", seed))
        sensor_noise = st.get("sensor_noise", sensor_noise)
    rows = {}
    for name, ctrl in (("design", controller), ("textbook PI + FF (baseline)", base)):
        v = (
            verification
            if name == "design" and verification is not None
            else verify_controller(
                ctrl, pwa.params, draws=draws, seed=seed, sensor_noise=sensor_noise
            )
        )
        rows[name] = {
            "verdict": "pass" if v.passed else "fail",
            **{k: float(v.metrics[k]) for k in VERIFICATION_COLUMNS},
            "failed_checks": len(v.failures),
            "first_failure": v.failures[0] if v.failures else "",
        }
    table = pd.DataFrame(rows).T
    table.index.name = "controller"
    return table
