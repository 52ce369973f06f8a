"""Evaluation of models against measurements, figures and the report."""

from .plots import plot_result, save_figure

__all__ = ["plot_result", "save_figure"]
