"""One result protocol: how every result object says how it ended and shows itself.

Every result of the package (:class:`~hydropwa.SimulationResult`, the identification fits
and :class:`~hydropwa.identification.IdentificationReport`, :class:`GreyBoxFit`,
:class:`ControlDesign`, :class:`EvaluationResult`, the control layer's
:class:`~hydropwa.control.TrackingMetrics` and :class:`~hydropwa.control.Verification`)
satisfies :class:`Result`:

- ``status``: how the computation ended, always a :class:`Status`: an object with ``name``,
  ``success`` and a ``message`` that says what happened and what to change. The solver's
  :class:`~hydropwa.simulation.SolverStatus` and the grey-box fit's ``FitStatus`` are such
  enums; results with no status of their own use :class:`ResultStatus`.
- ``success`` (``status.success``) and ``message`` (the status's message, with the result's
  own detail where it has one);
- ``summary()`` (text), ``to_pandas()`` (a DataFrame, SI values, units in
  ``df.attrs['units']`` or a ``unit`` column), ``plot(ax=...)`` (a Figure from
  :mod:`hydropwa.plotting`) and ``_repr_html_()`` (a table in engineering units for notebooks).

:class:`ResultMixin` gives ``summary`` and ``_repr_html_`` from one method a result writes,
``_summary_rows()``. This module is a leaf (it imports only the display helpers), so the
plotting layer, below every result, can type its arguments with these protocols.
"""

from __future__ import annotations

import enum
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

from ._display import channel_unit, html_table

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

__all__ = [
    "DerivedResult",
    "Result",
    "ResultMixin",
    "ResultStatus",
    "Status",
    "StatusEnum",
    "estimate_rows",
    "status_messages",
]


@runtime_checkable
class Status(Protocol):
    """How a computation ended: the one meaning of ``status`` on every result."""

    @property
    def name(self) -> str:
        """Short upper-case code (``SUCCESS``, ``MAX_STEPS``, ``NOT_CONVERGED``, ...)."""

    @property
    def success(self) -> bool:
        """Whether the result can be used as it is."""

    @property
    def message(self) -> str:
        """What happened and, where it did not succeed, what to change."""


#: Each status enum's messages, by class (:func:`status_messages`).
_STATUS_MESSAGES: dict[type, dict[Any, str]] = {}


class StatusEnum(enum.IntEnum):
    """Base of the package's status enums (a :class:`Status`): integer codes that say what
    happened and what to change.

    A subclass lists its members and registers one message per member with
    :func:`status_messages`; :attr:`success` is true for the member named ``SUCCESS``
    unless the subclass says otherwise.
    """

    @property
    def message(self) -> str:
        """What happened, and what to change."""
        return _STATUS_MESSAGES[type(self)][self]

    @property
    def success(self) -> bool:
        """True only for ``SUCCESS``."""
        return self.name == "SUCCESS"


def status_messages(cls: type[StatusEnum], messages: dict[Any, str]) -> None:
    """Register the message of every member of the status enum ``cls``.

    Raises
    ------
    TypeError
        When a member has no message (a status that could not say what happened).
    """
    missing = [m.name for m in cls if m not in messages]
    if missing:
        raise TypeError(f"{cls.__name__}: no message for {', '.join(missing)}")
    _STATUS_MESSAGES[cls] = dict(messages)


class ResultStatus(StatusEnum):
    """Outcome of a result that has no solver or optimiser status of its own.

    Each member's :attr:`message` says what happened and how to fix it (the pattern of
    :class:`~hydropwa.simulation.SolverStatus`).
    """

    SUCCESS = 0
    NOT_CONVERGED = 1
    PARTIAL = 2
    CHECK_FAILED = 3
    FAILED = 4
    NOT_SETTLED = 5


status_messages(
    ResultStatus,
    {
        ResultStatus.SUCCESS: "finished; every part met its tolerance or check",
        ResultStatus.NOT_CONVERGED: (
            "the optimiser stopped before meeting a tolerance; give more evaluations or starts, "
            "better data (wider excitation), or check that the bounds hold the optimum"
        ),
        ResultStatus.PARTIAL: (
            "some parts were not computed (skipped runs or parts; see the result's skipped list "
            "or notes); add the missing experiments or fix the runs named there"
        ),
        ResultStatus.CHECK_FAILED: (
            "a verification check failed (see summary() for which and by how much); re-tune the "
            "weights, or relax the criteria only if the target allows it"
        ),
        ResultStatus.FAILED: (
            "a computation inside failed (see the message for which); fix its inputs and run again"
        ),
        ResultStatus.NOT_SETTLED: (
            "the response did not settle within the window, so a step metric is NaN (see the "
            "message for which); lengthen the window, or re-tune a loop that is too slow or rings"
        ),
    },
)


@runtime_checkable
class Result(Protocol):
    """The shape every result object of the package has (see the module docstring)."""

    @property
    def status(self) -> Status:
        """How the computation ended."""

    @property
    def success(self) -> bool:
        """``status.success``."""

    @property
    def message(self) -> str:
        """What happened and what to change."""

    def summary(self) -> str:
        """A few lines of text in engineering units."""

    def to_pandas(self) -> pd.DataFrame:
        """The result's table or channels as a DataFrame (SI values)."""

    def plot(self, *, ax: Any = None) -> Any:
        """A matplotlib Figure of the result."""

    def _repr_html_(self) -> str:
        """A small table in engineering units for notebooks."""


class ResultMixin:
    """``summary()`` and ``_repr_html_()`` from ``_summary_rows()`` and ``status``.

    A result lists its headline quantities as ``(quantity, value, SI unit)`` rows; both
    views show them in engineering units (bar, mm, %), with the status and its message.
    """

    def _summary_rows(self) -> Sequence[tuple[str, Any, str]]:
        """(quantity, value in SI or text, SI unit) rows; results override it."""
        return ()

    def _summary_title(self) -> str:
        return type(self).__name__

    def _display_rows(self) -> list[tuple[str, str, str]]:
        rows = []
        for name, value, unit in self._summary_rows():
            shown, factor = channel_unit(unit)
            if isinstance(value, float | int) and not isinstance(value, bool):
                rows.append((name, f"{value * factor:.4g}", shown))
            else:
                rows.append((name, str(value), shown))
        return rows

    def _status_line(self) -> str:
        status: Status = self.status  # type: ignore[attr-defined]
        message: str = self.message  # type: ignore[attr-defined]
        return f"{status.name}: {message}"

    def summary(self) -> str:
        """The status and the headline quantities, one per line, in engineering units."""
        lines = [f"{self._summary_title()} ({self._status_line()})"]
        lines += [f"  {n}: {v} {u}".rstrip() for n, v, u in self._display_rows()]
        return "\n".join(lines)

    def _repr_html_(self) -> str:
        return html_table(
            self._summary_title(),
            ("quantity", "value", "unit"),
            self._display_rows(),
            note=self._status_line(),
        )


class DerivedResult(ResultMixin):
    """For a result whose ``status`` is computed from its parts (a property, not a field):
    ``success`` from it, and ``message`` as the parts' own details, then the status's fix."""

    def _status_details(self) -> list[str]:
        """What went wrong, one item per part (empty on success); results override it."""
        return []

    @property
    def success(self) -> bool:
        """``status.success``."""
        return bool(self.status.success)  # type: ignore[attr-defined]

    @property
    def message(self) -> str:
        """The failed parts' details, then the status's message."""
        return "; ".join([*self._status_details(), self.status.message])  # type: ignore[attr-defined]


def estimate_rows(estimates: dict[str, Any]) -> list[tuple[str, Any, str]]:
    """Summary rows ``(name, value, unit)`` of :class:`ParameterEstimate`-like objects."""
    return [(k, float(e.value), str(getattr(e, "unit", ""))) for k, e in estimates.items()]
