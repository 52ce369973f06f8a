"""Error types of hydropwa.

Every error that a user can cause (bad parameters, files, signal specs,
measurements) derives from :class:`HydropwaError`. The CLI turns these into a
single line on stderr and exit code 2; anything else is a bug.
"""

from __future__ import annotations

__all__ = [
    "HydropwaError",
    "ParameterError",
    "SignalError",
    "DataError",
    "SimulationError",
    "IdentificationError",
    "PwaError",
    "OutputExistsError",
    "OutputLockedError",
    "interrupt_cause",
]


class HydropwaError(Exception):
    """Base class of every error hydropwa raises on purpose."""


class ParameterError(HydropwaError, ValueError):
    """A parameter value or parameter file is invalid (names field, value and unit)."""


class SignalError(HydropwaError, ValueError):
    """An input signal or signal specification is malformed."""


class DataError(HydropwaError, ValueError):
    """A measurement file or dataset is unreadable or fails validation.

    The message names the run, the channel and the sample where possible.
    """


class SimulationError(HydropwaError, RuntimeError):
    """An integration failed.

    Attributes
    ----------
    t : float
        Time [s] at which the integration failed.
    state : dict[str, float]
        The state at that time, by name, in SI units.
    partial : object or None
        The result up to the failure (a ``SimulationResult``), when available.
    """

    def __init__(self, message: str, t: float = float("nan"), state=None, partial=None):
        super().__init__(message)
        self.t = t
        self.state = dict(state or {})
        self.partial = partial


class IdentificationError(HydropwaError):
    """Identification cannot proceed (e.g. no usable run is left)."""


class PwaError(HydropwaError, ValueError):
    """A piecewise-affine model, its cells or its JSON document is invalid."""


class OutputExistsError(HydropwaError, FileExistsError):
    """An output file exists and overwriting it was not asked for (``--force``)."""


class OutputLockedError(HydropwaError):
    """Another run holds the lock of the output folder (see ``hydropwa._io.output_lock``)."""


def interrupt_cause(exc: BaseException) -> KeyboardInterrupt | None:
    """The Ctrl-C behind ``exc``, if ``exc`` is how a compiled kernel reported one.

    A ``KeyboardInterrupt`` that Python raises while a numba function boxes its result
    reaches the caller as ``SystemError("... returned a result with an exception set")``
    with the interrupt as its cause. This finds it in the cause/context chain.
    """
    seen = set()
    cur: BaseException | None = exc
    while cur is not None and id(cur) not in seen:
        if isinstance(cur, KeyboardInterrupt):
            return cur
        seen.add(id(cur))
        cur = cur.__cause__ or cur.__context__
    return None
