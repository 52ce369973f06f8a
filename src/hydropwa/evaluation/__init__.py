"""Evaluation of models against measurements (Sec. VII) (figures: :mod:`hydropwa.plotting`).

``evaluate_run(run, params)`` → :class:`EvaluationResult` (simulations, metrics, ``plot()``);
``evaluate_dataset`` → one metrics table; ``nrmse_fit``, ``rmse``, ``peak_error``,
``drift_per_period`` are plain functions of arrays. See ``docs/architecture_evaluation.md``.

The paper study and its HTML report live in :mod:`hydropwa.studies.paper`; the names
``run_paper_study``, ``write_report``, ``StudyResult`` and ``StudyError`` are still found
here as deprecated aliases (a module ``__getattr__``, PEP 562).
"""

import importlib
import warnings

from ._compare import compare
from ._coverage import (
    CoverageResult,
    cell_coverage,
    coverage_study,
    load_pressure_coverage,
    pressure_band_scores,
)
from ._engineering import (
    BodeComparison,
    CellLoops,
    EngineeringError,
    cell_loops,
    error_bound_map,
    small_signal_bode,
)
from ._evaluate import (
    CHANNELS,
    MODELS,
    EvaluationResult,
    EvaluationStart,
    EvaluationWarning,
    evaluate_dataset,
    evaluate_run,
    evaluation_params,
    evaluation_start,
    sound_runs,
)
from ._metrics import channel_metrics, drift_per_period, nrmse_fit, peak_error, rmse

__all__ = [
    "BodeComparison",
    "CellLoops",
    "EngineeringError",
    "cell_loops",
    "error_bound_map",
    "small_signal_bode",
    "CHANNELS",
    "MODELS",
    "CoverageResult",
    "EvaluationResult",
    "EvaluationStart",
    "EvaluationWarning",
    "cell_coverage",
    "compare",
    "coverage_study",
    "channel_metrics",
    "drift_per_period",
    "evaluate_dataset",
    "evaluate_run",
    "evaluation_params",
    "evaluation_start",
    "load_pressure_coverage",
    "nrmse_fit",
    "peak_error",
    "pressure_band_scores",
    "rmse",
    "sound_runs",
]

#: The paper study's names, moved to :mod:`hydropwa.studies.paper` (issue 33).
_MOVED = {
    "StudyError": "hydropwa.studies.paper",
    "StudyResult": "hydropwa.studies.paper",
    "run_paper_study": "hydropwa.studies.paper",
    "write_report": "hydropwa.studies.paper",
}


def __getattr__(name: str):
    """The deprecated aliases of the paper study's names (PEP 562).

    The one deliberate upward reference of the library (``docs/architecture.md``): the module
    is imported by name only when an old import asks for it, so ``import hydropwa.evaluation``
    loads nothing of :mod:`hydropwa.studies`.
    """
    if name not in _MOVED:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    where = _MOVED[name]
    warnings.warn(
        f"hydropwa.evaluation.{name} moved to {where}.{name}; import it from {where}",
        DeprecationWarning,
        stacklevel=2,
    )
    return getattr(importlib.import_module(where), name)
