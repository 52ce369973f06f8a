"""Grey-box identification: fit the model itself to measured runs by output error.

The package is cut on the seams of pyPESTO and scipy's ``least_squares``:

* :mod:`.problem` – free parameters, bounds, start and log scaling (:class:`GreyBoxProblem`);
* :mod:`.data` – runs prepared for the fit: channels, noise, segments (:class:`Shooting`);
* :mod:`.objective` – the output-error residuals and their finite differences;
* :mod:`.jacobian` – Jacobian strategies (differences, Broyden updates), no closure state;
* :mod:`.optimize` – :class:`LeastSquares`, the one place calling scipy;
* :mod:`.stages` – locate, valley scan, coarse, full, restarts; multi-start;
* :mod:`.sliding` – the sliding stage;
* :mod:`.uncertainty`, :mod:`.intervals`, :mod:`.profile` – covariance, interval scan, profiles;
* :mod:`.selection` – which segments of a campaign excite the free parameters;
* :mod:`.validation` – the fitted model on held-out runs;
* :mod:`.result`, :mod:`.report` – :class:`GreyBoxFit` and what it reports;
* :mod:`.estimator` – :func:`fit_model`, the composition of the above;
* :mod:`.campaign` – :func:`fit_campaign`, the joint fit of a whole campaign.
"""

from .campaign import CampaignFit, fit_campaign
from .data import Shooting, noise_level
from .estimator import FitOptions, fit_model
from .problem import JOINT_GROUPS, PARAMETER_GROUPS, GreyBoxProblem, expand_free
from .result import (
    FitStatus,
    GreyBoxFit,
    Identifiability,
    Profile,
    RunFit,
    SlidingSummary,
    StageResult,
)
from .selection import Selection
from .stages import FitProgress
from .uncertainty import autocorrelation_time
from .validation import Validation

__all__ = [
    "JOINT_GROUPS",
    "PARAMETER_GROUPS",
    "CampaignFit",
    "FitOptions",
    "FitProgress",
    "FitStatus",
    "GreyBoxFit",
    "GreyBoxProblem",
    "Identifiability",
    "Profile",
    "RunFit",
    "Selection",
    "Shooting",
    "SlidingSummary",
    "StageResult",
    "Validation",
    "autocorrelation_time",
    "expand_free",
    "fit_campaign",
    "fit_model",
    "noise_level",
]
