"""The compiled entry points, generated from one table: model kinds × methods × open/closed loop.

Each entry point is a numba function in which the model kind and the Rosenbrock method are
compile-time constants (closure constants of :func:`_open_entry` / :func:`_closed_entry`), so its
machine code holds only its own model's right-hand side, Jacobian and stepper (see
:func:`~._dispatch._rhs_for`, :func:`~._dispatch._exact_derivatives`,
:func:`~._rosenbrock._step_for`), and a command compiles only the one it runs. The table is
:data:`hydropwa._layout.MODEL_KINDS` × :data:`~._rosenbrock.METHODS`; each entry is named
``_integrate_<model>[_ros23]`` and ``_closed_<model>[_ros23]`` (its on-disk cache file is keyed by
that name, numba's index by the closure constants).

The solver's arguments after the model kind are one :class:`SolverRun` (a named tuple, which numba
passes into the compiled code as one typed argument), so the argument list is written once: in
that class. The argument builders give the entries exactly the types they are compiled for.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple, get_type_hints

import numpy as np
from numba import njit

from .. import _jitcache  # noqa: F401  (one cache stamp for all compiled modules)
from .._layout import MODEL_KINDS
from ._march import _integrate, _integrate_closed
from ._rosenbrock import METHODS, ROS4LS, ROS23, ROS34PW2

#: Identifier of each model kind in the entry points' names (its registry row's ``entry_id``).
KERNEL_IDS: dict[int, str] = {row.kernel: row.entry_id for row in MODEL_KINDS.values()}
_METHOD_SUFFIX = {m.id: m.entry_suffix for m in METHODS}


def _compiled(fn, name):
    """``fn`` under its own name (and so its own cache file), compiled on first use and cached."""
    fn.__name__ = fn.__qualname__ = name
    return njit(cache=True, nogil=True, error_model="numpy")(fn)


def _open_entry(kind, method):
    """The open-loop entry of model ``kind`` and ``method`` (:func:`~._march._integrate`)."""

    def entry(run, jac_reuse, gustafsson, exact_jac):
        return _integrate(kind, run, method, jac_reuse, gustafsson, exact_jac)

    return _compiled(entry, f"_integrate_{KERNEL_IDS[kind]}{_METHOD_SUFFIX[method]}")


def _closed_entry(kind, method):
    """The closed-loop entry of model ``kind`` and ``method`` (:func:`~._march._integrate_closed`)."""

    def entry(run, ctl, ref, dref):
        return _integrate_closed(kind, run, method, ctl, ref, dref)

    return _compiled(entry, f"_closed_{KERNEL_IDS[kind]}{_METHOD_SUFFIX[method]}")


#: The entry tables by method id: (open loop, closed loop), each ``{kind: entry}``.
ENTRIES = {
    m.id: (
        {kind: _open_entry(kind, m.id) for kind in KERNEL_IDS},
        {kind: _closed_entry(kind, m.id) for kind in KERNEL_IDS},
    )
    for m in METHODS
}
#: The default method's (ROS34PW2) open- and closed-loop entries, and the others', by kind.
_ENTRY, _CLOSED = ENTRIES[ROS34PW2]
_ENTRY_ROS23, _CLOSED_ROS23 = ENTRIES[ROS23]
_ENTRY_ROS4LS, _CLOSED_ROS4LS = ENTRIES[ROS4LS]
# every entry under its name in this module (``_integrate_full``, ``_closed_pwa_ros23``, …)
globals().update({d.__name__: d for pair in ENTRIES.values() for t in pair for d in t.values()})


def _owned(a):
    """``a`` as a writable, C-contiguous float64 array (a copy only where it is not one).

    The kernels are compiled for exactly these arrays; a read-only array (a frozen
    parameter vector, a slice of a stored run) would otherwise be a new signature and
    compile the whole solver a second time.
    """
    a = np.ascontiguousarray(a, dtype=np.float64)
    return a if a.flags.writeable else a.copy()


class SolverRun(NamedTuple):
    """One integration's problem and tolerances: the solver's arguments after the model kind.

    The one place the solver's argument list is written: :func:`~._kernel.integrate`,
    :func:`~._kernel.integrate_closed_loop`, the generated entries and
    :func:`~._march._integrate` pass it on whole, and the compiled code reads its fields by
    name (numba types a named tuple field by field).

    Attributes
    ----------
    y0 : ndarray
        Initial state.
    t_out : ndarray
        Increasing output times [s]; integration runs from t_out[0] to t_out[-1].
    p : ndarray
        Packed parameters.
    sg : ndarray
        Packed input signals (kinds, parameters, sample times, values, offsets).
    rtol : float
        Relative tolerance; the absolute tolerance of state i is rtol·scale[i].
    scale : ndarray
        Typical magnitude of each state (SI).
    h0, hmax : float
        Initial and largest step [s].
    max_steps : int
        Step budget (accepted and rejected steps).
    """

    y0: np.ndarray
    t_out: np.ndarray
    p: np.ndarray
    sg: np.ndarray
    rtol: float
    scale: np.ndarray
    h0: float
    hmax: float
    max_steps: int

    def typed(self) -> SolverRun:
        """This run with exactly the field types the entries are compiled for (see :func:`_owned`)."""
        return SolverRun(*(_AS_TYPE[f](v) for f, v in zip(self._fields, self, strict=True)))


#: Each :class:`SolverRun` field's conversion to its compiled type, from the class's annotations.
_CONVERSIONS: dict[Any, Callable[[Any], Any]] = {np.ndarray: _owned, float: float, int: int}
_AS_TYPE = {f: _CONVERSIONS[hint] for f, hint in get_type_hints(SolverRun).items()}


def _open_args(run, jac_reuse, gustafsson, exact_jac):
    """The open-loop entry points' arguments, of exactly the types they are compiled for."""
    return (SolverRun(*run).typed(), bool(jac_reuse), bool(gustafsson), bool(exact_jac))


def _closed_args(run, ctl, ref, dref):
    """The closed-loop entry points' arguments, of exactly the types they are compiled for."""
    return (SolverRun(*run).typed(), _owned(ctl), _owned(ref), _owned(dref))


def _output_args(t_out, Y, n_done, p, sg):
    """The output passes' arguments, of exactly the types they are compiled for."""
    return (_owned(t_out), _owned(Y), int(n_done), _owned(p), _owned(sg))


def _point_args(y, u, ps, fl, p):
    """The point-derivative kernels' arguments and result arrays f, J, G (G column-major)."""
    n = len(y)
    f, J, G = np.zeros(n), np.zeros((n, n)), np.asfortranarray(np.zeros((n, 3)))
    return (_owned(y), float(u), float(ps), float(fl), _owned(p), f, J, G)
