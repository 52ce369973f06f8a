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

__all__ = [
    "ChannelResult",
    "EstimateShape",
    "EvaluationShape",
    "BodeComparisonShape",
    "CellLoopsShape",
    "ClosedLoopRun",
    "Columns",
    "FittedCurve",
    "FittedFrf",
    "FittedPoints",
    "ForceFit",
    "ForceModel",
    "FrequencyResponseShape",
    "FrictionPoints",
    "HoldsForceFit",
    "MetricTable",
    "Recorded",
    "TracedFit",
    "TracedRun",
    "VelocityModel",
    "require",
]


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
class Recorded(Protocol):
    """Recorded channels: ``channels`` (name → SI array, ``t`` [s] included), as a
    :class:`~hydropwa.SimulationResult` and a :class:`~hydropwa.data.Run` hold them."""

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


@runtime_checkable
class BodeComparisonShape(Protocol):
    """u → ẋ of the linearized model against the full model's small signal
    (:class:`~hydropwa.evaluation.BodeComparison`)."""

    @property
    def frequency(self) -> np.ndarray:
        """Frequencies [Hz]."""
        ...

    @property
    def full(self) -> np.ndarray:
        """The full model's small-signal response [m/s per unit command] (complex)."""
        ...

    @property
    def linearized(self) -> np.ndarray:
        """The PWA cell with the valve [m/s per unit command] (complex)."""
        ...

    @property
    def measured(self) -> Mapping[float, tuple[np.ndarray, np.ndarray]]:
        """Valve FRFs ν/u by amplitude [1]: (frequency [Hz], complex response [1])."""
        ...

    @property
    def natural_frequency(self) -> float:
        """The cell's hydraulic natural frequency [Hz]."""
        ...

    @property
    def valve_frequency(self) -> float:
        """The valve's natural frequency ω0/2π [Hz]."""
        ...

    @property
    def working_point(self) -> Mapping[str, float]:
        """``x`` [m], ``u`` [1], ``p_l`` [Pa], ``v`` [m/s] of the operating point."""
        ...


@runtime_checkable
class CellLoopsShape(Protocol):
    """Each PWA cell's designed loop (:class:`~hydropwa.evaluation.CellLoops`)."""

    @property
    def open_loop(self) -> Mapping[str, Any]:
        """Cell label → continuous-time poles [1/s] of the cell with the valve."""
        ...

    @property
    def closed_loop(self) -> Mapping[str, Any]:
        """Cell label → the sampled closed loop's poles as ln z / T_s [1/s]."""
        ...

    @property
    def table(self) -> Any:
        """A DataFrame with ``cell``, ``gain_margin [dB]`` and ``phase_margin [deg]``."""
        ...


@runtime_checkable
class ForceFit(Protocol):
    """An inverse-dynamics force fit (:class:`~hydropwa.identification.InverseDynamicsResult`)."""

    @property
    def time(self) -> np.ndarray:
        """Sample times [s]."""
        ...

    @property
    def force(self) -> np.ndarray:
        """Measured force [N]."""
        ...

    @property
    def predicted(self) -> np.ndarray:
        """The model's force [N]."""
        ...

    @property
    def relative_error(self) -> float:
        """‖force − predicted‖ / ‖force‖ [1]."""
        ...


@runtime_checkable
class ClosedLoopRun(Protocol):
    """A closed-loop simulation (:class:`~hydropwa.SimulationResult` with a controller)."""

    @property
    def model(self) -> str:
        """The model kind's name."""
        ...

    @property
    def t(self) -> np.ndarray:
        """Output times [s]."""
        ...

    @property
    def control(self) -> Mapping[str, Any]:
        """The controller's log: ``t`` [s] and ``u`` [1] at its samples."""
        ...

    def __getitem__(self, channel: str) -> np.ndarray:
        """An output channel [SI]: ``reference``, ``x``, ``error`` [m]."""
        ...


@runtime_checkable
class MetricTable(Protocol):
    """Named headline numbers of a result in engineering units
    (:class:`~hydropwa.control.TrackingMetrics`, :class:`~hydropwa.control.Verification`)."""

    def display(self) -> Mapping[str, float]:
        """Metric name → value in its display unit."""
        ...

    def display_units(self) -> Mapping[str, str]:
        """Metric name → display unit (mm, ms, %, 1/s, 1)."""
        ...


@runtime_checkable
class Columns(Protocol):
    """Named columns [SI] read as ``table["v"]``: a mapping of arrays or a DataFrame."""

    def __getitem__(self, name: str, /) -> Any:
        """The column ``name`` (an array or a Series)."""
        ...


@runtime_checkable
class FittedPoints(Protocol):
    """A fitted estimator that holds its points (``points_``; its fit, if any, ``fit_``)
    (:class:`~hydropwa.identification.DeadZoneIdentifier`)."""

    @property
    def points_(self) -> Columns:
        """The measured points."""
        ...


@runtime_checkable
class FittedCurve(Protocol):
    """A fitted estimator that holds its fit as ``fit_``
    (:class:`~hydropwa.identification.StribeckIdentifier`)."""

    @property
    def fit_(self) -> Any:
        """The fit (its own points and curve)."""
        ...


@runtime_checkable
class FrictionPoints(Protocol):
    """Steady friction points of a fit: ``velocity`` [m/s] and ``force`` [N]."""

    @property
    def velocity(self) -> np.ndarray:
        """Steady velocities [m/s]."""
        ...

    @property
    def force(self) -> np.ndarray:
        """Friction forces [N]."""
        ...


@runtime_checkable
class VelocityModel(Protocol):
    """A fitted dead zone: steady rod velocity [m/s] at commands u [1]."""

    def velocity(self, u: np.ndarray, /) -> Any:
        """Velocity [m/s] at the commands ``u`` [1]."""
        ...


@runtime_checkable
class ForceModel(Protocol):
    """A fitted friction curve: force [N] at velocities v [m/s]."""

    def force_at(self, v: np.ndarray, /) -> Any:
        """Friction force [N] at the velocities ``v`` [m/s]."""
        ...


@runtime_checkable
class FrequencyResponseShape(Protocol):
    """A measured frequency response: ``frequency`` [Hz] and complex ``response``
    (optionally ``coherence`` [1])."""

    @property
    def frequency(self) -> np.ndarray:
        """Frequencies [Hz]."""
        ...

    @property
    def response(self) -> np.ndarray:
        """The complex response [1]."""
        ...


@runtime_checkable
class FittedFrf(Protocol):
    """A fitted valve-FRF estimator: ``frf_`` by command amplitude (and ``fits_``,
    ``min_coherence`` where it has them) (:class:`~hydropwa.identification.ValveFrfIdentifier`)."""

    @property
    def frf_(self) -> Mapping[float, FrequencyResponseShape]:
        """Command amplitude [1] → measured response."""
        ...


@runtime_checkable
class HoldsForceFit(Protocol):
    """A result holding an inverse-dynamics force fit as ``fit``
    (:class:`~hydropwa.identification.EmpsResult`)."""

    @property
    def fit(self) -> ForceFit:
        """The force fit."""
        ...


def require(obj: Any, shape: type, who: str) -> None:
    """Raise a one-line ``TypeError`` when ``obj`` lacks an attribute ``shape`` declares."""
    if not isinstance(obj, shape):
        members = [
            n
            for n, v in vars(shape).items()
            if isinstance(v, property) or (callable(v) and not n.startswith("_"))
        ]
        missing = ", ".join(n for n in members if not hasattr(obj, n))
        doc = (shape.__doc__ or "").splitlines()[0]
        raise TypeError(f"{who}: a {type(obj).__name__} has no {missing}; it needs {doc}")
