"""The shapes of the result objects the figures read, declared as protocols.

The plotting layer sits below every result (it imports numpy, matplotlib and the package's
leaf modules only), so it cannot import :class:`GreyBoxFit` or :class:`EvaluationResult`.
Instead it names here exactly which attributes it reads; ``tests/core/test_results.py``
checks that the real result classes satisfy these protocols, so a rename upstream fails a
test instead of a figure, and :func:`require` turns a wrong argument into one line.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Protocol, runtime_checkable

import numpy as np

__all__ = ["ChannelResult", "EstimateShape", "EvaluationShape", "TracedFit", "TracedRun", "require"]


@runtime_checkable
class EstimateShape(Protocol):
    """A parameter estimate: ``value`` [SI], ``ci`` (low, high) [SI] and its ``unit``."""

    @property
    def value(self) -> float: ...

    @property
    def ci(self) -> tuple[float, float]: ...

    @property
    def unit(self) -> str: ...


@runtime_checkable
class TracedRun(Protocol):
    """One run of a fit: time [s], measured and simulated channels [SI], noise levels."""

    @property
    def name(self) -> str: ...

    @property
    def method(self) -> str: ...

    @property
    def t(self) -> np.ndarray: ...

    @property
    def measured(self) -> Mapping[str, np.ndarray]: ...

    @property
    def simulated(self) -> Mapping[str, np.ndarray]: ...

    @property
    def sigma(self) -> Mapping[str, float]: ...

    @property
    def n_eff(self) -> Mapping[str, float]: ...


@runtime_checkable
class ProfileShape(Protocol):
    """A profile likelihood: parameter ``name``, the ``values`` walked and their ``cost``."""

    @property
    def name(self) -> str: ...

    @property
    def values(self) -> np.ndarray: ...

    @property
    def cost(self) -> np.ndarray: ...


@runtime_checkable
class TracedFit(Protocol):
    """A fit over runs (:class:`~hydropwa.identification.GreyBoxFit`)."""

    @property
    def runs_(self) -> Sequence[TracedRun]: ...

    @property
    def profiles_(self) -> Mapping[str, ProfileShape]: ...

    @property
    def estimates_(self) -> Mapping[str, EstimateShape]: ...


@runtime_checkable
class ChannelResult(Protocol):
    """A trajectory: ``t`` [s] and ``channels`` (name → SI array, ``t`` included)."""

    @property
    def t(self) -> np.ndarray: ...

    @property
    def channels(self) -> Mapping[str, np.ndarray]: ...


@runtime_checkable
class EvaluationShape(Protocol):
    """A model evaluation against one run (:class:`~hydropwa.evaluation.EvaluationResult`)."""

    @property
    def run(self) -> str: ...

    @property
    def measured(self) -> Mapping[str, np.ndarray]: ...

    @property
    def simulations(self) -> Mapping[str, ChannelResult]: ...

    @property
    def meta(self) -> Mapping[str, Any]: ...


def require(obj: Any, shape: type, who: str) -> None:
    """Raise a one-line ``TypeError`` when ``obj`` lacks an attribute ``shape`` declares."""
    if not isinstance(obj, shape):
        members = [n for n, v in vars(shape).items() if isinstance(v, property)]
        missing = ", ".join(n for n in members if not hasattr(obj, n))
        doc = (shape.__doc__ or "").splitlines()[0]
        raise TypeError(f"{who}: a {type(obj).__name__} has no {missing}; it needs {doc}")
