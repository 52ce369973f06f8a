"""Closed-loop position control: discrete controllers, references, design on the PWA model, metrics."""

from ._controllers import (
    ANTI_WINDUP,
    DEFAULT_SAMPLE_TIME,
    ControlError,
    DeadZoneInverse,
    GainRow,
    PIController,
    StateFeedbackController,
)

__all__ = [
    "ANTI_WINDUP",
    "DEFAULT_SAMPLE_TIME",
    "ControlError",
    "DeadZoneInverse",
    "GainRow",
    "PIController",
    "StateFeedbackController",
]
