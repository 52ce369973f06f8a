"""Evaluation of models against measurements (Sec. VII), figures, the HTML report and the paper study.

``evaluate_run(run, params)`` → :class:`EvaluationResult` (simulations, metrics, ``plot()``);
``evaluate_dataset`` → one metrics table; ``nrmse_fit``, ``rmse``, ``peak_error``,
``drift_per_period`` are plain functions of arrays. See ``docs/architecture_evaluation.md``.
"""

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
from .plots import plot_result, save_figure

__all__ = [
    "CHANNELS",
    "MODELS",
    "EvaluationResult",
    "EvaluationStart",
    "EvaluationWarning",
    "channel_metrics",
    "drift_per_period",
    "evaluate_dataset",
    "evaluate_run",
    "evaluation_params",
    "evaluation_start",
    "nrmse_fit",
    "peak_error",
    "plot_result",
    "rmse",
    "save_figure",
]
