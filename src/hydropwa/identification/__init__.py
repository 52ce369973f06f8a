"""Parameter identification (Sec. VI of the paper) in the scikit-learn shape.

Settings go to ``__init__``, ``fit(data)`` returns the estimator, learned values
end in ``_``. ``data`` is a :class:`hydropwa.data.Dataset`, a dataset folder, a
run or a list of runs; the numpy-level functions (``fit_sinusoid``,
``fit_second_order``, ``fit_dead_zone``, ``fit_stribeck``,
``identify_inverse_dynamics``) work on plain arrays.
"""

from ._common import (
    ESTIMATOR_CHANNELS,
    IdentificationWarning,
    ParameterEstimate,
    SkippedRun,
    estimator_view,
    sandwich_covariance,
    screen_for_estimator,
)
from ._deadzone import (
    DeadZoneFit,
    DeadZoneIdentifier,
    VelocityEstimate,
    dead_zone_velocity,
    fit_dead_zone,
    velocity_from_position,
)
from ._frf import (
    FrequencyResponse,
    SecondOrderFit,
    SineFit,
    ValveFrfIdentifier,
    estimate_frf_h1,
    fit_second_order,
    fit_sinusoid,
    second_order_response,
    stepped_sine_point,
)
from ._friction import (
    BreakawayRun,
    FrictionPoint,
    StribeckFit,
    StribeckIdentifier,
    breakaway_peaks,
    curve_maximum,
    fit_stribeck,
    friction_point,
    friction_samples,
    steady_window,
)
from ._greybox import (
    PARAMETER_GROUPS,
    GreyBoxFit,
    Identifiability,
    Profile,
    RunFit,
    Shooting,
    expand_free,
    fit_model,
)
from ._inverse_dynamics import (
    EMPS_PUBLISHED,
    EmpsResult,
    InverseDynamicsResult,
    identify_emps,
    identify_inverse_dynamics,
)
from ._pipeline import PARTS, IdentificationReport, identify, load_runs

__all__ = [
    "ESTIMATOR_CHANNELS",
    "estimator_view",
    "sandwich_covariance",
    "screen_for_estimator",
    "DeadZoneFit",
    "IdentificationReport",
    "PARTS",
    "identify",
    "load_runs",
    "EMPS_PUBLISHED",
    "EmpsResult",
    "InverseDynamicsResult",
    "identify_emps",
    "identify_inverse_dynamics",
    "DeadZoneIdentifier",
    "FrequencyResponse",
    "BreakawayRun",
    "FrictionPoint",
    "IdentificationWarning",
    "ParameterEstimate",
    "SecondOrderFit",
    "SineFit",
    "SkippedRun",
    "StribeckFit",
    "StribeckIdentifier",
    "ValveFrfIdentifier",
    "VelocityEstimate",
    "dead_zone_velocity",
    "estimate_frf_h1",
    "fit_dead_zone",
    "fit_second_order",
    "fit_sinusoid",
    "fit_stribeck",
    "breakaway_peaks",
    "curve_maximum",
    "friction_point",
    "friction_samples",
    "second_order_response",
    "steady_window",
    "stepped_sine_point",
    "velocity_from_position",
    "PARAMETER_GROUPS",
    "GreyBoxFit",
    "Identifiability",
    "Profile",
    "RunFit",
    "Shooting",
    "expand_free",
    "fit_model",
]
