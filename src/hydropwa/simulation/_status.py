"""Typed outcome of one integration: the solver status with its fix-it message, and statistics.

The status codes are the compiled integrator's (``_kernel.OK``, ``MAX_STEPS``,
``STEP_COLLAPSE``, ``NON_FINITE``); :class:`SolverStatus` names them once, so callers compare
against names rather than integers (an ``IntEnum``, so sweep tables and JSON keep the integer).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, fields
from typing import Any

from .._result import StatusEnum, status_messages
from . import _kernel as K

__all__ = ["SolverStatus", "SolverStats"]


class SolverStatus(StatusEnum):
    """How an integration ended (the compiled integrator's status codes).

    Each member's :attr:`message` says what happened and how to fix it.
    """

    SUCCESS = K.OK
    MAX_STEPS = K.MAX_STEPS
    STEP_TOO_SMALL = K.STEP_COLLAPSE
    NONFINITE = K.NON_FINITE


status_messages(
    SolverStatus,
    {
        SolverStatus.SUCCESS: "the integration reached the final time",
        SolverStatus.MAX_STEPS: (
            "the step budget (max_steps) was exhausted; raise max_steps or loosen rtol"
        ),
        SolverStatus.STEP_TOO_SMALL: (
            "the step size collapsed below machine precision (the dynamics are too stiff or "
            "discontinuous here); check the parameters named below, or loosen rtol"
        ),
        SolverStatus.NONFINITE: (
            "the state became non-finite (NaN or inf); check the parameters and inputs named "
            "below, or tighten rtol / lower hmax"
        ),
    },
)


@dataclass(frozen=True)
class SolverStats(Mapping[str, Any]):
    """Statistics of one integration (also readable as a mapping: ``stats["steps"]``).

    Attributes
    ----------
    steps : int
        Accepted steps.
    rejected : int
        Rejected steps (error test failed).
    rhs_evaluations : int
        Right-hand-side evaluations.
    jacobians : int
        Jacobian evaluations.
    solver : str
        Rosenbrock method (``"ros34pw2"``, ``"ros4ls"`` or ``"ros23"``).
    wall_time : float
        Time of the integration alone [s].
    compile_time : float
        Time loading or compiling the compiled solver in this call [s] (non-zero only for a
        process's first run of a model).
    rtol : float
        Relative tolerance [1].
    status : SolverStatus
        How the integration ended.
    omega0 : float
        Valve natural frequency used [rad/s] (after the Table II amplitude schedule).
    """

    steps: int = 0
    rejected: int = 0
    rhs_evaluations: int = 0
    jacobians: int = 0
    solver: str = ""
    wall_time: float = 0.0
    compile_time: float = 0.0
    rtol: float = 0.0
    status: SolverStatus = SolverStatus.SUCCESS
    omega0: float = 0.0

    def __getitem__(self, key: str) -> Any:
        if key in self._names():
            return getattr(self, key)
        raise KeyError(key)

    def __iter__(self) -> Iterator[str]:
        return iter(self._names())

    def __len__(self) -> int:
        return len(self._names())

    @classmethod
    def _names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))

    def as_dict(self) -> dict[str, Any]:
        """Plain Python values (the status as its integer code), for JSON and file metadata."""
        return {k: (int(v) if isinstance(v, SolverStatus) else v) for k, v in self.items()}
