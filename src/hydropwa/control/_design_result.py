"""The result protocol (:class:`hydropwa._result.Result`) for :class:`ControlDesign`.

Kept apart from ``_design.py`` so the design code and the protocol change independently:
``ControlDesign`` takes this mixin as its base and nothing else.
"""

from __future__ import annotations

from typing import Any

from .._result import DerivedResult, ResultStatus

__all__ = ["DesignResult"]


class DesignResult(DerivedResult):
    """``status``, ``success``, ``message``, ``to_pandas``, ``plot`` and the summary rows of a
    design from its ``table``, ``warnings`` and ``verification``."""

    table: Any
    warnings: list[str]
    info: dict[str, Any]
    verification: Any

    @property
    def status(self) -> ResultStatus:
        """``CHECK_FAILED`` when a cell is not controllable or not stable, or the full-model
        verification failed; else ``SUCCESS`` (:class:`~hydropwa._result.ResultStatus`)."""
        failed = self.warnings or (self.verification is not None and not self.verification.passed)
        return ResultStatus.CHECK_FAILED if failed else ResultStatus.SUCCESS

    def _status_details(self) -> list[str]:
        what = list(self.warnings)
        if self.verification is not None and not self.verification.passed:
            what += list(self.verification.failures[:3]) or ["verification failed"]
        return what

    def to_pandas(self) -> Any:
        """The per-cell table (gains, poles, damping, bandwidth [Hz], spectral radii)."""
        return self.table

    def _summary_title(self) -> str:
        return f"ControlDesign: {self.info.get('method', '?')}, {len(self.table)} cell(s)"

    def _summary_rows(self) -> list[tuple[str, Any, str]]:
        t = self.table
        rows: list[tuple[str, Any, str]] = [
            ("sample time", float(self.info.get("sample_time", 0.0)), "s")
        ]
        if len(t):
            rows += [
                ("smallest damping", float(t["damping_min"].min()), ""),
                ("smallest bandwidth", float(t["bandwidth_hz"].min()), "Hz"),
                ("largest spectral radius", float(t["radius"].max()), ""),
            ]
        return rows

    def plot(self, *, ax: Any = None) -> Any:
        """Smallest damping and bandwidth per cell (:func:`hydropwa.plotting.plot_cell_design`)."""
        from ..plotting import plot_cell_design  # deferred: matplotlib loads only when plotting

        t = self.table
        return plot_cell_design(
            t["damping_min"].to_numpy(float), t["bandwidth_hz"].to_numpy(float), ax=ax
        )
