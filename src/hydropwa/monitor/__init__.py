"""Watching an identified axis: health indicators of logged runs, thresholds, alarms, faults.

``HealthMonitor(false_alarm=1e-3).fit(identified_params).check_dataset(dataset)`` →
:class:`HealthReport` (``write(out)``: ``health.json`` and ``health.html``); the
``hydropwa monitor`` command runs it on a dataset folder. See docs/monitoring.md.
"""

from ._indicators import INDICATORS, NUISANCE, Indicator, draw_within, parameter_intervals
from ._monitor import HealthMonitor, HealthReport, IndicatorValue, RunHealth, monitor

__all__ = [
    "INDICATORS",
    "NUISANCE",
    "HealthMonitor",
    "HealthReport",
    "Indicator",
    "IndicatorValue",
    "RunHealth",
    "draw_within",
    "monitor",
    "parameter_intervals",
]
