"""Watching an identified axis: health indicators of logged runs, thresholds, alarms, faults.

``HealthMonitor(false_alarm=1e-3).fit(identified_params).check_dataset(dataset)`` →
:class:`HealthReport` (``write(out)``: ``health.json`` and ``health.html``); the
``hydropwa monitor`` command runs it on a dataset folder. :func:`export_c` writes the
residual generator as C99 for the target (``hydropwa monitor ... --c DIR``), generated from the
package's numba source; :func:`online_check` runs that source over a logged run. See
docs/monitoring.md.
"""

from ._indicators import INDICATORS, NUISANCE, Indicator, draw_within, parameter_intervals
from ._monitor import HealthMonitor, HealthReport, IndicatorValue, RunHealth, monitor
from ._target import OnlineHealth, export_c, online_check, pack_online, target_thresholds

__all__ = [
    "INDICATORS",
    "NUISANCE",
    "HealthMonitor",
    "HealthReport",
    "Indicator",
    "IndicatorValue",
    "OnlineHealth",
    "RunHealth",
    "draw_within",
    "export_c",
    "monitor",
    "online_check",
    "pack_online",
    "parameter_intervals",
    "target_thresholds",
]
