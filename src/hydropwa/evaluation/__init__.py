"""Evaluation of models against measurements (Sec. VII), the HTML report and the paper study
(figures: :mod:`hydropwa.plotting`).

``evaluate_run(run, params)`` → :class:`EvaluationResult` (simulations, metrics, ``plot()``);
``evaluate_dataset`` → one metrics table; ``nrmse_fit``, ``rmse``, ``peak_error``,
``drift_per_period`` are plain functions of arrays. See ``docs/architecture_evaluation.md``.
"""

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
)
from ._metrics import channel_metrics, drift_per_period, nrmse_fit, peak_error, rmse
from ._report import write_report
from ._study import StudyError, StudyResult, run_paper_study

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
    "StudyError",
    "cell_coverage",
    "compare",
    "coverage_study",
    "StudyResult",
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
    "run_paper_study",
    "write_report",
]
