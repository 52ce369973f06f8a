"""Closed-loop position control: design on the PWA model, verify on the full model.

Controllers (:class:`PIController`, :class:`StateFeedbackController`) are frozen
objects that pack into a float vector evaluated inside the compiled integrator at
every sample instant (``simulate(model, controller=..., reference=...)``); design with
python-control on the PWA cells (:func:`design_state_feedback`, :func:`design_pi`);
tracking metrics and the comparison of one controller on the three models
(:func:`tracking_metrics`, :func:`compare_models`; the figure is :func:`hydropwa.plotting.plot_closed_loop`); controller
files with units (:func:`save_controller`, :func:`load_controller`); C99 code of the
controller for a real-time target (:func:`export_c`). See
docs/architecture_control.md.
"""

from ._bands import (
    INTEGRAL_BAND_FACTOR,
    INTEGRAL_LEAK,
    PRE_OPEN_FACTOR,
    PRESSURE_VENT_SAMPLES,
    QUIET_FACTOR,
    QUIET_OPEN_CORRELATION,
    command_noise,
    command_noise_correlation,
    integral_band_for,
    quiet_band_for,
    quiet_open_for,
)
from ._certcheck import CheckResult, check_certificate
from ._certify import Certificate, CertificateStatus, certify, write_certificate
from ._controllers import (
    ANTI_WINDUP,
    DEFAULT_SAMPLE_TIME,
    MACHINE_KEYS,
    SPOOL_COMMAND_NOISE,
    ControlError,
    DeadZoneInverse,
    FlowFeedForward,
    GainRow,
    PIController,
    SpoolModel,
    StateFeedbackController,
    position_observer_gains,
    spool_filter_gain,
)
from ._defaults import DEFAULT_DESIGN, DesignDefaults
from ._design import (
    DEFAULT_WEIGHTS,
    ControlDesign,
    cell_plant,
    clip_friction_slope,
    design_pi,
    design_state_feedback,
    design_textbook_pi,
    friction_slope_limit,
    valve_augment,
    valve_series,
)
from ._design_chamber import design_on_chamber
from ._design_force import ForceDesign, design_force, design_force_pi, hydraulic_stiffness
from ._estimator import (
    DEFAULT_PROCESS_NOISE,
    CellEstimator,
    design_cell_estimator,
)
from ._fidelity import (
    FIDELITY_MODELS,
    VALVE_FACTOR,
    closed_loop_fidelity,
    hold_oscillations,
    hydraulic_frequency,
    loop_bandwidth,
    model_warnings,
    valve_warning,
)
from ._io import (
    SCHEMA,
    SCHEMAS,
    controller_from_dict,
    controller_schema,
    controller_to_dict,
    load_controller,
    save_controller,
)
from ._metrics import METRIC_UNITS, TrackingMetrics, compare_models, tracking_metrics
from ._noise import NOISE_CHANNELS, sensor_noise_from
from ._reference import MotionProfile, MoveSequence, StepSequence, as_reference, parse_reference
from ._sequence import PressCycle, PressSpec, press_cycle, transfer_integral
from ._study import POSITIONING_TASK, closed_loop_study, closed_loop_verification
from ._target import c_structs, export_c, export_fmu, verdict_line
from ._verify import (
    DEFAULT_SENSOR_NOISE,
    DEFAULT_SPOOL_NOISE,
    Verification,
    VerificationCriteria,
    VerificationTask,
    check_machine,
    closed_loop_warnings,
    design_controller,
    draw_parameters,
    loaded_velocity,
    maximum_velocity,
    task_set,
    verify_controller,
)
from ._verify_force import ForceVerification, force_task_set, verify_force

__all__ = [
    "Certificate",
    "CertificateStatus",
    "CheckResult",
    "certify",
    "check_certificate",
    "write_certificate",
    "CellEstimator",
    "DEFAULT_PROCESS_NOISE",
    "design_cell_estimator",
    "MACHINE_KEYS",
    "ANTI_WINDUP",
    "DEFAULT_DESIGN",
    "DesignDefaults",
    "DEFAULT_SAMPLE_TIME",
    "DEFAULT_WEIGHTS",
    "FIDELITY_MODELS",
    "METRIC_UNITS",
    "SCHEMA",
    "SCHEMAS",
    "controller_schema",
    "ControlDesign",
    "ControlError",
    "DeadZoneInverse",
    "DEFAULT_SENSOR_NOISE",
    "DEFAULT_SPOOL_NOISE",
    "Verification",
    "VerificationCriteria",
    "VerificationTask",
    "design_controller",
    "design_on_chamber",
    "design_force",
    "design_force_pi",
    "ForceDesign",
    "hydraulic_stiffness",
    "verify_force",
    "ForceVerification",
    "force_task_set",
    "PressCycle",
    "PressSpec",
    "press_cycle",
    "transfer_integral",
    "design_textbook_pi",
    "check_machine",
    "closed_loop_warnings",
    "draw_parameters",
    "maximum_velocity",
    "task_set",
    "verify_controller",
    "FlowFeedForward",
    "SpoolModel",
    "position_observer_gains",
    "spool_filter_gain",
    "SPOOL_COMMAND_NOISE",
    "QUIET_FACTOR",
    "INTEGRAL_BAND_FACTOR",
    "INTEGRAL_LEAK",
    "PRE_OPEN_FACTOR",
    "PRESSURE_VENT_SAMPLES",
    "QUIET_OPEN_CORRELATION",
    "integral_band_for",
    "loaded_velocity",
    "command_noise",
    "command_noise_correlation",
    "quiet_band_for",
    "quiet_open_for",
    "NOISE_CHANNELS",
    "sensor_noise_from",
    "GainRow",
    "MotionProfile",
    "MoveSequence",
    "POSITIONING_TASK",
    "PIController",
    "StateFeedbackController",
    "StepSequence",
    "as_reference",
    "cell_plant",
    "clip_friction_slope",
    "friction_slope_limit",
    "valve_augment",
    "valve_series",
    "closed_loop_fidelity",
    "closed_loop_study",
    "closed_loop_verification",
    "compare_models",
    "controller_from_dict",
    "controller_to_dict",
    "design_pi",
    "design_state_feedback",
    "export_c",
    "verdict_line",
    "c_structs",
    "export_fmu",
    "hold_oscillations",
    "hydraulic_frequency",
    "loop_bandwidth",
    "model_warnings",
    "valve_warning",
    "VALVE_FACTOR",
    "load_controller",
    "parse_reference",
    "save_controller",
    "tracking_metrics",
    "TrackingMetrics",
]
